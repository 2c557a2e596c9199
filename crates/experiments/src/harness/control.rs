//! The machine control a speed-up is set against, so that a shortfall the machine causes is told
//! apart from the cache's: two TRA frames rendered at once, each on a thread and a cache of its
//! own, and WF on one thread. See `docs/experiments.md#table-1-and-figure-1`.

use super::check::Verdict;
use super::measure::timed;
use super::stats::{paired_ratio, PairedRatio};
use wfic::cache::{CacheConfig, Scheme};
use wfic_render::{render_with_scheme, Camera, FrameStats, RenderSettings, Scene};

/// The speed-up WF should reach over TRA at two threads, unless what keeps it below is
/// measured to be the machine's, not the cache's.
pub const SPEEDUP_GOAL: f64 = 1.98;

/// Frames (progress steps) a round's controls render: WF on one thread, then the TRA twins.
pub const CONTROL_FRAMES: usize = 2;

/// One scene's controls, rendered every round beside the frames they are set against.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Controls {
    /// Scene name.
    pub scene: String,
    /// WF on one thread, every round.
    pub wf_one: Vec<FrameStats>,
    /// Wall seconds of the two TRA frames rendered at once (start to both done), every round.
    pub tra_twins: Vec<f64>,
}

impl Controls {
    /// Renders one round's controls (`round` of `rounds`, 0-based), telling `progress` before
    /// each frame.
    pub fn render_round(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        settings: &RenderSettings,
        cache_config: CacheConfig,
        (round, rounds): (usize, usize),
        progress: &mut dyn FnMut(&str),
    ) {
        let name = &self.scene;
        progress(&format!(
            "{name} WF 1t (control) round {}/{rounds}",
            round + 1
        ));
        let (frame, _) = render_with_scheme(Scheme::Wf, scene, camera, settings, cache_config, 1);
        self.wf_one.push(frame.stats);
        progress(&format!(
            "{name} 2 x TRA 1t at once (control) round {}/{rounds}",
            round + 1
        ));
        // Two TRA frames at once, each on a thread and a cache of its own.
        let render_tra =
            || render_with_scheme(Scheme::Tra, scene, camera, settings, cache_config, 1);
        let (_, seconds) = timed(|| {
            std::thread::scope(|s| {
                let twins = [0, 1].map(|_| s.spawn(render_tra));
                for t in twins {
                    t.join().expect("a TRA twin frame");
                }
            })
        });
        self.tra_twins.push(seconds);
    }
}

/// One scene's speed-up of WF over TRA at two threads set against its [`Controls`], every ratio
/// taken per round, then its median and interval ([`paired_ratio`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SpeedupAnalysis {
    /// Scene.
    pub scene: String,
    /// `TRA_r / WF_r`: the speed-up.
    pub speedup: PairedRatio,
    /// `2 TRA_r / twins_r`: the speed-up of perfectly divided, unshared work on this machine.
    pub machine: PairedRatio,
    /// `WF1_r / TRA_r`: WF's own cost on one thread, nothing shared.
    pub wf_one: PairedRatio,
    /// Median [`FrameStats::idle_share`] of the WF frames: worker-time not spent shading.
    pub idle: f64,
    /// Median IC samples of WF at 2 threads over TRA's (sharing saves samples: below 1).
    pub samples: f64,
}

impl SpeedupAnalysis {
    /// The analysis from per-round seconds of TRA and WF, the controls, the WF frames' idle
    /// share and their samples over TRA's; `None` when a ratio has no round.
    pub fn new(
        scene: &str,
        (tra, wf): (&[f64], &[f64]),
        controls: &Controls,
        idle: f64,
        samples: f64,
    ) -> Option<Self> {
        let twice: Vec<f64> = tra.iter().map(|t| 2.0 * t).collect();
        let wf_one: Vec<f64> = controls.wf_one.iter().map(|r| r.seconds).collect();
        Some(Self {
            scene: scene.to_owned(),
            speedup: paired_ratio(tra, wf)?,
            machine: paired_ratio(&twice, &controls.tra_twins)?,
            wf_one: paired_ratio(&wf_one, tra)?,
            idle,
            samples,
        })
    }

    /// The speed-up the machine and the frame's idle time leave: `machine × (1 - idle)`.
    pub fn ceiling(&self) -> f64 {
        self.machine.median * (1.0 - self.idle)
    }

    /// [`Verdict::Yes`] at [`SPEEDUP_GOAL`] or above; else [`Verdict::Machine`] when the
    /// speed-up's interval reaches the [`Self::ceiling`], [`Verdict::No`] when not.
    pub fn verdict(&self) -> Verdict {
        if self.speedup.median >= SPEEDUP_GOAL {
            Verdict::Yes
        } else if self.speedup.hi >= self.ceiling() {
            Verdict::Machine
        } else {
            Verdict::No
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn controls(wf_one: &[f64], twins: &[f64]) -> Controls {
        Controls {
            scene: "s".into(),
            wf_one: wf_one
                .iter()
                .map(|&seconds| FrameStats {
                    seconds,
                    ..FrameStats::default()
                })
                .collect(),
            tra_twins: twins.to_vec(),
        }
    }

    #[test]
    fn a_shortfall_the_machine_explains_is_the_machines() {
        let same = |x: f64| vec![x; 9];
        let c = controls(&same(1.0), &same(1.02));
        let a = SpeedupAnalysis::new("s", (&same(1.0), &same(1.0 / 1.945)), &c, 0.01, 0.9).unwrap();
        assert!((a.ceiling() - 2.0 / 1.02 * 0.99).abs() < 1e-12, "{a:?}");
        assert_eq!(a.verdict(), Verdict::Machine);
        let fair = controls(&same(1.0), &same(1.0));
        let a =
            SpeedupAnalysis::new("s", (&same(1.0), &same(1.0 / 1.945)), &fair, 0.01, 0.9).unwrap();
        assert_eq!(a.verdict(), Verdict::No);
        let a = SpeedupAnalysis::new("s", (&same(1.99), &same(1.0)), &fair, 0.0, 0.9).unwrap();
        assert_eq!(a.verdict(), Verdict::Yes);
        assert!(SpeedupAnalysis::new("s", (&[], &[]), &fair, 0.0, 0.9).is_none());
    }

    #[test]
    fn a_round_renders_wf_alone_and_the_twins() {
        let scene = wfic_render::scenes::cornell().unwrap();
        let settings = RenderSettings::new(16, 16)
            .rays_per_record(16)
            .light_samples(1);
        let config = settings.cache_config(&scene).unwrap();
        let mut c = Controls {
            scene: "cornell".into(),
            ..Controls::default()
        };
        let mut labels = Vec::new();
        c.render_round(
            &scene,
            &scene.camera(),
            &settings,
            config,
            (1, 3),
            &mut |l| labels.push(l.to_owned()),
        );
        assert_eq!(labels.len(), CONTROL_FRAMES);
        assert_eq!(labels[0], "cornell WF 1t (control) round 2/3");
        assert_eq!(c.wf_one.len(), 1);
        assert_eq!(
            (c.wf_one[0].scheme.as_str(), c.wf_one[0].threads),
            ("wf", 1)
        );
        assert!(c.tra_twins.len() == 1 && c.tra_twins[0] > 0.0);
    }
}
