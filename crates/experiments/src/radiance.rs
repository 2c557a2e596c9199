//! `wfic compare radiance`: the same scene rendered by Radiance (Ward's own irradiance cache,
//! `rtrace -ab 1`) and by wfic (`wf`), side by side, at matched settings, each against its own
//! brute-force image; then the wfic setting whose error is at or below Radiance's, and the time
//! ratio there.
//!
//! What is matched. The geometry, materials and lights are exported from the wfic scene
//! (every triangle a Radiance `polygon`; diffuse materials as `plastic` with no specular
//! component, which is Lambertian; emitters as `light`, one-sided towards the winding normal in
//! both renderers). The camera is matched ray for ray: wfic's own primary rays (one through
//! each pixel's centre) are written to a file and fed to `rtrace -if`, so both renderers shade
//! exactly the same points. The cache: one bounce of indirect light (`-ab 1`, `-av 0 0 0`;
//! wfic's indirect term is one bounce), the same rays per record (`-ad N -as 0`: no
//! supersampling, which wfic does not do), the same accuracy `a` (`-aa`), Radiance's ambient
//! resolution `-ar` (its minimum record spacing; wfic clamps radii in pixels and scene
//! fractions instead, `RenderSettings`). Direct light: Radiance's is deterministic (`-dj 0`, every
//! source tested: `-dt 0 -dc 1`, sources subdivided at the default `-ds 0.2`); wfic samples area
//! lights stochastically (`light_samples` per hit), with the same per-pixel random stream in a
//! cached image and in its reference, so the direct term cancels in the cache error.
//!
//! Two errors. The *cache error* compares each cached image with that renderer's own
//! brute-force image (Radiance `-aa 0` with `4N` rays; wfic `--scheme none` with `4N` rays, same
//! seed and light samples): what the cache interpolates, nothing else. The *image error*
//! compares each cached image with one converged reference (wfic `none`, `4N` rays, 256 light
//! samples, another seed): what a user sees, direct-light noise and Radiance's source
//! subdivision included. Both are relative RMSE of luminance over the pixels that do not see an
//! emitter, and the mean relative error over the same pixels.
//!
//! The equal-error search sweeps wfic's accuracy at 2, 4/3, 1 and 2/3 times the matched one,
//! its rays per record at 1/2, 9/16, 5/8, 3/4, 7/8, 1, 5/4, 3/2 and 2 times (the smoke run: 1/2, 3/4,
//! 1, 3/2, 2), its lower radius clamp at 6 and 12 pixel footprints, and its smoothing at 1 and 1.5
//! ([`RenderSettings::smoothing`]: the same records, each pixel interpolating those valid at
//! `1.5 a`), at 2 threads. Each worker count's pick is the cheapest run at or below
//! Radiance's cache error at that worker count (`equal-error`, or `equal-error-1` and
//! `equal-error-2` when the two differ), rendered again at 1 and at 2 workers; the goal column
//! says yes only when that frame's own error is at or below Radiance's and its time at most
//! 0.1x. Accuracies above the matched one are in it because wfic's cache error is mostly its
//! records' own hemisphere noise: fewer records of more rays each can cost less and err less
//! (`paper-notes.md`, "Radiance side by side").
//!
//! Repeats. One frame's cache error moves by about a tenth between wfic's seeds and its time by
//! up to a quarter between runs, as much as the margins the goal is decided by. So every measured
//! setting is rendered [`RadianceConfig::repeats`] times (3 by default, 1 in the smoke run): wfic
//! with as many seeds, each against that seed's own brute-force image, Radiance with a fresh
//! ambient file each time (its errors move between runs too: Cornell at one process 1.16% to
//! 1.21% in `results/radiance/`). A row is the median of their times and records and the mean of
//! their errors; the equal-error table also gives the range of the cache errors.

use super::{median, Machine};
use wfic::cache::Scheme;
use wfic_render::film::Image;
use wfic_render::scene::luminance;
use wfic_render::{
    render_reference_grid, render_with_scheme, scenes, FrameResult, RenderSettings, Scene,
};
use glam::Vec3;
use std::fmt::Write as _;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

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
    /// The accuracies of the sweep as multiples of `accuracy` (each with every multiple of
    /// [`RadianceConfig::sweep_rays_scales`]). Above 1 as well as below: wfic's cache error is mostly its records' own
    /// hemisphere noise, so fewer records of more rays can be both cheaper and more accurate.
    pub sweep_accuracy_scales: Vec<f32>,
    /// The rays per record of the sweep as multiples of `rays`. Steps of an eighth around the
    /// matched count, a sixteenth at the low end: with steps of a half, the cheapest setting at
    /// Radiance's error could be half as dear again as one just beside it (Sponza's a 0.2, N 512
    /// erred 1.99% against Radiance's 1.98%, and the next one swept cost 35% more); smoothed,
    /// Sponza reaches Radiance's error between 9/16 and 5/8 of the matched count.
    pub sweep_rays_scales: Vec<f32>,
    /// The light-sample counts of the image-noise study: from 1, so the smallest count whose
    /// image noise is at or below Radiance's is found, not only bounded.
    pub light_sweep: Vec<u32>,
    /// Light samples of the converged reference.
    pub converged_light_samples: u32,
    /// The lower radius clamps of the sweep, in pixel footprints (wfic's `min_radius_pixels`;
    /// Radiance clamps by `-ar` instead).
    pub sweep_min_radius: Vec<f32>,
    /// The smoothings of the sweep (wfic's [`RenderSettings::smoothing`]: pixels interpolate
    /// the records valid at `k a`, records are placed at `a` as without it). The matched runs
    /// keep 1, Ward's cache as Radiance has it.
    pub sweep_smoothing: Vec<f32>,
    /// The brute-force references are traced at one pixel of each `stride` x `stride` block
    /// (every error is measured on those pixels), so they cost `1 / stride^2` of a full image.
    pub reference_stride: u32,
    /// Keep the exported scene, rays and ambient files (`DIR/work-NAME/`).
    pub keep_work: bool,
    /// Renders of every measured setting: Radiance runs again with a fresh ambient file (its
    /// error can differ from run to run), wfic with another seed against that seed's own
    /// brute-force image. A row is the median of their times and the mean of their errors: one
    /// frame's cache error moves by about a tenth between seeds, and its time by up to a quarter,
    /// which is as much as the margins the goal is decided by.
    pub repeats: u32,
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
            converged_light_samples: 256,
            reference_stride: 4,
            keep_work: false,
            repeats: 3,
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
            reference_stride: 2,
            repeats: 1,
            ..Self::full(scenes)
        }
    }
}

/// Radiance's binaries: where they are and the `RAYPATH` they need.
#[derive(Clone, Debug)]
pub struct RadianceBin {
    dir: PathBuf,
    raypath: Option<String>,
}

/// Where `pip install pyradiance` puts the binaries, for the error message.
const INSTALL_HINT: &str = "Radiance's `rtrace` was not found. Install it with `pip install pyradiance` \
(x86-64 Linux, Python 3.11 wheel): the binaries land in the package's `bin/` folder, \
`<site-packages>/pyradiance/bin` (for example ~/.local/lib/python3.11/site-packages/pyradiance/bin \
or /usr/local/lib/python3.11/site-packages/pyradiance/bin; `python3 -m pip show -f pyradiance` lists it). \
wfic looks on PATH, in WFIC_RADIANCE_BIN, and in an installed pyradiance package.";

