//! Parallel frames: image tiles handed out dynamically to worker threads, one cache handle per
//! worker, per-worker counters summed after the join (tray_rust's block queue, pbrt-v4's tile
//! integrator).

use super::camera::View;
use super::film::Image;
use super::integrator::{self, facing, RayCounts, Strata};
use super::sampler::{Rng, Stream};
use super::scene::Scene;
use super::{Camera, RenderSettings};
use crate::cache::{CacheHandle, IrradianceCache, Sequential, WorkerStats};
use crate::ic::{self, Record, WorkerId};
use crate::sync::{thread, AtomicUsize, Ordering};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::f32::consts::PI;
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// A frame's statistics (the paper's Table 1 columns and more).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// The scheme (`tra`, `lck`, `lck-rw`, `lw`, `wf`, `wf-discard`, or `none`).
    pub scheme: String,
    /// Worker threads.
    pub threads: usize,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Wall-clock time of the frame, LW's merge included.
    pub seconds: f64,
    /// Irradiance estimates computed (hemisphere samplings): the paper's "IC samples". With the
    /// `none` scheme, one per shaded pixel.
    pub ic_samples: u64,
    /// Cache lookups.
    pub lookups: u64,
    /// Lookups answered by the cache.
    pub hits: u64,
    /// Hits that used at least one record another worker computed.
    pub shared_hits: u64,
    /// `shared_hits / hits` (0 without hits): the share of successful lookups served by at least
    /// one record another thread computed.
    pub sharing: f64,
    /// LCK: time spent waiting for the lock, summed over workers.
    pub lock_wait_seconds: f64,
    /// LW: time spent merging the local caches at the end of the frame.
    pub merge_seconds: f64,
    /// WF `Discard`: records dropped after a lost compare-and-swap.
    pub discarded: u64,
    /// Records stored.
    pub stored: u64,
    /// Records refused by the cache (bad input; expected 0).
    pub rejected: u64,
    /// Rays traced, by kind.
    pub rays: RayCounts,
    /// Time spent in hemisphere sampling, summed over workers (for rays per second per core).
    pub hemisphere_seconds: f64,
    /// Records in the cache after the frame.
    pub cache_records: usize,
}

impl FrameStats {
    /// Hemisphere rays per second of one core's sampling time.
    pub fn hemisphere_rays_per_second(&self) -> f64 {
        if self.hemisphere_seconds > 0.0 {
            self.rays.hemisphere as f64 / self.hemisphere_seconds
        } else {
            0.0
        }
    }

    /// The statistics as a JSON object (keys as in the issue, plus the extra counters).
    pub fn to_json(&self, scene: &str) -> String {
        let esc = |s: &str| s.replace('\\', "\\\\").replace('"', "\\\"");
        format!(
            concat!(
                "{{\n",
                "  \"scene\": \"{}\",\n  \"scheme\": \"{}\",\n  \"threads\": {},\n",
                "  \"width\": {},\n  \"height\": {},\n  \"seconds\": {:.6},\n",
                "  \"ic_samples\": {},\n  \"lookups\": {},\n  \"hits\": {},\n",
                "  \"shared_hits\": {},\n  \"sharing\": {:.6},\n",
                "  \"lock_wait_seconds\": {:.6},\n  \"merge_seconds\": {:.6},\n",
                "  \"discarded\": {},\n  \"stored\": {},\n  \"rejected\": {},\n",
                "  \"cache_records\": {},\n",
                "  \"primary_rays\": {},\n  \"shadow_rays\": {},\n  \"hemisphere_rays\": {},\n",
                "  \"hemisphere_seconds\": {:.6},\n  \"hemisphere_rays_per_second\": {:.1}\n",
                "}}\n"
            ),
            esc(scene),
            esc(&self.scheme),
            self.threads,
            self.width,
            self.height,
            self.seconds,
            self.ic_samples,
            self.lookups,
            self.hits,
            self.shared_hits,
            self.sharing,
            self.lock_wait_seconds,
            self.merge_seconds,
            self.discarded,
            self.stored,
            self.rejected,
            self.cache_records,
            self.rays.primary,
            self.rays.shadow,
            self.rays.hemisphere,
            self.hemisphere_seconds,
            self.hemisphere_rays_per_second(),
        )
    }
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// The linear HDR image.
    pub image: Image,
    /// Its statistics.
    pub stats: FrameStats,
}

/// What one worker counts for itself.
#[derive(Clone, Copy, Debug, Default)]
struct Counters {
    rays: RayCounts,
    ic_samples: u64,
    hemisphere: Duration,
}

