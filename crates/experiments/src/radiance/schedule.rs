//! The comparison's schedule, one scene's: both renderers' references, the matched settings,
//! the sweep of wfic's settings and each worker count's pick. Each step adds its rows to the
//! scene's runs.

use super::{report, say, RadianceConfig, Role, Rtrace, Run};
use crate::harness::measure::repeat;
use crate::harness::metrics::{image_error, surface_mask, ImageError};
use wfic::cache::Scheme;
use wfic_render::film::Image;
use wfic_render::{render_reference_grid, render_with_scheme, RenderSettings, Scene};

/// The renderer's name in the rows Radiance renders from its own original model.
pub(super) const ORIGINAL: &str = "radiance (original model)";

/// The seed of wfic's repeat `i`: the matched seed first.
fn seed_of(i: u32) -> u64 {
    0x5eed + 0x1_0000 * u64::from(i)
}

/// The images a scene's rows are measured against: each renderer's own brute-force images
/// (wfic: one per seed, repeat `i` against `wfic_own[i]`; Radiance: one, every repeat against
/// it), wfic's converged one, the pixels measured.
pub(super) struct SceneReferences {
    pub(super) mask: Vec<bool>,
    pub(super) radiance: Image,
    /// Radiance's converged image ([`Rtrace::converged`]): its image error's reference.
    pub(super) radiance_converged: Image,
    /// Radiance's brute-force image of its own original model, when it runs.
    pub(super) original: Option<Image>,
    pub(super) wfic_own: Vec<Image>,
    /// The light samples of `wfic_own`: a wfic row with others has no cache error (its direct
    /// light differs from the reference's as well as its indirect).
    pub(super) reference_light: u32,
    pub(super) converged: Image,
}

impl SceneReferences {
    /// Radiance's brute-force image, wfic's one per seed and the converged one; their own rows
    /// into `runs`.
    pub(super) fn render(
        config: &RadianceConfig,
        scene: &Scene,
        rtrace: &Rtrace,
        original: Option<&Rtrace>,
        runs: &mut Vec<Run>,
    ) -> Result<Self, String> {
        let (name, n4, k) = (scene.name(), 4 * config.rays, config.reference_stride);
        say!(
            name,
            "radiance reference: -aa 0 -ad {n4}, 2 processes, 1 pixel in {}",
            k * k
        );
        let (radiance, radiance_seconds) = rtrace.reference(n4)?;
        let passes = config.converged_passes.max(1);
        say!(
            name,
            "radiance converged: -aa 0 -ad {n4} {}, {passes} rays a pixel",
            super::rtrace::CONVERGED_DIRECT
        );
        let (radiance_converged, radiance_converged_seconds) = rtrace.converged(n4, passes)?;
        let original = match original {
            Some(o) => {
                say!(name, "radiance reference of the original model");
                Some(o.reference(n4)?)
            }
            None => None,
        };
        // wfic's references on the same grid: brute force with the matched light samples (cache
        // error), and the converged one (image error) with more light samples and another seed.
        let repeats = config.repeats.max(1);
        say!(
            name,
            "wfic reference: none, {n4} rays, 2 threads, {repeats} seed(s)"
        );
        let s = config.settings(config.accuracy, n4, config.light_samples, seed_of(0));
        let rc = s.cache_config(scene).map_err(|e| e.to_string())?;
        let camera = scene.camera();
        let own: Vec<(Image, f64)> = (0..repeats)
            .map(|i| render_reference_grid(scene, &camera, &s.clone().seed(seed_of(i)), rc, 2, k))
            .collect();
        let (light, nc) = (config.converged_light_samples, n4 * passes);
        say!(
            name,
            "converged reference: none, {nc} rays, {light} light samples"
        );
        let converged_settings = config.settings(config.accuracy, nc, light, 0xc0ffee);
        let wfic_seconds = own[0].1;
        let (converged, converged_seconds) =
            render_reference_grid(scene, &camera, &converged_settings, rc, 2, k);
        let refs = Self {
            converged,
            radiance_converged,
            mask: surface_mask(scene, &s, k),
            radiance,
            original: original.as_ref().map(|(img, _)| img.clone()),
            wfic_own: own.into_iter().map(|(img, _)| img).collect(),
            reference_light: config.light_samples,
        };
        let radiance = Run::new("radiance", Role::Reference, 2, (0.0, n4), None);
        let wfic = Run::new("wfic", Role::Reference, 2, (0.0, n4), Some(&s));
        let radiance_c = Run::new("radiance", Role::Converged, 2, (0.0, n4), None);
        let wfic_c = Run::new(
            "wfic",
            Role::Converged,
            2,
            (0.0, nc),
            Some(&converged_settings),
        );
        runs.extend([
            refs.measured(radiance, &refs.radiance, 0, radiance_seconds),
            refs.measured(wfic, &refs.wfic_own[0], 0, wfic_seconds),
            refs.measured(
                radiance_c,
                &refs.radiance_converged,
                0,
                radiance_converged_seconds,
            ),
            refs.measured(wfic_c, &refs.converged, 0, converged_seconds),
        ]);
        if let (Some(img), Some((_, seconds))) = (&refs.original, &original) {
            let row = Run::new(ORIGINAL, Role::Reference, 2, (0.0, n4), None);
            runs.push(refs.measured(row, img, 0, *seconds));
        }
        Ok(refs)
    }

