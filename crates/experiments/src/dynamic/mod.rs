//! `wfic reproduce dynamic`: a scene that moves, and what removal buys (the paper's §5.1
//! future work); the five [`Mode`]s, the schedule and how to read the page are in
//! `docs/experiments.md#dynamic-scenes`.

mod report;

use crate::animation::render_sequence;
use crate::harness::measure::timed;
use crate::harness::metrics::{image_error, surface_mask};
use crate::harness::stats::{self, median_index, std_dev, Middle};
use crate::harness::table::star;
use crate::harness::{Check, Machine, Verdict};
use std::collections::HashMap;
use std::ops::Range;
use wfic::cache::{CacheConfig, CacheStats, Scheme};
use wfic::ic::Selection;
use wfic_render::film::Image;
use wfic_render::scenes::{self, short_block_bounds, CORNELL_SLIDE};
use wfic_render::{FrameResult, RenderSettings, Scene};

/// The only scene this experiment knows.
pub const SCENE: &str = "cornell-moving";

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct DynamicConfig {
    /// Scene name ([`SCENE`]).
    pub scene: String,
    /// Frames over the block's slide (at least 2).
    pub frames: usize,
    /// Threads of the parallel schemes (TRA always runs on one).
    pub threads: usize,
    /// Schemes, in table order.
    pub schemes: Vec<Scheme>,
    /// Image size and sampling.
    pub settings: RenderSettings,
    /// Times the removal mode is rendered per scheme (each frame's time is their median).
    pub passes: usize,
    /// Further tolerances of [`Mode::Removal`]'s selection, as multiples of the accuracy `a`
    /// (the main run's is `a`), each rendered `passes` times with WF (or the last scheme).
    pub sweep: Vec<f32>,
}

impl DynamicConfig {
    /// Threads `scheme` runs on ([`crate::harness::threads_of`]).
    pub fn threads_of(&self, scheme: Scheme) -> usize {
        crate::harness::threads_of(scheme, self.threads)
    }

    /// Every scheme's thread count, in table order.
    pub fn thread_counts(&self) -> Vec<usize> {
        self.schemes.iter().map(|&s| self.threads_of(s)).collect()
    }

    /// Frames rendered in all (references included): the progress bar's length.
    pub fn total_frames(&self) -> usize {
        let renders = 1
            + (Mode::ALL.len() + self.passes.saturating_sub(1)) * self.schemes.len()
            + self.passes * self.sweep.len();
        self.frames * renders
    }

    /// Refuses a configuration that cannot run, naming the argument.
    ///
    /// # Errors
    /// The argument at fault, named.
    pub fn validate(&self) -> Result<(), String> {
        if self.scene != SCENE {
            return Err(format!(
                "reproduce dynamic: unknown scene {:?}; the one moving scene is {SCENE:?}",
                self.scene
            ));
        }
        let range = |e: wfic_render::limits::OutOfRange| {
            format!(
                "reproduce dynamic: {} (removal needs a frame after the first; a tolerance is a \
                 multiple of the accuracy)",
                e.for_option()
            )
        };
        crate::bounds::SLIDE_FRAMES
            .check(self.frames)
            .map_err(range)?;
        wfic_render::limits::THREADS
            .check(self.threads)
            .map_err(range)?;
        crate::bounds::PASSES.check(self.passes).map_err(range)?;
        for &k in &self.sweep {
            crate::bounds::TOLERANCE.check(k).map_err(range)?;
        }
        self.settings.validate().map_err(range)?;
        if self.schemes.is_empty() {
            return Err("reproduce dynamic: --schemes must not be empty".to_owned());
        }
        if self.schemes.contains(&Scheme::None) {
            return Err("reproduce dynamic: `none` keeps no records; it is every frame's reference, always rendered".to_owned());
        }
        Ok(())
    }
}

