//! The ordering ablation (paper §3.3: "memory barriers only on the write path"): the wait-free
//! cache with its minimal sound orderings ([`Minimal`]) against `SeqCst` at every atomic site
//! ([`SeqCstEverywhere`]) and against a `SeqCst` fence at the start of every lookup
//! ([`ReadFence`], the read-path barrier the paper avoided). Same code, same workload as
//! `benches/cache_ops.rs` (`benches/common`): only the orderings differ.
//!
//! Groups, each with `minimal`, `seqcst`, `read-fence` and two controls: `minimal-copy`
//! ([`MinimalControl`]: the same orderings under another type, so a second copy of the same
//! machine code at another address; it measures what code placement alone does) and
//! `minimal-again` (`minimal` measured again after the others: the noise floor of one position):
//!
//! * `orderings/lookup-1t/*` — one thread, one lookup per iteration in the pre-filled cache.
//! * `orderings/insert-1t/*` — one thread, one insert per iteration, batches of
//!   [`INSERT_BATCH`] fresh records, each batch into a freshly pre-filled cache.
//! * `orderings/lookup-2t/*` — two threads looking up concurrently in one pre-filled cache (time
//!   per lookup of the pair: wall time over both threads' lookups).
//! * `orderings/insert-2t/*` — two threads inserting concurrently into a freshly pre-filled cache,
//!   each its own half of a batch of [`INSERT_BATCH_2T`] (time per insert of the pair).
//!
//! Two-thread frames run on two worker threads that live for the whole benchmark function
//! (`Pair`), are released together by a [`YieldBarrier`], and are timed from the first worker's
//! start to the last worker's end, each worker reading the clock itself. An insert frame is
//! [`INSERT_BATCH_2T`] records (a few ms per worker).
//!
//! Why so: the first version spawned two threads per 1 024-record frame (~75 µs per worker), and two
//! runs of the same insert code differed by up to 2x (fresh threads' first allocations, wake-ups
//! as long as the work). Spinning start lines were worse on this 2-vCPU virtual machine: whenever
//! both workers landed on one core, a spinner burnt the time slice its partner needed
//! (3x outliers). A sleeping `std::sync::Barrier` was worse again once measured
//! (`benches/insert_split.rs`): the early worker's wake-up put a median 0.56–2.3 ms between the two
//! workers' starts, a fifth or more of an insert frame, counted in its wall time. The yielding
//! start line neither sleeps nor burns a shared core. After the groups, the bench prints each
//! policy's median over `minimal`'s, read from criterion's `estimates.json`.

mod common;

use common::*;
use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput};
use std::hint::black_box;
use std::path::PathBuf;
use std::sync::{mpsc, Arc};
use std::thread;
use std::time::{Duration, Instant};
use wfic::cache::wf::{Minimal, Orderings};
use wfic::cache::{CacheHandle, CasFailure, IrradianceCache, WaitFree, WfHandle};
use wfic::ic::Record;
use wfic::ic::WorkerId;
use wfic::research::orderings::{MinimalControl, ReadFence, SeqCstEverywhere};

const GROUPS: [&str; 4] = ["lookup-1t", "insert-1t", "lookup-2t", "insert-2t"];
const POLICIES: [&str; 5] = [
    "minimal",
    "seqcst",
    "read-fence",
    "minimal-copy",
    "minimal-again",
];

fn make<O: Orderings>() -> WaitFree<O> {
    WaitFree::new(workload().config, CasFailure::Adopt)
}

fn lookup_1t<O: Orderings>(g: &mut BenchmarkGroup<'_, WallTime>, id: &str) {
    bench_lookup(g, id, |c| WaitFree::<O>::new(c, CasFailure::Adopt));
}

fn insert_1t<O: Orderings>(g: &mut BenchmarkGroup<'_, WallTime>, id: &str) {
    bench_insert(g, id, |c| WaitFree::<O>::new(c, CasFailure::Adopt));
}