impl RadianceBin {
    /// Finds `rtrace`: the folder `WFIC_RADIANCE_BIN` names, then `PATH`, then an installed
    /// `pyradiance` package (asked of `python3` without importing it). `RAYPATH` is taken from
    /// the environment, or set to the `lib/` folder next to the binaries when that holds
    /// `rayinit.cal` (pyradiance's layout).
    pub fn find() -> Result<Self, String> {
        let mut candidates: Vec<PathBuf> = Vec::new();
        if let Some(dir) = std::env::var_os("WFIC_RADIANCE_BIN") {
            candidates.push(PathBuf::from(dir));
        }
        if let Some(path) = std::env::var_os("PATH") {
            candidates.extend(std::env::split_paths(&path));
        }
        if let Some(dir) = pyradiance_dir() {
            candidates.push(dir.join("bin"));
        }
        let dir = candidates
            .into_iter()
            .find(|d| d.join("rtrace").is_file() && d.join("oconv").is_file())
            .ok_or_else(|| INSTALL_HINT.to_owned())?;
        let raypath = match std::env::var("RAYPATH") {
            Ok(p) if !p.is_empty() => Some(p),
            _ => {
                let lib = dir.parent().map(|p| p.join("lib"));
                lib.filter(|l| l.join("rayinit.cal").is_file())
                    .map(|l| format!(".:{}", l.display()))
            }
        };
        Ok(Self { dir, raypath })
    }

    fn command(&self, tool: &str) -> Command {
        let mut c = Command::new(self.dir.join(tool));
        if let Some(p) = &self.raypath {
            c.env("RAYPATH", p);
        }
        c
    }

    /// `rtrace -version`'s answer.
    pub fn version(&self) -> String {
        self.command("rtrace")
            .arg("-version")
            .output()
            .ok()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
            .unwrap_or_else(|| "unknown".to_owned())
    }
}

/// The `pyradiance` package folder, if `python3` knows one (found without importing it, which
/// would need numpy).
fn pyradiance_dir() -> Option<PathBuf> {
    let out = Command::new("python3")
        .args([
            "-c",
            "import importlib.util as u; s = u.find_spec('pyradiance'); \
             print(s.submodule_search_locations[0] if s else '')",
        ])
        .stderr(Stdio::null())
        .output()
        .ok()?;
    let dir = String::from_utf8_lossy(&out.stdout).trim().to_owned();
    (!dir.is_empty()).then(|| PathBuf::from(dir))
}

/// Runs `cmd`, feeding `stdin` from a file and writing stdout to a file, and returns its wall time.
fn run_timed(
    mut cmd: Command,
    stdin: Option<&Path>,
    stdout: &Path,
    what: &str,
) -> Result<f64, String> {
    let out = std::fs::File::create(stdout).map_err(|e| format!("{}: {e}", stdout.display()))?;
    cmd.stdout(out).stderr(Stdio::piped());
    if let Some(i) = stdin {
        cmd.stdin(std::fs::File::open(i).map_err(|e| format!("{}: {e}", i.display()))?);
    }
    let start = Instant::now();
    let child = cmd
        .spawn()
        .map_err(|e| format!("{what}: cannot start: {e}"))?;
    let result = child
        .wait_with_output()
        .map_err(|e| format!("{what}: {e}"))?;
    let seconds = start.elapsed().as_secs_f64();
    if !result.status.success() {
        return Err(format!(
            "{what} failed ({}): {}",
            result.status,
            String::from_utf8_lossy(&result.stderr).trim()
        ));
    }
    Ok(seconds)
}

/// Writes the scene as a Radiance scene file: one `plastic` (no specular: Lambertian) or
/// `light` per material, one `polygon` per triangle, corners in wfic's winding order (Radiance's
/// front side, from which a `light` emits, is the one the right-hand rule points to, as in wfic).
pub fn write_rad(scene: &Scene, path: &Path) -> Result<usize, String> {
    let io = |e: std::io::Error| format!("{}: {e}", path.display());
    let mut w = BufWriter::new(std::fs::File::create(path).map_err(io)?);
    writeln!(
        w,
        "# {} exported by wfic {}: {} triangles",
        scene.name(),
        env!("CARGO_PKG_VERSION"),
        scene.triangle_count()
    )
    .map_err(io)?;
    for (i, m) in scene.materials().iter().enumerate() {
        if m.is_emissive() {
            let e = m.emission;
            writeln!(w, "void light m{i}\n0\n0\n3 {} {} {}\n", e.x, e.y, e.z).map_err(io)?;
        } else {
            let a = m.albedo;
            writeln!(
                w,
                "void plastic m{i}\n0\n0\n5 {} {} {} 0 0\n",
                a.x, a.y, a.z
            )
            .map_err(io)?;
        }
    }
    let tris = scene.triangles();
    for (k, ([a, b, c], m)) in tris.iter().enumerate() {
        writeln!(
            w,
            "m{m} polygon t{k}\n0\n0\n9 {} {} {} {} {} {} {} {} {}",
            a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z
        )
        .map_err(io)?;
    }
    w.flush().map_err(io)?;
    Ok(tris.len())
}

/// wfic's primary rays for `settings`' image (one through each pixel's centre, rows from the
/// top), as `rtrace -if` reads them: origin and direction, six native-endian `f32`s a pixel.
fn write_rays(
    scene: &Scene,
    settings: &RenderSettings,
    stride: u32,
    path: &Path,
) -> Result<(), String> {
    let view = scene.camera().view(settings.width, settings.height);
    let mut bytes = Vec::with_capacity((settings.width * settings.height * 24) as usize);
    for y in (stride / 2..settings.height).step_by(stride as usize) {
        for x in (stride / 2..settings.width).step_by(stride as usize) {
            let d = view.direction(x as f32 + 0.5, y as f32 + 0.5);
            let o = view.eye();
            for c in [o.x, o.y, o.z, d.x, d.y, d.z] {
                bytes.extend_from_slice(&c.to_ne_bytes());
            }
        }
    }
    std::fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// Reads `rtrace -ff` output (three `f32`s a ray, the rays of [`write_rays`] with `stride`)
/// into a `w` x `h` image (black where no ray was traced).
fn read_floats(path: &Path, (w, h): (u32, u32), stride: u32) -> Result<Image, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let (sw, sh) = (
        (stride / 2..w).step_by(stride as usize).count() as u32,
        (stride / 2..h).step_by(stride as usize).count() as u32,
    );
    let want = (sw * sh * 12) as usize;
    if bytes.len() != want {
        return Err(format!(
            "{}: {} bytes, expected {want} ({w} x {h} RGB floats)",
            path.display(),
            bytes.len()
        ));
    }
    let mut img = Image::new(w, h);
    for (i, px) in bytes.chunks_exact(12).enumerate() {
        let f = |k: usize| f32::from_ne_bytes(px[k..k + 4].try_into().expect("4 bytes"));
        let (x, y) = (i as u32 % sw, i as u32 / sw);
        img.set(
            stride / 2 + x * stride,
            stride / 2 + y * stride,
            Vec3::new(f(0), f(4), f(8)),
        );
    }
    Ok(img)
}

