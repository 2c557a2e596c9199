//! Shared by the loom models: the model runner with its stated preemption bound, a tiny world,
//! and records placed at known depths.
#![allow(dead_code)]

pub mod models;
#[path = "../tree_shape.rs"]
pub mod tree_shape;

use glam::Vec3;
use std::panic::{catch_unwind, AssertUnwindSafe};
use wfic::cache::{CacheConfig, CacheHandle, Inserted, IrradianceCache};
use wfic::ic::{Record, RecordId, WorkerId};
use wfic::sync::{Arc, AtomicBool, Ordering};

use tree_shape::{counted_lookup, TreeShape, Work};

/// loom's preemption bound for every model: `None`, so each model explores every interleaving
/// loom can generate (no bound at all). The models are small enough: the whole loom suite runs in
/// seconds. Set `Some(n)` here to trade completeness for time if a model grows.
pub const PREEMPTION_BOUND: Option<usize> = None;

/// The depth at which [`child_record`] records are stored.
pub const CHILD_DEPTH: u32 = 1;

fn builder() -> loom::model::Builder {
    let mut b = loom::model::Builder::new();
    b.preemption_bound = PREEMPTION_BOUND;
    b
}

/// Runs `f` under loom, exhaustively (see [`PREEMPTION_BOUND`]); returns how many executions
/// loom ran, which is also printed (`--nocapture` shows it).
pub fn model(f: impl Fn() + Sync + Send + 'static) -> usize {
    let runs = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let counter = runs.clone();
    builder().check(move || {
        // A std atomic: invisible to loom, it only counts executions.
        counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        f();
    });
    let n = runs.load(std::sync::atomic::Ordering::Relaxed);
    eprintln!(
        "{}: {n} executions",
        std::thread::current().name().unwrap_or("model")
    );
    n
}

/// Runs a model whose body reports an outcome per execution, and returns how many executions gave
/// `true` and how many `false` (std counters, invisible to loom). Models use it to assert that both
/// outcomes of a race were explored, so a model cannot pass by never reaching its race.
pub fn model_outcomes(f: impl Fn() -> bool + Sync + Send + 'static) -> (usize, usize) {
    use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
    let counts = std::sync::Arc::new([AtomicUsize::new(0), AtomicUsize::new(0)]);
    let c = counts.clone();
    model(move || {
        c[usize::from(f())].fetch_add(1, Relaxed);
    });
    let (yes, no) = (counts[1].load(Relaxed), counts[0].load(Relaxed));
    eprintln!(
        "{}: {yes} true, {no} false",
        std::thread::current().name().unwrap_or("model")
    );
    (yes, no)
}

/// Runs a model that must fail; returns loom's (or the model's) panic message. loom is asked to
/// capture source locations, so a causality report names where the racing object was created and
/// where each thread accessed it (`created: src/...`).
pub fn expect_failure(f: impl Fn() + Sync + Send + 'static) -> String {
    let mut b = builder();
    b.location = true;
    let result = silently(|| catch_unwind(AssertUnwindSafe(|| b.check(f))));
    match result {
        Ok(()) => panic!("the model passed, but it was expected to fail"),
        Err(payload) => payload
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default(),
    }
}

