//! `wfic reproduce distributed`: one frame rendered by several MPI ranks sharing their
//! records, against one rank with the same threads, ranks that share nothing, and Radiance's
//! own multi-process sharing (`rtrace -n P` on one ambient file).
//!
//! Schedule: the experiment launches `mpirun` on this very binary (`wfic render
//! --distributed`, built with the `mpi` feature) once per job and reads rank 0's statistics and
//! image; it needs no MPI itself. As the tests do, it runs each job in a loopback-only network
//! namespace when it can (`unshare --net`, as root), with OpenMPI's transports restricted to
//! shared memory. Every main layout ([`DistributedConfig::layouts`]) runs
//! [`DistributedConfig::runs`] times and reports its median-time run; then the batch sweep, the
//! orbit animation and Radiance. Analysis: records, duplicates and bytes against one rank, the
//! exchange-cost model ([`Distributed::calibration`]) and the checks.

use crate::harness::measure::{repeat, time_command};
use crate::harness::metrics::{image_error, surface_mask, ImageError};
use crate::harness::stats::{self, median_index, Middle};
use crate::harness::table::{pct, Table};
use crate::harness::{Check, Machine, Output, Provenance, Verdict};
use crate::plot::{Figure, Line, Panel};
use crate::radiance::{self, RadianceBin, SharedAmbientRun};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use wfic_render::film::Image;
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
}

/// A timer too long to fire in a frame: the sweep's rounds start on the batch size (or a rank
/// running short of tiles) only.
const TIMER_OFF_MS: u64 = 600_000;

/// The labels of the layouts the tables and checks compare.
const ONE: &str = "1 rank x 2 threads";
const SHARED: &str = "2 ranks x 1 thread, shared";
const ALONE: &str = "2 ranks x 1 thread, independent";

