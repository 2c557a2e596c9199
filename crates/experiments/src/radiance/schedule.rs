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
/// per seed, repeat `i` against `own[i]`; Radiance: one, every repeat against it), the
/// converged one, the pixels measured.
pub(super) struct References<'a> {
    own: &'a [Image],
    converged: &'a Image,
    mask: &'a [bool],
}

impl References<'_> {
    /// `run` with its errors: `img` against the own reference of `repeat` and the converged one.
    fn measured(&self, mut run: Run, img: &Image, repeat: usize) -> Run {
        let own = &self.own[repeat.min(self.own.len() - 1)];
        run.cache_error = image_error(img, own, self.mask);
        run.image_error = image_error(img, self.converged, self.mask);
        run.cache_error_range = (run.cache_error.rel_rmse, run.cache_error.rel_rmse);
        run
    }

    /// `repeats` renders of the setting of `row` (`render(i)`: the image, seconds and records
    /// of repeat `i`), each measured, as one row ([`Run::combine`]); and the first image.
    fn frames(
        &self,
        row: &Run,
        repeats: usize,
        mut render: impl FnMut(usize) -> Result<(Image, f64, usize), String>,
    ) -> Result<(Run, Image), String> {
        let mut first = None;
        let runs = repeat(repeats, |i| {
            let (img, seconds, records) = render(i)?;
            let run = Run {
                seconds,
                records,
                ..row.clone()
            };
            let run = self.measured(run, &img, i);
            first.get_or_insert(img);
            Ok::<_, String>(run)
        })?;
        Ok((Run::combine(runs), first.expect("at least one repeat")))
    }

    /// wfic frames (`wf`, a fresh cache) of `scene` at settings `s` on `workers` threads, one
    /// per own reference (each with that reference's seed), as one row; and the first image.
    fn wfic_frames(
        &self,
        scene: &Scene,
        role: Role,
        s: &RenderSettings,
        workers: usize,
    ) -> Result<(Run, Image), String> {
        let row = Run::new(
            "wfic",
            role,
            workers,
            (s.accuracy, s.rays_per_record),
            Some(s),
        );
        self.frames(&row, self.own.len(), |i| {
            let s = s.clone().seed(seed_of(i as u32));
            let config = s.cache_config(scene).map_err(|e| e.to_string())?;
            let f = render_with_scheme(Scheme::Wf, scene, &scene.camera(), &s, config, workers).0;
            Ok((f.image, f.stats.seconds, f.stats.cache_records))
        })
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
    radiance_seconds: f64,
    pub(super) wfic_own: Vec<Image>,
    wfic_seconds: f64,
    wfic_settings: RenderSettings,
    pub(super) converged: Image,
}

impl SceneReferences {
    /// Radiance's brute-force image, wfic's one per seed and the converged one.
    pub(super) fn render(
        config: &RadianceConfig,
        scene: &Scene,
        rtrace: &Rtrace,
    ) -> Result<Self, String> {
        let (name, n4, k) = (scene.name(), 4 * config.rays, config.reference_stride);
        say!(
            name,
            "radiance reference: -aa 0 -ad {n4}, 2 processes, 1 pixel in {}",
            k * k
        );
        let (radiance, radiance_seconds) = rtrace.reference(n4)?;
        // wfic's references on the same grid: brute force with the matched light samples (cache
        // error), and the converged one (image error) with more light samples and another seed.
        let repeats = config.repeats.max(1);
        say!(
            name,
            "wfic reference: none, {n4} rays, 2 threads, {repeats} seed(s)"
        );
        let wfic_settings = config.settings(config.accuracy, n4, config.light_samples, seed_of(0));
        let rc = wfic_settings
            .cache_config(scene)
            .map_err(|e| e.to_string())?;
        let camera = scene.camera();
        let own: Vec<(Image, f64)> = (0..repeats)
            .map(|i| {
                let s = wfic_settings.clone().seed(seed_of(i));
                render_reference_grid(scene, &camera, &s, rc, 2, k)
            })
            .collect();
        let light = config.converged_light_samples;
        say!(
            name,
            "converged reference: none, {n4} rays, {light} light samples"
        );
        let conv_settings = config.settings(config.accuracy, n4, light, 0xc0ffee);
        Ok(Self {
            converged: render_reference_grid(scene, &camera, &conv_settings, rc, 2, k).0,
            mask: surface_mask(scene, &wfic_settings, k),
            radiance,
            radiance_seconds,
            wfic_seconds: own[0].1,
            wfic_own: own.into_iter().map(|(img, _)| img).collect(),
            wfic_settings,
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
        let radiance = Run {
            seconds: self.radiance_seconds,
            ..Run::new("radiance", Role::Reference, 2, (0.0, 4 * rays), None)
        };
        let wfic = Run {
            seconds: self.wfic_seconds,
            ..Run::new(
                "wfic",
                Role::Reference,
                2,
                (0.0, s.rays_per_record),
                Some(s),
            )
        };
        [
            self.radiance().measured(radiance, &self.radiance, 0),
            self.wfic().measured(wfic, &self.wfic_own[0], 0),
        ]
    }
}

/// The matched settings, Radiance's and wfic's, at 1 and 2 workers, `repeats` renders each, into
/// `runs`; and each renderer's first image at 1 worker, Radiance's first.
pub(super) fn matched(
    config: &RadianceConfig,
    scene: &Scene,
    rtrace: &Rtrace,
    refs: &SceneReferences,
    runs: &mut Vec<Run>,
) -> Result<Vec<Image>, String> {
    let (name, n, a, ar) = (
        scene.name(),
        config.rays,
        config.accuracy,
        config.resolution,
    );
    let repeats = config.repeats.max(1);
    let mut images = Vec::new();
    let mut keep = |(run, img): (Run, Image)| {
        if run.workers == 1 {
            images.push(img);
        }
        runs.push(run);
    };
    for workers in [1, 2] {
        let row = Run::new("radiance", Role::Matched, workers, (a, n), None);
        keep(refs.radiance().frames(&row, repeats as usize, |i| {
            say!(
                name,
                "radiance: -aa {a} -ad {n} -ar {ar}, {workers} process(es), run {} of {repeats}",
                i + 1
            );
            let amb = format!("amb-{workers}-{i}");
            let (img, seconds, records, _) = rtrace.cached((a, n, ar), workers, &amb)?;
            Ok((img, seconds, records))
        })?);
    }
    let base = config.settings(a, n, config.light_samples, 0x5eed);
    for workers in [1, 2] {
        say!(
            name,
            "wfic: wf, a {a}, {n} rays, {workers} thread(s), {repeats} seed(s)"
        );
        keep(
            refs.wfic()
                .wfic_frames(scene, Role::Matched, &base, workers)?,
        );
    }
    Ok(images)
}

/// The sweep of wfic's settings at 2 threads against its reference (whose rays stay `4N`), into
/// `runs`; and each row with its settings, cheapest first.
pub(super) fn sweep(
    config: &RadianceConfig,
    scene: &Scene,
    refs: &References,
    target: f64,
    runs: &mut Vec<Run>,
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
                    runs.push(run.clone());
                    swept.push((run, s));
                }
            }
        }
    }
    swept.sort_by(|x, y| x.0.seconds.total_cmp(&y.0.seconds));
    Ok(swept)
}

