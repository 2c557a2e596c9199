//! Deterministic frames as a property (real threads): for random workloads (the synthetic room's
//! shading points, a seed), random tile orders and random thread counts, the answers every tile
//! got and the record set (ids included) are those of the same frames run tile by tile in order
//! on one thread, for WF, LCK and TRA. `src/cache/deterministic.rs` has the fixed-order unit
//! tests and the negative controls; `verify/loom_deterministic.rs` and
//! `verify/shuttle_deterministic.rs` the model-checked ones.
#![cfg(not(checker))]

use proptest::prelude::*;
use wfic::cache::{CacheHandle, CacheJob, IrradianceCache, Scheme, TileHandle};
use wfic::ic::WorkerId;
use wfic::research::workload::Room;
use wfic::rng::Rng;

const ROOM: Room = Room { size: 4.0 };

/// What a run gives: every tile's answers, then the records as `(id, bits)` in id order.
type Outcome = (Vec<Vec<u32>>, Vec<(u64, [u32; 4])>);

/// Two frames of `tiles` tiles of `points` shading points each from `seed`'s room, each tile a
/// lookup a point and a record on a miss; run in `order` on one thread, or (`threads` > 0) by
/// `Frame::run_tiles` on that many threads.
struct Frames {
    seed: u64,
    tiles: usize,
    points: usize,
    order: Vec<usize>,
    threads: usize,
}

fn shade<H: CacheHandle>(h: &mut H, seed: u64, frame: u64, tile: usize, points: usize) -> Vec<u32> {
    (0..points)
        .map(|i| {
            let mut rng = Rng::new(seed ^ (frame << 40) ^ ((tile * points + i) as u64));
            let (p, n) = ROOM.surface_point(&mut rng);
            match h.lookup(p, n) {
                Some(hit) => hit.irradiance.x.to_bits(),
                None => {
                    let r = ROOM.record(&mut rng, p, n);
                    h.insert(r).expect("a room record");
                    !r.irradiance.x.to_bits()
                }
            }
        })
        .collect()
}

impl CacheJob for &Frames {
    type Output = Outcome;
    fn run<C: IrradianceCache>(self, mut cache: C) -> Outcome {
        let mut seen = Vec::new();
        for frame in 0..2 {
            let f = cache.frame();
            let work = |h: &mut TileHandle<C::Handle<'_>>, t: usize| {
                shade(h, self.seed, frame, t, self.points)
            };
            if self.threads > 0 {
                seen.extend(f.run_tiles(self.threads, self.tiles, work));
            } else {
                let mut out = vec![Vec::new(); self.tiles];
                for &t in &self.order {
                    let h = f.handle_for(WorkerId::new(t as u32));
                    out[t] = work(&mut TileHandle::new(h), t);
                }
                seen.extend(out);
            }
            f.close();
        }
        let mut records: Vec<(u64, [u32; 4])> = (cache.snapshot().iter())
            .map(|r| {
                let p = r.position.to_array().map(f32::to_bits);
                (r.id().get(), [p[0], p[1], p[2], r.irradiance.x.to_bits()])
            })
            .collect();
        records.sort_unstable();
        (seen, records)
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn any_tile_order_and_thread_count_gives_the_in_order_frames(
        seed in any::<u64>(),
        tiles in 2usize..40,
        points in 1usize..12,
        shuffle in any::<u64>(),
        threads in 1usize..9,
        accuracy in 0.3f32..1.2,
    ) {
        let in_order: Vec<usize> = (0..tiles).collect();
        let mut order = in_order.clone();
        let mut rng = Rng::new(shuffle);
        for i in (1..tiles).rev() {
            order.swap(i, rng.below(i as u64 + 1) as usize);
        }
        let run = |order: &[usize], threads| Frames {
            seed, tiles, points, order: order.to_vec(), threads,
        };
        for scheme in [Scheme::Wf, Scheme::Lck, Scheme::Tra] {
            let reference = scheme.build(ROOM.config(accuracy), &run(&in_order, 0));
            prop_assert!(!reference.1.is_empty());
            let shuffled = scheme.build(ROOM.config(accuracy), &run(&order, 0));
            prop_assert!(shuffled == reference, "{} in order {:?}", scheme, order);
            let threaded = scheme.build(ROOM.config(accuracy), &run(&in_order, threads));
            prop_assert!(threaded == reference, "{} at {} threads", scheme, threads);
        }
    }
}
