//! `wfic reproduce direct`: the direct-light estimators side by side, the light-bounds one
//! ([`DirectSampling::Bounds`]) against the earlier one it replaced
//! ([`DirectSampling::PowerOverDistance`]), in the same run.
//!
//! - **Efficiency.** At the primary hits of a `probe x probe` grid of pixel centres, each
//!   estimator estimates the direct irradiance `repeats` times with `L` light samples (the same
//!   streams for both, the order alternating from hit to hit). Its relative variance is the sum
//!   of the hits' sample variances of luminance over the sum of their squared means; its time
//!   the seconds of its calls. The ratio of `variance x time`, old over new, is how many times
//!   less work the new estimator needs for the same noise.
//! - **Noise in the renders.** Each scene at the default render settings (`wf`, one thread), three
//!   times per estimator, the seeds apart: the noise is the RMS difference of luminance between the
//!   first two over the pixels that see no emitter, over `sqrt 2` and the mean. Also the median
//!   frame time,
//!   and crops of the noisiest window side by side (`direct-crops.png`).

use crate::harness::metrics::surface_mask;
use crate::harness::stats::median;
use crate::harness::table::Table;
use crate::harness::{Check, Machine, Output, Provenance, Verdict};
use std::path::Path;
use std::time::Instant;
use wfic::cache::Scheme;
use wfic_render::film::Image;
use wfic_render::integrator::{direct_irradiance, facing, RayCounts};
use wfic_render::sampler::{for_sample, Stream};
use wfic_render::scene::luminance;
use wfic_render::settings::DirectSampling;
use wfic_render::{render_with_scheme, scenes, RenderSettings, Scene};

/// The estimators, the baseline first.
pub const ESTIMATORS: [DirectSampling; 2] =
    [DirectSampling::PowerOverDistance, DirectSampling::Bounds];

/// What the experiment runs.
#[derive(Clone, Debug, PartialEq)]
pub struct DirectConfig {
    /// Scenes.
    pub scenes: Vec<String>,
    /// Side of the grid of primary hits the estimators are measured at.
    pub probe: u32,
    /// Estimates per hit and estimator.
    pub repeats: u32,
    /// Light samples per estimate (each count measured).
    pub samples: Vec<u32>,
    /// Side of the renders.
    pub size: u32,
}

impl DirectConfig {
    /// The full run: 64 x 64 hits, 16 estimates each at 2 and 16 samples; 320 x 320 renders.
    pub fn full(scenes: Vec<String>) -> Self {
        Self {
            scenes,
            probe: 64,
            repeats: 16,
            samples: vec![2, 16],
            size: 320,
        }
    }

    /// A smoke run: 24 x 24 hits, 4 estimates; 96 x 96 renders.
    pub fn quick(scenes: Vec<String>) -> Self {
        Self {
            probe: 24,
            repeats: 4,
            size: 96,
            ..Self::full(scenes)
        }
    }
}

/// One estimator's efficiency on one scene at one sample count.
#[derive(Clone, Debug, PartialEq)]
pub struct Efficiency {
    /// Scene.
    pub scene: String,
    /// Light samples per estimate.
    pub samples: u32,
    /// Estimator.
    pub estimator: DirectSampling,
    /// Relative variance of one estimate.
    pub variance: f64,
    /// Seconds of all its estimates.
    pub seconds: f64,
}

/// One estimator's renders of one scene.
#[derive(Clone, Debug)]
pub struct Renders {
    /// Scene.
    pub scene: String,
    /// Estimator.
    pub estimator: DirectSampling,
    /// The seed-to-seed noise (relative RMS).
    pub noise: f64,
    /// Median frame seconds.
    pub seconds: f64,
    /// The first seed's image.
    pub image: Image,
}

/// What the run found.
pub struct Direct {
    /// Every estimator, scene and sample count.
    pub efficiency: Vec<Efficiency>,
    /// Every estimator and scene, baseline first.
    pub renders: Vec<Renders>,
    /// Per scene, the noise at [`FLOOR_SAMPLES`] light samples (the new estimator).
    pub floors: Vec<f64>,
}

