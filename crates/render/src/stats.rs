//! A frame's statistics: the paper's Table 1 columns and the renderer's own counters, and their
//! JSON form (`wfic render --stats`).

use super::integrator::{RayCounts, SampleCounters};
use super::settings::RenderSettings;
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
    pub fn of(scene: &super::scene::Scene, built_in: bool) -> Self {
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

/// A frame's statistics (the paper's Table 1 columns and more), written and read back as the
/// body of a [`StatsJson`].
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
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
    #[serde(flatten)]
    pub rays: RayCounts,
    /// Time spent in hemisphere sampling, summed over workers (for rays per second per core).
    pub hemisphere_seconds: f64,
    /// Records removed during the frame (and, for LW, at its merge).
    pub removed: u64,
    /// Records in the cache after the frame.
    pub cache_records: usize,
    /// Each worker's busy time: from its first look at the tile queue to finding it empty
    /// (tiles shaded, nothing else), in worker order (empty for a deterministic frame, whose
    /// tiles are not tied to workers).
    pub worker_seconds: Vec<f64>,
    /// A deterministic frame's pretrace passes: their seconds (from the frame's start, a removal
    /// before them included), and the records they computed
    /// (part of `ic_samples`). 0 for an ordinary frame.
    #[serde(default)]
    pub pretrace_seconds: f64,
    /// See `pretrace_seconds`.
    #[serde(default)]
    pub pretrace_records: u64,
    /// The image's hash ([`crate::Image::hash`]): equal for bit-identical images.
    #[serde(default)]
    pub frame_hash: String,
    /// For a deterministic frame, the hash of the cache's records after it
    /// ([`crate::deterministic::records_hash`]): ids, positions, normals, irradiances, radii and
    /// gradients, in id order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub records_hash: Option<String>,
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
            pretrace_seconds: 0.0,
            pretrace_records: 0,
            frame_hash: String::new(),
            records_hash: None,
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

    /// The statistics as the JSON file lays them out ([`StatsJson`]), for `scene` described by
    /// `source`.
    pub fn to_stats_json(&self, scene: &str, source: &SceneSummary) -> StatsJson {
        StatsJson {
            scene: scene.to_owned(),
            triangles: source.triangles,
            scene_source: source.source.clone(),
            frame: self.clone(),
            hemisphere_rays_per_second: self.hemisphere_rays_per_second(),
            idle_share: self.idle_share(),
        }
    }

    /// The statistics as a pretty-printed JSON object ([`StatsJson`], `scene` first), as
    /// `wfic render --stats` writes them.
    pub fn to_json(&self, scene: &str, source: &SceneSummary) -> String {
        self.to_stats_json(scene, source).to_json()
    }
}

/// A frame's statistics as `wfic render --stats` writes them and as readers parse them back:
/// the scene, then [`FrameStats`]' own fields (its ray counts as `primary_rays`, `shadow_rays`
/// and `hemisphere_rays`), then the two derived figures.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StatsJson {
    /// The scene's name.
    pub scene: String,
    /// Its triangles ([`SceneSummary::triangles`]).
    pub triangles: usize,
    /// Where it comes from ([`SceneSummary::source`]).
    pub scene_source: String,
    /// The frame's statistics, their fields at the object's top level.
    #[serde(flatten)]
    pub frame: FrameStats,
    /// [`FrameStats::hemisphere_rays_per_second`].
    pub hemisphere_rays_per_second: f64,
    /// [`FrameStats::idle_share`].
    pub idle_share: f64,
}

impl StatsJson {
    /// Pretty-printed JSON, with a final newline.
    pub fn to_json(&self) -> String {
        let mut out = serde_json::to_string_pretty(self).expect("statistics serialise");
        out.push('\n');
        out
    }

    /// Parses what [`StatsJson::to_json`] (or `wfic render --stats`) wrote.
    ///
    /// # Errors
    /// When `text` is not such a JSON object.
    pub fn from_json(text: &str) -> Result<Self, serde_json::Error> {
        serde_json::from_str(text)
    }
}

