//! `wfic reproduce scaling`: how a frame's cost grows with the image and with the accuracy.
//!
//! Each scene is rendered once per point on a fresh WF cache at two threads, default settings but
//! the one varied: the image side from 128 to 4 096 pixels (at the default accuracy), then the
//! accuracy `a` at 512 x 512. A point records the frame's seconds (median of three renders up to
//! 512 x 512, one above), the records it computed, its lookups, and the peak of the process's
//! resident memory during the frame (Linux: `VmHWM` after resetting it through
//! `/proc/self/clear_refs`): the scene, the cache, the film, and what the allocator kept from
//! earlier frames. The size sweep runs from the smallest image up, so what is kept is never more
//! than the frame itself needs; the accuracy sweep comes after the largest image, and its
//! memory column says little.
//!
//! The goal: time per pixel varies by at most 1.5x from 512 x 512 to 4 096 x 4 096. Where a
//! record's radius is clamped in pixel footprints (`RenderSettings`' radius clamps), the records
//! grow with the pixels; where Ward's radius or the scene's clamps decide, they stay put. So the
//! records a megapixel, and with them the hemisphere rays a pixel, fall as the image grows
//! towards the pixels' own work; the table shows how far.

use crate::bounds::check_resources;
use crate::harness::measure::Progress;
use crate::harness::provenance::command_line;
use crate::harness::stats::median;
use crate::harness::table::Table;
use crate::harness::{Check, Machine, Output, Provenance, Verdict};
use crate::plot::{Figure, Line, Panel};
use crate::reproduce_cli::{print_checks, ScalingArgs};
use std::path::Path;
use wfic::cache::Scheme;
use wfic_render::{render_with_scheme, scenes, RenderSettings};

/// Worker threads of every frame (the machines this runs on have two cores or more).
pub const THREADS: usize = 2;

/// What the experiment runs.
#[derive(Clone, Debug, PartialEq)]
pub struct ScalingConfig {
    /// Scenes.
    pub scenes: Vec<String>,
    /// Image sides of the size sweep (square images).
    pub sizes: Vec<u32>,
    /// Accuracies of the accuracy sweep.
    pub accuracies: Vec<f32>,
    /// Image side of the accuracy sweep.
    pub accuracy_size: u32,
    /// The sides the goal compares (the smallest and largest, both in `sizes`).
    pub goal_sizes: (u32, u32),
}

impl ScalingConfig {
    /// The full run: sides 128 to 4 096, accuracies 0.1 to 0.6 at 512.
    pub fn full(scenes: Vec<String>) -> Self {
        Self {
            scenes,
            sizes: vec![128, 256, 512, 1024, 2048, 4096],
            accuracies: vec![0.1, 0.15, 0.25, 0.4, 0.6],
            accuracy_size: 512,
            goal_sizes: (512, 4096),
        }
    }

    /// A smoke run: sides 64 to 256, three accuracies at 128.
    pub fn quick(scenes: Vec<String>) -> Self {
        Self {
            scenes,
            sizes: vec![64, 128, 256],
            accuracies: vec![0.15, 0.25, 0.4],
            accuracy_size: 128,
            goal_sizes: (128, 256),
        }
    }

    /// The largest image the run renders.
    pub fn largest(&self) -> u32 {
        self.sizes
            .iter()
            .copied()
            .chain([self.accuracy_size])
            .max()
            .unwrap_or(1)
    }
}

/// Which sweep a point belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sweep {
    /// The image side varies.
    Size,
    /// The accuracy varies.
    Accuracy,
}

/// One frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Scene.
    pub scene: String,
    /// Sweep.
    pub sweep: Sweep,
    /// Image side.
    pub size: u32,
    /// Ward's accuracy.
    pub accuracy: f32,
    /// Frame seconds (median of the renders).
    pub seconds: f64,
    /// Records computed (the cache starts empty: also the records held).
    pub records: u64,
    /// Cache lookups.
    pub lookups: u64,
    /// Peak resident bytes of the process during the frame, when known.
    pub peak_bytes: Option<u64>,
}

impl Point {
    fn pixels(&self) -> f64 {
        f64::from(self.size) * f64::from(self.size)
    }

    /// Nanoseconds a pixel.
    pub fn ns_per_pixel(&self) -> f64 {
        1e9 * self.seconds / self.pixels()
    }
}

