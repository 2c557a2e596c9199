//! Deterministic frames under shuttle (`cargo test --features shuttle`): a tiny synthetic render
//! (shading points on a patch of `wfic::research::workload`'s room's floor, in tiles, a lookup
//! each, the room's record on a miss, the framebuffer the values found) over two frames, on WF, LCK and TRA, at 2 to 4
//! threads, under thousands of random and PCT schedules; every schedule must give the
//! framebuffer hash and the record set of the same render run tile by tile on one thread. The
//! renderer itself is not built under the model checkers (its crate compiles to nothing there),
//! so the scene is the core's own synthetic one. The negative control renders with plain
//! lookups and must fail with the same check's message.
#![cfg(feature = "shuttle")]

mod shuttle_common;

use glam::Vec3;
use shuttle_common::{explore_all, Sched};
use wfic::cache::{
    CacheHandle, IrradianceCache, Locked, MutexFlavour, Sequential, TileHandle, WaitFree,
};
use wfic::ic::WorkerId;
use wfic::research::workload::Room;
use wfic::rng::Rng;
use wfic::sync::{thread, Arc, AtomicUsize, Ordering};

const TILES: usize = 8;
const POINTS_PER_TILE: usize = 6;
const ROOM: Room = Room { size: 4.0 };
/// Coarse: the records are large, so neighbouring tiles' points fall in each other's records.
const ACCURACY: f32 = 0.8;

/// Shades tile `tile` of `frame` through `handle`: each point's value, a lookup's answer or the
/// record a miss computes from the point's own stream.
fn shade_tile<H: CacheHandle>(handle: &mut H, frame: u64, tile: usize) -> Vec<u32> {
    (0..POINTS_PER_TILE)
        .map(|i| {
            let point = (tile * POINTS_PER_TILE + i) as u64;
            let mut rng = Rng::new(0x5eed ^ (frame << 32) ^ point);
            // A patch of the floor, so that tiles' records overlap.
            let (u, v) = (rng.range(1.0, 3.0), rng.range(1.0, 3.0));
            let (p, n) = (Vec3::new(u, 0.0, v), Vec3::Y);
            let value = match handle.lookup(p, n) {
                Some(hit) => hit.irradiance,
                None => {
                    let record = ROOM.record(&mut rng, p, n);
                    handle.insert(record).expect("a room record");
                    record.irradiance
                }
            };
            value.x.to_bits()
                ^ value.y.to_bits().rotate_left(11)
                ^ value.z.to_bits().rotate_left(22)
        })
        .collect()
}

