//! The irradiance cache as a sequential specification, a cache handle that records what it does,
//! and the set-consistency check.
//!
//! **Specification.** The state is the set of records stored so far (kept sorted by id, shared
//! behind an `Arc` so that the checker's many copies of it cost a reference count). An insert
//! stores its record; a lookup answers the ids of the records valid at its query
//! ([`crate::ic::valid_weight`] over the stored records: what [`BruteForce::valid_records`]
//! answers). Ids are compared exactly, so there is no floating-point tolerance anywhere.
//!
//! **Discarded inserts.** Whether a WF insert is `Stored` or `Discarded` is the cache's policy
//! choice, not something a sequential cache decides. The specification accepts either: a
//! `Discarded` insert is a no-op (the record must then never be seen), a `Stored` one adds the
//! record. Likewise an insert refused with `InsertError::ListFull` (only under loom) is a no-op.
//!
//! **Pending inserts.** A record's id is chosen by the cache and known only when the insert
//! returns, so an insert that was invoked and never returned carries [`InsertId::Unknown`]: its
//! worker, and no id (no real id can be mistaken for it). Such an insert may still have taken
//! effect (a WF record is visible before its insert returns). The specification then holds its
//! record unnamed; the first lookup that must see it (it is valid at the query) names it with the
//! one id the lookup returned that no named record explains, which must be an id of the insert's
//! worker that no other insert was given (an insert that returns with it later then fails). Later
//! lookups are held to that name. The set-consistency check follows the same rule
//! ([`check_set_consistency`]).
//!
//! [`BruteForce::valid_records`]: crate::research::BruteForce::valid_records

use super::{History, Specification, ThreadLog};
use crate::cache::{CacheConfig, CacheHandle, Inserted};
use crate::ic::{self, InsertError, Record, RecordId, Selection, WorkerId};
use glam::Vec3;
use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// The id of an inserted record, as far as the history knows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum InsertId {
    /// The id the cache gave the record: the insert returned it.
    Known(RecordId),
    /// Not known: the insert never returned (it is pending), or it was refused and got none. Only
    /// the worker that asked is known. Equal to no [`InsertId::Known`], whatever its id.
    Unknown(WorkerId),
}

impl InsertId {
    /// The id, when known.
    pub fn known(self) -> Option<RecordId> {
        match self {
            Self::Known(id) => Some(id),
            Self::Unknown(_) => None,
        }
    }

    /// The worker that inserted (or asked to insert) the record.
    pub fn worker(self) -> WorkerId {
        match self {
            Self::Known(id) => id.worker(),
            Self::Unknown(worker) => worker,
        }
    }
}

impl fmt::Display for InsertId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Known(id) => write!(f, "{id}"),
            Self::Unknown(worker) => write!(f, "r{}.?", worker.index()),
        }
    }
}

/// A cache operation.
#[derive(Clone, Copy, PartialEq)]
pub enum CacheOp {
    /// Insert a record. The recorder logs it as [`InsertId::Unknown`] at invocation and completes it
    /// with the id the cache gave the record (and the record sealed with it) when the insert
    /// returns one.
    Insert {
        /// The record; its own id field is not read (`id` says what is known).
        record: Record,
        /// The record's id, or who asked for it while that is all that is known.
        id: InsertId,
    },
    /// Ask which records are valid at a point with a normal.
    Lookup {
        /// The query point.
        point: Vec3,
        /// The query's unit normal.
        normal: Vec3,
    },
    /// Remove the records a selection takes, ages counted from frame `now`; returns how many.
    Remove {
        /// What to remove.
        selection: Selection,
        /// The frame the removal runs in (for [`Selection::older_than`]).
        now: u64,
    },
}

impl CacheOp {
    /// The insert of `record` that was given `id` (the record is sealed with it): for histories
    /// built by hand.
    pub fn insert(id: RecordId, record: Record) -> Self {
        Self::Insert {
            record: record.sealed(id),
            id: InsertId::Known(id),
        }
    }

    /// An insert of `record` by `worker` whose id is not known: a pending insert, in a history
    /// built by hand.
    pub fn insert_unknown(worker: WorkerId, record: Record) -> Self {
        Self::Insert {
            record,
            id: InsertId::Unknown(worker),
        }
    }
}

impl fmt::Debug for CacheOp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Insert { record: r, id } => write!(
                f,
                "insert {id} ({:.2},{:.2},{:.2}) R={:.2}",
                r.position.x, r.position.y, r.position.z, r.radius
            ),
            Self::Lookup { point, .. } => {
                write!(f, "lookup ({:.2},{:.2},{:.2})", point.x, point.y, point.z)
            }
            Self::Remove { selection, .. } => write!(f, "remove {selection}"),
        }
    }
}

/// What a cache operation returned.
#[derive(Clone, PartialEq)]
pub enum CacheRet {
    /// An insert's outcome.
    Inserted(Inserted),
    /// An insert refused (the cache is unchanged).
    Rejected(InsertError),
    /// A lookup's valid records.
    Found {
        /// Ids of the intact records valid at the query, sorted; a record met twice is there
        /// twice (the recorder does not deduplicate, so the checks can see it).
        ids: Vec<RecordId>,
        /// Records met that were not intact ([`Record::is_intact`]): torn reads. Always 0 in the
        /// specification.
        torn: usize,
    },
    /// A removal's count.
    Removed(usize),
}

