//! The shared irradiance caches: one trait, four access schemes (paper §3).
//!
//! | scheme | type | paper |
//! |---|---|---|
//! | TRA | [`Sequential`] | Listing 3 |
//! | LCK | [`Locked`] (`Mutex` or `RwLock`) | Listing 4 |
//! | LW  | [`LocalWrite`] | Listing 5 |
//! | WF  | [`WaitFree`] (`Adopt` or `Discard`) | Listing 6, with the fixes in `paper-notes.md` |
//!
//! plus [`NoCache`], the no-cache reference, behind the same trait.
//!
//! A cache is used in frames ([`frame`]): a [`Frame`] hands each worker a [`CacheHandle`] with a
//! distinct worker id; the handle carries the worker's own state (counters, LW's local cache) so
//! nothing on the hot path writes shared memory but the cache itself, and leaves that state in the
//! cache when it is dropped. Closing the frame takes `&mut` access: LW merges there, and the
//! borrow checker rules out a handle that outlives the frame. [`Scheme`] lists the schemes.

pub mod frame;
mod local_write;
mod locked;
mod none;
pub mod octree;
mod oracle;
mod scheme;
mod sequential;
pub mod wf;

#[cfg(not(checker))]
pub use frame::run_frame;
pub use frame::Frame;
pub use local_write::{LocalWrite, LwHandle};
pub use locked::{LckHandle, LockFlavour, Locked, MutexFlavour, RwLockFlavour};
pub use none::{NoCache, NoCacheHandle};
pub use oracle::BruteForce;
pub use scheme::{CacheJob, Rgb8, Scheme};
pub use sequential::{Octree, SeqHandle, Sequential};
pub use wf::{CasFailure, WaitFree, WfHandle};

use crate::ic::{
    self, Accumulator, InsertError, Interpolated, Record, RecordId, Selection, WorkerId,
};
use frame::{Deposit, Ledger, Local};
use glam::Vec3;
use octree::{Cell, Geometry};
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
    /// The accuracy is not in `(0, 2]`.
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
            Self::Accuracy(a) => write!(f, "accuracy {a} is not in (0, 2]"),
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
    /// A cache covering the box `min..max` (the root is the smallest cube around it, enlarged by
    /// 1%), answering at accuracy `a` (Ward's `a`, typically 0.1 to 0.5).
    pub fn new(min: Vec3, max: Vec3, accuracy: f32) -> Result<Self, ConfigError> {
        if !(accuracy > 0.0 && accuracy <= 2.0) {
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

    /// The scheme's short name, as the CLI spells it ([`Scheme::name`]).
    fn scheme(&self) -> &'static str;

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

    /// Interpolated irradiance at `point` with unit `normal`, or `None` when no record is valid
    /// there (or the query is not finite).
    fn lookup(&mut self, point: Vec3, normal: Vec3) -> Option<Interpolated>;

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
    ///   call never returns a record it removed (the exact guarantee: `paper-notes.md`,
    ///   removal). Memory is reclaimed when the frame closes.
    /// * none: nothing is stored, so nothing is removed.
    fn remove(&mut self, selection: &Selection) -> usize;

    /// Appends to `out` every record a lookup at `point`/`normal` would use now (not counted as a
    /// lookup). For tests and diagnostics.
    fn valid_records(&mut self, point: Vec3, normal: Vec3, out: &mut Vec<Record>);

    /// This handle's counters so far.
    fn stats(&self) -> &WorkerStats;
}

/// The bookkeeping every handle shares: identity, record numbering, counters, the scheme's own
/// part (`X`: LW's local octree), and the ledger it goes back to when the handle is dropped.
#[derive(Debug)]
pub(crate) struct HandleCore<'c, X: Local> {
    pub worker: WorkerId,
    pub frame: u64,
    pub next_seq: u64,
    pub stats: WorkerStats,
    pub local: X,
    ledger: &'c Ledger<X>,
}

impl<X: Local> Drop for HandleCore<'_, X> {
    fn drop(&mut self) {
        self.ledger.deposit(Deposit {
            worker: self.worker,
            stats: self.stats,
            local: self.local.take(),
        });
    }
}

impl<'c, X: Local> HandleCore<'c, X> {
    /// Registers a handle for `worker` in `ledger`'s open frame.
    ///
    /// # Panics
    /// If `worker` already has a handle in that frame.
    pub fn new(ledger: &'c Ledger<X>, worker: WorkerId, local: X) -> Self {
        let frame = ledger.issue(worker);
        Self {
            worker,
            frame,
            next_seq: 0,
            stats: WorkerStats::default(),
            local,
            ledger,
        }
    }

