//! Linearizability checking: record concurrent histories, check them against a sequential
//! specification, and shrink and print the ones that fail.
//!
//! * **Recording.** A [`Recorder`] hands each worker its own [`ThreadLog`]; a worker stamps every
//!   operation at invocation and at return with a ticket from one global clock and appends it to
//!   its own buffer (no sharing on the hot path but the clock). [`Recorder::into_history`] merges
//!   the logs into a [`History`].
//! * **Linearizability.** [`check`] is Wing & Gong's search (*Testing and verifying concurrent
//!   objects*, JPDC 1993) in Lowe's just-in-time form with memoisation (*Testing for
//!   linearizability*, CCPE 2017): walk the history's events in real-time order; at an invocation,
//!   try to linearize that operation now (its result must be what the [`Specification`] answers);
//!   at the return of an operation not yet linearized, backtrack. Every configuration reached —
//!   (the set of linearized operations as a bitset, the specification's state) — is remembered,
//!   and a configuration met again is not explored again: that is what makes histories of a
//!   thousand operations checkable in milliseconds instead of never.
//! * **Set consistency.** [`check_set_consistency`] is the weaker property a cache may satisfy
//!   without being linearizable: every record a lookup returns was inserted by an insert that began
//!   before the lookup ended (a pending insert, whose id is unknown, may explain one record of its
//!   worker); every matching insert that returned before the lookup began is seen; a record a
//!   thread's lookup saw is seen by the thread's later lookups where it is valid (reads are
//!   monotonic per thread); nothing is torn or returned twice.
//! * **Failures** are shrunk by [`shrink`] to a history no single operation of which can be removed
//!   while it still fails, and printed by [`History::render`] with threads as columns and the longest
//!   partial linearization the search reached.
//!
//! # The clock
//!
//! The clock is a [`crate::sync::unchecked::AtomicU64`] advanced by `fetch_add(1, Relaxed)` at
//! every invocation and every return; its tickets order the events.
//!
//! * Under **shuttle** every schedule is sequentially consistent and only one thread runs between
//!   two schedule points; the clock (a std atomic, not a schedule point) is read in the same atomic
//!   step as the code around it, so ticket order is exactly the order in which the schedule ran the
//!   events: the real-time order linearizability speaks of.
//! * Under **loom** the clock is invisible to the model checker (a std atomic, not loom's), so it
//!   adds no happens-before edge and no interleaving: the checked code cannot be made correct by it.
//! * On **std threads** it is Relaxed, so it adds no happens-before edge either: an operation that
//!   returned before another was invoked (by ticket) does not thereby synchronise with it, and a
//!   cache that forgot an Acquire is not rescued by the recorder. The price: on weakly ordered
//!   hardware an operation's own memory accesses may drift across its tickets, so an interval may be
//!   recorded a little narrower than it was. On x86-64 (where this crate is measured) a locked
//!   read-modify-write is a full barrier, so the intervals are exact up to compiler reordering,
//!   which does not move code across the opaque cache calls in practice. A violation reported from a
//!   std run is confirmed by replaying it as a hand-built history or under shuttle.
//!
//! # For caches
//!
//! [`CacheSpec`] is the sequential specification (the set of stored records, answered by brute
//! force), [`RecordingHandle`] wraps any [`CacheHandle`](crate::cache::CacheHandle) and records
//! its inserts and lookups (an insert's record id is known only once it returns: [`InsertId`]),
//! [`check_set_consistency`] is the weaker check. Small specifications for
//! testing the checker itself are [`Register`] and [`IntSet`].
//!
//! ```
//! use glam::Vec3;
//! use wfic::cache::{CacheConfig, IrradianceCache, Locked};
//! use wfic::ic::{Record, WorkerId};
//! use wfic::research::lincheck::{check, CacheSpec, Recorder, RecordingHandle};
//!
//! # // Real threads: not under a model checker, whose primitives need its runtime.
//! # #[cfg(not(any(feature = "loom", feature = "shuttle")))] {
//! let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(10.0), 0.5).unwrap();
//! let cache: Locked = Locked::new(config);
//! let recorder = Recorder::new();
//! let logs = std::thread::scope(|s| {
//!     let workers: Vec<_> = (0..2)
//!         .map(|t| {
//!             let (cache, log) = (&cache, recorder.log(t));
//!             s.spawn(move || {
//!                 let mut h = RecordingHandle::new(cache.handle(WorkerId::new(t as u32)), log);
//!                 h.insert(Record::new(Vec3::splat(5.0), Vec3::Z, Vec3::ONE, 1.0)).unwrap();
//!                 h.lookup(Vec3::splat(5.0), Vec3::Z);
//!                 h.into_parts().1
//!             })
//!         })
//!         .collect();
//!     workers.into_iter().map(|w| w.join().unwrap()).collect::<Vec<_>>()
//! });
//! let history = recorder.into_history(logs);
//! assert!(check(&history, &CacheSpec::new(config)).is_ok());
//! # }
//! ```

