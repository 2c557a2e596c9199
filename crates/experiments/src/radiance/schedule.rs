//! The comparison's schedule, one scene's: both renderers' references, the matched settings,
//! the sweep of wfic's settings and each worker count's pick.

use super::{report, say, RadianceConfig, Role, Rtrace, Run};
use crate::harness::measure::repeat;
use crate::harness::metrics::{image_error, surface_mask};
use wfic::cache::Scheme;
use wfic_render::film::Image;
use wfic_render::{render_reference_grid, render_with_scheme, RenderSettings, Scene};

/// The seed of wfic's repeat `i`: the matched seed first.
fn seed_of(i: u32) -> u64 {
    0x5eed + 0x1_0000 * u64::from(i)
}

/// The images a comparison measures against: the renderer's own brute-force images (wfic: one
/// per seed, repeat `i` against `own[i]`; Radiance: one, every repeat against `own[0]`), the
/// converged one, the pixels measured.
pub(super) struct References<'a> {
    own: &'a [Image],
    converged: &'a Image,
    mask: &'a [bool],
}

impl References<'_> {
    /// `run` with its errors: `img` against the own reference of `repeat` and the converged one.
    fn measured(&self, mut run: Run, img: &Image, repeat: usize) -> Run {
        run.cache_error = image_error(img, &self.own[repeat], self.mask);
        run.image_error = image_error(img, self.converged, self.mask);
        run.cache_error_range = (run.cache_error.rel_rmse, run.cache_error.rel_rmse);
        run
    }

    /// wfic frames (`wf`, a fresh cache) of `scene` at settings `s` on `workers` threads, one
    /// per own reference (each with that reference's seed), measured as one row
    /// ([`Run::combine`]); and the first frame's image.
    pub(super) fn wfic_frames(
        &self,
        scene: &Scene,
        role: Role,
        s: &RenderSettings,
        workers: usize,
    ) -> Result<(Run, Image), String> {
        let mut first = None;
        let runs = repeat(self.own.len(), |i| {
            let mut s = s.clone();
            s.seed = seed_of(i as u32);
            let config = s.cache_config(scene).map_err(|e| e.to_string())?;
            let camera = scene.camera();
            let f = render_with_scheme(Scheme::Wf, scene, &camera, &s, config, workers).0;
            let setting = (s.accuracy, s.rays_per_record);
            let stats = (f.stats.seconds, f.stats.cache_records);
            let run = Run::new("wfic", role, workers, Some(&s), setting, stats);
            let run = self.measured(run, &f.image, i);
            first.get_or_insert(f.image);
            Ok::<_, String>(run)
        })?;
        Ok((Run::combine(runs), first.expect("at least one repeat")))
    }

    /// [`Self::wfic_frames`] without the image.
    pub(super) fn wfic(
        &self,
        scene: &Scene,
        role: Role,
        s: &RenderSettings,
        workers: usize,
    ) -> Result<Run, String> {
        Ok(self.wfic_frames(scene, role, s, workers)?.0)
    }
}

/// Both renderers' references of one scene, and what they are measured on.
pub(super) struct SceneReferences {
    pub(super) mask: Vec<bool>,
    pub(super) radiance: Image,
    pub(super) radiance_seconds: f64,
    pub(super) wfic_own: Vec<Image>,
    pub(super) wfic_seconds: f64,
    pub(super) wfic_settings: RenderSettings,
    pub(super) converged: Image,
}

