//! `wfic reproduce distributed`: one frame rendered by several MPI ranks sharing their
//! records, against one rank, ranks that share nothing, and Radiance's `rtrace -n P`; each job
//! is `mpirun` on this binary (`wfic render --distributed`), see
//! `docs/experiments.md#distributed`.

mod report;

use crate::harness::measure::{repeat, time_command};
use crate::harness::metrics::{image_error, surface_mask, ImageError};
use crate::harness::stats::{self, median_index, Middle};
use crate::harness::table::pct;
use crate::harness::{Check, Machine, Verdict};
use crate::radiance::{self, RadianceBin, SharedAmbientRun};
use std::path::{Path, PathBuf};
use std::process::Command;
use wfic_render::film::Image;
use wfic_render::stats::{DistributedFrameStats, DistributedStats};
use wfic_render::{render_reference_grid, scenes, RenderSettings, Scene};

/// The scene of the experiment.
pub const SCENE: &str = "cornell";

/// What one run of the experiment does.
#[derive(Clone, Debug, PartialEq)]
pub struct DistributedConfig {
    /// Built-in scene.
    pub scene: String,
    /// Image size, sampling, accuracy (one primary ray a pixel, as `rtrace` traces).
    pub settings: RenderSettings,
    /// Repeats of every job; each reports its median-time run.
    pub runs: usize,
    /// The batch sizes of the sweep (2 ranks x 1 thread, the timer off).
    pub batches: Vec<usize>,
    /// The batch timer of the main jobs, in milliseconds.
    pub batch_ms: u64,
    /// The batch size of the main jobs.
    pub batch_records: usize,
    /// The brute-force references are traced at one pixel in `stride` x `stride`.
    pub stride: u32,
    /// Radiance's ambient resolution (`-ar`).
    pub radiance_resolution: u32,
    /// Run Radiance (false: `--no-radiance`, or `rtrace` was not found).
    pub radiance: bool,
    /// Frames of the orbit animation (0: none), the caches kept across frames.
    pub animation_frames: usize,
}

/// One `mpirun` job's layout.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layout {
    /// What the row is called in the tables.
    pub label: &'static str,
    /// Ranks.
    pub ranks: usize,
    /// Threads per rank.
    pub threads: usize,
    /// Whether the ranks exchange records.
    pub share: bool,
    /// Batch size (records).
    pub batch_records: usize,
    /// Batch timer (ms).
    pub batch_ms: u64,
    /// Deterministic frames (`--deterministic`: round-robin tiles, an exchange a pass).
    pub deterministic: bool,
}

/// A timer too long to fire in a frame: the sweep's rounds start on the batch size (or a rank
/// running short of tiles) only.
const TIMER_OFF_MS: u64 = 600_000;

/// The labels of the layouts the tables and checks compare.
const ONE: &str = "1 rank x 2 threads";
const SHARED: &str = "2 ranks x 1 thread, shared";
const ALONE: &str = "2 ranks x 1 thread, independent";

impl DistributedConfig {
    /// Refuses a configuration that cannot run: runs and batches out of their ranges
    /// ([`crate::bounds`], [`wfic_render::limits`]).
    ///
    /// # Errors
    /// The argument at fault, named with its range.
    pub fn validate(&self) -> Result<(), String> {
        let range = |e: wfic_render::limits::OutOfRange| e.for_option();
        crate::bounds::RUNS.check(self.runs).map_err(range)?;
        for &b in self.batches.iter().chain([&self.batch_records]) {
            wfic_render::limits::BATCH_RECORDS.check(b).map_err(range)?;
        }
        wfic_render::limits::BATCH_MS
            .check(self.batch_ms)
            .map_err(range)?;
        crate::bounds::ORBIT_FRAMES
            .check(self.animation_frames)
            .map_err(range)?;
        self.settings.validate().map_err(range)?;
        Ok(())
    }

    /// The main jobs: 1 x 2, 2 x 1 shared, 2 x 1 independent, 4 x 1 shared.
    pub fn layouts(&self) -> [Layout; 4] {
        let layout = |label, ranks, threads, share| Layout {
            label,
            ranks,
            threads,
            share,
            batch_records: self.batch_records,
            batch_ms: self.batch_ms,
            deterministic: false,
        };
        [
            layout(ONE, 1, 2, true),
            layout(SHARED, 2, 1, true),
            layout(ALONE, 2, 1, false),
            layout("4 ranks x 1 thread, shared", 4, 1, true),
        ]
    }

