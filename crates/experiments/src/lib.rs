//! The paper's experiments as code (DESIGN.md, layer 6): still images with an empty cache at
//! 1/2/4/8 threads per scheme (Table 1, Figure 1, [`table1`]) and the orbit reusing the cache
//! across frames (Figures 2–3, [`animation`]). Results as Markdown, CSV, and plots as PNG and
//! SVG ([`plot`], drawn with plotters and a font compiled in).
//!
//! Every table and plot states the machine's core count and which thread counts are
//! oversubscribed ([`Machine`]): on a 2-core machine, 4 and 8 threads measure time-slicing, not
//! scaling.

#![cfg(not(checker))]

pub mod animation;
pub mod cli;
pub mod render_cli;
pub mod reproduce_cli;
pub mod distributed;
pub mod dynamic;
pub mod paper;
pub mod plot;
pub mod radiance;
pub mod table1;

use wfic::cache::IrradianceCache;
use wfic::cache::{CacheJob, Scheme};
use wfic_render::{FrameStats, RenderSettings, Scene};

/// The machine a run measured: what every table and plot prints at the top.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Machine {
    /// Cores available to this process (`std::thread::available_parallelism`).
    pub cores: usize,
    /// CPU model from `/proc/cpuinfo` (or `unknown CPU`).
    pub cpu: String,
}

impl Machine {
    /// The machine this process runs on.
    pub fn detect() -> Self {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split_once(':'))
                    .map(|(_, v)| v.trim().to_owned())
            })
            .unwrap_or_else(|| "unknown CPU".to_owned());
        Self { cores, cpu }
    }

    /// Whether `threads` workers are more than the cores.
    pub fn oversubscribed(&self, threads: usize) -> bool {
        threads > self.cores
    }

    /// One line naming the cores and the oversubscribed thread counts among `threads`.
    pub fn banner(&self, threads: &[usize]) -> String {
        let mut over: Vec<usize> = threads
            .iter()
            .copied()
            .filter(|&t| self.oversubscribed(t))
            .collect();
        over.sort_unstable();
        over.dedup();
        let list: Vec<String> = over.iter().map(usize::to_string).collect();
        let tail = if list.is_empty() {
            "no thread count is oversubscribed".to_owned()
        } else {
            format!(
                "OVERSUBSCRIBED (time-sliced, not scaling): {} threads",
                list.join(", ")
            )
        };
        format!(
            "machine: {} cores ({}); {tail}",
            self.cores,
            self.cpu.trim()
        )
    }
}

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

/// The median of `values` (the mean of the middle two for an even count); `NaN` when empty.
pub fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| !x.is_nan()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Writes `text` to `path`, naming the path in the error.
pub(crate) fn write_file(path: &std::path::Path, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn banner_names_the_oversubscribed_thread_counts() {
        let m = Machine {
            cores: 2,
            cpu: "Test CPU".into(),
        };
        assert!(!m.oversubscribed(2));
        assert!(m.oversubscribed(4));
        let b = m.banner(&[1, 2, 4, 8, 4]);
        assert!(b.contains("2 cores (Test CPU)"), "{b}");
        assert!(b.contains("OVERSUBSCRIBED"), "{b}");
        assert!(b.ends_with(": 4, 8 threads"), "{b}");
        assert!(m
            .banner(&[1, 2])
            .contains("no thread count is oversubscribed"));
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
