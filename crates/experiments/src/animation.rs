//! Figures 2 and 3: the 360° camera orbit, the cache kept across frames, per scheme (paper §4.2).
//! Frame 0 starts from an empty cache (the still-image case); later frames mostly interpolate.
//!
//! Schedule: each scheme renders the whole orbit on a fresh cache. Analysis: per-frame times and
//! new samples, and their totals. Report: `animation-SCENE.md`, `.csv`, `.png` and `.svg`.

use crate::harness::table::{star, Table};
use crate::harness::{Machine, Output, Provenance};
use crate::plot::{Figure, Line, Panel};
use std::ops::Range;
use std::path::Path;
use wfic::cache::Rgb8;
use wfic::cache::{CacheConfig, CacheJob, CacheStats, IrradianceCache, Scheme};
use wfic::ic::Selection;
use wfic_render::parallel::render_frame_removing;
use wfic_render::{scenes, Camera, FrameResult, FrameStats, RenderSettings, Scene};

/// A frame of a sequence: the scene, its camera, and what to remove from the cache first.
pub(crate) type Shot<'a> = (&'a Scene, Camera, Option<Selection>);

/// Renders `frames` in order on one new cache of `scheme` over `config` (`shot(i)` says what
/// frame `i` is), returning `each(i, frame, cache statistics after it)` for every frame: the
/// schedule of both the orbit and `reproduce dynamic`.
pub(crate) fn render_sequence<'a, T>(
    scheme: Scheme,
    config: CacheConfig,
    (settings, threads): (&RenderSettings, usize),
    frames: Range<usize>,
    shot: impl FnMut(usize) -> Shot<'a>,
    each: impl FnMut(usize, FrameResult, CacheStats) -> T,
) -> Vec<T> {
    struct Sequence<'s, S, E> {
        settings: &'s RenderSettings,
        threads: usize,
        frames: Range<usize>,
        shot: S,
        each: E,
    }
    impl<'a, T, S, E> CacheJob for Sequence<'_, S, E>
    where
        S: FnMut(usize) -> Shot<'a>,
        E: FnMut(usize, FrameResult, CacheStats) -> T,
    {
        type Output = Vec<T>;
        fn run<C: IrradianceCache>(mut self, mut cache: C) -> Vec<T> {
            let mut out = Vec::with_capacity(self.frames.len());
            for i in self.frames.clone() {
                let (scene, camera, removal) = (self.shot)(i);
                let (s, t) = (self.settings, self.threads);
                let frame =
                    render_frame_removing(scene, &camera, s, &mut cache, t, removal.as_ref());
                out.push((self.each)(i, frame, cache.stats()));
            }
            out
        }
    }
    let job = Sequence {
        settings,
        threads,
        frames,
        shot,
        each,
    };
    scheme.build(config, job)
}

/// Renders the scene's orbit (`frames` frames, the cache kept across them) with `scheme` and a
/// fresh cache, calling `before(frame)` before every frame.
pub fn orbit_with_scheme(
    scheme: Scheme,
    scene: &Scene,
    settings: &RenderSettings,
    threads: usize,
    frames: usize,
    before: &mut dyn FnMut(usize),
) -> Result<Vec<FrameStats>, String> {
    let config = settings
        .cache_config(scene)
        .map_err(|e| format!("{}: {e}", scene.name()))?;
    let shot = |i| {
        before(i);
        (scene, Camera::orbit(scene, i as f32 / frames as f32), None)
    };
    let settings = (settings, threads);
    let stats = |_, frame: FrameResult, _| frame.stats;
    Ok(render_sequence(
        scheme,
        config,
        settings,
        0..frames,
        shot,
        stats,
    ))
}

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimationConfig {
    /// Built-in scene name.
    pub scene: String,
    /// Frames over one full turn.
    pub frames: usize,
    /// Threads of the parallel schemes (TRA always runs on one).
    pub threads: usize,
    /// Schemes, in plot order.
    pub schemes: Vec<Scheme>,
    /// Image size and sampling.
    pub settings: RenderSettings,
}

impl AnimationConfig {
    /// Refuses a configuration that cannot run: frames, threads or settings out of their ranges.
    ///
    /// # Errors
    /// The argument at fault, named with its range.
    pub fn validate(&self) -> Result<(), String> {
        let range = |e: wfic_render::limits::OutOfRange| e.for_option();
        wfic_render::limits::FRAMES
            .check(self.frames)
            .map_err(range)?;
        wfic_render::limits::THREADS
            .check(self.threads)
            .map_err(range)?;
        self.settings.validate().map_err(range)?;
        Ok(())
    }

