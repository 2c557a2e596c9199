//! The report of `wfic reproduce dynamic`: `dynamic.md`, `dynamic.csv`, `dynamic-sweep.csv`,
//! the time and error plot and the strip of frames.

use super::{mean_after_first, Dynamic, Mode, Row};
use crate::harness::table::{pct, Table};
use crate::harness::{Check, Output, Provenance};
use crate::plot::{Figure, Line, Panel};
use std::fmt::Write as _;
use std::path::Path;
use wfic_render::scenes::CORNELL_SLIDE;

/// A summary of frames after the first: the table rows of both Markdown tables.
struct Summary<'a> {
    label: String,
    mode: Mode,
    rows: Vec<&'a Row>,
    fresh_seconds: f64,
}

impl Summary<'_> {
    fn mean(&self, f: impl Fn(&Row) -> f64) -> f64 {
        mean_after_first(self.rows.iter().copied(), f)
    }

    fn last(&self) -> Option<&Row> {
        self.rows.iter().copied().rfind(|r| r.frame > 0)
    }

    fn max_error(&self) -> f64 {
        self.rows
            .iter()
            .filter(|r| r.frame > 0)
            .map(|r| r.error)
            .fold(0.0, f64::max)
    }
}

/// The CSV columns both CSVs share, `seconds` to `records`, of the row `row` picks.
fn frame_columns<'a, R: 'a>(t: Table<'a, R>, row: fn(&R) -> &Row) -> Table<'a, R> {
    t.csv("seconds", move |r| format!("{:.6}", row(r).seconds))
        .csv("seconds_min", move |r| {
            format!("{:.6}", row(r).seconds_range.0)
        })
        .csv("seconds_max", move |r| {
            format!("{:.6}", row(r).seconds_range.1)
        })
        .csv("passes", move |r| row(r).passes.to_string())
        .csv("ic_samples", move |r| row(r).ic_samples.to_string())
        .csv("removed", move |r| row(r).removed.to_string())
        .csv("records", move |r| row(r).records.to_string())
}

impl Dynamic {
    /// `dynamic.csv`: one row per scheme, mode and frame.
    pub fn csv(&self) -> String {
        let s = &self.config.settings;
        let m = &self.machine;
        let t = Table::new()
            .csv("scene", |_: &Row| self.config.scene.clone())
            .csv("scheme", |r| r.scheme.name().to_owned())
            .csv("mode", |r| r.mode.name().to_owned())
            .csv("threads", |r| r.threads.to_string())
            .csv("cores", |_| m.cores.to_string())
            .csv("oversubscribed", |r| {
                m.oversubscribed(r.threads).to_string()
            })
            .csv("width", |_| s.width.to_string())
            .csv("height", |_| s.height.to_string())
            .csv("frame", |r| r.frame.to_string());
        frame_columns(t, |r| r)
            .csv("nodes", |r| r.nodes.to_string())
            .csv("bytes_estimate", |r| r.bytes().to_string())
            .csv("rel_rmse", |r| format!("{:.6}", r.error))
            .csv_text(&self.rows)
    }

    /// `dynamic-sweep.csv`: the removal mode's frames at every tolerance (the main run's, `a`,
    /// among them).
    pub fn sweep_csv(&self) -> String {
        let rows: Vec<(f32, &Row)> = self
            .sweep_rows()
            .into_iter()
            .flat_map(|(t, rows)| rows.into_iter().map(move |r| (t, r)))
            .collect();
        let t = Table::new()
            .csv("scheme", |(_, r): &(f32, &Row)| r.scheme.name().to_owned())
            .csv("threads", |(_, r)| r.threads.to_string())
            .csv("tolerance", |(t, _)| t.to_string())
            .csv("frame", |(_, r)| r.frame.to_string());
        frame_columns(t, |(_, r)| r)
            .csv("rel_rmse", |(_, r)| format!("{:.6}", r.error))
            .csv_text(&rows)
    }

    /// What was rendered and how the error is measured: the page's first paragraphs.
    fn intro(&self) -> String {
        let s = &self.config.settings;
        let n = self.config.frames;
        format!(
            "`{}`: the Cornell box's short block slides {:.0} mm along the floor over {n} frames \
             ({:.1} mm a frame); the camera stays. {}x{}, {} primary rays a pixel, {} rays a \
             record, {} light samples, a = {}. Error: relative RMSE of luminance against each \
             frame's brute-force image (scheme `none`, same seed and light samples) over the \
             pixels that see a non-emitting surface; the references took {:.1} s.\n\n\
             How to read this page: docs/experiments.md#dynamic-scenes. Removal's margin: \
             `removal` up to {:.0} mm, `removal-near` {:.0} mm. The removal mode ran {} times \
             per scheme: its seconds are each frame's median (the CSV has the range).\n\n",
            self.config.scene,
            CORNELL_SLIDE.length() * 1000.0,
            CORNELL_SLIDE.length() * 1000.0 / (n - 1) as f32,
            s.width,
            s.height,
            s.pixel_samples,
            s.rays_per_record,
            s.light_samples,
            s.accuracy,
            self.reference_seconds,
            self.margin * 1000.0,
            self.margin * 1000.0,
            self.config.passes
        )
    }

    /// The means over frames after the first, per scheme and mode.
    fn modes_markdown(&self) -> String {
        let mut summaries = Vec::new();
        for &scheme in &self.config.schemes {
            let fresh_seconds = self.mean(scheme, Mode::Fresh, |r| r.seconds);
            for mode in Mode::ALL {
                let rows: Vec<&Row> = self.rows_of(scheme, mode).collect();
                if rows.iter().any(|r| r.frame > 0) {
                    let label = scheme.heading().to_owned();
                    summaries.push(Summary {
                        label,
                        mode,
                        rows,
                        fresh_seconds,
                    });
                }
            }
        }
        let last = |s: &Summary| s.last().cloned().expect("a frame after the first");
        let t = Table::new()
            .md("scheme", |s: &Summary| s.label.clone())
            .left()
            .md("threads", |s| self.machine.count(last(s).threads))
            .md("mode", |s| s.mode.name().to_owned())
            .left()
            .md("seconds", |s| format!("{:.3}", s.mean(|r| r.seconds)))
            .md("IC samples", |s| {
                format!("{:.0}", s.mean(|r| r.ic_samples as f64))
            })
            .md("removed", |s| {
                format!("{:.0}", s.mean(|r| r.removed as f64))
            })
            .md("records (last)", |s| last(s).records.to_string())
            .md("nodes (last)", |s| last(s).nodes.to_string())
            .md("memory est. (last)", |s| {
                format!("{:.0} KiB", last(s).bytes() as f64 / 1024.0)
            })
            .md("error mean", |s| pct(s.mean(|r| r.error)))
            .md("error max", |s| pct(s.max_error()))
            .md("time vs fresh", |s| {
                format!("{:.2}x", s.fresh_seconds / s.mean(|r| r.seconds))
            });
        format!(
            "## Frames after the first (means over frames 1..{})\n\n{}",
            self.config.frames - 1,
            t.markdown(&summaries)
        )
    }

    /// The removal mode at each tolerance of the sweep.
    fn sweep_markdown(&self) -> String {
        if self.sweep.is_empty() {
            return String::new();
        }
        let scheme = self.strip_scheme;
        let fresh_seconds = self.mean(scheme, Mode::Fresh, |r| r.seconds);
        let fresh_error = self.mean(scheme, Mode::Fresh, |r| r.error);
        let a = self.config.settings.accuracy;
        let summaries: Vec<Summary> = self
            .sweep_rows()
            .into_iter()
            .map(|(tolerance, rows)| Summary {
                label: format!("{tolerance:.3} ({}a)", tolerance / a),
                mode: Mode::Removal,
                rows,
                fresh_seconds,
            })
            .collect();
        let t = Table::new()
            .md("tolerance", |s: &Summary| s.label.clone())
            .md("seconds", |s| format!("{:.3}", s.mean(|r| r.seconds)))
            .md("IC samples", |s| {
                format!("{:.0}", s.mean(|r| r.ic_samples as f64))
            })
            .md("removed", |s| {
                format!("{:.0}", s.mean(|r| r.removed as f64))
            })
            .md("records (last)", |s| {
                s.last().map_or(0, |r| r.records).to_string()
            })
            .md("error mean", |s| pct(s.mean(|r| r.error)))
            .md("error max", |s| pct(s.max_error()))
            .md("time vs fresh", |s| {
                format!("{:.2}x", s.fresh_seconds / s.mean(|r| r.seconds))
            });
        let threads = self.config.threads_of(scheme);
        format!(
            "\n## Removal's tolerance ({}, {threads} threads{}; means over frames 1..{})\n\n\
             A fresh cache: {fresh_seconds:.3} s a frame, error {}.\n\n{}",
            scheme.heading(),
            self.star(threads),
            self.config.frames - 1,
            pct(fresh_error),
            t.markdown(&summaries)
        )
    }

    /// `dynamic.md`'s body.
    pub fn markdown(&self) -> String {
        let mut md = self.intro();
        md.push_str(&self.modes_markdown());
        md.push_str(&self.sweep_markdown());
        let _ = write!(
            md,
            "\n## Checks\n\n{}\n## Every frame with removal: seconds / error\n\n",
            Check::markdown(&self.checks(), false)
        );
        let mut t = Table::new().md("frame", |i: &usize| i.to_string());
        for &scheme in &self.config.schemes {
            t = t.md(scheme.heading(), move |&i| {
                self.rows_of(scheme, Mode::Removal)
                    .find(|r| r.frame == i)
                    .map_or(String::new(), |r| {
                        format!("{:.3} s / {}", r.seconds, pct(r.error))
                    })
            });
        }
        let frames: Vec<usize> = (0..self.config.frames).collect();
        let kept: Vec<String> = self.strip.iter().map(|(i, ..)| i.to_string()).collect();
        let _ = write!(
            md,
            "{}\n`dynamic-strip.png`: frames {}.\n\n`*`: oversubscribed (more threads than the {} cores).\n",
            t.markdown(&frames),
            kept.join(", "),
            self.machine.cores
        );
        md
    }

    /// Time and error per frame, one line per scheme and mode.
    pub fn figure(&self) -> Figure {
        let n = self.config.frames;
        let dash =
            |c: wfic::cache::Rgb8, k: u16| c.map(|v| ((u16::from(v) + k * 255) / (k + 1)) as u8);
        let (mut time, mut error, mut legend) = (Vec::new(), Vec::new(), Vec::new());
        for &scheme in &self.config.schemes {
            for mode in Mode::ALL {
                let colour = match mode {
                    Mode::Removal => scheme.colour(),
                    Mode::RemovalNear | Mode::RemovalLocal | Mode::Fresh => {
                        dash(scheme.colour(), 1)
                    }
                    Mode::Stale => dash(scheme.colour(), 2),
                };
                if matches!(mode, Mode::RemovalNear | Mode::RemovalLocal) {
                    // Three lines a scheme are enough to read; its numbers are in the tables.
                    continue;
                }
                let threads = self.machine.count(self.config.threads_of(scheme));
                let label = format!(
                    "{} {threads} {}",
                    scheme.heading(),
                    mode.name().to_uppercase()
                );
                legend.push((label.clone(), colour));
                let rows: Vec<&Row> = self.rows_of(scheme, mode).collect();
                let line = |label, y: fn(&Row) -> f64| Line {
                    label,
                    colour,
                    points: rows.iter().map(|r| (r.frame as f64, y(r))).collect(),
                    markers: mode == Mode::Removal,
                };
                time.push(line(label.clone(), |r| r.seconds));
                error.push(line(label, |r| 100.0 * r.error));
            }
        }
        let base = Panel {
            x_range: (0.0, (n - 1) as f64),
            x_label: "FRAME".into(),
            legend,
            ..Panel::default()
        };
        let threads = self.config.thread_counts();
        Figure {
            header: vec![
                format!(
                    "A SCENE THAT MOVES: {} ({} FRAMES), {}X{}; REMOVAL (DARK), FRESH (MID), STALE (LIGHT)",
                    self.config.scene.to_uppercase(),
                    n,
                    self.config.settings.width,
                    self.config.settings.height
                ),
                self.machine.banner(&threads),
            ],
            panels: vec![
                Panel {
                    title: "TIME PER FRAME".into(),
                    left_label: "TIME (S)".into(),
                    lines: time,
                    ..base.clone()
                },
                Panel {
                    title: "ERROR AGAINST THE FRAME'S BRUTE-FORCE IMAGE".into(),
                    left_label: "REL. RMSE (%)".into(),
                    lines: error,
                    ..base
                },
            ],
            columns: 1,
            panel_size: (1200, 480),
        }
    }

    /// The strip: one column per kept frame; rows removal, stale, reference, all at the
    /// reference's exposure.
    pub fn strip_image(&self) -> Option<image::RgbImage> {
        let (_, first, ..) = self.strip.first()?;
        let (w, h) = (first.width(), first.height());
        let gap = 4;
        let cols = self.strip.len() as u32;
        let mut out = image::RgbImage::from_pixel(
            cols * (w + gap) - gap,
            3 * (h + gap) - gap,
            image::Rgb([255, 255, 255]),
        );
        for (c, (_, a, stale, reference)) in self.strip.iter().enumerate() {
            let exposure = reference.auto_exposure();
            for (r, img) in [a, stale, reference].into_iter().enumerate() {
                let rgb = img.to_srgb8(exposure);
                for y in 0..h {
                    for x in 0..w {
                        let k = 3 * (y * w + x) as usize;
                        out.put_pixel(
                            c as u32 * (w + gap) + x,
                            r as u32 * (h + gap) + y,
                            image::Rgb([rgb[k], rgb[k + 1], rgb[k + 2]]),
                        );
                    }
                }
            }
        }
        Some(out)
    }

    /// Writes `dynamic.csv`, `dynamic-sweep.csv`, `dynamic.md`, `dynamic.png`, `dynamic.svg` and
    /// `dynamic-strip.png`, each with the provenance of `command`.
    pub fn write(&self, dir: &Path, command: &str) -> Result<(), String> {
        let provenance = Provenance::new(command, &self.machine, &self.config.thread_counts(), &[]);
        let out = Output::new(dir, &provenance)?;
        out.csv("dynamic.csv", &self.csv())?;
        let title = "A scene that moves: removal against a fresh and a stale cache";
        out.markdown("dynamic.md", title, &self.markdown())?;
        out.csv("dynamic-sweep.csv", &self.sweep_csv())?;
        out.figure("dynamic", &self.figure())?;
        if let Some(strip) = self.strip_image() {
            let path = out.path("dynamic-strip.png");
            strip
                .save(&path)
                .map_err(|e| format!("{}: {e}", path.display()))?;
        }
        Ok(())
    }
}
