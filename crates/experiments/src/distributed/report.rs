//! The report of `wfic reproduce distributed`: `distributed.md`, `distributed.csv` and the
//! batch sweep's plot.

use super::{AnimFrame, Animation, Distributed, Job, Layout, ONE, SHARED};
use crate::harness::metrics::ImageError;
use crate::harness::stats;
use crate::harness::table::{pct, Table};
use crate::harness::{Check, Output, Provenance};
use crate::plot::{Figure, Line, Panel};
use crate::radiance::SharedAmbientRun;
use std::fmt::Write as _;
use std::path::Path;

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
    /// The page's opening: how the jobs ran and what the columns mean.
    fn intro(&self) -> String {
        let s = &self.config.settings;
        format!(
            "Jobs ran under `mpirun` {}, OpenMPI over shared memory (`btl self,vader`). How to \
             read this page: docs/experiments.md#distributed.\n\n\
             `{}`, {}x{}, {} primary ray a pixel, {} rays a record, {} light samples, a = {}. \
             Shared ranks send their new records every {} records or {} ms. Reference: \
             `--scheme none`, {} rays a record, on a 1-in-{}x{} grid ({:.1} s). Seconds: rank \
             0's frame, the median of {} run(s).\n\n",
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

    /// A layout's name, marked when its processes times threads exceed the machine's cores
    /// (computed, as the provenance header's list is).
    fn layout_label(&self, layout: &Layout) -> String {
        let workers = layout.ranks * layout.threads;
        let mark = if self.machine.oversubscribed(workers) {
            " (oversubscribed)"
        } else {
            ""
        };
        format!("{}{mark}", layout.label)
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
            .md("layout", |j: &Job| self.layout_label(&j.layout))
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
             {} -aa {} -ar {} -as 0 -dj 0 -af FILE -n P`, one ray a pixel; reference `-aa 0 \
             -ad {}` ({:.1} s).\n\n{}",
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
             off)\n\n{}",
            t.markdown(&self.sweep)
        );
        let Some(n) = self.animations.first().map(|a| a.frames.len()) else {
            return md;
        };
        let later =
            |a: &Animation, f: fn(&AnimFrame) -> f64| stats::mean(a.frames[1..].iter().map(f));
        let total = |a: &Animation, f: fn(&AnimFrame) -> u64| a.frames.iter().map(f).sum::<u64>();
        let t = Table::new()
            .md("layout", |a: &Animation| self.layout_label(&a.layout))
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
            .md("records, all", |a| total(a, |f| f.records).to_string())
            .md("duplicates, all", |a| {
                total(a, |f| f.duplicates).to_string()
            })
            .md("bytes sent, all", |a| kib(total(a, |f| f.bytes)))
            .md("last frame's error", |a| pct(a.last_error.rel_rmse));
        let _ = write!(
            md,
            "\n## The orbit animation: {n} frames, the caches kept across frames\n\n{}",
            t.markdown(&self.animations)
        );
        md
    }

    /// `distributed.md`'s body.
    pub fn markdown(&self) -> String {
        let (insert, wire) = self.calibration();
        format!(
            "{}{}{}{}\n## The exchange-cost model, calibrated here\n\n{:.2} us to insert a received record, {:.0} bytes a record on the wire.\n\n\
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
            out.figure("distributed", &self.figure())?;
        }
        Ok(())
    }
}
