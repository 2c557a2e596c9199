//! Lookup and insert cost per scheme against the records held, 10^3 to 10^7 (issue 42, point 1).
//!
//! Record sets:
//! - `ward`: the workload's room filled by Ward's rule (`common/ward.rs`): a surface point gets a
//!   record only when a lookup there finds none valid, until a batch of samples inserts under 1%
//!   of them. The accuracy for each target count is found by a short search (the count grows
//!   about as `1 / a^2`); the sets are kept under `target/records-held/` once filled.
//!   Queries: 16 384 points uniform by area on the room's surfaces, the same points at every size.
//!   Fresh records (inserts): at a stored record's point moved within its influence radius.
//! - `real-*`: records a render of a built-in scene left in its cache, with the camera's own
//!   lookup points, written by `crates/render/examples/dump_records.rs` under
//!   `target/records-held/`; read when present. Fresh records: records of the set held out of
//!   the fill.
//!
//! Per set: TRA is filled, then each other scheme in turn (one pair in memory at a time); the
//! lookup cost is measured in ABBA rounds against TRA inside this process (as `lookup_pairs`: one
//! pass of every query on TRA, X, X, TRA per round; the median of the per-round ratios with its
//! quartiles, and each scheme's median ns per lookup). Then the insert cost: batches of 1 024 fresh
//! records into the filled caches, TRA's and X's batches alternating in order round by round, ns
//! per insert including the frame's close (LW's merge); below 10^6 records each round inserts
//! into a cache filled just before its batch (each scheme's in turn), from 10^6 on each round
//! inserts a new batch into the same caches (11 rounds grow them by at most 1.2%).
//!
//! The full run writes `results/records-held/README.md` and `results.csv`. `-- --test` runs
//! 10^3 and 10^4 records for a few rounds and asserts that every scheme gives TRA's answers.
//!
//! Run: `cargo bench --bench records_held [-- [--sizes 1000,10000] [--rounds N] [--no-real]
//! [SCHEME...]]` (a run with `--sizes` prints its tables and writes no page),
//! schemes `wf`, `lck` (the mutex flavour), `lw` (all by default).

mod common;

use common::prefilled;
use common::ward::{self, WardSet};
use glam::Vec3;
use std::collections::HashMap;
use std::hint::black_box;
use std::time::{Duration, Instant};
use wfic::cache::{
    CacheConfig, CacheHandle, IrradianceCache, LocalWrite, Locked, MutexFlavour, Sequential,
    WaitFree,
};
use wfic::ic::Record;

/// The Ward sets' target counts.
const SIZES: [usize; 5] = [1_000, 10_000, 100_000, 1_000_000, 10_000_000];
/// Lookup points per set.
const QUERIES: usize = 16_384;
/// ABBA rounds per pair (each four passes of every query).
const ROUNDS: usize = 101;
/// Records per insert batch, and insert rounds.
const BATCH: usize = 1024;
const INSERT_ROUNDS: usize = 11;
/// The seeds of the Ward fill, its queries and its fresh records.
const SEED: u64 = 0x3a7d_2026;
const QUERY_SEED: u64 = 0x9_e3b1;
const FRESH_SEED: u64 = 0xf7e5;

/// One record set and what a bench of it needs.
struct Set {
    /// `ward` or `real-SCENE-aACC`.
    kind: String,
    /// The Ward set's target count.
    target: Option<usize>,
    /// Accuracies tried by the search (the last is used).
    tried: Vec<f32>,
    /// Surface points sampled by the Ward fill.
    samples: Option<u64>,
    config: CacheConfig,
    records: Vec<Record>,
    fresh: Vec<Record>,
    /// Lookup points in random order, and the same points in Morton order.
    queries: Vec<(Vec3, Vec3)>,
    sorted: Vec<(Vec3, Vec3)>,
}

/// `queries` in the order of their points' Morton codes (in the room's cube; a real scene's
/// points are scaled into it first).
fn morton_order(queries: &[(Vec3, Vec3)], config: &CacheConfig) -> Vec<(Vec3, Vec3)> {
    let root = config.root();
    let mut q = queries.to_vec();
    let scale = |p: Vec3| (p - (root.center - root.half)) / (2.0 * root.half) * 5.0;
    q.sort_by_key(|&(p, _)| ward::morton(scale(p)));
    q
}

