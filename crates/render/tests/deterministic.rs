//! Deterministic frames (`RenderSettings::deterministic`): the image and the records, bit for
//! bit, at 1, 2, 3, 8 and 64 threads (64 oversubscribed on any machine this runs on: a check of
//! the schedule's freedom, not of speed), on scoped threads and on the rayon pool, with WF, LCK
//! and TRA, on every built-in scene, and over an animation that removes records between frames.

#![cfg(not(checker))]

use wfic::cache::{CacheConfig, CacheJob, IrradianceCache, Scheme};
use wfic::ic::Selection;
use wfic_render::parallel::render_frame_removing;
use wfic_render::{scenes, Camera, Pool, RenderSettings, Scene};

/// A small, cheap frame: what is compared is bits, not quality.
fn settings(pool: Pool, deterministic: bool) -> RenderSettings {
    let mut s = RenderSettings::new(40, 32)
        .accuracy(0.3)
        .rays_per_record(24)
        .light_samples(2)
        .pool(pool);
    s.tile_size = 8;
    s.deterministic = deterministic;
    s
}

/// What a run gives: each frame's image hash and records hash.
type Hashes = Vec<(String, Option<String>)>;

/// `frames` frames of the scene's orbit on a fresh cache, the frames after the first removing
/// the records older than one frame before they render.
struct Orbit<'a> {
    scene: &'a Scene,
    settings: RenderSettings,
    threads: usize,
    frames: usize,
}

impl CacheJob for Orbit<'_> {
    type Output = Hashes;
    fn run<C: IrradianceCache>(self, mut cache: C) -> Hashes {
        let stale = Selection::older_than(1);
        (0..self.frames)
            .map(|i| {
                let camera = Camera::orbit(self.scene, i as f32 / 8.0);
                let removal = (i > 0).then_some(&stale);
                let out = render_frame_removing(
                    self.scene,
                    &camera,
                    &self.settings,
                    &mut cache,
                    self.threads,
                    removal,
                );
                assert!(
                    out.stats.ic_samples > 0 || i > 0,
                    "the first frame computes records"
                );
                (out.stats.frame_hash, out.stats.records_hash)
            })
            .collect()
    }
}

fn run(scene: &Scene, scheme: Scheme, config: CacheConfig, run: (usize, Pool, bool)) -> Hashes {
    let (threads, pool, deterministic) = run;
    let job = Orbit {
        scene,
        settings: settings(pool, deterministic),
        threads,
        frames: 2,
    };
    scheme.build(config, job)
}

#[test]
fn every_scene_renders_the_same_bits_at_any_thread_count_and_pool() {
    for name in scenes::NAMES {
        let scene = scenes::load(name).expect("a built-in scene");
        let config = settings(Pool::Scoped, true)
            .cache_config(&scene)
            .expect("a cache over the scene");
        for scheme in [Scheme::Wf, Scheme::Lck, Scheme::Tra] {
            let first = run(&scene, scheme, config, (1, Pool::Scoped, true));
            assert!(first.iter().all(|(_, r)| r.is_some()), "records hashed");
            for (threads, pool) in [
                (2, Pool::Scoped),
                (3, Pool::Scoped),
                (8, Pool::Scoped),
                (64, Pool::Scoped),
                (2, Pool::Rayon),
                (8, Pool::Rayon),
            ] {
                let other = run(&scene, scheme, config, (threads, pool, true));
                assert_eq!(
                    first, other,
                    "{name} {scheme}: {threads} threads on {pool:?} differ from 1"
                );
            }
        }
    }
}

/// The negative control: the same comparison fails for ordinary frames, whose records depend on
/// the schedule (their ids name the worker, so at 1 and 2 threads they cannot agree), and so,
/// on most scenes, do the images.
#[test]
fn ordinary_frames_differ_between_thread_counts() {
    let mut images_differ = 0;
    for name in ["cornell", "sponza"] {
        let scene = scenes::load(name).expect("a built-in scene");
        let config = settings(Pool::Scoped, false).cache_config(&scene).unwrap();
        let one = run(&scene, Scheme::Wf, config, (1, Pool::Scoped, false));
        let two = run(&scene, Scheme::Wf, config, (2, Pool::Scoped, false));
        assert!(one.iter().all(|(_, r)| r.is_none()), "no record hash");
        images_differ += usize::from(one != two);
    }
    assert!(
        images_differ > 0,
        "ordinary frames at 1 and 2 threads gave the same images"
    );
}

#[test]
fn a_deterministic_frame_refuses_wf_discard_by_name() {
    let scene = scenes::cornell().unwrap();
    let config = settings(Pool::Scoped, true).cache_config(&scene).unwrap();
    let caught = std::panic::catch_unwind(|| {
        run(&scene, Scheme::WfDiscard, config, (1, Pool::Scoped, true))
    });
    let message = caught.expect_err("refused");
    let message = message
        .downcast_ref::<String>()
        .expect("a formatted message");
    assert!(message.contains("cannot run wf-discard"), "{message}");
}