/// Swept settings tried for a pick, cheapest first: the frame rendered again at the pick's
/// worker count can err a little above the sweep's 2-thread one (records land in another
/// order).
const PICK_TRIES: usize = 4;

/// A pick: whether it reached Radiance's error, its setting, its frames at 1 and 2 workers
/// measured so far, the worker counts it is the pick of.
struct Pick {
    reached: bool,
    setting: RenderSettings,
    frames: [Option<Run>; 2],
    counts: Vec<usize>,
}

/// Each worker count's pick: the cheapest swept setting at or below Radiance's error at that
/// count (`targets[w]`) whose frame at that count, rendered again, errs at or below it too (up
/// to [`PICK_TRIES`]); the most accurate swept one when none holds. One setting serves both
/// counts when it is the same. Into `runs`: the frames that erred above ([`Role::PickTried`]),
/// then each pick rendered at 1 and 2 workers. Returns the 1-worker pick's setting.
pub(super) fn picks(
    scene: &Scene,
    refs: &References,
    swept: &[(Run, RenderSettings)],
    targets: [f64; 2],
    runs: &mut Vec<Run>,
) -> Result<RenderSettings, String> {
    let key = |s: &RenderSettings| {
        (
            s.accuracy,
            s.rays_per_record,
            s.min_radius_pixels,
            s.smoothing,
        )
    };
    let mut picks: Vec<Pick> = Vec::new();
    for (w, &t) in targets.iter().enumerate() {
        let workers = w + 1;
        let mut found = None;
        for (_, st) in swept
            .iter()
            .filter(|(r, _)| r.cache_error.rel_rmse <= t)
            .take(PICK_TRIES)
        {
            let run = refs.wfic(scene, Role::PickTried, st, workers)?;
            say!(
                scene.name(),
                "{workers}-worker pick {}: cache error {:.2}% (radiance {:.2}%)",
                report::wfic_setting(&run),
                100.0 * run.cache_error.rel_rmse,
                100.0 * t
            );
            if run.cache_error.rel_rmse <= t {
                found = Some((st, run));
                break;
            }
            runs.push(run);
        }
        let reached = found.is_some();
        let (setting, frame) = found.map_or_else(
            || {
                let most = swept.iter().min_by(|x, y| {
                    x.0.cache_error
                        .rel_rmse
                        .total_cmp(&y.0.cache_error.rel_rmse)
                });
                (&most.expect("the sweep is not empty").1, None)
            },
            |(st, run)| (st, Some(run)),
        );
        match picks
            .iter_mut()
            .find(|p| p.reached == reached && key(&p.setting) == key(setting))
        {
            Some(pick) => {
                pick.frames[w] = frame;
                pick.counts.push(workers);
            }
            None => {
                let mut frames = [None, None];
                frames[w] = frame;
                let setting = setting.clone();
                picks.push(Pick {
                    reached,
                    setting,
                    frames,
                    counts: vec![workers],
                });
            }
        }
    }
    for pick in &mut picks {
        let workers = (pick.counts.len() == 1).then(|| pick.counts[0]);
        let role = Role::pick(pick.reached, workers);
        for (w, frame) in pick.frames.iter_mut().enumerate() {
            let run = match frame.take() {
                Some(run) => run,
                None => refs.wfic(scene, role, &pick.setting, w + 1)?,
            };
            runs.push(Run { role, ..run });
        }
    }
    Ok(picks.swap_remove(0).setting)
}