/// The tree a set's records make, from the records alone (`verify/tree_shape.rs`' rule: a node
/// for every cell on a record's root-to-placement path).
#[derive(Clone, Copy, Default)]
struct Shape {
    nodes: usize,
    depth: u32,
    /// Nodes holding at least one record, their mean and largest list length.
    lists: usize,
    mean_list: f64,
    max_list: u64,
}

fn shape(config: &CacheConfig, records: &[Record]) -> Shape {
    let g = config.geometry();
    // A node's key: its depth in the top byte, its octants 3 bits a level below.
    let mut nodes: HashMap<u64, u64> = HashMap::new();
    nodes.insert(0, 0);
    for r in records {
        let depth = g.placement_depth(wfic::ic::influence_radius(r, config.accuracy()));
        let (mut cell, mut path) = (g.root, 0u64);
        for level in 1..=depth {
            let o = cell.octant(r.position);
            cell = cell.child(o);
            path = path << 3 | o.index() as u64;
            nodes.entry(u64::from(level) << 56 | path).or_insert(0);
        }
        *nodes
            .get_mut(&(u64::from(depth) << 56 | path))
            .expect("made") += 1;
    }
    let lists: Vec<u64> = nodes.values().copied().filter(|&c| c > 0).collect();
    Shape {
        nodes: nodes.len(),
        depth: nodes.keys().map(|k| (k >> 56) as u32).max().unwrap_or(0),
        lists: lists.len(),
        mean_list: records.len() as f64 / lists.len().max(1) as f64,
        max_list: lists.iter().copied().max().unwrap_or(0),
    }
}

/// What one lookup does on average (TRA's counters over one pass of the queries).
#[derive(Clone, Copy, Default)]
struct Work {
    hit_rate: f64,
    nodes: f64,
    examined: f64,
    valid: f64,
}

/// One scheme's figures on one set.
#[derive(Clone, Default)]
struct Pair {
    scheme: String,
    ratio: (f64, f64, f64),
    lookup_ns: f64,
    tra_lookup_ns: f64,
    /// The same queries in Morton order.
    sorted_ratio: (f64, f64, f64),
    sorted_ns: f64,
    tra_sorted_ns: f64,
    insert_ns: f64,
    tra_insert_ns: f64,
    insert_ratio: (f64, f64, f64),
    /// The untimed batch before the rounds' (median ns per insert): what the first frame after
    /// a fill pays, the fill's close included in its allocator's deferred work.
    first_ns: f64,
    tra_first_ns: f64,
    /// ns per record to fill an empty cache with the set in one frame, the frame's close
    /// included (WF's close moves the tree into its slab): one fill each.
    fill_ns: f64,
    tra_fill_ns: f64,
}

/// One set's row of the page.
struct Row {
    kind: String,
    target: Option<usize>,
    accuracy: f32,
    tried: Vec<f32>,
    samples: Option<u64>,
    records: usize,
    shape: Shape,
    work: Work,
    pairs: Vec<Pair>,
}

fn quartiles(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(|a, b| a.total_cmp(b));
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.25), at(0.5), at(0.75))
}

/// One timed pass of every query through a fresh handle of `cache`.
fn pass<C: IrradianceCache>(cache: &mut C, queries: &[(Vec3, Vec3)]) -> Duration {
    let frame = cache.frame();
    let mut h = frame.handle();
    let start = Instant::now();
    for &(p, n) in queries {
        black_box(h.lookup(black_box(p), black_box(n)));
    }
    let t = start.elapsed();
    drop(h);
    frame.close();
    t
}

/// Every query's answer from `cache` (irradiance and weight), untimed.
fn answers<C: IrradianceCache>(cache: &mut C, queries: &[(Vec3, Vec3)]) -> Vec<Option<[f64; 4]>> {
    let frame = cache.frame();
    let mut h = frame.handle();
    let out = queries
        .iter()
        .map(|&(p, n)| {
            h.lookup(p, n).map(|i| {
                let e = i.irradiance.as_dvec3();
                [e.x, e.y, e.z, i.weight]
            })
        })
        .collect();
    drop(h);
    frame.close();
    out
}

