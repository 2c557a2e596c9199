//! The padding experiment (issue 9, point 5): does false sharing on a WF node's list head cost
//! anything? Every inserter into a node does a `fetch_add` on its list's `head`, which shares a
//! cache line with the segment table and with some of the node's child pointers, both read by every
//! lookup and by every insert that walks through the node.
//!
//! Same code, same workload as `cache_ops` and `orderings` (`benches/common`); only the layout of
//! the head differs, chosen by the (hidden) ordering-policy type:
//!
//! * `minimal` — [`Minimal`]: the head as shipped, a plain `AtomicUsize` next to the segment table.
//! * `padded` — [`MinimalPadded`]: the head in `crossbeam_utils::CachePadded` (128 bytes, aligned
//!   to 128 on x86_64, so the node is too).
//! * `spaced` — [`MinimalSpaced`]: the head between two 64-byte gaps: its own cache line without
//!   raising the node's alignment (nodes still come from plain `malloc`).
//! * `minimal-copy` ([`MinimalControl`]) and `padded-copy` ([`MinimalPaddedControl`]): the same
//!   layouts under a second type, i.e. a second copy of the code at another address; they show what
//!   code placement alone does (up to ~11% on inserts, `results/orderings/`).
//! * `minimal-again` — `minimal` measured once more: the noise floor of one run.
//!
//! Groups: `padding/lookup-1t`, `padding/insert-1t` (as `lookup/wf`, `insert/wf`),
//! `padding/mixed-2t` (as `mixed-2t/wf`: two workers, 99% lookups, 1% inserts, fresh scoped threads
//! per 20 000-operation frame) and `padding/insert-2t` (as `orderings/insert-2t/minimal`: two
//! persistent workers inserting 8 192 records into a freshly pre-filled cache).
//!
//! `PADDING_REVERSE=1` measures the variants of each group in the reverse order, so that a
//! position effect (frequency, heap state) can be told from a layout effect.
//!
//! `PADDING_ROUNDS=n` skips criterion and interleaves instead: for each group, `n` rounds, each
//! round one short block of every variant (in an order that rotates and reverses from round to
//! round), so slow drifts of the machine (neighbours, frequency) hit every variant alike. It prints
//! each variant's median time per operation and, per round, its ratio to `minimal` of the same
//! round: the median ratio and its quartiles. (On 2026-11-30 the criterion runs of the same
//! code differed by ±30% between positions, even on an idle machine.)

mod common;

use common::*;
use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput};
use std::hint::black_box;
use std::path::PathBuf;
use std::sync::{mpsc, Arc, Barrier};
use std::thread;
use std::time::{Duration, Instant};
use wfic::cache::wf::{
    Minimal, MinimalControl, MinimalPadded, MinimalPaddedControl, MinimalSpaced, Orderings,
};
use wfic::cache::{CacheHandle, CasFailure, IrradianceCache, WaitFree, WfHandle};
use wfic::ic::{Record, WorkerId};

