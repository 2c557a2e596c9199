//! The report of `wfic reproduce dynamic`: `dynamic.md`, `dynamic.csv`, `dynamic-sweep.csv`,
//! the time and error plot and the strip of frames.

use super::{mean_after_first, Dynamic, Mode, Row};
use crate::animation::{frame_figure, Series};
use crate::harness::table::{pct, Table};
use crate::harness::{Check, Output, Provenance};
use crate::plot::Figure;
use image::RgbImage;
use std::fmt::Write as _;
use std::path::Path;
use wfic::cache::Rgb8;
use wfic_render::scenes::CORNELL_SLIDE;

/// A summary of frames after the first: a row of both Markdown tables.
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

    /// A table of summaries: `head`'s columns, the means and the last frame's records,
    /// `more`'s columns, then the error and the time against a fresh cache.
    fn table<'t>(
        head: Table<'t, Self>,
        more: impl FnOnce(Table<'t, Self>) -> Table<'t, Self>,
    ) -> Table<'t, Self> {
        let mean = |f: fn(&Row) -> f64, digits| move |s: &Self| format!("{:.*}", digits, s.mean(f));
        let t = head
            .md("seconds", mean(|r| r.seconds, 3))
            .md("IC samples", mean(|r| r.ic_samples as f64, 0))
            .md("removed", mean(|r| r.removed as f64, 0))
            .md("records (last)", |s| {
                s.last().map_or(0, |r| r.records).to_string()
            });
        more(t)
            .md("error mean", |s| pct(s.mean(|r| r.error)))
            .md("error max", |s| {
                let after_first = s.rows.iter().filter(|r| r.frame > 0);
                pct(after_first.map(|r| r.error).fold(0.0, f64::max))
            })
            .md("time vs fresh", |s| {
                format!("{:.2}x", s.fresh_seconds / s.mean(|r| r.seconds))
            })
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
        let (slide, margin) = (CORNELL_SLIDE.length() * 1000.0, self.margin * 1000.0);
        format!(
            "`{}`: the Cornell box's short block slides {slide:.0} mm along the floor over {n} \
             frames ({:.1} mm a frame); the camera stays. {}x{}, {} primary rays a pixel, {} \
             rays a record, {} light samples, a = {}. Error: relative RMSE of luminance against \
             each frame's brute-force image (scheme `none`); the references took {:.1} s.\n\n\
             How to read this page: docs/experiments.md#dynamic-scenes. Removal's margin: \
             `removal` up to {margin:.0} mm, `removal-near` {margin:.0} mm. The removal mode ran \
             {} times per scheme: its seconds are each frame's median (the CSV has the range).\n\n",
            self.config.scene,
            slide / (n - 1) as f32,
            s.width,
            s.height,
            s.pixel_samples,
            s.rays_per_record,
            s.light_samples,
            s.accuracy,
            self.reference_seconds,
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
        let head = Table::new()
            .md("scheme", |s: &Summary| s.label.clone())
            .left()
            .md("threads", |s| self.machine.count(last(s).threads))
            .md("mode", |s| s.mode.name().to_owned())
            .left();
        let t = Summary::table(head, |t| {
            t.md("nodes (last)", move |s| last(s).nodes.to_string())
                .md("memory est. (last)", move |s| {
                    format!("{:.0} KiB", last(s).bytes() as f64 / 1024.0)
                })
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
        let head = Table::new().md("tolerance", |s: &Summary| s.label.clone());
        let threads = self.config.threads_of(scheme);
        format!(
            "\n## Removal's tolerance ({}, {threads} threads{}; means over frames 1..{})\n\n\
             A fresh cache: {fresh_seconds:.3} s a frame, error {}.\n\n{}",
            scheme.heading(),
            self.star(threads),
            self.config.frames - 1,
            pct(fresh_error),
            Summary::table(head, |t| t).markdown(&summaries)
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

    /// Time and error per frame: removal, fresh and stale, per scheme (the other removal modes
    /// are in the tables).
    pub fn figure(&self) -> Figure {
        let dash = |c: Rgb8, k: u16| c.map(|v| ((u16::from(v) + k * 255) / (k + 1)) as u8);
        let mut series = Vec::new();
        for &scheme in &self.config.schemes {
            let threads = self.machine.count(self.config.threads_of(scheme));
            for (k, mode) in [(0, Mode::Removal), (1, Mode::Fresh), (2, Mode::Stale)] {
                let name = mode.name().to_uppercase();
                series.push(Series {
                    label: format!("{} {threads} {name}", scheme.heading()),
                    colour: dash(scheme.colour(), k),
                    markers: mode == Mode::Removal,
                    points: (self.rows_of(scheme, mode))
                        .map(|r| [r.frame as f64, r.seconds, 100.0 * r.error])
                        .collect(),
                });
            }
        }
        let s = &self.config.settings;
        let title = format!(
            "A SCENE THAT MOVES: {} ({} FRAMES), {}X{}; REMOVAL (DARK), FRESH (MID), STALE (LIGHT)",
            self.config.scene.to_uppercase(),
            self.config.frames,
            s.width,
            s.height
        );
        frame_figure(
            vec![title, self.machine.banner(&self.config.thread_counts())],
            self.config.frames,
            [
                "ERROR AGAINST THE FRAME'S BRUTE-FORCE IMAGE",
                "REL. RMSE (%)",
            ],
            series,
            None,
        )
    }

    /// The strip: one column per kept frame; rows removal, stale, reference, all at the
    /// reference's exposure.
    pub fn strip_image(&self) -> Option<RgbImage> {
        let (_, first, ..) = self.strip.first()?;
        let (w, h, gap) = (first.width(), first.height(), 4);
        let cols = self.strip.len() as u32;
        let white = image::Rgb([255, 255, 255]);
        let mut out = RgbImage::from_pixel(cols * (w + gap) - gap, 3 * (h + gap) - gap, white);
        for (c, (_, a, stale, reference)) in (0..).zip(&self.strip) {
            let exposure = reference.auto_exposure();
            for (r, img) in (0..).zip([a, stale, reference]) {
                let tile = RgbImage::from_raw(w, h, img.to_srgb8(exposure)).expect("w x h pixels");
                let (x, y) = (c * (w + gap), r * (h + gap));
                image::imageops::replace(&mut out, &tile, i64::from(x), i64::from(y));
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