/// Which pixels see a non-emitting surface and lie on the reference grid (the pixels the
/// errors are measured on).
pub(crate) fn surface_mask(scene: &Scene, settings: &RenderSettings, stride: u32) -> Vec<bool> {
    let view = scene.camera().view(settings.width, settings.height);
    let mut mask = Vec::with_capacity((settings.width * settings.height) as usize);
    for y in 0..settings.height {
        for x in 0..settings.width {
            let d = view.direction(x as f32 + 0.5, y as f32 + 0.5);
            let on_grid = x % stride == stride / 2 && y % stride == stride / 2;
            mask.push(
                on_grid
                    && scene
                        .intersect(view.eye(), d, f32::INFINITY)
                        .is_some_and(|h| !h.material.is_emissive()),
            );
        }
    }
    mask
}

/// An image's error against a reference over the masked pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImageError {
    /// `sqrt(sum (L - L_ref)^2 / sum L_ref^2)` of luminance.
    pub rel_rmse: f64,
    /// Mean of `|L - L_ref| / L_ref` over the pixels whose `L_ref` is at least 1% of the
    /// masked pixels' mean (darker ones, mostly noise of the reference, would dominate it).
    pub mean_rel: f64,
}

/// [`ImageError`] of `img` against `reference` over the pixels `mask` selects.
pub fn image_error(img: &Image, reference: &Image, mask: &[bool]) -> ImageError {
    let floor = 0.01 * masked_mean(reference, mask);
    let (mut num, mut den, mut rel, mut n) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    for ((a, b), &m) in img.pixels().iter().zip(reference.pixels()).zip(mask) {
        if !m {
            continue;
        }
        let (la, lb) = (f64::from(luminance(*a)), f64::from(luminance(*b)));
        num += (la - lb) * (la - lb);
        den += lb * lb;
        if lb > floor && lb > 0.0 {
            rel += (la - lb).abs() / lb;
            n += 1;
        }
    }
    ImageError {
        rel_rmse: if den > 0.0 { (num / den).sqrt() } else { 0.0 },
        mean_rel: if n > 0 { rel / n as f64 } else { 0.0 },
    }
}

/// One measured render.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// `radiance` or `wfic`.
    pub renderer: &'static str,
    /// What the row is: `matched`, `sweep`, `equal-error`, `light-samples`, `reference`.
    pub role: &'static str,
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
    /// Against the converged reference.
    pub image_error: ImageError,
    /// Renders behind the row ([`RadianceConfig::repeats`]): `seconds` is their median,
    /// `records` their median, the errors their mean.
    pub repeats: u32,
    /// The smallest and largest cache error (relative RMSE) among them.
    pub cache_error_range: (f64, f64),
}

impl Run {
    /// One row from the renders of one setting: the median time and record count, the mean
    /// errors, the range of the cache error.
    pub fn combine(runs: Vec<Run>) -> Run {
        assert!(!runs.is_empty(), "a row needs a render");
        let k = runs.len() as f64;
        let mean = |f: &dyn Fn(&Run) -> f64| runs.iter().map(f).sum::<f64>() / k;
        let mut row = runs[0].clone();
        row.seconds = median(&runs.iter().map(|r| r.seconds).collect::<Vec<_>>());
        let records: Vec<f64> = runs.iter().map(|r| r.records as f64).collect();
        row.records = median(&records).round() as usize;
        row.cache_error = ImageError {
            rel_rmse: mean(&|r| r.cache_error.rel_rmse),
            mean_rel: mean(&|r| r.cache_error.mean_rel),
        };
        row.image_error = ImageError {
            rel_rmse: mean(&|r| r.image_error.rel_rmse),
            mean_rel: mean(&|r| r.image_error.mean_rel),
        };
        row.cache_error_range = runs.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| {
            (
                lo.min(r.cache_error.rel_rmse),
                hi.max(r.cache_error.rel_rmse),
            )
        });
        row.repeats = runs.iter().map(|r| r.repeats).sum();
        row
    }
}

/// One scene's comparison.
#[derive(Clone, Debug)]
pub struct SceneComparison {
    /// The scene.
    pub scene: String,
    /// Triangles, and whether the scene is a real model or a stand-in.
    pub triangles: usize,
    /// `real` or `stand-in`.
    pub source: &'static str,
    /// Seconds `rtrace` takes to load the octree and trace one ray (included in its times).
    pub radiance_load_seconds: f64,
    /// Seconds of `oconv` (not included anywhere, like wfic's BVH build).
    pub oconv_seconds: f64,
    /// Every measured render.
    pub runs: Vec<Run>,
    /// wfic's brute-force image, Radiance's brute-force image against it (the cross-check that
    /// both render the same scene).
    pub cross_check: ImageError,
    /// Mean luminance of Radiance's brute-force image over wfic's converged one (the masked
    /// pixels): 1 when both render the same light, whatever the noise.
    pub mean_ratio: f64,
}

impl SceneComparison {
    /// The run of `renderer` in `role` at `workers`, if measured.
    pub fn find(&self, renderer: &str, role: &str, workers: usize) -> Option<&Run> {
        self.runs
            .iter()
            .find(|r| r.renderer == renderer && r.role == role && r.workers == workers)
    }
}

/// Progress lines go to standard error.
fn say(scene: &str, what: &str) {
    eprintln!("[{scene}] {what}");
}

/// Runs the comparison and writes `radiance.md`, `radiance.csv` and one side-by-side PNG per
/// scene into `out_dir`.
pub fn run(config: &RadianceConfig, out_dir: &Path, command: &str) -> Result<(), String> {
    let bin = RadianceBin::find()?;
    std::fs::create_dir_all(out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let machine = Machine::detect();
    let version = bin.version();
    let mut results = Vec::new();
    for name in &config.scenes {
        let scene = scenes::load(name)?;
        results.push(compare_scene(&bin, config, &scene, out_dir)?);
    }
    let md = markdown(config, &results, &machine, &version, command);
    std::fs::write(out_dir.join("radiance.md"), md).map_err(|e| e.to_string())?;
    std::fs::write(out_dir.join("radiance.csv"), csv(&results)).map_err(|e| e.to_string())?;
    eprintln!(
        "wrote {}/radiance.md, radiance.csv and the side-by-side images",
        out_dir.display()
    );
    Ok(())
}

fn settings(
    config: &RadianceConfig,
    accuracy: f32,
    rays: u32,
    light: u32,
    seed: u64,
) -> RenderSettings {
    RenderSettings::new(config.size.0, config.size.1)
        .accuracy(accuracy)
        .rays_per_record(rays)
        .light_samples(light)
        .seed(seed)
        .quiet(true)
}

/// A cached wfic frame (`wf`, fresh cache).
fn wfic_frame(scene: &Scene, s: &RenderSettings, threads: usize) -> Result<FrameResult, String> {
    let config = s.cache_config(scene).map_err(|e| e.to_string())?;
    Ok(render_with_scheme(Scheme::Wf, scene, &scene.camera(), s, config, threads).0)
}

/// The images a comparison measures against: the renderer's own brute-force images (wfic: one
/// per seed, repeat `i` against `own[i]`; Radiance: one, every repeat against `own[0]`), the
/// converged one, the pixels measured.
struct References<'a> {
    own: &'a [Image],
    converged: &'a Image,
    mask: &'a [bool],
}

/// The seed of wfic's repeat `i`: the matched seed first.
fn seed_of(i: u32) -> u64 {
    0x5eed + 0x1_0000 * u64::from(i)
}