/// A `/proc/self/status` field in bytes (`VmHWM`).
fn status_bytes(field: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with(field))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Resets the peak resident size to the current one (Linux 4.0 and later).
fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// One frame of `scene` at `size` and `accuracy`: seconds, records, lookups, peak bytes.
fn frame(
    scene: &wfic_render::Scene,
    size: u32,
    accuracy: f32,
) -> Result<(f64, u64, u64, Option<u64>), String> {
    let settings = RenderSettings::new(size, size).accuracy(accuracy);
    let config = settings.cache_config(scene).map_err(|e| e.to_string())?;
    let reset = reset_peak();
    let (out, records) = render_with_scheme(
        Scheme::Wf,
        scene,
        &scene.camera(),
        &settings,
        config,
        THREADS,
    );
    let peak = status_bytes("VmHWM").filter(|_| reset);
    Ok((
        out.stats.seconds,
        records.len() as u64,
        out.stats.lookups,
        peak,
    ))
}

/// Renders every point; `progress(label)` before each scene's sweeps.
///
/// # Errors
/// An unknown scene, or settings the renderer refuses.
pub fn run(config: &ScalingConfig, progress: &mut dyn FnMut(&str)) -> Result<Vec<Point>, String> {
    let default_accuracy = RenderSettings::new(1, 1).accuracy;
    let mut points = Vec::new();
    for name in &config.scenes {
        let scene = scenes::load(name)?;
        let plan = (config
            .sizes
            .iter()
            .map(|&s| (Sweep::Size, s, default_accuracy)))
        .chain((config.accuracies.iter()).map(|&a| (Sweep::Accuracy, config.accuracy_size, a)));
        for (sweep, size, accuracy) in plan {
            progress(&format!("{name}: {size} x {size}, a = {accuracy}"));
            let repeats = if size <= 512 { 3 } else { 1 };
            let runs = (0..repeats)
                .map(|_| frame(&scene, size, accuracy))
                .collect::<Result<Vec<_>, _>>()?;
            let seconds = median(&runs.iter().map(|r| r.0).collect::<Vec<_>>());
            let (_, records, lookups, _) = runs[0];
            let peak_bytes = runs.iter().filter_map(|r| r.3).max();
            points.push(Point {
                scene: name.clone(),
                sweep,
                size,
                accuracy,
                seconds,
                records,
                lookups,
                peak_bytes,
            });
        }
    }
    Ok(points)
}

/// The goal, per scene: time per pixel within 1.5x across `sizes` (the largest over the
/// smallest of the points between them).
pub fn checks(points: &[Point], sizes: (u32, u32)) -> Vec<Check> {
    let mut scenes: Vec<&str> = points.iter().map(|p| p.scene.as_str()).collect();
    scenes.dedup();
    scenes
        .into_iter()
        .map(|scene| {
            let ns: Vec<(u32, f64)> = (points.iter())
                .filter(|p| p.scene == scene && p.sweep == Sweep::Size)
                .filter(|p| (sizes.0..=sizes.1).contains(&p.size))
                .map(|p| (p.size, p.ns_per_pixel()))
                .collect();
            let hi = ns.iter().map(|p| p.1).fold(f64::NAN, f64::max);
            let lo = ns.iter().map(|p| p.1).fold(f64::NAN, f64::min);
            let ratio = hi / lo;
            Check::new(
                scene,
                format!(
                    "time per pixel within 1.5x from {0}² to {1}²",
                    sizes.0, sizes.1
                ),
                Verdict::of(ratio <= 1.5),
                format!("{ratio:.3}x ({lo:.0} to {hi:.0} ns a pixel)"),
            )
        })
        .collect()
}