/// How a scheme's cache lives through the animation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// One cache; the records the block's motion since their frame changed by more than the
    /// accuracy are removed each frame ([`Selection::moving`]).
    Removal,
    /// One cache; the records near the moved block's swept bounds are removed each frame
    /// ([`Selection::near`]).
    RemovalNear,
    /// One cache; the records whose influence sphere meets the swept bounds are removed.
    RemovalLocal,
    /// A new cache every frame.
    Fresh,
    /// One cache, nothing removed.
    Stale,
}

impl Mode {
    /// All five, in table order.
    pub const ALL: [Mode; 5] = [
        Mode::Removal,
        Mode::RemovalNear,
        Mode::RemovalLocal,
        Mode::Fresh,
        Mode::Stale,
    ];

    /// The name tables and the CSV use.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Removal => "removal",
            Mode::RemovalNear => "removal-near",
            Mode::RemovalLocal => "removal-local",
            Mode::Fresh => "fresh",
            Mode::Stale => "stale",
        }
    }
}

/// One frame of one scheme in one mode.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Scheme.
    pub scheme: Scheme,
    /// Mode.
    pub mode: Mode,
    /// Threads.
    pub threads: usize,
    /// Frame number (0 is the first, from an empty cache in every mode).
    pub frame: usize,
    /// Wall-clock seconds (the removal included): the median of the passes.
    pub seconds: f64,
    /// The fastest and the slowest pass.
    pub seconds_range: (f64, f64),
    /// Passes timed.
    pub passes: usize,
    /// Irradiance records computed.
    pub ic_samples: u64,
    /// Records removed in the frame.
    pub removed: u64,
    /// Records alive after the frame.
    pub records: usize,
    /// Octree nodes after the frame.
    pub nodes: usize,
    /// Relative RMSE of luminance against the frame's brute-force image.
    pub error: f64,
}

impl Row {
    /// An estimate of the cache's memory after the frame: 160 bytes a record (its 128-byte body
    /// and its 32-byte key and flag) and 88 a node (WF's node; the arena octrees' are smaller).
    pub fn bytes(&self) -> usize {
        self.records * 160 + self.nodes * 88
    }

    /// Sets the seconds to the median pass of `times` (for two passes, the slower: a time that
    /// was measured), and the range and count of the passes.
    fn take_median(&mut self, times: &[f64]) {
        self.seconds = times[median_index(times, Middle::Upper)];
        self.seconds_range = stats::range(times.iter().copied());
        self.passes = times.len();
    }
}

/// A finished run.
#[derive(Clone, Debug)]
pub struct Dynamic {
    /// What was run.
    pub config: DynamicConfig,
    /// Where.
    pub machine: Machine,
    /// Every frame of every scheme and mode.
    pub rows: Vec<Row>,
    /// Seconds spent on the brute-force references (not part of any row).
    pub reference_seconds: f64,
    /// The margin of [`Mode::RemovalNear`]'s selection (metres), the largest of
    /// [`Mode::Removal`]'s.
    pub margin: f32,
    /// For the strip: WF's (or the last scheme's) frames with removal and stale, and the
    /// references, at a few frames.
    pub strip: Vec<(usize, Image, Image, Image)>,
    /// The scheme of the strip and the sweep.
    pub strip_scheme: Scheme,
    /// The tolerance sweep: each further tolerance of [`Mode::Removal`] with its frames.
    pub sweep: Vec<(f32, Vec<Row>)>,
}

/// The block's place at frame `i` of `frames`, as the animation's `t`.
fn t_of(i: usize, frames: usize) -> f32 {
    i as f32 / (frames - 1) as f32
}

/// What every render of the animation shares: the frames' scenes, references and masks.
struct Frames<'a> {
    scenes: &'a [Scene],
    references: &'a [Image],
    masks: &'a [Vec<bool>],
    settings: &'a RenderSettings,
    cache_config: CacheConfig,
    /// [`Selection::near`]'s margin for [`Mode::RemovalNear`].
    margin: f32,
    /// Threads of the parallel schemes.
    threads: usize,
}

