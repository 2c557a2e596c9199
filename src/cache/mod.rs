//! The shared irradiance caches: one trait, four access schemes (paper §3).
//!
//! | scheme | type | paper |
//! |---|---|---|
//! | TRA | [`Sequential`] | Listing 3 |
//! | LCK | [`Locked`] (`Mutex` or `RwLock`) | Listing 4 |
//! | LW  | [`LocalWrite`] | Listing 5 |
//! | WF  | [`WaitFree`] (`Adopt` or `Discard`) | Listing 6, with the two fixes of `docs/design.md` |
//!
//! plus [`NoCache`], the no-cache reference, behind the same trait.
//!
//! A cache is used in frames ([`frame`]): a [`Frame`] hands each worker a [`CacheHandle`] with a
//! distinct worker id; the handle carries the worker's own state (counters, LW's local cache) so
//! nothing on the hot path writes shared memory but the cache itself, and leaves that state in the
//! cache when it is dropped. Closing the frame takes `&mut` access: LW merges there, and the
//! borrow checker rules out a handle that outlives the frame. [`Scheme`] lists the schemes.

pub mod deterministic;
pub mod frame;
mod local_write;
mod locked;
mod none;
pub(crate) mod octree;
mod scheme;
mod sequential;
pub mod wf;

pub use deterministic::{TileHandle, Visibility};
#[cfg(not(checker))]
pub use frame::run_frame;
pub use frame::Frame;
pub use local_write::{LocalWrite, LwHandle};
pub use locked::{LckHandle, LockFlavour, Locked, MutexFlavour, RwLockFlavour};
pub use none::{NoCache, NoCacheHandle};
pub use octree::Cell;
pub use scheme::{CacheJob, Rgb8, Scheme};
pub use sequential::{Octree, SeqHandle, Sequential};
pub use wf::{CasFailure, WaitFree, WfHandle};

use crate::ic::{self, InsertError, Interpolated, Record, RecordId, Selection, WorkerId};
use glam::Vec3;
use octree::Geometry;
use std::fmt;
use std::ops::AddAssign;
use std::time::Duration;

/// Where a cache lives and how accurate it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheConfig {
    geometry: Geometry,
}

/// Why a [`CacheConfig`] was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigError {
    /// The accuracy is not in `(0, MAX_ACCURACY]` ([`CacheConfig::MAX_ACCURACY`]).
    Accuracy(f32),
    /// A renderer's smoothing (the factor its lookups widen the accuracy by: the renderer's
    /// `RenderSettings::smoothing`) is below 1 or not finite.
    Smoothing(f32),
    /// The bounds are empty, inverted or not finite.
    Bounds {
        /// Lower corner given.
        min: Vec3,
        /// Upper corner given.
        max: Vec3,
    },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Accuracy(a) => write!(
                f,
                "accuracy {a} is not in (0, {}]",
                CacheConfig::MAX_ACCURACY
            ),
            Self::Smoothing(k) => write!(
                f,
                "smoothing {k} is not a finite number of at least 1 (lookups interpolate at \
                 smoothing x accuracy, never below the accuracy records are placed at)"
            ),
            Self::Bounds { min, max } => {
                write!(f, "cache bounds {min}..{max} are empty or not finite")
            }
        }
    }
}

impl std::error::Error for ConfigError {}

impl CacheConfig {
    /// The largest accuracy a cache takes. Ward's error estimate is `d / R + sqrt(1 - n . n_i)`,
    /// a record valid where it is below `a`; at `a = 2` a record already serves points up to
    /// twice its radius away, and points of any normal (the square root is at most `sqrt 2`).
    /// Renderers use 0.1 to 0.5.
    pub const MAX_ACCURACY: f32 = 2.0;

