//! `wfic compare radiance`: the same scene rendered by Radiance (Ward's own irradiance cache,
//! `rtrace -ab 1`) and by wfic (`wf`) at matched settings, each against its own brute-force
//! image, then the time ratio at equal error ([`compare_scene`]'s schedule; what is matched and
//! the two errors: `docs/experiments.md#radiance-side-by-side`). Report: [`report`].

pub mod export;
pub mod report;
pub mod rtrace;
pub(crate) mod schedule;

pub use export::{write_rad, Export, Source};
pub use rtrace::{shared_ambient, RadianceBin, Rtrace, SharedAmbientRun};
use schedule::{image_picks, image_sweep, matched, picks, sweep, SceneReferences};

use crate::harness::metrics::{image_error, masked_mean, ImageError};
use crate::harness::stats::{self, median};
use crate::harness::{Machine, Output, Provenance};
use std::path::Path;
use wfic_render::{scenes, RenderSettings, Scene};

/// What one comparison runs.
#[derive(Clone, Debug, PartialEq)]
pub struct RadianceConfig {
    /// Built-in scenes to compare, in order.
    pub scenes: Vec<String>,
    /// Image width and height.
    pub size: (u32, u32),
    /// Hemisphere rays per record (`-ad`; wfic `rays_per_record`).
    pub rays: u32,
    /// Ward's accuracy (`-aa`; wfic `accuracy`).
    pub accuracy: f32,
    /// Radiance's ambient resolution (`-ar`).
    pub resolution: u32,
    /// wfic's light samples per primary hit in the matched runs.
    pub light_samples: u32,
    /// The sweep's accuracies as multiples of `accuracy`, above 1 as well as below (fewer
    /// records of more rays can be both cheaper and more accurate).
    pub sweep_accuracy_scales: Vec<f32>,
    /// The sweep's rays per record as multiples of `rays`, in steps fine enough not to miss
    /// the cheapest setting at Radiance's error.
    pub sweep_rays_scales: Vec<f32>,
    /// The light-sample counts of the image-noise study, from 1.
    pub light_sweep: Vec<u32>,
    /// Light samples of wfic's converged reference.
    pub converged_light_samples: u32,
    /// Renders averaged into each converged reference: Radiance traces each pixel's ray this many
    /// times with jittered sources, each at `-ad 4N`; wfic's converged image takes this many
    /// times `4N` rays. One jittered ray a pixel leaves a small bright source's shadows noisy.
    pub converged_passes: u32,
    /// The light-sample counts the image sweep gives each setting of the cache sweep's fastest
    /// front (the settings no faster setting beats on cache error): the candidates, beside the
    /// matched, swept and light-study rows, for the time at equal image error.
    pub image_light_samples: Vec<u32>,
    /// At most this many settings of that front, spread evenly over it.
    pub image_front: usize,
    /// The sweep's lower radius clamps in pixel footprints (wfic's `min_radius_pixels`).
    pub sweep_min_radius: Vec<f32>,
    /// The sweep's smoothings ([`RenderSettings::smoothing`]; the matched runs keep 1).
    pub sweep_smoothing: Vec<f32>,
    /// The references are traced, and every error measured, at one pixel of each `stride` x
    /// `stride` block.
    pub reference_stride: u32,
    /// Keep the exported scene, rays and ambient files (`DIR/work-NAME/`).
    pub keep_work: bool,
    /// Renders of every measured setting (one frame's error and time move by the goals' margins).
    pub repeats: u32,
    /// A copy of Radiance's source tree (`LBNL-ETA/Radiance`, branch `auxiliary`): the office
    /// and the desk are then also rendered by Radiance from its own original model
    /// ([`Rtrace::prepare_original`]), in rows of their own.
    pub radiance_tree: Option<std::path::PathBuf>,
}
impl RadianceConfig {
    /// The full comparison: 256 x 256, `rtrace -ab 1 -ad 512 -aa 0.15 -ar 128`, references at
    /// one pixel in 16.
    pub fn full(scenes: Vec<String>) -> Self {
        Self {
            scenes,
            size: (256, 256),
            rays: 512,
            accuracy: 0.15,
            resolution: 128,
            light_samples: 8,
            sweep_accuracy_scales: vec![2.0, 4.0 / 3.0, 1.0, 2.0 / 3.0],
            sweep_rays_scales: vec![0.5, 0.5625, 0.625, 0.75, 0.875, 1.0, 1.25, 1.5, 2.0],
            sweep_min_radius: vec![6.0, 12.0],
            sweep_smoothing: vec![1.0, 1.5],
            light_sweep: vec![1, 2, 4, 8, 16, 32, 64, 128],
            converged_light_samples: 1024,
            converged_passes: 8,
            image_light_samples: vec![16, 32, 64, 128],
            image_front: 6,
            reference_stride: 4,
            keep_work: false,
            repeats: 3,
            radiance_tree: None,
        }
    }

