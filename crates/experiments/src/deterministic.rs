//! `wfic reproduce deterministic`: what deterministic frames cost against ordinary WF frames, on
//! every scene, at 1 and 2 threads. How to read the page: `docs/experiments.md#deterministic`.
//!
//! Schedule: per scene, per seed (run), per thread count, an ordinary WF frame and a
//! deterministic one back to back on fresh caches, so a slow spell of the machine falls on both;
//! each seed's brute-force image on the reference grid. Analysis: the paired ratio of the times,
//! the records, the error of each against its seed's reference, and whether every deterministic
//! frame of a seed hashed alike. Report: `deterministic.md`, `deterministic.csv`.

use crate::harness::metrics::{image_error, surface_mask};
use crate::harness::stats::{mean, paired_ratio, std_dev};
use crate::harness::table::Table;
use crate::harness::{Check, Machine, Output, Provenance, Verdict};
use std::path::Path;
use wfic::cache::Scheme;
use wfic_render::{render_reference_grid, render_with_scheme, scenes, FrameStats, RenderSettings};

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct DeterministicConfig {
    /// Built-in scenes.
    pub scenes: Vec<String>,
    /// Thread counts.
    pub threads: Vec<usize>,
    /// Seeds (runs) per scene and thread count.
    pub runs: usize,
    /// Image size and sampling (the seed is set per run).
    pub settings: RenderSettings,
    /// The references are traced at one pixel in `stride` x `stride`.
    pub stride: u32,
    /// Rank counts of the MPI jobs (one thread a rank; empty: none run).
    pub ranks: Vec<usize>,
}

impl DeterministicConfig {
    /// Refuses a configuration that cannot run: no scenes, or runs, threads, ranks, the stride
    /// or the settings out of their ranges.
    ///
    /// # Errors
    /// The argument at fault, named with its range.
    pub fn validate(&self) -> Result<(), String> {
        if self.scenes.is_empty() || self.threads.is_empty() {
            return Err("reproduce deterministic: --scenes and --threads must not be empty".into());
        }
        let range = |e: wfic_render::limits::OutOfRange| e.for_option();
        crate::bounds::RUNS.check(self.runs).map_err(range)?;
        for &t in &self.threads {
            wfic_render::limits::THREADS.check(t).map_err(range)?;
        }
        for &r in &self.ranks {
            crate::bounds::RANKS.check(r).map_err(range)?;
        }
        crate::bounds::STRIDE.check(self.stride).map_err(range)?;
        self.settings.validate().map_err(range)?;
        Ok(())
    }

    /// Frames in all (references included): the progress bar's length.
    pub fn frames(&self) -> usize {
        self.scenes.len() * self.runs * (1 + 2 * (self.threads.len() + self.ranks.len()))
    }
}

/// One frame: a scene, a seed, a thread count, ordinary or deterministic.
#[derive(Clone, Debug)]
pub struct Row {
    /// Scene.
    pub scene: String,
    /// Run (the seed is the settings' plus this).
    pub run: usize,
    /// Threads (of each rank).
    pub threads: usize,
    /// MPI ranks (1: one process, no MPI).
    pub ranks: usize,
    /// Deterministic.
    pub deterministic: bool,
    /// The frame's statistics.
    pub stats: FrameStats,
    /// Relative RMSE against the seed's brute-force image, on the reference grid.
    pub error: f64,
}

/// A finished run.
#[derive(Clone, Debug)]
pub struct Deterministic {
    /// What ran.
    pub config: DeterministicConfig,
    /// Where.
    pub machine: Machine,
    /// Every frame.
    pub rows: Vec<Row>,
}