mod cache;
mod models;

pub use cache::{
    check_set_consistency, lookup_observes, CacheOp, CacheRet, CacheSpec, InsertId,
    RecordingHandle, SetViolation,
};
pub use models::{IntSet, Register, RegisterOp, RegisterRet, SetOp};

use crate::sync::unchecked::{AtomicU64, Ordering};
use std::collections::{HashMap, HashSet};
use std::fmt::{self, Debug, Write as _};
use std::hash::Hash;
use std::sync::Arc;

/// A sequential specification: the object's state, and what each operation answers in it.
///
/// The state is `Hash + Eq` so the checker can remember which (linearized set, state) pairs it has
/// explored; keep it small and canonical (two states that answer every future operation alike
/// should compare equal).
pub trait Specification: Clone + Hash + Eq {
    /// An operation, with its arguments.
    type Op: Clone + Debug;
    /// What an operation returns.
    type Ret: Clone + Debug + PartialEq;

    /// Applies `op` to the state and returns its result.
    fn apply(&mut self, op: &Self::Op) -> Self::Ret;

    /// Applies `op` as an operation that returned `observed`; false when the specification cannot
    /// return `observed` here (the state is then unspecified: the checker discards it). The default
    /// compares [`apply`](Self::apply)'s answer; override it for operations whose outcome is a
    /// legitimate choice of the implementation (a WF insert that was `Discarded`).
    fn step(&mut self, op: &Self::Op, observed: &Self::Ret) -> bool {
        self.apply(op) == *observed
    }

    /// Applies `op` as a pending operation: one that was invoked and never returned, so its result
    /// is unknown, and it may take effect at any point after its invocation. The default applies
    /// it and ignores the answer; override it when the answer is part of what the operation does
    /// to the state (an insert whose record id is chosen by the implementation: the specification
    /// cannot know it).
    fn apply_pending(&mut self, op: &Self::Op) {
        self.apply(op);
    }

    /// True when `op`, having returned `ret`, observed the effect of `other` (a read of the value a
    /// write wrote, a lookup that returned the record an insert stored). The default says never.
    fn observes(op: &Self::Op, ret: &Self::Ret, other: &Self::Op) -> bool {
        let _ = (op, ret, other);
        false
    }

    /// For [`shrink`]: edits `ret`, the result of `op`, to what it would have been had `removed`
    /// never run, and returns true; or returns false when that cannot be said, and `op` must be
    /// removed with `removed`. The default keeps `op` unchanged unless it
    /// [observes](Self::observes) `removed`, so a shrunk history never fails merely because
    /// something reads what nobody wrote. A set-like object whose elements are independent can do
    /// better: drop the removed element from the result.
    fn forget(op: &Self::Op, ret: &mut Self::Ret, removed: &Self::Op) -> bool {
        !Self::observes(op, ret, removed)
    }
}

/// One operation of a history: who ran it, what it was, what it returned and when.
#[derive(Clone, Debug, PartialEq)]
pub struct Operation<O, R> {
    /// The thread (column) that ran it.
    pub thread: usize,
    /// The operation and its arguments.
    pub op: O,
    /// Its result; `None` while pending (it never returned).
    pub ret: Option<R>,
    /// Clock ticket taken at invocation.
    pub invoked: u64,
    /// Clock ticket taken at return; `None` while pending.
    pub returned: Option<u64>,
}

