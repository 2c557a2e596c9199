//! Removal in every scheme, against a brute-force answer: what a selection takes, what stays, when
//! each scheme's removal becomes visible, and that WF's reclamation leaves exactly the memory of a
//! cache built from the survivors.
#![cfg(not(checker))]

mod common;

use common::{for_each_scheme, w, Rng, SchemeCheck, AXES};
use glam::Vec3;
use wfic::cache::{CacheConfig, CacheHandle, IrradianceCache, Octree, WaitFree};
use wfic::ic::{self, Record, Selection};

fn config() -> CacheConfig {
    CacheConfig::new(Vec3::ZERO, Vec3::splat(10.0), 0.3).unwrap()
}

/// `n` random records (positions in the world, radii 0.1 to 3).
fn records(n: usize, seed: u64) -> Vec<Record> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|i| {
            let p = Vec3::new(
                rng.range(0.0, 10.0),
                rng.range(0.0, 10.0),
                rng.range(0.0, 10.0),
            );
            Record::new(
                p,
                AXES[i % 6],
                Vec3::splat(1.0 + i as f32),
                rng.range(0.1, 3.0),
            )
        })
        .collect()
}

/// One frame in which worker 0 inserts `records`.
fn insert_frame<C: IrradianceCache>(cache: &mut C, records: &[Record]) {
    let frame = cache.frame();
    let mut h = frame.handle_for(w(0));
    for r in records {
        h.insert(*r).expect("valid record");
    }
    drop(h);
    frame.close();
}

/// The ids (worker, seq) of the valid records at `p`, sorted.
fn valid_ids(h: &mut impl CacheHandle, p: Vec3, n: Vec3) -> Vec<(u32, u64)> {
    let mut out = Vec::new();
    h.valid_records(p, n, &mut out);
    assert!(out.iter().all(Record::is_intact), "torn record");
    let mut ids: Vec<_> = out
        .iter()
        .map(|r| (r.id().worker().index(), r.id().seq()))
        .collect();
    ids.sort_unstable();
    ids
}

/// Inserts `records` in frame 0 (worker 0), then in frame 1 one handle removes what `selection`
/// takes and looks everything up again. Checks the count against the brute force answer, and
/// that after the frame closes exactly the unselected records are stored and found.
struct RemovesDuringAFrame {
    records: Vec<Record>,
    selection: Selection,
}

