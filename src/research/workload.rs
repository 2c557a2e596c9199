//! A synthetic irradiance-cache workload: shading points on the walls of a room and on two boxes in
//! it, a smooth made-up irradiance field, and a frame loop that drives any cache the way a renderer
//! does (lookup; on a miss, "sample the hemisphere" and insert). The `demo` command and the
//! benchmarks use it; the real renderer is in `render`.
//!
//! The hemisphere sampling is replaced by a fixed amount of arithmetic per record
//! (`work_per_record`), so the balance between cache access and sample computation can be chosen.

use crate::cache::CacheConfig;
#[cfg(not(checker))]
use crate::cache::{CacheHandle, FrameReport, IrradianceCache};
use crate::ic::Record;
use crate::rng::Rng;
#[cfg(not(checker))]
use crate::sync::{AtomicUsize, Ordering};
use glam::Vec3;
#[cfg(not(checker))]
use std::time::{Duration, Instant};

/// A box-shaped room of edge `size` with two boxes standing on its floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Room {
    /// Edge length of the room.
    pub size: f32,
}

impl Room {
    /// The cache bounds for this room at accuracy `a`.
    pub fn config(&self, accuracy: f32) -> CacheConfig {
        CacheConfig::new(Vec3::ZERO, Vec3::splat(self.size), accuracy)
            .expect("a room has positive size")
    }

    /// A random shading point and its normal: on one of the six walls (facing in) or on the top or
    /// a side of one of the two boxes.
    pub fn surface_point(&self, rng: &mut Rng) -> (Vec3, Vec3) {
        let s = self.size;
        let (u, v) = (rng.range(0.0, s), rng.range(0.0, s));
        match (rng.next_u64() % 8) as u8 {
            0 => (Vec3::new(u, 0.0, v), Vec3::Y),
            1 => (Vec3::new(u, s, v), Vec3::NEG_Y),
            2 => (Vec3::new(0.0, u, v), Vec3::X),
            3 => (Vec3::new(s, u, v), Vec3::NEG_X),
            4 => (Vec3::new(u, v, 0.0), Vec3::Z),
            5 => (Vec3::new(u, v, s), Vec3::NEG_Z),
            // Box tops at a fifth and two fifths of the room's height.
            6 => (
                Vec3::new(0.2 * s + 0.2 * u, 0.2 * s, 0.2 * s + 0.2 * v),
                Vec3::Y,
            ),
            _ => (
                Vec3::new(0.6 * s + 0.2 * u, 0.4 * s, 0.6 * s + 0.2 * v),
                Vec3::Y,
            ),
        }
    }

    /// The made-up irradiance field: smooth, positive, varying over the room.
    pub fn irradiance(&self, p: Vec3, n: Vec3) -> Vec3 {
        let q = p / self.size;
        let base = Vec3::new(0.6 + 0.4 * q.x, 0.5 + 0.3 * q.y, 0.4 + 0.5 * q.z);
        base * (1.2 + 0.3 * n.y)
    }

    /// The record a miss at `p` computes, with a harmonic-mean distance drawn from the room's scale.
    pub fn record(&self, rng: &mut Rng, p: Vec3, n: Vec3) -> Record {
        let radius = self.size * rng.range(0.02, 0.12);
        let e = self.irradiance(p, n);
        let g = (e / self.size) * 0.4;
        Record::new(p, n, e, radius).with_gradients(
            [Vec3::X * g.x, Vec3::X * g.y, Vec3::X * g.z],
            [Vec3::ZERO, Vec3::ZERO, Vec3::ZERO],
        )
    }
}

/// Stands in for hemisphere sampling: `iterations` rounds of dependent arithmetic.
#[inline(never)]
pub fn busy_work(iterations: u32, seed: u64) -> u64 {
    let mut x = seed | 1;
    for _ in 0..iterations {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
    }
    x
}