    /// The batch sweep's layout at `batch` records.
    fn sweep_layout(batch: usize) -> Layout {
        Layout {
            label: "2 ranks x 1 thread, batch sweep",
            ranks: 2,
            threads: 1,
            share: true,
            batch_records: batch,
            batch_ms: TIMER_OFF_MS,
            deterministic: false,
        }
    }

    /// Every layout's `(ranks, threads per rank)`, for the provenance.
    pub fn rank_counts(&self) -> Vec<(usize, usize)> {
        self.layouts()
            .iter()
            .map(|l| (l.ranks, l.threads))
            .collect()
    }

    /// Jobs (progress steps) in all: the progress bar's length.
    pub fn jobs(&self) -> usize {
        let animation = if self.animation_frames > 1 { 4 } else { 0 };
        self.runs * (4 + self.batches.len()) + 1 + animation + usize::from(self.radiance)
    }
}

/// One measured job (its median-time run of [`DistributedConfig::runs`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    /// The layout.
    pub layout: Layout,
    /// Seconds of the frame on rank 0 (agreement to assembled image), median over the runs.
    pub seconds: f64,
    /// The fastest and slowest run's seconds.
    pub range: (f64, f64),
    /// Wall-clock seconds of the whole `mpirun` (start-up and output included), of that run.
    pub wall: f64,
    /// Records computed, per rank.
    pub computed: Vec<u64>,
    /// Records computed where another rank's record is also valid.
    pub duplicates: u64,
    /// Bytes sent by all ranks (each record's payload once per other rank).
    pub bytes: u64,
    /// Exchange rounds (rank 0's; every rank runs the same rounds).
    pub rounds: u64,
    /// The largest rank's seconds in the rounds' collectives.
    pub collective_seconds: f64,
    /// The ranks' seconds spent inserting the others' records, summed.
    pub insert_seconds: f64,
    /// Records received, summed over the ranks.
    pub received: u64,
    /// Error against the brute-force reference.
    pub error: ImageError,
}

impl Job {
    /// Records computed in total.
    pub fn total(&self) -> u64 {
        self.computed.iter().sum()
    }
}

/// An orbit animation over one layout, the caches kept across frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    /// The layout.
    pub layout: Layout,
    /// Its frames, as rank 0 reported them.
    pub frames: Vec<DistributedFrameStats>,
    /// The last frame's error against its brute-force image.
    pub last_error: ImageError,
}

/// The experiment's results.
#[derive(Clone, Debug)]
pub struct Distributed {
    /// What ran.
    pub config: DistributedConfig,
    /// Where.
    pub machine: Machine,
    /// The main jobs: 1 x 2, 2 x 1 shared, 2 x 1 independent, 4 x 1 shared (oversubscribed).
    pub jobs: Vec<Job>,
    /// The batch sweep at 2 x 1.
    pub sweep: Vec<Job>,
    /// The orbit animations (1 x 2, 2 x 1 shared, 2 x 1 independent).
    pub animations: Vec<Animation>,
    /// Radiance at 1 and 2 processes, and its reference's seconds (`None`: not run).
    pub radiance: Option<(Vec<SharedAmbientRun>, f64)>,
    /// Radiance's version line.
    pub radiance_version: String,
    /// wfic's reference seconds.
    pub reference_seconds: f64,
    /// Whether the jobs ran in a loopback-only namespace.
    pub isolated: bool,
}