/// What a worker does in one frame: `work(worker, handle)` on the shared cache.
type Work<O> = Arc<dyn Fn(usize, &mut WfHandle<'_, O>) + Send + Sync>;
/// A worker's frame: when it started and ended.
type Done = (Instant, Instant);
/// What a worker runs in `Pair::run`: its number and the start line, to its start and end times.
type Job = Arc<dyn Fn(usize, &YieldBarrier) -> Done + Send + Sync>;

/// Two worker threads that live for a whole benchmark function, so every timed frame runs on
/// warm threads (their allocator caches and arenas included). Spawning fresh threads for every
/// frame made two runs of identical insert code differ by up to 2x: a new thread's first
/// allocations are not the steady state the cache meets in a renderer.
struct Pair<O: Orderings> {
    jobs: [mpsc::Sender<Box<dyn FnOnce() -> Done + Send>>; 2],
    done: mpsc::Receiver<Done>,
    threads: Vec<thread::JoinHandle<()>>,
    _policy: std::marker::PhantomData<O>,
}

impl<O: Orderings> Pair<O> {
    fn new() -> Self {
        let (done_tx, done) = mpsc::channel();
        let mut threads = Vec::new();
        let jobs = [0, 1].map(|_| {
            let (tx, rx) = mpsc::channel::<Box<dyn FnOnce() -> Done + Send>>();
            let done_tx = done_tx.clone();
            threads.push(thread::spawn(move || {
                for job in rx {
                    if done_tx.send(job()).is_err() {
                        break;
                    }
                }
            }));
            tx
        });
        Self {
            jobs,
            done,
            threads,
            _policy: std::marker::PhantomData,
        }
    }

    /// One frame: both workers take a handle, pass a [`YieldBarrier`] together and run `work`;
    /// returns the time from the first start to the last end. `end_frame` is not timed (WF's is
    /// a sum of counters).
    ///
    /// The workers outlive the frame, so this uses the low-level protocol (`handle`, then
    /// `end_frame` once both handles are dropped), which `Frame` cannot express for threads
    /// started before the frame; the cache's ledger still checks it.
    fn frame(&self, cache: &mut Arc<WaitFree<O>>, work: &Work<O>) -> Duration {
        let shared = Arc::clone(cache);
        let work = Arc::clone(work);
        let elapsed = self.run(Arc::new(move |k, start_line: &YieldBarrier| {
            let mut h = shared.handle(WorkerId::new(k as u32));
            start_line.wait();
            let start = Instant::now();
            work(k, &mut h);
            let end = Instant::now();
            // Dropped before the result is sent: the handle's counters are in the cache when
            // `frame` calls `end_frame`.
            drop(h);
            (start, end)
        }));
        // The jobs (and their clones of the cache) are gone once their results arrived.
        Arc::get_mut(cache)
            .expect("no worker holds the cache between frames")
            .end_frame();
        elapsed
    }

    /// Runs `job(worker, start_line)` on both workers; each job waits on the start line once its
    /// set-up is done and returns when it started and ended. Returns the time from the first start
    /// to the last end.
    fn run(&self, job: Job) -> Duration {
        let start_line = Arc::new(YieldBarrier::new(2));
        for (k, jobs) in self.jobs.iter().enumerate() {
            let (job, start_line) = (Arc::clone(&job), Arc::clone(&start_line));
            jobs.send(Box::new(move || job(k, &start_line)))
                .expect("bench worker alive");
        }
        let results = [0, 1].map(|_| self.done.recv().expect("bench worker alive"));
        let start = results.iter().map(|r| r.0).min().unwrap();
        let end = results.iter().map(|r| r.1).max().unwrap();
        end - start
    }
}

impl<O: Orderings> Drop for Pair<O> {
    fn drop(&mut self) {
        // Closing the job channels ends the workers' loops.
        let (a, _) = mpsc::channel();
        let (b, _) = mpsc::channel();
        drop(std::mem::replace(&mut self.jobs, [a, b]));
        for t in self.threads.drain(..) {
            t.join().expect("bench worker panicked");
        }
    }
}

fn lookup_2t<O: Orderings>(g: &mut BenchmarkGroup<'_, WallTime>, id: &str) {
    let w = workload();
    let mut cache = Arc::new(prefilled(make::<O>(), &w.prefill));
    let pair = Pair::<O>::new();
    g.bench_function(id, |b| {
        b.iter_custom(|iters| {
            let counts = [iters - iters / 2, iters / 2];
            let work: Work<O> = Arc::new(move |k, h| {
                // The two workers start at opposite ends of the query list.
                let mut i = k * w.queries.len() / 2;
                for _ in 0..counts[k] {
                    let (p, n) = w.queries[i];
                    black_box(h.lookup(black_box(p), black_box(n)));
                    i += 1;
                    if i == w.queries.len() {
                        i = 0;
                    }
                }
            });
            pair.frame(&mut cache, &work)
        })
    });
}

fn insert_2t<O: Orderings>(g: &mut BenchmarkGroup<'_, WallTime>, id: &str) {
    let w = workload();
    let batch: &'static [Record] = &w.fresh_2t[..INSERT_BATCH_2T];
    let pair = Pair::<O>::new();
    g.bench_function(id, |b| {
        b.iter_custom(|iters| {
            in_frames(iters, INSERT_BATCH_2T, |n| {
                let mut cache = Arc::new(prefilled(make::<O>(), &w.prefill));
                // Worker 0 inserts the first half of the batch, worker 1 the second.
                let halves = [&batch[..n - n / 2], &batch[n - n / 2..n]];
                let work: Work<O> = Arc::new(move |k, h| {
                    for r in halves[k] {
                        let _ = black_box(h.insert(black_box(*r)));
                    }
                });
                pair.frame(&mut cache, &work)
            })
        })
    });
}

fn group<'a>(c: &'a mut Criterion, name: &str) -> BenchmarkGroup<'a, WallTime> {
    let mut g = c.benchmark_group(format!("orderings/{name}"));
    configure(&mut g);
    g.throughput(Throughput::Elements(1));
    g
}