impl DistributedConfig {
    /// The main jobs: 1 x 2, 2 x 1 shared, 2 x 1 independent, 4 x 1 shared.
    pub fn layouts(&self) -> [Layout; 4] {
        let layout = |label, ranks, threads, share| Layout {
            label,
            ranks,
            threads,
            share,
            batch_records: self.batch_records,
            batch_ms: self.batch_ms,
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

/// One frame of an animation job.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimFrame {
    /// Rank 0's seconds for the frame.
    pub seconds: f64,
    /// Records computed in the frame, all ranks.
    pub records: u64,
    /// Of them, computed where another rank's record of the frame is also valid.
    pub duplicates: u64,
    /// Bytes sent in the frame, all ranks.
    pub bytes: u64,
}

/// An orbit animation over one layout, the caches kept across frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    /// The layout.
    pub layout: Layout,
    /// Its frames.
    pub frames: Vec<AnimFrame>,
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

/// The statistics `wfic render --distributed --stats` writes, as this experiment reads them:
/// the one place that maps the JSON document to Rust values.
pub mod rank_stats {
    use serde_json::Value;

    /// One rank's figures.
    #[derive(Clone, Debug, Default, PartialEq)]
    pub struct Rank {
        /// Records it computed.
        pub records_computed: u64,
        /// Bytes it sent.
        pub bytes_sent: u64,
        /// Records it received.
        pub records_received: u64,
        /// Exchange rounds.
        pub rounds: u64,
        /// Seconds in the rounds' collectives.
        pub collective_seconds: f64,
        /// Seconds inserting received records.
        pub insert_seconds: f64,
    }

    /// One frame of an animation: rank 0's seconds, and the frame's records, duplicates and
    /// ranks.
    #[derive(Clone, Debug, Default, PartialEq)]
    pub struct Frame {
        /// Rank 0's seconds.
        pub seconds: f64,
        /// Records computed in the frame, all ranks.
        pub records_computed: u64,
        /// Duplicates in the frame.
        pub duplicates: u64,
        /// Every rank's bytes sent in the frame.
        pub bytes_sent: Vec<u64>,
    }

    /// A job's statistics: the frame's (the last frame's for an animation) seconds,
    /// duplicates and ranks, and an animation's frames.
    #[derive(Clone, Debug, Default, PartialEq)]
    pub struct JobStats {
        /// Rank 0's seconds.
        pub seconds: f64,
        /// Records computed where another rank's record is also valid.
        pub duplicates: u64,
        /// Every rank's figures.
        pub ranks: Vec<Rank>,
        /// An animation's frames (empty for one frame).
        pub frames: Vec<Frame>,
    }

    fn field(v: &Value, key: &str) -> Result<u64, String> {
        v[key]
            .as_u64()
            .ok_or_else(|| format!("rank statistics without `{key}`: {v}"))
    }

    fn seconds(v: &Value, key: &str) -> Result<f64, String> {
        v[key]
            .as_f64()
            .ok_or_else(|| format!("rank statistics without `{key}`: {v}"))
    }

    fn rank(r: &Value) -> Result<Rank, String> {
        Ok(Rank {
            records_computed: field(r, "records_computed")?,
            bytes_sent: field(r, "bytes_sent")?,
            records_received: field(r, "records_received")?,
            rounds: field(r, "rounds")?,
            collective_seconds: seconds(r, "collective_seconds")?,
            insert_seconds: seconds(r, "insert_seconds")?,
        })
    }

    fn frame(e: &Value) -> Result<Frame, String> {
        let ranks = e["ranks"]
            .as_array()
            .ok_or_else(|| format!("a frame without ranks: {e}"))?;
        Ok(Frame {
            seconds: seconds(e, "seconds")?,
            records_computed: field(e, "records_computed")?,
            duplicates: field(e, "duplicates")?,
            bytes_sent: ranks
                .iter()
                .map(|r| field(r, "bytes_sent"))
                .collect::<Result<_, _>>()?,
        })
    }

    /// Reads the statistics document `text`; an animation's when `frames`.
    pub fn parse(text: &str, frames: bool) -> Result<JobStats, String> {
        let json: Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
        if frames {
            let entries = json["frames"]
                .as_array()
                .ok_or_else(|| format!("animation statistics without frames: {json}"))?;
            return Ok(JobStats {
                frames: entries.iter().map(frame).collect::<Result<_, _>>()?,
                ..JobStats::default()
            });
        }
        let ranks = json["ranks"]
            .as_array()
            .ok_or_else(|| format!("statistics without ranks: {json}"))?;
        Ok(JobStats {
            seconds: seconds(&json, "seconds")?,
            duplicates: field(&json, "duplicates")?,
            ranks: ranks.iter().map(rank).collect::<Result<_, _>>()?,
            frames: Vec::new(),
        })
    }
}

/// How `mpirun` is started.
struct Launcher {
    bin: PathBuf,
    isolate: bool,
}

impl Launcher {
    /// Finds `mpirun` and this binary; checks the binary was built with the `mpi` feature.
    fn find() -> Result<Self, String> {
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

    /// The `mpirun` command of one job of `frames` frames writing into `dir`.
    fn command(
        &self,
        layout: &Layout,
        config: &DistributedConfig,
        frames: usize,
        dir: &Path,
    ) -> Command {
        let s = &config.settings;
        let mut cmd = if self.isolate {
            let mut c = Command::new("unshare");
            c.args([
                "--net",
                "--",
                "sh",
                "-c",
                "ip link set lo up && exec \"$@\"",
                "sh",
            ]);
            c.arg("mpirun");
            c
        } else {
            Command::new("mpirun")
        };
        cmd.args(["-np", &layout.ranks.to_string()])
            .arg(&self.bin)
            .args([
                "render",
                "--distributed",
                "--quiet",
                "--scene",
                &config.scene,
            ])
            .args(["--width", &s.width.to_string()])
            .args(["--height", &s.height.to_string()])
            .args(["--accuracy", &s.accuracy.to_string()])
            .args(["--rays-per-record", &s.rays_per_record.to_string()])
            .args(["--light-samples", &s.light_samples.to_string()])
            .args(["--spp", &s.pixel_samples.to_string()])
            .args(["--seed", &s.seed.to_string()])
            .args(["--threads", &layout.threads.to_string()])
            .args(["--batch-records", &layout.batch_records.to_string()])
            .args(["--batch-ms", &layout.batch_ms.to_string()])
            .args(["--frames", &frames.to_string()])
            .arg("--out")
            .arg(dir.join("job.png"))
            .arg("--stats")
            .arg(dir.join("job.json"));
        if !layout.share {
            cmd.arg("--no-share");
        }
        cmd.env("OMPI_MCA_btl", "self,vader")
            .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
            .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
            .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1");
        cmd
    }

    /// Runs one job; returns rank 0's image (the last frame's), its statistics and the wall
    /// seconds.
    fn run(
        &self,
        layout: &Layout,
        config: &DistributedConfig,
        frames: usize,
        dir: &Path,
    ) -> Result<(Image, rank_stats::JobStats, f64), String> {
        let what = format!("mpirun -np {} ({})", layout.ranks, layout.label);
        let (_, wall) = time_command(&mut self.command(layout, config, frames, dir), &what)?;
        // The last frame's image (`job-NNN.pfm` when there are several).
        let pfm = if frames > 1 {
            dir.join(format!("job-{:03}.pfm", frames - 1))
        } else {
            dir.join("job.pfm")
        };
        let image = Image::read_pfm(&pfm).map_err(|e| format!("{}: {e}", pfm.display()))?;
        let json = dir.join("job.json");
        let text =
            std::fs::read_to_string(&json).map_err(|e| format!("{}: {e}", json.display()))?;
        let stats =
            rank_stats::parse(&text, frames > 1).map_err(|e| format!("{}: {e}", json.display()))?;
        Ok((image, stats, wall))
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
            self.launcher.run(layout, self.config, 1, self.work)
        })?;
        let times: Vec<f64> = runs.iter().map(|(_, s, _)| s.seconds).collect();
        let (image, stats, wall) = &runs[median_index(&times, Middle::Lower)];
        let ranks = &stats.ranks;
        Ok(Job {
            layout: *layout,
            seconds: stats.seconds,
            range: stats::range(times.iter().copied()),
            wall: *wall,
            computed: ranks.iter().map(|r| r.records_computed).collect(),
            duplicates: stats.duplicates,
            bytes: ranks.iter().map(|r| r.bytes_sent).sum(),
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
        scene: &Scene,
        ref_settings: &RenderSettings,
        progress: &mut dyn FnMut(&str),
    ) -> Result<Vec<Animation>, String> {
        let (config, n) = (self.config, self.config.animation_frames);
        progress("wfic reference of the animation's last frame");
        let mut last = scenes::load(&config.scene)?;
        last.set_camera(wfic_render::Camera::orbit(scene, (n - 1) as f32 / n as f32));
        let last_mask = surface_mask(&last, &config.settings, config.stride);
        let rc = ref_settings
            .cache_config(scene)
            .map_err(|e| e.to_string())?;
        let (last_reference, _) =
            render_reference_grid(&last, &last.camera(), ref_settings, rc, 2, config.stride);
        let mut animations = Vec::new();
        for layout in &config.layouts()[..3] {
            progress(&format!("animation, {n} frames: {}", layout.label));
            let (image, stats, _) = self.launcher.run(layout, config, n, self.work)?;
            let frames = stats
                .frames
                .iter()
                .map(|f| AnimFrame {
                    seconds: f.seconds,
                    records: f.records_computed,
                    duplicates: f.duplicates,
                    bytes: f.bytes_sent.iter().sum(),
                })
                .collect();
            animations.push(Animation {
                layout: *layout,
                frames,
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
    if config.runs == 0 || config.batches.contains(&0) || config.batch_records == 0 {
        return Err("--runs and every batch size must be at least 1".to_owned());
    }
    let scene: Scene = scenes::load(&config.scene)?;
    let launcher = Launcher::find()?;
    let bin = if config.radiance {
        Some(RadianceBin::find()?)
    } else {
        None
    };
    std::fs::create_dir_all(out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let work = out_dir.join("work-distributed");
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let s = &config.settings;
    let mask = surface_mask(&scene, s, config.stride);

    progress("wfic reference (no cache, 4x the rays)");
    let ref_settings = s.clone().rays_per_record(4 * s.rays_per_record);
    let rc = ref_settings
        .cache_config(&scene)
        .map_err(|e| e.to_string())?;
    let (reference, reference_seconds) =
        render_reference_grid(&scene, &scene.camera(), &ref_settings, rc, 2, config.stride);
    let bench = Bench {
        launcher: &launcher,
        config,
        work: &work,
        reference: &reference,
        mask: &mask,
    };
    let mut jobs = Vec::new();
    for layout in &config.layouts() {
        jobs.push(bench.measure(layout, progress)?);
    }
    let mut sweep = Vec::new();
    for &batch in &config.batches {
        sweep.push(bench.measure(&DistributedConfig::sweep_layout(batch), progress)?);
    }
    let animations = if config.animation_frames > 1 {
        bench.animate(&scene, &ref_settings, progress)?
    } else {
        Vec::new()
    };
    let (radiance, radiance_version) = match &bin {
        Some(bin) => {
            progress("radiance: reference and rtrace -n 1, -n 2 on one ambient file");
            let r = radiance::shared_ambient(
                bin,
                &scene,
                s,
                config.radiance_resolution,
                config.stride,
                &[1, 2],
                &work.join("radiance"),
            )?;
            (Some(r), bin.version())
        }
        None => (None, String::new()),
    };
    std::fs::remove_dir_all(&work).ok();
    Ok(Distributed {
        config: config.clone(),
        machine: machine.clone(),
        jobs,
        sweep,
        animations,
        radiance,
        radiance_version,
        reference_seconds,
        isolated: launcher.isolate,
    })
}

pub use crate::harness::stats::fit_line;

fn kib(bytes: u64) -> String {
    format!("{:.1} KiB", bytes as f64 / 1024.0)
}

/// One line of `distributed.csv`: a job, an animation's frame or a Radiance run (the figures a
/// kind has not are blank).
struct CsvLine<'a> {
    group: String,
    layout: String,
    ranks: usize,
    threads: usize,
    share: bool,
    batch: Option<(usize, u64)>,
    seconds: f64,
    job: Option<&'a Job>,
    records: u64,
    duplicates: Option<u64>,
    bytes: u64,
    error: Option<ImageError>,
}

impl<'a> CsvLine<'a> {
    /// A line of `layout`, its figures blank.
    fn new(group: String, l: &Layout) -> Self {
        Self {
            group,
            layout: l.label.replace(',', ";"),
            ranks: l.ranks,
            threads: l.threads,
            share: l.share,
            batch: Some((l.batch_records, l.batch_ms)),
            seconds: 0.0,
            job: None,
            records: 0,
            duplicates: None,
            bytes: 0,
            error: None,
        }
    }

    fn job(group: &str, j: &'a Job) -> Self {
        Self {
            seconds: j.seconds,
            job: Some(j),
            records: j.total(),
            duplicates: Some(j.duplicates),
            bytes: j.bytes,
            error: Some(j.error),
            ..Self::new(group.to_owned(), &j.layout)
        }
    }

    /// A blank cell, or `f` of the job.
    fn of_job(&self, f: impl Fn(&Job) -> String) -> String {
        self.job.map_or(String::new(), f)
    }
}

/// `{:.*}` of `x`, or blank.
fn opt(x: Option<f64>, digits: usize) -> String {
    x.map_or(String::new(), |x| format!("{x:.digits$}"))
}

impl Distributed {
    /// The job whose layout label is `label`.
    fn job(&self, label: &str) -> Option<&Job> {
        self.jobs.iter().find(|j| j.layout.label == label)
    }

    /// The exchange-cost model calibrated from the measured jobs: seconds of inserting one
    /// received record (all jobs that received any), and bytes per record on the wire.
    pub fn calibration(&self) -> (f64, f64) {
        let (mut secs, mut recs, mut bytes) = (0.0, 0u64, 0u64);
        for j in self.jobs.iter().chain(&self.sweep) {
            if j.received > 0 {
                secs += j.insert_seconds;
                recs += j.received;
                bytes += j.bytes;
            }
        }
        if recs == 0 {
            return (0.0, 0.0);
        }
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
        let ratio = |a: u64, b: u64| a as f64 / b as f64;
        out.push(Check::new(
            "",
            "2 shared ranks compute fewer records than 2 independent ones",
            Verdict::of(shared.total() < alone.total()),
            format!(
                "{} against {} ({} extra over one rank's {})",
                shared.total(),
                alone.total(),
                pct(ratio(shared.total(), one.total()) - 1.0),
                one.total()
            ),
        ));
        out.push(Check::new(
            "",
            "2 shared ranks as accurate as 1 rank (within 1.5x its error)",
            Verdict::of(shared.error.rel_rmse <= 1.5 * one.error.rel_rmse),
            format!(
                "{} against {}",
                pct(shared.error.rel_rmse),
                pct(one.error.rel_rmse)
            ),
        ));
        let runs = self.radiance.as_ref().map_or(&[][..], |(r, _)| r);
        let by = |p: usize| runs.iter().find(|r| r.processes == p);
        if let (Some(r1), Some(r2)) = (by(1), by(2)) {
            let (r2n, r1n) = (r2.records as u64, r1.records.max(1) as u64);
            out.push(Check::new(
                "",
                "wfic's extra records at 2 ranks no more than Radiance's at 2 processes",
                Verdict::of(ratio(shared.total(), one.total()) <= ratio(r2n, r1n)),
                format!(
                    "wfic {} ({} against {}); Radiance {} ({} against {})",
                    pct(ratio(shared.total(), one.total()) - 1.0),
                    shared.total(),
                    one.total(),
                    pct(ratio(r2n, r1n) - 1.0),
                    r2.records,
                    r1.records
                ),
            ));
        }
        if let (Some(first), Some(last)) = (self.sweep.first(), self.sweep.last()) {
            out.push(Check::new(
                "",
                "a larger batch means fewer rounds and more duplicates",
                Verdict::of(last.rounds < first.rounds && last.duplicates >= first.duplicates),
                format!(
                    "batch {}: {} rounds, {} duplicates; batch {}: {} rounds, {} duplicates",
                    first.layout.batch_records,
                    first.rounds,
                    first.duplicates,
                    last.layout.batch_records,
                    last.rounds,
                    last.duplicates
                ),
            ));
        }
        out
    }

    /// The page's opening: how the jobs ran and what the columns mean.
    fn intro(&self) -> String {
        let s = &self.config.settings;
        format!(
            "Jobs ran under `mpirun` {}, OpenMPI over shared memory (`btl self,vader`);              oversubscribed layouts (more processes than cores) are reported, not scaling.\n\n\
             `{}`, {}x{}, {} primary ray a pixel, {} rays a record, {} light samples, a = {}. \
             Each rank renders the tiles handed to it on its own WF cache; shared ranks send \
             their new records to the others every {} records or {} ms (a variable-count \
             allgather). Error: relative RMSE of luminance against wfic's brute-force image \
             (`--scheme none`, {} rays a record, same seed and light samples) over the pixels of \
             a 1-in-{}x{} grid that see a non-emitter (reference: {:.1} s). Seconds: rank 0's \
             frame (agreement to assembled image), the median of {} run(s); `mpirun` start-up \
             is in the wall column only. Duplicates: records computed where a record another \
             rank computed is also valid.\n\n",
            if self.isolated {
                "in a loopback-only network namespace"
            } else {
                "in this machine's network namespace"
            },
            self.config.scene,
            s.width,
            s.height,
            s.pixel_samples,
            s.rays_per_record,
            s.light_samples,
            s.accuracy,
            self.config.batch_records,
            self.config.batch_ms,
            4 * s.rays_per_record,
            self.config.stride,
            self.config.stride,
            self.reference_seconds,
            self.config.runs
        )
    }

    /// The main layouts against one rank.
    fn layouts_markdown(&self) -> String {
        let one = self.job(ONE);
        let against = |j: &Job| {
            one.map_or((1.0, 1.0), |o| {
                (j.seconds / o.seconds, j.total() as f64 / o.total() as f64)
            })
        };
        let t = Table::new()
            .md("layout", |j: &Job| j.layout.label.to_owned())
            .left()
            .md("seconds (range)", |j| {
                format!("{:.3} ({:.3}-{:.3})", j.seconds, j.range.0, j.range.1)
            })
            .md("wall", |j| format!("{:.2}", j.wall))
            .md("vs 1 x 2", |j| format!("{:.2}x", against(j).0))
            .md("records", |j| j.total().to_string())
            .md("per rank", |j| {
                let per: Vec<String> = j.computed.iter().map(u64::to_string).collect();
                per.join(" / ")
            })
            .left()
            .md("vs 1 x 2", |j| {
                format!("{:+.1}%", 100.0 * (against(j).1 - 1.0))
            })
            .md("duplicates", |j| j.duplicates.to_string())
            .md("bytes sent", |j| kib(j.bytes))
            .md("rounds", |j| j.rounds.to_string())
            .md("collectives (max rank)", |j| {
                format!("{:.3} s", j.collective_seconds)
            })
            .md("inserting (all ranks)", |j| {
                format!("{:.3} s", j.insert_seconds)
            })
            .md("error", |j| pct(j.error.rel_rmse))
            .md("mean rel. error", |j| pct(j.error.mean_rel));
        format!("## The layouts\n\n{}", t.markdown(&self.jobs))
    }

    /// Radiance's processes sharing one ambient file, against wfic's ranks.
    fn radiance_markdown(&self) -> String {
        let Some((runs, ref_seconds)) = &self.radiance else {
            return String::new();
        };
        let s = &self.config.settings;
        let r1 = runs.iter().find(|r| r.processes == 1).map(|r| r.records);
        let t = Table::new()
            .md("processes", |r: &SharedAmbientRun| r.processes.to_string())
            .md("seconds", |r| format!("{:.2}", r.seconds))
            .md("records", |r| r.records.to_string())
            .md("vs 1 process", |r| {
                r1.map_or("-".to_owned(), |one| {
                    format!(
                        "{:+.1}%",
                        100.0 * (r.records as f64 / one.max(1) as f64 - 1.0)
                    )
                })
            })
            .md("ambient file", |r| kib(r.ambient_bytes))
            .md("error", |r| pct(r.error.rel_rmse))
            .md("mean rel. error", |r| pct(r.error.mean_rel))
            .md("wfic's time against it", |r| {
                let versus = self.job(if r.processes == 1 { ONE } else { SHARED });
                versus.map_or("-".to_owned(), |j| {
                    let label = j.layout.label.trim_end_matches(", shared");
                    format!("{:.3}x ({label})", j.seconds / r.seconds)
                })
            });
        format!(
            "\n## Radiance: `rtrace -n P` sharing one ambient file\n\n{}. `rtrace -ab 1 -ad \
             {} -aa {} -ar {} -as 0 -dj 0 -af FILE -n P`, one ray a pixel, a fresh ambient \
             file each run; error against Radiance's own brute force (`-aa 0 -ad {}`, {:.1} \
             s) on the same grid. Radiance's processes share records through the file (each \
             appends its new records under a lock and reads the others'), so its \"bytes\" \
             are the file's size, written once and read by every other process.\n\n{}",
            self.radiance_version,
            s.rays_per_record,
            s.accuracy,
            self.config.radiance_resolution,
            4 * s.rays_per_record,
            ref_seconds,
            t.markdown(runs)
        )
    }

    /// The batch sweep and the orbit animation.
    fn sweep_markdown(&self) -> String {
        let t = Table::new()
            .md("batch (records)", |j: &Job| {
                j.layout.batch_records.to_string()
            })
            .md("seconds", |j| format!("{:.3}", j.seconds))
            .md("records", |j| j.total().to_string())
            .md("duplicates", |j| j.duplicates.to_string())
            .md("rounds", |j| j.rounds.to_string())
            .md("bytes sent", |j| kib(j.bytes))
            .md("collectives (max rank)", |j| {
                format!("{:.3} s", j.collective_seconds)
            })
            .md("error", |j| pct(j.error.rel_rmse));
        let mut md = format!(
            "\n## Batch size: duplicates against exchange cost (2 ranks x 1 thread, the timer \
             off)\n\nA round starts when a rank's outbox holds the batch, or when a rank runs \
             short of tiles (tiles are handed out at the rounds), or when a rank's workers are \
             done.\n\n{}",
            t.markdown(&self.sweep)
        );
        let Some(n) = self.animations.first().map(|a| a.frames.len()) else {
            return md;
        };
        let later =
            |a: &Animation, f: fn(&AnimFrame) -> f64| stats::mean(a.frames[1..].iter().map(f));
        let t = Table::new()
            .md("layout", |a: &Animation| a.layout.label.to_owned())
            .left()
            .md("first frame (s)", |a| format!("{:.3}", a.frames[0].seconds))
            .md("later frames, mean (s)", |a| {
                format!("{:.3}", later(a, |f| f.seconds))
            })
            .md("total (s)", |a| {
                format!("{:.3}", a.frames.iter().map(|f| f.seconds).sum::<f64>())
            })
            .md("records, first", |a| a.frames[0].records.to_string())
            .md("records, later (mean)", |a| {
                format!("{:.0}", later(a, |f| f.records as f64))
            })
            .md("records, all", |a| {
                a.frames.iter().map(|f| f.records).sum::<u64>().to_string()
            })
            .md("duplicates, all", |a| {
                a.frames
                    .iter()
                    .map(|f| f.duplicates)
                    .sum::<u64>()
                    .to_string()
            })
            .md("bytes sent, all", |a| {
                kib(a.frames.iter().map(|f| f.bytes).sum())
            })
            .md("last frame's error", |a| pct(a.last_error.rel_rmse));
        let _ = write!(
            md,
            "\n## The orbit animation: {n} frames, the caches kept across frames\n\nThe \
             scene's orbit camera, frame i at turn i / {n}; every rank keeps its cache (and \
             the records the others sent) from frame to frame, as the paper's animation \
             (§4.2) does in one process. Duplicates are counted within each frame. Error: \
             the last frame against its brute-force image.\n\n{}",
            t.markdown(&self.animations)
        );
        md
    }

    /// `distributed.md`'s body.
    pub fn markdown(&self) -> String {
        let (insert, wire) = self.calibration();
        format!(
            "{}{}{}{}\n## The exchange-cost model, calibrated here\n\nEvery rank receives every \
             other rank's records: with R ranks and M records a frame, each rank inserts about M \
             (R - 1) / R of them and the job moves about M (R - 1) records' bytes. Measured \
             here: {:.2} us to insert a received record, {:.0} bytes a record on the wire.\n\n\
             ## Checks\n\n{}",
            self.intro(),
            self.layouts_markdown(),
            self.radiance_markdown(),
            self.sweep_markdown(),
            insert * 1e6,
            wire,
            Check::markdown(&self.checks(), false)
        )
    }

    /// `distributed.csv`: one line a job, an animation's frame, a Radiance run.
    pub fn csv(&self) -> String {
        let mut lines: Vec<CsvLine> = Vec::new();
        for (group, jobs) in [("layout", &self.jobs), ("sweep", &self.sweep)] {
            lines.extend(jobs.iter().map(|j| CsvLine::job(group, j)));
        }
        for a in &self.animations {
            for (i, f) in a.frames.iter().enumerate() {
                lines.push(CsvLine {
                    seconds: f.seconds,
                    records: f.records,
                    duplicates: Some(f.duplicates),
                    bytes: f.bytes,
                    ..CsvLine::new(format!("animation frame {i}"), &a.layout)
                });
            }
        }
        for r in self.radiance.iter().flat_map(|(runs, _)| runs) {
            lines.push(CsvLine {
                group: "radiance".to_owned(),
                layout: format!("rtrace -n {}", r.processes),
                ranks: r.processes,
                threads: 1,
                share: true,
                batch: None,
                seconds: r.seconds,
                job: None,
                records: r.records as u64,
                duplicates: None,
                bytes: r.ambient_bytes,
                error: Some(r.error),
            });
        }
        let batch = |l: &CsvLine, f: fn((usize, u64)) -> String| l.batch.map_or(String::new(), f);
        Table::new()
            .csv("group", |l: &CsvLine| l.group.clone())
            .csv("layout", |l| l.layout.clone())
            .csv("ranks", |l| l.ranks.to_string())
            .csv("threads", |l| l.threads.to_string())
            .csv("share", |l| l.share.to_string())
            .csv("batch_records", move |l| batch(l, |b| b.0.to_string()))
            .csv("batch_ms", move |l| batch(l, |b| b.1.to_string()))
            .csv("seconds", |l| format!("{:.4}", l.seconds))
            .csv("seconds_min", |l| l.of_job(|j| format!("{:.4}", j.range.0)))
            .csv("seconds_max", |l| l.of_job(|j| format!("{:.4}", j.range.1)))
            .csv("wall", |l| l.of_job(|j| format!("{:.3}", j.wall)))
            .csv("records", |l| l.records.to_string())
            .csv("records_per_rank", |l| {
                l.of_job(|j| {
                    let per: Vec<String> = j.computed.iter().map(u64::to_string).collect();
                    per.join("/")
                })
            })
            .csv("duplicates", |l| {
                l.duplicates.map_or(String::new(), |d| d.to_string())
            })
            .csv("bytes_sent", |l| l.bytes.to_string())
            .csv("rounds", |l| l.of_job(|j| j.rounds.to_string()))
            .csv("collective_seconds", |l| {
                l.of_job(|j| format!("{:.4}", j.collective_seconds))
            })
            .csv("insert_seconds", |l| {
                l.of_job(|j| format!("{:.4}", j.insert_seconds))
            })
            .csv("records_received", |l| l.of_job(|j| j.received.to_string()))
            .csv("rel_rmse", |l| opt(l.error.map(|e| e.rel_rmse), 5))
            .csv("mean_rel", |l| opt(l.error.map(|e| e.mean_rel), 5))
            .csv_text(&lines)
    }

    /// The sweep's plot: duplicates and rounds against the batch size.
    pub fn figure(&self) -> Figure {
        let x = |j: &Job| (j.layout.batch_records as f64).log2();
        let ticks: Vec<(f64, String)> = self
            .sweep
            .iter()
            .map(|j| (x(j), j.layout.batch_records.to_string()))
            .collect();
        let (lo, hi) = (
            ticks.first().map_or(0.0, |t| t.0),
            ticks.last().map_or(1.0, |t| t.0),
        );
        let base = Panel {
            x_range: (lo, hi.max(lo + 1.0)),
            x_ticks: ticks,
            x_label: "BATCH (RECORDS, LOG SCALE)".into(),
            ..Panel::default()
        };
        let line = |label: &str, colour, f: &dyn Fn(&Job) -> f64| Line {
            label: label.to_owned(),
            colour,
            points: self.sweep.iter().map(|j| (x(j), f(j))).collect(),
            markers: true,
        };
        let blue = [40, 90, 200];
        let red = [200, 60, 40];
        Figure {
            header: vec![
                format!(
                    "BATCH SIZE: DUPLICATES AGAINST EXCHANGE ROUNDS, 2 RANKS X 1 THREAD, {} {}X{}",
                    self.config.scene.to_uppercase(),
                    self.config.settings.width,
                    self.config.settings.height
                ),
                self.machine.banner_with_ranks(&[], &[(2, 1)]),
            ],
            panels: vec![
                Panel {
                    title: "DUPLICATE RECORDS".into(),
                    left_label: "RECORDS".into(),
                    lines: vec![line("duplicates", red, &|j| j.duplicates as f64)],
                    legend: vec![("duplicates".into(), red)],
                    ..base.clone()
                },
                Panel {
                    title: "EXCHANGE ROUNDS".into(),
                    left_label: "ROUNDS".into(),
                    lines: vec![line("rounds", blue, &|j| j.rounds as f64)],
                    legend: vec![("rounds".into(), blue)],
                    ..base
                },
            ],
            columns: 2,
            panel_size: (640, 420),
        }
    }

    /// Writes `distributed.md`, `distributed.csv`, `distributed.png` and `distributed.svg`,
    /// each with the provenance of `command`.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn write(&self, out_dir: &Path, command: &str) -> Result<(), String> {
        let ranks = self.config.rank_counts();
        let provenance = Provenance::new(command, &self.machine, &[], &ranks);
        let out = Output::new(out_dir, &provenance)?;
        let title = "One frame over MPI ranks: wfic's record exchange against one process, \
                     ranks that share nothing, and Radiance's shared ambient file";
        out.markdown("distributed.md", title, &self.markdown())?;
        out.csv("distributed.csv", &self.csv())?;
        if !self.sweep.is_empty() {
            let figure = self.figure();
            figure.write_png(&out.path("distributed.png"))?;
            figure.write_svg(&out.path("distributed.svg"))?;
        }
        Ok(())
    }
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;

    #[test]
    fn the_statistics_document_is_read_in_one_place() {
        let rank = |n: u64| {
            format!(
                r#"{{"records_computed": {n}, "bytes_sent": {}, "records_received": 3,
                   "rounds": 4, "collective_seconds": 0.5, "insert_seconds": 0.25}}"#,
                10 * n
            )
        };
        let one = format!(
            r#"{{"seconds": 1.5, "duplicates": 2, "ranks": [{}, {}]}}"#,
            rank(7),
            rank(9)
        );
        let s = rank_stats::parse(&one, false).unwrap();
        assert_eq!((s.seconds, s.duplicates, s.ranks.len()), (1.5, 2, 2));
        assert_eq!(s.ranks[1].records_computed, 9);
        assert_eq!(s.ranks[1].bytes_sent, 90);
        assert_eq!(s.ranks[0].insert_seconds, 0.25);
        let frames = format!(
            r#"{{"frames": [{{"seconds": 2.0, "records_computed": 5, "duplicates": 1,
                "ranks": [{}]}}]}}"#,
            rank(5)
        );
        let a = rank_stats::parse(&frames, true).unwrap();
        assert_eq!(a.frames[0].bytes_sent, vec![50]);
        let e = rank_stats::parse(r#"{"seconds": 1.0, "ranks": []}"#, false).unwrap_err();
        assert!(e.contains("`duplicates`"), "{e}");
        assert!(rank_stats::parse("{}", true)
            .unwrap_err()
            .contains("frames"));
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
        let (insert, wire) = d.calibration();
        assert!((insert - 0.002 / 40.0).abs() < 1e-12 && wire > 0.0);
    }
}
