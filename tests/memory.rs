//! Memory per record, checked: every caching scheme filled with 10^3 and 10^4 records of the
//! benches' workload, as `examples/memory` measures them (the same module, `measure.rs`), against
//! the committed page's figures (`results/memory/memory.csv`):
//!
//! - the attribution accounts for every byte (nodes, slots, keys, records, spare capacity,
//!   directories and the empty cache sum to the measured total, exactly);
//! - each scheme's bytes and blocks are within [`BOUND`] of what the page reports at that N.
//!
//! An extra allocation per insert fails both (its bytes are in no part of the split, and it adds
//! a block a record); a change to a layout or to the segments' growth fails the first until the
//! attribution and the page are brought up to date (`cargo run --release --example memory`).
//!
//! `#[global_allocator]` is per binary, hence this test binary of its own; no libtest harness
//! (`harness = false` in `Cargo.toml`), so nothing else allocates while a cache is measured.

#[cfg(checker)]
fn main() {
    println!("memory: real allocations only: nothing to run under loom or shuttle");
}

#[cfg(not(checker))]
fn main() {
    real::main();
}

#[cfg(not(checker))]
#[path = "../benches/common/mod.rs"]
mod common;
#[cfg(not(checker))]
#[path = "../examples/memory/measure.rs"]
mod measure;
#[cfg(not(checker))]
#[path = "../verify/tree_shape.rs"]
mod tree_shape;

#[cfg(not(checker))]
mod real {
    use super::common;
    use super::measure::*;
    use wfic::cache::Scheme;

    #[global_allocator]
    static ALLOCATOR: Counting = Counting;

    /// How far a scheme's bytes or blocks may stray from the page's figure at the same N, as a
    /// fraction of it.
    const BOUND: f64 = 0.01;

    /// The sizes checked (the page's first two).
    const SIZES: [usize; 2] = [1_000, 10_000];

    /// The seed `examples/memory` draws its records with.
    const SEED: u64 = 0x0422;

    /// The page's live bytes and blocks for `scheme` at `n`.
    fn page_figures(csv: &str, scheme: Scheme, n: usize) -> (u64, u64) {
        let row = csv
            .lines()
            .skip(1)
            .map(|line| line.split(',').collect::<Vec<_>>())
            .find(|f| f[0] == scheme.name() && f[1] == n.to_string())
            .unwrap_or_else(|| panic!("results/memory/memory.csv has no row for {scheme} at {n}"));
        (row[2].parse().unwrap(), row[3].parse().unwrap())
    }

    fn within(measured: u64, page: u64) -> bool {
        (measured as f64 - page as f64).abs() <= BOUND * page as f64
    }

    /// The counter counts: a box held shows as one block of its size.
    fn the_counter_sees_a_box() {
        let before = Live::now();
        let held = Box::new([7u8; 24]);
        let during = Live::now();
        assert_eq!(
            (during.blocks - before.blocks, during.bytes - before.bytes),
            (1, 24),
            "the counting allocator did not see a 24-byte box"
        );
        drop(held);
        assert_eq!(Live::now(), before, "a box and its free");
    }

    fn every_scheme_as_the_page_reports() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/results/memory/memory.csv");
        let csv = std::fs::read_to_string(path).expect("read results/memory/memory.csv");
        let config = common::scene_config();
        let fixed: Vec<(Scheme, u64)> = SCHEMES
            .iter()
            .map(|&s| (s, measure(s, config, &[]).live.bytes))
            .collect();
        for n in SIZES {
            let records = common::scene_records(n, SEED);
            let shape = shape(&config, &records);
            for (scheme, fixed) in &fixed {
                let m = measure(*scheme, config, &records);
                assert_eq!(
                    (m.stats.records, m.stats.nodes),
                    (n, shape.nodes()),
                    "{scheme} at {n}: records and nodes against the tree shape"
                );
                let split = attribute(*scheme, n as u64, &shape, *fixed);
                assert_eq!(
                    m.live.bytes,
                    split.total(),
                    "{scheme} at {n}: the measured bytes are not what the split adds up to \
                     ({split:?})"
                );
                let (bytes, blocks) = page_figures(&csv, *scheme, n);
                println!(
                    "memory: {scheme} at {n}: {} bytes in {} blocks (the page: {bytes} in \
                     {blocks}), split exact",
                    m.live.bytes, m.live.blocks
                );
                assert!(
                    within(m.live.bytes, bytes),
                    "{scheme} at {n}: {} bytes, the page reports {bytes} (bound {BOUND})",
                    m.live.bytes
                );
                assert!(
                    within(m.live.blocks, blocks),
                    "{scheme} at {n}: {} blocks, the page reports {blocks} (bound {BOUND})",
                    m.live.blocks
                );
            }
        }
    }

    pub fn main() {
        // Of libtest's arguments, `--list` and `--ignored` run nothing (this binary has no list
        // and no ignored check); the rest are ignored.
        if std::env::args().any(|a| a == "--list" || a == "--ignored") {
            return;
        }
        println!("memory: the_counter_sees_a_box ...");
        the_counter_sees_a_box();
        println!("memory: every_scheme_as_the_page_reports ...");
        every_scheme_as_the_page_reports();
        println!("memory: ok");
    }
}