impl SchemeCheck for RemovesDuringAFrame {
    fn check<C: IrradianceCache>(&mut self, mut cache: C) {
        let scheme = cache.scheme().name();
        let a = cache.config().accuracy();
        let frame = cache.frame();
        let mut h = frame.handle_for(w(0));
        let sealed: Vec<Record> = self
            .records
            .iter()
            .map(|r| {
                let id = h.insert(*r).expect("valid record").id();
                r.sealed(id)
            })
            .collect();
        drop(h);
        frame.close();
        // Selected in frame 1 (the frame the removal runs in).
        let want: Vec<&Record> = sealed
            .iter()
            .filter(|r| self.selection.selects(r, a, 1))
            .collect();
        assert!(
            !want.is_empty() && want.len() < sealed.len(),
            "{scheme}: the test needs a selection that takes some records and leaves some"
        );

        let frame = cache.frame();
        let mut h = frame.handle_for(w(1));
        let removed = h.remove(&self.selection);
        let probe = want[0];
        let seen_after = valid_ids(&mut h, probe.position, probe.normal);
        let probe_id = (0, probe.id().seq());
        if scheme == "lw" {
            // LW: the global octree's records go at the merge; this worker removed none of its own.
            assert_eq!(removed, 0, "{scheme}: local records removed");
            assert!(
                seen_after.contains(&probe_id),
                "{scheme}: removed before the merge"
            );
        } else {
            assert_eq!(removed, want.len(), "{scheme}: removed count");
            assert!(
                !seen_after.contains(&probe_id),
                "{scheme}: a removed record is still found"
            );
        }
        drop(h);
        let report = frame.close();
        assert_eq!(
            report.workers.removed,
            want.len() as u64,
            "{scheme}: reported"
        );

        let stats = cache.stats();
        assert_eq!(
            stats.records,
            sealed.len() - want.len(),
            "{scheme}: records left"
        );
        assert_eq!(stats.totals.removed, want.len() as u64, "{scheme}: totals");
        let mut left: Vec<u64> = cache.snapshot().iter().map(|r| r.id().seq()).collect();
        left.sort_unstable();
        let expected: Vec<u64> = sealed
            .iter()
            .filter(|r| !self.selection.selects(r, a, 1))
            .map(|r| r.id().seq())
            .collect();
        assert_eq!(left, expected, "{scheme}: survivors");

        // Every lookup of the next frame finds exactly the valid survivors.
        let frame = cache.frame();
        let mut h = frame.handle_for(w(0));
        for r in sealed.iter().step_by(7) {
            let got: Vec<u64> = valid_ids(&mut h, r.position, r.normal)
                .into_iter()
                .map(|(_, s)| s)
                .collect();
            let want: Vec<u64> = sealed
                .iter()
                .filter(|s| !self.selection.selects(s, a, 1))
                .filter(|s| ic::valid_weight(s, r.position, r.normal, a).is_some())
                .map(|s| s.id().seq())
                .collect();
            assert_eq!(got, want, "{scheme}: valid survivors at {}", r.position);
        }
        drop(h);
        frame.close();
    }
}

#[test]
fn a_box_selection_removes_the_records_whose_influence_meets_it_in_every_scheme() {
    let selection =
        Selection::touching(Vec3::new(2.0, 2.0, 2.0), Vec3::new(5.0, 4.0, 6.0)).unwrap();
    for_each_scheme(
        config(),
        &mut RemovesDuringAFrame {
            records: records(600, 1),
            selection,
        },
    );
}

/// `older_than`: records of frame 0 are one frame old in frame 1, so `older_than(0)` takes them
/// and `older_than(1)` takes none; records inserted in frame 1 itself stay.
struct RemovesByAge;

impl SchemeCheck for RemovesByAge {
    fn check<C: IrradianceCache>(&mut self, mut cache: C) {
        let scheme = cache.scheme().name();
        let all = records(200, 2);
        insert_frame(&mut cache, &all[..100]);
        insert_frame(&mut cache, &all[100..]);
        // Between frames: the next frame is 2; frame 0's records are 2 old, frame 1's 1.
        assert_eq!(cache.remove(&Selection::older_than(1)), 100, "{scheme}");
        assert_eq!(
            cache.remove(&Selection::older_than(1)),
            0,
            "{scheme}: twice"
        );
        let left = cache.snapshot();
        assert_eq!(left.len(), 100, "{scheme}");
        assert!(left.iter().all(|r| r.id().frame() == 1), "{scheme}");
        assert_eq!(cache.stats().records, 100, "{scheme}");
        assert_eq!(cache.remove(&Selection::older_than(0)), 100, "{scheme}");
        assert_eq!(cache.stats().records, 0, "{scheme}");
        // Removals between frames count in the totals; nothing is left, not even a node below
        // the root (reclaimed at once).
        assert_eq!(cache.stats().totals.removed, 200, "{scheme}");
        assert_eq!(
            cache.stats().nodes,
            1,
            "{scheme}: nodes left after removing everything"
        );
    }
}

/// WF's removal between frames reclaims at once: no removed slot outlives the call.
#[test]
fn a_removal_between_frames_reclaims_wf_slots_at_once() {
    let mut cache = WaitFree::adopt(config());
    insert_frame(&mut cache, &records(300, 6));
    assert_eq!(cache.reserved_slots(), 300);
    let removed = cache.remove(&Selection::touching(Vec3::ZERO, Vec3::splat(5.0)).unwrap());
    assert!(removed > 30 && removed < 270, "{removed}");
    assert_eq!(
        cache.reserved_slots(),
        300 - removed,
        "removed slots outlived the removal"
    );
    assert_eq!(cache.stats().records, 300 - removed);
}