impl References<'_> {
    /// A row for `img`, rendered by `renderer` in `seconds` with `records` records.
    #[allow(clippy::too_many_arguments)]
    fn run(
        &self,
        renderer: &'static str,
        role: &'static str,
        workers: usize,
        s: Option<&RenderSettings>,
        (accuracy, rays): (f32, u32),
        seconds: f64,
        records: usize,
        img: &Image,
        repeat: usize,
    ) -> Run {
        let own = &self.own[repeat];
        let cache_error = image_error(img, own, self.mask);
        Run {
            renderer,
            role,
            workers,
            accuracy,
            rays,
            light_samples: s.map_or(0, |s| s.light_samples),
            min_radius_pixels: s.map_or(0.0, |s| s.min_radius_pixels),
            smoothing: s.map_or(1.0, |s| s.smoothing),
            seconds,
            records,
            cache_error,
            image_error: image_error(img, self.converged, self.mask),
            repeats: 1,
            cache_error_range: (cache_error.rel_rmse, cache_error.rel_rmse),
        }
    }

    /// wfic frames of `scene` at settings `s` on `workers` threads, one per own reference (each
    /// with that reference's seed), measured as one row ([`Run::combine`]); and the first frame's
    /// image.
    fn wfic_frames(
        &self,
        scene: &Scene,
        role: &'static str,
        s: &RenderSettings,
        workers: usize,
    ) -> Result<(Run, Image), String> {
        let mut runs = Vec::new();
        let mut first = None;
        for i in 0..self.own.len() {
            let mut s = s.clone();
            s.seed = seed_of(i as u32);
            let f = wfic_frame(scene, &s, workers)?;
            runs.push(self.run(
                "wfic",
                role,
                workers,
                Some(&s),
                (s.accuracy, s.rays_per_record),
                f.stats.seconds,
                f.stats.cache_records,
                &f.image,
                i,
            ));
            first.get_or_insert(f.image);
        }
        Ok((Run::combine(runs), first.expect("at least one repeat")))
    }

    /// [`Self::wfic_frames`] without the image.
    fn wfic(
        &self,
        scene: &Scene,
        role: &'static str,
        s: &RenderSettings,
        workers: usize,
    ) -> Result<Run, String> {
        Ok(self.wfic_frames(scene, role, s, workers)?.0)
    }
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
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let (n, a, k) = (config.rays, config.accuracy, config.reference_stride);
    let base = settings(config, a, n, config.light_samples, 0x5eed);
    let mask = surface_mask(scene, &base, k);
    let camera = scene.camera();

    // Radiance: export, octree, rays (every pixel, and the reference grid's).
    say(
        &name,
        &format!("exporting {} triangles to Radiance", scene.triangle_count()),
    );
    let rad = work.join("scene.rad");
    write_rad(scene, &rad)?;
    let oct = work.join("scene.oct");
    let mut oconv = bin.command("oconv");
    oconv.arg("-f").arg(&rad);
    let oconv_seconds = run_timed(oconv, None, &oct, "oconv")?;
    let rays = work.join("rays.f32");
    write_rays(scene, &base, 1, &rays)?;
    let grid_rays = work.join("grid-rays.f32");
    write_rays(scene, &base, k, &grid_rays)?;
    let one = work.join("one.f32");
    std::fs::write(
        &one,
        &std::fs::read(&rays).map_err(|e| e.to_string())?[..24],
    )
    .map_err(|e| e.to_string())?;

    let rtrace = |args: &[String], workers: usize, amb: Option<&Path>| {
        rtrace_command(bin, &oct, args, workers, amb)
    };
    let cache_args = |a: f32, n: u32| -> Vec<String> {
        [
            "-ad",
            &n.to_string(),
            "-as",
            "0",
            "-aa",
            &a.to_string(),
            "-ar",
            &config.resolution.to_string(),
        ]
        .map(str::to_owned)
        .to_vec()
    };
    let load = run_timed(
        rtrace(&["-ab".into(), "0".into()], 1, None),
        Some(&one),
        &work.join("one.out"),
        "rtrace (load)",
    )?;

    // Radiance's brute-force reference: no cache, 4N rays at every pixel of the grid.
    say(
        &name,
        &format!(
            "radiance reference: -aa 0 -ad {}, 2 processes, 1 pixel in {}",
            4 * n,
            k * k
        ),
    );
    let ref_out = work.join("ref.f32");
    let ref_args = ["-aa", "0", "-ad", &(4 * n).to_string(), "-as", "0"].map(str::to_owned);
    let ref_seconds = run_timed(
        rtrace(&ref_args, 2, None),
        Some(&grid_rays),
        &ref_out,
        "rtrace",
    )?;
    let radiance_ref = read_floats(&ref_out, config.size, k)?;

    // wfic's references on the same grid: brute force with the matched light samples (cache
    // error), and the converged one (image error) with more light samples and another seed.
    let repeats = config.repeats.max(1);
    say(
        &name,
        &format!(
            "wfic reference: none, {} rays, 2 threads, {repeats} seed(s)",
            4 * n
        ),
    );
    let ref_settings = settings(config, a, 4 * n, config.light_samples, seed_of(0));
    let rc = ref_settings
        .cache_config(scene)
        .map_err(|e| e.to_string())?;
    let mut wfic_refs_own = Vec::new();
    let mut wfic_ref_seconds = Vec::new();
    for i in 0..repeats {
        let mut rs = ref_settings.clone();
        rs.seed = seed_of(i);
        let (img, secs) = render_reference_grid(scene, &camera, &rs, rc, 2, k);
        wfic_refs_own.push(img);
        wfic_ref_seconds.push(secs);
    }
    let wfic_ref = &wfic_refs_own[0];
    let wfic_ref_seconds = wfic_ref_seconds[0];
    say(
        &name,
        &format!(
            "converged reference: none, {} rays, {} light samples",
            4 * n,
            config.converged_light_samples
        ),
    );
    let conv_settings = settings(config, a, 4 * n, config.converged_light_samples, 0xc0ffee);
    let (converged, _) = render_reference_grid(scene, &camera, &conv_settings, rc, 2, k);
    let cross_check = image_error(&radiance_ref, &converged, &mask);
    let mean_ratio = masked_mean(&radiance_ref, &mask) / masked_mean(&converged, &mask);

    let radiance_refs = References {
        own: std::slice::from_ref(&radiance_ref),
        converged: &converged,
        mask: &mask,
    };
    let wfic_refs = References {
        own: &wfic_refs_own,
        converged: &converged,
        mask: &mask,
    };
    let mut runs = vec![
        radiance_refs.run(
            "radiance",
            "reference",
            2,
            None,
            (0.0, 4 * n),
            ref_seconds,
            0,
            &radiance_ref,
            0,
        ),
        wfic_refs.run(
            "wfic",
            "reference",
            2,
            Some(&ref_settings),
            (0.0, ref_settings.rays_per_record),
            wfic_ref_seconds,
            0,
            wfic_ref,
            0,
        ),
    ];

    // Matched settings, 1 and 2 workers each, `repeats` renders of each.
    let mut radiance_images = Vec::new();
    for workers in [1, 2] {
        let mut rows = Vec::new();
        for i in 0..repeats {
            let amb = work.join(format!("amb-{workers}-{i}.amb"));
            std::fs::remove_file(&amb).ok();
            let out = work.join(format!("cached-{workers}.f32"));
            say(
                &name,
                &format!(
                    "radiance: -aa {a} -ad {n} -ar {}, {workers} process(es), run {} of {repeats}",
                    config.resolution,
                    i + 1
                ),
            );
            let seconds = run_timed(
                rtrace(&cache_args(a, n), workers, Some(&amb)),
                Some(&rays),
                &out,
                "rtrace",
            )?;
            let img = read_floats(&out, config.size, 1)?;
            let records = ambient_records(bin, &amb)?;
            rows.push(radiance_refs.run(
                "radiance",
                "matched",
                workers,
                None,
                (a, n),
                seconds,
                records,
                &img,
                0,
            ));
            if i == 0 {
                radiance_images.push(img);
            }
        }
        runs.push(Run::combine(rows));
    }
    let mut wfic_images = Vec::new();
    for workers in [1, 2] {
        say(
            &name,
            &format!("wfic: wf, a {a}, {n} rays, {workers} thread(s), {repeats} seed(s)"),
        );
        let (run, img) = wfic_refs.wfic_frames(scene, "matched", &base, workers)?;
        runs.push(run);
        wfic_images.push(img);
    }

    // The sweep: wfic settings against its reference (whose rays stay 4N).
    // Radiance's cache error at 1 and at 2 workers: each worker count gets the cheapest sweep
    // setting at or below its own (2 workers usually err less: they place more records).
    let target_at = |workers: usize| {
        runs.iter()
            .find(|r| r.renderer == "radiance" && r.role == "matched" && r.workers == workers)
            .map(|r| r.cache_error.rel_rmse)
            .expect("measured above")
    };
    let targets = [target_at(1), target_at(2)];
    let target = targets[0];
    let mut swept: Vec<(Run, RenderSettings)> = Vec::new();
    for &scale in &config.sweep_accuracy_scales {
        // Rounded to 1e-3 so the tables read 0.2, not 0.20000002.
        let sa = (config.accuracy * scale * 1000.0).round() / 1000.0;
        for &rs in &config.sweep_rays_scales {
            let sn = ((n as f32 * rs).round() as u32).max(16);
            for &rmin in &config.sweep_min_radius {
                for &k in &config.sweep_smoothing {
                    let mut s = settings(config, sa, sn, config.light_samples, 0x5eed).smoothing(k);
                    s.min_radius_pixels = rmin;
                    let run = wfic_refs.wfic(scene, "sweep", &s, 2)?;
                    say(
                        &name,
                        &format!(
                            "sweep {}: {:.3} s, {} records, cache error {:.2}% (radiance {:.2}%)",
                            wfic_setting(&run),
                            run.seconds,
                            run.records,
                            100.0 * run.cache_error.rel_rmse,
                            100.0 * target
                        ),
                    );
                    swept.push((run.clone(), s.clone()));
                    runs.push(run);
                }
            }
        }
    }
    // Each worker count's pick: the cheapest swept setting at or below Radiance's error at that
    // count whose frame at that count, rendered again, errs at or below it too (records land in
    // another order, so the frame can err a little above the sweep's 2-thread one: up to
    // PICK_TRIES settings are tried, cheapest first). The most accurate swept one when none
    // holds: the report says so. Each pick is rendered at 1 and at 2 workers, so its records at
    // 2 against 1 are measured; one setting serves both counts when it is the same.
    const PICK_TRIES: usize = 4;
    swept.sort_by(|x, y| x.0.seconds.total_cmp(&y.0.seconds));
    let same = |x: &RenderSettings, y: &RenderSettings| {
        (
            x.accuracy,
            x.rays_per_record,
            x.min_radius_pixels,
            x.smoothing,
        ) == (
            y.accuracy,
            y.rays_per_record,
            y.min_radius_pixels,
            y.smoothing,
        )
    };
    // (reached, setting, its frames at 1 and 2 workers, the worker counts it is the pick of)
    type Pick = (bool, RenderSettings, [Option<Run>; 2], Vec<usize>);
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
            let run = wfic_refs.wfic(scene, "pick-tried", st, workers)?;
            say(
                &name,
                &format!(
                    "{workers}-worker pick {}: cache error {:.2}% (radiance {:.2}%)",
                    wfic_setting(&run),
                    100.0 * run.cache_error.rel_rmse,
                    100.0 * t
                ),
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
    for (reached, st, frames, counts) in &mut picks {
        let role = match (*reached, counts.as_slice()) {
            (true, [_, _]) => "equal-error",
            (false, [_, _]) => "most-accurate",
            (true, [1]) => "equal-error-1",
            (true, _) => "equal-error-2",
            (false, [1]) => "most-accurate-1",
            (false, _) => "most-accurate-2",
        };
        for (w, frame) in frames.iter_mut().enumerate() {
            let mut run = match frame.take() {
                Some(run) => run,
                None => wfic_refs.wfic(scene, role, st, w + 1)?,
            };
            run.role = role;
            runs.push(run);
        }
    }
    // The light-sample sweep runs at the 1-worker pick (the first).
    let chosen = picks[0].1.clone();
    // Image noise against light samples, at the chosen cache setting, 1 and 2 threads.
    for &l in &config.light_sweep {
        let mut s = chosen.clone();
        s.light_samples = l;
        for workers in [1, 2] {
            let run = wfic_refs.wfic(scene, "light-samples", &s, workers)?;
            if workers == 2 {
                say(
                    &name,
                    &format!(
                        "light samples {l}: {:.3} s, image error {:.2}%",
                        run.seconds,
                        100.0 * run.image_error.rel_rmse
                    ),
                );
            }
            runs.push(run);
        }
    }

    write_side_by_side(
        &out_dir.join(format!("{name}-side-by-side.png")),
        &radiance_images[0],
        &wfic_images[0],
        &radiance_ref,
        wfic_ref,
        &mask,
        k,
    )?;
    if !config.keep_work {
        std::fs::remove_dir_all(&work).ok();
    }
    let info = scenes::info(&name);
    Ok(SceneComparison {
        scene: name,
        triangles: scene.triangle_count(),
        source: info.map_or("file", |i| i.source.name()),
        radiance_load_seconds: load,
        oconv_seconds,
        runs,
        cross_check,
        mean_ratio,
    })
}

