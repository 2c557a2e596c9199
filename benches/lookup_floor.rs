//! Where a lookup's time goes, and the cost it cannot go below (issue "Lookups at the memory
//! floor", point 1), on the `cache_ops` workload (see `cache_ops.rs`).
//!
//! The octree is the plain one every lock-based scheme uses ([`Octree`]); WF's tree has the same
//! shape (same geometry, same nodes visited, same records examined), so the split of the work is
//! the same. Each entry runs the same 16 384 queries in the same order, one per iteration:
//!
//! * `floor/lookup-tra` — TRA's lookup through its handle: the figure being explained.
//! * `floor/walk` — the walk alone: every node whose loose cell holds the point is visited and
//!   its list read, but no record is touched (the visitor counts; since the lean read path, the
//!   walk still reads each key, as the visitor sees only records that pass `|_| true`).
//! * `floor/walk+read` — the walk, and each examined record's position, normal and radius read
//!   (summed, so the loads cannot be dropped).
//! * `floor/walk+test` — the walk, and Ward's validity test on each examined record.
//! * `floor/walk+interpolate` — the walk, the test and the weighted, extrapolated sum of the valid
//!   records: the lookup without the handle's bookkeeping.
//! * `floor/walk+prefilter` — the walk, each key tested by the query's prefilter, and only the
//!   records it admits read (position, normal, radius summed): what a lookup reads.
//! * `floor/walk+prefilter+interpolate` — the same, and the exact test and weighted sum on the
//!   admitted records: a lookup without its handle's bookkeeping.
//! * `floor/examined-contiguous` — the records each query examines, gathered beforehand into one
//!   contiguous array in query order, and put through the same accumulator: no walk, no pointer,
//!   every byte streamed. What the same arithmetic costs when memory is no obstacle.
//! * `floor/valid-contiguous` — the same with only the valid records (1.5 per query): the
//!   arithmetic any exact lookup must do. This is the floor.

mod common;

use common::*;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use std::hint::black_box;
use std::time::Instant;
use wfic::cache::{CacheHandle, IrradianceCache, Octree, Sequential};
use wfic::ic::{valid_weight, Accumulator, Prefilter, Record};

/// Each query's examined (or valid) records, back to back in query order.
struct Gathered {
    records: Vec<Record>,
    /// `ranges[i]..ranges[i + 1]` are query `i`'s records.
    ranges: Vec<usize>,
}

fn gather(tree: &Octree, w: &Workload, only_valid: bool) -> Gathered {
    let mut records = Vec::new();
    let mut ranges = vec![0];
    for &(p, n) in &w.queries {
        tree.visit(p, &mut |r| {
            if !only_valid || valid_weight(r, p, n, ACCURACY).is_some() {
                records.push(*r);
            }
        });
        ranges.push(records.len());
    }
    Gathered { records, ranges }
}

/// Runs `iters` queries, cycling, through `one(query index)`.
fn cycle(iters: u64, queries: usize, mut one: impl FnMut(usize)) -> std::time::Duration {
    let mut i = 0;
    let start = Instant::now();
    for _ in 0..iters {
        one(i);
        i += 1;
        if i == queries {
            i = 0;
        }
    }
    start.elapsed()
}

fn floor(c: &mut Criterion) {
    let w = workload();
    let mut tree = Octree::new(w.config);
    for r in &w.prefill {
        tree.insert(*r).expect("pre-fill record refused");
    }
    let examined = gather(&tree, w, false);
    let valid = gather(&tree, w, true);
    let q = w.queries.len();

    let mut g = c.benchmark_group("floor");
    configure(&mut g);
    g.throughput(Throughput::Elements(1));

    let mut cache = prefilled(Sequential::new(w.config), &w.prefill);
    g.bench_function("lookup-tra", |b| {
        b.iter_custom(|iters| {
            let frame = cache.frame();
            let mut h = frame.handle();
            let t = cycle(iters, q, |i| {
                let (p, n) = w.queries[i];
                black_box(h.lookup(black_box(p), black_box(n)));
            });
            drop(h);
            frame.close();
            t
        })
    });
    g.bench_function("walk", |b| {
        b.iter_custom(|iters| {
            cycle(iters, q, |i| {
                let (p, _) = w.queries[i];
                let mut seen = 0u32;
                black_box(tree.visit(black_box(p), &mut |_| seen += 1));
                black_box(seen);
            })
        })
    });
    g.bench_function("walk+read", |b| {
        b.iter_custom(|iters| {
            cycle(iters, q, |i| {
                let (p, _) = w.queries[i];
                let mut sum = Vec3::ZERO;
                tree.visit(black_box(p), &mut |r| {
                    sum += r.position + r.normal * r.radius;
                });
                black_box(sum);
            })
        })
    });
    g.bench_function("walk+test", |b| {
        b.iter_custom(|iters| {
            cycle(iters, q, |i| {
                let (p, n) = w.queries[i];
                let mut valid = 0u32;
                tree.visit(black_box(p), &mut |r| {
                    valid += u32::from(valid_weight(r, p, n, ACCURACY).is_some());
                });
                black_box(valid);
            })
        })
    });
    g.bench_function("walk+interpolate", |b| {
        b.iter_custom(|iters| {
            cycle(iters, q, |i| {
                let (p, n) = w.queries[i];
                let mut acc = Accumulator::new(black_box(p), n, ACCURACY, None);
                tree.visit(p, &mut |r| {
                    acc.add(r);
                });
                black_box(acc.finish());
            })
        })
    });
    g.bench_function("walk+prefilter", |b| {
        b.iter_custom(|iters| {
            cycle(iters, q, |i| {
                let (p, n) = w.queries[i];
                let pre = Prefilter::new(black_box(p), n, ACCURACY);
                let mut sum = Vec3::ZERO;
                tree.visit_admitted(&pre, &mut |r| {
                    sum += r.position + r.normal * r.radius;
                });
                black_box(sum);
            })
        })
    });
    g.bench_function("walk+prefilter+interpolate", |b| {
        b.iter_custom(|iters| {
            cycle(iters, q, |i| {
                let (p, n) = w.queries[i];
                let mut acc = Accumulator::new(black_box(p), n, ACCURACY, None);
                let pre = *acc.prefilter();
                tree.visit_admitted(&pre, &mut |r| {
                    acc.add(r);
                });
                black_box(acc.finish());
            })
        })
    });
    for (name, set) in [
        ("examined-contiguous", &examined),
        ("valid-contiguous", &valid),
    ] {
        g.bench_function(name, |b| {
            b.iter_custom(|iters| {
                cycle(iters, q, |i| {
                    let (p, n) = w.queries[i];
                    let mut acc = Accumulator::new(black_box(p), n, ACCURACY, None);
                    for r in &set.records[set.ranges[i]..set.ranges[i + 1]] {
                        acc.add(r);
                    }
                    black_box(acc.finish());
                })
            })
        });
    }
    g.finish();
}

criterion_group!(benches, floor);
criterion_main!(benches);