    /// `run` rendered as `img` in `seconds`: `img` against its renderer's own reference of
    /// `repeat` and the converged one.
    fn measured(&self, run: Run, img: &Image, repeat: usize, seconds: f64) -> Run {
        let own = match (run.renderer, &self.original) {
            ("radiance", _) => &self.radiance,
            (ORIGINAL, Some(original)) => original,
            _ => &self.wfic_own[repeat],
        };
        let own_converged = match run.renderer {
            "radiance" => Some(&self.radiance_converged),
            ORIGINAL => None,
            _ => Some(&self.converged),
        };
        let nan = ImageError {
            rel_rmse: f64::NAN,
            mean_rel: f64::NAN,
        };
        let cache_error = if run.renderer == "wfic" && run.light_samples != self.reference_light {
            nan
        } else {
            image_error(img, own, &self.mask)
        };
        Run {
            seconds,
            cache_error,
            image_error: image_error(img, &self.converged, &self.mask),
            own_image_error: own_converged.map_or(nan, |c| image_error(img, c, &self.mask)),
            cache_error_range: (cache_error.rel_rmse, cache_error.rel_rmse),
            ..run
        }
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
            let run = self.measured(
                Run {
                    records,
                    ..row.clone()
                },
                &img,
                i,
                seconds,
            );
            first.get_or_insert(img);
            Ok::<_, String>(run)
        })?;
        Ok((Run::combine(runs), first.expect("at least one repeat")))
    }

    /// wfic frames (`wf`, a fresh cache) of `scene` at settings `s` on `workers` threads, one
    /// per own reference (each with that reference's seed), as one row; and the first image.
    pub(super) fn wfic(
        &self,
        scene: &Scene,
        role: Role,
        s: &RenderSettings,
        workers: usize,
    ) -> Result<(Run, Image), String> {
        let setting = (s.accuracy, s.rays_per_record);
        let row = Run::new("wfic", role, workers, setting, Some(s));
        self.frames(&row, self.wfic_own.len(), |i| {
            let s = s.clone().seed(seed_of(i as u32));
            let config = s.cache_config(scene).map_err(|e| e.to_string())?;
            let f = render_with_scheme(Scheme::Wf, scene, &scene.camera(), &s, config, workers).0;
            Ok((f.image, f.stats.seconds, f.stats.cache_records))
        })
    }
}

/// The matched settings, Radiance's and wfic's, at 1 and 2 workers, `repeats` renders each, into
/// `runs`; and each renderer's first image at 1 worker, Radiance's first.
pub(super) fn matched(
    config: &RadianceConfig,
    scene: &Scene,
    rtrace: &Rtrace,
    original: Option<&Rtrace>,
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
        if run.workers == 1 && run.renderer != ORIGINAL {
            images.push(img);
        }
        runs.push(run);
    };
    let models = std::iter::once(("radiance", rtrace)).chain(original.map(|o| (ORIGINAL, o)));
    for (renderer, model) in models {
        for workers in [1, 2] {
            let row = Run::new(renderer, Role::Matched, workers, (a, n), None);
            let frames = refs.frames(&row, repeats as usize, |i| {
                say!(
                    name,
                    "{renderer}: -aa {a} -ad {n} -ar {ar}, {workers} process(es), run {} of \
                     {repeats}",
                    i + 1
                );
                let amb = format!("amb-{workers}-{i}");
                let (img, seconds, records, _) = model.cached((a, n, ar), workers, &amb)?;
                Ok((img, seconds, records))
            })?;
            keep(frames);
        }
    }
    let base = config.settings(a, n, config.light_samples, 0x5eed);
    for workers in [1, 2] {
        say!(
            name,
            "wfic: wf, a {a}, {n} rays, {workers} thread(s), {repeats} seed(s)"
        );
        keep(refs.wfic(scene, Role::Matched, &base, workers)?);
    }
    Ok(images)
}