/// Per-frame constants shared by the workers (read-only).
struct Frame<'a> {
    scene: &'a Scene,
    view: View,
    settings: &'a RenderSettings,
    strata: Strata,
    eps: f32,
    diagonal: f32,
    /// The cache's accuracy `a` (1 without a cache).
    accuracy: f32,
    tiles_x: u32,
    tiles: usize,
}

impl Frame<'_> {
    fn tile_rect(&self, tile: usize) -> (u32, u32, u32, u32) {
        let ts = self.settings.tile_size;
        let (tx, ty) = (tile as u32 % self.tiles_x, tile as u32 / self.tiles_x);
        let (x0, y0) = (tx * ts, ty * ts);
        let x1 = (x0 + ts).min(self.settings.width);
        let y1 = (y0 + ts).min(self.settings.height);
        (x0, y0, x1, y1)
    }

    /// The radiance of pixel `(px, py)`: the mean of its `pixel_samples` primary rays, placed
    /// by stratified jitter on the most nearly square `cols x rows` grid with `cols * rows`
    /// equal to the count (a single ray goes through the centre).
    fn shade<H: CacheHandle>(
        &self,
        px: u32,
        py: u32,
        mut handle: Option<&mut H>,
        counters: &mut Counters,
    ) -> Vec3 {
        let n = self.settings.pixel_samples.max(1);
        if n == 1 {
            return self.shade_sample(px, py, 0, (0.5, 0.5), handle, counters);
        }
        let (cols, rows) = strata_grid(n);
        let mut pos = Rng::for_pixel(self.settings.seed, px, py, Stream::Position);
        let mut sum = Vec3::ZERO;
        for s in 0..n {
            let (i, j) = (s % cols, s / cols);
            let u = (i as f32 + pos.next_f32()) / cols as f32;
            let v = (j as f32 + pos.next_f32()) / rows as f32;
            sum += self.shade_sample(px, py, s, (u, v), handle.as_deref_mut(), counters);
        }
        sum / n as f32
    }

    /// The radiance along one primary ray through `(px + offset.0, py + offset.1)`, sample
    /// `sample` of its pixel.
    fn shade_sample<H: CacheHandle>(
        &self,
        px: u32,
        py: u32,
        sample: u32,
        offset: (f32, f32),
        handle: Option<&mut H>,
        counters: &mut Counters,
    ) -> Vec3 {
        let scene = self.scene;
        let dir = self
            .view
            .direction(px as f32 + offset.0, py as f32 + offset.1);
        counters.rays.primary += 1;
        let Some(hit) = scene.intersect(self.view.eye(), dir, f32::INFINITY) else {
            return Vec3::ZERO;
        };
        let x = self.view.eye() + dir * hit.t;
        let n = facing(hit.normal, dir);
        let mut radiance = if hit.normal.dot(dir) < 0.0 {
            hit.material.emission
        } else {
            Vec3::ZERO
        };
        let mut rng = Rng::for_sample(self.settings.seed, px, py, sample, Stream::Direct);
        let direct = integrator::direct_irradiance(
            scene,
            x,
            n,
            self.settings.light_samples,
            self.eps,
            &mut rng,
            &mut counters.rays,
        );
        let cached = match handle {
            Some(h) => match h.lookup(x, n) {
                Some(found) => Ok(found.irradiance),
                None => Err(Some(h)),
            },
            None => Err(None),
        };
        let indirect = match cached {
            Ok(e) => e,
            Err(handle) => {
                let mut rng =
                    Rng::for_sample(self.settings.seed, px, py, sample, Stream::Hemisphere);
                let start = Instant::now();
                let s = integrator::sample_irradiance(
                    scene,
                    x,
                    n,
                    self.strata,
                    self.eps,
                    &mut rng,
                    &mut counters.rays,
                );
                counters.hemisphere += start.elapsed();
                counters.ic_samples += 1;
                if let Some(h) = handle {
                    let footprint = self.view.footprint(hit.t, dir);
                    let (r_min, r_max) = self.settings.radius_bounds(footprint, self.diagonal);
                    let (radius, grad_t) = limit_gradient(&s, r_min, r_max, self.accuracy);
                    let record =
                        Record::new(x, n, s.irradiance, radius).with_gradients(grad_t, s.grad_r);
                    // Stored or discarded (WF `Discard`) or refused, the estimate is used for
                    // this pixel; a refusal is counted by the handle (`rejected`).
                    let _ = h.insert(record);
                }
                s.irradiance
            }
        };
        radiance += hit.material.albedo * (direct + indirect) * (1.0 / PI);
        radiance
    }

    fn render_tile<H: CacheHandle>(
        &self,
        tile: usize,
        mut handle: Option<&mut H>,
        counters: &mut Counters,
    ) -> Vec<Vec3> {
        let (x0, y0, x1, y1) = self.tile_rect(tile);
        let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
        for y in y0..y1 {
            for x in x0..x1 {
                out.push(self.shade(x, y, handle.as_deref_mut(), counters));
            }
        }
        out
    }
}