/// Panics unless `got` and TRA's `want` agree at every query (within 1e-5, relative).
fn check_answers(what: &str, want: &[Option<[f64; 4]>], got: &[Option<[f64; 4]>]) {
    assert_eq!(want.len(), got.len());
    for (i, (w, g)) in want.iter().zip(got).enumerate() {
        let same = match (w, g) {
            (None, None) => true,
            (Some(w), Some(g)) => w
                .iter()
                .zip(g)
                .all(|(a, b)| (a - b).abs() <= 1e-5 * a.abs().max(b.abs()).max(1.0)),
            _ => false,
        };
        assert!(same, "{what}: query {i} answered {g:?}, TRA {w:?}");
    }
}

/// TRA's counters over one pass of the queries.
fn work(tra: &mut Sequential, queries: &[(Vec3, Vec3)]) -> Work {
    let frame = tra.frame();
    let mut h = frame.handle();
    let mut valid = 0u64;
    for &(p, n) in queries {
        valid += h.lookup(p, n).map_or(0, |i| u64::from(i.records));
    }
    let s = *h.stats();
    drop(h);
    frame.close();
    let q = queries.len() as f64;
    Work {
        hit_rate: s.hits as f64 / q,
        nodes: s.lookup_nodes as f64 / q,
        examined: s.lookup_records as f64 / q,
        valid: valid as f64 / q,
    }
}

/// The lookup pair: ABBA rounds of `x` against `tra`; the ratio's quartiles, TRA's and `x`'s
/// median ns per lookup.
fn lookup_pair<C: IrradianceCache>(
    tra: &mut Sequential,
    x: &mut C,
    queries: &[(Vec3, Vec3)],
    rounds: usize,
) -> ((f64, f64, f64), f64, f64) {
    // One untimed pass each: caches, branch predictors and page tables warm.
    pass(tra, queries);
    pass(x, queries);
    let (mut ratios, mut ta, mut tb) = (Vec::new(), Vec::new(), Vec::new());
    let per = |t: f64| t / (2 * queries.len()) as f64 * 1e9;
    for _ in 0..rounds {
        let a1 = pass(tra, queries);
        let b1 = pass(x, queries);
        let b2 = pass(x, queries);
        let a2 = pass(tra, queries);
        let (a, b) = ((a1 + a2).as_secs_f64(), (b1 + b2).as_secs_f64());
        ratios.push(b / a);
        ta.push(per(a));
        tb.push(per(b));
    }
    (quartiles(ratios), quartiles(ta).1, quartiles(tb).1)
}

/// Inserts `batch` into `cache` in one frame; the time of the inserts and the frame's close.
fn insert_batch<C: IrradianceCache>(cache: &mut C, batch: &[Record]) -> Duration {
    let start = Instant::now();
    let frame = cache.frame();
    let mut h = frame.handle();
    for r in batch {
        let _ = black_box(h.insert(black_box(*r)));
    }
    drop(h);
    frame.close();
    start.elapsed()
}

/// Whether insert rounds fill fresh caches each round (small sets, or too few fresh records
/// for distinct batches): true below 100 times what the rounds insert.
fn refill(set: &Set, rounds: usize) -> bool {
    let inserted = rounds * BATCH;
    set.records.len() < 100 * inserted || set.fresh.len() < inserted
}