    /// A smoke run (CI): 96 x 96, 128 rays per record, a short sweep, references at one
    /// pixel in 4.
    pub fn quick(scenes: Vec<String>) -> Self {
        Self {
            size: (96, 96),
            rays: 128,
            sweep_accuracy_scales: vec![4.0 / 3.0, 1.0],
            sweep_rays_scales: vec![0.5, 0.75, 1.0, 1.5, 2.0],
            sweep_min_radius: vec![6.0, 12.0],
            light_sweep: vec![8, 32],
            converged_light_samples: 128,
            converged_passes: 2,
            image_light_samples: vec![32],
            image_front: 2,
            reference_stride: 2,
            repeats: 1,
            ..Self::full(scenes)
        }
    }

    /// wfic's settings at this size.
    fn settings(&self, accuracy: f32, rays: u32, light: u32, seed: u64) -> RenderSettings {
        RenderSettings::new(self.size.0, self.size.1)
            .accuracy(accuracy)
            .rays_per_record(rays)
            .light_samples(light)
            .seed(seed)
            .quiet(true)
    }
}

/// What a row of the comparison is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// A brute-force reference (no cache, `4N` rays).
    Reference,
    /// The matched settings.
    Matched,
    /// A setting of the sweep (wfic, 2 threads).
    Sweep,
    /// A swept setting rendered again at a worker count whose frame erred above Radiance's.
    PickTried,
    /// A worker count's pick, rendered at 1 and 2 workers: `reached` when it errs at or below
    /// Radiance's (`equal-error`), else the most accurate swept one (`most-accurate`);
    /// `workers` names the count it is the pick of when the two counts' picks differ.
    Pick {
        /// Whether it reached Radiance's cache error.
        reached: bool,
        /// The worker count it is the pick of (`None`: both).
        workers: Option<usize>,
    },
    /// The light-sample study at the pick.
    LightSamples,
    /// The image sweep: a setting of the cache sweep's fastest front with more light samples
    /// (wfic, 2 threads).
    ImageSweep,
    /// A renderer's converged image (no cache; Radiance with jittered, finely subdivided
    /// sources; wfic with many light samples): what its image error is measured against.
    Converged,
    /// The cheapest measured wfic setting whose image error is at or below Radiance's, against
    /// each renderer's own converged image, rendered again at `workers` (`reached`: it is;
    /// else the setting of least image error).
    ImagePick {
        /// Whether it reached Radiance's image error.
        reached: bool,
        /// The worker count it is the pick of.
        workers: usize,
    },
}

impl Role {
    /// [`Role::Pick`].
    pub fn pick(reached: bool, workers: Option<usize>) -> Self {
        Role::Pick { reached, workers }
    }

    /// The name tables and the CSV use.
    pub fn name(self) -> &'static str {
        match self {
            Role::Reference => "reference",
            Role::Matched => "matched",
            Role::Sweep => "sweep",
            Role::PickTried => "pick-tried",
            Role::LightSamples => "light-samples",
            Role::ImageSweep => "image-sweep",
            Role::Converged => "converged",
            Role::ImagePick {
                reached: true,
                workers: 1,
            } => "equal-image-1",
            Role::ImagePick { reached: true, .. } => "equal-image-2",
            Role::ImagePick { workers: 1, .. } => "least-image-error-1",
            Role::ImagePick { .. } => "least-image-error-2",
            Role::Pick { reached, workers } => match (reached, workers) {
                (true, None) => "equal-error",
                (true, Some(1)) => "equal-error-1",
                (true, Some(_)) => "equal-error-2",
                (false, None) => "most-accurate",
                (false, Some(1)) => "most-accurate-1",
                (false, Some(_)) => "most-accurate-2",
            },
        }
    }
}