/// The most nearly square grid `(cols, rows)` with `cols * rows == n` and `cols >= rows`
/// (`n` prime gives `(n, 1)`).
fn strata_grid(n: u32) -> (u32, u32) {
    let mut rows = (n as f64).sqrt() as u32;
    while rows > 1 && n % rows != 0 {
        rows -= 1;
    }
    let rows = rows.max(1);
    (n / rows, rows)
}

/// The record's radius and translational gradient, limited as Křivánek et al. (2006, "Making
/// radiance and irradiance caching practical") advise, so a record never extrapolates wildly:
/// * the radius is at most `E_c / |grad_t[c]|` for every channel (where irradiance changes fast,
///   records are closer together), then clamped to `[r_min, r_max]` ([`ic::clamp_radius`]);
/// * if a channel's gradient would still change it by more than its own value across the
///   record's reach `a R`, that gradient is scaled down to exactly that.
pub fn limit_gradient(
    s: &integrator::IrradianceSample,
    r_min: f32,
    r_max: f32,
    accuracy: f32,
) -> (f32, [Vec3; 3]) {
    let mut hmd = s.harmonic_mean;
    for c in 0..3 {
        let g = s.grad_t[c].length();
        if g > 0.0 {
            hmd = hmd.min(s.irradiance[c] / g);
        }
    }
    let radius = ic::clamp_radius(hmd, r_min, r_max);
    let reach = accuracy * radius;
    let mut grad_t = s.grad_t;
    for (c, g) in grad_t.iter_mut().enumerate() {
        let change = g.length() * reach;
        if change > s.irradiance[c] {
            *g *= s.irradiance[c] / change;
        }
    }
    (radius, grad_t)
}

fn progress_bar(tiles: usize, quiet: bool, label: &str) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(tiles as u64), ProgressDrawTarget::stderr());
    if let Ok(style) =
        ProgressStyle::with_template("{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles")
    {
        bar.set_style(style);
    }
    bar.set_message(label.to_owned());
    bar
}

/// What a worker hands back when it joins.
struct WorkerOutput<R> {
    tiles: Vec<(usize, Vec<Vec3>)>,
    counters: Counters,
    residue: Option<R>,
}

/// Renders the tiles with `threads` workers; each worker gets `cache.handle(WorkerId::new(i))`
/// (if a cache is given) and finishes it before it joins.
fn run_workers<C: IrradianceCache>(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    cache: Option<&C>,
    threads: usize,
    label: &str,
) -> (Image, Counters, Vec<C::Residue>) {
    let (w, h) = (settings.width, settings.height);
    let ts = settings.tile_size.max(1);
    let tiles_x = w.div_ceil(ts);
    let frame = Frame {
        scene,
        view: camera.view(w, h),
        settings,
        strata: settings.strata(),
        eps: 1e-4 * scene.diagonal(),
        diagonal: scene.diagonal(),
        accuracy: cache.map_or(1.0, |c| c.config().accuracy()),
        tiles_x,
        tiles: (tiles_x * h.div_ceil(ts)) as usize,
    };
    let bar = progress_bar(frame.tiles, settings.quiet, label);
    let next_tile = AtomicUsize::new(0);
    let outputs: Vec<WorkerOutput<C::Residue>> = thread::scope(|s| {
        let workers: Vec<_> = (0..threads.max(1))
            .map(|i| {
                let (frame, next_tile, bar) = (&frame, &next_tile, &bar);
                s.spawn(move || {
                    let mut handle = cache.map(|c| c.handle(WorkerId::new(i as u32)));
                    let mut counters = Counters::default();
                    let mut tiles = Vec::new();
                    loop {
                        // Relaxed: the counter only has to hand each tile to exactly one worker,
                        // which the atomicity of `fetch_add` guarantees on its own; no other
                        // memory is published through it (the tiles' pixels come back through
                        // the join).
                        let tile = next_tile.fetch_add(1, Ordering::Relaxed);
                        if tile >= frame.tiles {
                            break;
                        }
                        let pixels = frame.render_tile(tile, handle.as_mut(), &mut counters);
                        tiles.push((tile, pixels));
                        bar.inc(1);
                    }
                    WorkerOutput {
                        tiles,
                        counters,
                        residue: handle.map(CacheHandle::finish),
                    }
                })
            })
            .collect();
        workers
            .into_iter()
            .map(|w| match w.join() {
                Ok(out) => out,
                Err(panic) => std::panic::resume_unwind(panic),
            })
            .collect()
    });
    bar.finish_and_clear();

    let mut image = Image::new(w, h);
    let mut counters = Counters::default();
    let mut residues = Vec::with_capacity(outputs.len());
    for out in outputs {
        for (tile, pixels) in out.tiles {
            let (x0, y0, x1, _) = frame.tile_rect(tile);
            let tw = x1 - x0;
            for (i, p) in pixels.into_iter().enumerate() {
                image.set(x0 + i as u32 % tw, y0 + i as u32 / tw, p);
            }
        }
        counters.rays += out.counters.rays;
        counters.ic_samples += out.counters.ic_samples;
        counters.hemisphere += out.counters.hemisphere;
        residues.extend(out.residue);
    }
    (image, counters, residues)
}

