//! What a second inserting thread costs, taken apart: the same 8 192 fresh records inserted into a freshly pre-filled cache, split several
//! ways, with each worker's allocations, allocated bytes and minor page faults counted beside the
//! time.
//!
//! | variant | what runs |
//! |---|---|
//! | `wf-1t` | one worker inserts the whole batch into the shared WF cache |
//! | `wf-1t-half` | one worker inserts the first half only (the per-worker work of the splits) |
//! | `wf-2t-interleaved` | two workers, halves drawn from the same random stream: same lists, same children |
//! | `wf-2t-by-space` | two workers, split at the root's centre (`x`): below the root they share no node |
//! | `wf-2t-own-caches` | two workers, each its half into a WF cache of its own: nothing shared |
//! | `tra-1t`, `tra-1t-half`, `tra-2t-own-caches` | the same with TRA's plain octree (no atomics) |
//! | `wf-1t-persistent`, `wf-2t-interleaved-persistent` | as `wf-1t` and `wf-2t-interleaved`, on two workers that live for the whole run and are parked between frames (as `orderings`' `Pair` was), meeting at a `std::sync::Barrier` |
//! | `wf-2t-interleaved-persistent-yield` | the same, meeting at a [`YieldBarrier`] |
//! | `lookup-*` | lookups at the batch's positions, one thread or two with caches of their own: what two threads cost each other with no allocation and nothing written |
//!
//! The time is the frame's wall time (first worker's start to last worker's end, both released by
//! one barrier) per record of the batch. Criterion would time the variants one after another,
//! seconds apart, while the machine's speed drifts by more than the differences sought; so every
//! round runs every variant once, in an order rotated from round to round (and reversed on odd
//! rounds), and each variant's figure is the median over the rounds of its ratio to `wf-1t` in the
//! same round, with the quartiles.
//!
//! Counting: a global allocator that adds to thread-local counters (no shared counter, which would
//! itself be contended), and `minflt` of `/proc/thread-self/stat` read by each worker before the
//! barrier and after its last insert.
//!
//! Run: `cargo bench --no-default-features --bench insert_split [-- --rounds N] [-- --test]`.

mod common;

use common::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::hint::black_box;
use std::sync::{mpsc, Arc, Barrier};
use std::time::Instant;
use wfic::cache::wf::Minimal;
use wfic::cache::CacheHandle;
use wfic::cache::{CasFailure, IrradianceCache, Sequential, WaitFree};
use wfic::ic::{Record, WorkerId};

/// The system allocator, counting each thread's allocations and bytes in thread-local cells.
struct Counting;