/// What one rank did in a distributed frame (`wfic render --distributed`).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RankStats {
    /// The rank.
    pub rank: u32,
    /// Its worker threads.
    pub threads: usize,
    /// Tiles it rendered.
    pub tiles: usize,
    /// Irradiance estimates it computed (hemisphere samplings).
    pub ic_samples: u64,
    /// Records it computed and stored in its own cache.
    pub records_computed: u64,
    /// Records it sent (each to every other rank).
    pub records_sent: u64,
    /// Records it received from the other ranks.
    pub records_received: u64,
    /// Received records its cache stored.
    pub records_inserted: u64,
    /// Bytes it sent: its records' payloads, once per other rank.
    pub bytes_sent: u64,
    /// Bytes it received.
    pub bytes_received: u64,
    /// Exchange rounds.
    pub rounds: u64,
    /// Seconds its MPI thread spent in the rounds' two collectives (the state's allgather and
    /// the records' allgatherv), waiting for the slowest rank included.
    pub collective_seconds: f64,
    /// Seconds its MPI thread spent inserting the others' records into its cache.
    pub insert_seconds: f64,
    /// Digest of the records it sent, in order (`distributed::WireRecord::digest`).
    pub sent_digest: u64,
    /// Per rank (by rank; its own entry 0): the digest of the records it received from that
    /// rank, in order.
    pub received_digests: Vec<u64>,
    /// Records in its cache at the end.
    pub cache_records: u64,
    /// Seconds from the start of the frame to the end of its last round.
    pub seconds: f64,
}

/// One frame of a distributed render, as rank 0 reports it.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DistributedFrameStats {
    /// Every rank's statistics, by rank.
    pub ranks: Vec<RankStats>,
    /// Records computed over all ranks (the sum of [`RankStats::records_computed`]).
    pub records_computed: u64,
    /// Records computed where a record of another rank is also valid.
    pub duplicates: u64,
    /// Wall-clock seconds of the frame on rank 0 (agreement check to assembled image).
    pub seconds: f64,
}

impl DistributedFrameStats {
    /// A frame's statistics from its ranks': `records_computed` is their sum.
    pub fn new(ranks: Vec<RankStats>, duplicates: u64, seconds: f64) -> Self {
        Self {
            records_computed: ranks.iter().map(|r| r.records_computed).sum(),
            ranks,
            duplicates,
            seconds,
        }
    }
}

/// The frames of a distributed render as its statistics file holds them: one frame's fields at
/// the top level, several under `frames`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
pub enum DistributedFrames {
    /// Several frames (`--frames N`, N > 1), in order, under `frames`.
    Many {
        /// The frames, in order.
        frames: Vec<DistributedFrameStats>,
    },
    /// One frame, its fields beside the render's.
    One(DistributedFrameStats),
}

impl DistributedFrames {
    /// `frames` as the file lays them out: [`DistributedFrames::One`] for exactly one frame.
    pub fn new(mut frames: Vec<DistributedFrameStats>) -> Self {
        match frames.len() {
            1 => Self::One(frames.pop().expect("one frame")),
            _ => Self::Many { frames },
        }
    }

    /// The frames, in order, however they are laid out.
    pub fn frames(&self) -> &[DistributedFrameStats] {
        match self {
            Self::Many { frames } => frames,
            Self::One(frame) => std::slice::from_ref(frame),
        }
    }
}

/// The statistics of a distributed render (`wfic render --distributed --stats`): the render's
/// scene, size and exchange settings, then its frames' statistics.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DistributedStats {
    /// The scene's name.
    pub scene: String,
    /// Its triangles.
    pub triangles: usize,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// A round starts as soon as a rank's outbox holds this many records.
    pub batch_records: usize,
    /// ... or this long (milliseconds) after the previous round.
    pub batch_ms: u64,
    /// Whether the ranks shared their records.
    pub share: bool,
    /// The frames.
    #[serde(flatten)]
    pub frames: DistributedFrames,
}

impl DistributedStats {
    /// Pretty-printed JSON, with a final newline.
    pub fn to_json(&self) -> String {
        let mut out = serde_json::to_string_pretty(self).expect("statistics serialise");
        out.push('\n');
        out
    }