fn base_stats(settings: &RenderSettings, threads: usize, scheme: &str, c: &Counters) -> FrameStats {
    FrameStats {
        scheme: scheme.to_owned(),
        threads: threads.max(1),
        width: settings.width,
        height: settings.height,
        ic_samples: c.ic_samples,
        rays: c.rays,
        hemisphere_seconds: c.hemisphere.as_secs_f64(),
        ..FrameStats::default()
    }
}

/// Renders one frame of `scene` seen by `camera` with `threads` workers (0 counts as 1) sharing
/// `cache`, then closes the frame ([`IrradianceCache::end_frame`]: LW merges there, timed).
///
/// The cache keeps its records, so calling this again renders the next frame of an animation
/// with them (the paper's §4.2). With [`crate::cache::Sequential`] (TRA) a worker holds the
/// octree for the whole frame, so extra workers only wait: use one thread.
pub fn render_frame<C: IrradianceCache>(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    cache: &mut C,
    threads: usize,
) -> FrameResult {
    let start = Instant::now();
    let scheme = cache.scheme();
    let label = format!("{} {scheme}", scene.name());
    let (image, counters, residues) =
        run_workers(scene, camera, settings, Some(&*cache), threads, &label);
    let report = cache.end_frame(residues);
    let seconds = start.elapsed().as_secs_f64();
    let cache_records = cache.stats().records;
    let w: &WorkerStats = &report.workers;
    let stats = FrameStats {
        seconds,
        lookups: w.lookups,
        hits: w.hits,
        shared_hits: w.shared_hits,
        sharing: if w.hits > 0 {
            w.shared_hits as f64 / w.hits as f64
        } else {
            0.0
        },
        lock_wait_seconds: w.lock_wait.as_secs_f64(),
        merge_seconds: report.merge.as_secs_f64(),
        discarded: w.discarded,
        stored: w.stored,
        rejected: w.rejected,
        cache_records,
        ..base_stats(settings, threads, scheme, &counters)
    };
    FrameResult { image, stats }
}

/// Renders the reference (scheme `none`): the indirect irradiance is estimated at every pixel
/// with the same sampling as a cache record, and nothing is cached.
pub fn render_reference(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    threads: usize,
) -> FrameResult {
    let start = Instant::now();
    let label = format!("{} none", scene.name());
    let (image, counters, _) =
        run_workers::<Sequential>(scene, camera, settings, None, threads, &label);
    let stats = FrameStats {
        seconds: start.elapsed().as_secs_f64(),
        ..base_stats(settings, threads, "none", &counters)
    };
    FrameResult { image, stats }
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
    use super::strata_grid;

    #[test]
    fn strata_grids_are_as_square_as_the_count_allows() {
        assert_eq!(strata_grid(1), (1, 1));
        assert_eq!(strata_grid(4), (2, 2));
        assert_eq!(strata_grid(6), (3, 2));
        assert_eq!(strata_grid(7), (7, 1));
        assert_eq!(strata_grid(16), (4, 4));
        for n in 1..200 {
            let (c, r) = strata_grid(n);
            assert_eq!(c * r, n);
            assert!(c >= r);
        }
    }
}