    /// Threads `scheme` runs on ([`crate::harness::threads_of`]).
    pub fn threads_of(&self, scheme: Scheme) -> usize {
        crate::harness::threads_of(scheme, self.threads)
    }

    /// Every scheme's thread count, in plot order.
    pub fn thread_counts(&self) -> Vec<usize> {
        self.schemes.iter().map(|&s| self.threads_of(s)).collect()
    }
}

/// One scheme's orbit.
#[derive(Clone, Debug, PartialEq)]
pub struct Orbit {
    /// Scheme.
    pub scheme: Scheme,
    /// Threads.
    pub threads: usize,
    /// Every frame's statistics.
    pub frames: Vec<FrameStats>,
}

impl Orbit {
    /// Seconds over all frames.
    pub fn total_seconds(&self) -> f64 {
        self.frames.iter().map(|f| f.seconds).sum()
    }

    /// IC samples over all frames.
    pub fn total_samples(&self) -> u64 {
        self.frames.iter().map(|f| f.ic_samples).sum()
    }
}

/// A finished animation run.
#[derive(Clone, Debug)]
pub struct Animation {
    /// What was run.
    pub config: AnimationConfig,
    /// Where.
    pub machine: Machine,
    /// One orbit per scheme.
    pub orbits: Vec<Orbit>,
}

/// Runs the orbit for every scheme; `progress(label)` is called before every frame.
pub fn run(
    config: &AnimationConfig,
    machine: &Machine,
    progress: &mut dyn FnMut(&str),
) -> Result<Animation, String> {
    config.validate()?;
    let scene = scenes::load(&config.scene)?;
    let n = config.frames;
    let mut orbits = Vec::new();
    for &scheme in &config.schemes {
        let threads = config.threads_of(scheme);
        let label = format!("{} {} {threads}t", config.scene, scheme.name());
        let mut before = |i: usize| progress(&format!("{label} frame {}/{n}", i + 1));
        let frames = orbit_with_scheme(scheme, &scene, &config.settings, threads, n, &mut before)?;
        orbits.push(Orbit {
            scheme,
            threads,
            frames,
        });
    }
    Ok(Animation {
        config: config.clone(),
        machine: machine.clone(),
        orbits,
    })
}

impl Animation {
    /// `animation-<scene>.csv`: one row per scheme and frame.
    pub fn csv(&self) -> String {
        let rows: Vec<(&Orbit, usize, &FrameStats)> = self
            .orbits
            .iter()
            .flat_map(|o| o.frames.iter().enumerate().map(move |(i, f)| (o, i, f)))
            .collect();
        type Row<'a> = (&'a Orbit, usize, &'a FrameStats);
        let m = &self.machine;
        Table::new()
            .csv("scene", |_: &Row| self.config.scene.clone())
            .csv("scheme", |r| r.0.scheme.name().to_owned())
            .csv("threads", |r| r.0.threads.to_string())
            .csv("cores", |_| m.cores.to_string())
            .csv("oversubscribed", |r| {
                m.oversubscribed(r.0.threads).to_string()
            })
            .csv("width", |r| r.2.width.to_string())
            .csv("height", |r| r.2.height.to_string())
            .csv("frame", |r| r.1.to_string())
            .csv("seconds", |r| format!("{:.5}", r.2.seconds))
            .csv("ic_samples", |r| r.2.ic_samples.to_string())
            .csv("lookups", |r| r.2.lookups.to_string())
            .csv("hits", |r| r.2.hits.to_string())
            .csv("sharing", |r| format!("{:.4}", r.2.sharing))
            .csv("lock_wait_s", |r| format!("{:.5}", r.2.lock_wait_seconds))
            .csv("merge_s", |r| format!("{:.5}", r.2.merge_seconds))
            .csv("discarded", |r| r.2.discarded.to_string())
            .csv("cache_records", |r| r.2.cache_records.to_string())
            .csv_text(&rows)
    }

