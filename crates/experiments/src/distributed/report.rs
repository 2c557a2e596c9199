//! The report of `wfic reproduce distributed`: `distributed.md`, `distributed.csv` and the
//! batch sweep's plot.

use super::{bytes_sent, Animation, Distributed, Job, Layout, ONE, SHARED};
use crate::harness::metrics::ImageError;
use crate::harness::stats;
use crate::harness::table::{pct, Table};
use crate::harness::{Check, Output, Provenance};
use crate::plot::{Figure, Line, Panel};
use crate::radiance::SharedAmbientRun;
use std::path::Path;
use wfic_render::stats::DistributedFrameStats;

fn kib(bytes: u64) -> String {
    format!("{:.1} KiB", bytes as f64 / 1024.0)
}

/// One line of `distributed.csv`: a job, an animation's frame or a Radiance run (the figures a
/// kind has not are blank); a main job's line is also a row of the layouts' table.
struct Row<'a> {
    group: String,
    label: String,
    ranks: usize,
    threads: usize,
    share: bool,
    batch: Option<(usize, u64)>,
    seconds: f64,
    records: u64,
    duplicates: Option<u64>,
    bytes: u64,
    error: Option<ImageError>,
    job: Option<&'a Job>,
}

impl<'a> Row<'a> {
    /// A line of `layout`, its figures blank.
    fn new(group: String, l: &Layout) -> Self {
        Self {
            group,
            label: l.label.to_owned(),
            ranks: l.ranks,
            threads: l.threads,
            share: l.share,
            batch: Some((l.batch_records, l.batch_ms)),
            seconds: 0.0,
            records: 0,
            duplicates: None,
            bytes: 0,
            error: None,
            job: None,
        }
    }

    fn job(group: &str, j: &'a Job) -> Self {
        Self {
            seconds: j.seconds,
            records: j.total(),
            duplicates: Some(j.duplicates),
            bytes: j.bytes,
            error: Some(j.error),
            job: Some(j),
            ..Self::new(group.to_owned(), &j.layout)
        }
    }

    /// A line of an animation's frame `i`.
    fn frame(i: usize, l: &Layout, f: &DistributedFrameStats) -> Self {
        Self {
            seconds: f.seconds,
            records: f.records_computed,
            duplicates: Some(f.duplicates),
            bytes: bytes_sent(f),
            ..Self::new(format!("animation frame {i}"), l)
        }
    }

    fn radiance(r: &SharedAmbientRun) -> Self {
        Self {
            group: "radiance".to_owned(),
            label: format!("rtrace -n {}", r.processes),
            ranks: r.processes,
            threads: 1,
            share: true,
            batch: None,
            seconds: r.seconds,
            records: r.records as u64,
            duplicates: None,
            bytes: r.ambient_bytes,
            error: Some(r.error),
            job: None,
        }
    }

    /// A blank cell, or `f` of the job.
    fn of_job(&self, f: impl Fn(&Job) -> String) -> String {
        self.job.map_or(String::new(), f)
    }

    /// A blank cell, or `{:.5}` of `f` of the error.
    fn of_error(&self, f: fn(&ImageError) -> f64) -> String {
        self.error
            .map_or(String::new(), |e| format!("{:.5}", f(&e)))
    }
}