/// Reads the statistics `wfic render --distributed --stats` wrote to `path`: the one place the
/// experiment maps the renderer's JSON document to Rust values.
fn read_stats(path: &Path) -> Result<DistributedStats, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    DistributedStats::from_json(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Bytes sent by a frame's ranks, summed.
fn bytes_sent(frame: &DistributedFrameStats) -> u64 {
    frame.ranks.iter().map(|r| r.bytes_sent).sum()
}

/// wfic's brute-force reference of `scene` from its camera (`ref_settings`: no cache, more
/// rays) on the grid, its seconds, and the pixels the errors are measured on.
fn brute_force(
    scene: &Scene,
    config: &DistributedConfig,
    ref_settings: &RenderSettings,
) -> Result<(Image, f64, Vec<bool>), String> {
    let rc = ref_settings
        .cache_config(scene)
        .map_err(|e| e.to_string())?;
    let (image, seconds) =
        render_reference_grid(scene, &scene.camera(), ref_settings, rc, 2, config.stride);
    Ok((
        image,
        seconds,
        surface_mask(scene, &config.settings, config.stride),
    ))
}

/// How `mpirun` is started.
pub(crate) struct Launcher {
    bin: PathBuf,
    isolate: bool,
}

impl Launcher {
    /// Finds `mpirun` and this binary; checks the binary was built with the `mpi` feature.
    pub(crate) fn find() -> Result<Self, String> {
        if !cfg!(feature = "mpi") {
            return Err(
                "reproduce distributed runs `wfic render --distributed` under mpirun, \
                        which needs wfic built with the `mpi` feature: install OpenMPI \
                        (apt-get install libopenmpi-dev openmpi-bin libclang-dev), then run \
                        cargo run --release --features mpi -- reproduce distributed ..."
                    .to_owned(),
            );
        }
        let found = Command::new("mpirun").arg("--version").output();
        if !found.is_ok_and(|o| o.status.success()) {
            return Err("mpirun was not found: install OpenMPI (apt-get install \
                        libopenmpi-dev openmpi-bin)"
                .to_owned());
        }
        let bin = std::env::current_exe().map_err(|e| format!("this binary: {e}"))?;
        // A loopback-only namespace when this process may make one (root, or user namespaces).
        let isolate = Command::new("unshare")
            .args(["--net", "--", "sh", "-c", "ip link set lo up"])
            .output()
            .is_ok_and(|o| o.status.success());
        if !isolate {
            eprintln!(
                "note: cannot make a network namespace (unshare --net); mpirun runs in this \
                 one, and OpenMPI's launcher listens on every interface while it runs"
            );
        }
        Ok(Self { bin, isolate })
    }

    /// The `mpirun` command of one job of `frames` frames of built-in scene `scene` with `s`,
    /// writing into `dir`.
    fn command(
        &self,
        layout: &Layout,
        (scene, s): (&str, &RenderSettings),
        frames: usize,
        dir: &Path,
    ) -> Command {
        let mut cmd = Command::new(if self.isolate { "unshare" } else { "mpirun" });
        if self.isolate {
            let lo_up = "ip link set lo up && exec \"$@\"";
            cmd.args(["--net", "--", "sh", "-c", lo_up, "sh", "mpirun"]);
        }
        cmd.args(["-np", &layout.ranks.to_string()]).arg(&self.bin);
        cmd.args(["render", "--distributed", "--quiet", "--scene", scene]);
        for (flag, value) in [
            ("--width", s.width.to_string()),
            ("--height", s.height.to_string()),
            ("--accuracy", s.accuracy.to_string()),
            ("--rays-per-record", s.rays_per_record.to_string()),
            ("--light-samples", s.light_samples.to_string()),
            ("--spp", s.pixel_samples.to_string()),
            ("--seed", s.seed.to_string()),
            ("--threads", layout.threads.to_string()),
            ("--batch-records", layout.batch_records.to_string()),
            ("--batch-ms", layout.batch_ms.to_string()),
            ("--frames", frames.to_string()),
        ] {
            cmd.args([flag, &value]);
        }
        cmd.arg("--out").arg(dir.join("job.png"));
        cmd.arg("--stats").arg(dir.join("job.json"));
        if !layout.share {
            cmd.arg("--no-share");
        }
        if layout.deterministic {
            cmd.arg("--deterministic");
        }
        cmd.envs([
            ("OMPI_MCA_btl", "self,vader"),
            ("OMPI_MCA_rmaps_base_oversubscribe", "1"),
            ("OMPI_ALLOW_RUN_AS_ROOT", "1"),
            ("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1"),
        ]);
        cmd
    }

    /// Runs one job; returns rank 0's image (the last frame's), its statistics and the wall
    /// seconds.
    pub(crate) fn run(
        &self,
        layout: &Layout,
        job: (&str, &RenderSettings),
        frames: usize,
        dir: &Path,
    ) -> Result<(Image, DistributedStats, f64), String> {
        let what = format!("mpirun -np {} ({})", layout.ranks, layout.label);
        let (_, wall) = time_command(&mut self.command(layout, job, frames, dir), &what)?;
        // The last frame's image (`job-NNN.pfm` when there are several).
        let pfm = if frames > 1 {
            dir.join(format!("job-{:03}.pfm", frames - 1))
        } else {
            dir.join("job.pfm")
        };
        let image = Image::read_pfm(&pfm).map_err(|e| format!("{}: {e}", pfm.display()))?;
        Ok((image, read_stats(&dir.join("job.json"))?, wall))
    }
}

/// What every job of a run shares: the launcher, the configuration, the work folder, wfic's
/// brute-force reference and the pixels measured.
struct Bench<'a> {
    launcher: &'a Launcher,
    config: &'a DistributedConfig,
    work: &'a Path,
    reference: &'a Image,
    mask: &'a [bool],
}

