//! Radiance's side of the comparisons: finding its binaries, exporting a wfic scene, feeding
//! it wfic's primary rays, and timing `rtrace` runs (a brute-force reference, cached runs on
//! one ambient file shared by `P` processes).

use super::export::{write_rad, Export};
use crate::harness::measure::time_command;
use crate::harness::metrics::{image_error, surface_mask, ImageError};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use wfic_render::film::Image;
use wfic_render::{RenderSettings, Scene};

/// The settings of Radiance's converged image besides `-aa 0 -ad N` ([`Rtrace::converged`]).
pub const CONVERGED_DIRECT: &str = "-as 0 -dt 0 -dc 1 -ds 0.005 -dj 0";

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
        candidates.extend(std::env::var_os("WFIC_RADIANCE_BIN").map(PathBuf::from));
        if let Some(path) = std::env::var_os("PATH") {
            candidates.extend(std::env::split_paths(&path));
        }
        candidates.extend(pyradiance_dir().map(|dir| dir.join("bin")));
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

/// The error of an I/O operation on `path`.
fn io_error(path: &Path) -> impl Fn(std::io::Error) -> String + '_ {
    move |e| format!("{}: {e}", path.display())
}

/// Runs `cmd`, feeding `stdin` from a file and writing stdout to a file; its wall seconds.
fn run_to_file(
    mut cmd: Command,
    stdin: Option<&Path>,
    stdout: &Path,
    what: &str,
) -> Result<f64, String> {
    cmd.stdout(std::fs::File::create(stdout).map_err(io_error(stdout))?);
    if let Some(i) = stdin {
        cmd.stdin(std::fs::File::open(i).map_err(io_error(i))?);
    }
    Ok(time_command(&mut cmd, what)?.1)
}

/// The pixels of a `w` x `h` image's grid of one pixel in `stride` x `stride`, rows from the top.
fn grid((w, h): (u32, u32), stride: u32) -> impl Iterator<Item = (u32, u32)> {
    let along = move |n: u32| (stride / 2..n).step_by(stride as usize);
    along(h).flat_map(move |y| along(w).map(move |x| (x, y)))
}

/// wfic's primary rays for `settings`' image on its grid of `stride` (one through each pixel's
/// centre), as `rtrace -if` reads them: origin and direction, six native-endian `f32`s a pixel.
fn write_rays(
    scene: &Scene,
    settings: &RenderSettings,
    stride: u32,
    path: &Path,
) -> Result<(), String> {
    let (w, h) = (settings.width, settings.height);
    let view = scene.camera().view(w, h);
    let mut bytes = Vec::with_capacity((w * h * 24) as usize);
    for (x, y) in grid((w, h), stride) {
        let (o, d) = (view.eye(), view.direction(x as f32 + 0.5, y as f32 + 0.5));
        for c in [o.x, o.y, o.z, d.x, d.y, d.z] {
            bytes.extend_from_slice(&c.to_ne_bytes());
        }
    }
    std::fs::write(path, bytes).map_err(io_error(path))
}

/// Reads `rtrace -ff` output (three `f32`s a ray, the rays of [`write_rays`] with `stride`)
/// into a `w` x `h` image (black where no ray was traced).
fn read_floats(path: &Path, size: (u32, u32), stride: u32) -> Result<Image, String> {
    read_averaged(path, size, stride, 1)
}

/// [`read_floats`] for rays each traced `passes` times in a row: each pixel the mean of its
/// `passes` results.
fn read_averaged(
    path: &Path,
    (w, h): (u32, u32),
    stride: u32,
    passes: u32,
) -> Result<Image, String> {
    let bytes = std::fs::read(path).map_err(io_error(path))?;
    let per_pixel = 12 * passes.max(1) as usize;
    let want = per_pixel * grid((w, h), stride).count();
    if bytes.len() != want {
        return Err(format!(
            "{}: {} bytes, expected {want} ({w} x {h} RGB floats, {passes} a pixel)",
            path.display(),
            bytes.len()
        ));
    }
    let mut img = Image::new(w, h);
    for ((x, y), px) in grid((w, h), stride).zip(bytes.chunks_exact(per_pixel)) {
        let sum = px.chunks_exact(12).fold(Vec3::ZERO, |acc, c| {
            let f = |k: usize| f32::from_ne_bytes(c[k..k + 4].try_into().expect("4 bytes"));
            acc + Vec3::new(f(0), f(4), f(8))
        });
        img.set(x, y, sum / passes.max(1) as f32);
    }
    Ok(img)
}

