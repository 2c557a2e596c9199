//! A long animation with removal, rendered: the Cornell box's orbit, 1 000 frames a scheme
//! (`WFIC_LONG_RUN_FRAMES`; the long run, 10 000, is in docs/verification.md), each frame
//! removing the records older than one frame before it shades. The cache's memory must stay
//! bounded by what is alive, however long the animation runs:
//! - every frame, the records held are exactly those held before, less those removed, plus those
//!   stored (nothing leaks past a removal, nothing is counted twice);
//! - the records held never exceed the last two frames' records;
//! - the nodes held in the last tenth of the run are at most those of its second tenth, with a
//!   margin (the orbit repeats every 100 frames, so a tree that grows with the run, rather than
//!   with what is alive, fails);
//! - every frame is lit and finite.

#![cfg(not(checker))]

use wfic::cache::{CacheJob, IrradianceCache, Scheme};
use wfic::ic::Selection;
use wfic_render::parallel::render_frame_removing;
use wfic_render::{scenes, Camera, RenderSettings, Scene};

/// `WFIC_LONG_RUN_FRAMES`: the frames a scheme renders (default 1 000).
fn frames() -> usize {
    std::env::var("WFIC_LONG_RUN_FRAMES")
        .map_or(1000, |v| v.parse().expect("WFIC_LONG_RUN_FRAMES: a number"))
}

/// What the run saw, frame by frame: records and nodes held after it.
struct LongRun<'a> {
    scene: &'a Scene,
    settings: RenderSettings,
    frames: usize,
}

impl CacheJob for LongRun<'_> {
    type Output = Vec<(usize, usize)>;

    fn run<C: IrradianceCache>(self, mut cache: C) -> Self::Output {
        let scheme = cache.scheme().name();
        let stale = Selection::older_than(1);
        let mut held = Vec::with_capacity(self.frames);
        let mut stored: Vec<u64> = Vec::with_capacity(self.frames);
        for i in 0..self.frames {
            let before = cache.stats().records as u64;
            let camera = Camera::orbit(self.scene, i as f32 / 100.0);
            let out = render_frame_removing(
                self.scene,
                &camera,
                &self.settings,
                &mut cache,
                2,
                Some(&stale),
            );
            let stats = cache.stats();
            let now = stats.records as u64;
            let new = now + out.stats.removed - before;
            assert_eq!(
                new, out.stats.ic_samples,
                "{scheme}, frame {i}: {before} held - {} removed + {} computed != {now} held",
                out.stats.removed, out.stats.ic_samples
            );
            stored.push(new);
            let last_two = new + i.checked_sub(1).map_or(0, |j| stored[j]);
            assert!(
                now <= last_two,
                "{scheme}, frame {i}: {now} records held, more than the last two frames' {last_two}"
            );
            let mean = out.image.mean();
            assert!(
                out.image.pixels().iter().all(|p| p.is_finite()) && mean.max_element() > 0.0,
                "{scheme}, frame {i}: an unlit or non-finite frame ({mean})"
            );
            held.push((stats.records, stats.nodes));
        }
        held
    }
}

#[test]
fn a_long_orbit_with_removal_keeps_every_scheme_at_what_is_alive() {
    let frames = frames();
    assert!(frames >= 100, "WFIC_LONG_RUN_FRAMES: at least 100");
    let scene = scenes::cornell().expect("the Cornell box");
    let settings = RenderSettings::new(24, 24)
        .accuracy(0.15)
        .rays_per_record(16)
        .light_samples(1);
    let config = settings.cache_config(&scene).expect("a cache over the box");
    for scheme in [Scheme::Tra, Scheme::Lck, Scheme::Lw, Scheme::Wf] {
        let held = scheme.build(
            config,
            LongRun {
                scene: &scene,
                settings: settings.clone(),
                frames,
            },
        );
        let tenth = frames / 10;
        let early = held[tenth..2 * tenth].iter().map(|h| h.1).max().unwrap();
        let late = held[frames - tenth..].iter().map(|h| h.1).max().unwrap();
        let records = held.iter().map(|h| h.0).max().unwrap();
        assert!(
            late * 4 <= early * 5,
            "{scheme}: {late} nodes in the last tenth of {frames} frames, against {early} in the \
             second: the tree grows with the run"
        );
        eprintln!(
            "{scheme}: {frames} frames; at most {records} records held; nodes at most {early} in \
             the second tenth, {late} in the last"
        );
    }
}