    /// A cache covering the box `min..max` (the root is the smallest cube around it, enlarged by
    /// 1%), answering at accuracy `a` (Ward's `a`, typically 0.1 to 0.5).
    ///
    /// # Errors
    /// [`ConfigError::Accuracy`] unless `0 < accuracy <= MAX_ACCURACY` (NaN included);
    /// [`ConfigError::Bounds`] if a corner is not finite or the box is empty or inverted.
    pub fn new(min: Vec3, max: Vec3, accuracy: f32) -> Result<Self, ConfigError> {
        if !(accuracy > 0.0 && accuracy <= Self::MAX_ACCURACY) {
            return Err(ConfigError::Accuracy(accuracy));
        }
        let size = max - min;
        if !min.is_finite()
            || !max.is_finite()
            || size.min_element() < 0.0
            || size.max_element() <= 0.0
        {
            return Err(ConfigError::Bounds { min, max });
        }
        let root = Cell {
            center: (min + max) * 0.5,
            half: size.max_element() * 0.5 * 1.01,
        };
        Ok(Self {
            geometry: Geometry::new(root, accuracy),
        })
    }

    /// Ward's accuracy `a`.
    pub fn accuracy(&self) -> f32 {
        self.geometry.accuracy
    }

    /// The root cube.
    pub fn root(&self) -> Cell {
        self.geometry.root
    }

    /// The loose-octree geometry every scheme places records and prunes queries with (public so
    /// that tests can work out a tree's shape from its records without the caches' traversals).
    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// Validates `record` for this cache: its fields, and its position inside the root cube.
    pub fn check(&self, record: &Record) -> Result<(), InsertError> {
        record.validate()?;
        let root = self.geometry.root;
        if !root.contains(record.position) {
            return Err(InsertError::OutOfBounds {
                position: record.position,
                center: root.center,
                half_size: root.half,
            });
        }
        Ok(())
    }

    /// The depth at which `record` is stored.
    pub(crate) fn depth_of(&self, record: &Record) -> u32 {
        self.geometry
            .placement_depth(ic::influence_radius(record, self.geometry.accuracy))
    }
}

/// What became of an accepted record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Inserted {
    /// Stored: later lookups (by any worker, or by this worker only for LW until the frame ends) see it.
    Stored(RecordId),
    /// Not stored: the WF `Discard` policy lost a race to create a child node (paper §3.3). The
    /// caller still uses the sample for the pixel it computed it for.
    Discarded(RecordId),
    /// Not stored because the backend keeps nothing ([`NoCache`], the reference).
    NotCached(RecordId),
}

impl Inserted {
    /// The id the record was given.
    pub fn id(self) -> RecordId {
        match self {
            Self::Stored(id) | Self::Discarded(id) | Self::NotCached(id) => id,
        }
    }
}

/// Counters a worker keeps in its handle (never shared while the frame runs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WorkerStats {
    /// Lookups asked.
    pub lookups: u64,
    /// Lookups that found at least one valid record.
    pub hits: u64,
    /// Hits served by at least one record another worker computed.
    pub shared_hits: u64,
    /// Records offered (valid ones).
    pub inserts: u64,
    /// Records refused for bad input.
    pub rejected: u64,
    /// Records stored.
    pub stored: u64,
    /// Records dropped by WF `Discard`.
    pub discarded: u64,
    /// WF: compare-and-swaps on a child pointer that lost the race.
    pub cas_failures: u64,
    /// Records this handle removed ([`CacheHandle::remove`]; for LW, only its own local ones:
    /// the global ones are counted at the merge, in [`FrameReport::workers`]).
    pub removed: u64,
    /// LCK: time spent waiting to acquire the lock.
    pub lock_wait: Duration,
    /// Most tree levels plus compare-and-swap attempts one insert took (WF's step bound).
    pub max_insert_steps: u32,
    /// Most nodes one lookup visited. Lookups and [`CacheHandle::valid_records`] calls are
    /// traversals alike and both count here (and in the three counters below); only lookups count
    /// in `lookups` and `hits`.
    pub max_lookup_nodes: u32,
    /// Most records one lookup examined: every record read from the lists of the nodes it
    /// visited, valid for the query or not (for WF, every slot whose ready flag it loaded: a
    /// slot another worker has reserved but not yet written counts too).
    pub max_lookup_records: u32,
    /// Nodes visited by every lookup and `valid_records` call, summed. One traversal's count is
    /// the difference across it.
    pub lookup_nodes: u64,
    /// Records examined by every lookup and `valid_records` call, summed.
    pub lookup_records: u64,
    /// Nodes visited by every removal ([`CacheHandle::remove`], [`IrradianceCache::remove`] and
    /// LW's merge), summed, counted as lookups' are: one removal's count is the difference across
    /// it. A removal visits the root and each node whose loose cell its selection may reach.
    pub removal_nodes: u64,
    /// Records examined by every removal, summed: every slot whose state it read in the nodes it
    /// visited, selected or not (for WF, a slot reserved but not yet written counts too).
    pub removal_records: u64,
}