/// Runs `wfic reproduce scaling`; with `dry_run`, only checks its arguments and resources.
///
/// # Errors
/// Too few threads or too little memory for the largest image, an unknown scene, a file that
/// cannot be written.
pub fn reproduce(a: ScalingArgs, dry_run: bool) -> Result<(), String> {
    let scenes = a
        .scenes
        .unwrap_or_else(|| vec!["cornell".to_owned(), "sponza".to_owned()]);
    let config = if a.quick {
        ScalingConfig::quick(scenes)
    } else {
        ScalingConfig::full(scenes)
    };
    let side = config.largest();
    check_resources(THREADS, Some((side, side)))?;
    if dry_run {
        return Ok(());
    }
    let points_per_scene = config.sizes.len() + config.accuracies.len();
    let progress =
        Progress::new(config.scenes.len() * points_per_scene, a.output.quiet).echo(a.output.quiet);
    let start = std::time::Instant::now();
    let points = progress.run(|p| run(&config, p))?;
    write(&points, &config, &a.output.out_dir, &command_line())?;
    print_checks(&checks(&points, config.goal_sizes));
    println!(
        "wrote {}/scaling.md, scaling.csv, scaling.png, scaling.svg ({:.0} s)",
        a.output.out_dir.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The size sweep of `scene` fitted by least squares as `ns a pixel = floor + records a pixel x
/// cost a record`: the pixels' own work and the records' (their hemisphere rays), apart.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    /// Nanoseconds a pixel with no record to compute.
    pub floor_ns: f64,
    /// Microseconds a record.
    pub record_us: f64,
    /// The fit's coefficient of determination.
    pub r2: f64,
}

/// The [`Split`] of `scene`'s size sweep (at least two sizes), or `None`.
pub fn split(points: &[Point], scene: &str) -> Option<Split> {
    let xy: Vec<(f64, f64)> = (points.iter())
        .filter(|p| p.scene == scene && p.sweep == Sweep::Size)
        .map(|p| (p.records as f64 / p.pixels(), p.ns_per_pixel()))
        .collect();
    let n = xy.len() as f64;
    if xy.len() < 2 {
        return None;
    }
    let (mx, my) = (
        xy.iter().map(|p| p.0).sum::<f64>() / n,
        xy.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = xy.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: f64 = xy.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let syy: f64 = xy.iter().map(|p| (p.1 - my) * (p.1 - my)).sum();
    let slope = sxy / sxx;
    Some(Split {
        floor_ns: my - slope * mx,
        record_us: slope / 1e3,
        r2: sxy * sxy / (sxx * syy),
    })
}

/// Writes `scaling.md`, `scaling.csv` and the figure `scaling.png` / `.svg` into `out_dir`.
///
/// # Errors
/// A file that cannot be written.
pub fn write(
    points: &[Point],
    config: &ScalingConfig,
    out_dir: &Path,
    command: &str,
) -> Result<(), String> {
    let machine = Machine::detect();
    let provenance = Provenance::new(command, &machine, &[THREADS], &[]);
    let out = Output::new(out_dir, &provenance)?;
    let table = Table::new()
        .col("scene", "scene", |p: &&Point| p.scene.clone())
        .left()
        .col("sweep", "sweep", |p| {
            match p.sweep {
                Sweep::Size => "size",
                Sweep::Accuracy => "accuracy",
            }
            .to_owned()
        })
        .left()
        .col("side", "side", |p| p.size.to_string())
        .col("a", "accuracy", |p| p.accuracy.to_string())
        .col("frame s", "seconds", |p| format!("{:.3}", p.seconds))
        .col("ns a pixel", "ns_per_pixel", |p| {
            format!("{:.0}", p.ns_per_pixel())
        })
        .col("records", "records", |p| p.records.to_string())
        .col("records a megapixel", "records_per_mpixel", |p| {
            format!("{:.0}", 1e6 * p.records as f64 / p.pixels())
        })
        .col("lookups a pixel", "lookups_per_pixel", |p| {
            format!("{:.2}", p.lookups as f64 / p.pixels())
        })
        .col("peak resident MiB", "peak_bytes", |p| {
            p.peak_bytes
                .map_or("n/a".to_owned(), |b| format!("{:.1}", b as f64 / 1048576.0))
        });
    let rows: Vec<&Point> = points.iter().collect();
    let mut scenes: Vec<&str> = points.iter().map(|p| p.scene.as_str()).collect();
    scenes.dedup();
    let splits: Vec<(&str, Split)> = (scenes.into_iter())
        .filter_map(|s| split(points, s).map(|f| (s, f)))
        .collect();
    let split_table = Table::new()
        .md("scene", |(s, _): &(&str, Split)| s.to_string())
        .left()
        .md("ns a pixel without records", |(_, f)| {
            format!("{:.0}", f.floor_ns)
        })
        .md("µs a record", |(_, f)| format!("{:.0}", f.record_us))
        .md("R²", |(_, f)| format!("{:.3}", f.r2));
    let body = format!(
        "Each point is one frame on a fresh WF cache at {THREADS} threads (default settings but \
         the one varied); seconds are the median of three renders up to 512 x 512, one render \
         above. How to read it: [docs/experiments.md](../../docs/experiments.md#scaling).\n\n\
         {}\n## Goal\n\n{}\n## Where the time goes\n\nThe size sweep fitted as `ns a pixel = \
         floor + records a pixel x cost a record`: a pixel's own work (its primary ray, direct \
         light and lookup) and its share of the records' hemisphere rays. The records grow with \
         the image only where a radius clamp in pixel footprints decides a record's radius; \
         where Ward's radius or the scene's clamps decide, they do not. So the records a pixel \
         fall as the image grows, and time a pixel falls towards the floor.\n\n{}",
        table.markdown(&rows),
        Check::markdown(&checks(points, config.goal_sizes), true),
        split_table.markdown(&splits)
    );
    out.markdown(
        "scaling.md",
        "How a frame's cost grows with the image and the accuracy",
        &body,
    )?;
    out.csv("scaling.csv", &table.csv_text(&rows))?;
    out.figure("scaling", &figure(points, &machine))
}

/// Colours of the scenes' lines.
const COLOURS: [[u8; 3]; 5] = [
    [200, 60, 40],
    [40, 90, 180],
    [60, 150, 70],
    [150, 80, 160],
    [200, 140, 30],
];

/// Four panels: ns a pixel, records a megapixel and peak MiB a megapixel against the side
/// (log2), and frame seconds against the accuracy.
pub fn figure(points: &[Point], machine: &Machine) -> Figure {
    let mut scenes: Vec<&str> = points.iter().map(|p| p.scene.as_str()).collect();
    scenes.dedup();
    let series = |sweep: Sweep, y: &dyn Fn(&Point) -> Option<f64>| -> Vec<Line> {
        (scenes.iter().enumerate())
            .map(|(i, &scene)| Line {
                label: scene.to_owned(),
                colour: COLOURS[i % COLOURS.len()],
                points: (points.iter())
                    .filter(|p| p.scene == scene && p.sweep == sweep)
                    .filter_map(|p| {
                        let x = match sweep {
                            Sweep::Size => f64::from(p.size).log2(),
                            Sweep::Accuracy => f64::from(p.accuracy),
                        };
                        y(p).map(|y| (x, y))
                    })
                    .collect(),
                markers: true,
            })
            .collect()
    };
    let sides: Vec<u32> = {
        let mut s: Vec<u32> = (points.iter())
            .filter(|p| p.sweep == Sweep::Size)
            .map(|p| p.size)
            .collect();
        s.sort_unstable();
        s.dedup();
        s
    };
    let x_range = (
        f64::from(*sides.first().unwrap_or(&1)).log2(),
        f64::from(*sides.last().unwrap_or(&2)).log2().max(1.0),
    );
    let x_ticks: Vec<(f64, String)> = sides
        .iter()
        .map(|&s| (f64::from(s).log2(), s.to_string()))
        .collect();
    let legend: Vec<(String, [u8; 3])> = (scenes.iter().enumerate())
        .map(|(i, s)| (s.to_string(), COLOURS[i % COLOURS.len()]))
        .collect();
    let by_size = |title: &str, label: &str, y: &dyn Fn(&Point) -> Option<f64>| Panel {
        title: title.into(),
        x_range,
        x_ticks: x_ticks.clone(),
        x_label: "IMAGE SIDE (PIXELS)".into(),
        left_label: label.into(),
        lines: series(Sweep::Size, y),
        legend: legend.clone(),
        ..Panel::default()
    };
    let accuracies: Vec<f64> = (points.iter())
        .filter(|p| p.sweep == Sweep::Accuracy)
        .map(|p| f64::from(p.accuracy))
        .collect();
    let a_range = (
        accuracies
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
            .min(1.0),
        accuracies.iter().copied().fold(0.0, f64::max).max(0.1),
    );
    let mpix = |p: &Point| p.pixels() / 1e6;
    Figure {
        header: vec![
            "wfic reproduce scaling: a frame's cost against the image side and the accuracy".into(),
            format!("{}, {THREADS} threads, WF, one frame a point", machine.cpu),
        ],
        panels: vec![
            by_size("Time a pixel", "NS A PIXEL", &|p| Some(p.ns_per_pixel())),
            by_size("Records a megapixel", "RECORDS / MPIXEL", &|p| {
                Some(p.records as f64 / mpix(p))
            }),
            by_size("Peak resident memory", "MIB", &|p| {
                p.peak_bytes.map(|b| b as f64 / 1048576.0)
            }),
            Panel {
                title: "Frame time against the accuracy".into(),
                x_range: a_range,
                x_label: "ACCURACY a".into(),
                left_label: "FRAME SECONDS".into(),
                lines: series(Sweep::Accuracy, &|p| Some(p.seconds)),
                legend: legend.clone(),
                ..Panel::default()
            },
        ],
        columns: 2,
        panel_size: (640, 420),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(scene: &str, size: u32, seconds: f64) -> Point {
        Point {
            scene: scene.into(),
            sweep: Sweep::Size,
            size,
            accuracy: 0.25,
            seconds,
            records: 100,
            lookups: u64::from(size) * u64::from(size),
            peak_bytes: Some(1 << 20),
        }
    }

    #[test]
    fn the_goal_compares_time_per_pixel_between_the_goal_sizes_only() {
        // ns a pixel: a at 128 6104 (outside the goal's range: 2.1x if it counted), at 512 3815,
        // at 1024 2861 (1.33x); b at 512 3815, at 1024 6676 (1.75x).
        let points = vec![
            point("a", 128, 0.1),
            point("a", 512, 1.0),
            point("a", 1024, 3.0),
            point("b", 512, 1.0),
            point("b", 1024, 7.0),
        ];
        let checks = checks(&points, (512, 1024));
        assert_eq!(checks.len(), 2);
        assert_eq!(checks[0].verdict, Verdict::Yes, "{:?}", checks[0]);
        assert_eq!(checks[1].verdict, Verdict::No, "{:?}", checks[1]);
        assert!(checks[1].detail.starts_with("1.750x"), "{:?}", checks[1]);
    }

    #[test]
    fn the_split_recovers_a_floor_and_a_cost_a_record() {
        // ns a pixel = 4000 + records a pixel x 300 000 (300 µs a record), exactly.
        let points: Vec<Point> = [(128, 2000), (512, 8000), (2048, 40000)]
            .into_iter()
            .map(|(side, records)| {
                let pixels = f64::from(side * side);
                let ns = 4000.0 + records as f64 / pixels * 300_000.0;
                Point {
                    records,
                    ..point("a", side, ns * pixels / 1e9)
                }
            })
            .collect();
        let f = split(&points, "a").unwrap();
        assert!((f.floor_ns - 4000.0).abs() < 1e-6, "{f:?}");
        assert!((f.record_us - 300.0).abs() < 1e-9, "{f:?}");
        assert!((f.r2 - 1.0).abs() < 1e-12, "{f:?}");
        assert_eq!(split(&points[..1], "a"), None);
    }

    #[test]
    fn a_quick_run_renders_every_point_and_writes_its_page() {
        let config = ScalingConfig {
            scenes: vec!["cornell".into()],
            sizes: vec![16, 32],
            accuracies: vec![0.3],
            accuracy_size: 16,
            goal_sizes: (16, 32),
        };
        let points = run(&config, &mut |_| {}).unwrap();
        assert_eq!(points.len(), 3);
        assert!(points
            .iter()
            .all(|p| p.records > 0 && p.lookups > 0 && p.seconds > 0.0));
        let dir = std::env::temp_dir().join(format!("wfic-scaling-{}", std::process::id()));
        write(&points, &config, &dir, "wfic reproduce scaling --test").unwrap();
        let md = std::fs::read_to_string(dir.join("scaling.md")).unwrap();
        assert!(md.contains("| cornell | size | 32 |"), "{md}");
        assert_eq!(
            std::fs::read_to_string(dir.join("scaling.csv"))
                .unwrap()
                .lines()
                .count(),
            4
        );
        assert!(dir.join("scaling.png").is_file() && dir.join("scaling.svg").is_file());
        std::fs::remove_dir_all(&dir).ok();
    }
}