/// One measured row: a render, or the renders of one setting.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// `radiance` or `wfic`.
    pub renderer: &'static str,
    /// What the row is.
    pub role: Role,
    /// Workers (`rtrace -n`, wfic threads).
    pub workers: usize,
    /// Accuracy.
    pub accuracy: f32,
    /// Rays per record.
    pub rays: u32,
    /// wfic light samples (0 for Radiance: deterministic).
    pub light_samples: u32,
    /// wfic's lower radius clamp in pixel footprints (0 for Radiance, which uses `-ar`).
    pub min_radius_pixels: f32,
    /// wfic's smoothing ([`RenderSettings::smoothing`]; 1 for Radiance).
    pub smoothing: f32,
    /// Wall time of the frame (Radiance: the `rtrace` process, loading the octree included).
    pub seconds: f64,
    /// Cache records after the frame.
    pub records: usize,
    /// Against the renderer's own brute-force image.
    pub cache_error: ImageError,
    /// Against the converged reference (wfic's: the common one).
    pub image_error: ImageError,
    /// Against the renderer's own converged image (for wfic the same as `image_error`; NaN
    /// where the renderer has none, Radiance's original model).
    pub own_image_error: ImageError,
    /// Renders behind the row ([`RadianceConfig::repeats`]): `seconds` is their median,
    /// `records` their median, the errors their mean.
    pub repeats: u32,
    /// The smallest and largest cache error (relative RMSE) among them.
    pub cache_error_range: (f64, f64),
}

impl Run {
    /// A row of `renderer` in `role` at `workers` and `(accuracy, rays)`, with wfic's settings
    /// `s` (`None`: Radiance); not yet rendered.
    fn new(
        renderer: &'static str,
        role: Role,
        workers: usize,
        (accuracy, rays): (f32, u32),
        s: Option<&RenderSettings>,
    ) -> Self {
        Run {
            renderer,
            role,
            workers,
            accuracy,
            rays,
            light_samples: s.map_or(0, |s| s.light_samples),
            min_radius_pixels: s.map_or(0.0, |s| s.min_radius_pixels),
            smoothing: s.map_or(1.0, |s| s.smoothing),
            seconds: 0.0,
            records: 0,
            cache_error: ImageError::default(),
            image_error: ImageError::default(),
            own_image_error: ImageError::default(),
            repeats: 1,
            cache_error_range: (0.0, 0.0),
        }
    }

    /// One row from the renders of one setting: the median time and record count, the mean
    /// errors, the range of the cache error.
    pub fn combine(runs: Vec<Run>) -> Run {
        assert!(!runs.is_empty(), "a row needs a render");
        let mean_error = |e: fn(&Run) -> ImageError| ImageError {
            rel_rmse: stats::mean(runs.iter().map(|r| e(r).rel_rmse)),
            mean_rel: stats::mean(runs.iter().map(|r| e(r).mean_rel)),
        };
        let records: Vec<f64> = runs.iter().map(|r| r.records as f64).collect();
        Run {
            seconds: median(&runs.iter().map(|r| r.seconds).collect::<Vec<_>>()),
            records: median(&records).round() as usize,
            cache_error: mean_error(|r| r.cache_error),
            image_error: mean_error(|r| r.image_error),
            own_image_error: mean_error(|r| r.own_image_error),
            cache_error_range: stats::range(runs.iter().map(|r| r.cache_error.rel_rmse)),
            repeats: runs.iter().map(|r| r.repeats).sum(),
            ..runs[0].clone()
        }
    }
}

/// The run of `renderer` in `role` at `workers` among `runs`, if measured.
fn find<'a>(runs: &'a [Run], renderer: &str, role: Role, workers: usize) -> Option<&'a Run> {
    runs.iter()
        .find(|r| r.renderer == renderer && r.role == role && r.workers == workers)
}