const GROUPS: [&str; 4] = ["lookup-1t", "insert-1t", "mixed-2t", "insert-2t"];
const VARIANTS: [&str; 6] = [
    "minimal",
    "padded",
    "spaced",
    "minimal-copy",
    "padded-copy",
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

/// `mixed-2t/wf` of `cache_ops`: a frame of `FRAME_OPS` operations (99% lookups) on two scoped
/// threads ([`wfic::cache::Frame::run`]), each frame on a freshly pre-filled cache; timed from the
/// first worker's release to the last worker's end, plus closing the frame.
fn mixed_2t<O: Orderings>(g: &mut BenchmarkGroup<'_, WallTime>, id: &str) {
    let w = workload();
    g.bench_function(id, |b| {
        b.iter_custom(|iters| {
            in_frames(iters, FRAME_OPS, |ops| {
                let mut cache = prefilled(make::<O>(), &w.prefill);
                let counts = [ops - ops / 2, ops / 2];
                let barrier = Barrier::new(2);
                let frame = cache.frame();
                let times = frame.run(2, |h, worker| {
                    let k = worker.index() as usize;
                    barrier.wait();
                    let start = Instant::now();
                    for op in &w.mixed[k][..counts[k]] {
                        match *op {
                            Op::Lookup(i) => {
                                let (p, n) = w.queries[i as usize];
                                black_box(h.lookup(p, n));
                            }
                            Op::Insert(i) => {
                                let _ = black_box(h.insert(w.fresh[i as usize]));
                            }
                        }
                    }
                    (start, Instant::now())
                });
                let start = times.iter().map(|t| t.0).min().unwrap();
                let end = times.iter().map(|t| t.1).max().unwrap();
                let close = Instant::now();
                frame.close();
                (end - start) + close.elapsed()
            })
        })
    });
}

/// What a worker does in one frame: `work(worker, handle)` on the shared cache.
type Work<O> = Arc<dyn Fn(usize, &mut WfHandle<'_, O>) + Send + Sync>;
/// A worker's frame: when it started and ended.
type Done = (Instant, Instant);

/// Two worker threads that live for a whole benchmark function (as in `benches/orderings.rs`).
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

    /// One frame: both workers take a handle, pass a `Barrier` together and run `work`; returns
    /// the time from the first start to the last end.
    fn frame(&self, cache: &mut Arc<WaitFree<O>>, work: &Work<O>) -> Duration {
        let start_line = Arc::new(Barrier::new(2));
        for (k, jobs) in self.jobs.iter().enumerate() {
            let (cache, work, start_line) =
                (Arc::clone(cache), Arc::clone(work), Arc::clone(&start_line));
            let job = Box::new(move || {
                let mut h = cache.handle(WorkerId::new(k as u32));
                start_line.wait();
                let start = Instant::now();
                work(k, &mut h);
                let end = Instant::now();
                drop(h);
                (start, end)
            });
            jobs.send(job).expect("bench worker alive");
        }
        let results = [0, 1].map(|_| self.done.recv().expect("bench worker alive"));
        let start = results.iter().map(|r| r.0).min().unwrap();
        let end = results.iter().map(|r| r.1).max().unwrap();
        Arc::get_mut(cache)
            .expect("no worker holds the cache between frames")
            .end_frame();
        end - start
    }
}

impl<O: Orderings> Drop for Pair<O> {
    fn drop(&mut self) {
        let (a, _) = mpsc::channel();
        let (b, _) = mpsc::channel();
        drop(std::mem::replace(&mut self.jobs, [a, b]));
        for t in self.threads.drain(..) {
            t.join().expect("bench worker panicked");
        }
    }
}

/// `orderings/insert-2t` as in `benches/orderings.rs`.
fn insert_2t<O: Orderings>(g: &mut BenchmarkGroup<'_, WallTime>, id: &str) {
    let w = workload();
    let batch: &'static [Record] = &w.fresh_2t[..INSERT_BATCH_2T];
    let pair = Pair::<O>::new();
    g.bench_function(id, |b| {
        b.iter_custom(|iters| {
            in_frames(iters, INSERT_BATCH_2T, |n| {
                let mut cache = Arc::new(prefilled(make::<O>(), &w.prefill));
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

type Bench = fn(&mut BenchmarkGroup<'_, WallTime>, &str);

/// The six variants of one group, as (id, bench function), in `VARIANTS` order.
macro_rules! variants {
    ($f:ident) => {
        [
            ("minimal", $f::<Minimal> as Bench),
            ("padded", $f::<MinimalPadded> as Bench),
            ("spaced", $f::<MinimalSpaced> as Bench),
            ("minimal-copy", $f::<MinimalControl> as Bench),
            ("padded-copy", $f::<MinimalPaddedControl> as Bench),
            ("minimal-again", $f::<Minimal> as Bench),
        ]
    };
}

fn padding(c: &mut Criterion) {
    let reverse = std::env::var_os("PADDING_REVERSE").is_some_and(|v| v != "0");
    let groups: [(&str, [(&str, Bench); 6]); 4] = [
        ("lookup-1t", variants!(lookup_1t)),
        ("insert-1t", variants!(insert_1t)),
        ("mixed-2t", variants!(mixed_2t)),
        ("insert-2t", variants!(insert_2t)),
    ];
    for (name, mut variants) in groups {
        if reverse {
            variants.reverse();
        }
        let mut g = c.benchmark_group(format!("padding/{name}"));
        configure(&mut g);
        g.throughput(Throughput::Elements(1));
        for (id, bench) in variants {
            bench(&mut g, id);
        }
        g.finish();
    }
}

/// Node size, alignment, node count and tree bytes of a pre-filled cache and of one after an
/// `insert-2t` frame.
fn report_layout<O: Orderings>(name: &str) {
    let w = workload();
    let (size, align, [children, segments, head]) = WaitFree::<O>::node_layout();
    let mut cache = prefilled(make::<O>(), &w.prefill);
    let prefill_nodes = cache.stats().nodes;
    let cache = {
        let mut cache = cache;
        let frame = cache.frame();
        let mut h = frame.handle_for(WorkerId::new(0));
        for r in &w.fresh_2t {
            let _ = h.insert(*r);
        }
        drop(h);
        frame.close();
        cache
    };
    let mut cache = cache;
    let after_nodes = cache.stats().nodes;
    eprintln!(
        "{name:<8} node {size} B (align {align}; children at {children}, segment table at \
         {segments}, head at {head}); pre-filled cache {prefill_nodes} nodes = {} KiB \
         of nodes; after +{} inserts {after_nodes} nodes = {} KiB",
        prefill_nodes * size / 1024,
        w.fresh_2t.len(),
        after_nodes * size / 1024,
    );
}

fn criterion_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target"))
        .join("criterion")
}

/// The median point estimate (ns) in a criterion `estimates.json`.
fn median_ns(json: &str) -> Option<f64> {
    let at = json.find("\"median\"")?;
    let rest = &json[at..];
    let p = rest.find("\"point_estimate\":")? + "\"point_estimate\":".len();
    let num: String = rest[p..]
        .chars()
        .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '-' | '+'))
        .collect();
    num.parse().ok()
}

/// Each variant's median and its ratio to `minimal`, per group, from this run's estimates.
fn print_ratios() {
    let dir = criterion_dir();
    println!("\npadding: median time per operation (ns), ratio to `minimal`");
    print!("{:<10}", "group");
    for v in VARIANTS {
        print!(" {v:>13}");
    }
    println!();
    for group in GROUPS {
        let ns: Vec<Option<f64>> = VARIANTS
            .iter()
            .map(|v| {
                let path = dir
                    .join(format!("padding_{group}"))
                    .join(v)
                    .join("new")
                    .join("estimates.json");
                std::fs::read_to_string(path)
                    .ok()
                    .and_then(|j| median_ns(&j))
            })
            .collect();
        print!("{group:<10}");
        for v in &ns {
            print!(" {:>13}", v.map_or("-".to_owned(), |v| format!("{v:.1}")));
        }
        println!();
        print!("{:<10}", "  ratio");
        for v in &ns {
            let r = match (v, ns[0]) {
                (Some(v), Some(m)) if m > 0.0 => format!("{:.3}", v / m),
                _ => "-".to_owned(),
            };
            print!(" {r:>13}");
        }
        println!();
    }
}

/// One block of operations of a variant: returns the timed part and the operation count.
type Block<'a> = Box<dyn FnMut() -> (Duration, u64) + 'a>;

fn lookup_block<O: Orderings>() -> Block<'static> {
    let w = workload();
    let mut cache = prefilled(make::<O>(), &w.prefill);
    let mut i = 0;
    Box::new(move || {
        const OPS: usize = 16_384;
        let frame = cache.frame();
        let mut h = frame.handle();
        let start = Instant::now();
        for _ in 0..OPS {
            let (p, n) = w.queries[i];
            black_box(h.lookup(black_box(p), black_box(n)));
            i = (i + 1) % w.queries.len();
        }
        let elapsed = start.elapsed();
        drop(h);
        frame.close();
        (elapsed, OPS as u64)
    })
}

fn insert_block<O: Orderings>() -> Block<'static> {
    let w = workload();
    Box::new(move || {
        const BATCHES: usize = 8;
        let mut total = Duration::ZERO;
        for _ in 0..BATCHES {
            let mut cache = prefilled(make::<O>(), &w.prefill);
            let frame = cache.frame();
            let mut h = frame.handle();
            let start = Instant::now();
            for r in &w.fresh[..INSERT_BATCH] {
                let _ = black_box(h.insert(black_box(*r)));
            }
            total += start.elapsed();
        }
        (total, (BATCHES * INSERT_BATCH) as u64)
    })
}

fn mixed_block<O: Orderings>() -> Block<'static> {
    let w = workload();
    Box::new(move || {
        const FRAMES: usize = 3;
        let mut total = Duration::ZERO;
        for _ in 0..FRAMES {
            let mut cache = prefilled(make::<O>(), &w.prefill);
            let barrier = Barrier::new(2);
            let frame = cache.frame();
            let times = frame.run(2, |h, worker| {
                let k = worker.index() as usize;
                barrier.wait();
                let start = Instant::now();
                for op in &w.mixed[k] {
                    match *op {
                        Op::Lookup(i) => {
                            let (p, n) = w.queries[i as usize];
                            black_box(h.lookup(p, n));
                        }
                        Op::Insert(i) => {
                            let _ = black_box(h.insert(w.fresh[i as usize]));
                        }
                    }
                }
                (start, Instant::now())
            });
            let start = times.iter().map(|t| t.0).min().unwrap();
            let end = times.iter().map(|t| t.1).max().unwrap();
            let close = Instant::now();
            frame.close();
            total += (end - start) + close.elapsed();
        }
        let ops = w.mixed[0].len() + w.mixed[1].len();
        (total, (FRAMES * ops) as u64)
    })
}

fn insert_2t_block<O: Orderings>() -> Block<'static> {
    let w = workload();
    let batch: &'static [Record] = &w.fresh_2t[..INSERT_BATCH_2T];
    let pair = Pair::<O>::new();
    Box::new(move || {
        const FRAMES: usize = 2;
        let mut total = Duration::ZERO;
        for _ in 0..FRAMES {
            let mut cache = Arc::new(prefilled(make::<O>(), &w.prefill));
            let half = batch.len() / 2;
            let halves = [&batch[..half], &batch[half..]];
            let work: Work<O> = Arc::new(move |k, h| {
                for r in halves[k] {
                    let _ = black_box(h.insert(black_box(*r)));
                }
            });
            total += pair.frame(&mut cache, &work);
        }
        (total, (FRAMES * batch.len()) as u64)
    })
}

const INTERLEAVED: [&str; 5] = ["minimal", "padded", "spaced", "minimal-copy", "padded-copy"];

macro_rules! blocks {
    ($f:ident) => {
        vec![
            $f::<Minimal>(),
            $f::<MinimalPadded>(),
            $f::<MinimalSpaced>(),
            $f::<MinimalControl>(),
            $f::<MinimalPaddedControl>(),
        ]
    };
}

/// The `q`-quantile of sorted `v` (nearest rank).
fn quantile(v: &[f64], q: f64) -> f64 {
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn interleaved(rounds: usize) {
    let groups: [(&str, fn() -> Vec<Block<'static>>); 4] = [
        ("lookup-1t", || blocks!(lookup_block)),
        ("insert-1t", || blocks!(insert_block)),
        ("mixed-2t", || blocks!(mixed_block)),
        ("insert-2t", || blocks!(insert_2t_block)),
    ];
    println!("interleaved: {rounds} rounds per group, one block of every variant per round");
    for (name, make_blocks) in groups {
        let mut blocks = make_blocks();
        // One untimed warm-up block each.
        for b in &mut blocks {
            b();
        }
        let n = blocks.len();
        let mut ns = vec![Vec::with_capacity(rounds); n];
        for r in 0..rounds {
            let mut order: Vec<usize> = (0..n).map(|k| (k + r) % n).collect();
            if r % 2 == 1 {
                order.reverse();
            }
            let mut this = vec![0.0; n];
            for k in order {
                let (t, ops) = blocks[k]();
                this[k] = t.as_nanos() as f64 / ops as f64;
            }
            for k in 0..n {
                ns[k].push(this[k]);
            }
        }
        println!("padding/{name}: median ns/op [q1, q3]; per-round ratio to minimal: median [q1, q3] (min..max)");
        for k in 0..n {
            let mut t = ns[k].clone();
            t.sort_by(f64::total_cmp);
            let mut ratios: Vec<f64> = (0..rounds).map(|r| ns[k][r] / ns[0][r]).collect();
            ratios.sort_by(f64::total_cmp);
            println!(
                "  {:<13} {:>8.1} [{:>7.1}, {:>7.1}]   ratio {:.3} [{:.3}, {:.3}] ({:.3}..{:.3})",
                INTERLEAVED[k],
                quantile(&t, 0.5),
                quantile(&t, 0.25),
                quantile(&t, 0.75),
                quantile(&ratios, 0.5),
                quantile(&ratios, 0.25),
                quantile(&ratios, 0.75),
                ratios[0],
                ratios[rounds - 1],
            );
        }
    }
}

fn main() {
    report_layout::<Minimal>("minimal");
    report_layout::<MinimalPadded>("padded");
    report_layout::<MinimalSpaced>("spaced");
    if let Some(rounds) = std::env::var("PADDING_ROUNDS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .filter(|&r| r > 0)
    {
        interleaved(rounds);
        return;
    }
    let mut c = Criterion::default().configure_from_args();
    padding(&mut c);
    c.final_summary();
    print_ratios();
}