impl fmt::Debug for CacheRet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Inserted(Inserted::Stored(_)) => write!(f, "Stored"),
            Self::Inserted(Inserted::Discarded(_)) => write!(f, "Discarded"),
            Self::Inserted(Inserted::NotCached(_)) => write!(f, "NotCached"),
            Self::Rejected(e) => write!(f, "Rejected({e})"),
            Self::Found { ids, torn } => {
                write!(f, "{{")?;
                for (k, id) in ids.iter().enumerate() {
                    write!(f, "{}{id}", if k > 0 { ", " } else { "" })?;
                }
                write!(f, "}}")?;
                if *torn > 0 {
                    write!(f, " +{torn} torn")?;
                }
                Ok(())
            }
            Self::Removed(n) => write!(f, "Removed({n})"),
        }
    }
}

/// The sequential cache: the set of stored records. Equality and hashing look at the ids of the
/// named records only (a record's id determines it within one history), and at the bits of the
/// unnamed ones.
#[derive(Clone, Debug)]
pub struct CacheSpec {
    config: CacheConfig,
    /// Stored records with a known id, sealed with it; sorted by id, no duplicates.
    records: Arc<Vec<Record>>,
    /// Ids given to inserts that stored nothing (`Discarded`), sorted: no record may have them.
    spent: Arc<Vec<RecordId>>,
    /// Records of pending inserts ([`InsertId::Unknown`]) that have taken effect and that no
    /// lookup has named yet, with their worker, in the order they took effect.
    unnamed: Arc<Vec<(WorkerId, Record)>>,
}

impl CacheSpec {
    /// An empty cache with `config`'s bounds and accuracy.
    pub fn new(config: CacheConfig) -> Self {
        Self {
            config,
            records: Arc::new(Vec::new()),
            spent: Arc::new(Vec::new()),
            unnamed: Arc::new(Vec::new()),
        }
    }

    /// The stored records whose id is known, sorted by id.
    pub fn records(&self) -> &[Record] {
        &self.records
    }

    /// Ids of the stored records (those with a known id) valid at `point`/`normal`, sorted.
    pub fn valid_ids(&self, point: Vec3, normal: Vec3) -> Vec<RecordId> {
        ic::valid_among(self.records.iter(), point, normal, self.config.accuracy())
            .map(Record::id)
            .collect()
    }

    /// True when no record of the state has `id` and no insert that stored nothing was given it.
    fn is_fresh(&self, id: RecordId) -> bool {
        self.records.binary_search_by_key(&id, Record::id).is_err()
            && self.spent.binary_search(&id).is_err()
    }

    /// Removes every record `selection` takes in frame `now`, named or not; returns how many.
    /// The ids of the removed named records are spent: no later record may have them.
    fn remove(&mut self, selection: &Selection, now: u64) -> usize {
        let a = self.config.accuracy();
        let (gone, kept): (Vec<Record>, Vec<Record>) = self
            .records
            .iter()
            .partition(|r| selection.selects(r, a, now));
        let unnamed_gone = self
            .unnamed
            .iter()
            .filter(|(_, r)| selection.selects(r, a, now))
            .count();
        if !gone.is_empty() {
            let spent = Arc::make_mut(&mut self.spent);
            spent.extend(gone.iter().map(Record::id));
            spent.sort_unstable();
            self.records = Arc::new(kept);
        }
        if unnamed_gone > 0 {
            let left = self
                .unnamed
                .iter()
                .filter(|(_, r)| !selection.selects(r, a, now))
                .copied()
                .collect();
            self.unnamed = Arc::new(left);
        }
        gone.len() + unnamed_gone
    }

    /// Stores `record` as `id` (nothing when a record has that id already).
    fn store(&mut self, id: RecordId, record: &Record) {
        if let Err(at) = self.records.binary_search_by_key(&id, Record::id) {
            Arc::make_mut(&mut self.records).insert(at, record.sealed(id));
        }
    }