/// Records in a Radiance ambient file, counted from `lookamb -h`'s text (one `Position` line a
/// record). A missing file (no record was written) counts 0.
fn ambient_records(bin: &RadianceBin, amb: &Path) -> Result<usize, String> {
    if !amb.exists() {
        return Ok(0);
    }
    let what = format!("lookamb {}", amb.display());
    let (out, _) = time_command(bin.command("lookamb").arg("-h").arg(amb), &what)?;
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| l.trim_start().starts_with("Position"))
        .count())
}

/// An octree one of [`Rtrace`]'s preparations built, and where its scene came from.
struct Built {
    oct: PathBuf,
    oconv_seconds: f64,
    export: Option<Export>,
    original: Option<(PathBuf, String)>,
}

/// A scene exported for Radiance in a work folder: its octree, wfic's primary rays (every
/// pixel's, and the reference grid's), and the `rtrace` runs made on them.
pub struct Rtrace<'a> {
    bin: &'a RadianceBin,
    work: PathBuf,
    oct: PathBuf,
    rays: PathBuf,
    grid_rays: PathBuf,
    size: (u32, u32),
    stride: u32,
    /// Seconds of `oconv` (timed apart, like wfic's BVH build).
    pub oconv_seconds: f64,
    /// What the scene file holds, when it is wfic's export: its light sources and their power.
    pub export: Option<Export>,
    /// The folder Radiance's commands run in and the `RAYPATH` they get, when the model is
    /// Radiance's own original (its files name each other, its patterns and fonts, by name).
    original: Option<(PathBuf, String)>,
}

/// Greg Ward's office in Radiance's distribution (`obj/office`): the scene files in the order
/// `office.rif` lists them, and the scale wfic's conversion gives a unit (3 inches, in metres).
pub const OFFICE_FILES: [&str; 8] = [
    "model.b90",
    "desk",
    "misc",
    "window",
    "blinds",
    "lights",
    "lamp",
    "picture",
];
/// One office unit in metres.
pub const OFFICE_SCALE: f32 = 0.0762;

impl<'a> Rtrace<'a> {
    /// Exports `scene` into `work` (created): the scene file, its octree, the rays of
    /// `settings`' image and of its grid of one pixel in `stride` x `stride`.
    pub fn prepare(
        bin: &'a RadianceBin,
        scene: &Scene,
        settings: &RenderSettings,
        stride: u32,
        work: &Path,
    ) -> Result<Self, String> {
        std::fs::create_dir_all(work).map_err(io_error(work))?;
        let (rad, oct) = (work.join("scene.rad"), work.join("scene.oct"));
        let export = write_rad(scene, &rad)?;
        let mut oconv = bin.command("oconv");
        oconv.arg("-f").arg(&rad);
        let oconv_seconds = run_to_file(oconv, None, &oct, "oconv")?;
        let built = Built {
            oct,
            oconv_seconds,
            export: Some(export),
            original: None,
        };
        Self::with_rays(bin, work, built, scene, settings, stride)
    }

    /// The comparison over the octree `built`, with the rays of `scene` and `settings` (every
    /// pixel, and the grid of `stride`) written to `work`.
    fn with_rays(
        bin: &'a RadianceBin,
        work: &Path,
        built: Built,
        scene: &Scene,
        settings: &RenderSettings,
        stride: u32,
    ) -> Result<Self, String> {
        let (rays, grid_rays) = (work.join("rays.f32"), work.join("grid-rays.f32"));
        write_rays(scene, settings, 1, &rays)?;
        write_rays(scene, settings, stride, &grid_rays)?;
        Ok(Self {
            bin,
            work: work.to_owned(),
            oct: built.oct,
            rays,
            grid_rays,
            size: (settings.width, settings.height),
            stride,
            oconv_seconds: built.oconv_seconds,
            export: built.export,
            original: built.original,
        })
    }