/// The primary hits of `scene` on a `probe x probe` grid: position and facing normal.
fn hits(scene: &Scene, probe: u32) -> Vec<(u32, u32, glam::Vec3, glam::Vec3)> {
    let view = scene.camera().view(probe, probe);
    let mut out = Vec::new();
    for y in 0..probe {
        for x in 0..probe {
            let d = view.direction(x as f32 + 0.5, y as f32 + 0.5);
            if let Some(h) = scene.intersect(view.eye(), d, f32::INFINITY) {
                out.push((x, y, view.eye() + d * h.t, facing(h.normal, d)));
            }
        }
    }
    out
}

/// Both estimators' efficiency on `scene` with `samples` light samples.
fn efficiency(scene: &Scene, config: &DirectConfig, samples: u32) -> [Efficiency; 2] {
    let eps = 1e-4 * scene.diagonal();
    let mut sums = [(0.0f64, 0.0f64, 0.0f64); 2];
    let mut rays = RayCounts::default();
    for (i, &(px, py, x, n)) in hits(scene, config.probe).iter().enumerate() {
        for k in 0..2 {
            let e = (k + i) % 2;
            let start = Instant::now();
            let (mut s, mut sq) = (0.0f64, 0.0f64);
            for r in 0..config.repeats {
                let mut rng = for_sample(0x5eed, px, py, r, Stream::Direct);
                let v = direct_irradiance(
                    scene,
                    x,
                    n,
                    samples,
                    eps,
                    ESTIMATORS[e],
                    &mut rng,
                    &mut rays,
                );
                let l = f64::from(luminance(v));
                (s, sq) = (s + l, sq + l * l);
            }
            let r = f64::from(config.repeats);
            let mean = s / r;
            sums[e].0 += (sq - r * mean * mean) / (r - 1.0);
            sums[e].1 += mean * mean;
            sums[e].2 += start.elapsed().as_secs_f64();
        }
    }
    [0, 1].map(|e| Efficiency {
        scene: scene.name().to_owned(),
        samples,
        estimator: ESTIMATORS[e],
        variance: sums[e].0 / sums[e].1.max(f64::MIN_POSITIVE),
        seconds: sums[e].2,
    })
}

/// The seed-to-seed noise of `a` against `b` over the masked pixels: RMS difference of
/// luminance over `sqrt 2` and the mean.
fn noise(a: &Image, b: &Image, mask: &[bool]) -> f64 {
    let (mut diff, mut sum, mut n) = (0.0f64, 0.0f64, 0.0f64);
    for ((p, q), &m) in a.pixels().iter().zip(b.pixels()).zip(mask) {
        if m {
            let (lp, lq) = (f64::from(luminance(*p)), f64::from(luminance(*q)));
            diff += (lp - lq) * (lp - lq);
            sum += 0.5 * (lp + lq);
            n += 1.0;
        }
    }
    (diff / (2.0 * n)).sqrt() / (sum / n).max(f64::MIN_POSITIVE)
}

/// A default render of `scene` at `size` with `estimator`, `light_samples` and `seed`: its image
/// and seconds.
fn render(
    scene: &Scene,
    size: u32,
    estimator: DirectSampling,
    light_samples: u32,
    seed: u64,
) -> Result<(Image, f64), String> {
    let mut s = RenderSettings::new(size, size)
        .seed(seed)
        .light_samples(light_samples);
    s.direct = estimator;
    let config = s.cache_config(scene).map_err(|e| e.to_string())?;
    let frame = render_with_scheme(Scheme::Wf, scene, &scene.camera(), &s, config, 1).0;
    Ok((frame.image, frame.stats.seconds))
}

/// Light samples of the renders that show the cache's own noise.
pub const FLOOR_SAMPLES: u32 = 256;

