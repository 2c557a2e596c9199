//! A frame's statistics: the paper's Table 1 columns and the renderer's own counters, and their
//! JSON form (`wfic render --stats`).

use super::integrator::{RayCounts, SampleCounters};
use super::RenderSettings;
use wfic::cache::FrameReport;

/// What the statistics JSON says about the scene besides its name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneSummary {
    /// Triangles with a non-zero area.
    pub triangles: usize,
    /// `real` or `stand-in` for a built-in scene ([`super::scenes::SceneSource`]), `file` for
    /// an OBJ file the user named.
    pub source: String,
}

impl SceneSummary {
    /// The summary of `scene`: a built-in one's source from [`super::scenes::info`] when
    /// `built_in`, else `file`.
    pub fn of(scene: &super::Scene, built_in: bool) -> Self {
        let source = match super::scenes::info(scene.name()) {
            Some(i) if built_in => i.source.name().to_owned(),
            _ => "file".to_owned(),
        };
        Self {
            triangles: scene.triangle_count(),
            source,
        }
    }
}

/// A frame's statistics (the paper's Table 1 columns and more).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// The scheme (`tra`, `lck`, `lck-rw`, `lw`, `wf`, `wf-discard`, or `none`).
    pub scheme: String,
    /// Worker threads.
    pub threads: usize,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Wall-clock time of the frame, LW's merge included.
    pub seconds: f64,
    /// Irradiance estimates computed (hemisphere samplings): the paper's "IC samples". With the
    /// `none` scheme, one per shaded pixel.
    pub ic_samples: u64,
    /// Cache lookups.
    pub lookups: u64,
    /// Lookups that found a valid record at the cache's accuracy. Under smoothing
    /// ([`crate::RenderSettings::smoothing`]) that accuracy is `k a`, and a pixel whose
    /// lookup found records but none valid at `a` still computes a new record: then `hits +
    /// ic_samples` exceeds `lookups`.
    pub hits: u64,
    /// Hits that used at least one record another worker computed.
    pub shared_hits: u64,
    /// `shared_hits / hits` (0 without hits): the share of successful lookups served by at least
    /// one record another thread computed.
    pub sharing: f64,
    /// LCK: time spent waiting for the lock, summed over workers.
    pub lock_wait_seconds: f64,
    /// LW: time spent merging the local caches at the end of the frame.
    pub merge_seconds: f64,
    /// WF `Discard`: records dropped after a lost compare-and-swap.
    pub discarded: u64,
    /// Records stored.
    pub stored: u64,
    /// Records refused by the cache (bad input; expected 0).
    pub rejected: u64,
    /// Rays traced, by kind.
    pub rays: RayCounts,
    /// Time spent in hemisphere sampling, summed over workers (for rays per second per core).
    pub hemisphere_seconds: f64,
    /// Records removed during the frame (and, for LW, at its merge).
    pub removed: u64,
    /// Records in the cache after the frame.
    pub cache_records: usize,
    /// Each worker's busy time: from its first look at the tile queue to finding it empty
    /// (tiles shaded, nothing else), in worker order.
    pub worker_seconds: Vec<f64>,
}

impl FrameStats {
    /// The statistics of a frame of `scheme` on `threads` workers that took `seconds`: what the
    /// workers counted while shading, what the cache's frame report says, and the records the
    /// cache held afterwards.
    pub fn new(
        scheme: &str,
        threads: usize,
        settings: &RenderSettings,
        seconds: f64,
        counters: &SampleCounters,
        report: &FrameReport,
        cache_records: usize,
    ) -> Self {
        let w = &report.workers;
        Self {
            scheme: scheme.to_owned(),
            threads,
            width: settings.width,
            height: settings.height,
            seconds,
            ic_samples: counters.ic_samples,
            lookups: w.lookups,
            hits: w.hits,
            shared_hits: w.shared_hits,
            sharing: if w.hits > 0 {
                w.shared_hits as f64 / w.hits as f64
            } else {
                0.0
            },
            lock_wait_seconds: w.lock_wait.as_secs_f64(),
            merge_seconds: report.merge.as_secs_f64(),
            discarded: w.discarded,
            stored: w.stored,
            rejected: w.rejected,
            rays: counters.rays,
            hemisphere_seconds: counters.hemisphere.as_secs_f64(),
            removed: w.removed,
            cache_records,
            worker_seconds: Vec::new(),
        }
    }