/// FNV-1a over words.
fn hash(words: impl IntoIterator<Item = u64>) -> u64 {
    words.into_iter().fold(0xcbf2_9ce4_8422_2325, |h, w| {
        (h ^ w).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Two frames of the render on `threads` threads (0: tile by tile on this thread), through tile
/// handles (`plain`: their inner handles, the negative control); the framebuffer's hash and the
/// record set's (ids, positions, irradiances).
fn render<C: IrradianceCache + 'static>(mut cache: C, threads: usize, plain: bool) -> (u64, u64) {
    let mut pixels = vec![0u32; TILES * POINTS_PER_TILE * 2];
    for frame in 0..2u64 {
        let shared = Arc::new(cache);
        let next = Arc::new(AtomicUsize::new(0));
        let work = {
            let (cache, next) = (shared.clone(), next.clone());
            move || {
                let mut done = Vec::new();
                loop {
                    // Relaxed: the counter only hands out distinct tiles.
                    let tile = next.fetch_add(1, Ordering::Relaxed);
                    if tile >= TILES {
                        return done;
                    }
                    let inner = cache.handle(WorkerId::new(tile as u32));
                    let values = if plain {
                        let mut inner = inner;
                        shade_tile(&mut inner, frame, tile)
                    } else {
                        shade_tile(&mut TileHandle::new(inner), frame, tile)
                    };
                    done.push((tile, values));
                }
            }
        };
        let done: Vec<(usize, Vec<u32>)> = if threads == 0 {
            work()
        } else {
            let workers: Vec<_> = (0..threads).map(|_| thread::spawn(work.clone())).collect();
            workers
                .into_iter()
                .flat_map(|w| w.join().unwrap())
                .collect()
        };
        drop(work);
        for (tile, values) in done {
            let at = (frame as usize * TILES + tile) * POINTS_PER_TILE;
            pixels[at..at + POINTS_PER_TILE].copy_from_slice(&values);
        }
        cache = Arc::try_unwrap(shared).ok().expect("the workers are done");
        cache.end_frame();
    }
    let mut records = cache.snapshot();
    records.sort_unstable_by_key(|r| r.id());
    let record_words = records.iter().flat_map(|r| {
        let [x, y, z] = r.position.to_array().map(f32::to_bits);
        let [e, f, g] = r.irradiance.to_array().map(f32::to_bits);
        [
            r.id().get(),
            u64::from(x) << 32 | u64::from(y),
            u64::from(z) << 32 | u64::from(e),
            u64::from(f) << 32 | u64::from(g),
        ]
    });
    (hash(pixels.into_iter().map(u64::from)), hash(record_words))
}

/// The render on `threads` threads against the same render tile by tile on one thread.
fn same_as_one_thread<C: IrradianceCache + 'static>(make: fn() -> C, threads: usize, plain: bool) {
    let one = render(make(), 0, plain);
    let many = render(make(), threads, plain);
    assert!(
        one == many,
        "the framebuffer or the records depend on the schedule: {one:x?} alone, {many:x?} at {threads} threads"
    );
}

fn wf() -> WaitFree {
    WaitFree::adopt(ROOM.config(ACCURACY))
}

fn lck() -> Locked<MutexFlavour> {
    Locked::new(ROOM.config(ACCURACY))
}

fn tra() -> Sequential {
    Sequential::new(ROOM.config(ACCURACY))
}

const SEEDS: [u64; 2] = [0x5eed_0002, 0xde7e_2026];

#[test]
fn shuttle_deterministic_wf_random() {
    for threads in [2, 3, 4] {
        explore_all(
            "shuttle_deterministic_wf_random",
            &format!("{threads} threads, {TILES} tiles x {POINTS_PER_TILE} points, 2 frames"),
            Sched::Random,
            &SEEDS,
            1000,
            move || same_as_one_thread(wf, threads, false),
        );
    }
}

#[test]
fn shuttle_deterministic_wf_pct() {
    for threads in [2, 4] {
        explore_all(
            "shuttle_deterministic_wf_pct",
            &format!("{threads} threads, {TILES} tiles x {POINTS_PER_TILE} points, 2 frames"),
            Sched::Pct(3),
            &SEEDS,
            1000,
            move || same_as_one_thread(wf, threads, false),
        );
    }
}

#[test]
fn shuttle_deterministic_lck_and_tra_random() {
    explore_all(
        "shuttle_deterministic_lck_random",
        "3 threads",
        Sched::Random,
        &SEEDS,
        500,
        || same_as_one_thread(lck, 3, false),
    );
    explore_all(
        "shuttle_deterministic_tra_random",
        "2 threads",
        Sched::Random,
        &SEEDS,
        300,
        || same_as_one_thread(tra, 2, false),
    );
}

/// The negative control: with plain lookups a tile uses its neighbours' records whenever the
/// schedule has inserted them, and shuttle finds a schedule whose render differs.
#[test]
fn plain_lookups_fail_the_same_check() {
    let _alone = shuttle_common::exclusive();
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let outcome = std::panic::catch_unwind(|| {
        shuttle_common::explore(
            "demo_plain_lookups_depend_on_the_schedule",
            "2 threads, plain lookups",
            Sched::Random,
            7,
            1000,
            || same_as_one_thread(wf, 2, true),
        )
    });
    std::panic::set_hook(hook);
    assert!(
        outcome.is_err(),
        "shuttle found no schedule where plain lookups differ"
    );
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("target/shuttle-failures/demo_plain_lookups_depend_on_the_schedule-random-7.txt");
    let saved = shuttle_common::load_failure(&path);
    assert!(
        saved.message.contains("depend on the schedule"),
        "{}",
        saved.message
    );
}