#[test]
fn an_age_selection_removes_the_older_frames_in_every_scheme() {
    for_each_scheme(config(), &mut RemovesByAge);
}

/// Two workers of one frame remove overlapping selections: each record is counted by exactly one.
struct OverlappingRemovals;

impl SchemeCheck for OverlappingRemovals {
    fn check<C: IrradianceCache>(&mut self, mut cache: C) {
        let scheme = cache.scheme().name();
        let all = records(400, 3);
        insert_frame(&mut cache, &all);
        let before = cache.snapshot();
        let a = cache.config().accuracy();
        let s1 = Selection::touching(Vec3::splat(1.0), Vec3::splat(6.0)).unwrap();
        let s2 = Selection::touching(Vec3::splat(4.0), Vec3::splat(9.0)).unwrap();
        let either = before
            .iter()
            .filter(|r| s1.selects(r, a, 1) || s2.selects(r, a, 1))
            .count();
        let frame = cache.frame();
        let counts = frame.run(2, |h, worker| {
            h.remove(if worker == w(0) { &s1 } else { &s2 })
        });
        let report = frame.close();
        // LW's handles remove only their own (empty) local records; the merge counts the rest.
        let by_handles = if scheme == "lw" { 0 } else { either };
        assert_eq!(
            counts.iter().sum::<usize>(),
            by_handles,
            "{scheme}: per call"
        );
        assert_eq!(
            report.workers.removed, either as u64,
            "{scheme}: counted once each"
        );
        assert_eq!(cache.stats().records, before.len() - either, "{scheme}");
    }
}

#[test]
fn overlapping_removals_count_each_record_once_in_every_scheme() {
    for_each_scheme(config(), &mut OverlappingRemovals);
}

/// `WFIC_MOVING_FRAMES`: the frames of the moving scenes below (default 1 000; the long run,
/// 10 000, is in docs/verification.md).
fn frames() -> u32 {
    std::env::var("WFIC_MOVING_FRAMES")
        .map_or(1000, |v| v.parse().expect("WFIC_MOVING_FRAMES: a number"))
}

/// A moving scene's cache over 1 000 frames (`WFIC_MOVING_FRAMES`): each frame two workers insert records around a point
/// that moves through the world while one of them removes the records the last frame's region
/// touched and every record older than 4 frames. After every frame WF's lists hold exactly its
/// live records (no removed slot survives the frame's close) and its tree has exactly the nodes
/// of a cache built from the survivors: memory bounded by what is alive, however long it runs.
#[test]
fn a_thousand_frames_of_a_moving_scene_keep_wf_memory_at_what_is_alive() {
    let mut cache = WaitFree::adopt(config());
    let mut rng = Rng::new(4);
    let mut peak = (0, 0);
    let mut removed = 0u64;
    let at = |frame: u32| {
        let t = frame as f32 * 0.05;
        Vec3::new(5.0 + 4.0 * t.cos(), 5.0 + 4.0 * t.sin(), 5.0)
    };
    for frame_no in 0..frames() {
        let centre = at(frame_no);
        let batch: Vec<Record> = (0..40)
            .map(|i| {
                let p = centre
                    + Vec3::new(
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                    );
                Record::new(p, AXES[i % 6], Vec3::ONE, rng.range(0.05, 0.5))
            })
            .collect();
        let last = at(frame_no.saturating_sub(1));
        let swept = Selection::touching(last - 1.0, last + 1.0).unwrap();
        let frame = cache.frame();
        frame.run(2, |h, worker| {
            let (front, back) = batch.split_at(20);
            if worker == w(0) {
                h.remove(&swept);
                h.remove(&Selection::older_than(4));
                for r in front {
                    h.insert(*r).unwrap();
                }
            } else {
                for r in back {
                    h.insert(*r).unwrap();
                }
            }
        });
        removed += frame.close().workers.removed;
        let stats = cache.stats();
        assert_eq!(
            cache.reserved_slots(),
            stats.records,
            "frame {frame_no}: a removed slot outlived the frame"
        );
        let mut fresh = WaitFree::adopt(config());
        let survivors = cache.snapshot();
        let f = fresh.frame();
        let mut h = f.handle_for(w(0));
        for r in &survivors {
            h.insert(*r).unwrap();
        }
        drop(h);
        f.close();
        assert_eq!(
            stats.nodes,
            fresh.stats().nodes,
            "frame {frame_no}: nodes beyond those the survivors need"
        );
        peak = (peak.0.max(stats.records), peak.1.max(stats.nodes));
    }
    // The live set stays small: at most five frames of records. And nothing is lost or counted
    // twice: every record inserted is alive at the end or was removed exactly once.
    assert!(peak.0 <= 5 * 40, "peak records {}", peak.0);
    assert_eq!(
        removed as usize + cache.stats().records,
        frames() as usize * 40
    );
}