std::thread_local! {
    /// Set while this thread runs a model that is expected to fail (loom runs a model's threads
    /// on the thread that called it).
    static EXPECTING_FAILURE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f` with the panics of this thread not printed. The hook that hides them is installed
/// once and chains to the one before it; it is never swapped out and back, because that would
/// drop any hook installed in between: the `generator` crate under loom installs, once, a hook
/// that hides the unwinding it uses to end a model's threads, and a restored earlier hook made
/// every later model print those as panics.
fn silently<R>(f: impl FnOnce() -> R) -> R {
    static INSTALL: std::sync::Once = std::sync::Once::new();
    INSTALL.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !EXPECTING_FAILURE.with(std::cell::Cell::get) {
                previous(info);
            }
        }));
    });
    EXPECTING_FAILURE.with(|e| e.set(true));
    let r = f();
    EXPECTING_FAILURE.with(|e| e.set(false));
    r
}

/// The model world: a 4-unit box at accuracy 1.
pub fn config() -> CacheConfig {
    CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 1.0).unwrap()
}

/// A record stored in the root (influence 10 > the root's half-size); `x` shifts it along x.
pub fn root_record(x: f32) -> Record {
    Record::new(
        Vec3::new(2.0 + x, 2.0, 2.0),
        Vec3::Z,
        Vec3::new(1.0, 2.0, 3.0),
        10.0,
    )
}

/// A record stored at depth 1, in the (-,-,-) octant; `x` shifts it along x inside that octant.
pub fn child_record(x: f32) -> Record {
    Record::new(
        Vec3::new(1.0 + x, 1.0, 1.0),
        Vec3::Z,
        Vec3::new(3.0, 2.0, 1.0),
        0.8,
    )
}

/// A record stored at `depth` (1 to 3) in the (-,-,-) depth-1 cell, at `(x, 1, 1)`: its influence
/// radius is 0.7 of the depth-`depth` cell's half-size, so it fits that cell and not its children.
/// Below depth 1 the x coordinate picks the branch: `x` below 0.99 (the depth-1 cell's centre) goes
/// to the -x children, above it to the +x ones. The placement is asserted, not assumed.
pub fn record_at_depth(depth: u32, x: f32) -> Record {
    let config = config();
    let half = config.root().half / (1u32 << depth) as f32;
    let r = Record::new(
        Vec3::new(x, 1.0, 1.0),
        Vec3::Z,
        Vec3::new(2.0, 3.0, 1.0),
        0.7 * half / config.accuracy(),
    );
    let placed = config
        .geometry()
        .placement_depth(wfic::ic::influence_radius(&r, config.accuracy()));
    assert_eq!(
        placed, depth,
        "record_at_depth({depth}, {x}) is placed at depth {placed}"
    );
    r
}

/// A sealed record for the bare-list models; its x coordinate names it.
pub fn sealed(x: f32) -> Record {
    Record::new(Vec3::new(x, 0.0, 0.0), Vec3::Z, Vec3::splat(x + 1.0), 1.0).sealed(RecordId::new(
        WorkerId::new(0),
        0,
        x as u64,
    ))
}

/// Inserts `r` through a fresh handle of worker `worker`; returns the outcome, the steps the
/// insert took and the compare-and-swaps it lost.
pub fn insert_one<C: IrradianceCache>(cache: &C, worker: u32, r: Record) -> (Inserted, u32, u64) {
    let mut h = cache.handle(WorkerId::new(worker));
    let outcome = h.insert(r).expect("model record refused");
    let stats = *h.stats();
    drop(h);
    (outcome, stats.max_insert_steps, stats.cas_failures)
}

/// The records valid at `p` (normal +z), through a fresh handle of worker `worker`.
pub fn valid_at<C: IrradianceCache>(cache: &C, worker: u32, p: Vec3) -> Vec<Record> {
    let mut h = cache.handle(WorkerId::new(worker));
    let mut out = Vec::new();
    h.valid_records(p, Vec3::Z, &mut out);
    drop(h);
    out
}

/// The records valid at `p` (normal +z), through a fresh handle of worker `worker`, and the work
/// the handle counted for the lookup (nodes visited, records examined).
pub fn lookup_at<C: IrradianceCache>(cache: &C, worker: u32, p: Vec3) -> (Vec<Record>, Work) {
    let mut h = cache.handle(WorkerId::new(worker));
    let mut out = Vec::new();
    let did = counted_lookup(&mut h, p, Vec3::Z, &mut out);
    drop(h);
    (out, did)
}

/// The shape of the tree the cache's stored records make (`tree_shape`), after checking that the
/// cache has exactly those nodes: none off every stored record's path, none missing.
pub fn settled_shape<C: IrradianceCache>(cache: &mut C) -> TreeShape {
    let snapshot = cache.snapshot();
    let shape = TreeShape::of(cache.config(), &snapshot);
    assert_eq!(
        cache.stats().nodes,
        shape.nodes(),
        "a node off every stored record's path, or one missing"
    );
    shape
}

/// A start signal that makes loom explore "the other thread goes first".
///
/// loom's DPOR remembers only the *last* access to each atomic. When thread B loads a pointer and
/// then compare-and-swaps it, B's own load is the last access its CAS is compared with, so the race
/// between B's CAS and thread A's earlier load of the same pointer is never noticed and the
/// schedule "B publishes, then A reads" is never run (we saw exactly one execution of the
/// lookup-versus-child-creation model without this). B stores the flag first thing and A loads it
/// just before its racing operation: a dependent pair loom does see, so it also runs B ahead of A.
/// Both accesses are Relaxed, so the flag adds no happens-before edge that could hide a bug.
#[derive(Clone)]
pub struct Go(Arc<AtomicBool>);

impl Go {
    /// A fresh signal.
    pub fn new() -> Self {
        Self(Arc::new(AtomicBool::new(false)))
    }

    /// Called by the spawned thread before its operation.
    pub fn signal(&self) {
        // Relaxed: a scheduling hint for loom, not a synchronisation.
        self.0.store(true, Ordering::Relaxed);
    }

    /// Spawns `f` as the racing thread (signalling first), then lets the caller go on: the caller's
    /// next operation races with `f`, and loom also explores `f` running first.
    pub fn race<T: 'static>(
        f: impl FnOnce() -> T + Send + 'static,
    ) -> wfic::sync::thread::JoinHandle<T> {
        let go = Go::new();
        let g = go.clone();
        let t = wfic::sync::thread::spawn(move || {
            g.signal();
            f()
        });
        go.peek();
        t
    }

    /// Called by the other thread just before its racing operation.
    pub fn peek(&self) -> bool {
        // Relaxed: as above.
        self.0.load(Ordering::Relaxed)
    }
}