impl AddAssign<&WorkerStats> for WorkerStats {
    fn add_assign(&mut self, o: &WorkerStats) {
        self.lookups += o.lookups;
        self.hits += o.hits;
        self.shared_hits += o.shared_hits;
        self.inserts += o.inserts;
        self.rejected += o.rejected;
        self.stored += o.stored;
        self.discarded += o.discarded;
        self.cas_failures += o.cas_failures;
        self.removed += o.removed;
        self.lock_wait += o.lock_wait;
        self.max_insert_steps = self.max_insert_steps.max(o.max_insert_steps);
        self.max_lookup_nodes = self.max_lookup_nodes.max(o.max_lookup_nodes);
        self.max_lookup_records = self.max_lookup_records.max(o.max_lookup_records);
        self.lookup_nodes += o.lookup_nodes;
        self.lookup_records += o.lookup_records;
        self.removal_nodes += o.removal_nodes;
        self.removal_records += o.removal_records;
    }
}

impl WorkerStats {
    /// Counts one removal: the records it took and its work.
    pub(crate) fn count_removal(&mut self, removed: usize, work: frame::Work) -> usize {
        self.removed += removed as u64;
        self.removal_nodes += u64::from(work.nodes);
        self.removal_records += u64::from(work.records);
        removed
    }
}

/// What closing a frame did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameReport {
    /// The frame's workers' counters, summed.
    pub workers: WorkerStats,
    /// LW: time spent merging the local caches into the global one.
    pub merge: Duration,
}

/// A cache's contents and history, read when no frame is running.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CacheStats {
    /// Records stored.
    pub records: usize,
    /// Octree nodes.
    pub nodes: usize,
    /// Counters of every finished handle, summed over all frames.
    pub totals: WorkerStats,
    /// LW: total merge time over all frames.
    pub merge: Duration,
    /// Frames closed.
    pub frames: u64,
}

/// A shared irradiance cache.
///
/// `Sync`: workers share it by reference during a frame. Everything a worker changes for itself
/// lives in its [`CacheHandle`]. Use it through [`IrradianceCache::frame`] (or [`run_frame`]);
/// [`IrradianceCache::handle`] and [`IrradianceCache::end_frame`] are the low-level protocol
/// underneath, for the model checkers and for benchmarks whose threads outlive a frame.
pub trait IrradianceCache: Send + Sync {
    /// A worker's handle, borrowing the cache for the frame.
    type Handle<'c>: CacheHandle
    where
        Self: 'c;

    /// Which scheme this cache is ([`Scheme::name`] spells it as the command line does).
    fn scheme(&self) -> Scheme;

    /// The cache's configuration.
    fn config(&self) -> &CacheConfig;

    /// Opens a frame: the entry point for everything that uses the cache.
    fn frame(&mut self) -> Frame<'_, Self>
    where
        Self: Sized,
    {
        Frame::new(self)
    }

    /// Low-level (model checkers, persistent-worker benchmarks; others use [`Frame`]): a handle
    /// for `worker` in the open frame. Record ids are made of the worker number, the frame number
    /// and a count per handle, so each worker number gets one handle per frame. The handle leaves
    /// its counters (and LW's local records) in the cache when it is dropped.
    ///
    /// # Panics
    /// If `worker` already has a handle in the open frame.
    fn handle(&self, worker: WorkerId) -> Self::Handle<'_>;

    /// Low-level (see [`IrradianceCache::handle`]; [`Frame`] calls it when it closes): closes the
    /// open frame with what its handles left: sums their counters and, for LW, merges the local
    /// caches into the global one (timed). No handle can be alive: this takes `&mut self`.
    ///
    /// # Panics
    /// If a handle of the frame was leaked (`mem::forget`): its records would be lost.
    fn end_frame(&mut self) -> FrameReport;