    /// A lookup at `point`/`normal` that returned `ids`. The named records valid there must be
    /// among `ids`, and the rest of `ids` must name, one each, exactly the unnamed records valid
    /// there: each with a fresh id of its own worker (the first such id, by id, for the first
    /// record, by the order they took effect: a choice only when one worker has two unnamed
    /// records, which one handle running one operation at a time cannot leave). Names them.
    fn step_lookup(&mut self, point: Vec3, normal: Vec3, ids: &[RecordId]) -> bool {
        let named = self.valid_ids(point, normal);
        let answerable = ic::is_valid_query(point, normal);
        let a = self.config.accuracy();
        let unnamed: Vec<usize> = (0..self.unnamed.len())
            .filter(|&k| {
                answerable && ic::valid_weight(&self.unnamed[k].1, point, normal, a).is_some()
            })
            .collect();
        if unnamed.is_empty() {
            return ids == named.as_slice();
        }
        // `ids` must be sorted without duplicates (the specification answers a sorted set), and
        // contain `named`; the rest are the candidate names.
        let mut rest = Vec::new();
        let mut k = 0;
        for (j, &id) in ids.iter().enumerate() {
            if j > 0 && ids[j - 1] >= id {
                return false;
            }
            if named.get(k) == Some(&id) {
                k += 1;
            } else {
                rest.push(id);
            }
        }
        if k < named.len() || rest.len() != unnamed.len() {
            return false;
        }
        let mut names = Vec::with_capacity(unnamed.len());
        for &u in &unnamed {
            let worker = self.unnamed[u].0;
            let Some(j) = rest
                .iter()
                .position(|&id| id.worker() == worker && self.is_fresh(id))
            else {
                return false;
            };
            names.push((rest.remove(j), u));
        }
        for &(id, u) in &names {
            let record = self.unnamed[u].1;
            self.store(id, &record);
        }
        let left = (0..self.unnamed.len())
            .filter(|k| !unnamed.contains(k))
            .map(|k| self.unnamed[k])
            .collect();
        self.unnamed = Arc::new(left);
        true
    }
}

/// The bits of every field a specification state compares (position, normal, irradiance,
/// radius, gradients): floats compared by bits, so equality and hashing agree.
fn record_bits(r: &Record) -> impl Iterator<Item = u32> + '_ {
    [r.position, r.normal, r.irradiance]
        .into_iter()
        .chain(r.grad_t)
        .chain(r.grad_r)
        .flat_map(|v| v.to_array())
        .chain([r.radius])
        .map(f32::to_bits)
}

impl PartialEq for CacheSpec {
    fn eq(&self, other: &Self) -> bool {
        let records = Arc::ptr_eq(&self.records, &other.records)
            || self
                .records
                .iter()
                .map(Record::id)
                .eq(other.records.iter().map(Record::id));
        records
            && self.spent == other.spent
            && self.unnamed.len() == other.unnamed.len()
            && self
                .unnamed
                .iter()
                .zip(other.unnamed.iter())
                .all(|((w, r), (v, q))| w == v && record_bits(r).eq(record_bits(q)))
    }
}

impl Eq for CacheSpec {}

impl Hash for CacheSpec {
    fn hash<H: Hasher>(&self, state: &mut H) {
        state.write_usize(self.records.len());
        self.records.iter().for_each(|r| r.id().hash(state));
        self.spent.hash(state);
        state.write_usize(self.unnamed.len());
        for (worker, record) in self.unnamed.iter() {
            worker.hash(state);
            record_bits(record).for_each(|b| state.write_u32(b));
        }
    }
}

impl Specification for CacheSpec {
    type Op = CacheOp;
    type Ret = CacheRet;

    /// The sequential cache's answer. A lookup answers the records whose id is known (an unnamed
    /// record, from a pending insert, has no id to answer with: [`step`](Self::step) is exact).
    ///
    /// # Panics
    /// On a valid insert with [`InsertId::Unknown`]: the cache chooses the id, so the
    /// specification cannot answer it (a pending one is [`apply_pending`](Self::apply_pending)'s).
    fn apply(&mut self, op: &CacheOp) -> CacheRet {
        match op {
            CacheOp::Insert { record, id } => {
                if let Err(e) = self.config.check(record) {
                    return CacheRet::Rejected(e);
                }
                let InsertId::Known(id) = *id else {
                    panic!(
                        "insert {id} has no id to answer with: only a pending one can be applied"
                    )
                };
                self.store(id, record);
                CacheRet::Inserted(Inserted::Stored(id))
            }
            CacheOp::Lookup { point, normal } => CacheRet::Found {
                ids: self.valid_ids(*point, *normal),
                torn: 0,
            },
            CacheOp::Remove { selection, now } => CacheRet::Removed(self.remove(selection, *now)),
        }
    }

    /// A pending insert with a known id stores its record as `apply` does (when the id is fresh);
    /// one with an unknown id stores its record unnamed, for a later lookup to name. A pending
    /// lookup changes nothing.
    fn apply_pending(&mut self, op: &CacheOp) {
        match op {
            CacheOp::Insert { record, id } if self.config.check(record).is_ok() => match *id {
                InsertId::Known(id) => {
                    if self.is_fresh(id) {
                        self.store(id, record);
                    }
                }
                InsertId::Unknown(worker) => {
                    Arc::make_mut(&mut self.unnamed).push((worker, *record))
                }
            },
            CacheOp::Remove { selection, now } => {
                self.remove(selection, *now);
            }
            CacheOp::Insert { .. } | CacheOp::Lookup { .. } => {}
        }
    }