/// The same moving scene in every scheme, 1 000 frames (`WFIC_MOVING_FRAMES`): after every frame the cache has exactly
/// the nodes a plain octree built from its survivors has (TRA, LCK and LW prune their arenas when
/// a frame with removals closes), at most five frames of records are alive, and every record
/// inserted is alive at the end or was counted by exactly one removal.
struct MovingScene;

impl SchemeCheck for MovingScene {
    fn check<C: IrradianceCache>(&mut self, mut cache: C) {
        let scheme = cache.scheme().name();
        let mut rng = Rng::new(5);
        let at = |frame: u32| {
            let t = frame as f32 * 0.05;
            Vec3::new(5.0 + 4.0 * t.cos(), 5.0 + 4.0 * t.sin(), 5.0)
        };
        let (mut removed, mut stored, mut peak) = (0, 0, 0);
        for frame_no in 0..frames() {
            let centre = at(frame_no);
            let batch: Vec<Record> = (0..40)
                .map(|i| {
                    let p = centre
                        + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0);
                    Record::new(p, AXES[i % 6], Vec3::ONE, rng.range(0.05, 0.5))
                })
                .collect();
            let last = at(frame_no.saturating_sub(1));
            let swept = Selection::touching(last - 1.0, last + 1.0).unwrap();
            let frame = cache.frame();
            frame.run(2, |h, worker| {
                let (front, back) = batch.split_at(20);
                let mine = if worker == w(0) {
                    h.remove(&swept);
                    h.remove(&Selection::older_than(4));
                    front
                } else {
                    back
                };
                for r in mine {
                    h.insert(*r).unwrap();
                }
            });
            let report = frame.close();
            removed += report.workers.removed;
            stored += report.workers.stored;
            let stats = cache.stats();
            let mut fresh = Octree::new(*cache.config());
            for r in cache.snapshot() {
                fresh.insert(r).unwrap();
            }
            assert_eq!(
                stats.nodes,
                fresh.node_count(),
                "{scheme}, frame {frame_no}: nodes beyond those the survivors need"
            );
            peak = peak.max(stats.records);
        }
        assert!(peak <= 5 * 40, "{scheme}: peak records {peak}");
        // WF-D discards the sample of a lost child race: stored or discarded, never both.
        let discarded = cache.stats().totals.discarded;
        assert_eq!(stored + discarded, u64::from(frames()) * 40, "{scheme}");
        assert_eq!(removed + cache.stats().records as u64, stored, "{scheme}");
    }
}

#[test]
fn a_thousand_frames_of_a_moving_scene_keep_every_scheme_at_what_is_alive() {
    for_each_scheme(config(), &mut MovingScene);
}