impl Bench<'_> {
    /// Runs `layout` [`DistributedConfig::runs`] times; its median-time run (the lower middle
    /// for an even count), with the range of the runs' seconds.
    fn measure(&self, layout: &Layout, progress: &mut dyn FnMut(&str)) -> Result<Job, String> {
        let runs = self.config.runs;
        let runs = repeat(runs, |k| {
            progress(&format!("{} (run {} of {runs})", layout.label, k + 1));
            let job = (self.config.scene.as_str(), &self.config.settings);
            self.launcher.run(layout, job, 1, self.work)
        })?;
        let frame = |s: &DistributedStats| s.frames.frames().first().cloned().unwrap_or_default();
        let times: Vec<f64> = runs.iter().map(|(_, s, _)| frame(s).seconds).collect();
        let (image, stats, wall) = &runs[median_index(&times, Middle::Lower)];
        let stats = frame(stats);
        let ranks = &stats.ranks;
        Ok(Job {
            layout: *layout,
            seconds: stats.seconds,
            range: stats::range(times.iter().copied()),
            wall: *wall,
            computed: ranks.iter().map(|r| r.records_computed).collect(),
            duplicates: stats.duplicates,
            bytes: bytes_sent(&stats),
            rounds: ranks.first().map_or(0, |r| r.rounds),
            collective_seconds: ranks
                .iter()
                .map(|r| r.collective_seconds)
                .fold(0.0, f64::max),
            insert_seconds: ranks.iter().map(|r| r.insert_seconds).sum(),
            received: ranks.iter().map(|r| r.records_received).sum(),
            error: image_error(image, self.reference, self.mask),
        })
    }

    /// The orbit animation over the first three main layouts, each frame's figures and the
    /// last frame's error against its own reference.
    fn animate(
        &self,
        ref_settings: &RenderSettings,
        progress: &mut dyn FnMut(&str),
    ) -> Result<Vec<Animation>, String> {
        let (config, n) = (self.config, self.config.animation_frames);
        progress("wfic reference of the animation's last frame");
        let mut last = scenes::load(&config.scene)?;
        let orbit = wfic_render::Camera::orbit(&last, (n - 1) as f32 / n as f32);
        last.set_camera(orbit);
        let (last_reference, _, last_mask) = brute_force(&last, config, ref_settings)?;
        let mut animations = Vec::new();
        for layout in &config.layouts()[..3] {
            progress(&format!("animation, {n} frames: {}", layout.label));
            let job = (config.scene.as_str(), &config.settings);
            let (image, stats, _) = self.launcher.run(layout, job, n, self.work)?;
            animations.push(Animation {
                layout: *layout,
                frames: stats.frames.frames().to_vec(),
                last_error: image_error(&image, &last_reference, &last_mask),
            });
        }
        Ok(animations)
    }
}