    /// Removes, between frames, every record `selection` takes out (ages counted from the next
    /// frame, [`Selection::older_than`]) and reclaims their memory; returns how many.
    fn remove(&mut self, selection: &Selection) -> usize;

    /// Every stored record (any order).
    fn snapshot(&mut self) -> Vec<Record>;

    /// Contents and counters.
    fn stats(&mut self) -> CacheStats;
}

/// A worker's access to a cache during a frame. Dropping it leaves its counters (and LW's local
/// records) in the cache for the frame's close.
pub trait CacheHandle {
    /// The worker this handle belongs to.
    fn worker(&self) -> WorkerId;

    /// The number of the frame this handle belongs to (the frames the cache closed before it):
    /// the frame its records' ids carry, modulo 2^16 ([`RecordId::frame`]).
    fn frame(&self) -> u64;

    /// Interpolated irradiance at `point` with unit `normal`, or `None` when no record is valid
    /// there (or the query is not finite).
    fn lookup(&mut self, point: Vec3, normal: Vec3) -> Option<Interpolated>;

    /// [`Self::lookup`] over only the records `visible` admits, summed in record-id order: the
    /// answer depends on which admitted records the cache holds, never on the order it holds
    /// them in (the lookup of a deterministic frame, [`deterministic`]). Counted as a lookup.
    fn lookup_visible(
        &mut self,
        point: Vec3,
        normal: Vec3,
        visible: Visibility,
    ) -> Option<Interpolated>;

    /// Stores `record` (its id and check field are assigned here). Bad input is refused with a
    /// typed error and changes nothing.
    fn insert(&mut self, record: Record) -> Result<Inserted, InsertError>;

    /// Removes, during the frame, every record `selection` takes out (ages counted from this
    /// handle's frame); returns how many this call removed. What "every" means differs by scheme:
    ///
    /// * TRA, LCK: every record stored when the call takes the octree (TRA's handle holds it; LCK
    ///   takes the write lock), so every later lookup misses them.
    /// * LW: this worker's own local records at once; the global octree's at the merge
    ///   ([`IrradianceCache::end_frame`], before the frame's local records join it), so until
    ///   then every worker's lookups still use them. Returns the local count.
    /// * WF: every record whose insert happens-before the call, concurrently with the other
    ///   workers' lookups and inserts and wait-free (one compare-and-swap per selected record,
    ///   never retried); a record inserted concurrently may stay. A lookup that happens-after the
    ///   call never returns a record it removed (the exact guarantee: `docs/design.md`,
    ///   removal). Memory is reclaimed when the frame closes.
    /// * none: nothing is stored, so nothing is removed.
    fn remove(&mut self, selection: &Selection) -> usize;

    /// Appends to `out` every record a lookup at `point`/`normal` would use now (not counted as a
    /// lookup). For tests and diagnostics.
    fn valid_records(&mut self, point: Vec3, normal: Vec3, out: &mut Vec<Record>);

    /// This handle's counters so far.
    fn stats(&self) -> &WorkerStats;
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;

    #[test]
    fn config_errors_say_what_is_wrong() {
        for a in [0.0, -0.1, 2.01, f32::NAN] {
            let e = CacheConfig::new(Vec3::ZERO, Vec3::ONE, a).unwrap_err();
            assert!(matches!(e, ConfigError::Accuracy(_)), "{a}");
        }
        assert!(CacheConfig::new(Vec3::ZERO, Vec3::ONE, 2.0).is_ok());
        let e = CacheConfig::new(Vec3::ZERO, Vec3::ONE, 0.0).unwrap_err();
        assert_eq!(e.to_string(), "accuracy 0 is not in (0, 2]");
        let e = CacheConfig::new(Vec3::ONE, Vec3::ZERO, 0.5).unwrap_err();
        assert_eq!(
            e.to_string(),
            "cache bounds [1, 1, 1]..[0, 0, 0] are empty or not finite"
        );
    }