    /// # Panics
    /// On an insert that returned an id its operation does not carry (the recorder always
    /// completes the operation; a hand-built one must use [`CacheOp::insert`]).
    fn step(&mut self, op: &CacheOp, observed: &CacheRet) -> bool {
        match (op, observed) {
            (CacheOp::Insert { record, id }, CacheRet::Inserted(outcome)) => {
                assert_eq!(
                    id.known(),
                    Some(outcome.id()),
                    "insert {id} returned {outcome:?} with another id"
                );
                let id = outcome.id();
                if self.config.check(record).is_err() || !self.is_fresh(id) {
                    return false;
                }
                match outcome {
                    Inserted::Stored(_) => self.store(id, record),
                    // The cache's policy chose not to store it: a no-op, but the id is used.
                    Inserted::Discarded(_) => {
                        let spent = Arc::make_mut(&mut self.spent);
                        let at = spent.binary_search(&id).unwrap_err();
                        spent.insert(at, id);
                    }
                    // A cache that keeps nothing is not this specification.
                    Inserted::NotCached(_) => return false,
                }
                true
            }
            // A model-checking capacity limit (loom only): a no-op.
            #[cfg(feature = "loom")]
            (CacheOp::Insert { .. }, CacheRet::Rejected(InsertError::ListFull)) => true,
            (CacheOp::Insert { record, .. }, CacheRet::Rejected(e)) => {
                self.config.check(record).err() == Some(*e)
            }
            (CacheOp::Lookup { point, normal }, CacheRet::Found { ids, torn }) => {
                *torn == 0 && self.step_lookup(*point, *normal, ids)
            }
            (CacheOp::Remove { selection, now }, CacheRet::Removed(n)) => {
                self.remove(selection, *now) == *n
            }
            _ => false,
        }
    }

    fn observes(op: &CacheOp, ret: &CacheRet, other: &CacheOp) -> bool {
        lookup_observes(op, ret, other)
    }

    /// Records are independent: a lookup that saw a removed insert's record keeps the rest. A
    /// removed insert whose id is unknown may be behind any id of its worker, so a lookup that
    /// returned one goes with it. A removal's count may include a removed insert's record when it
    /// selects it: it goes with the insert. Without a removal, a lookup might have returned
    /// records the removal took, which nobody can name: every lookup goes with a removal.
    fn forget(op: &CacheOp, ret: &mut CacheRet, removed: &CacheOp) -> bool {
        match (op, &mut *ret, removed) {
            (CacheOp::Remove { selection, now }, _, CacheOp::Insert { record, .. }) => {
                // The accuracy is not known here: ask at the largest (`a = 1`), which selects a
                // superset of what any cache's accuracy selects.
                !selection.selects(record, 1.0, *now)
            }
            (CacheOp::Lookup { .. }, _, CacheOp::Remove { .. }) => false,
            (
                CacheOp::Lookup { .. },
                CacheRet::Found { ids, .. },
                CacheOp::Insert {
                    id: InsertId::Known(id),
                    ..
                },
            ) => {
                ids.retain(|x| x != id);
                true
            }
            _ => !lookup_observes(op, ret, removed),
        }
    }
}

/// True when `op` is a lookup whose result `ret` contains the record `other` inserted; for an
/// insert whose id is unknown, when it contains an id of the insert's worker (it may be that
/// record: nobody can tell).
pub fn lookup_observes(op: &CacheOp, ret: &CacheRet, other: &CacheOp) -> bool {
    match (op, ret, other) {
        (CacheOp::Lookup { .. }, CacheRet::Found { ids, .. }, CacheOp::Insert { id, .. }) => {
            match *id {
                InsertId::Known(id) => ids.contains(&id),
                InsertId::Unknown(worker) => ids.iter().any(|x| x.worker() == worker),
            }
        }
        _ => false,
    }
}

/// A cache handle that records every insert and lookup in its thread's log.
///
/// Lookups are answered by [`CacheHandle::valid_records`], one traversal of the cache like a
/// lookup's, and recorded as the sorted ids of the intact records it met (a record met twice is
/// recorded twice) plus a count of torn ones.
#[derive(Debug)]
pub struct RecordingHandle<H> {
    handle: H,
    log: ThreadLog<CacheOp, CacheRet>,
    scratch: Vec<Record>,
}

impl<H: CacheHandle> RecordingHandle<H> {
    /// Wraps `handle`, recording into `log`.
    pub fn new(handle: H, log: ThreadLog<CacheOp, CacheRet>) -> Self {
        Self {
            handle,
            log,
            scratch: Vec::new(),
        }
    }

    /// Inserts `record` through the handle, recording the call and its outcome.
    pub fn insert(&mut self, record: Record) -> Result<Inserted, InsertError> {
        // The id is assigned inside the insert: until it returns, only the worker is known.
        let worker = self.handle.worker();
        self.log.invoke(CacheOp::insert_unknown(worker, record));
        let result = self.handle.insert(record);
        match result {
            Ok(outcome) => {
                if let Some(op) = self.log.pending_op_mut() {
                    *op = CacheOp::insert(outcome.id(), record);
                }
                self.log.ret(CacheRet::Inserted(outcome));
            }
            Err(e) => self.log.ret(CacheRet::Rejected(e)),
        }
        result
    }

