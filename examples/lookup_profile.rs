//! Runs the `cache_ops` workload's lookups on one scheme, for a profiler or a cache simulator:
//! `cargo run --release --no-default-features --example lookup_profile -- SCHEME PASSES`.
//! With `PASSES = 0` it only builds the cache, so the difference between two runs under
//! `valgrind --tool=cachegrind` is what the lookups alone cost (`verify/lookup_lines.sh`).

#[path = "../benches/common/mod.rs"]
mod common;

use common::*;
use std::hint::black_box;
use wfic::cache::{CacheConfig, CacheHandle, IrradianceCache, Sequential, WaitFree};

fn run<C: IrradianceCache>(make: fn(CacheConfig) -> C, passes: usize) {
    let w = workload();
    let mut cache = prefilled(make(w.config), &w.prefill);
    let frame = cache.frame();
    let mut h = frame.handle();
    for _ in 0..passes {
        for &(p, n) in &w.queries {
            black_box(h.lookup(black_box(p), black_box(n)));
        }
    }
    let s = *h.stats();
    drop(h);
    frame.close();
    println!(
        "{} lookups, {} nodes, {} records examined",
        s.lookups, s.lookup_nodes, s.lookup_records
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: lookup_profile tra|wf PASSES";
    let scheme = args.get(1).expect(usage);
    let passes: usize = args.get(2).expect(usage).parse().expect(usage);
    match scheme.as_str() {
        "tra" => run(Sequential::new, passes),
        "wf" => run(WaitFree::adopt, passes),
        other => panic!("unknown scheme {other}: {usage}"),
    }
}