/// The sweep of wfic's settings at 2 threads against its reference (whose rays stay `4N`), into
/// `runs`; and each row with its settings, cheapest first.
pub(super) fn sweep(
    config: &RadianceConfig,
    scene: &Scene,
    refs: &SceneReferences,
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
                    let (run, _) = refs.wfic(scene, Role::Sweep, &s, 2)?;
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

/// A worker count's pick: the cheapest swept setting (`swept` is cheapest first) at or below
/// Radiance's error `target` whose frame at that count, rendered again, errs at or below it too
/// (up to [`PICK_TRIES`]; the frames that erred above go to `runs` as [`Role::PickTried`]);
/// the most accurate swept one when none holds. Whether it reached `target`, its setting, and
/// its frame at that count when it did.
fn pick<'s>(
    scene: &Scene,
    refs: &SceneReferences,
    swept: &'s [(Run, RenderSettings)],
    (workers, target): (usize, f64),
    runs: &mut Vec<Run>,
) -> Result<(bool, &'s RenderSettings, Option<Run>), String> {
    for (_, st) in swept
        .iter()
        .filter(|(r, _)| r.cache_error.rel_rmse <= target)
        .take(PICK_TRIES)
    {
        let (run, _) = refs.wfic(scene, Role::PickTried, st, workers)?;
        say!(
            scene.name(),
            "{workers}-worker pick {}: cache error {:.2}% (radiance {:.2}%)",
            report::wfic_setting(&run),
            100.0 * run.cache_error.rel_rmse,
            100.0 * target
        );
        if run.cache_error.rel_rmse <= target {
            return Ok((true, st, Some(run)));
        }
        runs.push(run);
    }
    let error = |x: &&(Run, RenderSettings)| x.0.cache_error.rel_rmse;
    let most = swept.iter().min_by(|x, y| error(x).total_cmp(&error(y)));
    Ok((false, &most.expect("the sweep is not empty").1, None))
}

/// Each worker count's pick (`targets[w]`: Radiance's error at `w + 1` workers), one setting for
/// both counts when they pick the same, rendered at 1 and 2 workers into `runs`. Returns the
/// 1-worker pick's setting.
pub(super) fn picks(
    scene: &Scene,
    refs: &SceneReferences,
    swept: &[(Run, RenderSettings)],
    targets: [f64; 2],
    runs: &mut Vec<Run>,
) -> Result<RenderSettings, String> {
    let one = pick(scene, refs, swept, (1, targets[0]), runs)?;
    let two = pick(scene, refs, swept, (2, targets[1]), runs)?;
    let key = |s: &RenderSettings| {
        (
            s.accuracy,
            s.rays_per_record,
            s.min_radius_pixels,
            s.smoothing,
        )
    };
    let setting = one.1.clone();
    // (role, setting, its frames at 1 and 2 workers measured so far)
    let picks = if one.0 == two.0 && key(one.1) == key(two.1) {
        vec![(Role::pick(one.0, None), one.1, [one.2, two.2])]
    } else {
        vec![
            (Role::pick(one.0, Some(1)), one.1, [one.2, None]),
            (Role::pick(two.0, Some(2)), two.1, [None, two.2]),
        ]
    };
    for (role, st, frames) in picks {
        for (w, frame) in frames.into_iter().enumerate() {
            let run = match frame {
                Some(run) => run,
                None => refs.wfic(scene, role, st, w + 1)?.0,
            };
            runs.push(Run { role, ..run });
        }
    }
    Ok(setting)
}

/// The settings of the cache sweep's fastest front (`swept` is cheapest first): each swept
/// setting that errs less than every faster one; at most `n` of them, spread evenly over the
/// front from the fastest to the most accurate.
pub(super) fn fastest_front(swept: &[(Run, RenderSettings)], n: usize) -> Vec<&RenderSettings> {
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for (run, s) in swept {
        if run.cache_error.rel_rmse < best {
            best = run.cache_error.rel_rmse;
            front.push(s);
        }
    }
    let last = front.len().saturating_sub(1);
    match n {
        _ if front.len() <= n => front,
        0 => Vec::new(),
        1 => vec![front[last]],
        _ => (0..n).map(|i| front[i * last / (n - 1)]).collect(),
    }
}