/// The insert rounds: `tra` and `x` alternately first. Returns true if `tra` now holds more.
fn insert_pair<C: IrradianceCache>(
    set: &Set,
    tra: &mut Sequential,
    x: &mut C,
    make: fn(CacheConfig) -> C,
    rounds: usize,
    p: &mut Pair,
) -> bool {
    let refill = refill(set, rounds);
    let (mut ta, mut tb, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
    let (mut fa, mut fb) = (Vec::new(), Vec::new());
    let per = |t: Duration, batch: &[Record]| t.as_secs_f64() / batch.len() as f64 * 1e9;
    // A first batch, untimed in the rounds, before the timed ones: the first frame after a
    // fill pays the allocator's deferred work of the fill's close (glibc sorts the blocks WF's
    // move into its slab freed at the next allocations), once per move, not per insert; it is
    // reported on its own (`first_ns`). Its records are the rounds' last batch where the set
    // holds enough fresh ones, else the first half of the one timed batch.
    let (first, timed) = if set.fresh.len() >= (rounds + 1) * BATCH || refill {
        let n = set.fresh.len();
        if n >= 2 * BATCH {
            (&set.fresh[n - BATCH..], &set.fresh[..n - BATCH])
        } else {
            (&set.fresh[..n / 2], &set.fresh[n / 2..])
        }
    } else {
        (&set.fresh[..0], &set.fresh[..])
    };
    if !refill && !first.is_empty() {
        fa.push(per(insert_batch(tra, first), first));
        fb.push(per(insert_batch(x, first), first));
    }
    for k in 0..rounds {
        let batch = if refill {
            &timed[..BATCH.min(timed.len())]
        } else {
            &timed[k * BATCH..(k + 1) * BATCH]
        };
        let (a, b) = if refill {
            // Each cache is filled just before its batch, so both are as warm: filling both
            // first left the one filled first out of the caches and cost its inserts up to twice
            // the other's (TRA against LCK, the same code, 0.45 at 10^5 records).
            let mut fresh_tra = || {
                let mut c = prefilled(Sequential::new(set.config), &set.records);
                fa.push(per(insert_batch(&mut c, first), first));
                insert_batch(&mut c, batch)
            };
            let mut fresh_x = || {
                let mut c = prefilled(make(set.config), &set.records);
                fb.push(per(insert_batch(&mut c, first), first));
                insert_batch(&mut c, batch)
            };
            if k % 2 == 0 {
                let a = fresh_tra();
                (a, fresh_x())
            } else {
                let b = fresh_x();
                (fresh_tra(), b)
            }
        } else if k % 2 == 0 {
            (insert_batch(tra, batch), insert_batch(x, batch))
        } else {
            let b = insert_batch(x, batch);
            (insert_batch(tra, batch), b)
        };
        ta.push(per(a, batch));
        tb.push(per(b, batch));
        ratios.push(b.as_secs_f64() / a.as_secs_f64());
    }
    p.tra_insert_ns = quartiles(ta).1;
    p.insert_ns = quartiles(tb).1;
    p.insert_ratio = quartiles(ratios);
    let median = |v: Vec<f64>| {
        if v.is_empty() {
            f64::NAN
        } else {
            quartiles(v).1
        }
    };
    p.tra_first_ns = median(fa);
    p.first_ns = median(fb);
    !refill
}

/// Settings of one run.
struct Run {
    test: bool,
    rounds: usize,
    insert_rounds: usize,
    schemes: Vec<String>,
}

/// One scheme against TRA on `set`: answers checked, lookups, inserts. Returns the figures and
/// whether `tra` was changed.
fn bench_scheme<C: IrradianceCache>(
    name: &str,
    set: &Set,
    (tra, tra_fill_ns): (&mut Sequential, f64),
    want: &[Option<[f64; 4]>],
    make: fn(CacheConfig) -> C,
    run: &Run,
) -> (Pair, bool) {
    let t0 = Instant::now();
    let mut x = prefilled(make(set.config), &set.records);
    let fill_ns = t0.elapsed().as_secs_f64() / set.records.len() as f64 * 1e9;
    assert_eq!(x.stats().records, set.records.len(), "{name} lost records");
    check_answers(name, want, &answers(&mut x, &set.queries));
    let mut p = Pair {
        scheme: name.to_string(),
        fill_ns,
        tra_fill_ns,
        ..Pair::default()
    };
    (p.ratio, p.tra_lookup_ns, p.lookup_ns) = lookup_pair(tra, &mut x, &set.queries, run.rounds);
    (p.sorted_ratio, p.tra_sorted_ns, p.sorted_ns) =
        lookup_pair(tra, &mut x, &set.sorted, run.rounds);
    let changed = insert_pair(set, tra, &mut x, make, run.insert_rounds, &mut p);
    eprintln!(
        "  {name}: lookup {:.0} ns (TRA {:.0}), {name}/TRA {:.3} ({:.3}-{:.3}); sorted {:.0} ns \
         (TRA {:.0}), {:.3}; insert {:.0} ns (TRA {:.0})",
        p.lookup_ns,
        p.tra_lookup_ns,
        p.ratio.1,
        p.ratio.0,
        p.ratio.2,
        p.sorted_ns,
        p.tra_sorted_ns,
        p.sorted_ratio.1,
        p.insert_ns,
        p.tra_insert_ns
    );
    (p, changed)
}

/// Every scheme of the run on `set`.
fn bench_set(set: &Set, run: &Run) -> Row {
    let t0 = Instant::now();
    let shape = shape(&set.config, &set.records);
    let t1 = Instant::now();
    let mut tra = prefilled(Sequential::new(set.config), &set.records);
    let tra_fill_ns = t1.elapsed().as_secs_f64() / set.records.len() as f64 * 1e9;
    let stats = tra.stats();
    assert_eq!(stats.records, set.records.len(), "TRA lost records");
    assert_eq!(
        stats.nodes, shape.nodes,
        "the tree's nodes differ from its shape's"
    );
    let work = work(&mut tra, &set.queries);
    let want = answers(&mut tra, &set.queries);
    eprintln!(
        "{} ({} records, a = {}): {} nodes, depth {}, lists mean {:.1} max {}; per lookup {:.1} \
         nodes, {:.1} examined, {:.2} valid, hit rate {:.1}% (filled in {:.1} s)",
        set.kind,
        set.records.len(),
        set.config.accuracy(),
        shape.nodes,
        shape.depth,
        shape.mean_list,
        shape.max_list,
        work.nodes,
        work.examined,
        work.valid,
        100.0 * work.hit_rate,
        t0.elapsed().as_secs_f64()
    );
    let schemes: Vec<&str> = run.schemes.iter().map(String::as_str).collect();
    let mut pairs = Vec::new();
    for (i, &name) in schemes.iter().enumerate() {
        let (p, changed) = match name {
            "wf" => bench_scheme(
                name,
                set,
                (&mut tra, tra_fill_ns),
                &want,
                WaitFree::adopt,
                run,
            ),
            "lck" => bench_scheme(
                name,
                set,
                (&mut tra, tra_fill_ns),
                &want,
                Locked::<MutexFlavour>::new,
                run,
            ),
            "lw" => bench_scheme(
                name,
                set,
                (&mut tra, tra_fill_ns),
                &want,
                LocalWrite::new,
                run,
            ),
            other => panic!("unknown scheme {other} (wf, lck, lw)"),
        };
        pairs.push(p);
        if changed && i + 1 < schemes.len() {
            drop(std::mem::replace(&mut tra, Sequential::new(set.config)));
            tra = prefilled(Sequential::new(set.config), &set.records);
        }
    }
    Row {
        kind: set.kind.clone(),
        target: set.target,
        accuracy: set.config.accuracy(),
        tried: set.tried.clone(),
        samples: set.samples,
        records: set.records.len(),
        shape,
        work,
        pairs,
    }
}

/// The Ward set of about `target` records: from disk if kept (full runs), else filled.
fn ward_for(target: usize, hint: &mut Option<(f32, usize)>, keep: bool) -> Set {
    let path = ward::cache_path(target, SEED);
    let t0 = Instant::now();
    let (ws, tried): (WardSet, Vec<f32>) = match keep.then(|| ward::load(&path)).flatten() {
        Some(found) => found,
        None => {
            let h = *hint.get_or_insert_with(|| {
                let pilot = ward::ward_set(0.25, SEED);
                (0.25, pilot.records.len())
            });
            let (ws, tried) = ward::search(target, h, SEED);
            if keep {
                ward::save(&path, &ws, &tried).expect("keep the set");
            }
            (ws, tried)
        }
    };
    *hint = Some((ws.accuracy, ws.records.len()));
    let off = ws.records.len() as f64 / target as f64;
    assert!(
        (0.8..=1.2).contains(&off),
        "the Ward set for {target} has {} records",
        ws.records.len()
    );
    eprintln!(
        "ward {target}: {} records at a = {} ({} samples; tried {tried:?}) in {:.1} s",
        ws.records.len(),
        ws.accuracy,
        ws.samples,
        t0.elapsed().as_secs_f64()
    );
    let queries = ward::uniform_queries(QUERIES, QUERY_SEED);
    let config = ward::config(ws.accuracy);
    Set {
        kind: "ward".into(),
        target: Some(target),
        fresh: ward::fresh_like(&ws, (INSERT_ROUNDS + 1) * BATCH, FRESH_SEED),
        sorted: morton_order(&queries, &config),
        queries,
        config,
        tried,
        samples: Some(ws.samples),
        records: ws.records,
    }
}

/// The real sets `dump_records` left under `target/records-held/`, smallest first.
fn real_sets() -> Vec<Set> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/records-held");
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    paths.retain(|p| {
        p.file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with("real-") && n.ends_with(".bin"))
    });
    let mut sets: Vec<Set> = paths
        .iter()
        .filter_map(|p| {
            let real = ward::load_real(p)?;
            let kind = p.file_stem()?.to_str()?.to_string();
            // Hold out a tenth of the records (at most the rounds' batches), shuffled, for the
            // inserts.
            let mut records = real.records;
            let mut rng = wfic::rng::Rng::new(FRESH_SEED);
            for i in (1..records.len()).rev() {
                records.swap(i, rng.below(i as u64 + 1) as usize);
            }
            let held = (records.len() / 10).min((INSERT_ROUNDS + 1) * BATCH);
            let fresh = records.split_off(records.len() - held);
            Some(Set {
                kind,
                target: None,
                tried: vec![real.config.accuracy()],
                samples: None,
                config: real.config,
                records,
                fresh,
                sorted: morton_order(&real.queries, &real.config),
                queries: real.queries,
            })
        })
        .collect();
    sets.sort_by_key(|s| s.records.len());
    sets
}

