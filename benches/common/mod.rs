//! The workload shared by the cache benchmarks (`cache_ops`, `orderings`): a room with three
//! boxes, a pre-filled cache, lookup queries, fresh records to insert. See `cache_ops.rs` for the
//! full description.
#![allow(dead_code)]

use criterion::measurement::WallTime;
use criterion::BenchmarkGroup;
use glam::Vec3;
use std::hint::black_box;
use std::sync::OnceLock;
use std::time::{Duration, Instant};
use wfic::cache::{CacheConfig, CacheHandle, IrradianceCache, Octree};
use wfic::ic::{clamp_radius, Accumulator, Record, WorkerId};
use wfic::rng::Rng;

pub mod ward;

/// Records in the cache before any timed operation.
pub const PREFILL: usize = 4096;
/// Distinct lookup queries, cycled through.
pub const QUERIES: usize = 16_384;
/// Fresh records inserted by two threads into one freshly pre-filled cache
/// (`orderings/insert-2t/*`): large enough that a frame is about a millisecond per worker.
pub const INSERT_BATCH_2T: usize = 8192;
/// Fresh records inserted into one freshly pre-filled cache (`insert/*`).
pub const INSERT_BATCH: usize = 1024;
/// Operations (both workers together) per frame of `mixed-2t/*`, each frame on a fresh cache.
pub const FRAME_OPS: usize = 20_000;
/// One operation in this many is an insert in `mixed-2t/*` (1%).
pub const INSERT_EVERY: usize = 100;
/// Ward's accuracy `a`.
pub const ACCURACY: f32 = 0.25;
/// Share of queries placed inside a stored record's radius of validity; the rest are uniform on
/// the surfaces and hit only where records happen to overlap them.
pub const NEAR_SHARE: f32 = 0.81;
/// Record radii (clamped harmonic mean distances).
pub const MIN_RADIUS: f32 = 0.05;
pub const MAX_RADIUS: f32 = 0.5;
/// The worker number that pre-fills caches (a "previous frame"); bench workers are 0 and 1.
pub const PREFILL_WORKER: WorkerId = WorkerId::new(1000);

// ---------------------------------------------------------------------------------------------
// Deterministic workload
// ---------------------------------------------------------------------------------------------

/// An axis-aligned rectangle of the scene: `origin + s * u + t * v`, `s` in `[0, len_u]`, `t` in
/// `[0, len_v]`.
pub struct Face {
    origin: Vec3,
    u: Vec3,
    v: Vec3,
    len_u: f32,
    len_v: f32,
    normal: Vec3,
}

impl Face {
    /// The face of the box `lo..hi` lying at `at` on `axis`, with its normal along `sign * axis`.
    fn of_box(axis: usize, at: f32, lo: Vec3, hi: Vec3, sign: f32) -> Self {
        let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut origin = lo;
        origin[axis] = at;
        Self {
            origin,
            u: Vec3::AXES[b],
            v: Vec3::AXES[c],
            len_u: hi[b] - lo[b],
            len_v: hi[c] - lo[c],
            normal: Vec3::AXES[axis] * sign,
        }
    }

    fn area(&self) -> f32 {
        self.len_u * self.len_v
    }

    fn point(&self, s: f32, t: f32) -> Vec3 {
        self.origin + self.u * s + self.v * t
    }
}

/// A point on a surface of the scene.
#[derive(Clone, Copy)]
pub struct SurfacePoint {
    face: usize,
    s: f32,
    t: f32,
}

pub struct Scene {
    faces: Vec<Face>,
    /// Cumulative face areas, for area-weighted sampling.
    cumulative: Vec<f32>,
    boxes: Vec<(Vec3, Vec3)>,
}

impl Scene {
    fn room() -> Self {
        let (lo, hi) = (Vec3::ZERO, Vec3::splat(5.0));
        let boxes = vec![
            (Vec3::new(1.0, 0.0, 1.0), Vec3::new(2.0, 1.5, 2.0)),
            (Vec3::new(3.0, 0.0, 2.5), Vec3::new(4.2, 0.8, 4.0)),
            (Vec3::new(0.6, 0.0, 3.6), Vec3::new(1.6, 2.2, 4.4)),
        ];
        let mut faces = Vec::new();
        for axis in 0..3 {
            // The room is seen from inside: normals point inwards.
            faces.push(Face::of_box(axis, lo[axis], lo, hi, 1.0));
            faces.push(Face::of_box(axis, hi[axis], lo, hi, -1.0));
        }
        for &(blo, bhi) in &boxes {
            for axis in 0..3 {
                // The bottom face rests on the floor and is never seen.
                if axis != 1 {
                    faces.push(Face::of_box(axis, blo[axis], blo, bhi, -1.0));
                }
                faces.push(Face::of_box(axis, bhi[axis], blo, bhi, 1.0));
            }
        }
        let cumulative = faces
            .iter()
            .scan(0.0, |sum, f| {
                *sum += f.area();
                Some(*sum)
            })
            .collect();
        Self {
            faces,
            cumulative,
            boxes,
        }
    }