/// Each group runs `minimal`, `seqcst`, `read-fence`, `minimal-copy`, then `minimal` again
/// (`minimal-again`). The repeat shows how much two runs of the very same code differ (heap state,
/// frequency): the noise floor of the ratios. The copy shows what a second, identical copy of the
/// code at another address costs: the part of a ratio that is code placement, not ordering.
fn orderings(c: &mut Criterion) {
    let mut g = group(c, "lookup-1t");
    lookup_1t::<Minimal>(&mut g, "minimal");
    lookup_1t::<SeqCstEverywhere>(&mut g, "seqcst");
    lookup_1t::<ReadFence>(&mut g, "read-fence");
    lookup_1t::<MinimalControl>(&mut g, "minimal-copy");
    lookup_1t::<Minimal>(&mut g, "minimal-again");
    g.finish();
    let mut g = group(c, "insert-1t");
    insert_1t::<Minimal>(&mut g, "minimal");
    insert_1t::<SeqCstEverywhere>(&mut g, "seqcst");
    insert_1t::<ReadFence>(&mut g, "read-fence");
    insert_1t::<MinimalControl>(&mut g, "minimal-copy");
    insert_1t::<Minimal>(&mut g, "minimal-again");
    g.finish();
    let mut g = group(c, "lookup-2t");
    lookup_2t::<Minimal>(&mut g, "minimal");
    lookup_2t::<SeqCstEverywhere>(&mut g, "seqcst");
    lookup_2t::<ReadFence>(&mut g, "read-fence");
    lookup_2t::<MinimalControl>(&mut g, "minimal-copy");
    lookup_2t::<Minimal>(&mut g, "minimal-again");
    g.finish();
    let mut g = group(c, "insert-2t");
    insert_2t::<Minimal>(&mut g, "minimal");
    insert_2t::<SeqCstEverywhere>(&mut g, "seqcst");
    insert_2t::<ReadFence>(&mut g, "read-fence");
    insert_2t::<MinimalControl>(&mut g, "minimal-copy");
    insert_2t::<Minimal>(&mut g, "minimal-again");
    g.finish();
}

/// Criterion's output directory (it honours `CARGO_TARGET_DIR`, else `target` here).
fn criterion_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target"))
        .join("criterion")
}

/// The parts of a criterion `estimates.json` the ratios need.
#[derive(serde::Deserialize)]
struct Estimates {
    median: Estimate,
}

#[derive(serde::Deserialize)]
struct Estimate {
    point_estimate: f64,
}

/// The median point estimate (ns) in a criterion `estimates.json`.
fn median_ns(json: &str) -> Option<f64> {
    serde_json::from_str::<Estimates>(json)
        .ok()
        .map(|e| e.median.point_estimate)
}

/// Prints each policy's median over `minimal`'s, per group, from this run's estimates.
fn print_ratios() {
    let dir = criterion_dir();
    println!("\nordering ablation: median time per operation (ns), and ratio to `minimal`");
    println!(
        "{:<10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>11} {:>15} {:>17} {:>18}",
        "group",
        "minimal",
        "seqcst",
        "fence",
        "copy",
        "again",
        "seqcst/min",
        "read-fence/min",
        "minimal-copy/min",
        "minimal-again/min"
    );
    for group in GROUPS {
        // Criterion turns the '/' of a group name into '_' in its directory names.
        let ns: Vec<Option<f64>> = POLICIES
            .iter()
            .map(|p| {
                let path = dir
                    .join(format!("orderings_{group}"))
                    .join(p)
                    .join("new")
                    .join("estimates.json");
                std::fs::read_to_string(path)
                    .ok()
                    .and_then(|j| median_ns(&j))
            })
            .collect();
        let show = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:.1}"));
        let ratio = |v: Option<f64>| match (v, ns[0]) {
            (Some(v), Some(m)) if m > 0.0 => format!("{:.3}", v / m),
            _ => "-".to_owned(),
        };
        println!(
            "{:<10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>11} {:>15} {:>17} {:>18}",
            group,
            show(ns[0]),
            show(ns[1]),
            show(ns[2]),
            show(ns[3]),
            show(ns[4]),
            ratio(ns[1]),
            ratio(ns[2]),
            ratio(ns[3]),
            ratio(ns[4])
        );
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    orderings(&mut c);
    c.final_summary();
    print_ratios();
}