/// Both estimators' renders of `scene` (three seeds each, interleaved), and the noise of the new
/// estimator at [`FLOOR_SAMPLES`] light samples: what is left when the direct light's noise is
/// all but gone, the cache's.
fn renders(scene: &Scene, size: u32) -> Result<([Renders; 2], f64), String> {
    let mut images: [Vec<(Image, f64)>; 2] = [Vec::new(), Vec::new()];
    let defaults = RenderSettings::new(size, size).light_samples;
    // Two seeds for the noise, a third for a steadier median time.
    for seed in [0x5eed, 0x5eef, 0x5ef1] {
        for (e, estimator) in ESTIMATORS.into_iter().enumerate() {
            images[e].push(render(scene, size, estimator, defaults, seed)?);
        }
    }
    let mask = surface_mask(scene, &RenderSettings::new(size, size), 1);
    let floor = {
        let a = render(scene, size, DirectSampling::Bounds, FLOOR_SAMPLES, 0x5eed)?.0;
        let b = render(scene, size, DirectSampling::Bounds, FLOOR_SAMPLES, 0x5eef)?.0;
        noise(&a, &b, &mask)
    };
    let rows = [0, 1].map(|e| Renders {
        scene: scene.name().to_owned(),
        estimator: ESTIMATORS[e],
        noise: noise(&images[e][0].0, &images[e][1].0, &mask),
        seconds: median(&images[e].iter().map(|(_, t)| *t).collect::<Vec<_>>()),
        image: images[e][0].0.clone(),
    });
    Ok((rows, floor))
}

/// Runs the experiment; `progress(label)` before each scene's steps.
///
/// # Errors
/// An unknown scene.
pub fn run(config: &DirectConfig, progress: &mut dyn FnMut(&str)) -> Result<Direct, String> {
    let (mut efficiency_rows, mut render_rows, mut floors) = (Vec::new(), Vec::new(), Vec::new());
    for name in &config.scenes {
        let scene = scenes::load(name)?;
        for &samples in &config.samples {
            progress(&format!("{name}: estimators at {samples} light samples"));
            efficiency_rows.extend(efficiency(&scene, config, samples));
        }
        progress(&format!("{name}: renders, three seeds per estimator"));
        let (rows, floor) = renders(&scene, config.size)?;
        render_rows.extend(rows);
        floors.push(floor);
    }
    Ok(Direct {
        efficiency: efficiency_rows,
        renders: render_rows,
        floors,
    })
}

/// The scenes whose noise the new estimator must cut to a third (a bulb of many triangles, many
/// troffers); on the others it must not raise it.
const CUT: [&str; 3] = ["desk", "conference", "office"];

impl Direct {
    /// The goals, per scene: the noise cut (or not raised), the frame time at most 1.25x.
    pub fn checks(&self) -> Vec<Check> {
        let mut out = Vec::new();
        for pair in self.renders.chunks(2) {
            let [old, new] = pair else { continue };
            let cut = CUT.contains(&new.scene.as_str());
            let bar = if cut { old.noise / 3.0 } else { old.noise };
            out.push(Check::new(
                &new.scene,
                if cut {
                    "noise at most a third"
                } else {
                    "noise no higher"
                },
                Verdict::of(new.noise <= bar),
                format!(
                    "{:.2}% against {:.2}%",
                    100.0 * new.noise,
                    100.0 * old.noise
                ),
            ));
            let ratio = new.seconds / old.seconds;
            out.push(Check::new(
                &new.scene,
                "frame time at most 1.25x",
                Verdict::of(ratio <= 1.25),
                format!(
                    "{ratio:.3}x ({:.2} s against {:.2} s)",
                    new.seconds, old.seconds
                ),
            ));
        }
        out
    }