/// One synthetic frame's parameters.
#[cfg(not(checker))]
#[derive(Clone, Copy, Debug)]
pub struct SyntheticFrame {
    /// The room.
    pub room: Room,
    /// Worker threads.
    pub threads: u32,
    /// Shading points in the frame (handed out in chunks to the workers).
    pub points: usize,
    /// Busy-work iterations per computed record (the cost of a miss).
    pub work_per_record: u32,
    /// Seed of the frame's shading points.
    pub seed: u64,
}

/// What one synthetic frame did.
#[cfg(not(checker))]
#[derive(Clone, Copy, Debug)]
pub struct SyntheticResult {
    /// Wall-clock time of the frame, merge included.
    pub wall: Duration,
    /// The cache's report.
    pub report: FrameReport,
}

/// Shading points per chunk handed to a worker.
#[cfg(not(checker))]
const CHUNK: usize = 256;

/// Runs one frame of `frame` on `cache` with `frame.threads` workers ([`crate::cache::Frame::run`]);
/// `progress` is called with the number of points finished so far (from worker threads).
#[cfg(not(checker))]
pub fn run_synthetic<C: IrradianceCache>(
    cache: &mut C,
    frame: &SyntheticFrame,
    progress: &(dyn Fn(usize) + Sync),
) -> SyntheticResult {
    let start = Instant::now();
    let next = AtomicUsize::new(0);
    let open = cache.frame();
    open.run(frame.threads as usize, |handle, _| {
        let mut sink = 0u64;
        loop {
            // Relaxed: the counter only hands out distinct chunks; no data is published through
            // it (each chunk's points are generated from its index).
            let chunk = next.fetch_add(1, Ordering::Relaxed);
            let first = chunk * CHUNK;
            if first >= frame.points {
                break;
            }
            let last = (first + CHUNK).min(frame.points);
            let mut rng = Rng::new(frame.seed ^ (chunk as u64).wrapping_mul(0x2545_f491_4f6c_dd1d));
            for _ in first..last {
                let (p, n) = frame.room.surface_point(&mut rng);
                if handle.lookup(p, n).is_none() {
                    sink ^= busy_work(frame.work_per_record, rng.next_u64());
                    let record = frame.room.record(&mut rng, p, n);
                    handle
                        .insert(record)
                        .expect("room records are valid and inside the bounds");
                }
            }
            progress(last);
        }
        std::hint::black_box(sink);
    });
    let report = open.close();
    SyntheticResult {
        wall: start.elapsed(),
        report,
    }
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;
    use crate::cache::{CasFailure, WaitFree};

    #[test]
    fn surface_points_lie_in_the_room_with_unit_normals() {
        let room = Room { size: 4.0 };
        let mut rng = Rng::new(1);
        for _ in 0..1000 {
            let (p, n) = room.surface_point(&mut rng);
            assert!(p.min_element() >= 0.0 && p.max_element() <= 4.0);
            assert!((n.length() - 1.0).abs() < 1e-6);
            assert_eq!(room.record(&mut rng, p, n).validate(), Ok(()));
        }
    }

    #[test]
    fn a_frame_fills_the_cache_and_a_second_reuses_it() {
        let room = Room { size: 4.0 };
        let mut cache =
            WaitFree::<crate::cache::wf::Minimal>::new(room.config(0.3), CasFailure::Adopt);
        let frame = SyntheticFrame {
            room,
            threads: 2,
            points: 20_000,
            work_per_record: 10,
            seed: 9,
        };
        let first = run_synthetic(&mut cache, &frame, &|_| {});
        assert_eq!(first.report.workers.lookups, 20_000);
        assert!(first.report.workers.stored > 100);
        assert!(first.report.workers.hits > first.report.workers.stored);
        let second = run_synthetic(&mut cache, &SyntheticFrame { seed: 10, ..frame }, &|_| {});
        assert!(second.report.workers.stored < first.report.workers.stored / 2);
    }
}
