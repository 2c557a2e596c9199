//! WF: the wait-free shared irradiance cache (paper §3.3, Listing 6), done right.
//!
//! Each node holds an occupancy mask, an append-only record list (`list.rs`) and eight child
//! pointers. A lookup reads the mask and the list's head first (32 bytes), the keys of the list's
//! records next (32 bytes each), a record only when its key passes the query's prefilter, and a
//! child pointer only when the mask says that child is published and its loose cell holds the
//! query point.
//!
//! * **Insert** walks from the root towards the node that fits the record (the same placement as
//!   every other cache, [`crate::research::Geometry`]). When a child on the way is missing, the whole rest of
//!   the path — the missing child, its descendants down to the target depth, and the record in the
//!   last of them — is built privately and published with *one* compare-and-swap of the parent's
//!   child pointer (Listing 6, lines 7–15). If another thread published that child first:
//!   - [`CasFailure::Discard`] (the paper): the private subtree and the record are dropped and
//!     counted; the caller still uses the sample for its pixel.
//!   - [`CasFailure::Adopt`]: the private subtree is dropped and the walk continues into the
//!     winner's child, where the record is stored. No sample is lost, as in Mitsuba 0.6's
//!     lock-free octree.
//! * **Lookup** reads masks, child pointers and published slots only: no read-modify-write, no
//!   fence, no store (unless the [`ReadFence`](crate::research::orderings::ReadFence) policy asks for the paper's avoided barrier).
//! * **The mask** has two rules: no record is stored below a child whose bit is clear, and no bit
//!   is set before its child is published. The publisher of a child sets its bit right after the
//!   compare-and-swap, and any insert that walks into a child sets it first if it does not see it
//!   set (one `fetch_or`, never retried), so a lookup that happens-after an insert sees every bit
//!   on the record's path. The `fetch_or` is Release and the lookup's load of the mask Acquire, so
//!   a bit a lookup sees carries its child: the lookup follows the pointer without a null check.
//!
//! **Wait-freedom, exactly.** No operation loops on a condition another thread controls: every
//! loop is over the tree's levels, a node's eight children, or a list's slots, and no
//! compare-and-swap is ever retried. What bounds each part of an insert:
//!
//! * *By a constant* ([`MAX_DEPTH`] = 16): the descent (one Acquire load
//!   per level) and the child compare-and-swaps (at most one per level: a lost one moves the insert
//!   one level down, into the winner's child, or ends it under `Discard`). These are the `steps`
//!   counted in [`WorkerStats::max_insert_steps`](super::WorkerStats), at most `2 * depth`; that
//!   bound is true by construction (`steps` counts the loop's iterations), so the tests that assert
//!   it guard the counting, not the algorithm. A graft builds `depth - level + 1 <= 16` fresh
//!   nodes (each initialises 8 child pointers and an empty list) and one first segment; a lost race
//!   frees exactly those and, under `Adopt`, may graft again one level further down. The worst
//!   case, a race lost at every level, builds and frees `depth (depth + 1) / 2 <= 136` nodes and 16
//!   segments: a constant, if a large one.
//! * *By the list's size*: the push is one `fetch_add`, one segment load, one write and one store,
//!   plus, for the insert whose index opens segment `s`, allocating and initialising that
//!   segment's `4 * 2^s` slots (about as many as the list already holds) and one compare-and-swap.
//!   Amortised over the inserts that fill the segment this is constant, but a single insert's worst
//!   case grows with the list: WF is wait-free with a bound that depends on the size of the
//!   structure, not on other threads (bounded, not population-oblivious, wait-freedom).
//! * *By the allocator*: `Box::new` and the frees go through the global allocator, which is not
//!   wait-free (glibc's malloc takes an arena lock when its per-thread cache misses). Only an
//!   insert that grafts a path (at most 17 blocks per graft, see above) or opens a segment (one
//!   block) allocates; every other insert, and every lookup, allocates nothing. So the claim is
//!   "wait-free given a wait-free allocator", as for any wait-free structure that allocates.
//!
//! A lookup makes no read-modify-write and retries nothing: it visits the root and, per level,
//! only nodes whose loose cell holds the query point (at most 27 per level, a property of the loose
//! octree's geometry), and reads each visited list once, up to the head it loaded. Its work is
//! bounded by the nodes and records present, never by what other threads do.
//!
//! **Removal** ([`CacheHandle::remove`]) runs during a frame, beside lookups and inserts: it walks
//! the nodes whose loose cells the selection may reach, as a lookup walks (the same mask loads, so
//! it meets every record whose insert happens-before it), and takes each selected live record with
//! one compare-and-swap of its slot's state, never retried (`list.rs`, 4). It is wait-free by the
//! lookup's argument: its work is bounded by the nodes and slots present.
//!
//! **Memory** is reclaimed only with `&mut` access: nothing is ever unlinked or freed while the
//! cache is shared, so no reader can meet freed memory and no epoch scheme is needed. When a frame
//! closes ([`IrradianceCache::end_frame`]), every list that opened its second or a later segment
//! past its first block in that frame (each handle notes the lists its inserts made grow so, so
//! the close need not walk the tree) and has more than a sixteenth of its slots unused is rebuilt
//! as one block of its records and a sixteenth (`list.rs`, 5). When
//! records were removed in the frame, and after a removal between frames
//! ([`IrradianceCache::remove`]), the close walks the whole tree instead: every list holding a
//! removed record is rebuilt from its live records the same way, and every subtree left with none
//! is freed (its bit cleared: the only place a mask bit is ever cleared). A cache that removes what
//! it inserts, frame after frame, holds memory bounded by its live records and the tree over
//! them; between frames a list's unused slots are at most a sixteenth of its records, or the
//! seven of one segment of eight, or the three of a first segment of four.
//!
//! **Where the nodes lie.** A graft boxes its nodes one by one, so the allocator scatters them
//! among the lists' blocks. A frame's close that finds the nodes boxed since the last move, or
//! freed in the slab since, at least a quarter of the slab moves every node below the root into
//! one fresh slab in breadth-first order (`WaitFree::relocate`): a node's children side by side,
//! the upper levels in a few pages, as the sequential octree's arena keeps them. Each move is
//! paid for by the quarter of new or freed nodes before it, so a node is moved a constant number
//! of times on average, and the slab's unused places stay under a quarter of it. Nodes are still
//! owned through their parents' pointers; the slab holds only their memory, and a node's
//! `in_slab` flag says whether freeing it frees a box or only drops it in place.