    /// Writes `direct.md`, `direct.csv` and `direct-crops.png` into `out_dir`.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn write(&self, out_dir: &Path, command: &str) -> Result<(), String> {
        let provenance = Provenance::new(command, &Machine::detect(), &[1], &[]);
        let out = Output::new(out_dir, &provenance)?;
        let eff = Table::new()
            .col("scene", "scene", |r: &&Efficiency| r.scene.clone())
            .left()
            .col("light samples", "samples", |r| r.samples.to_string())
            .col("estimator", "estimator", |r| r.estimator.name().to_owned())
            .left()
            .col("relative variance", "variance", |r| {
                format!("{:.5}", r.variance)
            })
            .col("seconds", "seconds", |r| format!("{:.3}", r.seconds))
            .col("variance x time, old / this", "efficiency", |r| {
                let old = self.efficiency.iter().find(|o| {
                    o.scene == r.scene && o.samples == r.samples && o.estimator == ESTIMATORS[0]
                });
                old.map_or(String::new(), |o| {
                    format!("{:.2}", o.variance * o.seconds / (r.variance * r.seconds))
                })
            });
        let rows: Vec<&Efficiency> = self.efficiency.iter().collect();
        let ren = Table::new()
            .col("scene", "scene", |r: &&Renders| r.scene.clone())
            .left()
            .col("estimator", "estimator", |r| r.estimator.name().to_owned())
            .left()
            .col("seed-to-seed noise", "noise", |r| {
                format!("{:.2}%", 100.0 * r.noise)
            })
            .col("the same at 256 light samples", "floor", |r| {
                let i = self
                    .renders
                    .iter()
                    .position(|o| o.scene == r.scene)
                    .unwrap_or(0)
                    / 2;
                match (r.estimator, self.floors.get(i)) {
                    (DirectSampling::Bounds, Some(f)) => format!("{:.2}%", 100.0 * f),
                    _ => String::new(),
                }
            })
            .col("frame seconds (median of 3)", "seconds", |r| {
                format!("{:.3}", r.seconds)
            });
        let render_rows: Vec<&Renders> = self.renders.iter().collect();
        let body = format!(
            "## Estimator efficiency\n\n{}\n## Renders at the default settings\n\n{}\n## Goals\n\n{}\n\
             Crops of each scene's noisiest window, the old estimator left: `direct-crops.png`.\n",
            eff.markdown(&rows),
            ren.markdown(&render_rows),
            Check::markdown(&self.checks(), true)
        );
        out.markdown(
            "direct.md",
            "Direct light: the light-bounds estimator against the earlier one",
            &body,
        )?;
        out.csv("direct.csv", &eff.csv_text(&rows))?;
        let crops = self.crops();
        let png = out.path("direct-crops.png");
        crops
            .save(&png)
            .map_err(|e| format!("{}: {e}", png.display()))
    }

    /// Each scene's noisiest 64 x 64 window (by the old estimator's local contrast against the
    /// new one's), old and new side by side at twice the size, one row a scene, one exposure per
    /// row.
    fn crops(&self) -> image::RgbImage {
        const W: u32 = 64;
        let pairs: Vec<&[Renders]> = self.renders.chunks(2).filter(|p| p.len() == 2).collect();
        let mut out = image::RgbImage::new(4 * W + 8, (2 * W + 8) * pairs.len().max(1) as u32);
        for (row, pair) in pairs.iter().enumerate() {
            let (old, new) = (&pair[0].image, &pair[1].image);
            let (w, h) = (old.width(), old.height());
            let side = W.min(w).min(h);
            let mut best = (0, 0, -1.0);
            for y in (0..=h - side).step_by(16) {
                for x in (0..=w - side).step_by(16) {
                    let mut d = 0.0;
                    for j in 0..side {
                        for i in 0..side {
                            let a = luminance(old.get(x + i, y + j));
                            let b = luminance(new.get(x + i, y + j));
                            d += f64::from((a - b) * (a - b));
                        }
                    }
                    if d > best.2 {
                        best = (x, y, d);
                    }
                }
            }
            let exposure = old.auto_exposure();
            for (col, img) in [old, new].into_iter().enumerate() {
                let rgb = img.to_srgb8(exposure);
                for j in 0..2 * side {
                    for i in 0..2 * side {
                        let (sx, sy) = (best.0 + i / 2, best.1 + j / 2);
                        let k = 3 * (sy * w + sx) as usize;
                        let px = image::Rgb([rgb[k], rgb[k + 1], rgb[k + 2]]);
                        let ox = col as u32 * (2 * W + 8) + i;
                        out.put_pixel(ox, row as u32 * (2 * W + 8) + j, px);
                    }
                }
            }
        }
        out
    }
}