    /// The share of the frame's worker-time spent not shading: `1 - Σ worker_seconds /
    /// (threads × seconds)`. It holds the tail (a worker that found the queue empty while the
    /// other still shaded its last tile), starting and joining the workers, the cache's frame
    /// close and assembling the image. 0 when no worker time was recorded.
    pub fn idle_share(&self) -> f64 {
        let busy: f64 = self.worker_seconds.iter().sum();
        if self.worker_seconds.is_empty() || self.seconds <= 0.0 {
            return 0.0;
        }
        (1.0 - busy / (self.threads.max(1) as f64 * self.seconds)).max(0.0)
    }

    /// Hemisphere rays per second of one core's sampling time.
    pub fn hemisphere_rays_per_second(&self) -> f64 {
        if self.hemisphere_seconds > 0.0 {
            self.rays.hemisphere as f64 / self.hemisphere_seconds
        } else {
            0.0
        }
    }

    /// The statistics as a pretty-printed JSON object, `scene` first; the ray counts appear as
    /// `primary_rays`, `shadow_rays` and `hemisphere_rays`, with the derived
    /// `hemisphere_rays_per_second`.
    pub fn to_json(&self, scene: &str, source: &SceneSummary) -> String {
        let json = StatsJson {
            scene,
            triangles: source.triangles,
            scene_source: &source.source,
            scheme: &self.scheme,
            threads: self.threads,
            width: self.width,
            height: self.height,
            seconds: self.seconds,
            ic_samples: self.ic_samples,
            lookups: self.lookups,
            hits: self.hits,
            shared_hits: self.shared_hits,
            sharing: self.sharing,
            lock_wait_seconds: self.lock_wait_seconds,
            merge_seconds: self.merge_seconds,
            discarded: self.discarded,
            stored: self.stored,
            rejected: self.rejected,
            cache_records: self.cache_records,
            primary_rays: self.rays.primary,
            shadow_rays: self.rays.shadow,
            hemisphere_rays: self.rays.hemisphere,
            hemisphere_seconds: self.hemisphere_seconds,
            hemisphere_rays_per_second: self.hemisphere_rays_per_second(),
            worker_seconds: &self.worker_seconds,
            idle_share: self.idle_share(),
        };
        let mut out = serde_json::to_string_pretty(&json).expect("statistics serialise");
        out.push('\n');
        out
    }
}

/// The JSON layout of [`FrameStats::to_json`].
#[derive(serde::Serialize)]
struct StatsJson<'a> {
    scene: &'a str,
    triangles: usize,
    scene_source: &'a str,
    scheme: &'a str,
    threads: usize,
    width: u32,
    height: u32,
    seconds: f64,
    ic_samples: u64,
    lookups: u64,
    hits: u64,
    shared_hits: u64,
    sharing: f64,
    lock_wait_seconds: f64,
    merge_seconds: f64,
    discarded: u64,
    stored: u64,
    rejected: u64,
    cache_records: usize,
    primary_rays: u64,
    shadow_rays: u64,
    hemisphere_rays: u64,
    hemisphere_seconds: f64,
    hemisphere_rays_per_second: f64,
    worker_seconds: &'a [f64],
    idle_share: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_json_has_every_key_with_its_value() {
        let stats = FrameStats {
            scheme: "wf".to_owned(),
            threads: 2,
            width: 8,
            height: 4,
            seconds: 0.5,
            ic_samples: 10,
            lookups: 32,
            hits: 22,
            shared_hits: 11,
            sharing: 0.5,
            discarded: 1,
            stored: 9,
            rays: RayCounts {
                primary: 32,
                shadow: 64,
                hemisphere: 1000,
            },
            hemisphere_seconds: 0.25,
            cache_records: 9,
            worker_seconds: vec![0.5, 0.25],
            ..FrameStats::default()
        };
        let summary = SceneSummary {
            triangles: 36,
            source: "stand-in".to_owned(),
        };
        let json: serde_json::Value =
            serde_json::from_str(&stats.to_json("cornell \"box\"", &summary)).unwrap();
        assert_eq!(json["scene"], "cornell \"box\"");
        assert_eq!(json["triangles"], 36);
        assert_eq!(json["scene_source"], "stand-in");
        assert_eq!(json["scheme"], "wf");
        assert_eq!(json["threads"], 2);
        assert_eq!(json["lookups"], 32);
        assert_eq!(json["shared_hits"], 11);
        assert_eq!(json["discarded"], 1);
        assert_eq!(json["cache_records"], 9);
        assert_eq!(json["primary_rays"], 32);
        assert_eq!(json["hemisphere_rays"], 1000);
        assert_eq!(json["hemisphere_rays_per_second"], 4000.0);
        assert_eq!(json["worker_seconds"], serde_json::json!([0.5, 0.25]));
        // 0.75 s of the 2 x 0.5 s worker-time shaded.
        assert_eq!(json["idle_share"], 0.25);
        assert_eq!(json.as_object().unwrap().len(), 26);
    }
}