    /// Looks up the records valid at `point`/`normal`, recording the call and the ids found.
    /// Returns the ids (sorted, duplicates kept) and the number of torn records met.
    pub fn lookup(&mut self, point: Vec3, normal: Vec3) -> (Vec<RecordId>, usize) {
        self.log.invoke(CacheOp::Lookup { point, normal });
        self.scratch.clear();
        self.handle.valid_records(point, normal, &mut self.scratch);
        let torn = self.scratch.iter().filter(|r| !r.is_intact()).count();
        let mut ids: Vec<RecordId> = self
            .scratch
            .iter()
            .filter(|r| r.is_intact())
            .map(Record::id)
            .collect();
        ids.sort_unstable();
        self.log.ret(CacheRet::Found {
            ids: ids.clone(),
            torn,
        });
        (ids, torn)
    }

    /// Removes what `selection` takes through the handle (ages counted from frame `now`, the
    /// handle's frame), recording the call and its count.
    pub fn remove(&mut self, selection: Selection, now: u64) -> usize {
        self.log.invoke(CacheOp::Remove { selection, now });
        let n = self.handle.remove(&selection);
        self.log.ret(CacheRet::Removed(n));
        n
    }

    /// The wrapped handle (operations through it are not recorded).
    pub fn handle(&mut self) -> &mut H {
        &mut self.handle
    }

    /// The handle and the log: the log for
    /// [`Recorder::into_history`](super::Recorder::into_history), the handle to keep using or to
    /// drop (which hands its state back to the cache).
    pub fn into_parts(self) -> (H, ThreadLog<CacheOp, CacheRet>) {
        (self.handle, self.log)
    }
}

/// How a cache history broke set consistency (operation indices into the history).
#[derive(Clone, Debug, PartialEq)]
pub enum SetViolation {
    /// A lookup returned a record no insert of the history stored: no insert was given its id (or
    /// the one that was stored nothing), and no pending insert of its worker whose id is unknown is
    /// left to explain it ([`check_set_consistency`] states the rule).
    Phantom {
        /// The lookup.
        lookup: usize,
        /// The record's id.
        id: RecordId,
    },
    /// A lookup returned a record whose insert began only after the lookup ended.
    FromTheFuture {
        /// The lookup.
        lookup: usize,
        /// The insert.
        insert: usize,
        /// The record's id.
        id: RecordId,
    },
    /// A lookup missed a record valid at its query whose insert returned before the lookup began.
    Lost {
        /// The lookup.
        lookup: usize,
        /// The insert.
        insert: usize,
        /// The record's id.
        id: RecordId,
    },
    /// A lookup missed a record valid at its query that an earlier lookup of the same thread
    /// returned: reads are not monotonic.
    Forgotten {
        /// The earlier lookup (the latest of the thread that returned the record).
        earlier: usize,
        /// The later lookup.
        later: usize,
        /// The record's id.
        id: RecordId,
    },
    /// A lookup returned the same record more than once (a set has each element once).
    Duplicate {
        /// The lookup.
        lookup: usize,
        /// The record's id.
        id: RecordId,
    },
    /// A lookup met torn records.
    Torn {
        /// The lookup.
        lookup: usize,
        /// How many.
        count: usize,
    },
    /// A lookup returned a record that a removal selecting it had taken: the removal returned
    /// before the lookup began, and the record's insert returned before the removal began.
    Resurrected {
        /// The lookup.
        lookup: usize,
        /// The removal.
        removal: usize,
        /// The record's id.
        id: RecordId,
    },
    /// A removal counted more records than it could have taken: more than the records it
    /// selects whose insert began before it ended.
    OverCounted {
        /// The removal.
        removal: usize,
        /// What it returned.
        count: usize,
        /// The records it could have taken.
        at_most: usize,
    },
    /// The removals together counted more records than they could have taken between them: a
    /// record counted by two of them.
    CountedTwice {
        /// Their counts, summed.
        total: usize,
        /// The distinct records any of them could have taken.
        at_most: usize,
    },
    /// The removals together counted fewer records than they must have taken: every record some
    /// removal selects whose insert returned `Stored` before that removal began.
    Uncounted {
        /// Their counts, summed.
        total: usize,
        /// The records they must have taken.
        at_least: usize,
    },
}

impl fmt::Display for SetViolation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Phantom { lookup, id } => {
                write!(f, "lookup #{lookup} returned {id}, which no insert stored")
            }
            Self::FromTheFuture { lookup, insert, id } => write!(
                f,
                "lookup #{lookup} returned {id}, whose insert #{insert} began after the lookup ended"
            ),
            Self::Lost { lookup, insert, id } => write!(
                f,
                "lookup #{lookup} missed {id}, valid there, whose insert #{insert} returned before the lookup began"
            ),
            Self::Forgotten { earlier, later, id } => write!(
                f,
                "lookup #{later} missed {id}, valid there, which lookup #{earlier} of the same thread returned"
            ),
            Self::Duplicate { lookup, id } => {
                write!(f, "lookup #{lookup} returned {id} more than once")
            }
            Self::Torn { lookup, count } => write!(f, "lookup #{lookup} met {count} torn records"),
            Self::Resurrected { lookup, removal, id } => write!(
                f,
                "lookup #{lookup} returned {id}, which removal #{removal} took before the lookup began"
            ),
            Self::OverCounted { removal, count, at_most } => write!(
                f,
                "removal #{removal} counted {count} records, but could have taken at most {at_most}"
            ),
            Self::CountedTwice { total, at_most } => write!(
                f,
                "the removals counted {total} records between them, but could have taken at most {at_most}"
            ),
            Self::Uncounted { total, at_least } => write!(
                f,
                "the removals counted {total} records between them, but must have taken {at_least}"
            ),
        }
    }
}