impl<O, R> Operation<O, R> {
    /// True when `self` returned before `other` was invoked (real-time order).
    pub fn precedes(&self, other: &Self) -> bool {
        self.returned.is_some_and(|r| r < other.invoked)
    }
}

/// A concurrent history: operations sorted by invocation ticket.
///
/// Invariants: tickets are unique; an operation returns after it is invoked; a thread invokes an
/// operation only after its previous one returned.
#[derive(Clone, Debug, PartialEq)]
pub struct History<O, R> {
    ops: Vec<Operation<O, R>>,
}

impl<O, R> Default for History<O, R> {
    fn default() -> Self {
        Self { ops: Vec::new() }
    }
}

impl<O, R> History<O, R> {
    /// A history of `ops` (any order).
    ///
    /// # Panics
    /// When the invariants are broken: a ticket used twice, a return before its invocation, or a
    /// thread with two operations in flight.
    pub fn from_operations(mut ops: Vec<Operation<O, R>>) -> Self {
        ops.sort_by_key(|o| o.invoked);
        let mut seen = HashSet::with_capacity(ops.len() * 2);
        let mut last: HashMap<usize, Option<u64>> = HashMap::new();
        for o in &ops {
            assert!(seen.insert(o.invoked), "ticket {} used twice", o.invoked);
            if let Some(r) = o.returned {
                assert!(
                    r > o.invoked,
                    "operation returns at {r} before its invocation"
                );
                assert!(seen.insert(r), "ticket {r} used twice");
            }
            assert_eq!(
                o.ret.is_some(),
                o.returned.is_some(),
                "result without return"
            );
            if let Some(prev) = last.insert(o.thread, o.returned) {
                assert!(
                    prev.is_some_and(|p| p < o.invoked),
                    "thread {} invokes at {} with an operation in flight",
                    o.thread,
                    o.invoked
                );
            }
        }
        Self { ops }
    }

    /// The operations, by invocation order. Indices into this slice name operations everywhere
    /// in this module.
    pub fn operations(&self) -> &[Operation<O, R>] {
        &self.ops
    }

    /// Number of operations.
    pub fn len(&self) -> usize {
        self.ops.len()
    }

    /// True when there are no operations.
    pub fn is_empty(&self) -> bool {
        self.ops.is_empty()
    }

    /// Number of threads (one more than the largest thread number).
    pub fn threads(&self) -> usize {
        self.ops.iter().map(|o| o.thread + 1).max().unwrap_or(0)
    }
}

impl<O: Clone, R: Clone> History<O, R> {
    /// The sub-history of the operations whose index `keep` accepts (tickets unchanged).
    pub fn filter(&self, mut keep: impl FnMut(usize) -> bool) -> Self {
        Self {
            ops: (0..self.ops.len())
                .filter(|&i| keep(i))
                .map(|i| self.ops[i].clone())
                .collect(),
        }
    }
}

/// Builds a history by hand, one event at a time, in real-time order.
///
/// ```
/// use wfic::research::lincheck::{check, HistoryBuilder, Register, RegisterOp::*, RegisterRet::*};
/// // The classic stale read: the write returned before the read began, yet the read missed it.
/// let h = HistoryBuilder::new()
///     .call(0, Write(1), Done)
///     .call(1, Read, Value(0))
///     .build();
/// assert!(check(&h, &Register::default()).is_err());
/// ```
#[derive(Debug)]
pub struct HistoryBuilder<O, R> {
    time: u64,
    ops: Vec<Operation<O, R>>,
    open: HashMap<usize, usize>,
}

impl<O, R> Default for HistoryBuilder<O, R> {
    fn default() -> Self {
        Self {
            time: 0,
            ops: Vec::new(),
            open: HashMap::new(),
        }
    }
}

impl<O, R> HistoryBuilder<O, R> {
    /// An empty history.
    pub fn new() -> Self {
        Self::default()
    }

    /// `thread` invokes `op` now.
    ///
    /// # Panics
    /// When `thread` already has an operation in flight.
    pub fn invoke(mut self, thread: usize, op: O) -> Self {
        let i = self.ops.len();
        assert!(
            self.open.insert(thread, i).is_none(),
            "thread {thread} already has an operation in flight"
        );
        self.ops.push(Operation {
            thread,
            op,
            ret: None,
            invoked: self.time,
            returned: None,
        });
        self.time += 1;
        self
    }

