//! The report of Table 1: `table1.md` laid out as the paper's Table 1 with the paper's figures
//! beside ours, `table1.csv`, `speedup.csv` and Figure 1.

use super::{Measurement, Table1, CHECK_THREADS, SPEEDUP_GOAL};
use crate::harness::control::SpeedupAnalysis;
use crate::harness::stats;
use crate::harness::table::{star, Table};
use crate::harness::{Check, Output, Provenance};
use crate::paper;
use crate::plot::{Bar, Figure, Line, Panel};
use std::fmt::Write as _;
use std::path::Path;
use wfic::cache::Scheme;
use wfic_render::FrameStats;

impl Table1 {
    /// The header's list after the provenance: sampling, runs, the oversubscribed columns.
    fn settings_text(&self) -> String {
        let s = &self.config.settings;
        format!(
            "- image {}x{}, {} primary ray(s) per pixel, accuracy {}, {} rays per record, {} light \
             samples per primary hit, {}-pixel tiles; {} timed run(s) per column ({} for TRA, and for \
             LCK, LW and WF at {CHECK_THREADS} threads, which the checks compare{}), medians; one \
             untimed warm-up frame per scene; whole run {:.0} s\n\
             - columns marked `*` are oversubscribed (more threads than the {} cores): they \
             measure time-slicing, not scaling\n\n",
            s.width,
            s.height,
            s.pixel_samples,
            s.accuracy,
            s.rays_per_record,
            s.light_samples,
            s.tile_size,
            self.config.runs,
            self.config.rounds(),
            if self.config.controls {
                ", each round also renders WF on one thread and two TRA frames at once, the \
                 machine control"
            } else {
                ""
            },
            self.seconds,
            self.machine.cores
        )
    }