    /// Validates and seals a record for `config`, counting it.
    #[inline]
    pub fn admit(
        &mut self,
        config: &CacheConfig,
        mut record: Record,
    ) -> Result<Record, InsertError> {
        if let Err(e) = config.check(&record) {
            self.stats.rejected += 1;
            return Err(e);
        }
        let id = RecordId::new(self.worker, self.frame, self.next_seq);
        self.next_seq += 1;
        record.seal(id);
        self.stats.inserts += 1;
        Ok(record)
    }

    /// Counts an insert's outcome and steps.
    #[inline]
    pub fn inserted(&mut self, outcome: Inserted, steps: u32) -> Inserted {
        match outcome {
            Inserted::Stored(_) => self.stats.stored += 1,
            Inserted::Discarded(_) => self.stats.discarded += 1,
            Inserted::NotCached(_) => {}
        }
        self.stats.max_insert_steps = self.stats.max_insert_steps.max(steps);
        outcome
    }

    /// Counts one traversal's work: a lookup's, or a `valid_records` call's (which is not a lookup:
    /// `lookups` and `hits` are left alone).
    #[inline]
    pub fn traversed(&mut self, work: Work) {
        let s = &mut self.stats;
        s.max_lookup_nodes = s.max_lookup_nodes.max(work.nodes);
        s.max_lookup_records = s.max_lookup_records.max(work.records);
        s.lookup_nodes += u64::from(work.nodes);
        s.lookup_records += u64::from(work.records);
    }

    /// A fresh accumulator for a query by this worker, or `None` for a query that cannot be answered.
    #[inline]
    pub fn begin_lookup(
        &mut self,
        config: &CacheConfig,
        point: Vec3,
        normal: Vec3,
    ) -> Option<Accumulator> {
        self.stats.lookups += 1;
        ic::is_valid_query(point, normal)
            .then(|| Accumulator::new(point, normal, config.accuracy(), Some(self.worker)))
    }

    /// Counts a lookup's outcome and its work.
    #[inline]
    pub fn end_lookup(&mut self, acc: &Accumulator, work: Work) -> Option<Interpolated> {
        self.traversed(work);
        let out = acc.finish();
        if let Some(hit) = &out {
            self.stats.hits += 1;
            if hit.foreign > 0 {
                self.stats.shared_hits += 1;
            }
        }
        out
    }
}

/// What one traversal of a cache did: the nodes it visited and the records it examined (read from
/// those nodes' lists, valid or not).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Work {
    pub nodes: u32,
    pub records: u32,
}

impl std::ops::AddAssign for Work {
    fn add_assign(&mut self, other: Work) {
        self.nodes += other.nodes;
        self.records += other.records;
    }
}