/// Runs the experiment; `progress` is told each job's label before it starts.
///
/// # Errors
/// An unknown scene, no `mpirun` or no `mpi` feature, a job that fails, Radiance failing.
pub fn run(
    config: &DistributedConfig,
    machine: &Machine,
    out_dir: &Path,
    progress: &mut dyn FnMut(&str),
) -> Result<Distributed, String> {
    config.validate()?;
    let scene: Scene = scenes::load(&config.scene)?;
    let launcher = Launcher::find()?;
    let bin = config.radiance.then(RadianceBin::find).transpose()?;
    let work = out_dir.join("work-distributed");
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let s = &config.settings;

    progress("wfic reference (no cache, 4x the rays)");
    let ref_settings = s.clone().rays_per_record(4 * s.rays_per_record);
    let (reference, reference_seconds, mask) = brute_force(&scene, config, &ref_settings)?;
    let bench = Bench {
        launcher: &launcher,
        config,
        work: &work,
        reference: &reference,
        mask: &mask,
    };
    let mut measure = |layout: Layout| bench.measure(&layout, progress);
    let jobs = config.layouts().into_iter().map(&mut measure);
    let jobs = jobs.collect::<Result<_, _>>()?;
    let sweep = config
        .batches
        .iter()
        .map(|&b| DistributedConfig::sweep_layout(b));
    let sweep = sweep.map(&mut measure).collect::<Result<_, _>>()?;
    let animations = if config.animation_frames > 1 {
        bench.animate(&ref_settings, progress)?
    } else {
        Vec::new()
    };
    let radiance = if let Some(bin) = &bin {
        progress("radiance: reference and rtrace -n 1, -n 2 on one ambient file");
        let dir = work.join("radiance");
        let resolution = config.radiance_resolution;
        let runs =
            radiance::shared_ambient(bin, &scene, s, resolution, config.stride, &[1, 2], &dir)?;
        Some(runs)
    } else {
        None
    };
    std::fs::remove_dir_all(&work).ok();
    Ok(Distributed {
        config: config.clone(),
        machine: machine.clone(),
        jobs,
        sweep,
        animations,
        radiance,
        radiance_version: bin.as_ref().map_or(String::new(), RadianceBin::version),
        reference_seconds,
        isolated: launcher.isolate,
    })
}

impl Distributed {
    /// The job whose layout label is `label`.
    fn job(&self, label: &str) -> Option<&Job> {
        self.jobs.iter().find(|j| j.layout.label == label)
    }

    /// The exchange-cost model calibrated from the measured jobs: seconds of inserting one
    /// received record (all jobs that received any), and bytes per record on the wire.
    pub fn calibration(&self) -> (f64, f64) {
        let exchanged = || {
            self.jobs
                .iter()
                .chain(&self.sweep)
                .filter(|j| j.received > 0)
        };
        let recs: u64 = exchanged().map(|j| j.received).sum();
        if recs == 0 {
            return (0.0, 0.0);
        }
        let secs: f64 = exchanged().map(|j| j.insert_seconds).sum();
        let bytes: u64 = exchanged().map(|j| j.bytes).sum();
        (secs / recs as f64, bytes as f64 / recs as f64)
    }

    /// The claims the experiment makes, each with whether it held and the figures.
    pub fn checks(&self) -> Vec<Check> {
        let mut out = Vec::new();
        let (Some(one), Some(shared), Some(alone)) =
            (self.job(ONE), self.job(SHARED), self.job(ALONE))
        else {
            return out;
        };
        let mut check = |claim: &str, holds: bool, detail: String| {
            out.push(Check::new("", claim, Verdict::of(holds), detail));
        };
        let ratio = |a: u64, b: u64| a as f64 / b as f64;
        let (shared_n, one_n) = (shared.total(), one.total());
        check(
            "2 shared ranks compute fewer records than 2 independent ones",
            shared_n < alone.total(),
            format!(
                "{shared_n} against {} ({} extra over one rank's {one_n})",
                alone.total(),
                pct(ratio(shared_n, one_n) - 1.0),
            ),
        );
        let (shared_err, one_err) = (shared.error.rel_rmse, one.error.rel_rmse);
        check(
            "2 shared ranks as accurate as 1 rank (within 1.5x its error)",
            shared_err <= 1.5 * one_err,
            format!("{} against {}", pct(shared_err), pct(one_err)),
        );
        let runs = self.radiance.as_ref().map_or(&[][..], |(r, _)| r);
        let by = |p: usize| runs.iter().find(|r| r.processes == p);
        if let (Some(r1), Some(r2)) = (by(1), by(2)) {
            let (wfic, rad) = (
                ratio(shared_n, one_n),
                ratio(r2.records as u64, r1.records.max(1) as u64),
            );
            check(
                "wfic's extra records at 2 ranks no more than Radiance's at 2 processes",
                wfic <= rad,
                format!(
                    "wfic {} ({shared_n} against {one_n}); Radiance {} ({} against {})",
                    pct(wfic - 1.0),
                    pct(rad - 1.0),
                    r2.records,
                    r1.records
                ),
            );
        }
        if let (Some(first), Some(last)) = (self.sweep.first(), self.sweep.last()) {
            let batch = |j: &Job| {
                let b = j.layout.batch_records;
                format!(
                    "batch {b}: {} rounds, {} duplicates",
                    j.rounds, j.duplicates
                )
            };
            check(
                "a larger batch means fewer rounds and more duplicates",
                last.rounds < first.rounds && last.duplicates >= first.duplicates,
                format!("{}; {}", batch(first), batch(last)),
            );
        }
        out
    }
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;