    /// `thread`'s operation in flight returns `ret` now.
    ///
    /// # Panics
    /// When `thread` has no operation in flight.
    pub fn ret(mut self, thread: usize, ret: R) -> Self {
        let i = self
            .open
            .remove(&thread)
            .unwrap_or_else(|| panic!("thread {thread} has no operation in flight"));
        self.ops[i].ret = Some(ret);
        self.ops[i].returned = Some(self.time);
        self.time += 1;
        self
    }

    /// `thread` invokes `op`, which returns `ret` at once.
    pub fn call(self, thread: usize, op: O, ret: R) -> Self {
        self.invoke(thread, op).ret(thread, ret)
    }

    /// The history (operations still in flight stay pending).
    pub fn build(self) -> History<O, R> {
        History::from_operations(self.ops)
    }
}

/// Hands out per-thread logs that share one clock, and merges them back into a history.
///
/// `Sync`, and the logs are `Send + 'static`, so it works with std, loom and shuttle threads
/// alike: it uses no primitive of the [`sync`](crate::sync) facade (see the module docs for why
/// the clock must not be one).
#[derive(Debug, Default)]
pub struct Recorder {
    /// The global clock. A std `Arc` and atomic on purpose: invisible to the model checkers.
    clock: Arc<AtomicU64>,
}

impl Recorder {
    /// A recorder whose clock starts at zero.
    pub fn new() -> Self {
        Self::default()
    }

    /// A log for `thread` (use each thread number once per history).
    pub fn log<O, R>(&self, thread: usize) -> ThreadLog<O, R> {
        ThreadLog {
            clock: Arc::clone(&self.clock),
            thread,
            ops: Vec::new(),
        }
    }

    /// Merges the logs of one run into a history.
    ///
    /// # Panics
    /// When a log came from another recorder, or two logs share a thread number.
    pub fn into_history<O, R>(
        &self,
        logs: impl IntoIterator<Item = ThreadLog<O, R>>,
    ) -> History<O, R> {
        let mut ops = Vec::new();
        let mut threads = HashSet::new();
        for log in logs {
            assert!(
                Arc::ptr_eq(&log.clock, &self.clock),
                "thread {}'s log belongs to another recorder",
                log.thread
            );
            assert!(
                threads.insert(log.thread),
                "two logs for thread {}",
                log.thread
            );
            ops.extend(log.ops);
        }
        History::from_operations(ops)
    }
}

/// One thread's log: owned by the thread, so appending to it shares nothing.
#[derive(Debug)]
pub struct ThreadLog<O, R> {
    clock: Arc<AtomicU64>,
    thread: usize,
    ops: Vec<Operation<O, R>>,
}

impl<O, R> ThreadLog<O, R> {
    /// The next clock ticket.
    #[inline]
    fn tick(&self) -> u64 {
        // Relaxed: the ticket only has to be unique and in execution order; it must not
        // synchronise anything (see the module docs: a recorder that created happens-before edges
        // could hide the very bugs it is recording).
        self.clock.fetch_add(1, Ordering::Relaxed)
    }

    /// The thread this log records.
    pub fn thread(&self) -> usize {
        self.thread
    }

    /// Reserves room for `n` more operations (to keep allocation out of a timed run).
    pub fn reserve(&mut self, n: usize) {
        self.ops.reserve(n);
    }

    /// Records the invocation of `op`: call it immediately before the operation starts.
    ///
    /// # Panics
    /// When the previous operation has not returned.
    #[inline]
    pub fn invoke(&mut self, op: O) {
        assert!(
            self.ops.last().map_or(true, |o| o.returned.is_some()),
            "thread {} invokes with an operation in flight",
            self.thread
        );
        let invoked = self.tick();
        self.ops.push(Operation {
            thread: self.thread,
            op,
            ret: None,
            invoked,
            returned: None,
        });
    }