impl Frames<'_> {
    /// What frame `i` removes in `mode` (at `tolerance` in [`Mode::Removal`]), if anything.
    fn selection(&self, mode: Mode, tolerance: f32, i: usize) -> Option<Selection> {
        if i == 0 {
            return None;
        }
        let n = self.scenes.len();
        let (a_lo, a_hi) = short_block_bounds(CORNELL_SLIDE * t_of(i - 1, n));
        let (b_lo, b_hi) = short_block_bounds(CORNELL_SLIDE * t_of(i, n));
        let (lo, hi) = (a_lo.min(b_lo), a_hi.max(b_hi));
        let ok = "the block's bounds are finite and ordered, the margin and step finite";
        let frame = u16::try_from(i).unwrap_or(u16::MAX);
        let step = CORNELL_SLIDE / (n - 1) as f32;
        match mode {
            Mode::Removal => Some(Selection::moving(b_lo, b_hi, step, frame, tolerance).expect(ok)),
            Mode::RemovalNear => Some(Selection::near(lo, hi, self.margin).expect(ok)),
            Mode::RemovalLocal => Some(Selection::touching(lo, hi).expect(ok)),
            Mode::Fresh | Mode::Stale => None,
        }
    }

    /// Renders `span` of the frames on one new cache of `scheme` in `mode` (removing at
    /// `tolerance`), keeping the images of the frames in `keep`.
    fn render(
        &self,
        (scheme, mode, tolerance): (Scheme, Mode, f32),
        span: Range<usize>,
        keep: &[usize],
        progress: &mut dyn FnMut(&str),
    ) -> (Vec<Row>, Vec<Image>) {
        let n = self.scenes.len();
        let threads = crate::harness::threads_of(scheme, self.threads);
        let shot = |i: usize| {
            progress(&format!(
                "{} {} frame {}/{n}",
                scheme.name(),
                mode.name(),
                i + 1
            ));
            let scene = &self.scenes[i];
            (scene, scene.camera(), self.selection(mode, tolerance, i))
        };
        let mut kept = Vec::new();
        let row = |i: usize, out: FrameResult, cache: CacheStats| {
            let error = image_error(&out.image, &self.references[i], &self.masks[i]).rel_rmse;
            if keep.contains(&i) {
                kept.push(out.image);
            }
            Row {
                scheme,
                mode,
                threads,
                frame: i,
                seconds: out.stats.seconds,
                seconds_range: (out.stats.seconds, out.stats.seconds),
                passes: 1,
                ic_samples: out.stats.ic_samples,
                removed: out.stats.removed,
                records: cache.records,
                nodes: cache.nodes,
                error,
            }
        };
        let settings = (self.settings, threads);
        let rows = render_sequence(scheme, self.cache_config, settings, span, shot, row);
        (rows, kept)
    }

    /// The removal mode's frames of `scheme` at `tolerance`, on one new cache.
    fn removal(&self, scheme: Scheme, tolerance: f32, progress: &mut dyn FnMut(&str)) -> Vec<Row> {
        let n = self.scenes.len();
        self.render((scheme, Mode::Removal, tolerance), 0..n, &[], progress)
            .0
    }

    /// The removal mode's further passes, the schemes interleaved so that a slow spell of the
    /// machine falls on all of them: only their times are kept ([`take_medians`]).
    fn more_passes(
        &self,
        config: &DynamicConfig,
        rows: &mut [Row],
        progress: &mut dyn FnMut(&str),
    ) {
        let mut passes = Vec::new();
        for _ in 1..config.passes {
            for &scheme in &config.schemes {
                passes.extend(self.removal(scheme, config.settings.accuracy, progress));
            }
        }
        take_medians(rows, &passes);
    }

    /// The tolerance sweep with `scheme`: each tolerance's passes back to back, the first
    /// pass's frames with their times the median of the passes.
    fn sweep(
        &self,
        config: &DynamicConfig,
        scheme: Scheme,
        progress: &mut dyn FnMut(&str),
    ) -> Vec<(f32, Vec<Row>)> {
        let mut sweep = Vec::with_capacity(config.sweep.len());
        for &k in &config.sweep {
            let tolerance = k * config.settings.accuracy;
            let mut first = self.removal(scheme, tolerance, progress);
            let mut passes = Vec::new();
            for _ in 1..config.passes {
                passes.extend(self.removal(scheme, tolerance, progress));
            }
            take_medians(&mut first, &passes);
            sweep.push((tolerance, first));
        }
        sweep
    }
}