    #[test]
    fn config_root_accuracy_check_and_depth() {
        let c = CacheConfig::new(Vec3::new(-2.0, 0.0, 0.0), Vec3::new(6.0, 2.0, 4.0), 0.4).unwrap();
        assert_eq!(c.accuracy(), 0.4);
        assert_eq!(c.geometry().accuracy, 0.4);
        // The smallest cube around the box, enlarged by 1%: centre (2, 1, 2), half 4 * 1.01.
        assert_eq!(c.root().center, Vec3::new(2.0, 1.0, 2.0));
        assert!((c.root().half - 4.04).abs() < 1e-6);
        assert_eq!(c.geometry().root, c.root());
        let inside = Record::new(Vec3::new(5.9, 4.9, 5.9), Vec3::Z, Vec3::ONE, 1.0);
        assert_eq!(c.check(&inside), Ok(()));
        let outside = Record::new(Vec3::new(6.1, 1.0, 2.0), Vec3::Z, Vec3::ONE, 1.0);
        assert!(matches!(
            c.check(&outside),
            Err(InsertError::OutOfBounds { half_size, .. }) if (half_size - 4.04).abs() < 1e-6
        ));
        let bad = Record::new(Vec3::ONE, Vec3::Z, Vec3::ONE, -1.0);
        assert_eq!(c.check(&bad), Err(InsertError::NonPositiveRadius(-1.0)));
        // Depth follows the influence radius a R: a small record goes deeper than a large one,
        // each where the geometry places its radius.
        let small = Record::new(Vec3::ONE, Vec3::Z, Vec3::ONE, 0.05);
        let large = Record::new(Vec3::ONE, Vec3::Z, Vec3::ONE, 5.0);
        assert_eq!(c.depth_of(&small), c.geometry().placement_depth(0.02));
        assert_eq!(c.depth_of(&large), c.geometry().placement_depth(2.0));
        assert!(c.depth_of(&small) >= 2, "{}", c.depth_of(&small));
        assert!(c.depth_of(&large) < c.depth_of(&small));
    }

    #[test]
    fn inserted_names_its_id() {
        let id = RecordId::new(crate::ic::WorkerId::new(3), 1, 4);
        for outcome in [
            Inserted::Stored(id),
            Inserted::Discarded(id),
            Inserted::NotCached(id),
        ] {
            assert_eq!(outcome.id(), id);
        }
    }

    #[test]
    fn worker_stats_add_every_counter_and_keep_the_maxima() {
        let a = WorkerStats {
            lookups: 1,
            hits: 2,
            shared_hits: 3,
            inserts: 4,
            rejected: 5,
            stored: 6,
            discarded: 7,
            cas_failures: 8,
            removed: 15,
            lock_wait: Duration::from_micros(9),
            max_insert_steps: 10,
            max_lookup_nodes: 3,
            max_lookup_records: 12,
            lookup_nodes: 13,
            lookup_records: 14,
            removal_nodes: 16,
            removal_records: 17,
        };
        let b = WorkerStats {
            lookups: 100,
            hits: 200,
            shared_hits: 300,
            inserts: 400,
            rejected: 500,
            stored: 600,
            discarded: 700,
            cas_failures: 800,
            removed: 1500,
            lock_wait: Duration::from_micros(900),
            max_insert_steps: 2,
            max_lookup_nodes: 30,
            max_lookup_records: 1,
            lookup_nodes: 1300,
            lookup_records: 1400,
            removal_nodes: 1600,
            removal_records: 1700,
        };
        let mut sum = a;
        sum += &b;
        assert_eq!(
            sum,
            WorkerStats {
                lookups: 101,
                hits: 202,
                shared_hits: 303,
                inserts: 404,
                rejected: 505,
                stored: 606,
                discarded: 707,
                cas_failures: 808,
                removed: 1515,
                lock_wait: Duration::from_micros(909),
                max_insert_steps: 10,
                max_lookup_nodes: 30,
                max_lookup_records: 12,
                lookup_nodes: 1313,
                lookup_records: 1414,
                removal_nodes: 1616,
                removal_records: 1717,
            }
        );
    }
}