    /// The operation in flight, to complete its description with what only its return reveals
    /// (the id a cache gave a record). `None` when nothing is in flight.
    pub fn pending_op_mut(&mut self) -> Option<&mut O> {
        self.ops
            .last_mut()
            .filter(|o| o.returned.is_none())
            .map(|o| &mut o.op)
    }

    /// Records the return of the operation in flight: call it immediately after it returns.
    ///
    /// # Panics
    /// When nothing is in flight.
    #[inline]
    pub fn ret(&mut self, ret: R) {
        let returned = self.tick();
        let thread = self.thread;
        let op = self
            .ops
            .last_mut()
            .filter(|o| o.returned.is_none())
            .unwrap_or_else(|| panic!("thread {thread} returns with nothing in flight"));
        op.ret = Some(ret);
        op.returned = Some(returned);
    }

    /// Operations recorded so far.
    pub fn len(&self) -> usize {
        self.ops.len()
    }

    /// True when nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.ops.is_empty()
    }
}

/// A linearization: operation indices in the order they take effect.
pub type Linearization = Vec<usize>;

/// Why a history is not linearizable: how far the search got.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NotLinearizable {
    /// The longest sequence of operations the search linearized (a valid sequential run of the
    /// specification, respecting real-time order) before it had to backtrack for good; of several
    /// as long, the first the search reached (it tries operations in invocation order).
    pub longest: Linearization,
    /// The operations that could have come next after `longest` (every operation invoked before the
    /// first return among those not linearized): none of them could be, or each led to a dead end.
    pub stuck: Vec<usize>,
    /// Configurations explored.
    pub steps: u64,
}

/// Per-operation set of linearized operations, compared and hashed word by word.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct Bitset(Box<[u64]>);

impl Bitset {
    fn new(n: usize) -> Self {
        Self(vec![0; n.div_ceil(64)].into_boxed_slice())
    }
    fn set(&mut self, i: usize) {
        self.0[i / 64] |= 1 << (i % 64);
    }
    fn clear(&mut self, i: usize) {
        self.0[i / 64] &= !(1 << (i % 64));
    }
}

/// Checks that `history` is linearizable with respect to the specification starting in `init`.
///
/// Pending operations (no return) may take effect at any point after their invocation, or never;
/// their result is not compared (they are applied by [`Specification::apply_pending`]). Returns a
/// linearization, or how far the search got.
pub fn check<S: Specification>(
    history: &History<S::Op, S::Ret>,
    init: &S,
) -> Result<Linearization, NotLinearizable> {
    let ops = history.operations();
    let n = ops.len();
    // The event list: node 0 is the head; op i has its call at 1 + 2i and its return at 2 + 2i.
    // Dancing links (Knuth): a lifted node keeps its own links, so lifts are undone in reverse.
    const NIL: usize = usize::MAX;
    let call = |i: usize| 1 + 2 * i;
    let ret = |i: usize| 2 + 2 * i;
    let mut events: Vec<(u64, usize)> = Vec::with_capacity(2 * n);
    for (i, o) in ops.iter().enumerate() {
        events.push((o.invoked, call(i)));
        // A pending operation returns after everything else.
        events.push((o.returned.unwrap_or(u64::MAX), ret(i)));
    }
    events.sort_unstable();
    let mut next = vec![NIL; 2 * n + 1];
    let mut prev = vec![NIL; 2 * n + 1];
    let mut last = 0;
    for &(_, node) in &events {
        next[last] = node;
        prev[node] = last;
        last = node;
    }
    let lift = |next: &mut Vec<usize>, prev: &mut Vec<usize>, node: usize| {
        let (p, q) = (prev[node], next[node]);
        next[p] = q;
        if q != NIL {
            prev[q] = p;
        }
    };
    let unlift = |next: &mut Vec<usize>, prev: &mut Vec<usize>, node: usize| {
        let (p, q) = (prev[node], next[node]);
        next[p] = node;
        if q != NIL {
            prev[q] = node;
        }
    };

    let mut state = init.clone();
    let mut linearized = Bitset::new(n);
    let mut memo: HashSet<(Bitset, S)> = HashSet::new();
    let mut stack: Vec<(usize, S)> = Vec::with_capacity(n);
    let mut longest: Linearization = Vec::new();
    let mut steps = 0u64;
    let mut node = next[0];
    loop {
        if next[0] == NIL {
            return Ok(stack.into_iter().map(|(i, _)| i).collect());
        }
        debug_assert_ne!(node, NIL, "a return always follows its call");
        let i = (node - 1) / 2;
        if node == call(i) {
            steps += 1;
            let mut after = state.clone();
            let ok = match &ops[i].ret {
                Some(r) => after.step(&ops[i].op, r),
                None => {
                    after.apply_pending(&ops[i].op);
                    true
                }
            };
            if ok {
                linearized.set(i);
                if memo.insert((linearized.clone(), after.clone())) {
                    stack.push((i, std::mem::replace(&mut state, after)));
                    lift(&mut next, &mut prev, call(i));
                    lift(&mut next, &mut prev, ret(i));
                    if stack.len() > longest.len() {
                        longest = stack.iter().map(|&(j, _)| j).collect();
                    }
                    node = next[0];
                    continue;
                }
                linearized.clear(i);
            }
            node = next[node];
        } else {
            // The return of an operation not linearized yet: it must have taken effect by now.
            let Some((j, before)) = stack.pop() else {
                let stuck = stuck_after(history, &longest);
                return Err(NotLinearizable {
                    longest,
                    stuck,
                    steps,
                });
            };
            state = before;
            linearized.clear(j);
            unlift(&mut next, &mut prev, ret(j));
            unlift(&mut next, &mut prev, call(j));
            node = next[call(j)];
        }
    }
}