impl std::error::Error for SetViolation {}

/// Checks the set-consistency of a cache history: for every lookup that returned,
///
/// 1. every record it returned was stored by an insert of the history that began before the
///    lookup ended (no phantom, nothing from the future; a `Discarded` record is a phantom), or
///    may be a pending insert's, by the rule below;
/// 2. every record valid at its query whose insert returned `Stored` before the lookup began is
///    among those returned (nothing lost);
/// 3. it met no torn record, and returned no record twice;
/// 4. every record an earlier lookup of the same thread returned that is valid at its query is
///    among those returned (reads are monotonic per thread: nothing is forgotten).
///
/// With removals, 2 and 4 exempt every record that a removal selecting it began before the
/// lookup ended, and three more rules hold (WF's guarantee, `docs/design.md`, removal):
///
/// 5. a lookup returns no record that a removal selecting it took for certain: the removal
///    returned before the lookup began, and the record's insert returned before the removal began
///    (nothing resurrected);
/// 6. a removal counts at most the records it selects whose insert began before it ended;
/// 7. when every removal returned, their counts add up to at most the distinct records any of them
///    could have taken (none counted twice), and at least the records some removal selecting them
///    must have taken (those whose insert returned `Stored` before that removal began).
///    Removals that did not return are not checked.
///
/// Pending lookups are not checked. A pending insert whose id is unknown ([`InsertId::Unknown`]:
/// invoked, never returned) may have stored its record (a WF record is visible before its insert
/// returns), but which id it got is not recorded. So: let `X` be the ids of worker `w` that
/// lookups returned and that no insert of the history carries, and `P` the pending inserts of `w`
/// whose id is unknown. Each id of `X` is explained by its own insert of `P` (one insert stores
/// one record) invoked before every lookup that returned the id ended, as many of `X` as can be
/// (a maximum matching; it is found greedily, ids by the earliest end of a lookup returning them,
/// inserts by invocation); an id left over is a phantom, reported at that earliest lookup. An id
/// some insert of the history carries is that insert's and never a pending one's.
///
/// # Panics
/// On an insert that returned an id its operation does not carry (the recorder always completes
/// the operation; a hand-built one must use [`CacheOp::insert`]).
pub fn check_set_consistency(
    history: &History<CacheOp, CacheRet>,
    config: &CacheConfig,
) -> Result<(), SetViolation> {
    let ix = SetIndex::new(history.operations(), config.accuracy());
    check_removal_counts(ix.ops, &ix.removals, &ix.stored, |k| ix.visible(k), ix.a)?;
    // Per thread, every id its lookups returned so far, with the latest lookup that returned it.
    let mut seen: HashMap<usize, BTreeMap<RecordId, usize>> = HashMap::new();
    for l in ix.lookups() {
        // The recorder sorts the ids (and keeps duplicates); sort a copy anyway, so that a
        // hand-built result in another order is judged the same.
        let mut ids = l.ids.clone();
        ids.sort_unstable();
        ix.check_returned(&l, &ids)?;
        let mine = seen.entry(l.op.thread).or_default();
        if ic::is_valid_query(l.point, l.normal) {
            ix.check_nothing_missed(&l, &ids, mine)?;
        }
        mine.extend(ids.iter().map(|&id| (id, l.index)));
    }
    Ok(())
}

/// One lookup of the history that returned, with what it returned.
struct ReturnedLookup<'h> {
    index: usize,
    op: &'h super::Operation<CacheOp, CacheRet>,
    point: Vec3,
    normal: Vec3,
    ids: &'h Vec<RecordId>,
    torn: usize,
    end: u64,
}

/// A history indexed for [`check_set_consistency`]: its inserts by id, the stored ones, the ids
/// adopted by pending inserts, and its removals.
struct SetIndex<'h> {
    ops: &'h [super::Operation<CacheOp, CacheRet>],
    /// Ward's accuracy of the cache.
    a: f32,
    /// Every insert that carries an id, by id.
    named: HashMap<RecordId, usize>,
    /// The inserts that stored their record, for losses.
    stored: Vec<usize>,
    /// Ids no insert carries, with the earliest end of a lookup that returned each (and that lookup).
    orphans: HashMap<RecordId, (u64, usize)>,
    /// Orphan ids matched to a pending insert of their worker.
    adopted: HashMap<RecordId, usize>,
    /// The removals: operation index, selection, and the frame it was judged at.
    removals: Vec<(usize, Selection, u64)>,
}

