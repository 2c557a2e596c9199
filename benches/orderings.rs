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
//!   each its own half of a batch (time per insert of the pair).
//!
//! Two-thread frames are timed from the barrier's release to the last worker's end, each worker
//! reading the clock itself (as `cache_ops`'s `mixed-2t`). After the groups, the bench prints each
//! policy's median over `minimal`'s, read from criterion's `estimates.json`.

mod common;

use common::*;
use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput};
use std::hint::black_box;
use std::path::PathBuf;
use std::sync::Barrier;
use std::thread;
use std::time::{Duration, Instant};
use wfic::cache::wf::{Minimal, MinimalControl, Orderings, ReadFence, SeqCstEverywhere};
use wfic::cache::{CacheHandle, CasFailure, IrradianceCache, WaitFree};
use wfic::ic::WorkerId;

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

/// Two workers released by a barrier, each running `work(worker, handle)`; returns the time from
/// the first release to the last end. `end_frame` is not timed (WF's is a sum of counters).
fn two_threads<O: Orderings>(
    cache: &mut WaitFree<O>,
    work: &(dyn Fn(usize, &mut wfic::cache::WfHandle<'_, O>) + Sync),
) -> Duration {
    let barrier = Barrier::new(2);
    let results = thread::scope(|s| {
        let (shared, barrier) = (&*cache, &barrier);
        let workers = [0usize, 1].map(|k| {
            s.spawn(move || {
                let mut h = shared.handle(WorkerId::new(k as u32));
                barrier.wait();
                let start = Instant::now();
                work(k, &mut h);
                let end = Instant::now();
                (h.finish(), start, end)
            })
        });
        workers.map(|t| t.join().expect("bench worker panicked"))
    });
    let start = results.iter().map(|r| r.1).min().unwrap();
    let end = results.iter().map(|r| r.2).max().unwrap();
    cache.end_frame(results.into_iter().map(|r| r.0).collect());
    end - start
}

fn lookup_2t<O: Orderings>(g: &mut BenchmarkGroup<'_, WallTime>, id: &str) {
    let w = workload();
    let mut cache = prefilled(make::<O>(), &w.prefill);
    g.bench_function(id, |b| {
        b.iter_custom(|iters| {
            let counts = [iters - iters / 2, iters / 2];
            two_threads(&mut cache, &|k, h| {
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
            })
        })
    });
}

fn insert_2t<O: Orderings>(g: &mut BenchmarkGroup<'_, WallTime>, id: &str) {
    let w = workload();
    let batch = &w.fresh[..INSERT_BATCH];
    g.bench_function(id, |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            let mut left = iters as usize;
            while left > 0 {
                let n = left.min(INSERT_BATCH);
                let mut cache = prefilled(make::<O>(), &w.prefill);
                // Worker 0 inserts the first half of the batch, worker 1 the second.
                let halves = [&batch[..n - n / 2], &batch[n - n / 2..n]];
                total += two_threads(&mut cache, &|k, h| {
                    for r in halves[k] {
                        let _ = black_box(h.insert(black_box(*r)));
                    }
                });
                left -= n;
            }
            total
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