/// The goal column of the equal-error table: `yes` when the wfic run in `role` (an
/// `equal-error` pick) errs at or below Radiance's run `rad` and takes at most 0.1x its time.
/// The pick comes from the sweep's frame, so the frame rendered again can err above: it says so.
fn speed_goal(role: &str, wf: &Run, rad: &Run) -> &'static str {
    if !role.starts_with("equal-error") {
        "NO"
    } else if wf.cache_error.rel_rmse > rad.cache_error.rel_rmse {
        "NO: error above"
    } else if wf.seconds <= 0.1 * rad.seconds {
        "yes"
    } else {
        "NO"
    }
}

/// Mean luminance over the masked pixels.
fn masked_mean(img: &Image, mask: &[bool]) -> f64 {
    let (sum, n) = img
        .pixels()
        .iter()
        .zip(mask)
        .filter(|(_, &m)| m)
        .fold((0.0f64, 0usize), |(s, n), (p, _)| {
            (s + f64::from(luminance(*p)), n + 1)
        });
    sum / n.max(1) as f64
}

/// `rtrace` on the octree `oct` as both comparisons run it: one bounce (`-ab 1`), no ambient
/// value or weight, deterministic direct light (`-dj 0`), binary floats in and out, `workers`
/// processes, sharing the ambient file `amb` when given; `args` add the cache's settings.
fn rtrace_command(
    bin: &RadianceBin,
    oct: &Path,
    args: &[String],
    workers: usize,
    amb: Option<&Path>,
) -> Command {
    let mut c = bin.command("rtrace");
    c.args(["-h-", "-fff", "-ab", "1", "-av", "0", "0", "0", "-aw", "0"]);
    c.args(["-dj", "0", "-lw", "1e-7"]);
    c.args(args);
    c.args(["-n", &workers.to_string()]);
    if let Some(amb) = amb {
        c.arg("-af").arg(amb);
    }
    c.arg(oct);
    c
}