/// One scene's comparison.
#[derive(Clone, Debug)]
pub struct SceneComparison {
    /// The scene.
    pub scene: String,
    /// Triangles.
    pub triangles: usize,
    /// `real` or `stand-in`.
    pub source: &'static str,
    /// Seconds `rtrace` takes to load the octree and trace one ray (included in its times).
    pub radiance_load_seconds: f64,
    /// Seconds of `oconv` (not included anywhere, like wfic's BVH build).
    pub oconv_seconds: f64,
    /// Emitting triangles of the scene, the light sources Radiance was given for them
    /// (spheres, polygons), and the export's emitted power over the scene's
    /// ([`export::Export`]).
    pub sources: (usize, usize, usize, f64),
    /// Every measured row.
    pub runs: Vec<Run>,
    /// Radiance's brute-force image against wfic's converged one (the cross-check that both
    /// render the same scene).
    pub cross_check: ImageError,
    /// Mean luminance of Radiance's brute-force image over wfic's converged one (the masked
    /// pixels): 1 when both render the same light, whatever the noise.
    pub mean_ratio: f64,
}

impl SceneComparison {
    /// The run of `renderer` in `role` at `workers`, if measured.
    pub fn find(&self, renderer: &str, role: Role, workers: usize) -> Option<&Run> {
        find(&self.runs, renderer, role, workers)
    }
}

/// A progress line, `[SCENE] what`, to standard error.
macro_rules! say {
    ($scene:expr, $($what:tt)*) => {
        eprintln!("[{}] {}", $scene, format_args!($($what)*))
    };
}
pub(crate) use say;

/// Runs the comparison and writes `radiance.md`, `radiance.csv` and one side-by-side PNG per
/// scene into `out_dir`, the files headed by the provenance of `command`.
pub fn run(config: &RadianceConfig, out_dir: &Path, command: &str) -> Result<(), String> {
    let bin = RadianceBin::find()?;
    // Radiance's processes and wfic's threads: 1 and 2 workers.
    let provenance = Provenance::new(command, &Machine::detect(), &[1, 2], &[]);
    let out = Output::new(out_dir, &provenance)?;
    let results = config
        .scenes
        .iter()
        .map(|name| compare_scene(&bin, config, &scenes::load(name)?, out_dir))
        .collect::<Result<Vec<_>, String>>()?;
    let title = "wfic against Radiance, side by side";
    let md = report::markdown(config, &results, &bin.version());
    out.markdown("radiance.md", title, &md)?;
    out.csv("radiance.csv", &report::csv(&results))?;
    let dir = out_dir.display();
    eprintln!("wrote {dir}/radiance.md, radiance.csv and the side-by-side images");
    Ok(())
}

/// Compares one scene (what [`run`] does per scene), its scratch files under
/// `out_dir/work-NAME/`, its side-by-side image in `out_dir`.
pub fn compare_scene(
    bin: &RadianceBin,
    config: &RadianceConfig,
    scene: &Scene,
    out_dir: &Path,
) -> Result<SceneComparison, String> {
    let name = scene.name().to_owned();
    let work = out_dir.join(format!("work-{name}"));
    let base = config.settings(config.accuracy, config.rays, config.light_samples, 0x5eed);
    let triangles = scene.triangle_count();
    say!(&name, "exporting {triangles} triangles to Radiance");
    let rtrace = Rtrace::prepare(bin, scene, &base, config.reference_stride, &work)?;
    let original = match (&config.radiance_tree, name.as_str()) {
        (Some(tree), "desk" | "office") => {
            say!(&name, "Radiance's original model from {}", tree.display());
            let dir = work.join("original");
            let stride = config.reference_stride;
            Some(Rtrace::prepare_original(
                bin, tree, scene, &base, stride, &dir,
            )?)
        }
        _ => None,
    };
    let load = rtrace.load_seconds()?;
    let mut runs = Vec::new();
    let refs = SceneReferences::render(config, scene, &rtrace, original.as_ref(), &mut runs)?;
    let images = matched(config, scene, &rtrace, original.as_ref(), &refs, &mut runs)?;
    // Radiance's cache error at 1 and at 2 workers: each worker count gets the cheapest sweep
    // setting at or below its own (2 workers usually err less: they place more records).
    let targets = [1, 2].map(|w| {
        let radiance = find(&runs, "radiance", Role::Matched, w).expect("measured above");
        radiance.cache_error.rel_rmse
    });
    let swept = sweep(config, scene, &refs, targets[0], &mut runs)?;
    let pick = picks(scene, &refs, &swept, targets, &mut runs)?;
    // Image noise against light samples, at the 1-worker pick, 1 and 2 threads.
    for &l in &config.light_sweep {
        let s = pick.clone().light_samples(l);
        for workers in [1, 2] {
            let (run, _) = refs.wfic(scene, Role::LightSamples, &s, workers)?;
            if workers == 2 {
                let (secs, e) = (run.seconds, 100.0 * run.image_error.rel_rmse);
                say!(&name, "light samples {l}: {secs:.3} s, image error {e:.2}%");
            }
            runs.push(run);
        }
    }
    image_sweep(config, scene, &refs, &swept, &mut runs)?;
    image_picks(config, scene, &refs, &mut runs)?;
    report::write_side_by_side(
        &out_dir.join(format!("{name}-side-by-side.png")),
        [&images[0], &images[1]],
        [&refs.radiance, &refs.wfic_own[0]],
        &refs.mask,
        config.reference_stride,
    )?;
    if !config.keep_work {
        std::fs::remove_dir_all(&work).ok();
    }
    Ok(SceneComparison {
        triangles,
        source: scenes::info(&name).map_or("file", |i| i.source.name()),
        radiance_load_seconds: load,
        oconv_seconds: rtrace.oconv_seconds,
        sources: {
            let e = rtrace.export.as_ref().expect("wfic's export");
            let power = e.export_power.element_sum() / e.scene_power.element_sum();
            (
                e.emitting_triangles,
                e.spheres(),
                e.sources.len() - e.spheres(),
                power,
            )
        },
        runs,
        cross_check: image_error(&refs.radiance, &refs.converged, &refs.mask),
        mean_ratio: masked_mean(&refs.radiance, &refs.mask)
            / masked_mean(&refs.converged, &refs.mask),
        scene: name,
    })
}