    /// Radiance's own model of the office, as its distribution has it (`tree` is a copy of
    /// `LBNL-ETA/Radiance`, branch `auxiliary`): its scene files with their materials, patterns,
    /// text and light sources as published, only scaled to metres (`xform -s`, the conversion's
    /// scale) so that wfic's rays for `scene` (the `desk` or `office` view) and `settings` apply.
    /// The distribution names `pine.pic`, which it holds as `pine.hdr`; a link in `work` gives it.
    pub fn prepare_original(
        bin: &'a RadianceBin,
        tree: &Path,
        scene: &Scene,
        settings: &RenderSettings,
        stride: u32,
        work: &Path,
    ) -> Result<Self, String> {
        let work = &std::path::absolute(work).map_err(io_error(work))?;
        let tree = &std::path::absolute(tree).map_err(io_error(tree))?;
        std::fs::create_dir_all(work).map_err(io_error(work))?;
        let (office, lib) = (tree.join("obj/office"), tree.join("lib"));
        if !office.join("office.rif").is_file() || !lib.join("pine.hdr").is_file() {
            return Err(format!(
                "{} holds no obj/office/office.rif and lib/pine.hdr: give a copy of \
                 LBNL-ETA/Radiance, branch auxiliary",
                tree.display()
            ));
        }
        let links = work.join("lib");
        std::fs::create_dir_all(&links).map_err(io_error(&links))?;
        let pic = links.join("pine.pic");
        std::fs::remove_file(&pic).ok();
        std::os::unix::fs::symlink(lib.join("pine.hdr"), &pic).map_err(io_error(&pic))?;
        let raypath = format!(
            ".:{}:{}{}",
            links.display(),
            lib.display(),
            bin.raypath
                .as_ref()
                .map_or(String::new(), |p| format!(":{p}"))
        );
        let rad = work.join("original.rad");
        let text = format!(
            "# Greg Ward's office (Radiance's obj/office), its scene files in office.rif's \
             order, in metres\n!xform -s {OFFICE_SCALE} {}\n",
            OFFICE_FILES.join(" ")
        );
        std::fs::write(&rad, text).map_err(io_error(&rad))?;
        let oct = work.join("original.oct");
        // `!xform` lines run through the shell, which must find Radiance's own `xform`.
        let path = std::env::join_paths(
            std::iter::once(bin.dir.clone()).chain(
                std::env::var_os("PATH")
                    .iter()
                    .flat_map(std::env::split_paths),
            ),
        )
        .map_err(|e| e.to_string())?;
        let mut oconv = bin.command("oconv");
        oconv.env("RAYPATH", &raypath).env("PATH", path);
        oconv.current_dir(&office);
        oconv.arg("-f").arg(&rad);
        oconv.stdout(std::fs::File::create(&oct).map_err(io_error(&oct))?);
        let (out, oconv_seconds) = time_command(&mut oconv, "oconv (original)")?;
        let warnings = String::from_utf8_lossy(&out.stderr);
        if warnings.contains("bad status") || warnings.contains("empty file") {
            return Err(format!("oconv (original): {}", warnings.trim()));
        }
        let built = Built {
            oct,
            oconv_seconds,
            export: None,
            original: Some((office, raypath)),
        };
        Self::with_rays(bin, work, built, scene, settings, stride)
    }

    /// `rtrace` as both comparisons run it: one bounce, no ambient value or weight,
    /// deterministic direct light, binary floats in and out, `workers` processes sharing the
    /// ambient file `amb` when given; `args` (space-separated) add the cache's settings.
    fn rtrace(&self, args: &str, workers: usize, amb: Option<&Path>) -> Command {
        let mut c = self.bin.command("rtrace");
        if let Some((dir, raypath)) = &self.original {
            c.env("RAYPATH", raypath).current_dir(dir);
        }
        c.args(["-h-", "-fff", "-ab", "1", "-av", "0", "0", "0", "-aw", "0"]);
        c.args(["-dj", "0", "-lw", "1e-7"]).args(args.split(' '));
        c.args(["-n", &workers.to_string()]);
        if let Some(amb) = amb {
            c.arg("-af").arg(amb);
        }
        c.arg(&self.oct);
        c
    }

    /// Seconds `rtrace` takes to load the octree and trace one ray.
    pub fn load_seconds(&self) -> Result<f64, String> {
        let one = self.work.join("one.f32");
        let rays = std::fs::read(&self.rays).map_err(io_error(&self.rays))?;
        std::fs::write(&one, &rays[..24]).map_err(io_error(&one))?;
        let cmd = self.rtrace("-ab 0", 1, None);
        run_to_file(cmd, Some(&one), &self.work.join("one.out"), "rtrace (load)")
    }

    /// Radiance's brute-force image on the grid: no cache (`-aa 0`), `rays` rays, 2 processes;
    /// and its seconds.
    pub fn reference(&self, rays: u32) -> Result<(Image, f64), String> {
        let out = self.work.join("ref.f32");
        let cmd = self.rtrace(&format!("-aa 0 -ad {rays} -as 0"), 2, None);
        let seconds = run_to_file(cmd, Some(&self.grid_rays), &out, "rtrace (reference)")?;
        Ok((read_floats(&out, self.size, self.stride)?, seconds))
    }