mod list;
pub(crate) mod orderings;

use super::deterministic::Visibility;
use super::frame::{collect_valid, HandleCore, Ledger, Local, Work};
use super::octree::{Cell, Octant, MAX_DEPTH};
use super::{
    CacheConfig, CacheHandle, CacheStats, FrameReport, Inserted, IrradianceCache, Scheme,
    WorkerStats,
};
use crate::ic::{InsertError, Interpolated, Key, Record, Selection, WorkerId};
use crate::sync::{fence, AtomicPtr, AtomicU8, Ordering, Tracked};
use glam::Vec3;
#[cfg(not(feature = "loom"))]
use list::RecordList;
use orderings::{ord, Site};
use std::marker::PhantomData;
use std::mem::MaybeUninit;
use std::ptr;

/// The record list itself, for the loom models that exercise it alone.
#[cfg(feature = "loom")]
pub use list::{ListFull, RecordList};
pub use orderings::{Minimal, Orderings};

/// What an insert does when its compare-and-swap on a missing child loses the race.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum CasFailure {
    /// Drop the sample from the cache and count it (Listing 6 as printed).
    Discard,
    /// Continue into the child the winner published and store the sample there.
    #[default]
    Adopt,
}

/// An octree node. Children and segments are owned through raw pointers, freed in `Drop`.
///
/// `Send` and `Sync` are derived, not asserted: `AtomicPtr` is both whatever it points to, so the
/// `_owns` marker makes the node's auto traits those of the `Box`es it really owns (as
/// `RecordList`'s marker does for its segments). Sharing a node is sound because a child is only
/// dereferenced after an Acquire load saw its Release publication, is never changed or freed
/// while the tree is shared (only `Drop` and `WaitFree::reclaim`, both with `&mut`, free one), and
/// is read only through `&`.
#[repr(C)]
struct Node<O: Orderings> {
    /// Bit `o` set once `children[o]` is published and its publisher, or an insert that walked
    /// into it, has said so.
    occupied: AtomicU8,
    /// Where the node's memory is: false for a node boxed on its own (every node a graft builds),
    /// true for one a frame's close moved into the cache's slab (`WaitFree::relocate`). Written
    /// only while the node is private or with `&mut` access to the cache; read only with `&mut`,
    /// to know how to free the node. It sits in the padding before the list: no byte more.
    in_slab: bool,
    /// The list's head, first block pointer and first block length. With the mask, the 32 bytes
    /// a walk reads of every node it visits; a leaf costs no more.
    records: RecordList<O>,
    /// Null, or a child published by a Release compare-and-swap and never changed again while the
    /// tree is shared (`reclaim`, with `&mut`, unlinks an emptied one). Read only where the mask
    /// says a child whose loose cell holds the query was published.
    children: [AtomicPtr<Node<O>>; 8],
    /// The node owns its children as boxes (see the type's documentation).
    _owns: PhantomData<[Box<Node<O>>; 8]>,
    /// Under loom, a node never freed fails the model (`Allocation leaked.`); zero-sized elsewhere.
    _tracked: Tracked,
}

impl<O: Orderings> Node<O> {
    /// A node with no child and an empty list. Under loom a leak report names the caller's line.
    #[cfg_attr(feature = "loom", track_caller)]
    fn new() -> Self {
        Self {
            children: std::array::from_fn(|_| AtomicPtr::new(ptr::null_mut())),
            occupied: AtomicU8::new(0),
            in_slab: false,
            records: RecordList::new(),
            _owns: PhantomData,
            _tracked: Tracked::new(),
        }
    }

    /// The child in `octant`, whose bit a lookup saw in this node's mask with an Acquire load
    /// (`WaitFree::walk_node`): published, so no null check.
    ///
    /// # Panics
    /// Under the model checkers (and in debug builds), if the pointer is null: a mask bit seen
    /// without its child, which only a weakened ordering allows (the ordering study).
    #[inline]
    fn follow(&self, octant: Octant) -> &Node<O> {
        // Relaxed (ChildFollow): the Acquire load of the mask that showed this octant's bit
        // synchronised with a Release `fetch_or` made after the compare-and-swap that published
        // the child (by its publisher, or by an insert that loaded the child with Acquire), or
        // came with this node's own construction (`build_path`). So the publication
        // happens-before this load, which (write-read coherence, and the pointer never changes
        // again) returns the child, and the child's construction is visible.
        let child = self.children[octant.index()].load(ord::<O>(Site::ChildFollow));
        // Checked where it costs nothing that is measured: under the model checkers, whose
        // ordering study weakens the sites this rests on, and in debug builds.
        if cfg!(any(checker, debug_assertions)) {
            assert!(
                !child.is_null(),
                "a lookup saw a mask bit without its published child"
            );
        }
        // SAFETY: non-null by the argument above (checked just above where it is cheap); from
        // `Box::into_raw` in `graft` or `build_path`, published once and freed only with `&mut`
        // access to the cache (its drop, or `reclaim`), which `&self` rules out.
        unsafe { &*child }
    }

    /// The child in `octant`, if published (an insert's walk, which has no mask bit to rely on).
    #[inline]
    fn child(&self, octant: Octant) -> Option<&Node<O>> {
        // Acquire (ChildRead): pairs with the Release compare-and-swap in `graft`; everything the
        // publisher built privately (the child's own children, its list and the record in it)
        // is visible before we read through the pointer.
        let child = self.children[octant.index()].load(ord::<O>(Site::ChildRead));
        // SAFETY: a non-null child pointer came from `Box::into_raw` in `graft`, was published
        // once and is freed only with `&mut` access to the cache (its drop, or `reclaim`), which
        // `&self` rules out.
        unsafe { child.as_ref() }
    }
}