#[cfg(test)]
mod tests {
    use super::report::{csv, markdown, speed_goal};
    use super::*;

    /// The role named `name`.
    fn r(name: &str) -> Role {
        let pick = |reached, workers| Role::Pick { reached, workers };
        [
            Role::Reference,
            Role::Matched,
            Role::Sweep,
            Role::PickTried,
            Role::LightSamples,
            Role::ImageSweep,
            pick(true, None),
            pick(true, Some(1)),
            pick(true, Some(2)),
            pick(false, None),
            pick(false, Some(1)),
            pick(false, Some(2)),
        ]
        .into_iter()
        .find(|r| r.name() == name)
        .expect("a role's name")
    }

    /// One render of `renderer`'s `role` at `workers`: a 0.15, N 512, 8 light samples, 6 px,
    /// 100 records, every error `error`. Tests change the fields they are about.
    fn one_run(
        renderer: &'static str,
        role: Role,
        workers: usize,
        seconds: f64,
        error: f64,
    ) -> Run {
        let e = ImageError {
            rel_rmse: error,
            mean_rel: error,
        };
        Run {
            renderer,
            role,
            workers,
            accuracy: 0.15,
            rays: 512,
            light_samples: 8,
            min_radius_pixels: 6.0,
            smoothing: 1.0,
            seconds,
            records: 100,
            cache_error: e,
            image_error: e,
            own_image_error: e,
            repeats: 1,
            cache_error_range: (error, error),
        }
    }

    /// The equal-image pick: the cheapest 2-thread wfic row at or below the target, else the
    /// one of least image error; a 1-thread row is no candidate.
    #[test]
    fn the_image_pick_is_the_cheapest_at_or_below_radiance_else_the_least_error() {
        use super::schedule::image_candidate;
        let runs = vec![
            one_run("wfic", r("sweep"), 2, 1.0, 0.05),
            one_run("wfic", r("light-samples"), 2, 0.5, 0.08),
            one_run("wfic", r("light-samples"), 2, 2.0, 0.03),
            one_run("wfic", r("light-samples"), 1, 0.1, 0.01),
            one_run("radiance", r("matched"), 2, 0.01, 0.01),
        ];
        assert_eq!(image_candidate(&runs, 0.06), Some((true, &runs[0])));
        assert_eq!(image_candidate(&runs, 0.09), Some((true, &runs[1])));
        assert_eq!(image_candidate(&runs, 0.01), Some((false, &runs[2])));
        // The image sweep's rows are candidates too: a finer cache with more light samples.
        let mut more = runs.clone();
        more.push(one_run("wfic", r("image-sweep"), 2, 1.5, 0.02));
        assert_eq!(image_candidate(&more, 0.025), Some((true, &more[5])));
        let pick = |reached, seconds, error| Run {
            role: Role::ImagePick {
                reached,
                workers: 1,
            },
            ..one_run("wfic", r("sweep"), 1, seconds, error)
        };
        let rad = one_run("radiance", r("matched"), 1, 10.0, 0.05);
        assert_eq!(report::image_goal(&pick(true, 0.9, 0.05), &rad), "yes");
        assert_eq!(report::image_goal(&pick(true, 1.1, 0.05), &rad), "NO");
        assert_eq!(
            report::image_goal(&pick(false, 0.1, 0.08), &rad),
            "NO: error above"
        );
    }