#[path = "records_held/page.rs"]
mod page;

/// `--probe SCHEME TARGET PASSES [sorted]`: only fills SCHEME with the kept Ward set of TARGET
/// records and makes PASSES passes of the queries, for a counter run around it (the difference
/// between PASSES and 0 is the lookups'): `valgrind --tool=cachegrind` here, as the VM exposes no
/// hardware counters to `perf`.
fn probe(args: &[String]) {
    let target: usize = args[1].parse().expect("target");
    let passes: usize = args[2].parse().expect("passes");
    let (ws, _) = ward::load(&ward::cache_path(target, SEED)).expect("a kept set: run the bench");
    let config = ward::config(ws.accuracy);
    let queries = ward::uniform_queries(QUERIES, QUERY_SEED);
    let queries = if args.get(3).is_some_and(|a| a == "sorted") {
        morton_order(&queries, &config)
    } else {
        queries
    };
    fn go<C: IrradianceCache>(mut c: C, q: &[(Vec3, Vec3)], passes: usize) {
        for _ in 0..passes {
            pass(&mut c, q);
        }
    }
    match args[0].as_str() {
        "tra" => go(
            prefilled(Sequential::new(config), &ws.records),
            &queries,
            passes,
        ),
        "wf" => go(
            prefilled(WaitFree::adopt(config), &ws.records),
            &queries,
            passes,
        ),
        other => panic!("probe: tra or wf, not {other}"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Some(i) = args.iter().position(|a| a == "--probe") {
        return probe(&args[i + 1..]);
    }
    let test = args.iter().any(|a| a == "--test");
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
    };
    let sizes: Vec<usize> = match value("--sizes") {
        Some(s) => s.split(',').map(|n| n.parse().expect("a size")).collect(),
        None if test => vec![1_000, 10_000],
        None => SIZES.to_vec(),
    };
    let rounds = value("--rounds").map_or(if test { 3 } else { ROUNDS }, |r| {
        r.parse().expect("rounds")
    });
    let skip: Vec<&String> = ["--sizes", "--rounds"]
        .iter()
        .filter_map(|f| value(f))
        .collect();
    let named: Vec<String> = args
        .iter()
        .filter(|a| !a.starts_with("--") && !skip.contains(a))
        .cloned()
        .collect();
    let run = Run {
        test,
        rounds,
        insert_rounds: if test { 3 } else { INSERT_ROUNDS },
        schemes: if named.is_empty() {
            vec!["wf".into(), "lck".into(), "lw".into()]
        } else {
            named.clone()
        },
    };
    let started = page::Context::now();
    let mut rows = Vec::new();
    let mut hint = None;
    for &n in &sizes {
        let set = ward_for(n, &mut hint, !test);
        rows.push(bench_set(&set, &run));
    }
    if !test && !args.iter().any(|a| a == "--no-real") {
        for set in real_sets() {
            rows.push(bench_set(&set, &run));
        }
    }
    if !run.test && value("--sizes").is_none() {
        page::write(&started, &rows, &run);
    } else {
        print!("{}", page::tables(&rows));
    }
}