impl<O: Orderings> Node<O> {
    /// Sets `octant`'s bit in the occupancy mask unless this thread already sees it set. Called
    /// before an insert goes below a published child, so that no record is stored under a child
    /// that lookups may skip: a lookup that happens-after the insert loads a mask holding the bit.
    #[inline]
    fn mark(&self, octant: Octant) {
        // Relaxed (MaskTest): only saves the read-modify-write when the bit is already set. If
        // this load sees the bit, any load that happens-after it sees the bit too (read-read
        // coherence, and bits are never cleared while the cache is shared: only `reclaim`, with
        // `&mut`, clears one), and whoever set it had seen the child, so
        // skipping the `fetch_or` loses nothing; this insert reads nothing through the mask.
        if self.occupied.load(ord::<O>(Site::MaskTest)) & octant.bit() == 0 {
            // Release (MaskSet): publishes the child with its bit. This thread saw the child
            // published (its own compare-and-swap, or an Acquire load of the pointer or of the
            // failed compare-and-swap), so a lookup whose Acquire load sees the bit happens-after
            // that publication and follows the pointer with no null check (`Node::follow`). Every
            // later write to the mask is a `fetch_or` too, so a lookup that reads a later value
            // still synchronises with this one (a release sequence). What a lookup must see, the
            // bit set by an insert that happens-before it, write-read coherence gives.
            self.occupied
                .fetch_or(octant.bit(), ord::<O>(Site::MaskSet));
        }
    }
}

impl<O: Orderings> Drop for Node<O> {
    fn drop(&mut self) {
        for child in &self.children {
            // Relaxed: `&mut self` — every other thread's accesses happen-before this drop.
            let child = child.load(Ordering::Relaxed);
            if !child.is_null() {
                // SAFETY: a child is owned by this node alone (boxed by `graft` or `build_path`,
                // or moved into the slab by `relocate`), and is being dropped with it. Recursion
                // is bounded by the tree depth.
                unsafe { free_node(child) };
            }
        }
    }
}

/// Drops `node` and its subtree and, for a boxed node, frees its memory; a slab node's memory is
/// the slab's, freed with it (`WaitFree::relocate`).
///
/// # Safety
/// `node` is a live node (from `Box::into_raw`, or placed in the slab by `relocate`) that no
/// pointer reachable from the tree leads to any more, or only its dropping parent's, and that
/// nothing accesses again.
unsafe fn free_node<O: Orderings>(node: *mut Node<O>) {
    // SAFETY: live, and owned by the caller alone (the contract above).
    if unsafe { (*node).in_slab } {
        // SAFETY: a slab node is dropped once, here, by its only owner; its memory stays the
        // slab's (a `MaybeUninit`, never dropped as a node).
        unsafe { ptr::drop_in_place(node) };
    } else {
        // SAFETY: a boxed node, from `Box::into_raw`, owned by the caller alone.
        drop(unsafe { Box::from_raw(node) });
    }
}

/// WF: the wait-free cache, with the ordering policy `O` and a compare-and-swap failure policy.
pub struct WaitFree<O: Orderings = Minimal> {
    config: CacheConfig,
    policy: CasFailure,
    /// Declared before `slab`, so dropped first: dropping the tree drops the slab's nodes in
    /// place, and only then is the slab's memory freed.
    root: Box<Node<O>>,
    /// The memory of the nodes the last relocation moved, in breadth-first order (`relocate`).
    /// Its nodes are owned by their parents, as boxed ones are; the slab only holds the memory.
    slab: Box<[MaybeUninit<Node<O>>]>,
    /// Nodes boxed since the last relocation, as the handles counted them (`Grown`).
    loose: usize,
    /// Slab nodes freed since the last relocation, whose memory lies unused.
    dead: usize,
    ledger: Ledger<Grown>,
    stats: CacheStats,
}

impl<O: Orderings> std::fmt::Debug for WaitFree<O> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WaitFree")
            .field("orderings", &O::NAME)
            .field("policy", &self.policy)
            .field("config", &self.config)
            .finish_non_exhaustive()
    }
}

impl WaitFree<Minimal> {
    /// The shipped wait-free cache: minimal orderings, losers of a child race adopt the winner's
    /// child (no sample lost).
    pub fn adopt(config: CacheConfig) -> Self {
        Self::new(config, CasFailure::Adopt)
    }

    /// The paper's variant: minimal orderings, losers of a child race discard their sample.
    pub fn discard(config: CacheConfig) -> Self {
        Self::new(config, CasFailure::Discard)
    }
}

/// How an insert ended inside the tree.
enum Placed {
    Stored,
    /// Stored at the bottom of a path this insert grafted: that many new boxed nodes.
    Grafted(u32),
    /// Stored in the first slot of the second or a later segment past the list's first block:
    /// the list grew, and the frame's close may rebuild it (`list.rs`, 5).
    Grew,
    Discarded,
    Full,
}

/// What a handle leaves for the frame's close: where each list it made grow lies (the record's
/// position and depth: the close finds the node again by that path, with `&mut`), and how many
/// nodes its grafts published. Only a list that opened a segment can have come to need a rebuild,
/// so the close looks at these lists alone rather than walking the tree; the node count tells it
/// when the boxed nodes are many enough to move into a slab (`WaitFree::relocate`).
#[derive(Debug, Default)]
pub(crate) struct Grown {
    lists: Vec<(Vec3, u32)>,
    nodes: usize,
}

impl Local for Grown {
    fn take(&mut self) -> Self {
        std::mem::take(self)
    }
}

impl<O: Orderings> WaitFree<O> {
    /// An empty cache.
    pub fn new(config: CacheConfig, policy: CasFailure) -> Self {
        Self {
            config,
            policy,
            root: Box::new(Node::new()),
            slab: Box::new([]),
            loose: 0,
            dead: 0,
            ledger: Ledger::new(),
            stats: CacheStats::default(),
        }
    }

    /// The compare-and-swap failure policy.
    pub fn policy(&self) -> CasFailure {
        self.policy
    }

    /// Stores an admitted record. Returns the outcome, the steps taken (levels descended plus
    /// compare-and-swap attempts) and the compare-and-swaps lost.
    #[inline]
    fn place(&self, record: Record) -> (Placed, u32, u32) {
        let depth = self.config.depth_of(&record);
        let mut node: &Node<O> = &self.root;
        let mut cell = self.config.root();
        let mut steps = 0;
        let mut lost = 0;
        for level in 1..=depth {
            steps += 1;
            let octant = cell.octant(record.position);
            cell = cell.child(octant);
            node = match node.child(octant) {
                Some(child) => {
                    // Whoever published the child may not have set its bit yet.
                    if O::HELP_MARK {
                        node.mark(octant);
                    }
                    child
                }
                None => {
                    steps += 1;
                    match self.graft(node, octant, cell, level, depth, record) {
                        None => {
                            node.mark(octant);
                            return (Placed::Grafted(depth - level + 1), steps, lost);
                        }
                        Some(winner) => {
                            lost += 1;
                            match self.policy {
                                CasFailure::Discard => return (Placed::Discarded, steps, lost),
                                CasFailure::Adopt => {
                                    if O::HELP_MARK {
                                        node.mark(octant);
                                    }
                                    winner
                                }
                            }
                        }
                    }
                }
            };
        }
        match node.records.push_keyed(self.key(&record), record) {
            Ok(index) if node.records.opens_segment(index) => (Placed::Grew, steps, lost),
            Ok(_) => (Placed::Stored, steps, lost),
            Err(list::ListFull) => (Placed::Full, steps, lost),
        }
    }

