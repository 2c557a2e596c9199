//! Figures 2 and 3: the 360° camera orbit, the cache kept across frames, per scheme (paper §4.2).
//! Frame 0 starts from an empty cache (the still-image case); later frames mostly interpolate.

use super::plot::{Figure, Line, Panel};
use super::{orbit_with_scheme, write_file, Machine};
use wfic::cache::Scheme;
use wfic_render::{scenes, FrameStats, RenderSettings};
use std::fmt::Write as _;
use std::path::Path;

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
    /// Threads `scheme` runs on.
    pub fn threads_of(&self, scheme: Scheme) -> usize {
        if scheme == Scheme::Tra {
            1
        } else {
            self.threads
        }
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
        let mut out = String::from(
            "scene,scheme,threads,cores,oversubscribed,width,height,frame,seconds,ic_samples,lookups,\
             hits,sharing,lock_wait_s,merge_s,discarded,cache_records\n",
        );
        for o in &self.orbits {
            for (i, f) in o.frames.iter().enumerate() {
                let _ = writeln!(
                    out,
                    "{},{},{},{},{},{},{},{i},{:.5},{},{},{},{:.4},{:.5},{:.5},{},{}",
                    self.config.scene,
                    o.scheme.name(),
                    o.threads,
                    self.machine.cores,
                    self.machine.oversubscribed(o.threads),
                    f.width,
                    f.height,
                    f.seconds,
                    f.ic_samples,
                    f.lookups,
                    f.hits,
                    f.sharing,
                    f.lock_wait_seconds,
                    f.merge_seconds,
                    f.discarded,
                    f.cache_records
                );
            }
        }
        out
    }

    /// `animation-<scene>.md`: totals per scheme.
    pub fn markdown(&self, command: &str) -> String {
        let mut md = String::new();
        let s = &self.config.settings;
        let _ = writeln!(
            md,
            "# Animation: {}, {} frames over one orbit, cache kept across frames\n",
            self.config.scene, self.config.frames
        );
        let _ = writeln!(md, "- command: `{command}`");
        let _ = writeln!(md, "- {}", self.machine.banner(&self.threads()));
        let _ = writeln!(
            md,
            "- image {}x{}, accuracy {}, {} rays per record, {} light samples per pixel\n",
            s.width, s.height, s.accuracy, s.rays_per_record, s.light_samples
        );
        let _ = writeln!(
            md,
            "| scheme | threads | frame 0 (s) | frames 1.. mean (s) | total (s) | frame 0 samples | frames 1.. samples | total samples | lock wait (s) | merge (s) | discarded |"
        );
        let _ = writeln!(
            md,
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        );
        for o in &self.orbits {
            let rest = &o.frames[1.min(o.frames.len())..];
            let mean = if rest.is_empty() {
                f64::NAN
            } else {
                rest.iter().map(|f| f.seconds).sum::<f64>() / rest.len() as f64
            };
            let star = if self.machine.oversubscribed(o.threads) {
                "*"
            } else {
                ""
            };
            let _ = writeln!(
                md,
                "| {} | {}{star} | {:.3} | {:.4} | {:.2} | {} | {} | {} | {:.3} | {:.4} | {} |",
                o.scheme.heading(),
                o.threads,
                o.frames.first().map_or(f64::NAN, |f| f.seconds),
                mean,
                o.total_seconds(),
                o.frames.first().map_or(0, |f| f.ic_samples),
                rest.iter().map(|f| f.ic_samples).sum::<u64>(),
                o.total_samples(),
                o.frames.iter().map(|f| f.lock_wait_seconds).sum::<f64>(),
                o.frames.iter().map(|f| f.merge_seconds).sum::<f64>(),
                o.frames.iter().map(|f| f.discarded).sum::<u64>(),
            );
        }
        let _ = writeln!(
            md,
            "\n`*`: oversubscribed (more threads than the {} cores).",
            self.machine.cores
        );
        md
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
            let star = if self.machine.oversubscribed(o.threads) {
                "*"
            } else {
                ""
            };
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
            let pts = |g: &dyn Fn(&FrameStats) -> f64| -> Vec<(f64, f64)> {
                o.frames
                    .iter()
                    .enumerate()
                    .map(|(i, f)| (i as f64, g(f)))
                    .collect()
            };
            time_lines.push(Line {
                label: label.clone(),
                colour: o.scheme.colour(),
                points: pts(&|f| f.seconds),
                markers: false,
            });
            sample_lines.push(Line {
                label,
                colour: o.scheme.colour(),
                points: pts(&|f| f.ic_samples as f64),
                markers: false,
            });
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

    /// Writes `animation-<scene>.csv`, `.md`, `.png` and `.svg` into `dir`.
    pub fn write(&self, dir: &Path, command: &str) -> Result<(), String> {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let stem = format!("animation-{}", self.config.scene);
        write_file(&dir.join(format!("{stem}.csv")), &self.csv())?;
        write_file(&dir.join(format!("{stem}.md")), &self.markdown(command))?;
        let figure = self.figure();
        figure.write_png(&dir.join(format!("{stem}.png")))?;
        figure.write_svg(&dir.join(format!("{stem}.svg")))
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
}