    /// The image sweep's settings: those of the cache sweep that err less than every faster
    /// one, spread over that front from the fastest to the most accurate.
    #[test]
    fn the_image_sweep_takes_the_fastest_front_spread_evenly() {
        use super::schedule::fastest_front;
        // (seconds, cache error), cheapest first as the sweep returns them; rays tell them apart.
        let swept: Vec<(Run, RenderSettings)> = [
            (0.1, 0.05),
            (0.2, 0.06),
            (0.3, 0.04),
            (0.4, 0.04),
            (0.5, 0.03),
            (0.6, 0.02),
            (0.7, 0.025),
            (0.8, 0.01),
        ]
        .into_iter()
        .enumerate()
        .map(|(i, (t, e))| {
            let run = one_run("wfic", r("sweep"), 2, t, e);
            (run, RenderSettings::new(8, 8).rays_per_record(i as u32 + 1))
        })
        .collect();
        let rays = |n| -> Vec<u32> {
            fastest_front(&swept, n)
                .iter()
                .map(|s| s.rays_per_record)
                .collect()
        };
        // The front: 0.05, 0.04 (the first of two), 0.03, 0.02, 0.01.
        assert_eq!(rays(8), vec![1, 3, 5, 6, 8]);
        assert_eq!(rays(3), vec![1, 5, 8]);
        assert_eq!(rays(2), vec![1, 8]);
        assert_eq!(rays(1), vec![8]);
        assert!(rays(0).is_empty());
    }

    #[test]
    fn the_speed_goal_needs_the_error_at_or_below_and_a_tenth_of_the_time() {
        let run = |seconds: f64, error: f64| one_run("wfic", r("equal-error"), 1, seconds, error);
        let rad = run(10.0, 0.02);
        assert_eq!(speed_goal(r("equal-error"), &run(1.0, 0.02), &rad), "yes");
        assert_eq!(
            speed_goal(r("equal-error-2"), &run(0.5, 0.019), &rad),
            "yes"
        );
        assert_eq!(speed_goal(r("equal-error"), &run(1.01, 0.01), &rad), "NO");
        assert_eq!(
            speed_goal(r("equal-error-1"), &run(0.5, 0.0201), &rad),
            "NO: error above"
        );
        assert_eq!(speed_goal(r("most-accurate"), &run(0.5, 0.01), &rad), "NO");
    }

    #[test]
    fn a_row_is_the_median_time_and_the_mean_error_of_its_renders() {
        let run = |seconds: f64, error: f64, records: usize| Run {
            records,
            cache_error: ImageError {
                rel_rmse: error,
                mean_rel: 2.0 * error,
            },
            image_error: ImageError {
                rel_rmse: 3.0 * error,
                mean_rel: 4.0 * error,
            },
            cache_error_range: (0.0, 0.0),
            ..one_run("wfic", r("sweep"), 2, seconds, error)
        };
        // A slow outlier moves the median not at all; the errors are averaged.
        let row = Run::combine(vec![
            run(1.0, 0.010, 100),
            run(9.0, 0.013, 104),
            run(1.2, 0.016, 101),
        ]);
        assert_eq!(row.seconds, 1.2);
        assert_eq!(row.records, 101);
        assert!((row.cache_error.rel_rmse - 0.013).abs() < 1e-12);
        assert!((row.cache_error.mean_rel - 0.026).abs() < 1e-12);
        assert!((row.image_error.rel_rmse - 0.039).abs() < 1e-12);
        assert!((row.image_error.mean_rel - 0.052).abs() < 1e-12);
        assert_eq!(row.cache_error_range, (0.010, 0.016));
        assert_eq!(row.repeats, 3);
        // An even count takes the middle two.
        let row = Run::combine(vec![run(1.0, 0.01, 10), run(2.0, 0.01, 20)]);
        assert_eq!((row.seconds, row.records), (1.5, 15));
    }