/// The operations that could come next after the linearized prefix `done`.
fn stuck_after<O, R>(history: &History<O, R>, done: &[usize]) -> Vec<usize> {
    let ops = history.operations();
    let mut taken = vec![false; ops.len()];
    done.iter().for_each(|&i| taken[i] = true);
    let horizon = (0..ops.len())
        .filter(|&i| !taken[i])
        .filter_map(|i| ops[i].returned)
        .min()
        .unwrap_or(u64::MAX);
    (0..ops.len())
        .filter(|&i| !taken[i] && ops[i].invoked < horizon)
        .collect()
}

/// Shrinks a failing history to one from which no single operation can be removed while
/// `fails` still holds (a local minimum; the search removes whole thread suffixes first, then
/// chunks of halving size, then single operations, until nothing more can go).
///
/// Removing an operation makes the others [forget](Specification::forget) it: the cache's lookups
/// drop the removed record from their results; a register's reads of a removed write are removed
/// too. So the result never fails merely because something reads what nobody wrote; it is the
/// observed history projected onto fewer operations.
///
/// # Panics
/// When `fails(history)` is false.
pub fn shrink<S: Specification>(
    history: &History<S::Op, S::Ret>,
    mut fails: impl FnMut(&History<S::Op, S::Ret>) -> bool,
) -> History<S::Op, S::Ret> {
    assert!(fails(history), "shrink needs a failing history");
    let mut h = history.clone();
    // Removes `drop` from `h`, making the others forget them (or removing them too, transitively).
    let without = |h: &History<S::Op, S::Ret>, drop: &[usize]| {
        let mut ops = h.operations().to_vec();
        let mut gone = vec![false; ops.len()];
        let mut work: Vec<usize> = drop.to_vec();
        while let Some(i) = work.pop() {
            if std::mem::replace(&mut gone[i], true) {
                continue;
            }
            let removed = ops[i].op.clone();
            for (j, o) in ops.iter_mut().enumerate() {
                if gone[j] {
                    continue;
                }
                if let Some(r) = o.ret.as_mut() {
                    if !S::forget(&o.op, r, &removed) {
                        work.push(j);
                    }
                }
            }
        }
        History {
            ops: ops
                .into_iter()
                .zip(gone)
                .filter_map(|(o, g)| (!g).then_some(o))
                .collect(),
        }
    };
    // 1. Thread suffixes, longest first.
    for t in 0..h.threads() {
        let mine: Vec<usize> = (0..h.len())
            .filter(|&i| h.operations()[i].thread == t)
            .collect();
        for k in 0..mine.len() {
            let candidate = without(&h, &mine[k..]);
            if fails(&candidate) {
                h = candidate;
                break;
            }
        }
    }
    // 2. Chunks of halving size, down to single operations, until a pass changes nothing.
    loop {
        let before = h.len();
        let mut size = (h.len() / 2).max(1);
        loop {
            let mut start = 0;
            while start < h.len() {
                let chunk: Vec<usize> = (start..(start + size).min(h.len())).collect();
                // The chunk is never empty (start < len), so the candidate is always shorter.
                let candidate = without(&h, &chunk);
                if fails(&candidate) {
                    h = candidate;
                } else {
                    start += size;
                }
            }
            if size == 1 {
                break;
            }
            size /= 2;
        }
        if h.len() == before {
            return h;
        }
    }
}