thread_local! {
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
    static BYTES: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: every call is forwarded unchanged to `System`, which upholds `GlobalAlloc`'s contract;
// the counting touches only const-initialised thread-local cells (no allocation, no destructor).
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        // SAFETY: the caller's `layout` is passed on unchanged.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        // SAFETY: as `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System` with this `layout` (every allocation goes through it).
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count(new_size);
        // SAFETY: as `dealloc`; `new_size` is the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

fn count(size: usize) {
    // `try_with`: a thread being torn down has no cells left; it is not measuring.
    let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
    let _ = BYTES.try_with(|c| c.set(c.get() + size as u64));
}

/// This thread's minor page faults so far (`minflt`, field 10 of `/proc/thread-self/stat`).
fn minor_faults() -> u64 {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").unwrap_or_default();
    // The command name (field 2) is in parentheses and may hold spaces: count from its end.
    stat.rsplit_once(')')
        .and_then(|(_, rest)| rest.split_whitespace().nth(7))
        .and_then(|f| f.parse().ok())
        .unwrap_or(0)
}

/// What one worker did: its timed span, the records it handled, and what it allocated and
/// faulted in the span.
#[derive(Clone, Copy)]
struct Span {
    start: Instant,
    end: Instant,
    records: usize,
    allocs: u64,
    bytes: u64,
    faults: u64,
}

/// What a worker does with each record of its part.
#[derive(Clone, Copy, PartialEq)]
enum Op {
    /// Inserts it.
    Insert,
    /// Looks its position and normal up (no allocation, nothing written): the control that
    /// shows what two threads cost each other where the allocator is not involved.
    Lookup,
}

/// Waits at the start line (`start_line()` returns once every worker is there), applies `op` to
/// each of `records` through `h`, and reports the span.
fn work<H: CacheHandle>(h: &mut H, op: Op, records: &[Record], start_line: &dyn Fn()) -> Span {
    let (a0, b0, f0) = (
        ALLOCS.with(Cell::get),
        BYTES.with(Cell::get),
        minor_faults(),
    );
    start_line();
    let start = Instant::now();
    match op {
        Op::Insert => {
            for r in records {
                let _ = black_box(h.insert(black_box(*r)));
            }
        }
        Op::Lookup => {
            for r in records {
                black_box(h.lookup(black_box(r.position), black_box(r.normal)));
            }
        }
    }
    let end = Instant::now();
    Span {
        start,
        end,
        records: records.len(),
        allocs: ALLOCS.with(Cell::get) - a0,
        bytes: BYTES.with(Cell::get) - b0,
        faults: minor_faults() - f0,
    }
}

/// One frame's figures, per record of the batch; `busy` is per record of each worker's own part
/// (its span over its records, averaged over the workers): what one worker's operation cost
/// while the other ran, free of any skew between their starts.
#[derive(Clone, Copy, Default)]
struct Sample {
    ns: f64,
    busy: f64,
    /// Microseconds between the first and the last worker's start (both released by one barrier).
    skew_us: f64,
    allocs: f64,
    bytes: f64,
    faults: f64,
}

fn sample(spans: &[Span], records: usize) -> Sample {
    let start = spans.iter().map(|s| s.start).min().expect("a worker");
    let end = spans.iter().map(|s| s.end).max().expect("a worker");
    let n = records as f64;
    let last_start = spans.iter().map(|s| s.start).max().expect("a worker");
    Sample {
        ns: (end - start).as_secs_f64() * 1e9 / n,
        skew_us: (last_start - start).as_secs_f64() * 1e6,
        busy: spans
            .iter()
            .filter(|s| s.records > 0)
            .map(|s| (s.end - s.start).as_secs_f64() * 1e9 / s.records.max(1) as f64)
            .sum::<f64>()
            / spans.iter().filter(|s| s.records > 0).count().max(1) as f64,
        allocs: spans.iter().map(|s| s.allocs).sum::<u64>() as f64 / n,
        bytes: spans.iter().map(|s| s.bytes).sum::<u64>() as f64 / n,
        faults: spans.iter().map(|s| s.faults).sum::<u64>() as f64 / n,
    }
}

/// `parts[k]` inserted by worker `k`, all workers into one freshly pre-filled cache. Workers are
/// threads started for the frame, each taking its handle from the frame (std's scoped threads
/// rather than `Frame::run`, so the bench also builds under the model checkers' features).
fn shared<C: IrradianceCache + Sync>(make: impl Fn() -> C, op: Op, parts: &[&[Record]]) -> Sample {
    let w = workload();
    let mut cache = prefilled(make(), &w.prefill);
    let frame = cache.frame();
    let start_line = Barrier::new(parts.len());
    let spans: Vec<Span> = std::thread::scope(|s| {
        let workers: Vec<_> = parts
            .iter()
            .map(|&part| {
                let (frame, start_line) = (&frame, &start_line);
                s.spawn(move || {
                    let mut h = frame.handle();
                    work(&mut h, op, part, &|| {
                        start_line.wait();
                    })
                })
            })
            .collect();
        workers
            .into_iter()
            .map(|t| t.join().expect("worker"))
            .collect()
    });
    frame.close();
    sample(&spans, parts.iter().map(|p| p.len()).sum())
}

/// `parts[k]` inserted by worker `k` into a freshly pre-filled cache of its own.
fn own<C: IrradianceCache + Send>(make: impl Fn() -> C, op: Op, parts: &[&[Record]]) -> Sample {
    let w = workload();
    let mut caches: Vec<C> = parts
        .iter()
        .map(|_| prefilled(make(), &w.prefill))
        .collect();
    let start_line = Barrier::new(parts.len());
    let spans: Vec<Span> = std::thread::scope(|s| {
        let workers: Vec<_> = caches
            .iter_mut()
            .zip(parts)
            .map(|(cache, &part)| {
                let start_line = &start_line;
                s.spawn(move || {
                    let frame = cache.frame();
                    let mut h = frame.handle();
                    let span = work(&mut h, op, part, &|| {
                        start_line.wait();
                    });
                    drop(h);
                    frame.close();
                    span
                })
            })
            .collect();
        workers
            .into_iter()
            .map(|t| t.join().expect("worker"))
            .collect()
    });
    sample(&spans, parts.iter().map(|p| p.len()).sum())
}

/// Two worker threads that live for the whole run and take one job a frame over a channel, as
/// `benches/orderings.rs`'s `Pair` does (there, so that every frame runs on warm threads); the
/// variants marked `persistent` run on these instead of on threads started for the frame.
struct Persistent {
    jobs: Vec<mpsc::Sender<Box<dyn FnOnce() -> Span + Send>>>,
    done: mpsc::Receiver<Span>,
}

impl Persistent {
    fn new() -> Self {
        let (done_tx, done) = mpsc::channel();
        let jobs = (0..2)
            .map(|_| {
                let (tx, rx) = mpsc::channel::<Box<dyn FnOnce() -> Span + Send>>();
                let done_tx = done_tx.clone();
                std::thread::spawn(move || {
                    for job in rx {
                        if done_tx.send(job()).is_err() {
                            break;
                        }
                    }
                });
                tx
            })
            .collect();
        Self { jobs, done }
    }

    /// `parts[k]` inserted by persistent worker `k` into one freshly pre-filled shared WF cache
    /// (the low-level protocol: a handle per worker, `end_frame` once both are dropped).
    /// With `yielding`, the workers meet at a [`YieldBarrier`] instead of a `std::sync::Barrier`.
    fn shared(&self, parts: [&'static [Record]; 2], yielding: bool) -> Sample {
        let w = workload();
        let cache = Arc::new(prefilled(
            WaitFree::<Minimal>::new(w.config, CasFailure::Adopt),
            &w.prefill,
        ));
        let sleeping = Arc::new(Barrier::new(2));
        let spinning = Arc::new(YieldBarrier::new(2));
        for (k, jobs) in self.jobs.iter().enumerate() {
            let (cache, part) = (Arc::clone(&cache), parts[k]);
            let (sleeping, spinning) = (Arc::clone(&sleeping), Arc::clone(&spinning));
            jobs.send(Box::new(move || {
                let mut h = cache.handle(WorkerId::new(k as u32));
                let start_line = || {
                    if yielding {
                        spinning.wait();
                    } else {
                        sleeping.wait();
                    }
                };
                work(&mut h, Op::Insert, part, &start_line)
            }))
            .expect("worker alive");
        }
        let spans = [0, 1].map(|_| self.done.recv().expect("worker alive"));
        let mut cache = Arc::into_inner(cache).expect("the workers dropped their clones");
        cache.end_frame();
        sample(&spans, parts.iter().map(|p| p.len()).sum())
    }
}

fn quartiles(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.25), at(0.5), at(0.75))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let test = args.iter().any(|a| a == "--test");
    let rounds: usize = args
        .iter()
        .position(|a| a == "--rounds")
        .and_then(|i| args.get(i + 1))
        .map(|n| n.parse().expect("--rounds N"))
        .unwrap_or(if test { 2 } else { 101 });
    let w = workload();
    let batch: &'static [Record] = &w.fresh_2t[..INSERT_BATCH_2T];
    let half = batch.len() / 2;
    let halves: [&'static [Record]; 2] = [&batch[..half], &batch[half..]];
    let centre = w.config.root().center.x;
    let (west, east): (Vec<Record>, Vec<Record>) =
        batch.iter().partition(|r| r.position.x < centre);
    let wf = || WaitFree::<Minimal>::new(w.config, CasFailure::Adopt);
    let tra = || Sequential::new(w.config);

    let persistent = Persistent::new();
    type Variant<'a> = (&'static str, Box<dyn Fn() -> Sample + 'a>);
    let variants: Vec<Variant<'_>> = vec![
        ("wf-1t", Box::new(|| shared(wf, Op::Insert, &[batch]))),
        (
            "wf-1t-half",
            Box::new(|| shared(wf, Op::Insert, &halves[..1])),
        ),
        (
            "wf-2t-interleaved",
            Box::new(|| shared(wf, Op::Insert, &halves)),
        ),
        (
            "wf-2t-by-space",
            Box::new(|| shared(wf, Op::Insert, &[&west, &east])),
        ),
        (
            "wf-2t-own-caches",
            Box::new(|| own(wf, Op::Insert, &halves)),
        ),
        ("tra-1t", Box::new(|| own(tra, Op::Insert, &[batch]))),
        (
            "tra-1t-half",
            Box::new(|| own(tra, Op::Insert, &halves[..1])),
        ),
        (
            "tra-2t-own-caches",
            Box::new(|| own(tra, Op::Insert, &halves)),
        ),
        (
            "wf-1t-persistent",
            Box::new(|| persistent.shared([batch, &[]], false)),
        ),
        (
            "wf-2t-interleaved-persistent",
            Box::new(|| persistent.shared(halves, false)),
        ),
        (
            "wf-2t-interleaved-persistent-yield",
            Box::new(|| persistent.shared(halves, true)),
        ),
        (
            "lookup-wf-1t-half",
            Box::new(|| own(wf, Op::Lookup, &halves[..1])),
        ),
        (
            "lookup-wf-2t-own-caches",
            Box::new(|| own(wf, Op::Lookup, &halves)),
        ),
        (
            "lookup-tra-1t-half",
            Box::new(|| own(tra, Op::Lookup, &halves[..1])),
        ),
        (
            "lookup-tra-2t-own-caches",
            Box::new(|| own(tra, Op::Lookup, &halves)),
        ),
    ];
    // One untimed frame of each: pages, arenas and branch predictors warm.
    for (_, v) in &variants {
        v();
    }
    let n = variants.len();
    let mut samples: Vec<Vec<Sample>> = vec![Vec::new(); n];
    for round in 0..rounds {
        let mut order: Vec<usize> = (0..n).map(|i| (i + round) % n).collect();
        if round % 2 == 1 {
            order.reverse();
        }
        for i in order {
            samples[i].push(variants[i].1());
        }
    }
    println!(
        "insert-split: {} records ({} west of the root's centre), {rounds} rounds; figures per \
         record of the batch, medians over rounds; ratio: per-round time / wf-1t's, median \
         (quartiles)\n",
        batch.len(),
        west.len()
    );
    println!(
        "| variant | ns/record (wall) | ratio to wf-1t | busy ns/record of a worker's part | \
         start skew µs | allocations/record | bytes/record | minor faults/record |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for (i, (name, _)) in variants.iter().enumerate() {
        let med = |f: fn(&Sample) -> f64| quartiles(samples[i].iter().map(f).collect()).1;
        let ratios: Vec<f64> = samples[i]
            .iter()
            .zip(&samples[0])
            .map(|(s, base)| s.ns / base.ns)
            .collect();
        let (lo, r, hi) = quartiles(ratios);
        println!(
            "| {name} | {:.0} | {r:.3} ({lo:.3}–{hi:.3}) | {:.0} | {:.0} | {:.3} | {:.0} | {:.4} |",
            med(|s| s.ns),
            med(|s| s.busy),
            med(|s| s.skew_us),
            med(|s| s.allocs),
            med(|s| s.bytes),
            med(|s| s.faults),
        );
    }
}