impl<'h> SetIndex<'h> {
    fn new(ops: &'h [super::Operation<CacheOp, CacheRet>], a: f32) -> Self {
        let (named, stored, unnamed) = Self::index_inserts(ops);
        let removals = ops
            .iter()
            .enumerate()
            .filter_map(|(k, o)| match o.op {
                CacheOp::Remove { selection, now } => Some((k, selection, now)),
                _ => None,
            })
            .collect();
        let mut ix = Self {
            ops,
            a,
            named,
            stored,
            orphans: HashMap::new(),
            adopted: HashMap::new(),
            removals,
        };
        ix.adopt_orphans(&unnamed);
        ix
    }

    /// Every insert that carries an id, by id; those that stored their record; the pending
    /// inserts whose id is unknown, by worker, in invocation order.
    #[allow(clippy::type_complexity)]
    fn index_inserts(
        ops: &[super::Operation<CacheOp, CacheRet>],
    ) -> (
        HashMap<RecordId, usize>,
        Vec<usize>,
        HashMap<WorkerId, Vec<usize>>,
    ) {
        let mut named: HashMap<RecordId, usize> = HashMap::new();
        let mut stored = Vec::new();
        let mut unnamed: HashMap<WorkerId, Vec<usize>> = HashMap::new();
        for (k, o) in ops.iter().enumerate() {
            let CacheOp::Insert { id, .. } = o.op else {
                continue;
            };
            if let Some(CacheRet::Inserted(outcome)) = &o.ret {
                assert_eq!(
                    id.known(),
                    Some(outcome.id()),
                    "insert #{k} ({id}) returned {outcome:?} with another id"
                );
            }
            match (id, &o.ret) {
                (InsertId::Known(id), ret) => {
                    named.insert(id, k);
                    if matches!(ret, Some(CacheRet::Inserted(Inserted::Stored(_)))) {
                        stored.push(k);
                    }
                }
                (InsertId::Unknown(worker), None) => unnamed.entry(worker).or_default().push(k),
                // Refused: it stored nothing.
                (InsertId::Unknown(_), Some(_)) => {}
            }
        }
        (named, stored, unnamed)
    }

    /// Ids no insert carries, with the earliest end of a lookup that returned each (and that
    /// lookup), then matched to the pending inserts of their worker.
    fn adopt_orphans(&mut self, unnamed: &HashMap<WorkerId, Vec<usize>>) {
        let ops = self.ops;
        for l in self.lookups() {
            for &id in l.ids.iter().filter(|id| !self.named.contains_key(id)) {
                let first = self.orphans.entry(id).or_insert((l.end, l.index));
                *first = (*first).min((l.end, l.index));
            }
        }
        let mut by_worker: HashMap<WorkerId, Vec<(u64, RecordId)>> = HashMap::new();
        for (&id, &(end, _)) in &self.orphans {
            by_worker.entry(id.worker()).or_default().push((end, id));
        }
        for (worker, mut ids) in by_worker {
            ids.sort_unstable();
            let pending = unnamed.get(&worker).map_or(&[][..], Vec::as_slice);
            let mut next = 0;
            for (end, id) in ids {
                if let Some(&insert) = pending.get(next).filter(|&&k| ops[k].invoked < end) {
                    self.adopted.insert(id, insert);
                    next += 1;
                }
            }
        }
    }

    /// May a lookup see insert `k`'s record? When it was stored, or may still be (pending).
    fn visible(&self, k: usize) -> bool {
        matches!(
            self.ops[k].ret,
            None | Some(CacheRet::Inserted(Inserted::Stored(_)))
        )
    }

    /// The lookups that returned, in history order.
    fn lookups(&self) -> impl Iterator<Item = ReturnedLookup<'h>> + 'h {
        self.ops
            .iter()
            .enumerate()
            .filter_map(|(index, op)| match (&op.op, &op.ret, op.returned) {
                (
                    CacheOp::Lookup { point, normal },
                    Some(CacheRet::Found { ids, torn }),
                    Some(end),
                ) => Some(ReturnedLookup {
                    index,
                    op,
                    point: *point,
                    normal: *normal,
                    ids,
                    torn: *torn,
                    end,
                }),
                _ => None,
            })
    }