impl SceneReferences {
    /// Radiance's brute-force image, wfic's one per seed and the converged one.
    pub(super) fn render(
        config: &RadianceConfig,
        scene: &Scene,
        rtrace: &Rtrace,
    ) -> Result<Self, String> {
        let (name, n, a, k) = (
            scene.name(),
            config.rays,
            config.accuracy,
            config.reference_stride,
        );
        say!(
            name,
            "radiance reference: -aa 0 -ad {}, 2 processes, 1 pixel in {}",
            4 * n,
            k * k
        );
        let (radiance, radiance_seconds) = rtrace.reference(4 * n)?;
        // wfic's references on the same grid: brute force with the matched light samples (cache
        // error), and the converged one (image error) with more light samples and another seed.
        let repeats = config.repeats.max(1);
        say!(
            name,
            "wfic reference: none, {} rays, 2 threads, {repeats} seed(s)",
            4 * n
        );
        let wfic_settings = config.settings(a, 4 * n, config.light_samples, seed_of(0));
        let rc = wfic_settings
            .cache_config(scene)
            .map_err(|e| e.to_string())?;
        let camera = scene.camera();
        let mut own = Vec::new();
        for i in 0..repeats {
            let mut rs = wfic_settings.clone();
            rs.seed = seed_of(i);
            own.push(render_reference_grid(scene, &camera, &rs, rc, 2, k));
        }
        let light = config.converged_light_samples;
        say!(
            name,
            "converged reference: none, {} rays, {light} light samples",
            4 * n
        );
        let conv_settings = config.settings(a, 4 * n, light, 0xc0ffee);
        let (converged, _) = render_reference_grid(scene, &camera, &conv_settings, rc, 2, k);
        Ok(Self {
            mask: surface_mask(scene, &wfic_settings, k),
            radiance,
            radiance_seconds,
            wfic_seconds: own[0].1,
            wfic_own: own.into_iter().map(|(img, _)| img).collect(),
            wfic_settings,
            converged,
        })
    }

    pub(super) fn radiance(&self) -> References<'_> {
        References {
            own: std::slice::from_ref(&self.radiance),
            converged: &self.converged,
            mask: &self.mask,
        }
    }

    pub(super) fn wfic(&self) -> References<'_> {
        References {
            own: &self.wfic_own,
            converged: &self.converged,
            mask: &self.mask,
        }
    }

    /// The two references' own rows.
    pub(super) fn rows(&self, rays: u32) -> [Run; 2] {
        let s = &self.wfic_settings;
        let radiance = Run::new(
            "radiance",
            Role::Reference,
            2,
            None,
            (0.0, 4 * rays),
            (self.radiance_seconds, 0),
        );
        let wfic = Run::new(
            "wfic",
            Role::Reference,
            2,
            Some(s),
            (0.0, s.rays_per_record),
            (self.wfic_seconds, 0),
        );
        [
            self.radiance().measured(radiance, &self.radiance, 0),
            self.wfic().measured(wfic, &self.wfic_own[0], 0),
        ]
    }
}

/// The matched settings, Radiance's and wfic's, at 1 and 2 workers, `repeats` renders each;
/// and each renderer's first image at 1 worker.
pub(super) fn matched(
    config: &RadianceConfig,
    scene: &Scene,
    rtrace: &Rtrace,
    refs: &SceneReferences,
) -> Result<(Vec<Run>, Image, Image), String> {
    let (name, n, a) = (scene.name(), config.rays, config.accuracy);
    let repeats = config.repeats.max(1);
    let mut runs = Vec::new();
    let mut radiance_images = Vec::new();
    for workers in [1, 2] {
        let rows = repeat(repeats as usize, |i| {
            say!(
                name,
                "radiance: -aa {a} -ad {n} -ar {}, {workers} process(es), run {} of {repeats}",
                config.resolution,
                i + 1
            );
            let setting = (a, n, config.resolution);
            let (img, seconds, records, _) =
                rtrace.cached(setting, workers, &format!("amb-{workers}-{i}"))?;
            let run = Run::new(
                "radiance",
                Role::Matched,
                workers,
                None,
                (a, n),
                (seconds, records),
            );
            let run = refs.radiance().measured(run, &img, 0);
            if i == 0 {
                radiance_images.push(img);
            }
            Ok::<_, String>(run)
        })?;
        runs.push(Run::combine(rows));
    }
    let base = config.settings(a, n, config.light_samples, 0x5eed);
    let mut wfic_images = Vec::new();
    for workers in [1, 2] {
        say!(
            name,
            "wfic: wf, a {a}, {n} rays, {workers} thread(s), {repeats} seed(s)"
        );
        let (run, img) = refs
            .wfic()
            .wfic_frames(scene, Role::Matched, &base, workers)?;
        runs.push(run);
        wfic_images.push(img);
    }
    let (rad, wf) = (radiance_images.swap_remove(0), wfic_images.swap_remove(0));
    Ok((runs, rad, wf))
}