/// Records in a Radiance ambient file, counted from `lookamb -h`'s text (one `Position` line a
/// record). A missing file (no record was written) counts 0.
fn ambient_records(bin: &RadianceBin, amb: &Path) -> Result<usize, String> {
    if !amb.exists() {
        return Ok(0);
    }
    let out = bin
        .command("lookamb")
        .arg("-h")
        .arg(amb)
        .output()
        .map_err(|e| format!("lookamb: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "lookamb {}: {}",
            amb.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| l.trim_start().starts_with("Position"))
        .count())
}

/// A false-colour map of `|L - L_ref| / L_ref` (black 0, through red, to yellow-white at 20% and
/// above), grey where the pixel is not measured; each measured pixel of the `stride` grid fills
/// its `stride` x `stride` block.
fn error_map(img: &Image, reference: &Image, mask: &[bool], stride: u32) -> Vec<[u8; 3]> {
    let w = img.width();
    (0..img.pixels().len())
        .map(|i| {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let (gx, gy) = (
                (x / stride * stride + stride / 2).min(w - 1),
                (y / stride * stride + stride / 2).min(img.height() - 1),
            );
            let j = (gy * w + gx) as usize;
            if !mask[j] {
                return [60, 60, 60];
            }
            let (a, b) = (img.pixels()[j], reference.pixels()[j]);
            let (la, lb) = (luminance(a), luminance(b));
            let e = if lb > 0.0 {
                ((la - lb).abs() / lb / 0.2).min(1.0)
            } else {
                1.0
            };
            let r = (e * 3.0).min(1.0);
            let g = (e * 3.0 - 1.0).clamp(0.0, 1.0);
            let bl = (e * 3.0 - 2.0).clamp(0.0, 1.0);
            [(r * 255.0) as u8, (g * 255.0) as u8, (bl * 255.0) as u8]
        })
        .collect()
}