    /// True when `p` is hidden inside a box (the floor under a box).
    fn hidden(&self, p: Vec3) -> bool {
        self.boxes
            .iter()
            .any(|&(lo, hi)| p.cmpgt(lo).all() && p.cmplt(hi).all())
    }

    /// A visible surface point, uniform by area.
    fn sample(&self, rng: &mut Rng) -> SurfacePoint {
        let total = *self.cumulative.last().unwrap();
        loop {
            let x = rng.next_f32() * total;
            let face = self.cumulative.partition_point(|&c| c <= x);
            let face = face.min(self.faces.len() - 1);
            let f = &self.faces[face];
            let sp = SurfacePoint {
                face,
                s: rng.next_f32() * f.len_u,
                t: rng.next_f32() * f.len_v,
            };
            let (p, n) = self.position(sp);
            if !self.hidden(p + n * 1e-3) {
                return sp;
            }
        }
    }

    fn position(&self, sp: SurfacePoint) -> (Vec3, Vec3) {
        let f = &self.faces[sp.face];
        (f.point(sp.s, sp.t), f.normal)
    }

    /// A record at `sp`, as a renderer would have computed it there.
    fn record(&self, sp: SurfacePoint, rng: &mut Rng) -> Record {
        let f = &self.faces[sp.face];
        let (p, n) = self.position(sp);
        // Near the edge of a face other surfaces are near, so the harmonic mean distance is small.
        let edge = sp.s.min(f.len_u - sp.s).min(sp.t).min(f.len_v - sp.t);
        let radius = clamp_radius(0.8 * edge * rng.range(0.5, 1.5), MIN_RADIUS, MAX_RADIUS);
        let light = Vec3::new(2.5, 4.9, 2.5);
        let falloff = 2.0 / (1.0 + (p - light).length_squared() * 0.25);
        let irradiance =
            Vec3::new(1.0, 0.9, 0.8) * (0.3 + falloff) + Vec3::splat(0.05 * rng.next_f32());
        let mut tangent =
            |scale: f32| f.u * rng.range(-scale, scale) + f.v * rng.range(-scale, scale);
        let grad_t = [tangent(0.1), tangent(0.1), tangent(0.1)];
        let grad_r = [tangent(0.05), tangent(0.05), tangent(0.05)];
        Record::new(p, n, irradiance, radius).with_gradients(grad_t, grad_r)
    }
}

/// One operation of a `mixed-2t` worker: an index into the queries or into the fresh records.
#[derive(Clone, Copy)]
pub enum Op {
    /// Look up query `i`.
    Lookup(u32),
    /// Insert fresh record `i`.
    Insert(u32),
}

pub struct Workload {
    pub config: CacheConfig,
    /// Records every cache starts from.
    pub prefill: Vec<Record>,
    /// Lookup points and normals.
    pub queries: Vec<(Vec3, Vec3)>,
    /// Records not in the pre-fill, for the inserts.
    pub fresh: Vec<Record>,
    /// More records not in the pre-fill, for `orderings/insert-2t/*` ([`INSERT_BATCH_2T`]), drawn
    /// from their own random stream so that the other fields stay as they were.
    pub fresh_2t: Vec<Record>,
    /// Each `mixed-2t` worker's operations for one frame (`FRAME_OPS / 2` each).
    pub mixed: [Vec<Op>; 2],
}

