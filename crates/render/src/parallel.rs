//! Rendering a frame in one process: the image's tiles handed out dynamically to the workers of
//! one cache frame (tray_rust's block queue, pbrt-v4's tile integrator), on scoped threads or on
//! a rayon pool, and the reference grid's rows the same way. Both are an atomic counter over
//! work items consumed by the renderer's one worker loop ([`crate::work`]). What a sample
//! computes is the integrator's ([`PixelIntegrator`]); what a frame counts is [`FrameStats`].

use super::camera::Camera;
use super::film::Image;
use super::integrator::{PixelIntegrator, SampleCounters};
use super::scene::Scene;
/// Where a frame's workers run (defined with the other settings).
pub use super::settings::Pool;
use super::settings::RenderSettings;
use super::stats::FrameStats;
use super::work::{shade, Blocks, Counter, GridRows, Tiles};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::time::Instant;
use wfic::cache::{CacheConfig, CacheHandle, CacheJob, IrradianceCache, NoCache, Scheme};
use wfic::ic::{Selection, WorkerId};

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// The linear HDR image.
    pub image: Image,
    /// Its statistics.
    pub stats: FrameStats,
}

/// Whether a frame shows its progress: on a terminal, unless asked to be quiet (a log file or a
/// pipe gets no bar).
fn shows_progress(quiet: bool, terminal: bool) -> bool {
    !quiet && terminal
}

/// The frame's progress bar on stderr, or a hidden one where [`shows_progress`] says so. (The
/// choice is that function's, tested; a bar drawn or not is seen only on a terminal.)
fn progress_bar(tiles: usize, quiet: bool, label: &str) -> ProgressBar {
    if shows_progress(quiet, std::io::stderr().is_terminal()) {
        let bar = ProgressBar::with_draw_target(Some(tiles as u64), ProgressDrawTarget::stderr());
        if let Ok(style) =
            ProgressStyle::with_template("{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles")
        {
            bar.set_style(style);
        }
        bar.set_message(label.to_owned());
        bar
    } else {
        ProgressBar::hidden()
    }
}

/// Renders one frame of `scene` seen by `camera` with `threads` workers (0 counts as 1) sharing
/// `cache`, on the pool `settings.pool` names, then closes the cache's frame (LW merges there,
/// timed).
///
/// The cache keeps its records, so calling this again renders the next frame of an animation
/// with them (the paper's §4.2). With [`wfic::cache::Sequential`] (TRA) a worker holds the
/// octree for the whole frame, so extra workers only wait: use one thread. With
/// [`NoCache`] the frame is the reference: the indirect term is estimated at every primary hit.
///
/// # Panics
/// With `invalid render settings: ...` if [`RenderSettings::validate`] refuses `settings` or
/// `threads` is above [`crate::limits::THREADS`]; if a worker panics.
pub fn render_frame<C: IrradianceCache>(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    cache: &mut C,
    threads: usize,
) -> FrameResult {
    render_frame_removing(scene, camera, settings, cache, threads, None)
}

/// [`render_frame`], with worker 0 first removing what `removal` selects through its handle
/// ([`wfic::cache::CacheHandle::remove`]), while the other workers already shade: for a scene
/// that changed since the cache's last frame. With `settings.deterministic` the frame is
/// [`crate::deterministic::render`]'s, which removes before its first pass. The frame's time includes the removal; the
/// statistics count what it took ([`FrameStats::removed`]).
///
/// # Panics
/// As [`render_frame`].
pub fn render_frame_removing<C: IrradianceCache>(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    cache: &mut C,
    threads: usize,
    removal: Option<&Selection>,
) -> FrameResult {
    settings.assert_valid(threads);
    if settings.deterministic {
        return crate::deterministic::render(scene, camera, settings, cache, threads, removal);
    }
    let start = Instant::now();
    let threads = threads.max(1);
    let scheme = cache.scheme().name();
    let integrator = PixelIntegrator::new(scene, camera, settings, cache.config().accuracy());
    let tiles = Tiles::new(settings);
    let bar = progress_bar(
        tiles.count(),
        settings.quiet,
        &format!("{} {scheme}", scene.name()),
    );
    let source = Counter::new(tiles.count());
    let frame = cache.frame();
    let work = |handle: &mut C::Handle<'_>, worker: WorkerId| {
        if let Some(selection) = removal.filter(|_| worker == WorkerId::new(0)) {
            handle.remove(selection);
        }
        shade(&integrator, &tiles, &source, handle, |_| bar.inc(1))
    };
    let outputs = match settings.pool {
        Pool::Scoped => frame.run(threads, work),
        Pool::Rayon => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .thread_name(|i| format!("wfic-render-{i}"))
                .build()
                .expect("a rayon pool of the frame's threads");
            frame.run_on_pool(&pool, work)
        }
    };
    let report = frame.close();
    bar.finish_and_clear();

    let mut image = Image::new(settings.width, settings.height);
    let mut counters = SampleCounters::default();
    let worker_seconds: Vec<f64> = outputs.iter().map(|o| o.busy.as_secs_f64()).collect();
    for out in outputs {
        out.paint(&tiles, &mut image);
        counters += out.counters;
    }
    let seconds = start.elapsed().as_secs_f64();
    let mut stats = FrameStats::new(
        scheme,
        threads,
        settings,
        seconds,
        &counters,
        &report,
        cache.stats().records,
    );
    stats.worker_seconds = worker_seconds;
    stats.frame_hash = image.hash();
    FrameResult { image, stats }
}