    /// `animation-<scene>.md`'s body: totals per scheme.
    pub fn markdown(&self) -> String {
        let s = &self.config.settings;
        let sum = |o: &Orbit, skip, f: fn(&FrameStats) -> f64| {
            o.frames.iter().skip(skip).map(f).sum::<f64>()
        };
        let count = |o: &Orbit, skip, f: fn(&FrameStats) -> u64| {
            o.frames.iter().skip(skip).map(f).sum::<u64>().to_string()
        };
        let first = |o: &Orbit| o.frames.first().cloned();
        let t = Table::new()
            .md("scheme", |o: &Orbit| o.scheme.heading().to_owned())
            .left()
            .md("threads", |o| self.machine.count(o.threads))
            .md("frame 0 (s)", |o| {
                format!("{:.3}", first(o).map_or(f64::NAN, |f| f.seconds))
            })
            .md("frames 1.. mean (s)", |o| {
                let rest = o.frames.len().saturating_sub(1) as f64;
                format!("{:.4}", sum(o, 1, |f| f.seconds) / rest)
            })
            .md("total (s)", |o| format!("{:.2}", o.total_seconds()))
            .md("frame 0 samples", |o| {
                first(o).map_or(0, |f| f.ic_samples).to_string()
            })
            .md("frames 1.. samples", |o| count(o, 1, |f| f.ic_samples))
            .md("total samples", |o| o.total_samples().to_string())
            .md("lock wait (s)", |o| {
                format!("{:.3}", sum(o, 0, |f| f.lock_wait_seconds))
            })
            .md("merge (s)", |o| {
                format!("{:.4}", sum(o, 0, |f| f.merge_seconds))
            })
            .md("discarded", |o| count(o, 0, |f| f.discarded));
        format!(
            "- image {}x{}, accuracy {}, {} rays per record, {} light samples per pixel\n\n{}\n\
             `*`: oversubscribed (more threads than the {} cores).\n",
            s.width,
            s.height,
            s.accuracy,
            s.rays_per_record,
            s.light_samples,
            t.markdown(&self.orbits),
            self.machine.cores
        )
    }

    /// Figures 2–3: time per frame and new IC samples per frame, one line per scheme. The y axes
    /// are scaled to frames 1.. (frame 0, the empty cache, is clipped; its values are in the note).
    pub fn figure(&self) -> Figure {
        let n = self.config.frames;
        let series: Vec<Series> = (self.orbits.iter())
            .map(|o| Series {
                label: format!(
                    "{} {}T{}",
                    o.scheme.heading(),
                    o.threads,
                    star(self.machine.oversubscribed(o.threads))
                ),
                colour: o.scheme.colour(),
                markers: false,
                points: (o.frames.iter().enumerate())
                    .map(|(i, f)| [i as f64, f.seconds, f.ic_samples as f64])
                    .collect(),
            })
            .collect();
        let first: Vec<String> = (self.orbits.iter())
            .filter_map(|o| {
                let f = o.frames.first()?;
                Some(format!(
                    "{} {:.2}S/{}",
                    o.scheme.heading(),
                    f.seconds,
                    f.ic_samples
                ))
            })
            .collect();
        let s = &self.config.settings;
        let title = format!(
            "ANIMATION: {} ({n} FRAMES, 360 DEGREE ORBIT, CACHE REUSED), {}X{}",
            self.config.scene.to_uppercase(),
            s.width,
            s.height
        );
        frame_figure(
            vec![title, self.machine.banner(&self.config.thread_counts())],
            n,
            ["NEW IC SAMPLES PER FRAME", "SAMPLES"],
            series,
            (n > 1).then(|| format!("FRAME 0 (EMPTY CACHE) CLIPPED: {}", first.join(", "))),
        )
    }

    /// Writes `animation-<scene>.csv`, `.md`, `.png` and `.svg` into `dir`, each with the
    /// provenance of `command`.
    pub fn write(&self, dir: &Path, command: &str) -> Result<(), String> {
        let provenance = Provenance::new(command, &self.machine, &self.config.thread_counts(), &[]);
        let out = Output::new(dir, &provenance)?;
        let stem = format!("animation-{}", self.config.scene);
        out.csv(&format!("{stem}.csv"), &self.csv())?;
        let title = format!(
            "Animation: {}, {} frames over one orbit, cache kept across frames",
            self.config.scene, self.config.frames
        );
        out.markdown(&format!("{stem}.md"), &title, &self.markdown())?;
        out.figure(&stem, &self.figure())
    }
}

/// One line of a [`frame_figure`]: a scheme's (and mode's) `[frame, seconds, other]` points.
pub(crate) struct Series {
    pub label: String,
    pub colour: Rgb8,
    pub markers: bool,
    pub points: Vec<[f64; 3]>,
}