/// Sets each removal row of `rows` to the median of its frame's times, its own and those of
/// `passes` (further passes of the same frames).
fn take_medians(rows: &mut [Row], passes: &[Row]) {
    let removal = |r: &&Row| r.mode == Mode::Removal;
    let mut times: HashMap<(Scheme, usize), Vec<f64>> = HashMap::new();
    for r in rows.iter().filter(removal).chain(passes) {
        times
            .entry((r.scheme, r.frame))
            .or_default()
            .push(r.seconds);
    }
    for r in rows.iter_mut().filter(|r| r.mode == Mode::Removal) {
        r.take_median(&times[&(r.scheme, r.frame)]);
    }
}

/// The margin within which the block, seen face on, fills more than the cache's accuracy of a
/// point's view: `sqrt(A / (pi a))` for the largest face of its bounds.
fn near_margin(accuracy: f32) -> f32 {
    let (lo, hi) = short_block_bounds(glam::Vec3::ZERO);
    let e = hi - lo;
    let face = (e.x * e.y).max(e.y * e.z).max(e.x * e.z);
    (face / (std::f32::consts::PI * accuracy)).sqrt()
}

/// Every frame's brute-force reference (scheme `none`); and their seconds.
fn references(
    scenes: &[Scene],
    config: &DynamicConfig,
    cache_config: CacheConfig,
    progress: &mut dyn FnMut(&str),
) -> (Vec<Image>, f64) {
    let n = scenes.len();
    let shot = |i: usize| {
        progress(&format!("reference frame {}/{n}", i + 1));
        (&scenes[i], scenes[i].camera(), None)
    };
    let settings = (&config.settings, config.threads);
    let image = |_, out: FrameResult, _| out.image;
    timed(|| render_sequence(Scheme::None, cache_config, settings, 0..n, shot, image))
}

/// Runs the experiment; `progress(label)` is called before every frame.
pub fn run(
    config: &DynamicConfig,
    machine: &Machine,
    progress: &mut dyn FnMut(&str),
) -> Result<Dynamic, String> {
    config.validate()?;
    let n = config.frames;
    let scenes: Vec<Scene> = (0..n)
        .map(|i| scenes::cornell_moving(t_of(i, n)).map_err(|e| e.to_string()))
        .collect::<Result<_, _>>()?;
    // The block moves inside the box: one cache configuration (the box's bounds) fits every
    // frame.
    let cache_config = config
        .settings
        .cache_config(&scenes[0])
        .map_err(|e| e.to_string())?;
    let (references, reference_seconds) = references(&scenes, config, cache_config, progress);
    let masks: Vec<Vec<bool>> = scenes
        .iter()
        .map(|s| surface_mask(s, &config.settings, 1))
        .collect();
    let frames = Frames {
        scenes: &scenes,
        references: &references,
        masks: &masks,
        settings: &config.settings,
        cache_config,
        margin: near_margin(config.settings.accuracy),
        threads: config.threads,
    };
    let mut keep: Vec<usize> = (0..4).map(|j| j * (n - 1) / 3).collect();
    keep.dedup();
    let strip_scheme = if config.schemes.contains(&Scheme::Wf) {
        Scheme::Wf
    } else {
        *config.schemes.last().expect("not empty")
    };
    let accuracy = config.settings.accuracy;
    let mut rows = Vec::new();
    let (mut with_removal, mut stale) = (Vec::new(), Vec::new());
    for &scheme in &config.schemes {
        for mode in Mode::ALL {
            // One cache for the whole animation, or (fresh) a new one for every frame.
            let spans: Vec<Range<usize>> = match mode {
                Mode::Fresh => (0..n).map(|i| i..i + 1).collect(),
                _ => std::iter::once(0..n).collect(),
            };
            let mut kept = Vec::new();
            for span in spans {
                let (r, k) = frames.render((scheme, mode, accuracy), span, &keep, &mut *progress);
                rows.extend(r);
                kept.extend(k);
            }
            match mode {
                Mode::Removal if scheme == strip_scheme => with_removal = kept,
                Mode::Stale if scheme == strip_scheme => stale = kept,
                _ => {}
            }
        }
    }
    frames.more_passes(config, &mut rows, progress);
    let sweep = frames.sweep(config, strip_scheme, progress);
    let strip = keep
        .iter()
        .zip(with_removal.into_iter().zip(stale))
        .map(|(&i, (a, c))| (i, a, c, references[i].clone()))
        .collect();
    Ok(Dynamic {
        config: config.clone(),
        machine: machine.clone(),
        rows,
        reference_seconds,
        margin: frames.margin,
        strip,
        strip_scheme,
        sweep,
    })
}