impl Workload {
    fn build() -> Self {
        let config = scene_config();
        let scene = Scene::room();
        let mut rng = Rng::new(0x1c_2009);

        let sites: Vec<SurfacePoint> = (0..PREFILL).map(|_| scene.sample(&mut rng)).collect();
        let prefill: Vec<Record> = sites.iter().map(|&sp| scene.record(sp, &mut rng)).collect();

        let queries = (0..QUERIES)
            .map(|_| {
                let sp = if rng.next_f32() < NEAR_SHARE {
                    // Inside the validity radius `a * R` of a stored record, on its face.
                    let i = rng.below(PREFILL as u64) as usize;
                    let (site, f) = (sites[i], &scene.faces[sites[i].face]);
                    let reach = 0.9 * ACCURACY * prefill[i].radius * rng.next_f32().sqrt();
                    let angle = rng.range(0.0, std::f32::consts::TAU);
                    SurfacePoint {
                        s: (site.s + reach * angle.cos()).clamp(0.0, f.len_u),
                        t: (site.t + reach * angle.sin()).clamp(0.0, f.len_v),
                        ..site
                    }
                } else {
                    scene.sample(&mut rng)
                };
                let (p, n) = scene.position(sp);
                // Ray hits are not exactly on the surface.
                (p + n * rng.range(-1e-4, 1e-4), n)
            })
            .collect();

        let fresh_len = INSERT_BATCH.max(2 * FRAME_OPS.div_ceil(2 * INSERT_EVERY));
        let fresh: Vec<Record> = (0..fresh_len)
            .map(|_| {
                let sp = scene.sample(&mut rng);
                scene.record(sp, &mut rng)
            })
            .collect();

        let mixed = std::array::from_fn(|k| {
            let per_worker = FRAME_OPS.div_ceil(2);
            // Each worker inserts its own fresh records, at a different phase of the 1%.
            let phase = (INSERT_EVERY / 2) * k;
            let mut next_insert = (per_worker.div_ceil(INSERT_EVERY) * k) as u32;
            (0..per_worker)
                .map(|j| {
                    if j % INSERT_EVERY == phase {
                        next_insert += 1;
                        Op::Insert(next_insert - 1)
                    } else {
                        Op::Lookup(rng.below(QUERIES as u64) as u32)
                    }
                })
                .collect()
        });

        let mut rng_2t = Rng::new(0x2_7e4d);
        let fresh_2t: Vec<Record> = (0..INSERT_BATCH_2T)
            .map(|_| {
                let sp = scene.sample(&mut rng_2t);
                scene.record(sp, &mut rng_2t)
            })
            .collect();

        for r in fresh.iter().chain(&fresh_2t) {
            config.check(r).expect("fresh record refused");
        }
        let w = Self {
            config,
            prefill,
            queries,
            fresh,
            fresh_2t,
            mixed,
        };
        w.report();
        w
    }

    /// Prints what the workload looks like, so a change in it shows.
    fn report(&self) {
        let mut tree = Octree::new(self.config);
        for r in &self.prefill {
            tree.insert(*r).expect("pre-fill record refused");
        }
        let (mut hits, mut nodes, mut examined, mut valid) = (0usize, 0u64, 0u64, 0u64);
        for &(p, n) in &self.queries {
            let mut acc = Accumulator::new(p, n, ACCURACY, None);
            nodes += u64::from(tree.visit(p, &mut |r| {
                examined += 1;
                valid += u64::from(acc.add(r));
            }));
            hits += usize::from(acc.finish().is_some());
        }
        let q = self.queries.len() as f64;
        eprintln!(
            "cache_ops workload: {} records in {} nodes; {} queries, hit rate {:.1}%, per lookup \
             {:.1} nodes visited, {:.1} records examined, {:.2} valid",
            tree.len(),
            tree.node_count(),
            self.queries.len(),
            100.0 * hits as f64 / q,
            nodes as f64 / q,
            examined as f64 / q,
            valid as f64 / q,
        );
    }
}

/// `n` records of the workload's scene, as the pre-fill draws them (a surface point uniform by
/// area, then its record) from a stream of their own seeded with `seed`: the fill for a cache of
/// any size (`examples/memory`), all inside [`Workload::config`]'s bounds.
pub fn scene_records(n: usize, seed: u64) -> Vec<Record> {
    let scene = Scene::room();
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| {
            let sp = scene.sample(&mut rng);
            scene.record(sp, &mut rng)
        })
        .collect()
}

/// The cache configuration of the workload: the room's 5 m cube at accuracy [`ACCURACY`].
pub fn scene_config() -> CacheConfig {
    CacheConfig::new(Vec3::ZERO, Vec3::splat(5.0), ACCURACY).expect("config")
}

pub fn workload() -> &'static Workload {
    static WORKLOAD: OnceLock<Workload> = OnceLock::new();
    WORKLOAD.get_or_init(Workload::build)
}