/// Radiance's cached image beside wfic's (one exposure for both), their error maps against
/// their own references below.
fn write_side_by_side(
    path: &Path,
    radiance: &Image,
    wfic: &Image,
    radiance_ref: &Image,
    wfic_ref: &Image,
    mask: &[bool],
    stride: u32,
) -> Result<(), String> {
    let (w, h) = (wfic.width(), wfic.height());
    let gap = 8u32;
    let (cw, ch) = (2 * w + gap, 2 * h + gap);
    let mut canvas = vec![255u8; (cw * ch * 3) as usize];
    let exposure = wfic.auto_exposure();
    let mut blit = |x0: u32, y0: u32, rgb: &[[u8; 3]]| {
        for (i, p) in rgb.iter().enumerate() {
            let (x, y) = (x0 + i as u32 % w, y0 + i as u32 / w);
            let at = ((y * cw + x) * 3) as usize;
            canvas[at..at + 3].copy_from_slice(p);
        }
    };
    let tone = |img: &Image| -> Vec<[u8; 3]> {
        img.to_srgb8(exposure)
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect()
    };
    blit(0, 0, &tone(radiance));
    blit(w + gap, 0, &tone(wfic));
    blit(0, h + gap, &error_map(radiance, radiance_ref, mask, stride));
    blit(w + gap, h + gap, &error_map(wfic, wfic_ref, mask, stride));
    image::save_buffer(path, &canvas, cw, ch, image::ColorType::Rgb8)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// A row's mean cache error, with the range of its renders when there were several.
fn with_range(run: &Run) -> String {
    if run.repeats > 1 {
        format!(
            "{} ({}–{})",
            pct(run.cache_error.rel_rmse),
            pct(run.cache_error_range.0),
            pct(run.cache_error_range.1)
        )
    } else {
        pct(run.cache_error.rel_rmse)
    }
}

fn pct(x: f64) -> String {
    format!("{:.2}%", 100.0 * x)
}

/// The report.
fn markdown(
    config: &RadianceConfig,
    results: &[SceneComparison],
    machine: &Machine,
    version: &str,
    command: &str,
) -> String {
    let (w, h) = config.size;
    let n = config.rays;
    let k = config.reference_stride;
    let mut s = String::new();
    let _ = writeln!(s, "# wfic against Radiance, side by side\n");
    let _ = writeln!(
        s,
        "`{command}` on {} ({} cores; 1 and 2 workers are not oversubscribed). {version}.\n",
        machine.cpu, machine.cores
    );
    let _ = writeln!(
        s,
        "{w} x {h}, one ray per pixel (wfic's primary rays fed to `rtrace -if`). Radiance: \
         `rtrace -ab 1 -ad {n} -as 0 -aa {} -ar {} -av 0 0 0 -aw 0 -dj 0 -lw 1e-7 -n P -af FILE` \
         (direct light deterministic, `-dt`/`-dc`/`-ds` at Radiance's defaults); reference `-aa 0 -ad {}`. \
         wfic: `wf`, accuracy {}, {n} rays per record, {} light samples, radius clamps at their \
         defaults (6 to 120 pixel footprints); reference `--scheme none` with {} rays. Converged \
         reference: wfic `none`, {} rays, {} light samples, another seed. The references are traced \
         at one pixel of every {k} x {k} block, and every error is measured on those pixels: \
         relative RMSE of luminance over the ones that do not see an emitter (mean relative error \
         in brackets, over the pixels brighter than 1% of the mean). Times are wall-clock seconds \
         of the frame (Radiance: the `rtrace` process, loading its octree included; the load \
         alone is listed below). Every row but the references is {} render(s) of its setting \
         (Radiance: runs with a fresh ambient file each; wfic: seeds, each against its own seed's \
         brute-force image): the median time and record count, the mean errors. A wfic setting \
         ending in `k K` smooths: it computes the records Ward's cache computes at its accuracy \
         `a`, and each pixel interpolates all those valid at `K a`.\n",
        config.accuracy,
        config.resolution,
        4 * n,
        config.accuracy,
        config.light_samples,
        4 * n,
        4 * n,
        config.converged_light_samples,
        config.repeats.max(1)
    );
    let _ = writeln!(
        s,
        "| scene | triangles | source | renderer | workers | setting | seconds | records | records 2/1 | cache error | image error |"
    );
    let _ = writeln!(s, "|---|---:|---|---|---:|---|---:|---:|---:|---:|---:|");
    for r in results {
        for (renderer, role) in [
            ("radiance", "matched"),
            ("wfic", "matched"),
            ("wfic", "equal-error"),
            ("wfic", "most-accurate"),
            ("wfic", "equal-error-1"),
            ("wfic", "most-accurate-1"),
            ("wfic", "equal-error-2"),
            ("wfic", "most-accurate-2"),
        ] {
            let (Some(one), Some(two)) = (r.find(renderer, role, 1), r.find(renderer, role, 2))
            else {
                continue;
            };
            for run in [one, two] {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {role}: a {} N {}{} | {:.3} | {} | {} | {} ({}) | {} ({}) |",
                    r.scene,
                    r.triangles,
                    r.source,
                    renderer,
                    run.workers,
                    run.accuracy,
                    run.rays,
                    if renderer == "wfic" {
                        format!(
                            " L {} r_min {} px{}",
                            run.light_samples,
                            run.min_radius_pixels,
                            smoothing_label(run)
                        )
                    } else {
                        String::new()
                    },
                    run.seconds,
                    run.records,
                    if run.workers == 2 {
                        format!("{:.3}", run.records as f64 / one.records.max(1) as f64)
                    } else {
                        "".to_owned()
                    },
                    pct(run.cache_error.rel_rmse),
                    pct(run.cache_error.mean_rel),
                    pct(run.image_error.rel_rmse),
                    pct(run.image_error.mean_rel),
                );
            }
        }
    }
    let _ = writeln!(s, "\n## Time at equal error\n");
    let _ = writeln!(
        s,
        "Each worker count's wfic setting is the cheapest swept one (2 threads) at or below \
         Radiance's cache error at that worker count. The goal holds when the frames rendered \
         again at that setting err at or below Radiance (else `NO: error above`) and take at \
         most 0.1x its time. A swept setting whose frames at that worker count erred above is \
         passed over for the next cheapest (up to 4 tries; `radiance.csv` lists them as \
         `pick-tried`). With {} render(s) a row, errors are means (the range of the renders in \
         brackets) and times medians.\n",
        config.repeats.max(1)
    );
    let _ = writeln!(
        s,
        "| scene | workers | radiance s | radiance cache error (range) | wfic setting | wfic s | wfic cache error (range) | time ratio wfic/radiance | goal <= 0.1 | extra records at 2 (wfic) | goal <= 2% |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---|---:|---:|---:|---|---:|---|");
    for r in results {
        for workers in [1, 2] {
            // This worker count's pick: one setting for both, or one each.
            let own = [
                "equal-error",
                "most-accurate",
                if workers == 1 {
                    "equal-error-1"
                } else {
                    "equal-error-2"
                },
                if workers == 1 {
                    "most-accurate-1"
                } else {
                    "most-accurate-2"
                },
            ];
            let Some(role) = own
                .into_iter()
                .find(|role| r.find("wfic", role, workers).is_some())
            else {
                continue;
            };
            let (w1, w2) = (r.find("wfic", role, 1), r.find("wfic", role, 2));
            let (Some(rad), Some(wf)) = (
                r.find("radiance", "matched", workers),
                r.find("wfic", role, workers),
            ) else {
                continue;
            };
            let ratio = wf.seconds / rad.seconds;
            let extra = match (w1, w2) {
                (Some(a), Some(b)) => b.records as f64 / a.records.max(1) as f64 - 1.0,
                _ => f64::NAN,
            };
            let _ = writeln!(
                s,
                "| {} | {workers} | {:.3} | {} | {role}: {} | {:.3} | {} | {:.4} | {} | {} | {} |",
                r.scene,
                rad.seconds,
                with_range(rad),
                wfic_setting(wf),
                wf.seconds,
                with_range(wf),
                ratio,
                speed_goal(role, wf, rad),
                pct(extra),
                if extra <= 0.02 { "yes" } else { "NO" },
            );
        }
    }
    let _ = writeln!(
        s,
        "\n## Image noise against light samples (wfic at the equal-error cache setting)\n"
    );
    let _ = writeln!(
        s,
        "| scene | radiance image error (1 worker) | light samples | wfic s, 1 thread | wfic s, 2 threads | wfic image error | at or below radiance | time ratio to radiance, 1 / 2 workers |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---|---|");
    for r in results {
        let Some(rad) = r.find("radiance", "matched", 1) else {
            continue;
        };
        let rad2 = r.find("radiance", "matched", 2).unwrap_or(rad);
        let mut first = true;
        for run in r
            .runs
            .iter()
            .filter(|x| x.role == "light-samples" && x.workers == 2)
        {
            let one = r
                .runs
                .iter()
                .find(|x| {
                    x.role == "light-samples"
                        && x.workers == 1
                        && x.light_samples == run.light_samples
                })
                .unwrap_or(run);
            let meets = run.image_error.rel_rmse <= rad.image_error.rel_rmse;
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.3} | {:.3} | {} | {} | {:.4} / {:.4} |",
                r.scene,
                pct(rad.image_error.rel_rmse),
                run.light_samples,
                one.seconds,
                run.seconds,
                pct(run.image_error.rel_rmse),
                match (meets, first) {
                    (true, true) => "**yes: the smallest count**",
                    (true, false) => "yes",
                    _ => "no",
                },
                one.seconds / rad.seconds,
                run.seconds / rad2.seconds
            );
            first &= !meets;
        }
    }
    let _ = writeln!(s, "\n## The sweep (wfic, 2 threads) and the references\n");
    let _ = writeln!(
        s,
        "| scene | renderer | role | a | N | L | r_min px | k | seconds | records | cache error | image error |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    for r in results {
        for run in r
            .runs
            .iter()
            .filter(|x| x.role == "sweep" || x.role == "reference")
        {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {:.3} | {} | {} | {} |",
                r.scene,
                run.renderer,
                run.role,
                run.accuracy,
                run.rays,
                run.light_samples,
                run.min_radius_pixels,
                run.smoothing,
                run.seconds,
                run.records,
                pct(run.cache_error.rel_rmse),
                pct(run.image_error.rel_rmse)
            );
        }
    }
    let _ = writeln!(s, "\n## Cross-check and load times\n");
    let _ = writeln!(
        s,
        "| scene | Radiance brute force vs converged wfic: error | mean luminance ratio | rtrace load + 1 ray (s) | oconv (s) |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|");
    for r in results {
        let _ = writeln!(
            s,
            "| {} | {} ({}) | {:.4} | {:.3} | {:.3} |",
            r.scene,
            pct(r.cross_check.rel_rmse),
            pct(r.cross_check.mean_rel),
            r.mean_ratio,
            r.radiance_load_seconds,
            r.oconv_seconds
        );
    }
    let _ = writeln!(
        s,
        "\nSide-by-side images: `SCENE-side-by-side.png` (top: Radiance, wfic, cached, one exposure; \
         bottom: each one's relative error against its own brute-force image, black 0 to white 20%, \
         grey: not measured)."
    );
    s
}

/// A wfic row's setting as the tables name it: `a 0.15 N 320 r_min 6 px`, with `k 1.5` after it
/// when the row smooths.
fn wfic_setting(run: &Run) -> String {
    format!(
        "a {} N {} r_min {} px{}",
        run.accuracy,
        run.rays,
        run.min_radius_pixels,
        smoothing_label(run)
    )
}

/// ` k K` for a row that smooths (K above 1), else nothing.
fn smoothing_label(run: &Run) -> String {
    if run.smoothing > 1.0 {
        format!(" k {}", run.smoothing)
    } else {
        String::new()
    }
}