    #[test]
    fn the_statistics_file_is_read_as_the_renderer_writes_it() {
        use wfic_render::stats::{DistributedFrameStats, DistributedFrames, RankStats};
        let rank = |n: u64| RankStats {
            records_computed: n,
            bytes_sent: 10 * n,
            rounds: 4,
            ..RankStats::default()
        };
        let frame = DistributedFrameStats::new(vec![rank(7), rank(9)], 2, 1.5);
        let stats = DistributedStats {
            scene: "cornell".into(),
            triangles: 32,
            width: 8,
            height: 8,
            batch_records: 256,
            batch_ms: 20,
            share: true,
            frames: DistributedFrames::new(vec![frame.clone()]),
        };
        let path = std::env::temp_dir().join(format!("wfic-dstats-{}.json", std::process::id()));
        std::fs::write(&path, stats.to_json()).unwrap();
        let read = read_stats(&path).unwrap();
        assert_eq!(read.frames.frames(), [frame]);
        std::fs::write(&path, "{}").unwrap();
        assert!(read_stats(&path).unwrap_err().contains("wfic-dstats"));
        std::fs::remove_file(&path).unwrap();
    }

    fn job(layout: Layout, computed: Vec<u64>, seconds: f64) -> Job {
        Job {
            layout,
            seconds,
            range: (seconds, seconds),
            wall: 2.0 * seconds,
            bytes: if layout.share && layout.ranks > 1 {
                1000
            } else {
                0
            },
            computed,
            duplicates: 3,
            rounds: 5,
            collective_seconds: 0.01,
            insert_seconds: 0.002,
            received: 40,
            error: ImageError {
                rel_rmse: 0.02,
                mean_rel: 0.01,
            },
        }
    }

    #[test]
    fn the_report_and_the_csv_of_a_run() {
        let config = DistributedConfig {
            scene: SCENE.into(),
            settings: RenderSettings::new(32, 32),
            runs: 1,
            batches: vec![8, 4096],
            batch_ms: 20,
            batch_records: 256,
            stride: 2,
            radiance_resolution: 128,
            radiance: false,
            animation_frames: 0,
        };
        let [one, shared, alone, four] = config.layouts();
        let d = Distributed {
            jobs: vec![
                job(one, vec![100], 1.0),
                job(shared, vec![52, 53], 0.6),
                job(alone, vec![100, 100], 0.5),
                job(four, vec![30, 30, 30, 30], 0.9),
            ],
            sweep: vec![job(DistributedConfig::sweep_layout(8), vec![50, 50], 0.7)],
            animations: Vec::new(),
            radiance: None,
            radiance_version: String::new(),
            reference_seconds: 1.0,
            isolated: false,
            machine: Machine {
                cores: 2,
                cpu: "test".into(),
            },
            config,
        };
        let checks = d.checks();
        assert_eq!(checks[0].verdict, Verdict::Yes, "{checks:?}");
        assert!(
            checks[0].detail.contains("105 against 200 (5.00% extra"),
            "{checks:?}"
        );
        let csv = d.csv();
        let rows: Vec<Vec<&str>> = csv.lines().map(|l| l.split(',').collect()).collect();
        assert!(rows.iter().all(|r| r.len() == 21), "{csv}");
        assert_eq!(
            rows[2][..5],
            ["layout", "2 ranks x 1 thread; shared", "2", "1", "true"]
        );
        assert_eq!(
            (rows[2][11], rows[2][12], rows[2][14]),
            ("105", "52/53", "1000")
        );
        assert_eq!((rows[5][0], rows[5][6]), ("sweep", "600000"));
        let md = d.markdown();
        assert!(
            md.contains("| 2 ranks x 1 thread, shared | 0.600 (0.600-0.600) |"),
            "{md}"
        );
        assert!(md.contains("| 8 | 0.700 | 100 | 3 | 5 |"), "{md}");
        // Four ranks on two cores are marked where they are reported, two are not.
        assert!(
            md.contains("| 4 ranks x 1 thread, shared (oversubscribed) | 0.900"),
            "{md}"
        );
        assert!(
            !md.contains("2 ranks x 1 thread, shared (oversubscribed)"),
            "{md}"
        );
        let (insert, wire) = d.calibration();
        assert!((insert - 0.002 / 40.0).abs() < 1e-12 && wire > 0.0);
    }
}
