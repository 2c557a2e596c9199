//! `wfic reproduce distributed` (issue 14): one frame rendered by several MPI ranks sharing
//! their records, against one rank with the same threads, ranks that share nothing, and
//! Radiance's own multi-process sharing (`rtrace -n P` on one ambient file).
//!
//! The experiment launches `mpirun` on this very binary (`wfic render --distributed`, built with
//! the `mpi` feature) once per job and reads rank 0's statistics and image; it needs no MPI
//! itself. As the tests do, it runs each job in a loopback-only network namespace when it can
//! (`unshare --net`, as root), with OpenMPI's transports restricted to shared memory.

use super::radiance::{self, image_error, ImageError, RadianceBin, SharedAmbientRun};
use super::Machine;
use wfic_render::film::Image;
use wfic_render::{render_reference_grid, scenes, RenderSettings, Scene};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

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

    /// Runs one job; returns rank 0's image, its statistics JSON and the wall seconds.
    fn run(
        &self,
        layout: &Layout,
        config: &DistributedConfig,
        frames: usize,
        dir: &Path,
    ) -> Result<(Image, serde_json::Value, f64), String> {
        let s = &config.settings;
        let png = dir.join("job.png");
        let json = dir.join("job.json");
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
            .arg(&png)
            .arg("--stats")
            .arg(&json);
        if !layout.share {
            cmd.arg("--no-share");
        }
        cmd.env("OMPI_MCA_btl", "self,vader")
            .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
            .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
            .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1");
        let start = std::time::Instant::now();
        let out = cmd
            .output()
            .map_err(|e| format!("mpirun: cannot start: {e}"))?;
        let wall = start.elapsed().as_secs_f64();
        if !out.status.success() {
            return Err(format!(
                "mpirun -np {} ({}) failed ({}): {}",
                layout.ranks,
                layout.label,
                out.status,
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        // The last frame's image (`job-NNN.pfm` when there are several).
        let pfm = if frames > 1 {
            dir.join(format!("job-{:03}.pfm", frames - 1))
        } else {
            png.with_extension("pfm")
        };
        let image = Image::read_pfm(&pfm).map_err(|e| format!("{}: {e}", pfm.display()))?;
        let text =
            std::fs::read_to_string(&json).map_err(|e| format!("{}: {e}", json.display()))?;
        let stats = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", json.display()))?;
        Ok((image, stats, wall))
    }
}

fn field(v: &serde_json::Value, key: &str) -> Result<u64, String> {
    v[key]
        .as_u64()
        .ok_or_else(|| format!("rank statistics without `{key}`: {v}"))
}

fn seconds(v: &serde_json::Value, key: &str) -> Result<f64, String> {
    v[key]
        .as_f64()
        .ok_or_else(|| format!("rank statistics without `{key}`: {v}"))
}

/// The median of `xs` (sorted copy; the lower middle for an even count).
fn median_index(xs: &[f64]) -> usize {
    let mut order: Vec<usize> = (0..xs.len()).collect();
    order.sort_by(|&a, &b| xs[a].total_cmp(&xs[b]));
    order[(xs.len() - 1) / 2]
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
    let mask = radiance::surface_mask(&scene, s, config.stride);

    progress("wfic reference (no cache, 4x the rays)");
    let ref_settings = s.clone().rays_per_record(4 * s.rays_per_record);
    let rc = ref_settings
        .cache_config(&scene)
        .map_err(|e| e.to_string())?;
    let (reference, reference_seconds) =
        render_reference_grid(&scene, &scene.camera(), &ref_settings, rc, 2, config.stride);

    let (b, ms) = (config.batch_records, config.batch_ms);
    let layouts = [
        Layout {
            label: "1 rank x 2 threads",
            ranks: 1,
            threads: 2,
            share: true,
            batch_records: b,
            batch_ms: ms,
        },
        Layout {
            label: "2 ranks x 1 thread, shared",
            ranks: 2,
            threads: 1,
            share: true,
            batch_records: b,
            batch_ms: ms,
        },
        Layout {
            label: "2 ranks x 1 thread, independent",
            ranks: 2,
            threads: 1,
            share: false,
            batch_records: b,
            batch_ms: ms,
        },
        Layout {
            label: "4 ranks x 1 thread, shared (oversubscribed)",
            ranks: 4,
            threads: 1,
            share: true,
            batch_records: b,
            batch_ms: ms,
        },
    ];
    let measure = |layout: &Layout, progress: &mut dyn FnMut(&str)| -> Result<Job, String> {
        let mut runs = Vec::new();
        for k in 0..config.runs {
            progress(&format!(
                "{} (run {} of {})",
                layout.label,
                k + 1,
                config.runs
            ));
            let (image, stats, wall) = launcher.run(layout, config, 1, &work)?;
            runs.push((image, stats, wall));
        }
        let times: Vec<f64> = runs
            .iter()
            .map(|(_, j, _)| seconds(j, "seconds"))
            .collect::<Result<_, _>>()?;
        let (image, json, wall) = &runs[median_index(&times)];
        let ranks = json["ranks"]
            .as_array()
            .ok_or_else(|| format!("statistics without ranks: {json}"))?;
        let mut job = Job {
            layout: *layout,
            seconds: seconds(json, "seconds")?,
            range: (
                times.iter().copied().fold(f64::INFINITY, f64::min),
                times.iter().copied().fold(0.0, f64::max),
            ),
            wall: *wall,
            computed: Vec::new(),
            duplicates: field(json, "duplicates")?,
            bytes: 0,
            rounds: field(&ranks[0], "rounds")?,
            collective_seconds: 0.0,
            insert_seconds: 0.0,
            received: 0,
            error: image_error(image, &reference, &mask),
        };
        for r in ranks {
            job.computed.push(field(r, "records_computed")?);
            job.bytes += field(r, "bytes_sent")?;
            job.received += field(r, "records_received")?;
            job.collective_seconds = job
                .collective_seconds
                .max(seconds(r, "collective_seconds")?);
            job.insert_seconds += seconds(r, "insert_seconds")?;
        }
        Ok(job)
    };
    let mut jobs = Vec::new();
    for layout in &layouts {
        jobs.push(measure(layout, progress)?);
    }
    let mut sweep = Vec::new();
    for &batch in &config.batches {
        let layout = Layout {
            label: "2 ranks x 1 thread, batch sweep",
            ranks: 2,
            threads: 1,
            share: true,
            batch_records: batch,
            batch_ms: TIMER_OFF_MS,
        };
        sweep.push(measure(&layout, progress)?);
    }
    let mut animations = Vec::new();
    if config.animation_frames > 1 {
        let n = config.animation_frames;
        progress("wfic reference of the animation's last frame");
        let mut last = scenes::load(&config.scene)?;
        last.set_camera(wfic_render::Camera::orbit(
            &scene,
            (n - 1) as f32 / n as f32,
        ));
        let last_mask = radiance::surface_mask(&last, s, config.stride);
        let (last_reference, _) =
            render_reference_grid(&last, &last.camera(), &ref_settings, rc, 2, config.stride);
        for layout in &layouts[..3] {
            progress(&format!("animation, {n} frames: {}", layout.label));
            let (image, json, _) = launcher.run(layout, config, n, &work)?;
            let entries = json["frames"]
                .as_array()
                .ok_or_else(|| format!("animation statistics without frames: {json}"))?;
            let mut frames = Vec::new();
            for e in entries {
                let ranks = e["ranks"]
                    .as_array()
                    .ok_or_else(|| format!("a frame without ranks: {e}"))?;
                let mut bytes = 0;
                for r in ranks {
                    bytes += field(r, "bytes_sent")?;
                }
                frames.push(AnimFrame {
                    seconds: seconds(e, "seconds")?,
                    records: field(e, "records_computed")?,
                    duplicates: field(e, "duplicates")?,
                    bytes,
                });
            }
            animations.push(Animation {
                layout: *layout,
                frames,
                last_error: image_error(&image, &last_reference, &last_mask),
            });
        }
    }
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

/// A least-squares line `y = a + b x` through the points; `None` with fewer than two distinct x.
pub fn fit_line(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let sxx: f64 = points.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    if points.len() < 2 || sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = points.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let b = sxy / sxx;
    Some((my - b * mx, b))
}

fn pct(x: f64) -> String {
    format!("{:.2}%", 100.0 * x)
}

fn kib(bytes: u64) -> String {
    format!("{:.1} KiB", bytes as f64 / 1024.0)
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

    /// The claims the issue makes, each with whether it held and the figures.
    pub fn checks(&self) -> Vec<(String, bool, String)> {
        let mut out = Vec::new();
        let (Some(one), Some(shared), Some(alone)) = (
            self.job("1 rank x 2 threads"),
            self.job("2 ranks x 1 thread, shared"),
            self.job("2 ranks x 1 thread, independent"),
        ) else {
            return out;
        };
        out.push((
            "2 shared ranks compute fewer records than 2 independent ones".to_owned(),
            shared.total() < alone.total(),
            format!(
                "{} against {} ({} extra over one rank's {})",
                shared.total(),
                alone.total(),
                pct(shared.total() as f64 / one.total() as f64 - 1.0),
                one.total()
            ),
        ));
        out.push((
            "2 shared ranks as accurate as 1 rank (within 1.5x its error)".to_owned(),
            shared.error.rel_rmse <= 1.5 * one.error.rel_rmse,
            format!(
                "{} against {}",
                pct(shared.error.rel_rmse),
                pct(one.error.rel_rmse)
            ),
        ));
        if let Some((runs, _)) = &self.radiance {
            if let (Some(r1), Some(r2)) = (
                runs.iter().find(|r| r.processes == 1),
                runs.iter().find(|r| r.processes == 2),
            ) {
                out.push((
                    "wfic's extra records at 2 ranks no more than Radiance's at 2 processes"
                        .to_owned(),
                    shared.total() as f64 / one.total() as f64
                        <= r2.records as f64 / r1.records.max(1) as f64,
                    format!(
                        "wfic {} ({} against {}); Radiance {} ({} against {})",
                        pct(shared.total() as f64 / one.total() as f64 - 1.0),
                        shared.total(),
                        one.total(),
                        pct(r2.records as f64 / r1.records.max(1) as f64 - 1.0),
                        r2.records,
                        r1.records
                    ),
                ));
            }
        }
        if let (Some(first), Some(last)) = (self.sweep.first(), self.sweep.last()) {
            out.push((
                "a larger batch means fewer rounds and more duplicates".to_owned(),
                last.rounds < first.rounds && last.duplicates >= first.duplicates,
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

    /// `distributed.md`.
    pub fn markdown(&self, command: &str) -> String {
        let s = &self.config.settings;
        let mut md = String::new();
        let _ = writeln!(
            md,
            "# One frame over MPI ranks: wfic's record exchange against one process, ranks \
             that share nothing, and Radiance's shared ambient file\n"
        );
        let _ = writeln!(md, "`{command}`\n");
        let _ = writeln!(
            md,
            "machine: {} cores ({}); 4 ranks are oversubscribed (more processes than cores): \
             reported, not scaling. Jobs ran under `mpirun` {}, OpenMPI over shared memory \
             (`btl self,vader`).\n",
            self.machine.cores,
            self.machine.cpu,
            if self.isolated {
                "in a loopback-only network namespace"
            } else {
                "in this machine's network namespace"
            }
        );
        let _ = writeln!(
            md,
            "`{}`, {}x{}, {} primary ray a pixel, {} rays a record, {} light samples, a = {}. \
             Each rank renders the tiles handed to it on its own WF cache; shared ranks send \
             their new records to the others every {} records or {} ms (a variable-count \
             allgather). Error: relative RMSE of luminance against wfic's brute-force image \
             (`--scheme none`, {} rays a record, same seed and light samples) over the pixels of \
             a 1-in-{}x{} grid that see a non-emitter (reference: {:.1} s). Seconds: rank 0's \
             frame (agreement to assembled image), the median of {} run(s); `mpirun` start-up \
             is in the wall column only. Duplicates: records computed where a record another \
             rank computed is also valid.\n",
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
        );
        let one = self.job("1 rank x 2 threads");
        let _ = writeln!(md, "## The layouts\n");
        let _ = writeln!(
            md,
            "| layout | seconds (range) | wall | vs 1 x 2 | records | per rank | vs 1 x 2 | \
             duplicates | bytes sent | rounds | collectives (max rank) | inserting (all ranks) \
             | error | mean rel. error |"
        );
        let _ = writeln!(
            md,
            "|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|"
        );
        for j in &self.jobs {
            let per: Vec<String> = j.computed.iter().map(u64::to_string).collect();
            let (t, r) = one.map_or((1.0, 1.0), |o| {
                (j.seconds / o.seconds, j.total() as f64 / o.total() as f64)
            });
            let _ = writeln!(
                md,
                "| {} | {:.3} ({:.3}-{:.3}) | {:.2} | {:.2}x | {} | {} | {:+.1}% | {} | {} | {} | \
                 {:.3} s | {:.3} s | {} | {} |",
                j.layout.label,
                j.seconds,
                j.range.0,
                j.range.1,
                j.wall,
                t,
                j.total(),
                per.join(" / "),
                100.0 * (r - 1.0),
                j.duplicates,
                kib(j.bytes),
                j.rounds,
                j.collective_seconds,
                j.insert_seconds,
                pct(j.error.rel_rmse),
                pct(j.error.mean_rel)
            );
        }
        if let Some((runs, ref_seconds)) = &self.radiance {
            let _ = writeln!(
                md,
                "\n## Radiance: `rtrace -n P` sharing one ambient file\n\n{}. `rtrace -ab 1 -ad \
                 {} -aa {} -ar {} -as 0 -dj 0 -af FILE -n P`, one ray a pixel, a fresh ambient \
                 file each run; error against Radiance's own brute force (`-aa 0 -ad {}`, {:.1} \
                 s) on the same grid. Radiance's processes share records through the file (each \
                 appends its new records under a lock and reads the others'), so its \"bytes\" \
                 are the file's size, written once and read by every other process.\n",
                self.radiance_version,
                s.rays_per_record,
                s.accuracy,
                self.config.radiance_resolution,
                4 * s.rays_per_record,
                ref_seconds
            );
            let _ = writeln!(
                md,
                "| processes | seconds | records | vs 1 process | ambient file | error | mean \
                 rel. error | wfic's time against it |"
            );
            let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|");
            let r1 = runs.iter().find(|r| r.processes == 1).map(|r| r.records);
            let shared = self.job("2 ranks x 1 thread, shared");
            let one_rank = self.job("1 rank x 2 threads");
            for r in runs {
                let versus = if r.processes == 1 { one_rank } else { shared };
                let _ = writeln!(
                    md,
                    "| {} | {:.2} | {} | {} | {} | {} | {} | {} |",
                    r.processes,
                    r.seconds,
                    r.records,
                    r1.map_or("-".to_owned(), |one| format!(
                        "{:+.1}%",
                        100.0 * (r.records as f64 / one.max(1) as f64 - 1.0)
                    )),
                    kib(r.ambient_bytes),
                    pct(r.error.rel_rmse),
                    pct(r.error.mean_rel),
                    versus.map_or("-".to_owned(), |j| format!(
                        "{:.3}x ({})",
                        j.seconds / r.seconds,
                        j.layout.label.trim_end_matches(", shared")
                    ))
                );
            }
        }
        let _ = writeln!(
            md,
            "\n## Batch size: duplicates against exchange cost (2 ranks x 1 thread, the timer \
             off)\n\nA round starts when a rank's outbox holds the batch, or when a rank runs \
             short of tiles (tiles are handed out at the rounds), or when a rank's workers are \
             done.\n"
        );
        let _ = writeln!(
            md,
            "| batch (records) | seconds | records | duplicates | rounds | bytes sent | \
             collectives (max rank) | error |"
        );
        let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|");
        for j in &self.sweep {
            let _ = writeln!(
                md,
                "| {} | {:.3} | {} | {} | {} | {} | {:.3} s | {} |",
                j.layout.batch_records,
                j.seconds,
                j.total(),
                j.duplicates,
                j.rounds,
                kib(j.bytes),
                j.collective_seconds,
                pct(j.error.rel_rmse)
            );
        }
        if !self.animations.is_empty() {
            let n = self.animations[0].frames.len();
            let _ = writeln!(
                md,
                "\n## The orbit animation: {n} frames, the caches kept across frames\n\nThe \
                 scene's orbit camera, frame i at turn i / {n}; every rank keeps its cache (and \
                 the records the others sent) from frame to frame, as the paper's animation \
                 (§4.2) does in one process. Duplicates are counted within each frame. Error: \
                 the last frame against its brute-force image.\n"
            );
            let _ = writeln!(
                md,
                "| layout | first frame (s) | later frames, mean (s) | total (s) | records, \
                 first | records, later (mean) | records, all | duplicates, all | bytes sent, \
                 all | last frame's error |"
            );
            let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
            for a in &self.animations {
                let later = &a.frames[1..];
                let mean = |f: &dyn Fn(&AnimFrame) -> f64| {
                    later.iter().map(f).sum::<f64>() / later.len().max(1) as f64
                };
                let _ = writeln!(
                    md,
                    "| {} | {:.3} | {:.3} | {:.3} | {} | {:.0} | {} | {} | {} | {} |",
                    a.layout.label,
                    a.frames[0].seconds,
                    mean(&|f| f.seconds),
                    a.frames.iter().map(|f| f.seconds).sum::<f64>(),
                    a.frames[0].records,
                    mean(&|f| f.records as f64),
                    a.frames.iter().map(|f| f.records).sum::<u64>(),
                    a.frames.iter().map(|f| f.duplicates).sum::<u64>(),
                    kib(a.frames.iter().map(|f| f.bytes).sum()),
                    pct(a.last_error.rel_rmse)
                );
            }
        }
        let (insert, wire) = self.calibration();
        let _ = writeln!(
            md,
            "\n## The exchange-cost model, calibrated here\n\nEvery rank receives every other \
             rank's records: with R ranks and M records a frame, each rank inserts about M (R - \
             1) / R of them and the job moves about M (R - 1) records' bytes. Measured here: \
             {:.2} us to insert a received record, {:.0} bytes a record on the wire. See \
             `paper-notes.md` (\"Beyond one machine\") for the model.\n",
            insert * 1e6,
            wire
        );
        let _ = writeln!(md, "## Checks\n");
        let _ = writeln!(md, "| claim | holds | measured |");
        let _ = writeln!(md, "|---|---|---|");
        for (claim, ok, detail) in self.checks() {
            let _ = writeln!(
                md,
                "| {claim} | {} | {detail} |",
                if ok { "yes" } else { "**no**" }
            );
        }
        md
    }

    /// `distributed.csv`: one row a job.
    pub fn csv(&self) -> String {
        let mut out = String::from(
            "group,layout,ranks,threads,share,batch_records,batch_ms,seconds,seconds_min,\
             seconds_max,wall,records,records_per_rank,duplicates,bytes_sent,rounds,\
             collective_seconds,insert_seconds,records_received,rel_rmse,mean_rel\n",
        );
        for (group, jobs) in [("layout", &self.jobs), ("sweep", &self.sweep)] {
            for j in jobs {
                let per: Vec<String> = j.computed.iter().map(u64::to_string).collect();
                let l = &j.layout;
                let _ = writeln!(
                    out,
                    "{group},{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.3},{},{},{},{},{},{:.4},{:.4},{},{:.5},{:.5}",
                    l.label.replace(',', ";"),
                    l.ranks,
                    l.threads,
                    l.share,
                    l.batch_records,
                    l.batch_ms,
                    j.seconds,
                    j.range.0,
                    j.range.1,
                    j.wall,
                    j.total(),
                    per.join("/"),
                    j.duplicates,
                    j.bytes,
                    j.rounds,
                    j.collective_seconds,
                    j.insert_seconds,
                    j.received,
                    j.error.rel_rmse,
                    j.error.mean_rel
                );
            }
        }
        for a in &self.animations {
            let l = &a.layout;
            for (i, f) in a.frames.iter().enumerate() {
                let _ = writeln!(
                    out,
                    "animation frame {i},{},{},{},{},{},{},{:.4},,,,{},,{},{},,,,,,",
                    l.label.replace(',', ";"),
                    l.ranks,
                    l.threads,
                    l.share,
                    l.batch_records,
                    l.batch_ms,
                    f.seconds,
                    f.records,
                    f.duplicates,
                    f.bytes
                );
            }
        }
        if let Some((runs, _)) = &self.radiance {
            for r in runs {
                let _ = writeln!(
                    out,
                    "radiance,rtrace -n {},{},1,true,,,{:.4},,,,{},,,{},,,,,{:.5},{:.5}",
                    r.processes,
                    r.processes,
                    r.seconds,
                    r.records,
                    r.ambient_bytes,
                    r.error.rel_rmse,
                    r.error.mean_rel
                );
            }
        }
        out
    }

    /// The sweep's plot: duplicates and rounds against the batch size.
    pub fn figure(&self) -> super::plot::Figure {
        use super::plot::{Figure, Line, Panel};
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
                self.machine.banner(&[1, 2]),
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

    /// Writes `distributed.md`, `distributed.csv`, `distributed.png` and `distributed.svg`.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn write(&self, out_dir: &Path, command: &str) -> Result<(), String> {
        let io = |p: PathBuf, e: std::io::Error| format!("{}: {e}", p.display());
        let md = out_dir.join("distributed.md");
        std::fs::write(&md, self.markdown(command)).map_err(|e| io(md.clone(), e))?;
        let csv = out_dir.join("distributed.csv");
        std::fs::write(&csv, self.csv()).map_err(|e| io(csv.clone(), e))?;
        if !self.sweep.is_empty() {
            let figure = self.figure();
            figure.write_png(&out_dir.join("distributed.png"))?;
            figure.write_svg(&out_dir.join("distributed.svg"))?;
        }
        Ok(())
    }
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;

    #[test]
    fn a_line_through_points_is_fitted_exactly() {
        let (a, b) = fit_line(&[(1.0, 3.0), (2.0, 5.0), (4.0, 9.0)]).unwrap();
        assert!(
            (a - 1.0).abs() < 1e-12 && (b - 2.0).abs() < 1e-12,
            "{a} {b}"
        );
        assert_eq!(fit_line(&[(1.0, 3.0), (1.0, 5.0)]), None);
    }

    #[test]
    fn the_median_run_is_picked() {
        assert_eq!(median_index(&[3.0, 1.0, 2.0]), 2);
        assert_eq!(median_index(&[5.0]), 0);
        assert_eq!(median_index(&[4.0, 1.0, 3.0, 2.0]), 3);
    }
}