/// Renders one frame with `scheme` and a fresh cache (the reference for `none`), returning the
/// frame and the records the cache holds afterwards.
pub fn render_with_scheme(
    scheme: Scheme,
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    config: CacheConfig,
    threads: usize,
) -> (FrameResult, Vec<wfic::ic::Record>) {
    struct Frame<'a> {
        scene: &'a Scene,
        camera: &'a Camera,
        settings: &'a RenderSettings,
        threads: usize,
    }
    impl CacheJob for Frame<'_> {
        type Output = (FrameResult, Vec<wfic::ic::Record>);
        fn run<C: IrradianceCache>(self, mut cache: C) -> Self::Output {
            let out = render_frame(
                self.scene,
                self.camera,
                self.settings,
                &mut cache,
                self.threads,
            );
            (out, cache.snapshot())
        }
    }
    scheme.build(
        config,
        Frame {
            scene,
            camera,
            settings,
            threads,
        },
    )
}

/// Renders the reference (scheme `none`): [`render_frame`] with a [`NoCache`] over `config`.
pub fn render_reference(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    config: CacheConfig,
    threads: usize,
) -> FrameResult {
    render_frame(scene, camera, settings, &mut NoCache::new(config), threads)
}

/// [`render_reference`] at the pixels of a `stride` x `stride` grid only: pixel `(x, y)` is
/// shaded when `x % stride == stride / 2` and `y % stride == stride / 2`; the others stay black.
/// A shaded pixel has the value the full reference gives it (every pixel's random streams
/// depend on the seed and the pixel only), at `1 / stride^2` of the cost: for error measures
/// against a brute-force image too slow to compute whole (`wfic compare radiance`). Returns the
/// image and the wall-clock seconds.
///
/// # Panics
/// As [`render_frame`].
pub fn render_reference_grid(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    config: CacheConfig,
    threads: usize,
    stride: u32,
) -> (Image, f64) {
    settings.assert_valid(threads);
    let start = Instant::now();
    let mut cache = NoCache::new(config);
    let integrator = PixelIntegrator::new(scene, camera, settings, config.accuracy());
    let rows = GridRows::new(settings, stride);
    let source = Counter::new(rows.count());
    let frame = cache.frame();
    let outputs = frame.run(threads.max(1), |handle, _| {
        shade(&integrator, &rows, &source, handle, |_| ())
    });
    frame.close();
    let mut image = Image::new(settings.width, settings.height);
    for out in outputs {
        out.paint(&rows, &mut image);
    }
    (image, start.elapsed().as_secs_f64())
}