/// The records of each rank, joined with `sep`.
fn per_rank(j: &Job, sep: &str) -> String {
    let per: Vec<String> = j.computed.iter().map(u64::to_string).collect();
    per.join(sep)
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
    fn layout_label(&self, label: &str, ranks: usize, threads: usize) -> String {
        let over = self.machine.oversubscribed(ranks * threads);
        format!("{label}{}", if over { " (oversubscribed)" } else { "" })
    }

    /// Every line of `distributed.csv`, the main jobs' first.
    fn rows(&self) -> Vec<Row<'_>> {
        let mut rows: Vec<Row> = self.jobs.iter().map(|j| Row::job("layout", j)).collect();
        rows.extend(self.sweep.iter().map(|j| Row::job("sweep", j)));
        for a in &self.animations {
            let frames = a.frames.iter().enumerate();
            rows.extend(frames.map(|(i, f)| Row::frame(i, &a.layout, f)));
        }
        rows.extend(self.radiance.iter().flat_map(|(r, _)| r).map(Row::radiance));
        rows
    }

    /// The layouts' table against one rank (Markdown) and `distributed.csv`, in one spec.
    fn table(&self) -> Table<'_, Row<'_>> {
        let one = self.job(ONE);
        let against = move |r: &Row| {
            one.map_or((1.0, 1.0), |o| {
                (r.seconds / o.seconds, r.records as f64 / o.total() as f64)
            })
        };
        let batch = |r: &Row, f: fn((usize, u64)) -> String| r.batch.map_or(String::new(), f);
        Table::new()
            .csv("group", |r: &Row| r.group.clone())
            .col("layout", "layout", |r| {
                self.layout_label(&r.label, r.ranks, r.threads)
            })
            .left()
            .csv_as(|r| r.label.replace(',', ";"))
            .csv("ranks", |r| r.ranks.to_string())
            .csv("threads", |r| r.threads.to_string())
            .csv("share", |r| r.share.to_string())
            .csv("batch_records", move |r| batch(r, |b| b.0.to_string()))
            .csv("batch_ms", move |r| batch(r, |b| b.1.to_string()))
            .col("seconds (range)", "seconds", |r| {
                r.of_job(|j| format!("{:.3} ({:.3}-{:.3})", j.seconds, j.range.0, j.range.1))
            })
            .csv_as(|r| format!("{:.4}", r.seconds))
            .csv("seconds_min", |r| r.of_job(|j| format!("{:.4}", j.range.0)))
            .csv("seconds_max", |r| r.of_job(|j| format!("{:.4}", j.range.1)))
            .col("wall", "wall", |r| r.of_job(|j| format!("{:.2}", j.wall)))
            .csv_as(|r| r.of_job(|j| format!("{:.3}", j.wall)))
            .md("vs 1 x 2", move |r| format!("{:.2}x", against(r).0))
            .col("records", "records", |r| r.records.to_string())
            .col("per rank", "records_per_rank", |r| {
                r.of_job(|j| per_rank(j, " / "))
            })
            .left()
            .csv_as(|r| r.of_job(|j| per_rank(j, "/")))
            .md("vs 1 x 2", move |r| {
                format!("{:+.1}%", 100.0 * (against(r).1 - 1.0))
            })
            .col("duplicates", "duplicates", |r| {
                r.duplicates.map_or(String::new(), |d| d.to_string())
            })
            .col("bytes sent", "bytes_sent", |r| kib(r.bytes))
            .csv_as(|r| r.bytes.to_string())
            .col("rounds", "rounds", |r| r.of_job(|j| j.rounds.to_string()))
            .col("collectives (max rank)", "collective_seconds", |r| {
                r.of_job(|j| format!("{:.3} s", j.collective_seconds))
            })
            .csv_as(|r| r.of_job(|j| format!("{:.4}", j.collective_seconds)))
            .col("inserting (all ranks)", "insert_seconds", |r| {
                r.of_job(|j| format!("{:.3} s", j.insert_seconds))
            })
            .csv_as(|r| r.of_job(|j| format!("{:.4}", j.insert_seconds)))
            .csv("records_received", |r| r.of_job(|j| j.received.to_string()))
            .col("error", "rel_rmse", |r| {
                r.error.map_or(String::new(), |e| pct(e.rel_rmse))
            })
            .csv_as(|r| r.of_error(|e| e.rel_rmse))
            .col("mean rel. error", "mean_rel", |r| {
                r.error.map_or(String::new(), |e| pct(e.mean_rel))
            })
            .csv_as(|r| r.of_error(|e| e.mean_rel))
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
                    let more = r.records as f64 / one.max(1) as f64 - 1.0;
                    format!("{:+.1}%", 100.0 * more)
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

    /// The batch sweep's table.
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
        format!(
            "\n## Batch size: duplicates against exchange cost (2 ranks x 1 thread, the timer \
             off)\n\n{}",
            t.markdown(&self.sweep)
        )
    }

    /// The orbit animation's table (empty without one).
    fn animation_markdown(&self) -> String {
        let Some(n) = self.animations.first().map(|a| a.frames.len()) else {
            return String::new();
        };
        let later = |a: &Animation, f: fn(&DistributedFrameStats) -> f64| {
            stats::mean(a.frames[1..].iter().map(f))
        };
        let total = |a: &Animation, f: fn(&DistributedFrameStats) -> u64| {
            a.frames.iter().map(f).sum::<u64>()
        };
        let t = Table::new()
            .md("layout", |a: &Animation| {
                self.layout_label(a.layout.label, a.layout.ranks, a.layout.threads)
            })
            .left()
            .md("first frame (s)", |a| format!("{:.3}", a.frames[0].seconds))
            .md("later frames, mean (s)", |a| {
                format!("{:.3}", later(a, |f| f.seconds))
            })
            .md("total (s)", |a| {
                format!("{:.3}", a.frames.iter().map(|f| f.seconds).sum::<f64>())
            })
            .md("records, first", |a| {
                a.frames[0].records_computed.to_string()
            })
            .md("records, later (mean)", |a| {
                format!("{:.0}", later(a, |f| f.records_computed as f64))
            })
            .md("records, all", |a| {
                total(a, |f| f.records_computed).to_string()
            })
            .md("duplicates, all", |a| {
                total(a, |f| f.duplicates).to_string()
            })
            .md("bytes sent, all", |a| kib(total(a, bytes_sent)))
            .md("last frame's error", |a| pct(a.last_error.rel_rmse));
        format!(
            "\n## The orbit animation: {n} frames, the caches kept across frames\n\n{}",
            t.markdown(&self.animations)
        )
    }

    /// `distributed.md`'s body.
    pub fn markdown(&self) -> String {
        let (insert, wire) = self.calibration();
        let rows = self.rows();
        format!(
            "{}## The layouts\n\n{}{}{}{}\n## The exchange-cost model, calibrated here\n\n\
             {:.2} us to insert a received record, {:.0} bytes a record on the wire.\n\n\
             ## Checks\n\n{}",
            self.intro(),
            self.table().markdown(&rows[..self.jobs.len()]),
            self.radiance_markdown(),
            self.sweep_markdown(),
            self.animation_markdown(),
            insert * 1e6,
            wire,
            Check::markdown(&self.checks(), false)
        )
    }

    /// `distributed.csv`: one line a job, an animation's frame, a Radiance run.
    pub fn csv(&self) -> String {
        self.table().csv_text(&self.rows())
    }

    /// The sweep's plot: duplicates and rounds against the batch size.
    pub fn figure(&self) -> Figure {
        let x = |j: &Job| (j.layout.batch_records as f64).log2();
        let ticks: Vec<(f64, String)> = self
            .sweep
            .iter()
            .map(|j| (x(j), j.layout.batch_records.to_string()))
            .collect();
        let lo = ticks.first().map_or(0.0, |t| t.0);
        let hi = ticks.last().map_or(1.0, |t| t.0);
        let panel = |title: &str, axis: &str, label: &str, colour, f: fn(&Job) -> u64| Panel {
            title: title.into(),
            left_label: axis.into(),
            lines: vec![Line {
                label: label.to_owned(),
                colour,
                points: self.sweep.iter().map(|j| (x(j), f(j) as f64)).collect(),
                markers: true,
            }],
            legend: vec![(label.into(), colour)],
            x_range: (lo, hi.max(lo + 1.0)),
            x_ticks: ticks.clone(),
            x_label: "BATCH (RECORDS, LOG SCALE)".into(),
            ..Panel::default()
        };
        let s = &self.config.settings;
        Figure {
            header: vec![
                format!(
                    "BATCH SIZE: DUPLICATES AGAINST EXCHANGE ROUNDS, 2 RANKS X 1 THREAD, {} {}X{}",
                    self.config.scene.to_uppercase(),
                    s.width,
                    s.height
                ),
                self.machine.banner_with_ranks(&[], &[(2, 1)]),
            ],
            panels: vec![
                panel(
                    "DUPLICATE RECORDS",
                    "RECORDS",
                    "duplicates",
                    [200, 60, 40],
                    |j| j.duplicates,
                ),
                panel("EXCHANGE ROUNDS", "ROUNDS", "rounds", [40, 90, 200], |j| {
                    j.rounds
                }),
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
