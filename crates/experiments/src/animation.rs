//! Figures 2 and 3: the 360° camera orbit, the cache kept across frames, per scheme (paper §4.2).
//! Frame 0 starts from an empty cache (the still-image case); later frames mostly interpolate.
//!
//! Schedule: each scheme renders the whole orbit on a fresh cache. Analysis: per-frame times and
//! new samples, and their totals. Report: `animation-SCENE.md`, `.csv`, `.png` and `.svg`.

use crate::harness::table::{star, Table};
use crate::harness::{Machine, Output, Provenance};
use crate::plot::{Figure, Line, Panel};
use std::path::Path;
use wfic::cache::{CacheJob, IrradianceCache, Scheme};
use wfic_render::{scenes, FrameStats, RenderSettings, Scene};

/// Renders the scene's orbit (`frames` frames, the cache kept across them) with `scheme` and a
/// fresh cache, calling `each(frame, &stats)` after every frame.
pub fn orbit_with_scheme(
    scheme: Scheme,
    scene: &Scene,
    settings: &RenderSettings,
    threads: usize,
    frames: usize,
    each: &mut dyn FnMut(usize, &FrameStats),
) -> Result<Vec<FrameStats>, String> {
    struct Orbit<'a> {
        scene: &'a Scene,
        settings: &'a RenderSettings,
        threads: usize,
        frames: usize,
        each: &'a mut dyn FnMut(usize, &FrameStats),
    }
    impl CacheJob for Orbit<'_> {
        type Output = Vec<FrameStats>;
        fn run<C: IrradianceCache>(self, mut cache: C) -> Vec<FrameStats> {
            let each = self.each;
            wfic_render::render_orbit(
                self.scene,
                self.settings,
                &mut cache,
                self.threads,
                self.frames,
                |i, f| each(i, &f.stats),
            )
        }
    }
    let config = settings
        .cache_config(scene)
        .map_err(|e| format!("{}: {e}", scene.name()))?;
    let job = Orbit {
        scene,
        settings,
        threads,
        frames,
        each,
    };
    Ok(scheme.build(config, job))
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
    if config.frames == 0 || config.threads == 0 {
        return Err("--frames and --threads must be at least 1".to_owned());
    }
    let scene = scenes::load(&config.scene)?;
    let mut orbits = Vec::new();
    for &scheme in &config.schemes {
        let threads = config.threads_of(scheme);
        let label = format!("{} {} {threads}t", config.scene, scheme.name());
        progress(&format!("{label} frame 1/{}", config.frames));
        let frames = orbit_with_scheme(
            scheme,
            &scene,
            &config.settings,
            threads,
            config.frames,
            &mut |i, _| {
                if i + 1 < config.frames {
                    progress(&format!("{label} frame {}/{}", i + 2, config.frames));
                }
            },
        )?;
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
    fn threads(&self) -> Vec<usize> {
        self.orbits.iter().map(|o| o.threads).collect()
    }

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
        let rest = |o: &Orbit| -> Vec<FrameStats> { o.frames.iter().skip(1).cloned().collect() };
        let sum = |o: &Orbit, f: fn(&FrameStats) -> f64| o.frames.iter().map(f).sum::<f64>();
        let count = |o: &Orbit, skip, f: fn(&FrameStats) -> u64| {
            o.frames.iter().skip(skip).map(f).sum::<u64>().to_string()
        };
        let t = Table::new()
            .md("scheme", |o: &Orbit| o.scheme.heading().to_owned())
            .left()
            .md("threads", |o| self.machine.count(o.threads))
            .md("frame 0 (s)", |o| {
                format!("{:.3}", o.frames.first().map_or(f64::NAN, |f| f.seconds))
            })
            .md("frames 1.. mean (s)", |o| {
                let rest = rest(o);
                let mean = if rest.is_empty() {
                    f64::NAN
                } else {
                    rest.iter().map(|f| f.seconds).sum::<f64>() / rest.len() as f64
                };
                format!("{mean:.4}")
            })
            .md("total (s)", |o| format!("{:.2}", o.total_seconds()))
            .md("frame 0 samples", |o| {
                o.frames.first().map_or(0, |f| f.ic_samples).to_string()
            })
            .md("frames 1.. samples", |o| count(o, 1, |f| f.ic_samples))
            .md("total samples", |o| o.total_samples().to_string())
            .md("lock wait (s)", |o| {
                format!("{:.3}", sum(o, |f| f.lock_wait_seconds))
            })
            .md("merge (s)", |o| {
                format!("{:.4}", sum(o, |f| f.merge_seconds))
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
        let mut time_lines = Vec::new();
        let mut sample_lines = Vec::new();
        let mut legend = Vec::new();
        let (mut tmax, mut smax) = (0.0f64, 0.0f64);
        let mut first = Vec::new();
        for o in &self.orbits {
            let star = star(self.machine.oversubscribed(o.threads));
            let label = format!("{} {}T{star}", o.scheme.heading(), o.threads);
            legend.push((label.clone(), o.scheme.colour()));
            for f in o.frames.iter().skip(1) {
                tmax = tmax.max(f.seconds);
                smax = smax.max(f.ic_samples as f64);
            }
            if let Some(f0) = o.frames.first() {
                first.push(format!(
                    "{} {:.2}S/{}",
                    o.scheme.heading(),
                    f0.seconds,
                    f0.ic_samples
                ));
            }
            let line = |label, g: fn(&FrameStats) -> f64| Line {
                label,
                colour: o.scheme.colour(),
                points: (o.frames.iter().enumerate())
                    .map(|(i, f)| (i as f64, g(f)))
                    .collect(),
                markers: false,
            };
            time_lines.push(line(label.clone(), |f| f.seconds));
            sample_lines.push(line(label, |f| f.ic_samples as f64));
        }
        let note = if n > 1 {
            Some(format!(
                "FRAME 0 (EMPTY CACHE) CLIPPED: {}",
                first.join(", ")
            ))
        } else {
            None
        };
        let base = Panel {
            x_range: (0.0, (n.max(2) - 1) as f64),
            x_label: "FRAME".into(),
            legend,
            note,
            ..Panel::default()
        };
        let s = &self.config.settings;
        Figure {
            header: vec![
                format!(
                    "ANIMATION: {} ({} FRAMES, 360 DEGREE ORBIT, CACHE REUSED), {}X{}",
                    self.config.scene.to_uppercase(),
                    n,
                    s.width,
                    s.height
                ),
                self.machine.banner(&self.threads()),
            ],
            panels: vec![
                Panel {
                    title: "TIME PER FRAME".into(),
                    left_label: "TIME (S)".into(),
                    left_max: (n > 1).then_some(tmax * 1.1),
                    lines: time_lines,
                    ..base.clone()
                },
                Panel {
                    title: "NEW IC SAMPLES PER FRAME".into(),
                    left_label: "SAMPLES".into(),
                    left_max: (n > 1).then_some(smax * 1.1),
                    lines: sample_lines,
                    ..base
                },
            ],
            columns: 1,
            panel_size: (1200, 480),
        }
    }

    /// Writes `animation-<scene>.csv`, `.md`, `.png` and `.svg` into `dir`, each with the
    /// provenance of `command`.
    pub fn write(&self, dir: &Path, command: &str) -> Result<(), String> {
        let provenance = Provenance::new(command, &self.machine, &self.threads(), &[]);
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
        let stats = orbit_with_scheme(Scheme::Wf, &scene, &settings, 2, 3, &mut |i, s| {
            seen.push((i, s.ic_samples))
        })
        .unwrap();
        assert_eq!(stats.len(), 3);
        assert_eq!(seen.len(), 3);
        assert_eq!(seen[2].0, 2);
        assert!(stats[0].ic_samples > 0);
        // The records of earlier frames are kept: the cache only grows.
        assert!(stats[2].cache_records >= stats[0].cache_records);
        assert!(stats[2].cache_records as u64 >= stats[0].ic_samples);
        // The reference computes every primary hit in every frame and keeps nothing.
        let none =
            orbit_with_scheme(Scheme::None, &scene, &settings, 2, 3, &mut |_, _| {}).unwrap();
        assert!(none.iter().all(|s| s.cache_records == 0 && s.hits == 0));
        assert!(none[2].ic_samples > 2 * stats[2].ic_samples, "{none:?}");
    }
}
