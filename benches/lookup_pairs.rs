//! Lookup cost of each scheme against TRA's, measured in pairs inside one process (issue "Lookups
//! at the memory floor", point 3: `lookup/wf` within 2% of `lookup/tra`).
//!
//! Criterion measures one benchmark after another, seconds apart; on a shared machine the speed of
//! memory drifts by more than the 2% this comparison needs (`lookup/tra` alone ranged 570–930 ns
//! in three consecutive runs here). So this bench builds every cache once, pre-filled alike, and
//! then times one pass over the 16 384 `cache_ops` queries on TRA and on the other scheme in turn,
//! ABBA (TRA, X, X, TRA) so that a steady drift cancels, `ROUNDS` times. Each round gives a ratio
//! X / TRA of two passes made within milliseconds of each other; the median over the rounds is the
//! figure, with its quartiles. `-- --test` runs a few rounds, for CI.
//!
//! Run: `cargo bench --no-default-features --bench lookup_pairs [-- SCHEME...]`.

mod common;

use common::*;
use std::hint::black_box;
use std::time::{Duration, Instant};
use wfic::cache::{
    CacheHandle, IrradianceCache, LocalWrite, Locked, MutexFlavour, RwLockFlavour, Sequential,
    WaitFree,
};

/// Rounds per scheme (each: four passes of 16 384 lookups).
const ROUNDS: usize = 101;

/// One timed pass of every query through a fresh handle of `cache`.
fn pass<C: IrradianceCache>(cache: &mut C, w: &Workload) -> Duration {
    let frame = cache.frame();
    let mut h = frame.handle();
    let start = Instant::now();
    for &(p, n) in &w.queries {
        black_box(h.lookup(black_box(p), black_box(n)));
    }
    let t = start.elapsed();
    drop(h);
    frame.close();
    t
}

fn quartiles(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(|a, b| a.total_cmp(b));
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.25), at(0.5), at(0.75))
}

/// Times `other` against `tra` in ABBA rounds; prints and returns the median ratio.
fn pair<C: IrradianceCache>(name: &str, tra: &mut Sequential, other: &mut C, rounds: usize) -> f64 {
    let w = workload();
    // One untimed pass each: caches, branch predictors and page tables warm.
    pass(tra, w);
    pass(other, w);
    let (mut ratios, mut t_tra, mut t_other) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..rounds {
        let a1 = pass(tra, w);
        let b1 = pass(other, w);
        let b2 = pass(other, w);
        let a2 = pass(tra, w);
        let (a, b) = ((a1 + a2).as_secs_f64(), (b1 + b2).as_secs_f64());
        ratios.push(b / a);
        let per = |t: f64| t / (2 * w.queries.len()) as f64 * 1e9;
        t_tra.push(per(a));
        t_other.push(per(b));
    }
    let (lo, median, hi) = quartiles(ratios);
    let (_, tra_ns, _) = quartiles(t_tra);
    let (_, other_ns, _) = quartiles(t_other);
    println!("| {name} | {other_ns:.0} | {tra_ns:.0} | {median:.3} | {lo:.3}–{hi:.3} |");
    median
}

fn main() {
    // `cargo bench` passes `--bench`; `-- --test` asks for a short run.
    let args: Vec<String> = std::env::args().skip(1).collect();
    let test = args.iter().any(|a| a == "--test");
    // Scheme names given on the command line select the pairs to run (all by default).
    let names: Vec<&str> = args
        .iter()
        .map(String::as_str)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let wanted = |name: &str| names.is_empty() || names.contains(&name);
    let rounds = if test { 3 } else { ROUNDS };
    let w = workload();
    let mut tra = prefilled(Sequential::new(w.config), &w.prefill);
    let mut mutex = prefilled(Locked::<MutexFlavour>::new(w.config), &w.prefill);
    let mut rwlock = prefilled(Locked::<RwLockFlavour>::new(w.config), &w.prefill);
    let mut lw = prefilled(LocalWrite::new(w.config), &w.prefill);
    let mut wf = prefilled(WaitFree::adopt(w.config), &w.prefill);
    println!(
        "Lookups on the cache_ops workload, {rounds} ABBA rounds of {} queries per scheme, one \
         thread; ns per lookup are medians over the rounds.\n",
        w.queries.len()
    );
    println!("| scheme | ns per lookup | TRA's, same rounds | scheme / TRA (median) | quartiles |");
    println!("|---|---:|---:|---:|---|");
    if wanted("lck-mutex") {
        pair("lck-mutex", &mut tra, &mut mutex, rounds);
    }
    if wanted("lck-rwlock") {
        pair("lck-rwlock", &mut tra, &mut rwlock, rounds);
    }
    if wanted("lw") {
        pair("lw", &mut tra, &mut lw, rounds);
    }
    if wanted("wf") {
        pair("wf", &mut tra, &mut wf, rounds);
    }
}