/// Mean of `f` over `rows` after frame 0.
fn mean_after_first<'a>(rows: impl IntoIterator<Item = &'a Row>, f: impl Fn(&Row) -> f64) -> f64 {
    stats::mean(rows.into_iter().filter(|r| r.frame > 0).map(f))
}

impl Dynamic {
    fn rows_of(&self, scheme: Scheme, mode: Mode) -> impl Iterator<Item = &Row> {
        self.rows
            .iter()
            .filter(move |r| r.scheme == scheme && r.mode == mode)
    }

    fn mean(&self, scheme: Scheme, mode: Mode, f: impl Fn(&Row) -> f64) -> f64 {
        mean_after_first(self.rows_of(scheme, mode), f)
    }

    fn star(&self, threads: usize) -> &'static str {
        star(self.machine.oversubscribed(threads))
    }

    /// The main run's removal frames of the sweep's scheme (tolerance `a`) and the sweep's, in
    /// order of tolerance.
    fn sweep_rows(&self) -> Vec<(f32, Vec<&Row>)> {
        let mut out = vec![(
            self.config.settings.accuracy,
            self.rows_of(self.strip_scheme, Mode::Removal).collect(),
        )];
        out.extend(self.sweep.iter().map(|(t, r)| (*t, r.iter().collect())));
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        out
    }

    /// The frames (after the first) another scheme rendered faster than WF with removal.
    fn frames_wf_lost(&self) -> Vec<String> {
        let mut lost = Vec::new();
        for i in 1..self.config.frames {
            let of = |s| self.rows_of(s, Mode::Removal).find(|r| r.frame == i);
            let wf = of(Scheme::Wf).map_or(f64::INFINITY, |r| r.seconds);
            for &s in &self.config.schemes {
                if s == Scheme::Wf || s == Scheme::Tra {
                    continue;
                }
                if let Some(t) = of(s).map(|r| r.seconds).filter(|&t| t < wf) {
                    lost.push(format!(
                        "frame {i}: {} {t:.3} s < WF {wf:.3} s",
                        s.heading()
                    ));
                }
            }
        }
        lost
    }

    /// The checks: removal as accurate as a fresh cache and several times faster, per scheme;
    /// WF the fastest with removal on every frame after the first.
    pub fn checks(&self) -> Vec<Check> {
        let mut out = Vec::new();
        for &scheme in &self.config.schemes {
            let h = scheme.heading();
            let t_a = self.mean(scheme, Mode::Removal, |r| r.seconds);
            let t_b = self.mean(scheme, Mode::Fresh, |r| r.seconds);
            let e_a = self.mean(scheme, Mode::Removal, |r| r.error);
            let e_b = self.mean(scheme, Mode::Fresh, |r| r.error);
            let e_c = self.mean(scheme, Mode::Stale, |r| r.error);
            // "Within noise": the fresh frames' own spread of error, frame to frame.
            let fresh: Vec<f64> = self
                .rows_of(scheme, Mode::Fresh)
                .filter(|r| r.frame > 0)
                .map(|r| r.error)
                .collect();
            let spread = std_dev(&fresh);
            out.push(Check::new(
                "",
                format!(
                    "{h}: removal as accurate as a fresh cache (within the fresh frames' spread)"
                ),
                Verdict::of(e_a <= e_b + spread),
                format!(
                    "mean error {:.2}% against {:.2}% (spread {:.2}%); stale {:.2}%",
                    100.0 * e_a,
                    100.0 * e_b,
                    100.0 * spread,
                    100.0 * e_c
                ),
            ));
            out.push(Check::new(
                "",
                format!(
                    "{h}: removal several (>= 3) times faster than a fresh cache after frame 0"
                ),
                Verdict::of(t_b >= 3.0 * t_a),
                format!("{t_a:.3} s against {t_b:.3} s a frame: {:.2}x", t_b / t_a),
            ));
        }
        // WF fastest with removal on every frame after the first, among the schemes at the
        // configured thread count (TRA runs on one).
        if self.config.schemes.contains(&Scheme::Wf) {
            let lost = self.frames_wf_lost();
            out.push(Check::new(
                "",
                format!(
                    "WF the fastest scheme with removal at {} threads{} on every frame after the first",
                    self.config.threads,
                    self.star(self.config.threads)
                ),
                Verdict::of(lost.is_empty()),
                if lost.is_empty() {
                    "no frame where another scheme was faster".to_owned()
                } else {
                    format!("{} frames lost: {}", lost.len(), lost.join("; "))
                },
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny() -> DynamicConfig {
        DynamicConfig {
            scene: SCENE.into(),
            frames: 3,
            threads: 2,
            schemes: vec![Scheme::Lw, Scheme::Wf],
            settings: RenderSettings::new(24, 24)
                .rays_per_record(32)
                .light_samples(1)
                .quiet(true),
            passes: 2,
            sweep: vec![4.0],
        }
    }

    #[test]
    fn a_short_run_removes_reuses_and_writes_every_output() {
        let machine = Machine {
            cores: 2,
            cpu: "test".into(),
        };
        let mut calls = 0;
        let d = run(&tiny(), &machine, &mut |_| calls += 1).unwrap();
        // 3 references, then 2 schemes x 5 modes x 3 frames, the removal mode's second pass,
        // and the sweep's one tolerance twice (WF).
        assert_eq!(calls, 3 + 30 + 6 + 6);
        assert_eq!(d.rows.len(), 30);
        let of = |s: Scheme, m: Mode, i: usize| {
            d.rows
                .iter()
                .find(|r| r.scheme == s && r.mode == m && r.frame == i)
                .unwrap()
                .clone()
        };
        for s in [Scheme::Lw, Scheme::Wf] {
            // Frame 0 is the same empty-cache frame in every mode.
            assert!(of(s, Mode::Fresh, 0).ic_samples > 0);
            // Removal takes records in later frames; stale never does.
            assert!(of(s, Mode::Removal, 1).removed > 0, "{s}");
            assert!(of(s, Mode::RemovalNear, 1).removed > 0, "{s}");
            // The removal mode's time is the median of its two passes (the slower, at two),
            // within their range; the other modes ran once.
            let r = of(s, Mode::Removal, 1);
            assert_eq!(r.passes, 2);
            assert!(
                r.seconds_range.0 <= r.seconds && r.seconds == r.seconds_range.1,
                "{r:?}"
            );
            assert_eq!(of(s, Mode::Fresh, 1).passes, 1);
            assert_eq!(of(s, Mode::Stale, 2).removed, 0);
            // A fresh cache recomputes about as much every frame; reuse computes less.
            assert!(
                of(s, Mode::Fresh, 2).ic_samples > of(s, Mode::Stale, 2).ic_samples,
                "{s}"
            );
            assert!(
                of(s, Mode::Removal, 2).ic_samples < of(s, Mode::Fresh, 2).ic_samples,
                "{s}"
            );
            // A fresh cache holds exactly the frame's own records.
            let f = of(s, Mode::Fresh, 2);
            assert_eq!(f.records as u64, f.ic_samples, "{s}");
            for m in Mode::ALL {
                let e = of(s, m, 2).error;
                assert!(e.is_finite() && e > 0.0 && e < 1.0, "{s} {m:?}: {e}");
            }
        }
        assert_eq!(d.strip.len(), 3);
        // The sweep: a looser tolerance (4a) removes no more than the main run's a over the run
        // (its margins are smaller, its swept boxes the same; a few records of slack for the
        // workers' different interleavings).
        assert_eq!(d.strip_scheme, Scheme::Wf);
        let (t, loose) = &d.sweep[0];
        assert_eq!(*t, 4.0 * d.config.settings.accuracy);
        assert_eq!(loose.len(), 3);
        assert!(loose
            .iter()
            .all(|r| r.passes == 2 && r.mode == Mode::Removal));
        assert!(
            loose.iter().map(|r| r.removed).sum::<u64>()
                <= d.rows_of(Scheme::Wf, Mode::Removal)
                    .map(|r| r.removed)
                    .sum::<u64>()
                    + 8,
            "{loose:?}"
        );
        let dir = std::env::temp_dir().join(format!("wfic-dynamic-{}", std::process::id()));
        d.write(&dir, "wfic reproduce dynamic (test)").unwrap();
        let csv = std::fs::read_to_string(dir.join("dynamic.csv")).unwrap();
        assert_eq!(csv.lines().count(), 1 + 30);
        assert!(
            csv.contains("\ncornell-moving,wf,removal,2,2,false,24,24,1,"),
            "{csv}"
        );
        let md = std::fs::read_to_string(dir.join("dynamic.md")).unwrap();
        assert!(md.contains("| WF | 2 | removal |"), "{md}");
        assert!(md.contains("WF the fastest scheme with removal"), "{md}");
        assert!(md.contains("## Removal's tolerance (WF"), "{md}");
        assert!(md.contains("| 1.000 (4a) |"), "{md}");
        let sweep = std::fs::read_to_string(dir.join("dynamic-sweep.csv")).unwrap();
        assert_eq!(sweep.lines().count(), 1 + 6, "{sweep}");
        let strip = image::open(dir.join("dynamic-strip.png")).unwrap();
        assert_eq!(
            (strip.width(), strip.height()),
            (3 * 24 + 2 * 4, 3 * 24 + 2 * 4)
        );
        assert_eq!(image::open(dir.join("dynamic.png")).unwrap().width(), 1200);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_arguments_are_refused_by_name() {
        let machine = Machine {
            cores: 2,
            cpu: "test".into(),
        };
        let refused = |config: DynamicConfig, says: &str| {
            let e = run(&config, &machine, &mut |_| {}).unwrap_err();
            assert!(e.contains(says), "{e}");
        };
        refused(
            DynamicConfig {
                scene: "cornell".into(),
                ..tiny()
            },
            "cornell-moving",
        );
        refused(
            DynamicConfig {
                frames: 1,
                ..tiny()
            },
            "--frames 1",
        );
        refused(
            DynamicConfig {
                schemes: vec![Scheme::None],
                ..tiny()
            },
            "none",
        );
        refused(
            DynamicConfig {
                passes: 0,
                ..tiny()
            },
            "--passes 0",
        );
        refused(
            DynamicConfig {
                sweep: vec![2.0, -1.0],
                ..tiny()
            },
            "--sweep -1",
        );
    }
}