    #[test]
    fn the_smoke_run_renders_each_setting_once_the_full_run_three_times() {
        // CI's `--quick` run stays a smoke run; the committed one averages three renders.
        assert_eq!(RadianceConfig::quick(vec![]).repeats, 1);
        assert_eq!(RadianceConfig::full(vec![]).repeats, 3);
    }

    #[test]
    fn the_tables_give_a_repeated_rows_range_and_the_csv_its_renders() {
        let run = |renderer, role: Role, workers, seconds, error, range, repeats| Run {
            min_radius_pixels: 12.0,
            repeats,
            cache_error_range: range,
            ..one_run(renderer, role, workers, seconds, error)
        };
        let comparison = SceneComparison {
            scene: "cornell".into(),
            triangles: 32,
            source: "real",
            radiance_load_seconds: 0.0,
            oconv_seconds: 0.0,
            sources: (2, 0, 1, 1.0),
            runs: vec![
                run(
                    "radiance",
                    r("matched"),
                    1,
                    2.0,
                    0.0118,
                    (0.0116, 0.0121),
                    3,
                ),
                run(
                    "radiance",
                    r("matched"),
                    2,
                    1.5,
                    0.0119,
                    (0.0114, 0.0122),
                    3,
                ),
                run(
                    "wfic",
                    r("equal-error"),
                    1,
                    0.3,
                    0.0118,
                    (0.0112, 0.0128),
                    3,
                ),
                Run {
                    smoothing: 1.5,
                    ..run(
                        "wfic",
                        r("equal-error"),
                        2,
                        0.1,
                        0.0115,
                        (0.0115, 0.0115),
                        1,
                    )
                },
            ],
            cross_check: ImageError {
                rel_rmse: 0.0,
                mean_rel: 0.0,
            },
            mean_ratio: 1.0,
        };
        let config = RadianceConfig::full(vec!["cornell".into()]);
        let md = markdown(&config, std::slice::from_ref(&comparison), "R");
        let row = |workers: usize| {
            md.lines()
                .find(|l| l.starts_with(&format!("| cornell | {workers} | ")))
                .unwrap_or_else(|| panic!("no equal-error row for {workers} in\n{md}"))
                .to_owned()
        };
        // Three renders: the mean with its range; one render: the error alone.
        assert!(row(1).contains("| 1.18% (1.16%–1.21%) |"), "{}", row(1));
        assert!(row(1).contains("| 1.18% (1.12%–1.28%) |"), "{}", row(1));
        assert!(row(1).contains("a 0.15 N 512 r_min 12 px"), "{}", row(1));
        assert!(row(2).contains("| 1.15% |"), "{}", row(2));
        // A smoothed row says so; an unsmoothed one does not.
        assert!(
            row(2).contains("a 0.15 N 512 r_min 12 px k 1.5 |"),
            "{}",
            row(2)
        );
        assert!(!row(1).contains(" k "), "{}", row(1));
        assert!(md.contains("is 3 render(s) of its setting"), "{md}");
        let csv = csv(std::slice::from_ref(&comparison));
        let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
        let line: Vec<&str> = csv.lines().nth(3).unwrap().split(',').collect();
        let col = |name: &str| line[header.iter().position(|h| *h == name).unwrap()];
        assert_eq!(
            (
                col("repeats"),
                col("cache_rel_rmse_min"),
                col("cache_rel_rmse_max")
            ),
            ("3", "0.011200", "0.012800")
        );
        assert_eq!(col("smoothing"), "1");
        let last: Vec<&str> = csv.lines().nth(4).unwrap().split(',').collect();
        assert_eq!(
            last[header.iter().position(|h| *h == "smoothing").unwrap()],
            "1.5"
        );
    }
}