    /// Builds, privately, the path from the missing child of `parent` in `octant` (cell `cell`, at
    /// `level`) down to `depth`, with `record` in its last node, and publishes it with one
    /// compare-and-swap. `None` when published; otherwise frees the private path and returns the
    /// child that won.
    #[cold]
    #[inline(never)]
    fn graft<'a>(
        &'a self,
        parent: &'a Node<O>,
        octant: Octant,
        cell: Cell,
        level: u32,
        depth: u32,
        record: Record,
    ) -> Option<&'a Node<O>> {
        let top = build_path::<O>(cell, level, depth, self.key(&record), record);
        let top = Box::into_raw(top);
        match parent.children[octant.index()].compare_exchange(
            ptr::null_mut(),
            top,
            // Release (ChildPublish): publishes the private subtree — its nodes, segments and the
            // record — to readers that load the pointer with Acquire. Nothing is read through the
            // replaced null, so no Acquire half is needed.
            ord::<O>(Site::ChildPublish),
            // Acquire (ChildCasFailure): with `Adopt` we walk into the winner's subtree next, so
            // its construction must happen-before our reads of it.
            ord::<O>(Site::ChildCasFailure),
        ) {
            Ok(_) => None,
            Err(winner) => {
                // SAFETY: `top` came from `Box::into_raw` above and was never shared (the
                // compare-and-swap failed): we are its only owner.
                drop(unsafe { Box::from_raw(top) });
                // SAFETY: a non-null published child, live as long as the cache (see `Node::child`).
                Some(unsafe { &*winner })
            }
        }
    }

    /// The key a record is stored with in this cache.
    #[inline]
    fn key(&self, record: &Record) -> Key {
        Key::of(record, self.config.accuracy())
    }

    /// Visits the nodes a query at `point` must visit, depth first, children in octant order, and
    /// calls `f` with each published record there whose key `admit` passes; returns the nodes
    /// visited and the keys examined. Only the child pointers of the octants whose loose cells
    /// hold the point are loaded.
    #[inline]
    fn walk(&self, point: Vec3, admit: impl Fn(&Key) -> bool, f: &mut impl FnMut(&Record)) -> Work {
        if O::READ_FENCE {
            // SeqCst fence: the read-path barrier of the ReadFence policy (the paper's avoided cost).
            fence(Ordering::SeqCst);
        }
        let mut work = Work::default();
        self.walk_node(&self.root, self.config.root(), point, &admit, f, &mut work);
        work
    }

    fn walk_node(
        &self,
        node: &Node<O>,
        cell: Cell,
        point: Vec3,
        admit: &impl Fn(&Key) -> bool,
        f: &mut impl FnMut(&Record),
        work: &mut Work,
    ) {
        work.nodes += 1;
        work.records += node.records.scan(admit, f);
        // Acquire (MaskRead): pairs with the Release `fetch_or`s of `Node::mark`, each made
        // after its thread saw the child published, so every bit seen here comes with its child's
        // pointer and everything built before that child's publication (`Node::follow`). A bit
        // from the private store in `build_path` came with the node itself, which this lookup
        // reached through such an edge. A child whose bit this load misses was published without
        // any edge to this lookup, or its bit was set by an insert that does not happen-before it.
        let occupied = node.occupied.load(ord::<O>(Site::MaskRead));
        if occupied != 0 {
            let mask = occupied & self.config.geometry().children_holding(&cell, point);
            for octant in Octant::in_mask(mask) {
                let child = node.follow(octant);
                self.walk_node(child, cell.child(octant), point, admit, f, work);
            }
        }
    }

    /// Removes every live record `selection` takes in frame `now` from the nodes a walk reaches
    /// (module documentation); returns how many this call took, and the nodes it visited and the
    /// slots it examined.
    fn remove_from(&self, selection: &Selection, now: u64) -> (usize, Work) {
        let mut removed = 0;
        let mut work = Work::default();
        self.remove_in(
            &self.root,
            self.config.root(),
            true,
            selection,
            now,
            (&mut removed, &mut work),
        );
        (removed, work)
    }

    fn remove_in(
        &self,
        node: &Node<O>,
        cell: Cell,
        root: bool,
        selection: &Selection,
        now: u64,
        (removed, work): (&mut usize, &mut Work),
    ) {
        if !root {
            // The loose cell holds every stored record's influence sphere, here and below.
            let (lo, hi) = self.config.geometry().loose_bounds(&cell);
            if !selection.may_select_within(lo, hi) {
                return;
            }
        }
        let accuracy = self.config.accuracy();
        let (taken, examined) = node
            .records
            .remove_where(|r| selection.selects(r, accuracy, now));
        *removed += taken as usize;
        *work += Work {
            nodes: 1,
            records: examined,
        };
        // Acquire (MaskRead): as in `walk_node`: every bit seen comes with its child, and every
        // bit on the path of a record whose insert happens-before this removal is seen.
        let occupied = node.occupied.load(ord::<O>(Site::MaskRead));
        for octant in Octant::in_mask(occupied) {
            let child = node.follow(octant);
            self.remove_in(
                child,
                cell.child(octant),
                false,
                selection,
                now,
                (&mut *removed, &mut *work),
            );
        }
    }

    /// Reclaims what removals and growth left (`&mut`: no handle exists): rebuilds every list
    /// that holds a removed record, or has outgrown its first block with too many unused slots,
    /// as one block of its live records (`list.rs`, 5), and frees every subtree left with no
    /// record.
    fn reclaim(&mut self) {
        /// Compacts `node`'s subtree; true when it holds no record and no child any more.
        /// Counts the nodes it frees into `freed`: (boxed, in the slab).
        fn prune<O: Orderings>(node: &mut Node<O>, freed: &mut (usize, usize)) -> bool {
            let mut live = node.records.compact();
            for octant in Octant::ALL {
                let slot = &mut node.children[octant.index()];
                // Relaxed: `&mut self` — every other thread's accesses happen-before this.
                let child = slot.load(Ordering::Relaxed);
                // SAFETY: a published child, live until freed here, and `&mut` makes this the
                // only access.
                let Some(child_ref) = (unsafe { child.as_mut() }) else {
                    continue;
                };
                if prune(child_ref, freed) {
                    // Relaxed: as above; nothing can load the pointer before the next frame,
                    // whose handles are made after this `&mut` access ends.
                    slot.store(ptr::null_mut(), Ordering::Relaxed);
                    // Relaxed: as above. The one place a bit is cleared: with its child gone.
                    node.occupied.fetch_and(!octant.bit(), Ordering::Relaxed);
                    if child_ref.in_slab {
                        freed.1 += 1;
                    } else {
                        freed.0 += 1;
                    }
                    // SAFETY: a live node, unlinked just above, so owned here alone.
                    unsafe { free_node(child) };
                } else {
                    live += 1;
                }
            }
            live == 0
        }
        let mut freed = (0, 0);
        prune(&mut self.root, &mut freed);
        self.loose = self.loose.saturating_sub(freed.0);
        self.dead += freed.1;
    }

    /// Relocates when the nodes outside the slab, or freed in it, reach a quarter of it: each
    /// relocation moves every node once, and at least a quarter as many nodes were made or freed
    /// since the last, so a node is moved a constant number of times on average, and the slab's
    /// unused memory stays under a quarter of it.
    fn settle(&mut self) {
        let changed = self.loose + self.dead;
        if changed > 0 && changed * 4 >= self.slab.len() {
            self.relocate();
        }
    }

    /// Moves every node below the root into one fresh slab, in breadth-first order, and frees the
    /// old slab and the boxed nodes' memory (`&mut`: no handle exists).
    ///
    /// Why: a graft boxes its nodes one by one, so the allocator scatters them among the lists'
    /// blocks, and a walk through a tree larger than the caches meets a cold line, and often a
    /// cold page, at every node. In the slab, a node's children lie side by side and the upper
    /// levels in a few pages, as the sequential octree's arena keeps them
    /// (`results/records-held`). Nodes are moved bitwise: nothing points into a node but its
    /// parent's child pointer, which is rewritten, and a list's blocks are its own allocations.
    fn relocate(&mut self) {
        let mut count = 0usize;
        self.for_each_node(&mut |_| count += 1);
        let count = count - 1; // the root stays in its box
        let mut slab: Box<[MaybeUninit<Node<O>>]> =
            (0..count).map(|_| MaybeUninit::uninit()).collect();
        let base = slab.as_mut_ptr().cast::<Node<O>>();
        let mut filled = 0;
        // Moves `parent`'s children to the slab's next places and points `parent` at them.
        let adopt = |parent: &mut Node<O>, filled: &mut usize| {
            for slot in &parent.children {
                // Relaxed: `&mut self` — no other thread is running.
                let child = slot.load(Ordering::Relaxed);
                if child.is_null() {
                    continue;
                }
                if *filled >= count {
                    broken("more nodes than counted");
                }
                // SAFETY: `*filled < count`, inside the new slab.
                let to = unsafe { base.add(*filled) };
                *filled += 1;
                // SAFETY: `child` is a live node (published, reached from the root with `&mut`),
                // and `to` is unused memory of the new slab, which no node overlaps. The copy
                // becomes the node; the old place is never dropped as a node (below).
                let boxed = unsafe {
                    let boxed = !(*child).in_slab;
                    ptr::copy_nonoverlapping(child, to, 1);
                    (*to).in_slab = true;
                    boxed
                };
                if boxed {
                    // SAFETY: from `Box::into_raw`; its node was moved out just above, so the box
                    // is freed as memory only.
                    drop(unsafe { Box::from_raw(child.cast::<MaybeUninit<Node<O>>>()) });
                }
                // Relaxed: as above.
                slot.store(to, Ordering::Relaxed);
            }
        };
        adopt(&mut self.root, &mut filled);
        let mut next = 0;
        while next < filled {
            // SAFETY: the `next`-th place was filled by `adopt`, and nothing else refers to it
            // while this loop holds it.
            adopt(unsafe { &mut *base.add(next) }, &mut filled);
            next += 1;
        }
        if filled != count {
            broken("fewer nodes than counted");
        }
        // The old slab's nodes were all moved out or dropped (`free_node`): only memory is left.
        self.slab = slab;
        self.loose = 0;
        self.dead = 0;
    }

    /// The nodes the slab has places for, live or freed since the last move (`relocate`): a
    /// frame's close that moved the tree leaves it equal to the nodes below the root.
    pub fn slab_len(&self) -> usize {
        self.slab.len()
    }

    /// Slots reserved in every list, live or not.
    pub fn reserved_slots(&mut self) -> usize {
        let mut slots = 0;
        self.for_each_node(&mut |node| slots += node.records.reserved());
        slots
    }

    /// Slots allocated in every list, reserved or not: what the lists' memory is made of (a
    /// frame's close rebuilds a list whose unused slots grew too many, `list.rs`, 5).
    pub fn allocated_slots(&mut self) -> usize {
        let mut slots = 0;
        self.for_each_node(&mut |node| slots += node.records.allocated());
        slots
    }

    /// The node at `depth` on `position`'s path, if every node on the path exists (`&mut`: for
    /// the frame's close; a removal between frames may have freed the path since).
    fn node_on_path(&mut self, position: Vec3, depth: u32) -> Option<&mut Node<O>> {
        let mut node = &mut *self.root;
        let mut cell = self.config.root();
        for _ in 1..=depth {
            let octant = cell.octant(position);
            cell = cell.child(octant);
            // Relaxed: `&mut self` — every other thread's accesses happen-before this.
            let child = node.children[octant.index()].load(Ordering::Relaxed);
            // SAFETY: a published child is live until `reclaim` or `Drop` frees it (both with
            // `&mut`, and the pointer is loaded after either), and `&mut self` makes this the only
            // access.
            node = unsafe { child.as_mut() }?;
        }
        Some(node)
    }

    fn for_each_node(&mut self, f: &mut impl FnMut(&mut Node<O>)) {
        fn walk<O: Orderings>(node: &mut Node<O>, f: &mut impl FnMut(&mut Node<O>)) {
            f(node);
            for child in &node.children {
                // Relaxed: `&mut self` — no other thread is running.
                let child = child.load(Ordering::Relaxed);
                // SAFETY: published children are live until the cache is dropped, and `&mut self`
                // makes this the only access.
                if let Some(child) = unsafe { child.as_mut() } {
                    walk(child, f);
                }
            }
        }
        walk(&mut self.root, f);
    }
}