/// The image sweep: each setting of the cache sweep's fastest front ([`fastest_front`]) with
/// each of the config's image light-sample counts, at 2 threads, into `runs`. A finer cache with
/// more light samples can reach an image error that neither alone does.
pub(super) fn image_sweep(
    config: &RadianceConfig,
    scene: &Scene,
    refs: &SceneReferences,
    swept: &[(Run, RenderSettings)],
    runs: &mut Vec<Run>,
) -> Result<(), String> {
    for s in fastest_front(swept, config.image_front) {
        for &l in &config.image_light_samples {
            let s = s.clone().light_samples(l);
            let (run, _) = refs.wfic(scene, Role::ImageSweep, &s, 2)?;
            say!(
                scene.name(),
                "image sweep {} L {l}: {:.3} s, image error {:.2}%",
                report::wfic_setting(&run),
                run.seconds,
                100.0 * run.own_image_error.rel_rmse
            );
            runs.push(run);
        }
    }
    Ok(())
}

/// wfic's settings of the measured row `run`.
fn settings_of(config: &RadianceConfig, run: &Run) -> RenderSettings {
    let mut s = config.settings(run.accuracy, run.rays, run.light_samples, seed_of(0));
    s.min_radius_pixels = run.min_radius_pixels;
    s.smoothing = run.smoothing;
    s
}

/// The cheapest measured wfic setting (its rows at 2 threads: the matched one, the sweep's over
/// the cache's settings, the light study's over the light samples, the image sweep's) whose image error against
/// wfic's converged image is at or below `target`, and `true`; when none is, the one of least
/// image error, and `false`.
pub(super) fn image_candidate(runs: &[Run], target: f64) -> Option<(bool, &Run)> {
    let candidates = || {
        runs.iter().filter(|r| {
            r.renderer == "wfic"
                && r.workers == 2
                && matches!(
                    r.role,
                    Role::Matched | Role::Sweep | Role::LightSamples | Role::ImageSweep
                )
        })
    };
    let reached = candidates()
        .filter(|r| r.own_image_error.rel_rmse <= target)
        .min_by(|a, b| a.seconds.total_cmp(&b.seconds));
    match reached {
        Some(r) => Some((true, r)),
        None => candidates()
            .min_by(|a, b| {
                let e = |r: &Run| r.own_image_error.rel_rmse;
                e(a).total_cmp(&e(b))
            })
            .map(|r| (false, r)),
    }
}

/// Time at equal image error: for 1 and 2 workers, [`image_candidate`] against Radiance's image
/// error (against its own converged image) at that count, rendered again at that count (its
/// repeats as every row's), into `runs`.
pub(super) fn image_picks(
    config: &RadianceConfig,
    scene: &Scene,
    refs: &SceneReferences,
    runs: &mut Vec<Run>,
) -> Result<(), String> {
    for workers in [1, 2] {
        let Some(rad) = super::find(runs, "radiance", Role::Matched, workers) else {
            continue;
        };
        let target = rad.own_image_error.rel_rmse;
        let Some((reached, run)) = image_candidate(runs, target) else {
            continue;
        };
        let s = settings_of(config, run);
        let role = Role::ImagePick { reached, workers };
        let (row, _) = refs.wfic(scene, role, &s, workers)?;
        say!(
            scene.name(),
            "{}: {:.3} s, image error {:.2}% (radiance {:.2}%)",
            role.name(),
            row.seconds,
            100.0 * row.own_image_error.rel_rmse,
            100.0 * target
        );
        runs.push(row);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A wfic row has a cache error only at its reference's light samples: at others its direct
    /// light differs from the reference's too, and the difference is no cache's. Radiance's rows
    /// always have one.
    #[test]
    fn a_cache_error_needs_the_references_light_samples() {
        let flat = |v: f32| {
            let mut img = Image::new(2, 2);
            for (x, y) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                img.set(x, y, Vec3::splat(v));
            }
            img
        };
        let refs = SceneReferences {
            mask: vec![true; 4],
            radiance: flat(1.0),
            radiance_converged: flat(1.0),
            original: None,
            wfic_own: vec![flat(1.0)],
            reference_light: 8,
            converged: flat(1.0),
        };
        let row = |renderer, light| {
            let s = RenderSettings::new(2, 2).light_samples(light);
            let run = Run::new(renderer, Role::Sweep, 2, (0.15, 512), Some(&s));
            refs.measured(run, &flat(1.1), 0, 1.0)
        };
        let e = row("wfic", 8).cache_error.rel_rmse;
        assert!((e - 0.1).abs() < 1e-5, "{e}");
        assert!(row("wfic", 16).cache_error.rel_rmse.is_nan());
        assert!((row("radiance", 16).cache_error.rel_rmse - 0.1).abs() < 1e-5);
        // The image errors stay measured whatever the light samples.
        assert!((row("wfic", 16).own_image_error.rel_rmse - 0.1).abs() < 1e-5);
    }
}
