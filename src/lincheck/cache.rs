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
//! [`BruteForce::valid_records`]: crate::cache::BruteForce::valid_records

use super::{History, Specification, ThreadLog};
use crate::cache::{CacheConfig, CacheHandle, Inserted};
use crate::ic::{self, InsertError, Record, RecordId};
use glam::Vec3;
use std::collections::HashMap;
use std::fmt;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

/// A cache operation.
#[derive(Clone, Copy, PartialEq)]
pub enum CacheOp {
    /// Insert a record. Recorded with the id the cache gave it (sealed), once the insert returned.
    Insert(Record),
    /// Ask which records are valid at a point with a normal.
    Lookup {
        /// The query point.
        point: Vec3,
        /// The query's unit normal.
        normal: Vec3,
    },
}

impl fmt::Debug for CacheOp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Insert(r) => write!(
                f,
                "insert {} ({:.2},{:.2},{:.2}) R={:.2}",
                r.id(),
                r.position.x,
                r.position.y,
                r.position.z,
                r.radius
            ),
            Self::Lookup { point, .. } => {
                write!(f, "lookup ({:.2},{:.2},{:.2})", point.x, point.y, point.z)
            }
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
        }
    }
}

/// The sequential cache: the set of stored records. Equality and hashing look at the ids only
/// (a record's id determines it within one history).
#[derive(Clone, Debug)]
pub struct CacheSpec {
    config: CacheConfig,
    /// Sorted by id, no duplicates.
    records: Arc<Vec<Record>>,
}

impl CacheSpec {
    /// An empty cache with `config`'s bounds and accuracy.
    pub fn new(config: CacheConfig) -> Self {
        Self {
            config,
            records: Arc::new(Vec::new()),
        }
    }

    /// The records stored, sorted by id.
    pub fn records(&self) -> &[Record] {
        &self.records
    }

    /// Ids of the stored records valid at `point`/`normal`, sorted.
    pub fn valid_ids(&self, point: Vec3, normal: Vec3) -> Vec<RecordId> {
        ic::valid_among(self.records.iter(), point, normal, self.config.accuracy())
            .map(Record::id)
            .collect()
    }
}

impl PartialEq for CacheSpec {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.records, &other.records)
            || self
                .records
                .iter()
                .map(Record::id)
                .eq(other.records.iter().map(Record::id))
    }
}

impl Eq for CacheSpec {}

impl Hash for CacheSpec {
    fn hash<H: Hasher>(&self, state: &mut H) {
        state.write_usize(self.records.len());
        self.records.iter().for_each(|r| r.id().hash(state));
    }
}

impl Specification for CacheSpec {
    type Op = CacheOp;
    type Ret = CacheRet;

    fn apply(&mut self, op: &CacheOp) -> CacheRet {
        match op {
            CacheOp::Insert(r) => {
                if let Err(e) = self.config.check(r) {
                    return CacheRet::Rejected(e);
                }
                if let Err(at) = self.records.binary_search_by_key(&r.id(), Record::id) {
                    Arc::make_mut(&mut self.records).insert(at, *r);
                }
                CacheRet::Inserted(Inserted::Stored(r.id()))
            }
            CacheOp::Lookup { point, normal } => CacheRet::Found {
                ids: self.valid_ids(*point, *normal),
                torn: 0,
            },
        }
    }

    fn step(&mut self, op: &CacheOp, observed: &CacheRet) -> bool {
        match (op, observed) {
            // The cache's policy chose not to store it: a no-op, as long as the record was valid.
            (CacheOp::Insert(r), CacheRet::Inserted(Inserted::Discarded(id))) => {
                *id == r.id() && self.config.check(r).is_ok()
            }
            // A model-checking capacity limit (loom only): a no-op.
            #[cfg(feature = "loom")]
            (CacheOp::Insert(_), CacheRet::Rejected(InsertError::ListFull)) => true,
            _ => self.apply(op) == *observed,
        }
    }

    fn observes(op: &CacheOp, ret: &CacheRet, other: &CacheOp) -> bool {
        lookup_observes(op, ret, other)
    }

    /// Records are independent: a lookup that saw a removed insert's record keeps the rest.
    fn forget(op: &CacheOp, ret: &mut CacheRet, removed: &CacheOp) -> bool {
        if let (CacheOp::Lookup { .. }, CacheRet::Found { ids, .. }, CacheOp::Insert(r)) =
            (op, &mut *ret, removed)
        {
            ids.retain(|&id| id != r.id());
        }
        true
    }
}