/// Collects the records a query would use, through any cache's walk (given the query's prefilter
/// and a visitor for the records it admits); returns the walk's work (none for a query that
/// cannot be answered).
pub(crate) fn collect_valid(
    config: &CacheConfig,
    point: Vec3,
    normal: Vec3,
    out: &mut Vec<Record>,
    walk: impl FnOnce(&ic::Prefilter, &mut dyn FnMut(&Record)) -> Work,
) -> Work {
    if !ic::is_valid_query(point, normal) {
        return Work::default();
    }
    let pre = ic::Prefilter::new(point, normal, config.accuracy());
    walk(&pre, &mut |r: &Record| {
        if ic::valid_weight(r, point, normal, config.accuracy()).is_some() {
            out.push(*r);
        }
    })
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
            }
        );
    }

    /// A record at `x` on the line y = z = 1, facing +z, of radius 1, sealed as `worker`'s `seq`.
    fn sealed_at(x: f32, worker: u32, seq: u64) -> Record {
        Record::new(Vec3::new(x, 1.0, 1.0), Vec3::Z, Vec3::ONE, 1.0).sealed(RecordId::new(
            WorkerId::new(worker),
            0,
            seq,
        ))
    }

    /// The bookkeeping every scheme's handle delegates to, counted by hand: record numbering,
    /// refusals, outcomes, step maxima, each traversal's work, hits and shared hits.
    #[test]
    fn a_handle_core_counts_what_its_worker_does() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.5).unwrap();
        let ledger = Ledger::<()>::new();
        let me = WorkerId::new(2);
        let mut core = HandleCore::new(&ledger, me, ());
        let fresh = |x: f32| Record::new(Vec3::new(x, 1.0, 1.0), Vec3::Z, Vec3::ONE, 1.0);

        // Admission numbers the worker's records 0, 1, 2 in this frame and refuses bad input.
        let ids: Vec<RecordId> = (0..3)
            .map(|k| core.admit(&config, fresh(1.0 + k as f32)).unwrap().id())
            .collect();
        let expected: Vec<RecordId> = (0..3).map(|k| RecordId::new(me, 0, k)).collect();
        assert_eq!(ids, expected);
        assert!(matches!(
            core.admit(&config, fresh(9.0)),
            Err(InsertError::OutOfBounds { .. })
        ));
        assert_eq!((core.stats.inserts, core.stats.rejected), (3, 1));

        // Outcomes: two stored, one discarded, one not cached (counted nowhere); the most steps.
        assert_eq!(
            core.inserted(Inserted::Stored(ids[0]), 3),
            Inserted::Stored(ids[0])
        );
        core.inserted(Inserted::Stored(ids[1]), 5);
        core.inserted(Inserted::Discarded(ids[2]), 4);
        core.inserted(Inserted::NotCached(ids[2]), 1);
        let s = core.stats;
        assert_eq!((s.stored, s.discarded, s.max_insert_steps), (2, 1, 5));

        // Traversals: maxima per field (from different traversals) and sums.
        core.traversed(Work {
            nodes: 3,
            records: 7,
        });
        core.traversed(Work {
            nodes: 5,
            records: 2,
        });
        let s = core.stats;
        assert_eq!(
            (
                s.max_lookup_nodes,
                s.max_lookup_records,
                s.lookup_nodes,
                s.lookup_records
            ),
            (5, 7, 8, 9)
        );
        assert_eq!(s.lookups, 0, "a traversal alone is not a lookup");

        // Lookups: one that cannot be answered, a miss, a hit on the worker's own records, a hit
        // that uses another worker's record.
        let q = Vec3::new(1.1, 1.0, 1.0);
        assert!(core.begin_lookup(&config, Vec3::NAN, Vec3::Z).is_none());
        let miss = core.begin_lookup(&config, q, Vec3::Z).unwrap();
        assert_eq!(miss.point(), q);
        assert_eq!(core.end_lookup(&miss, Work::default()), None);
        let mut own = core.begin_lookup(&config, q, Vec3::Z).unwrap();
        assert!(own.add(&sealed_at(1.0, 2, 0)) && own.add(&sealed_at(1.2, 2, 1)));
        let hit = core.end_lookup(&own, Work::default()).unwrap();
        assert_eq!((hit.records, hit.foreign), (2, 0));
        let mut shared = core.begin_lookup(&config, q, Vec3::Z).unwrap();
        assert!(shared.add(&sealed_at(1.0, 2, 0)) && shared.add(&sealed_at(1.2, 5, 0)));
        let hit = core.end_lookup(&shared, Work::default()).unwrap();
        assert_eq!((hit.records, hit.foreign), (2, 1));
        let s = core.stats;
        assert_eq!((s.lookups, s.hits, s.shared_hits), (4, 2, 1));
        // A second shared hit counts one more (not a doubling of the first).
        core.end_lookup(&shared, Work::default());
        core.end_lookup(&shared, Work::default());
        assert_eq!(core.stats.shared_hits, 3);
        // `end_lookup` counts its traversal too.
        core.end_lookup(
            &miss,
            Work {
                nodes: 1,
                records: 1,
            },
        );
        assert_eq!(core.stats.lookup_nodes, 9);
    }

    #[test]
    fn collect_valid_keeps_the_valid_records_and_counts_every_one_it_is_shown() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.5).unwrap();
        let (q, mut out) = (Vec3::new(1.1, 1.0, 1.0), Vec::new());
        // Valid, far (invalid), valid: three examined over two nodes, two kept in visit order.
        let shown = [
            sealed_at(1.0, 0, 0),
            sealed_at(3.5, 0, 1),
            sealed_at(1.2, 1, 0),
        ];
        let work = collect_valid(&config, q, Vec3::Z, &mut out, |pre, f| {
            assert_eq!(pre.point(), q);
            shown.iter().for_each(f);
            Work {
                nodes: 2,
                records: 3,
            }
        });
        assert_eq!(
            work,
            Work {
                nodes: 2,
                records: 3
            }
        );
        assert_eq!(out, vec![shown[0], shown[2]]);
        // A query that cannot be answered visits nothing.
        let work = collect_valid(&config, Vec3::NAN, Vec3::Z, &mut out, |_, _| {
            panic!("an unanswerable query must not be visited")
        });
        assert_eq!(work, Work::default());
        assert_eq!(out.len(), 2);
    }

    #[test]
    fn a_ledger_names_its_cache_in_debug_output() {
        let (a, b) = (Ledger::<()>::new(), Ledger::<()>::new());
        let (a, b) = (format!("{a:?}"), format!("{b:?}"));
        let number = |s: &str| -> u64 {
            s.strip_prefix("Ledger(cache #")
                .and_then(|r| r.strip_suffix(')'))
                .unwrap_or_else(|| panic!("unexpected Debug output {s:?}"))
                .parse()
                .unwrap()
        };
        assert_ne!(number(&a), number(&b), "each cache has its own number");
    }
}