/// Renders `frames` frames of the scene's orbit ([`Camera::orbit`] at `i / frames` turns) with one
/// cache that keeps its records from frame to frame (the paper's §4.2 walkthroughs), calling
/// `each(i, &frame)` after each frame; returns the frames' statistics.
pub fn render_orbit<C: IrradianceCache>(
    scene: &Scene,
    settings: &RenderSettings,
    cache: &mut C,
    threads: usize,
    frames: usize,
    mut each: impl FnMut(usize, &FrameResult),
) -> Vec<FrameStats> {
    (0..frames)
        .map(|i| {
            let camera = Camera::orbit(scene, i as f32 / frames.max(1) as f32);
            let out = render_frame(scene, &camera, settings, cache, threads);
            each(i, &out);
            out.stats
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes;
    use glam::Vec3;

    /// Settings out of their ranges, and too many threads, stop a render with the documented
    /// message before it starts.
    #[test]
    fn a_render_refuses_settings_out_of_range_with_the_documented_message() {
        let (scene, camera, settings, config) = cornell();
        for (bad, threads, expected) in [
            (
                settings.clone().pixel_samples(0),
                1,
                "invalid render settings: pixel_samples 0 is not in [1, 4096]",
            ),
            (
                settings.clone(),
                1025,
                "invalid render settings: threads 1025 is not in [1, 1024]",
            ),
        ] {
            let panic = std::panic::catch_unwind(|| {
                render_reference(&scene, &camera, &bad, config, threads)
            })
            .expect_err("refused");
            assert_eq!(panic.downcast_ref::<String>().unwrap(), expected);
        }
    }

    #[test]
    fn progress_shows_on_a_terminal_unless_quiet() {
        assert!(shows_progress(false, true));
        assert!(!shows_progress(true, true), "quiet");
        assert!(!shows_progress(false, false), "not a terminal");
        assert!(!shows_progress(true, false));
    }

    /// Frame `i` of an `n`-frame orbit is the scene seen from `i / n` turns; each frame reaches
    /// the callback in order, and its statistics are returned.
    #[test]
    fn an_orbit_renders_frame_i_of_n_from_i_over_n_turns() {
        let (scene, _, settings, config) = cornell();
        let mut seen = Vec::new();
        let stats = render_orbit(
            &scene,
            &settings,
            &mut NoCache::new(config),
            1,
            2,
            |i, f| seen.push((i, f.image.clone(), f.stats.rays)),
        );
        assert_eq!(seen.iter().map(|s| s.0).collect::<Vec<_>>(), [0, 1]);
        assert_eq!(stats.len(), 2);
        // (Images compared with `==`: a failed `assert_eq!` would print every pixel.)
        assert!(
            seen[0].1 != seen[1].1,
            "the two frames see the box from opposite sides"
        );
        for (k, turns) in [0.0, 0.5].into_iter().enumerate() {
            let camera = Camera::orbit(&scene, turns);
            let want = render_reference(&scene, &camera, &settings, config, 1);
            assert!(
                seen[k].1 == want.image,
                "frame {k} is seen from {turns} turns"
            );
            assert_eq!(stats[k].rays, seen[k].2, "frame {k}'s statistics");
        }
    }

    /// Worker 0 removes what the selection takes, also when it is the only worker.
    #[test]
    fn one_worker_removes_what_the_selection_takes() {
        let (scene, camera, settings, config) = cornell();
        let mut cache = wfic::cache::Sequential::new(config);
        render_frame(&scene, &camera, &settings, &mut cache, 1);
        let held = cache.stats().records as u64;
        assert!(held > 0);
        let earlier = Selection::older_than(0);
        let out = render_frame_removing(&scene, &camera, &settings, &mut cache, 1, Some(&earlier));
        assert_eq!(out.stats.removed, held, "every record of the first frame");
    }

    /// A small, cheap Cornell box frame.
    fn cornell() -> (Scene, Camera, RenderSettings, CacheConfig) {
        let scene = scenes::cornell().unwrap();
        let mut settings = RenderSettings::new(23, 19)
            .rays_per_record(16)
            .light_samples(2);
        settings.tile_size = 8;
        let config = settings.cache_config(&scene).unwrap();
        let camera = scene.camera();
        (scene, camera, settings, config)
    }

    #[test]
    fn the_reference_is_the_same_on_any_workers() {
        let (scene, camera, settings, config) = cornell();
        let one = render_reference(&scene, &camera, &settings, config, 1);
        for (pool, threads) in [(Pool::Scoped, 3), (Pool::Rayon, 2)] {
            let settings = settings.clone().pool(pool);
            let other = render_reference(&scene, &camera, &settings, config, threads);
            assert_eq!(other.image, one.image, "{pool:?} x {threads}");
            assert_eq!(other.stats.ic_samples, one.stats.ic_samples);
            assert_eq!(other.stats.rays, one.stats.rays);
            assert_eq!(other.stats.worker_seconds.len(), threads);
        }
        // One estimate per pixel that hit a diffuse surface.
        assert!(one.stats.ic_samples > 0 && one.stats.ic_samples <= 23 * 19);
    }

    #[test]
    fn the_reference_grid_is_the_reference_at_the_grid_pixels() {
        let (scene, camera, settings, config) = cornell();
        let full = render_reference(&scene, &camera, &settings, config, 1).image;
        let (grid, _) = render_reference_grid(&scene, &camera, &settings, config, 2, 3);
        for y in 0..settings.height {
            for x in 0..settings.width {
                let want = if x % 3 == 1 && y % 3 == 1 {
                    full.get(x, y)
                } else {
                    Vec3::ZERO
                };
                assert_eq!(grid.get(x, y), want, "({x}, {y})");
            }
        }
    }
}