/// True when `op` is a lookup whose result `ret` contains the record `other` inserted.
pub fn lookup_observes(op: &CacheOp, ret: &CacheRet, other: &CacheOp) -> bool {
    match (op, ret, other) {
        (CacheOp::Lookup { .. }, CacheRet::Found { ids, .. }, CacheOp::Insert(r)) => {
            ids.binary_search(&r.id()).is_ok()
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
        self.log.invoke(CacheOp::Insert(record));
        let result = self.handle.insert(record);
        match result {
            Ok(outcome) => {
                if let Some(op) = self.log.pending_op_mut() {
                    // The id is assigned inside the insert: describe the op with it.
                    *op = CacheOp::Insert(record.sealed(outcome.id()));
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

    /// The wrapped handle (operations through it are not recorded).
    pub fn handle(&mut self) -> &mut H {
        &mut self.handle
    }

    /// The handle and the log, for [`Recorder::into_history`](super::Recorder::into_history) and
    /// [`CacheHandle::finish`].
    pub fn into_parts(self) -> (H, ThreadLog<CacheOp, CacheRet>) {
        (self.handle, self.log)
    }
}

/// How a cache history broke set consistency (operation indices into the history).
#[derive(Clone, Debug, PartialEq)]
pub enum SetViolation {
    /// A lookup returned a record no insert of the history stored.
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
            Self::Duplicate { lookup, id } => {
                write!(f, "lookup #{lookup} returned {id} more than once")
            }
            Self::Torn { lookup, count } => write!(f, "lookup #{lookup} met {count} torn records"),
        }
    }
}

impl std::error::Error for SetViolation {}

/// Checks the set-consistency of a cache history: for every lookup that returned,
///
/// 1. every record it returned was stored by an insert of the history that began before the
///    lookup ended (no phantom, nothing from the future; a `Discarded` record is a phantom);
/// 2. every record valid at its query whose insert returned `Stored` before the lookup began is
///    among those returned (nothing lost);
/// 3. it met no torn record, and returned no record twice.
///
/// Pending lookups are not checked; a pending insert cannot be matched (its id is unknown), so a
/// record seen from one is reported as a phantom.
pub fn check_set_consistency(
    history: &History<CacheOp, CacheRet>,
    config: &CacheConfig,
) -> Result<(), SetViolation> {
    let ops = history.operations();
    let mut stored: HashMap<RecordId, usize> = HashMap::new();
    let mut inserts = Vec::new();
    for (k, o) in ops.iter().enumerate() {
        if let (CacheOp::Insert(r), Some(CacheRet::Inserted(Inserted::Stored(id)))) =
            (&o.op, &o.ret)
        {
            debug_assert_eq!(r.id(), *id);
            stored.insert(*id, k);
            inserts.push(k);
        }
    }
    let a = config.accuracy();
    for (lookup, o) in ops.iter().enumerate() {
        let (CacheOp::Lookup { point, normal }, Some(CacheRet::Found { ids, torn }), Some(end)) =
            (&o.op, &o.ret, o.returned)
        else {
            continue;
        };
        if *torn > 0 {
            return Err(SetViolation::Torn {
                lookup,
                count: *torn,
            });
        }
        // The recorder sorts the ids (and keeps duplicates); sort a copy anyway, so that a
        // hand-built result in another order is judged the same.
        let mut ids = ids.clone();
        ids.sort_unstable();
        if let Some(pair) = ids.windows(2).find(|pair| pair[0] == pair[1]) {
            return Err(SetViolation::Duplicate {
                lookup,
                id: pair[0],
            });
        }
        for &id in &ids {
            let Some(&insert) = stored.get(&id) else {
                return Err(SetViolation::Phantom { lookup, id });
            };
            if ops[insert].invoked > end {
                return Err(SetViolation::FromTheFuture { lookup, insert, id });
            }
        }
        if !ic::is_valid_query(*point, *normal) {
            continue;
        }
        for &insert in &inserts {
            let CacheOp::Insert(r) = &ops[insert].op else {
                unreachable!("only inserts are indexed")
            };
            let id = r.id();
            if ops[insert].precedes(o)
                && ic::valid_weight(r, *point, *normal, a).is_some()
                && ids.binary_search(&id).is_err()
            {
                return Err(SetViolation::Lost { lookup, insert, id });
            }
        }
    }
    Ok(())
}