/// Two panels over `frames` frames, one line a series: the time per frame above `other`'s
/// `[title, axis label]`. With `clipped` (its note), both axes are scaled to frames 1.. .
pub(crate) fn frame_figure(
    header: Vec<String>,
    frames: usize,
    other: [&str; 2],
    series: Vec<Series>,
    clipped: Option<String>,
) -> Figure {
    let top = |k: usize| {
        let points = series.iter().flat_map(|s| &s.points);
        let max = points
            .filter(|p| p[0] > 0.0)
            .map(|p| p[k])
            .fold(0.0, f64::max);
        clipped.is_some().then_some(max * 1.1)
    };
    let panel = |[title, label]: [&str; 2], k: usize| Panel {
        title: title.into(),
        x_range: (0.0, (frames.max(2) - 1) as f64),
        x_label: "FRAME".into(),
        left_label: label.into(),
        left_max: top(k),
        lines: (series.iter())
            .map(|s| Line {
                label: s.label.clone(),
                colour: s.colour,
                points: s.points.iter().map(|p| (p[0], p[k])).collect(),
                markers: s.markers,
            })
            .collect(),
        legend: series.iter().map(|s| (s.label.clone(), s.colour)).collect(),
        note: clipped.clone(),
        ..Panel::default()
    };
    Figure {
        header,
        panels: vec![panel(["TIME PER FRAME", "TIME (S)"], 1), panel(other, 2)],
        columns: 1,
        panel_size: (1200, 480),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_short_orbit_writes_csv_markdown_and_plot_and_reuses_the_cache() {
        let config = AnimationConfig {
            scene: "cornell".into(),
            frames: 4,
            threads: 3,
            schemes: vec![Scheme::Tra, Scheme::Lw, Scheme::Wf],
            settings: RenderSettings::new(24, 24)
                .rays_per_record(16)
                .light_samples(1),
        };
        let machine = Machine {
            cores: 2,
            cpu: "test".into(),
        };
        let mut calls = 0;
        let a = run(&config, &machine, &mut |_| calls += 1).unwrap();
        assert_eq!(calls, 3 * 4);
        assert_eq!(a.orbits.len(), 3);
        assert_eq!(a.orbits[0].threads, 1);
        assert_eq!(a.orbits[2].threads, 3);
        for o in &a.orbits {
            assert_eq!(o.frames.len(), 4);
            // The cache is kept: records only accumulate.
            let records: Vec<usize> = o.frames.iter().map(|f| f.cache_records).collect();
            assert!(records.windows(2).all(|w| w[0] <= w[1]), "{records:?}");
            assert!(o.frames[0].ic_samples > 0);
        }
        let dir = std::env::temp_dir().join(format!("wfic-anim-{}", std::process::id()));
        a.write(&dir, "wfic reproduce animation (test)").unwrap();
        let csv = std::fs::read_to_string(dir.join("animation-cornell.csv")).unwrap();
        assert_eq!(csv.lines().count(), 1 + 3 * 4);
        assert!(csv.contains("\ncornell,wf,3,2,true,24,24,3,"), "{csv}");
        let md = std::fs::read_to_string(dir.join("animation-cornell.md")).unwrap();
        assert!(md.contains("| WF | 3* |"), "{md}");
        assert!(md.contains("OVERSUBSCRIBED"));
        let png = image::open(dir.join("animation-cornell.png")).unwrap();
        assert_eq!(png.width(), 1200);
        let svg = std::fs::read_to_string(dir.join("animation-cornell.svg")).unwrap();
        assert!(svg.contains("NEW IC SAMPLES PER FRAME"));
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(run(
            &AnimationConfig {
                scene: "nowhere".into(),
                ..config
            },
            &machine,
            &mut |_| {}
        )
        .is_err());
    }

    #[test]
    fn orbit_reuses_the_cache_and_the_reference_keeps_nothing() {
        let scene = wfic_render::scenes::cornell().unwrap();
        let settings = RenderSettings::new(24, 24).rays_per_record(16);
        let mut seen = Vec::new();
        let stats =
            orbit_with_scheme(Scheme::Wf, &scene, &settings, 2, 3, &mut |i| seen.push(i)).unwrap();
        assert_eq!(stats.len(), 3);
        assert_eq!(seen, [0, 1, 2]);
        assert!(stats[0].ic_samples > 0);
        // The records of earlier frames are kept: the cache only grows.
        assert!(stats[2].cache_records >= stats[0].cache_records);
        assert!(stats[2].cache_records as u64 >= stats[0].ic_samples);
        // The reference computes every primary hit in every frame and keeps nothing.
        let none = orbit_with_scheme(Scheme::None, &scene, &settings, 2, 3, &mut |_| {}).unwrap();
        assert!(none.iter().all(|s| s.cache_records == 0 && s.hits == 0));
        assert!(none[2].ic_samples > 2 * stats[2].ic_samples, "{none:?}");
    }
}