/// `cache` with `records` inserted by a previous frame's worker.
pub fn prefilled<C: IrradianceCache>(mut cache: C, records: &[Record]) -> C {
    let frame = cache.frame();
    let mut h = frame.handle_for(PREFILL_WORKER);
    for r in records {
        h.insert(*r).expect("pre-fill record refused");
    }
    drop(h);
    frame.close();
    cache
}

/// The measurement settings every cache benchmark group uses.
pub fn configure(g: &mut BenchmarkGroup<'_, WallTime>) {
    g.sample_size(20)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(500));
}

// ---------------------------------------------------------------------------------------------
// Single-thread lookup and insert measurements, shared by cache_ops and orderings
// ---------------------------------------------------------------------------------------------

/// One lookup per iteration, cycling through the queries, in one pre-filled cache.
pub fn bench_lookup<C: IrradianceCache>(
    g: &mut BenchmarkGroup<'_, WallTime>,
    id: &str,
    make: fn(CacheConfig) -> C,
) {
    let w = workload();
    let mut cache = prefilled(make(w.config), &w.prefill);
    g.bench_function(id, |b| {
        b.iter_custom(|iters| {
            let frame = cache.frame();
            let mut h = frame.handle();
            let mut i = 0;
            let start = Instant::now();
            for _ in 0..iters {
                let (p, n) = w.queries[i];
                black_box(h.lookup(black_box(p), black_box(n)));
                i += 1;
                if i == w.queries.len() {
                    i = 0;
                }
            }
            let elapsed = start.elapsed();
            drop(h);
            frame.close();
            elapsed
        })
    });
}

/// One insert per iteration: batches of `INSERT_BATCH` fresh records, each into a freshly
/// pre-filled cache; only the inserts are timed.
pub fn bench_insert<C: IrradianceCache>(
    g: &mut BenchmarkGroup<'_, WallTime>,
    id: &str,
    make: fn(CacheConfig) -> C,
) {
    let w = workload();
    let batch = &w.fresh[..INSERT_BATCH];
    g.bench_function(id, |b| {
        b.iter_custom(|iters| {
            in_frames(iters, INSERT_BATCH, |n| {
                let mut cache = prefilled(make(w.config), &w.prefill);
                let frame = cache.frame();
                let mut h = frame.handle();
                let start = Instant::now();
                for r in &batch[..n] {
                    let _ = black_box(h.insert(black_box(*r)));
                }
                let elapsed = start.elapsed();
                drop(h);
                // The frame is closed and the cache dropped here, outside the timing.
                elapsed
            })
        })
    });
}

/// `iters` operations for criterion's `iter_custom`, in frames of at most `frame` operations (each
/// typically on a freshly pre-filled cache): `timed(n)` runs one frame of `n` operations and
/// returns its timed part; the sum is returned.
pub fn in_frames(iters: u64, frame: usize, mut timed: impl FnMut(usize) -> Duration) -> Duration {
    let mut total = Duration::ZERO;
    let mut left = iters as usize;
    while left > 0 {
        let n = left.min(frame);
        total += timed(n);
        left -= n;
    }
    total
}

/// A one-shot start line for bench workers that waits by yielding instead of sleeping: each
/// arriving worker counts itself in, then calls `yield_now` until all have arrived. A worker on a
/// core of its own keeps running (there is nothing to yield to), so it leaves the line within
/// microseconds of the last arrival; one that shares a core with its partner hands the core over
/// instead of burning the partner's time slice (which a pure spin would). `std::sync::Barrier`
/// puts the early worker to sleep, and waking a sleeping thread on this virtual machine put a
/// median 0.56–2.3 ms between the two workers' starts (`benches/insert_split.rs`, workers parked
/// between frames), a fifth to a half of a two-thread insert frame.
pub struct YieldBarrier {
    arrived: std::sync::atomic::AtomicUsize,
    workers: usize,
}

impl YieldBarrier {
    pub fn new(workers: usize) -> Self {
        Self {
            arrived: std::sync::atomic::AtomicUsize::new(0),
            workers,
        }
    }

    pub fn wait(&self) {
        use std::sync::atomic::Ordering;
        // AcqRel/Acquire: each worker's set-up before the line happens-before the others leave
        // it (bench code, outside the crate's `sync` facade: nothing here is model-checked).
        self.arrived.fetch_add(1, Ordering::AcqRel);
        while self.arrived.load(Ordering::Acquire) < self.workers {
            std::thread::yield_now();
        }
    }
}