    /// Radiance's converged image on the grid, what a Radiance user would take as the truth of
    /// the scene: no cache (`-aa 0`), `rays` rays (`-ad`), every source tested (`-dt 0 -dc 1`),
    /// sources subdivided finely (`-ds 0.005`) and sampled at their parts' centres (`-dj 0`:
    /// the direct light a fine quadrature, no noise), each pixel's ray traced `passes` times and
    /// averaged (each trace draws its own hemisphere), 2 processes; and its seconds.
    ///
    /// Jittered sources (`-dj 0.9`) were tried and dropped: on the desk a pass erred 17% from
    /// its mean, nearly all of it in the two pixels of the lamp's reflector beside the bulb,
    /// and the mean of 64 passes still 3.9%, while the unjittered images at `-ds` 0.2, 0.005
    /// and 0.001 agreed with that mean within its noise there (docs/tried-and-dropped.md).
    pub fn converged(&self, rays: u32, passes: u32) -> Result<(Image, f64), String> {
        let input = self.work.join("converged-rays.f32");
        let bytes = std::fs::read(&self.grid_rays).map_err(io_error(&self.grid_rays))?;
        let repeated: Vec<u8> = bytes
            .chunks_exact(24)
            .flat_map(|ray| ray.repeat(passes as usize))
            .collect();
        std::fs::write(&input, repeated).map_err(io_error(&input))?;
        let out = self.work.join("converged.f32");
        let cmd = self.rtrace(&format!("-aa 0 -ad {rays} {CONVERGED_DIRECT}"), 2, None);
        let seconds = run_to_file(cmd, Some(&input), &out, "rtrace (converged)")?;
        Ok((
            read_averaged(&out, self.size, self.stride, passes)?,
            seconds,
        ))
    }

    /// A cached image of every pixel (`-ad rays -as 0 -aa accuracy -ar resolution`) by
    /// `workers` processes sharing the fresh ambient file `NAME.amb`: the image, its seconds,
    /// the records and bytes of the ambient file.
    pub fn cached(
        &self,
        (accuracy, rays, resolution): (f32, u32, u32),
        workers: usize,
        name: &str,
    ) -> Result<(Image, f64, usize, u64), String> {
        let amb = self.work.join(format!("{name}.amb"));
        std::fs::remove_file(&amb).ok();
        let out = self.work.join(format!("{name}.f32"));
        let args = format!("-ad {rays} -as 0 -aa {accuracy} -ar {resolution}");
        let cmd = self.rtrace(&args, workers, Some(&amb));
        let seconds = run_to_file(cmd, Some(&self.rays), &out, "rtrace")?;
        let img = read_floats(&out, self.size, 1)?;
        let bytes = std::fs::metadata(&amb).map_or(0, |m| m.len());
        Ok((img, seconds, ambient_records(self.bin, &amb)?, bytes))
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

/// Radiance's side of `wfic reproduce distributed`: one brute-force reference (`-aa 0 -ad 4N`
/// on the grid) and, per count in `processes`, one cached run of that many `rtrace` processes
/// sharing a fresh ambient file, against it; the runs and the reference's seconds.
pub fn shared_ambient(
    bin: &RadianceBin,
    scene: &Scene,
    settings: &RenderSettings,
    resolution: u32,
    stride: u32,
    processes: &[usize],
    work: &Path,
) -> Result<(Vec<SharedAmbientRun>, f64), String> {
    let (n, a) = (settings.rays_per_record, settings.accuracy);
    let mask = surface_mask(scene, settings, stride);
    let rtrace = Rtrace::prepare(bin, scene, settings, stride, work)?;
    let (reference, ref_seconds) = rtrace.reference(4 * n)?;
    let mut runs = Vec::new();
    for &p in processes {
        let (img, seconds, records, ambient_bytes) =
            rtrace.cached((a, n, resolution), p, &format!("shared-{p}"))?;
        runs.push(SharedAmbientRun {
            processes: p,
            seconds,
            records,
            ambient_bytes,
            error: image_error(&img, &reference, &mask),
        });
    }
    Ok((runs, ref_seconds))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rays traced several times in a row come back as their mean, each on its own pixel of the
    /// grid; a file of the wrong length is refused, naming it.
    #[test]
    fn a_pixels_repeated_traces_are_averaged_on_its_grid_pixel() {
        let dir = std::env::temp_dir().join(format!("wfic-read-averaged-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("out.f32");
        // A 4 x 2 image, stride 2: pixels (1, 1) and (3, 1), three traces each.
        let traces = [[1.0f32, 2.0, 3.0], [3.0, 2.0, 1.0], [2.0, 2.0, 2.0]];
        let mut bytes = Vec::new();
        for scale in [1.0f32, 10.0] {
            for t in traces {
                for c in t {
                    bytes.extend_from_slice(&(c * scale).to_ne_bytes());
                }
            }
        }
        std::fs::write(&path, &bytes).unwrap();
        let img = read_averaged(&path, (4, 2), 2, 3).unwrap();
        assert_eq!(img.get(1, 1), Vec3::splat(2.0));
        assert_eq!(img.get(3, 1), Vec3::splat(20.0));
        assert_eq!(img.get(0, 0), Vec3::ZERO);
        let err = read_averaged(&path, (4, 2), 2, 2).unwrap_err();
        assert!(
            err.contains("out.f32") && err.contains("2 a pixel"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