/// Ends the process when `relocate` finds the tree other than it counted it, which `&mut` access
/// rules out. Not a panic: unwinding would drop a tree whose moved nodes point into the new
/// slab, freed on the way out.
#[cold]
fn broken(what: &str) -> ! {
    eprintln!("wfic: WaitFree::relocate: {what}");
    std::process::abort()
}

/// A private chain of nodes from `cell` at `level` down to `depth`, holding `record` at the bottom.
fn build_path<O: Orderings>(
    cell: Cell,
    level: u32,
    depth: u32,
    key: Key,
    record: Record,
) -> Box<Node<O>> {
    // The octants of the path below `cell`, on the stack (no allocation on the insert path).
    let mut octants = [Octant::ALL[0]; MAX_DEPTH as usize];
    let steps = (depth - level) as usize;
    let mut c = cell;
    for octant in &mut octants[..steps] {
        *octant = c.octant(record.position);
        c = c.child(*octant);
    }
    let mut node = Box::new(Node::<O>::new());
    // A fresh list in a fresh node: the push cannot find it full (the first segment has room).
    let pushed = node.records.push_keyed(key, record);
    debug_assert!(pushed.is_ok());
    for &octant in octants[..steps].iter().rev() {
        let parent = Box::new(Node::<O>::new());
        // Relaxed: the parent is still private; the Release compare-and-swap in `graft` publishes
        // the whole chain at once.
        parent.children[octant.index()].store(Box::into_raw(node), Ordering::Relaxed);
        // Relaxed: still private, published with the chain.
        parent.occupied.store(octant.bit(), Ordering::Relaxed);
        node = parent;
    }
    node
}