/// Runs the experiment; `progress(label)` is called before every frame.
pub fn run(
    config: &DeterministicConfig,
    machine: &Machine,
    progress: &mut dyn FnMut(&str),
) -> Result<Deterministic, String> {
    config.validate()?;
    let launcher = if config.ranks.is_empty() {
        None
    } else {
        Some(crate::distributed::Launcher::find()?)
    };
    let work = std::env::temp_dir().join(format!("wfic-deterministic-{}", std::process::id()));
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let mut rows = Vec::new();
    for name in &config.scenes {
        let scene = scenes::load(name)?;
        let camera = scene.camera();
        for run in 0..config.runs {
            let mut settings = config.settings.clone().quiet(true);
            settings.seed = settings.seed.wrapping_add(run as u64);
            let cache = settings.cache_config(&scene).map_err(|e| e.to_string())?;
            progress(&format!("{name} seed {run}: reference"));
            let threads = *config.threads.iter().max().unwrap_or(&1);
            let (reference, _) =
                render_reference_grid(&scene, &camera, &settings, cache, threads, config.stride);
            let mask = surface_mask(&scene, &settings, config.stride);
            for &threads in &config.threads {
                for deterministic in [false, true] {
                    progress(&format!(
                        "{name} seed {run}: {threads} threads, deterministic {deterministic}"
                    ));
                    settings.deterministic = deterministic;
                    let (out, _) =
                        render_with_scheme(Scheme::Wf, &scene, &camera, &settings, cache, threads);
                    rows.push(Row {
                        scene: name.clone(),
                        run,
                        threads,
                        ranks: 1,
                        deterministic,
                        error: image_error(&out.image, &reference, &mask).rel_rmse,
                        stats: out.stats,
                    });
                }
            }
            for &ranks in &config.ranks {
                let launcher = launcher.as_ref().expect("found when ranks are asked for");
                for deterministic in [false, true] {
                    progress(&format!(
                        "{name} seed {run}: {ranks} ranks, deterministic {deterministic}"
                    ));
                    let layout = crate::distributed::Layout {
                        label: "the ranks",
                        ranks,
                        threads: 1,
                        share: true,
                        batch_records: 256,
                        batch_ms: 20,
                        deterministic,
                    };
                    let (image, stats, _) = launcher.run(&layout, (name, &settings), 1, &work)?;
                    let frame = stats.frames.frames().first().cloned().unwrap_or_default();
                    rows.push(Row {
                        scene: name.clone(),
                        run,
                        threads: 1,
                        ranks,
                        deterministic,
                        error: image_error(&image, &reference, &mask).rel_rmse,
                        stats: FrameStats {
                            seconds: frame.seconds,
                            cache_records: frame.records_computed as usize,
                            frame_hash: image.hash(),
                            ..FrameStats::default()
                        },
                    });
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&work);
    Ok(Deterministic {
        config: config.clone(),
        machine: machine.clone(),
        rows,
    })
}

/// One scene at one thread and rank count: the paired frames of its runs.
struct Pair<'a> {
    scene: &'a str,
    threads: usize,
    ranks: usize,
    ordinary: Vec<&'a Row>,
    deterministic: Vec<&'a Row>,
}

impl Pair<'_> {
    fn of(&self, deterministic: bool, f: impl Fn(&Row) -> f64) -> Vec<f64> {
        let rows = if deterministic {
            &self.deterministic
        } else {
            &self.ordinary
        };
        rows.iter().map(|r| f(r)).collect()
    }

    fn seconds_ratio(&self) -> String {
        paired_ratio(
            &self.of(true, |r| r.stats.seconds),
            &self.of(false, |r| r.stats.seconds),
        )
        .map_or("-".into(), |p| p.text())
    }

    fn records_ratio(&self) -> f64 {
        let records = |d| mean(self.of(d, |r| r.stats.cache_records as f64));
        records(true) / records(false)
    }
}

impl Deterministic {
    fn pairs(&self) -> Vec<Pair<'_>> {
        let mut out = Vec::new();
        let layouts: Vec<(usize, usize)> = (self.config.threads.iter().map(|&t| (t, 1)))
            .chain(self.config.ranks.iter().map(|&r| (1, r)))
            .collect();
        for scene in &self.config.scenes {
            for &(threads, ranks) in &layouts {
                let of = |d: bool| -> Vec<&Row> {
                    (self.rows.iter())
                        .filter(|r| {
                            &r.scene == scene
                                && (r.threads, r.ranks) == (threads, ranks)
                                && r.deterministic == d
                        })
                        .collect()
                };
                out.push(Pair {
                    scene,
                    threads,
                    ranks,
                    ordinary: of(false),
                    deterministic: of(true),
                });
            }
        }
        out
    }

    /// Whether every deterministic frame of each scene and seed hashed alike, across the thread
    /// counts: the scenes and seeds where they did not.
    fn hash_mismatches(&self) -> Vec<String> {
        let mut bad = Vec::new();
        for scene in &self.config.scenes {
            for run in 0..self.config.runs {
                let hashes: Vec<&str> = (self.rows.iter())
                    .filter(|r| &r.scene == scene && r.run == run && r.deterministic)
                    .map(|r| r.stats.frame_hash.as_str())
                    .collect();
                if hashes.windows(2).any(|w| w[0] != w[1]) {
                    bad.push(format!("{scene} seed {run}: {}", hashes.join(" ")));
                }
            }
        }
        bad
    }

    /// The goals at 2 threads (at most 1.10x WF's time, 5% more records, error within the
    /// seeds' spread), and bit-identical frames at every thread count.
    pub fn checks(&self) -> Vec<Check> {
        let mut out = Vec::new();
        for p in self
            .pairs()
            .iter()
            .filter(|p| (p.threads, p.ranks) == (2, 1))
        {
            let time = paired_ratio(
                &p.of(true, |r| r.stats.seconds),
                &p.of(false, |r| r.stats.seconds),
            );
            out.push(Check::new(
                p.scene,
                "time at most 1.10x WF's (2 threads)",
                time.map_or(Verdict::No, |t| {
                    if t.hi <= 1.10 {
                        Verdict::Yes
                    } else if t.lo <= 1.10 {
                        Verdict::Tie
                    } else {
                        Verdict::No
                    }
                }),
                format!(
                    "{} (deterministic / WF, paired over the seeds)",
                    p.seconds_ratio()
                ),
            ));
            let records = p.records_ratio();
            out.push(Check::new(
                p.scene,
                "at most 5% more records (2 threads)",
                Verdict::of(records <= 1.05),
                format!("{records:.3}x WF's"),
            ));
            let (e_d, e_w) = (p.of(true, |r| r.error), p.of(false, |r| r.error));
            let spread = std_dev(&e_w);
            out.push(Check::new(
                p.scene,
                "error equal within noise (2 threads)",
                Verdict::of(mean(e_d.iter().copied()) <= mean(e_w.iter().copied()) + spread),
                format!(
                    "{:.2}% against {:.2}% (spread over the seeds {:.2}%)",
                    100.0 * mean(e_d.iter().copied()),
                    100.0 * mean(e_w.iter().copied()),
                    100.0 * spread
                ),
            ));
        }
        let bad = self.hash_mismatches();
        out.push(Check::new(
            "",
            format!(
                "deterministic frames bit-identical at {:?} threads and {:?} ranks",
                self.config.threads, self.config.ranks
            ),
            Verdict::of(bad.is_empty()),
            if bad.is_empty() {
                "every scene and seed hashed alike".into()
            } else {
                bad.join("; ")
            },
        ));
        out
    }

    /// `deterministic.md`'s body.
    pub fn markdown(&self) -> String {
        let s = &self.config.settings;
        let pairs = self.pairs();
        let mean_of = |p: &Pair, d, f: fn(&Row) -> f64| mean(p.of(d, f));
        let table = Table::new()
            .md("scene", |p: &Pair| p.scene.to_owned())
            .left()
            .md("threads", |p| {
                if p.ranks > 1 {
                    format!("{} ranks x 1", p.ranks)
                } else {
                    self.machine.count(p.threads)
                }
            })
            .md("WF (s)", |p| {
                format!("{:.3}", mean_of(p, false, |r| r.stats.seconds))
            })
            .md("deterministic (s)", |p| {
                format!("{:.3}", mean_of(p, true, |r| r.stats.seconds))
            })
            .md("ratio (paired)", |p| p.seconds_ratio())
            .md("pretrace (s)", |p| {
                format!("{:.3}", mean_of(p, true, |r| r.stats.pretrace_seconds))
            })
            .md("WF records", |p| {
                format!("{:.0}", mean_of(p, false, |r| r.stats.cache_records as f64))
            })
            .md("deterministic records", |p| {
                format!("{:.0}", mean_of(p, true, |r| r.stats.cache_records as f64))
            })
            .md("of them pretrace", |p| {
                format!(
                    "{:.0}",
                    mean_of(p, true, |r| r.stats.pretrace_records as f64)
                )
            })
            .md("records ratio", |p| format!("{:.3}", p.records_ratio()))
            .md("WF error", |p| {
                format!("{:.2}%", 100.0 * mean_of(p, false, |r| r.error))
            })
            .md("deterministic error", |p| {
                format!("{:.2}%", 100.0 * mean_of(p, true, |r| r.error))
            })
            .md("WF lookups", |p| {
                format!("{:.0}", mean_of(p, false, |r| r.stats.lookups as f64))
            })
            .md("deterministic lookups", |p| {
                format!("{:.0}", mean_of(p, true, |r| r.stats.lookups as f64))
            });
        format!(
            "{}x{}, {} primary rays a pixel, {} rays a record, {} light samples, a = {}, {} \
             seeds (runs); times are means, the ratio the median of the per-seed ratios with its \
             interval; errors are relative RMSE against each seed's `--scheme none` image on a \
             1-in-{}x{} grid. A row of ranks is `mpirun` of `wfic render --distributed` ({}), \
             its time rank 0's frame, its records those the ranks computed; its lookups are not \
             counted.\n\n{}\n## Checks\n\n{}",
            s.width,
            s.height,
            s.pixel_samples,
            s.rays_per_record,
            s.light_samples,
            s.accuracy,
            self.config.runs,
            self.config.stride,
            self.config.stride,
            if self.config.ranks.is_empty() {
                "none ran"
            } else {
                "one thread a rank, shared records"
            },
            table.markdown(&pairs),
            Check::markdown(&self.checks(), true),
        )
    }

    /// `deterministic.csv`: one line a frame.
    pub fn csv(&self) -> String {
        let m = &self.machine;
        Table::new()
            .csv("scene", |r: &&Row| r.scene.clone())
            .csv("run", |r| r.run.to_string())
            .csv("seed", |r| {
                (self.config.settings.seed.wrapping_add(r.run as u64)).to_string()
            })
            .csv("threads", |r| r.threads.to_string())
            .csv("ranks", |r| r.ranks.to_string())
            .csv("oversubscribed", |r| {
                m.oversubscribed(r.threads * r.ranks).to_string()
            })
            .csv("deterministic", |r| r.deterministic.to_string())
            .csv("seconds", |r| format!("{:.5}", r.stats.seconds))
            .csv("pretrace_seconds", |r| {
                format!("{:.5}", r.stats.pretrace_seconds)
            })
            .csv("records", |r| r.stats.cache_records.to_string())
            .csv("pretrace_records", |r| r.stats.pretrace_records.to_string())
            .csv("lookups", |r| r.stats.lookups.to_string())
            .csv("rel_rmse", |r| format!("{:.5}", r.error))
            .csv("frame_hash", |r| r.stats.frame_hash.clone())
            .csv_text(&self.rows.iter().collect::<Vec<_>>())
    }

    /// Writes `deterministic.md` and `deterministic.csv` into `dir`, with the provenance of
    /// `command`.
    pub fn write(&self, dir: &Path, command: &str) -> Result<(), String> {
        let ranks: Vec<(usize, usize)> = self.config.ranks.iter().map(|&r| (r, 1)).collect();
        let provenance = Provenance::new(command, &self.machine, &self.config.threads, &ranks);
        let out = Output::new(dir, &provenance)?;
        out.csv("deterministic.csv", &self.csv())?;
        let title = "Deterministic frames against ordinary WF frames";
        out.markdown("deterministic.md", title, &self.markdown())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(run: usize, threads: usize, deterministic: bool, seconds: f64, hash: &str) -> Row {
        let mut stats = FrameStats {
            seconds,
            cache_records: if deterministic { 104 } else { 100 },
            frame_hash: hash.to_owned(),
            ..FrameStats::default()
        };
        stats.threads = threads;
        Row {
            scene: "cornell".into(),
            run,
            threads,
            ranks: 1,
            deterministic,
            stats,
            error: if deterministic { 0.051 } else { 0.05 },
        }
    }

    fn experiment(rows: Vec<Row>) -> Deterministic {
        Deterministic {
            config: DeterministicConfig {
                scenes: vec!["cornell".into()],
                threads: vec![1, 2],
                runs: 2,
                settings: RenderSettings::new(8, 8),
                stride: 2,
                ranks: Vec::new(),
            },
            machine: Machine::detect(),
            rows,
        }
    }

    #[test]
    fn the_checks_read_the_goals_and_the_hashes() {
        let rows = |h: &str| {
            let mut r = Vec::new();
            for run in 0..2 {
                for t in [1, 2] {
                    r.push(row(run, t, false, 1.0, "x"));
                    let hash = if t == 2 && run == 1 { h } else { "a" };
                    r.push(row(run, t, true, 1.2, hash));
                }
            }
            r
        };
        let verdicts =
            |e: &Deterministic| -> Vec<Verdict> { e.checks().iter().map(|c| c.verdict).collect() };
        // 1.2x the time: no; 4% more records: yes; error 5.1% against 5.0% with no spread: no;
        // every seed hashed alike: yes.
        let same = experiment(rows("a"));
        assert_eq!(
            verdicts(&same),
            [Verdict::No, Verdict::Yes, Verdict::No, Verdict::Yes]
        );
        let differ = experiment(rows("b"));
        let last = differ.checks().pop().unwrap();
        assert_eq!(last.verdict, Verdict::No);
        assert!(
            last.detail.contains("cornell seed 1: a b"),
            "{}",
            last.detail
        );
        assert!(same.markdown().contains("| cornell | 2 |"));
        assert_eq!(same.csv().lines().count(), 9);
    }
}