    /// One scene's table laid out as the paper's (a column per configuration), and the
    /// paper's figures beside ours.
    fn scene_markdown(&self, scene: &str) -> String {
        let ms: Vec<&Measurement> = self
            .config
            .columns()
            .iter()
            .filter_map(|&(sc, t)| self.get(scene, sc, t))
            .collect();
        let column = |m: &Measurement| {
            let over = star(self.machine.oversubscribed(m.threads));
            format!("{} {}{over}", m.scheme.heading(), m.threads)
        };
        type Metric<'m> = (&'static str, Box<dyn Fn(&Measurement) -> String + 'm>);
        let metrics: Vec<Metric> = vec![
            ("Time (s)", Box::new(|m| format!("{:.3}", m.time()))),
            ("IC samples", Box::new(|m| format!("{}", m.samples()))),
            ("Overheads †", Box::new(|m| m.overhead_text())),
            ("Speed-up", Box::new(|m| format!("{:.3}", self.speedup(m)))),
            (
                "Sharing",
                Box::new(|m| format!("{:.0}%", 100.0 * m.median(|s| s.sharing))),
            ),
        ];
        let mut t = Table::new().md("", |r: &Metric| r.0.to_owned()).left();
        for &m in &ms {
            t = t.md(&column(m), move |r: &Metric| (r.1)(m));
        }
        let mut md = format!("## {scene}\n\n{}\n", t.markdown(&metrics));
        if paper::cell(scene, Scheme::Tra, 1).is_some() {
            let beside: Vec<(&Measurement, paper::PaperCell)> = ms
                .iter()
                .filter_map(|&m| Some((m, paper::cell(scene, m.scheme, m.threads)?)))
                .collect();
            type Pair<'m> = (&'m Measurement, paper::PaperCell);
            let t = Table::new()
                .md("column", |(m, _): &Pair| column(m))
                .left()
                .md("paper time (s)", |(_, p)| format!("{:.3}", p.time))
                .md("ours", |(m, _)| format!("{:.3}", m.time()))
                .md("paper IC samples", |(_, p)| p.samples.to_string())
                .md("ours", |(m, _)| m.samples().to_string())
                .md("paper overhead †", |(_, p)| p.overhead.to_string())
                .md("ours", |(m, _)| m.overhead_text())
                .md("paper speed-up", |(_, p)| format!("{:.3}", p.speedup))
                .md("ours", |(m, _)| format!("{:.3}", self.speedup(m)));
            let _ = writeln!(
                md,
                "Beside the paper (8-core Xeon; its 4 and 8 threads were real cores):\n\n{}",
                t.markdown(&beside)
            );
        }
        md
    }

    /// The speed-up set against the machine control, one row a scene.
    fn speedup_markdown(&self) -> String {
        let analyses: Vec<SpeedupAnalysis> = self
            .config
            .scenes
            .iter()
            .filter_map(|s| self.speedup_analysis(s))
            .collect();
        if analyses.is_empty() {
            return String::new();
        }
        let goal = format!("goal >= {SPEEDUP_GOAL}");
        let t = Table::new()
            .md("scene", |a: &SpeedupAnalysis| a.scene.clone())
            .left()
            .md("speed-up TRA/WF 2", |a| a.speedup.text())
            .md("machine 2 TRA/twins", |a| a.machine.text())
            .md("idle WF 2", |a| format!("{:.2}%", 100.0 * a.idle))
            .md("ceiling", |a| format!("{:.3}", a.ceiling()))
            .md("gap (ceiling − speed-up)", |a| {
                format!("{:+.3}", a.ceiling() - a.speedup.median)
            })
            .md("WF 1 / TRA", |a| a.wf_one.text())
            .md("samples WF 2 / TRA", |a| format!("{:.3}", a.samples))
            .md(&goal, |a| a.verdict().text().to_owned())
            .left();
        format!(
            "## WF's speed-up at 2 threads, set against the machine\n\n\
             How to read it: docs/experiments.md#table-1-and-figure-1.\n\n{}\n",
            t.markdown(&analyses)
        )
    }

    /// `table1.md`'s body: the tables laid out as the paper's Table 1, the paper's figures
    /// beside ours, the speed-up against the machine, and the checks.
    pub fn markdown(&self) -> String {
        let mut md = self.settings_text();
        for scene in &self.config.scenes {
            md.push_str(&self.scene_markdown(scene));
        }
        md.push_str(
            "† Overheads: lock-wait seconds summed over threads (LCK, LCK-RW), merge seconds (LW), \
             samples discarded (WF, WF-D). Sharing: hits served by a record another thread computed.\n\n",
        );
        md.push_str(&self.speedup_markdown());
        let _ = write!(
            md,
            "## Checks (2 threads, real cores)\n\n\
             Verdicts: docs/experiments.md#how-results-are-measured-and-labelled.\n\n{}",
            Check::markdown(&self.checks(), true)
        );
        md
    }

    /// `table1.csv`: one row per configuration, medians and every run's time.
    pub fn csv(&self) -> String {
        let (cores, s) = (self.machine.cores, &self.config.settings);
        let over = |m: &Measurement| self.machine.oversubscribed(m.threads).to_string();
        let med = |m: &Measurement, f: fn(&FrameStats) -> f64| m.median(f).to_string();
        let fixed =
            |m: &Measurement, f: fn(&FrameStats) -> f64, d: usize| format!("{:.d$}", m.median(f));
        let range = |m: &Measurement| stats::range(m.times());
        Table::new()
            .csv("scene", |m: &Measurement| m.scene.clone())
            .csv("scheme", |m| m.scheme.name().to_owned())
            .csv("threads", |m| m.threads.to_string())
            .csv("cores", move |_| cores.to_string())
            .csv("oversubscribed", over)
            .csv("width", move |_| s.width.to_string())
            .csv("height", move |_| s.height.to_string())
            .csv("runs", |m| m.runs.len().to_string())
            .csv("time_median_s", |m| format!("{:.4}", m.time()))
            .csv("time_min_s", move |m| format!("{:.4}", range(m).0))
            .csv("time_max_s", move |m| format!("{:.4}", range(m).1))
            .csv("times_s", |m| {
                let list: Vec<String> = m.times().iter().map(|t| format!("{t:.4}")).collect();
                list.join(";")
            })
            .csv("ic_samples_median", |m| m.samples().to_string())
            .csv("lookups_median", move |m| med(m, |s| s.lookups as f64))
            .csv("hits_median", move |m| med(m, |s| s.hits as f64))
            .csv("sharing_median", move |m| fixed(m, |s| s.sharing, 4))
            .csv("lock_wait_s_median", move |m| {
                fixed(m, |s| s.lock_wait_seconds, 5)
            })
            .csv("merge_s_median", move |m| fixed(m, |s| s.merge_seconds, 5))
            .csv("discarded_median", move |m| med(m, |s| s.discarded as f64))
            .csv("discarded_total", |m| {
                m.runs.iter().map(|r| r.discarded).sum::<u64>().to_string()
            })
            .csv("cache_records_median", move |m| {
                med(m, |s| s.cache_records as f64)
            })
            .csv("speedup_vs_tra", |m| format!("{:.4}", self.speedup(m)))
            .csv_text(&self.measurements)
    }

    /// `speedup.csv`: per scene and round, the times WF's speed-up at [`CHECK_THREADS`] is
    /// judged on (TRA, WF at 2 threads and its idle share, WF on one thread, the TRA twins).
    pub fn speedup_csv(&self) -> String {
        type Round<'a> = (
            &'a str,
            usize,
            &'a FrameStats,
            &'a FrameStats,
            &'a FrameStats,
            f64,
        );
        let mut rows: Vec<Round> = Vec::new();
        for c in &self.controls {
            let (Some(tra), Some(wf)) = (
                self.get(&c.scene, Scheme::Tra, 1),
                self.get(&c.scene, Scheme::Wf, CHECK_THREADS),
            ) else {
                continue;
            };
            let rounds = tra
                .runs
                .iter()
                .zip(&wf.runs)
                .zip(&c.wf_one)
                .zip(&c.tra_twins);
            for (r, (((t, w), one), &twins)) in rounds.enumerate() {
                rows.push((&c.scene, r, t, w, one, twins));
            }
        }
        Table::new()
            .csv("scene", |r: &Round| r.0.to_owned())
            .csv("round", |r| r.1.to_string())
            .csv("tra_s", |r| format!("{:.5}", r.2.seconds))
            .csv("wf2_s", |r| format!("{:.5}", r.3.seconds))
            .csv("wf2_idle_share", |r| format!("{:.5}", r.3.idle_share()))
            .csv("wf1_s", |r| format!("{:.5}", r.4.seconds))
            .csv("tra_twins_s", |r| format!("{:.5}", r.5))
            .csv("speedup", |r| format!("{:.4}", r.2.seconds / r.3.seconds))
            .csv("machine", |r| format!("{:.4}", 2.0 * r.2.seconds / r.5))
            .csv_text(&rows)
    }

    /// Figure 1: one panel per scene, time per scheme as lines (left axis), speed-up over TRA as
    /// bars (right axis), x = threads; oversubscribed thread counts shaded.
    pub fn figure(&self) -> Figure {
        let threads = self.config.thread_counts();
        let schemes: Vec<Scheme> = self.config.parallel_schemes().collect();
        let bar_w = 0.8 / (schemes.len().max(1) as f64);
        let line = |scheme: Scheme, points| Line {
            label: scheme.heading().into(),
            colour: scheme.colour(),
            points,
            markers: true,
        };
        let bar = |x, width, value, scheme: Scheme| Bar {
            x,
            width,
            value,
            colour: scheme.colour(),
        };
        let x_end = threads.len() as f64 - 0.5;
        let mut panels = Vec::new();
        for scene in &self.config.scenes {
            let (mut lines, mut bars) = (Vec::new(), Vec::new());
            if let Some(tra) = self.get(scene, Scheme::Tra, 1) {
                lines.push(line(Scheme::Tra, vec![(0.0, tra.time())]));
                bars.push(bar(0.0, bar_w, 1.0, Scheme::Tra));
            }
            for (k, &scheme) in schemes.iter().enumerate() {
                let off = (k as f64 - (schemes.len() as f64 - 1.0) / 2.0) * bar_w;
                let mut points = Vec::new();
                for (i, &t) in threads.iter().enumerate().skip(1) {
                    if let Some(m) = self.get(scene, scheme, t) {
                        points.push((i as f64, m.time()));
                        bars.push(bar(i as f64 + off, bar_w * 0.9, self.speedup(m), scheme));
                    }
                }
                lines.push(line(scheme, points));
            }
            let first_over = threads.iter().position(|&t| self.machine.oversubscribed(t));
            let over = format!("OVERSUBSCRIBED: > {} CORES", self.machine.cores);
            panels.push(Panel {
                title: scene.to_uppercase(),
                x_range: (-0.5, x_end),
                x_ticks: threads
                    .iter()
                    .enumerate()
                    .map(|(i, &t)| (i as f64, self.machine.count(t)))
                    .collect(),
                x_label: "THREADS".into(),
                left_label: "LINES: TIME (S)".into(),
                lines,
                right_label: Some("BARS: SPEED-UP VS TRA".into()),
                bars,
                shaded: first_over.map_or(vec![], |i| vec![(i as f64 - 0.5, x_end, over)]),
                legend: std::iter::once(Scheme::Tra)
                    .chain(schemes.iter().copied())
                    .map(|s| (s.heading().to_owned(), s.colour()))
                    .collect(),
                ..Panel::default()
            });
        }
        let s = &self.config.settings;
        Figure {
            header: vec![
                format!(
                    "FIGURE 1 (REPRODUCED): STILL IMAGES, EMPTY CACHE, {}X{}, {} SPP, MEDIAN OF {} \
                     RUN(S){}",
                    s.width,
                    s.height,
                    s.pixel_samples,
                    self.config.runs,
                    if self.config.rounds() > self.config.runs {
                        format!(
                            " ({} FOR LCK, LW, WF AT {CHECK_THREADS} THREADS)",
                            self.config.rounds()
                        )
                    } else {
                        String::new()
                    }
                ),
                self.machine.banner(&threads),
            ],
            panels,
            columns: self.config.scenes.len().clamp(1, 2),
            panel_size: (760, 520),
        }
    }

    /// Writes `table1.md`, `table1.csv`, `speedup.csv` (with the machine control),
    /// `figure1.png` and `figure1.svg` into `dir`, each with the provenance of `command`.
    pub fn write(&self, dir: &Path, command: &str) -> Result<(), String> {
        let threads = self.config.thread_counts();
        let provenance = Provenance::new(command, &self.machine, &threads, &[]);
        let out = Output::new(dir, &provenance)?;
        let title = "Table 1: still images, empty cache";
        out.markdown("table1.md", title, &self.markdown())?;
        out.csv("table1.csv", &self.csv())?;
        if !self.controls.is_empty() {
            out.csv("speedup.csv", &self.speedup_csv())?;
        }
        out.figure("figure1", &self.figure())
    }
}