/// A WF worker.
#[must_use = "a handle does nothing unless it is used"]
pub struct WfHandle<'c, O: Orderings> {
    cache: &'c WaitFree<O>,
    core: HandleCore<'c, Grown>,
}

impl<O: Orderings> IrradianceCache for WaitFree<O> {
    type Handle<'c> = WfHandle<'c, O>;

    fn scheme(&self) -> Scheme {
        match self.policy {
            CasFailure::Adopt => Scheme::Wf,
            CasFailure::Discard => Scheme::WfDiscard,
        }
    }

    fn config(&self) -> &CacheConfig {
        &self.config
    }

    fn handle(&self, worker: WorkerId) -> WfHandle<'_, O> {
        WfHandle {
            cache: self,
            core: HandleCore::new(&self.ledger, worker, Grown::default()),
        }
    }

    fn end_frame(&mut self) -> FrameReport {
        let (deposits, report) = self.ledger.close_frame(&mut self.stats);
        let lists: Vec<Grown> = deposits.into_iter().map(|d| d.local).collect();
        self.loose += lists.iter().map(|grown| grown.nodes).sum::<usize>();
        if report.workers.removed > 0 {
            // Every list and subtree the removals touched: the whole walk.
            self.reclaim();
        } else {
            // Only the lists that opened a segment this frame can need a rebuild.
            for (position, depth) in lists.into_iter().flat_map(|grown| grown.lists) {
                if let Some(node) = self.node_on_path(position, depth) {
                    node.records.compact();
                }
            }
        }
        self.settle();
        report
    }

    fn remove(&mut self, selection: &Selection) -> usize {
        let (removed, work) = self.remove_from(selection, self.stats.frames);
        if removed > 0 {
            self.reclaim();
            self.settle();
        }
        self.stats.totals.count_removal(removed, work)
    }

    fn snapshot(&mut self) -> Vec<Record> {
        let mut out = Vec::new();
        self.for_each_node(&mut |node| node.records.for_each(&mut |r| out.push(*r)));
        out
    }

    fn stats(&mut self) -> CacheStats {
        let (mut records, mut nodes) = (0, 0);
        self.for_each_node(&mut |node| {
            nodes += 1;
            records += node.records.published();
        });
        CacheStats {
            records,
            nodes,
            ..self.stats
        }
    }
}