/// Shrinks a history that is not linearizable against `init` (see [`shrink`]) and returns it with
/// the checker's verdict on it.
pub fn shrink_nonlinearizable<S: Specification>(
    history: &History<S::Op, S::Ret>,
    init: &S,
) -> (History<S::Op, S::Ret>, NotLinearizable) {
    let small = shrink::<S>(history, |h| check(h, init).is_err());
    let failure = check(&small, init).expect_err("the shrunk history still fails");
    (small, failure)
}

impl<O: Debug, R: Debug> History<O, R> {
    /// The history as a table: one column per thread, one row per event in real-time order
    /// (`#k` names operation `k`). With `failure`, followed by the longest partial linearization
    /// and the operations that could not extend it.
    pub fn render(&self, failure: Option<&NotLinearizable>) -> String {
        let threads = self.threads();
        let mut rows: Vec<(u64, usize, String)> = Vec::new();
        for (k, o) in self.ops.iter().enumerate() {
            rows.push((o.invoked, o.thread, format!("#{k} {:?}", o.op)));
            if let (Some(r), Some(t)) = (&o.ret, o.returned) {
                rows.push((t, o.thread, format!("#{k} -> {r:?}")));
            }
        }
        rows.sort_by_key(|r| r.0);
        let width = rows
            .iter()
            .map(|r| r.2.chars().count())
            .max()
            .unwrap_or(0)
            .clamp(10, 100);
        let mut out = String::new();
        let cell = |s: &str| {
            if s.chars().count() > width {
                let s: String = s.chars().take(width - 3).collect();
                format!("{s}...")
            } else {
                format!("{s:<width$}")
            }
        };
        let line: Vec<String> = (0..threads).map(|t| cell(&format!("thread {t}"))).collect();
        let _ = writeln!(out, "{}", line.join(" | ").trim_end());
        let _ = writeln!(
            out,
            "{}",
            vec!["-".repeat(width); threads].join("-+-").trim_end()
        );
        for (_, t, text) in &rows {
            let line: Vec<String> = (0..threads)
                .map(|c| cell(if c == *t { text } else { "" }))
                .collect();
            let _ = writeln!(out, "{}", line.join(" | ").trim_end());
        }
        if let Some(f) = failure {
            let _ = writeln!(
                out,
                "not linearizable: longest partial linearization ({} of {} operations):",
                f.longest.len(),
                self.len()
            );
            for &k in &f.longest {
                let o = &self.ops[k];
                let _ = writeln!(out, "  #{k} (thread {}) {}", o.thread, describe(o));
            }
            let _ = writeln!(out, "and none of these can come next:");
            for &k in &f.stuck {
                let o = &self.ops[k];
                let _ = writeln!(out, "  #{k} (thread {}) {}", o.thread, describe(o));
            }
        }
        out
    }
}

/// `op -> ret`, or `op (pending)`.
fn describe<O: Debug, R: Debug>(o: &Operation<O, R>) -> String {
    match &o.ret {
        Some(r) => format!("{:?} -> {r:?}", o.op),
        None => format!("{:?} (pending)", o.op),
    }
}

impl fmt::Display for NotLinearizable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "not linearizable: {} operations linearized at most, stuck before {:?} ({} steps)",
            self.longest.len(),
            self.stuck,
            self.steps
        )
    }
}

impl std::error::Error for NotLinearizable {}

#[cfg(test)]
mod tests;

#[cfg(all(test, feature = "shuttle"))]
mod shuttle_tests;