    /// Parses what [`DistributedStats::to_json`] (or `wfic render --distributed --stats`)
    /// wrote.
    ///
    /// # Errors
    /// When `text` is not such a JSON object.
    pub fn from_json(text: &str) -> Result<Self, serde_json::Error> {
        serde_json::from_str(text)
    }
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
            frame_hash: "00c0ffee00c0ffee".to_owned(),
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
        assert_eq!(json["removed"], 0);
        assert_eq!(json["frame_hash"], "00c0ffee00c0ffee");
        assert_eq!(json["pretrace_records"], 0);
        // An ordinary frame has no record hash: the key is left out.
        assert!(json.get("records_hash").is_none());
        assert_eq!(json.as_object().unwrap().len(), 30);
    }

    fn rank(rank: u32) -> RankStats {
        RankStats {
            rank,
            threads: 2,
            tiles: 7 + rank as usize,
            ic_samples: 300,
            records_computed: 290 + u64::from(rank),
            records_sent: 290,
            records_received: 310,
            records_inserted: 305,
            bytes_sent: 33_640,
            bytes_received: 35_960,
            rounds: 11,
            collective_seconds: 0.125,
            insert_seconds: 0.0625,
            sent_digest: u64::MAX - 3,
            received_digests: vec![0, 16_693_685_070_742_802_857],
            cache_records: 600,
            seconds: 1.5,
        }
    }

    fn distributed(frames: usize) -> DistributedStats {
        DistributedStats {
            scene: "cornell".to_owned(),
            triangles: 32,
            width: 64,
            height: 48,
            batch_records: 256,
            batch_ms: 20,
            share: true,
            frames: DistributedFrames::new(
                (0..frames)
                    .map(|i| DistributedFrameStats::new(vec![rank(0), rank(1)], i as u64, 2.25))
                    .collect(),
            ),
        }
    }

    #[test]
    fn the_frame_json_reads_back_through_its_type() {
        let mut stats = FrameStats {
            scheme: "lw".to_owned(),
            threads: 2,
            width: 8,
            height: 4,
            seconds: 0.5,
            ic_samples: 10,
            lookups: 32,
            hits: 22,
            shared_hits: 11,
            sharing: 0.5,
            lock_wait_seconds: 0.125,
            merge_seconds: 0.25,
            discarded: 1,
            stored: 9,
            rejected: 2,
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
            source: "real".to_owned(),
        };
        let written = stats.to_json("desk", &summary);
        let read = StatsJson::from_json(&written).unwrap();
        assert_eq!(read, stats.to_stats_json("desk", &summary));
        assert_eq!(read.to_json(), written);
        // Every field reaches the file: a change to any shows in what is read back.
        stats.rejected = 3;
        assert_ne!(
            StatsJson::from_json(&stats.to_json("desk", &summary)).unwrap(),
            read
        );
    }

    #[test]
    fn distributed_statistics_read_back_through_their_type() {
        for frames in [1, 3] {
            let stats = distributed(frames);
            let text = stats.to_json();
            let back = DistributedStats::from_json(&text).unwrap();
            assert_eq!(back, stats, "{frames} frame(s)");
            assert_eq!(back.frames.frames().len(), frames);
            assert_eq!(back.to_json(), text);
        }
    }

    #[test]
    fn distributed_statistics_keep_the_file_layout() {
        // One frame: its fields beside the render's.
        let one: serde_json::Value = serde_json::from_str(&distributed(1).to_json()).unwrap();
        let keys = |v: &serde_json::Value| {
            let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
            k.sort();
            k
        };
        let header = [
            "batch_ms",
            "batch_records",
            "height",
            "scene",
            "share",
            "triangles",
            "width",
        ];
        let frame = ["duplicates", "ranks", "records_computed", "seconds"];
        let mut want: Vec<&str> = header.iter().chain(&frame).copied().collect();
        want.sort_unstable();
        assert_eq!(keys(&one), want);
        assert_eq!(one["records_computed"], 581);
        assert_eq!(one["ranks"][1]["sent_digest"], u64::MAX - 3);
        assert_eq!(keys(&one["ranks"][0]).len(), 17);
        // Several: under `frames`.
        let many: serde_json::Value = serde_json::from_str(&distributed(2).to_json()).unwrap();
        let mut want: Vec<&str> = header.iter().copied().chain(["frames"]).collect();
        want.sort_unstable();
        assert_eq!(keys(&many), want);
        assert_eq!(keys(&many["frames"][1]), frame);
        assert_eq!(many["frames"][1]["duplicates"], 1);
    }

    #[test]
    fn a_distributed_statistics_file_of_the_hand_built_layout_parses() {
        // As `wfic render --distributed --stats` wrote it through `serde_json::json!` (keys
        // sorted), one frame of one rank.
        let text = r#"{
  "batch_ms": 20, "batch_records": 256, "duplicates": 0, "height": 64,
  "ranks": [{
      "bytes_received": 0, "bytes_sent": 0, "cache_records": 747,
      "collective_seconds": 0.000196684, "ic_samples": 747, "insert_seconds": 1.731e-6,
      "rank": 0, "received_digests": [0], "records_computed": 747, "records_inserted": 0,
      "records_received": 0, "records_sent": 747, "rounds": 11, "seconds": 0.129152011,
      "sent_digest": 16693685070742802857, "threads": 1, "tiles": 16 }],
  "records_computed": 747, "scene": "cornell", "seconds": 0.130704292, "share": true,
  "triangles": 32, "width": 64 }"#;
        let stats = DistributedStats::from_json(text).unwrap();
        let DistributedFrames::One(frame) = &stats.frames else {
            panic!("one frame: {stats:?}")
        };
        assert_eq!(frame.records_computed, 747);
        assert_eq!(frame.ranks[0].sent_digest, 16_693_685_070_742_802_857);
        assert_eq!(frame.ranks[0].rounds, 11);
        assert_eq!((stats.width, stats.batch_ms, stats.share), (64, 20, true));
    }
}