impl<O: Orderings> CacheHandle for WfHandle<'_, O> {
    fn worker(&self) -> WorkerId {
        self.core.worker
    }

    fn frame(&self) -> u64 {
        self.core.frame
    }

    #[inline]
    fn lookup(&mut self, point: Vec3, normal: Vec3) -> Option<Interpolated> {
        let mut acc = self.core.begin_lookup(&self.cache.config, point, normal)?;
        let pre = *acc.prefilter();
        let work = self.cache.walk(point, |k| pre.admits(k), &mut |r| {
            acc.add(r);
        });
        self.core.end_lookup(&acc, work)
    }

    fn lookup_visible(
        &mut self,
        point: Vec3,
        normal: Vec3,
        visible: Visibility,
    ) -> Option<Interpolated> {
        let cache = self.cache;
        self.core
            .lookup_visible(&cache.config, point, normal, visible, |pre, _, f| {
                cache.walk(pre.point(), |k| pre.admits(k), &mut |r| f(r))
            })
    }

    fn insert(&mut self, record: Record) -> Result<Inserted, InsertError> {
        let record = self.core.admit(&self.cache.config, record)?;
        let (placed, steps, lost) = self.cache.place(record);
        self.core.stats.cas_failures += u64::from(lost);
        match placed {
            Placed::Stored => Ok(self.core.inserted(Inserted::Stored(record.id()), steps)),
            Placed::Grafted(nodes) => {
                self.core.local.nodes += nodes as usize;
                Ok(self.core.inserted(Inserted::Stored(record.id()), steps))
            }
            Placed::Grew => {
                let depth = self.cache.config.depth_of(&record);
                self.core.local.lists.push((record.position, depth));
                Ok(self.core.inserted(Inserted::Stored(record.id()), steps))
            }
            Placed::Discarded => Ok(self.core.inserted(Inserted::Discarded(record.id()), steps)),
            #[cfg(feature = "loom")]
            Placed::Full => Err(InsertError::ListFull),
            // Outside loom a list has 4 (2^50 - 1) slots: filling them takes 7 * 10^17 bytes of
            // segments, more than any 64-bit address space (2^57 bytes at most) can map, so an
            // allocation fails long before (`list.rs`).
            #[cfg(not(feature = "loom"))]
            Placed::Full => unreachable!("a record list ran out of its 4 (2^50 - 1) slots"),
        }
    }

    fn remove(&mut self, selection: &Selection) -> usize {
        let (removed, work) = self.cache.remove_from(selection, self.core.frame);
        self.core.stats.count_removal(removed, work)
    }

    fn valid_records(&mut self, point: Vec3, normal: Vec3, out: &mut Vec<Record>) {
        let cache = self.cache;
        let work = collect_valid(&cache.config, point, normal, out, |pre, f| {
            cache.walk(pre.point(), |k| pre.admits(k), &mut |r| f(r))
        });
        self.core.traversed(work);
    }

    fn stats(&self) -> &WorkerStats {
        &self.core.stats
    }
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;
    use crate::cache::CacheConfig;
    use std::mem::size_of;

    /// A cache keeps the policy it was built with and shows it, with its orderings, when printed.
    #[test]
    fn a_cache_keeps_and_shows_its_policy_and_orderings() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.3).unwrap();
        for (cache, policy) in [
            (WaitFree::discard(config), CasFailure::Discard),
            (WaitFree::adopt(config), CasFailure::Adopt),
        ] {
            assert_eq!(cache.policy(), policy);
            let shown = format!("{cache:?}");
            assert!(shown.starts_with("WaitFree {"), "{shown}");
            assert!(shown.contains(&format!("policy: {policy:?}")), "{shown}");
            assert!(shown.contains(Minimal::NAME), "{shown}");
        }
    }

    /// The leak tracker ([`crate::sync::Tracked`]) costs nothing outside loom: a node is its
    /// occupancy mask, its list (head, first block pointer and length) and its eight child
    /// pointers, 96 bytes on 64-bit targets, with what every visit reads (mask, head, first
    /// block) in its first 32. Not aligned to a cache line: an aligned layout, through glibc's `memalign`,
    /// spreads nodes out (`docs/tried-and-dropped.md`).
    #[test]
    fn a_node_is_its_mask_its_list_and_its_children() {
        use std::mem::offset_of;
        assert_eq!(
            size_of::<Node<Minimal>>(),
            8 + size_of::<RecordList<Minimal>>() + size_of::<[AtomicPtr<Node<Minimal>>; 8]>()
        );
        #[cfg(target_pointer_width = "64")]
        {
            assert_eq!(size_of::<Node<Minimal>>(), 96);
            assert_eq!(offset_of!(Node<Minimal>, occupied), 0);
            assert_eq!(offset_of!(Node<Minimal>, records), 8);
            assert_eq!(8 + RecordList::<Minimal>::HOT_FIELDS_END, 32);
            assert_eq!(offset_of!(Node<Minimal>, children), 32);
        }
    }

    /// Records in `0..4` cubed (or the box `lo..hi`), unsealed: a handle seals them.
    fn records_in(rng: &mut crate::rng::Rng, n: usize, lo: f32, hi: f32) -> Vec<Record> {
        (0..n)
            .map(|i| {
                let p = Vec3::new(rng.range(lo, hi), rng.range(lo, hi), rng.range(lo, hi));
                let normal = [Vec3::Z, Vec3::X, -Vec3::Y][i % 3];
                Record::new(
                    p,
                    normal,
                    Vec3::splat(rng.range(0.0, 2.0)),
                    rng.range(0.02, 1.0),
                )
            })
            .collect()
    }

    /// Inserts `records` in one frame, by one handle.
    fn insert_frame(cache: &mut WaitFree<Minimal>, records: &[Record]) {
        let frame = cache.frame();
        let mut h = frame.handle();
        for r in records {
            h.insert(*r).unwrap();
        }
        drop(h);
        frame.close();
    }

    /// The nodes below the root as the tree holds them: (boxed, in the slab), and whether the
    /// slab's nodes, read in its order, are the tree's breadth-first order with each node's
    /// children side by side (every slab node reached once, from the root down).
    fn places(cache: &mut WaitFree<Minimal>) -> (usize, usize, bool) {
        let base = cache.slab.as_ptr().cast::<Node<Minimal>>();
        let (mut boxed, mut in_slab) = (0, 0);
        // Breadth first, the root's children first.
        let mut queue: std::collections::VecDeque<*const Node<Minimal>> =
            std::collections::VecDeque::from([&*cache.root as *const Node<Minimal>]);
        let mut order = Vec::new();
        while let Some(node) = queue.pop_front() {
            // SAFETY (test): live nodes of a tree no one else holds.
            for child in unsafe { &(*node).children } {
                let child = child.load(Ordering::Relaxed).cast_const();
                if child.is_null() {
                    continue;
                }
                // SAFETY (test): as above.
                if unsafe { (*child).in_slab } {
                    in_slab += 1;
                    order.push(child);
                } else {
                    boxed += 1;
                }
                queue.push_back(child);
            }
        }
        // SAFETY (test): offsets inside the slab, compared as addresses only.
        let breadth_first = order
            .iter()
            .enumerate()
            .all(|(i, &p)| std::ptr::eq(p, unsafe { base.add(i) }));
        (boxed, in_slab, breadth_first)
    }

    /// A frame's close that finds the boxed nodes at least a quarter of the slab moves every node
    /// into one slab, breadth first; the tree answers every lookup as before, and holds every
    /// record once. A later frame that boxes fewer new nodes than a quarter of the slab leaves
    /// them boxed; once they reach a quarter, the next close moves them all.
    #[test]
    fn a_close_moves_the_nodes_into_one_breadth_first_slab_once_a_quarter_are_new() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.3).unwrap();
        let mut rng = crate::rng::Rng::new(5);
        let mut cache = WaitFree::<Minimal>::adopt(config);
        let mut tree = crate::cache::Octree::new(config);
        let first = records_in(&mut rng, 2000, 0.0, 2.0);
        insert_frame(&mut cache, &first);
        let nodes = cache.stats().nodes - 1;
        assert!(nodes > 100, "{nodes} nodes");
        assert_eq!(places(&mut cache), (0, nodes, true));
        assert_eq!(cache.slab.len(), nodes);
        assert_eq!((cache.loose, cache.dead), (0, 0));
        // A few records in a new corner: new nodes, fewer than a quarter of the slab.
        let few = records_in(&mut rng, 8, 3.0, 4.0);
        insert_frame(&mut cache, &few);
        let (boxed, in_slab, breadth_first) = places(&mut cache);
        assert!(boxed > 0 && boxed * 4 < nodes, "{boxed} boxed of {nodes}");
        assert_eq!((in_slab, breadth_first, cache.loose), (nodes, true, boxed));
        // Enough new nodes to reach a quarter: all moved, the slab now the whole tree.
        let more = records_in(&mut rng, 2000, 2.0, 4.0);
        insert_frame(&mut cache, &more);
        let all = cache.stats().nodes - 1;
        assert_eq!(places(&mut cache), (0, all, true));
        assert_eq!((cache.slab.len(), cache.loose), (all, 0));
        // What the tree holds and answers is unchanged by the moves.
        let mut held: Vec<Record> = Vec::new();
        for r in cache.snapshot() {
            tree.insert(r).unwrap();
            held.push(r);
        }
        assert_eq!(held.len(), first.len() + few.len() + more.len());
        let frame = cache.frame();
        let mut h = frame.handle();
        for q in records_in(&mut rng, 2000, 0.0, 4.0) {
            let mut want = crate::ic::Accumulator::new(q.position, q.normal, 0.3, None);
            tree.walk(q.position, |_| true, &mut |r| {
                want.add(r);
            });
            assert_eq!(h.lookup(q.position, q.normal), want.finish());
        }
    }

    /// Removal frees slab nodes in place (their memory stays the slab's, counted as dead) and
    /// boxed ones outright; once the dead reach a quarter of the slab the close moves the live
    /// nodes into a slab of just their number.
    #[test]
    fn removal_frees_slab_nodes_and_a_quarter_dead_compacts_the_slab() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.3).unwrap();
        let mut rng = crate::rng::Rng::new(6);
        let mut cache = WaitFree::<Minimal>::adopt(config);
        insert_frame(&mut cache, &records_in(&mut rng, 2000, 0.0, 4.0));
        let before = cache.slab.len();
        // A small box: some nodes freed, fewer than a quarter; they stay in the slab, dead.
        let small = Selection::touching(Vec3::splat(0.0), Vec3::splat(0.5)).unwrap();
        assert!(IrradianceCache::remove(&mut cache, &small) > 0);
        let live = cache.stats().nodes - 1;
        assert!(
            live < before && (before - live) * 4 < before,
            "{live} of {before}"
        );
        assert_eq!((cache.slab.len(), cache.dead), (before, before - live));
        assert_eq!(places(&mut cache).1, live);
        // Half the room: the dead pass a quarter, and the slab is rebuilt at the live count.
        let half = Selection::touching(Vec3::splat(0.0), Vec3::new(4.0, 4.0, 2.0)).unwrap();
        assert!(IrradianceCache::remove(&mut cache, &half) > 0);
        let live = cache.stats().nodes - 1;
        assert_eq!((cache.slab.len(), cache.dead, cache.loose), (live, 0, 0));
        assert_eq!(places(&mut cache), (0, live, true));
        // A few boxed nodes (fewer than a quarter), then removed: the boxes are freed and no
        // longer counted, so they do not bring the next move forward.
        let corner = Selection::touching(Vec3::splat(0.1), Vec3::splat(0.2)).unwrap();
        insert_frame(&mut cache, &records_in(&mut rng, 3, 0.1, 0.2));
        let (boxed, _, _) = places(&mut cache);
        assert!(
            boxed > 0 && cache.loose == boxed,
            "{boxed} boxed, {} loose",
            cache.loose
        );
        assert!(IrradianceCache::remove(&mut cache, &corner) >= 3);
        let (boxed_after, _, _) = places(&mut cache);
        assert_eq!(cache.loose, boxed_after, "freed boxes still counted");
        assert!(
            boxed_after < boxed,
            "{boxed_after} of {boxed} boxed nodes left"
        );
    }

    /// WF's walk with the prefilter gives, query by query, the bit-identical interpolation that
    /// the plain octree's walk gives without it, over the same nodes and keys: the prefilter and
    /// the geometric choice of children change what is read, not what is found. Most examined
    /// records never reach the exact test.
    #[test]
    fn the_prefiltered_walk_finds_what_the_unfiltered_octree_finds() {
        use crate::cache::Octree;
        use crate::ic::{Accumulator, RecordId};
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.3).unwrap();
        let mut rng = crate::rng::Rng::new(11);
        let cache = WaitFree::<Minimal>::adopt(config);
        let mut tree = Octree::new(config);
        let vec3 = |rng: &mut crate::rng::Rng, lo: f32, hi: f32| {
            Vec3::new(rng.range(lo, hi), rng.range(lo, hi), rng.range(lo, hi))
        };
        for seq in 0..3000 {
            let normal = [Vec3::Z, Vec3::X, -Vec3::Y][seq % 3];
            let r = Record::new(
                vec3(&mut rng, 0.0, 4.0),
                normal,
                vec3(&mut rng, 0.0, 2.0),
                rng.range(0.02, 1.0),
            )
            .with_gradients(
                [vec3(&mut rng, -0.1, 0.1); 3],
                [vec3(&mut rng, -0.1, 0.1); 3],
            )
            .sealed(RecordId::new(WorkerId::new(0), 0, seq as u64));
            let (placed, _, _) = cache.place(r);
            assert!(matches!(
                placed,
                Placed::Stored | Placed::Grew | Placed::Grafted(_)
            ));
            tree.insert(r).unwrap();
        }
        let (mut hits, mut examined, mut tested) = (0, 0, 0);
        for q in 0..3000 {
            let point = vec3(&mut rng, 0.0, 4.0);
            let normal = [Vec3::Z, Vec3::X, -Vec3::Y][q % 3];
            let mut plain = Accumulator::new(point, normal, 0.3, None);
            let plain_work = tree.walk(point, |_| true, &mut |r| {
                plain.add(r);
            });
            let mut filtered = Accumulator::new(point, normal, 0.3, None);
            let pre = *filtered.prefilter();
            let work = cache.walk(point, |k| pre.admits(k), &mut |r| {
                tested += 1;
                filtered.add(r);
            });
            assert_eq!(work, plain_work, "query {q}");
            assert_eq!(filtered.finish(), plain.finish(), "query {q}");
            hits += usize::from(plain.finish().is_some());
            examined += work.records;
        }
        assert!(hits > 300 && hits < 2700, "{hits} hits");
        assert!(
            tested * 3 < examined,
            "{tested} of {examined} examined reached the exact test"
        );
    }
}