    /// The inserted record behind an id that passed the phantom check: its insert's, or the
    /// pending insert's that adopted it.
    fn record_of(&self, id: RecordId) -> &'h Record {
        let ops = self.ops;
        let k = self.named.get(&id).or_else(|| self.adopted.get(&id));
        match k.map(|&k| &ops[k].op) {
            Some(CacheOp::Insert { record, .. }) => record,
            _ => unreachable!("{id} passed the phantom check"),
        }
    }

    /// Whether a removal selecting `record` began before `end`.
    fn removed_before(&self, record: &Record, end: u64) -> bool {
        self.removals
            .iter()
            .any(|&(k, sel, now)| self.ops[k].invoked < end && sel.selects(record, self.a, now))
    }

    /// Rules 1 and 5 and the whole-record rules: what lookup `l` returned (`ids`, sorted) is
    /// whole, returned once, genuine, not from the future and not resurrected.
    fn check_returned(&self, l: &ReturnedLookup<'_>, ids: &[RecordId]) -> Result<(), SetViolation> {
        let (lookup, ops) = (l.index, self.ops);
        if l.torn > 0 {
            return Err(SetViolation::Torn {
                lookup,
                count: l.torn,
            });
        }
        if let Some(pair) = ids.windows(2).find(|pair| pair[0] == pair[1]) {
            return Err(SetViolation::Duplicate {
                lookup,
                id: pair[0],
            });
        }
        for &id in ids {
            match self.named.get(&id) {
                Some(&insert) if !self.visible(insert) => {
                    return Err(SetViolation::Phantom { lookup, id });
                }
                Some(&insert) if ops[insert].invoked > l.end => {
                    return Err(SetViolation::FromTheFuture { lookup, insert, id });
                }
                Some(&insert) => {
                    let record = self.record_of(id);
                    for &(k, sel, now) in &self.removals {
                        let r = &ops[k];
                        if r.precedes(l.op)
                            && ops[insert].precedes(r)
                            && sel.selects(record, self.a, now)
                        {
                            return Err(SetViolation::Resurrected {
                                lookup,
                                removal: k,
                                id,
                            });
                        }
                    }
                }
                // Adopted by a pending insert invoked before every lookup returning it ended.
                None if self.adopted.contains_key(&id) => {}
                None => {
                    return Err(SetViolation::Phantom {
                        lookup: self.orphans[&id].1,
                        id,
                    });
                }
            }
        }
        Ok(())
    }

    /// Rules 2 and 4: lookup `l` (a valid query, returning `ids`, sorted) misses no stored record
    /// whose insert preceded it, and forgets none its thread saw earlier (`mine`), unless a
    /// removal selecting the record began before it ended.
    fn check_nothing_missed(
        &self,
        l: &ReturnedLookup<'_>,
        ids: &[RecordId],
        mine: &BTreeMap<RecordId, usize>,
    ) -> Result<(), SetViolation> {
        let (lookup, ops, a) = (l.index, self.ops, self.a);
        for &insert in &self.stored {
            let CacheOp::Insert { record, id } = &ops[insert].op else {
                unreachable!("only inserts are indexed")
            };
            let id = id.known().expect("a stored insert carries its id");
            if ops[insert].precedes(l.op)
                && ic::valid_weight(record, l.point, l.normal, a).is_some()
                && ids.binary_search(&id).is_err()
                && !self.removed_before(record, l.end)
            {
                return Err(SetViolation::Lost { lookup, insert, id });
            }
        }
        // Monotonic reads, except for a record a removal that began before this lookup ended
        // selects: it may have vanished legitimately (as for `Lost` above).
        for (&id, &earlier) in mine {
            let record = self.record_of(id);
            if ic::valid_weight(record, l.point, l.normal, a).is_some()
                && ids.binary_search(&id).is_err()
                && !self.removed_before(record, l.end)
            {
                return Err(SetViolation::Forgotten {
                    earlier,
                    later: lookup,
                    id,
                });
            }
        }
        Ok(())
    }
}

/// Rules 6 and 7 of [`check_set_consistency`]: the removals' counts against the records each could
/// have taken and the records they must have taken.
fn check_removal_counts(
    ops: &[super::Operation<CacheOp, CacheRet>],
    removals: &[(usize, Selection, u64)],
    stored: &[usize],
    visible: impl Fn(usize) -> bool,
    a: f32,
) -> Result<(), SetViolation> {
    let record = |k: usize| match &ops[k].op {
        CacheOp::Insert { record, .. } => record,
        _ => unreachable!("only inserts are indexed"),
    };
    // Inserts that may have stored a record: stored, or pending (named or not).
    let candidates: Vec<usize> = ops
        .iter()
        .enumerate()
        .filter(|(k, o)| matches!(o.op, CacheOp::Insert { .. }) && visible(*k))
        .map(|(k, _)| k)
        .collect();
    let mut could = std::collections::HashSet::new();
    let mut must = std::collections::HashSet::new();
    let mut total = 0;
    let mut all_returned = true;
    for &(k, sel, now) in removals {
        let r = &ops[k];
        let end = r.returned.unwrap_or(u64::MAX);
        let mine: Vec<usize> = candidates
            .iter()
            .copied()
            .filter(|&i| ops[i].invoked < end && sel.selects(record(i), a, now))
            .collect();
        could.extend(mine.iter().copied());
        must.extend(
            stored
                .iter()
                .copied()
                .filter(|&i| ops[i].precedes(r) && sel.selects(record(i), a, now)),
        );
        match r.ret {
            Some(CacheRet::Removed(n)) => {
                if n > mine.len() {
                    return Err(SetViolation::OverCounted {
                        removal: k,
                        count: n,
                        at_most: mine.len(),
                    });
                }
                total += n;
            }
            _ => all_returned = false,
        }
    }
    if all_returned && total > could.len() {
        return Err(SetViolation::CountedTwice {
            total,
            at_most: could.len(),
        });
    }
    if all_returned && total < must.len() {
        return Err(SetViolation::Uncounted {
            total,
            at_least: must.len(),
        });
    }
    Ok(())
}