/// Every run as CSV.
fn csv(results: &[SceneComparison]) -> String {
    let mut s = String::from(
        "scene,triangles,source,renderer,role,workers,accuracy,rays,light_samples,min_radius_pixels,smoothing,seconds,records,\
         cache_rel_rmse,cache_mean_rel,image_rel_rmse,image_mean_rel,repeats,cache_rel_rmse_min,cache_rel_rmse_max\n",
    );
    for r in results {
        for run in &r.runs {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{},{:.4},{},{:.6},{:.6},{:.6},{:.6},{},{:.6},{:.6}",
                r.scene,
                r.triangles,
                r.source,
                run.renderer,
                run.role,
                run.workers,
                run.accuracy,
                run.rays,
                run.light_samples,
                run.min_radius_pixels,
                run.smoothing,
                run.seconds,
                run.records,
                run.cache_error.rel_rmse,
                run.cache_error.mean_rel,
                run.image_error.rel_rmse,
                run.image_error.mean_rel,
                run.repeats,
                run.cache_error_range.0,
                run.cache_error_range.1
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One render of `renderer`'s `role` at `workers`: a 0.15, N 512, 8 light samples, 6 px,
    /// 100 records, every error `error`. Tests change the fields they are about.
    fn one_run(
        renderer: &'static str,
        role: &'static str,
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
            repeats: 1,
            cache_error_range: (error, error),
        }
    }

    #[test]
    fn the_speed_goal_needs_the_error_at_or_below_and_a_tenth_of_the_time() {
        let run = |seconds: f64, error: f64| one_run("wfic", "equal-error", 1, seconds, error);
        let rad = run(10.0, 0.02);
        assert_eq!(speed_goal("equal-error", &run(1.0, 0.02), &rad), "yes");
        assert_eq!(speed_goal("equal-error-2", &run(0.5, 0.019), &rad), "yes");
        assert_eq!(speed_goal("equal-error", &run(1.01, 0.01), &rad), "NO");
        assert_eq!(
            speed_goal("equal-error-1", &run(0.5, 0.0201), &rad),
            "NO: error above"
        );
        assert_eq!(speed_goal("most-accurate", &run(0.5, 0.01), &rad), "NO");
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
            ..one_run("wfic", "sweep", 2, seconds, error)
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
        let run = |renderer, role, workers, seconds, error, range, repeats| Run {
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
            runs: vec![
                run("radiance", "matched", 1, 2.0, 0.0118, (0.0116, 0.0121), 3),
                run("radiance", "matched", 2, 1.5, 0.0119, (0.0114, 0.0122), 3),
                run("wfic", "equal-error", 1, 0.3, 0.0118, (0.0112, 0.0128), 3),
                Run {
                    smoothing: 1.5,
                    ..run("wfic", "equal-error", 2, 0.1, 0.0115, (0.0115, 0.0115), 1)
                },
            ],
            cross_check: ImageError {
                rel_rmse: 0.0,
                mean_rel: 0.0,
            },
            mean_ratio: 1.0,
        };
        let machine = Machine {
            cores: 2,
            cpu: "test CPU".into(),
        };
        let config = RadianceConfig::full(vec!["cornell".into()]);
        let md = markdown(
            &config,
            std::slice::from_ref(&comparison),
            &machine,
            "R",
            "cmd",
        );
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

    #[test]
    fn the_error_is_relative_to_the_reference_and_skips_masked_pixels() {
        let mut a = Image::new(2, 1);
        let mut b = Image::new(2, 1);
        a.set(0, 0, Vec3::splat(1.1));
        b.set(0, 0, Vec3::splat(1.0));
        // The second pixel is far off but masked out.
        a.set(1, 0, Vec3::splat(9.0));
        b.set(1, 0, Vec3::splat(1.0));
        let e = image_error(&a, &b, &[true, false]);
        assert!((e.rel_rmse - 0.1).abs() < 1e-5, "{e:?}");
        assert!((e.mean_rel - 0.1).abs() < 1e-5, "{e:?}");
        let all = image_error(&a, &b, &[true, true]);
        assert!(all.rel_rmse > 1.0, "{all:?}");
    }
}

/// One run of Radiance's own multi-process sharing: `rtrace -n P` processes sharing one ambient
/// file (Radiance's answer to distributing the cache, over NFS and file locks on a cluster).
#[derive(Clone, Debug, PartialEq)]
pub struct SharedAmbientRun {
    /// `rtrace` processes.
    pub processes: usize,
    /// Wall-clock seconds of the `rtrace` run.
    pub seconds: f64,
    /// Records in the ambient file at the end.
    pub records: usize,
    /// Bytes of the ambient file at the end (every record written once, read by the others).
    pub ambient_bytes: u64,
    /// Error against Radiance's brute-force image (`-aa 0`, 4x the rays) on the grid.
    pub error: ImageError,
}

/// Radiance's side of `wfic reproduce distributed`: the scene exported as [`compare_scene`]
/// does, one brute-force reference (`-aa 0 -ad 4N`, at one pixel in `stride` x `stride`, 2
/// processes), and for each count in `processes` one cached run (`-ab 1 -ad N -aa a -ar res`)
/// with that many `rtrace` processes sharing a fresh ambient file, each measured against the
/// reference over the non-emitter pixels of the grid. Returns the runs and the reference's
/// seconds. Work files go to `work`.
///
/// # Errors
/// A Radiance tool that fails, or a file that cannot be written or read.
pub fn shared_ambient(
    bin: &RadianceBin,
    scene: &Scene,
    settings: &RenderSettings,
    resolution: u32,
    stride: u32,
    processes: &[usize],
    work: &Path,
) -> Result<(Vec<SharedAmbientRun>, f64), String> {
    std::fs::create_dir_all(work).map_err(|e| format!("{}: {e}", work.display()))?;
    let (n, a) = (settings.rays_per_record, settings.accuracy);
    let size = (settings.width, settings.height);
    let mask = surface_mask(scene, settings, stride);
    let rad = work.join("scene.rad");
    write_rad(scene, &rad)?;
    let oct = work.join("scene.oct");
    let mut oconv = bin.command("oconv");
    oconv.arg("-f").arg(&rad);
    run_timed(oconv, None, &oct, "oconv")?;
    let rays = work.join("rays.f32");
    write_rays(scene, settings, 1, &rays)?;
    let grid_rays = work.join("grid-rays.f32");
    write_rays(scene, settings, stride, &grid_rays)?;
    let rtrace = |args: &[String], workers: usize, amb: Option<&Path>| {
        rtrace_command(bin, &oct, args, workers, amb)
    };
    let ref_out = work.join("ref.f32");
    let ref_args = ["-aa", "0", "-ad", &(4 * n).to_string(), "-as", "0"].map(str::to_owned);
    let ref_seconds = run_timed(
        rtrace(&ref_args, 2, None),
        Some(&grid_rays),
        &ref_out,
        "rtrace (reference)",
    )?;
    let reference = read_floats(&ref_out, size, stride)?;
    let cache_args = [
        "-ad",
        &n.to_string(),
        "-as",
        "0",
        "-aa",
        &a.to_string(),
        "-ar",
        &resolution.to_string(),
    ]
    .map(str::to_owned);
    let mut runs = Vec::new();
    for &p in processes {
        let amb = work.join(format!("shared-{p}.amb"));
        std::fs::remove_file(&amb).ok();
        let out = work.join(format!("shared-{p}.f32"));
        let seconds = run_timed(
            rtrace(&cache_args, p, Some(&amb)),
            Some(&rays),
            &out,
            "rtrace",
        )?;
        let img = read_floats(&out, size, 1)?;
        runs.push(SharedAmbientRun {
            processes: p,
            seconds,
            records: ambient_records(bin, &amb)?,
            ambient_bytes: std::fs::metadata(&amb).map_or(0, |m| m.len()),
            error: image_error(&img, &reference, &mask),
        });
    }
    Ok((runs, ref_seconds))
}