/// The sweep of wfic's settings at 2 threads, each row with its settings, against its
/// reference (whose rays stay `4N`).
pub(super) fn sweep(
    config: &RadianceConfig,
    scene: &Scene,
    refs: &References,
    target: f64,
) -> Result<Vec<(Run, RenderSettings)>, String> {
    let mut swept = Vec::new();
    for &scale in &config.sweep_accuracy_scales {
        // Rounded to 1e-3 so the tables read 0.2, not 0.20000002.
        let sa = (config.accuracy * scale * 1000.0).round() / 1000.0;
        for &rs in &config.sweep_rays_scales {
            let sn = ((config.rays as f32 * rs).round() as u32).max(16);
            for &rmin in &config.sweep_min_radius {
                for &k in &config.sweep_smoothing {
                    let mut s = config
                        .settings(sa, sn, config.light_samples, 0x5eed)
                        .smoothing(k);
                    s.min_radius_pixels = rmin;
                    let run = refs.wfic(scene, Role::Sweep, &s, 2)?;
                    say!(
                        scene.name(),
                        "sweep {}: {:.3} s, {} records, cache error {:.2}% (radiance {:.2}%)",
                        report::wfic_setting(&run),
                        run.seconds,
                        run.records,
                        100.0 * run.cache_error.rel_rmse,
                        100.0 * target
                    );
                    swept.push((run, s));
                }
            }
        }
    }
    Ok(swept)
}

/// Swept settings tried for a pick, cheapest first: the frame rendered again at the pick's
/// worker count can err a little above the sweep's 2-thread one (records land in another
/// order).
const PICK_TRIES: usize = 4;

/// A worker count's pick: whether it reached Radiance's error, its setting, its frames at 1
/// and 2 workers (as measured so far), the worker counts it is the pick of.
pub(super) type Pick = (bool, RenderSettings, [Option<Run>; 2], Vec<usize>);

/// Whether two settings are the same cache setting.
fn same(x: &RenderSettings, y: &RenderSettings) -> bool {
    let key = |s: &RenderSettings| {
        (
            s.accuracy,
            s.rays_per_record,
            s.min_radius_pixels,
            s.smoothing,
        )
    };
    key(x) == key(y)
}

/// Each worker count's pick: the cheapest swept setting at or below Radiance's error at that
/// count (`targets[w]`) whose frame at that count, rendered again, errs at or below it too (up
/// to [`PICK_TRIES`]); the most accurate swept one when none holds. Frames that erred above go
/// to `runs` as [`Role::PickTried`]. One setting serves both counts when it is the same.
pub(super) fn picks(
    scene: &Scene,
    refs: &References,
    swept: &[(Run, RenderSettings)],
    targets: [f64; 2],
    runs: &mut Vec<Run>,
) -> Result<Vec<Pick>, String> {
    let mut picks: Vec<Pick> = Vec::new();
    for (w, &t) in targets.iter().enumerate() {
        let workers = w + 1;
        let mut found = None;
        for (_, st) in swept
            .iter()
            .filter(|(r, _)| r.cache_error.rel_rmse <= t)
            .take(PICK_TRIES)
        {
            if let Some((_, earlier, frames, _)) =
                picks.iter().find(|(ok, p, _, _)| *ok && same(p, st))
            {
                // The other count's pick: its frame at this count is measured already.
                if let Some(run) = frames[w].as_ref().filter(|r| r.cache_error.rel_rmse <= t) {
                    found = Some((earlier.clone(), run.clone()));
                    break;
                }
            }
            let run = refs.wfic(scene, Role::PickTried, st, workers)?;
            say!(
                scene.name(),
                "{workers}-worker pick {}: cache error {:.2}% (radiance {:.2}%)",
                report::wfic_setting(&run),
                100.0 * run.cache_error.rel_rmse,
                100.0 * t
            );
            if run.cache_error.rel_rmse <= t {
                found = Some((st.clone(), run));
                break;
            }
            runs.push(run);
        }
        let (reached, st, run) = match found {
            Some((st, run)) => (true, st, Some(run)),
            None => {
                let most = swept
                    .iter()
                    .min_by(|x, y| {
                        x.0.cache_error
                            .rel_rmse
                            .total_cmp(&y.0.cache_error.rel_rmse)
                    })
                    .expect("the sweep is not empty");
                (false, most.1.clone(), None)
            }
        };
        if let Some(pick) = picks
            .iter_mut()
            .find(|(ok, p, _, _)| *ok == reached && same(p, &st))
        {
            pick.2[w] = pick.2[w].take().or(run);
            pick.3.push(workers);
        } else {
            let mut frames = [None, None];
            frames[w] = run;
            picks.push((reached, st, frames, vec![workers]));
        }
    }
    Ok(picks)
}
