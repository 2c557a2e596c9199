//! A node's append-only record list: Listing 6's `ICList::Add` (`index = XADD(&head);
//! records[index] = sample`), with the two things the listing leaves out.
//!
//! 1. **Per-slot publication.** A reserved index is not a written record. Each slot carries a ready
//!    flag, stored with Release after the record is written; a reader loads it with Acquire and
//!    reads only slots it saw ready. The head counts *reservations*: it never means "a prefix is
//!    initialised" — slot `k + 1` can be ready while slot `k` is still being written, and readers
//!    skip `k` instead of stopping there.
//! 2. **No fixed capacity.** Slots live in segments of geometrically growing size (`B, 2B, 4B, ...`),
//!    allocated on first use and installed with one compare-and-swap; a thread that loses the race
//!    frees its own segment and uses the winner's. With `B = 4` and 50 segments the list has
//!    `4 (2^50 - 1)` slots, about 4.5 * 10^15: at 160 bytes a slot, more than any 64-bit address
//!    space holds (2^57 bytes with 5-level paging), so the list is bounded by memory, not by a
//!    constant. The list itself holds only the head, the first segment's pointer and its length
//!    (item 5); the other
//!    segments' pointers live in a directory, allocated (and installed with one compare-and-swap,
//!    like a segment) when the list first outgrows its first segment, and found through a pointer
//!    at the end of the first segment. So a node stays small however long its list may grow, and a
//!    first segment is 4 × (32 + 128) + 8 = 648 bytes: the keys of the many short lists lie close
//!    together (an inline directory would spread them out: `benches/lookup_pairs.rs` measures
//!    the lookups), and the block stays inside glibc's per-thread cache of small blocks (at most
//!    1 032 bytes), which a larger first segment would miss on every node a WF insert creates
//!    (`insert/wf` in `benches/cache_ops.rs`; `docs/tried-and-dropped.md` has the layouts tried).
//!    Under `loom` the segments are shrunk to `2, 4, 8` slots so three inserts reach a segment
//!    boundary; the logic is the same.
//!
//! 3. **Keys apart from records.** A segment is one allocation holding its slots' *hot* halves
//!    (the ready flag and the record's [`Key`], 32 bytes, two to a cache line) followed by their
//!    *cold* halves (the records). A scan reads the flags and keys of a node's slots back to back and
//!    touches a record only when its key passes the query's prefilter; both halves are written
//!    before the flag's Release store, so the protocol is the same one flag per slot.
//!
//! 4. **Removal by tombstone.** A slot's flag is a state: unwritten, live (set with Release after
//!    the record is written, as in 1), removed. A removal reads a live slot's record and, if its
//!    selection takes it, moves the slot from live to removed with one compare-and-swap, never
//!    retried: a failure means another removal took it first (counted once, by the winner), and a
//!    slot still unwritten is never touched, so the writer's later store of "live" cannot bring a
//!    removed record back. Readers take only live slots. The slots themselves are reclaimed when
//!    the cache has `&mut` access (`compact`, at the frame's close): the live records move to a
//!    fresh list, and no reader can exist.
//! 5. **One block at the frame's close.** Doubling segments leave up to half a long list's slots
//!    unused, and a scan past the first block goes through the directory. So `compact` also
//!    rebuilds a list that has opened two or more segments past its first block once its unused
//!    slots exceed a sixteenth of its records ([`SPARE_DIVISOR`]): the records move, in slot
//!    order, into a single first block of their number plus a sixteenth. A list's first block
//!    therefore holds `first_len` slots (`segment_len(0)`, or more once rebuilt), and later
//!    inserts open segments of 8, 16, ... slots after it, as for any list. So between frames a
//!    list's unused slots are at most a sixteenth of its records, or the seven of one segment of
//!    eight. The rule keeps the copying bounded on average: a rebuilt list must grow by its own
//!    sixteenth plus 8 records (filling its block and a first segment) before the next rebuild,
//!    so at most 17 records are copied for each one inserted (a property test checks this and
//!    the bound on unused slots over random growth), and a list growing by one record a frame, or spilling a record past its block, is not
//!    copied again each frame (a rule without the second segment's condition rebuilt half the
//!    lists a batch of inserts touched, each close: `docs/tried-and-dropped.md`).
//!
//! Every operation is wait-free: a push is one `fetch_add`, at most one segment compare-and-swap
//! (never retried: if it fails, somebody else's segment is as good), one write and one store; a
//! scan reads at most `head` slots.

use super::orderings::{ord, Orderings, Site};
use crate::ic::{Key, Record};
use crate::sync::{AtomicPtr, AtomicU8, AtomicUsize, Ordering, Tracked, UnsafeCell};
use std::alloc::{self, Layout};
use std::marker::PhantomData;
use std::mem::{align_of, size_of, MaybeUninit};
use std::ptr;

/// log2 of the first segment's size (4 slots).
#[cfg(not(feature = "loom"))]
const BASE_SHIFT: u32 = 2;
/// log2 of the first segment's size: shrunk under loom so segment boundaries are reached in a few
/// inserts. This shouldn't change the logic, only how soon the model meets it.
#[cfg(feature = "loom")]
const BASE_SHIFT: u32 = 1;

/// A list that has outgrown its first block is rebuilt as one block at the frame's close when its
/// unused slots exceed its records over this (module documentation, 5).
pub(crate) const SPARE_DIVISOR: usize = 16;

/// Number of segments: more slots than any address space can hold (see the module documentation).
#[cfg(not(feature = "loom"))]
pub(crate) const SEGMENTS: usize = 50;
/// Number of segments under loom (2 + 4 + 8 = 14 slots), to keep the model's state small.
#[cfg(feature = "loom")]
pub(crate) const SEGMENTS: usize = 3;

/// The segment and offset of slot `index`, or `None` past the last segment.
///
/// Segment `s` holds `2^(s + BASE_SHIFT)` slots and starts at index `2^(s + BASE_SHIFT) - 2^BASE_SHIFT`.
#[inline]
pub(crate) fn locate(index: usize) -> Option<(usize, usize)> {
    let shifted = index.checked_add(1 << BASE_SHIFT)?;
    let segment = (usize::BITS - 1 - shifted.leading_zeros() - BASE_SHIFT) as usize;
    (segment < SEGMENTS).then(|| (segment, shifted - (1 << (segment as u32 + BASE_SHIFT))))
}

/// How many slots segment `segment` holds.
#[inline]
pub(crate) const fn segment_len(segment: usize) -> usize {
    1 << (segment as u32 + BASE_SHIFT)
}

/// A slot's state: reserved (or not yet reserved) and not written.
const UNWRITTEN: u8 = 0;
/// A slot's state: its key and record are written, and no removal has taken it.
const LIVE: u8 = 1;
/// A slot's state: a removal took its record. Never left.
const REMOVED: u8 = 2;

/// What a scan reads of every slot: the publication state and the record's key.
struct Hot {
    /// Written once by the thread that reserved the slot, before `state` becomes [`LIVE`].
    key: UnsafeCell<MaybeUninit<Key>>,
    /// [`UNWRITTEN`], then [`LIVE`] (stored with Release once the key and the record are fully
    /// written), then perhaps [`REMOVED`] (by one compare-and-swap from `LIVE`). Never goes back.
    state: AtomicU8,
    /// Under loom, a slot never freed — so a segment never freed — fails the model (`Allocation
    /// leaked.`); zero-sized elsewhere.
    _tracked: Tracked,
}

/// What a scan reads only of the slots whose key passes: the record.
struct Cold {
    /// Written once by the thread that reserved the slot, before the slot's `ready` is set.
    record: UnsafeCell<MaybeUninit<Record>>,
}

impl Hot {
    /// An unwritten slot. Under loom a leak report names the caller's line (in `install`).
    #[cfg_attr(feature = "loom", track_caller)]
    fn empty() -> Self {
        Self {
            key: UnsafeCell::new(MaybeUninit::uninit()),
            state: AtomicU8::new(UNWRITTEN),
            _tracked: Tracked::new(),
        }
    }
}

/// What a segment holds, for the list's auto traits: hot halves, cold halves and (the first
/// segment) the directory of the others, owned.
type Segment = (Box<[Hot]>, Box<[Cold]>, Box<Directory>);

/// The pointers of a list's segments after the first: entry `s - 1` is segment `s`'s, null or an
/// allocation of `block_layout(segment_len(s), false)` (hot halves, then cold ones).
struct Directory {
    entries: [AtomicPtr<Hot>; SEGMENTS - 1],
    /// Under loom, a directory never freed fails the model (`Allocation leaked.`).
    _tracked: Tracked,
}

impl Directory {
    /// An empty directory. Under loom a leak report names the caller's line.
    #[cfg_attr(feature = "loom", track_caller)]
    fn new() -> Self {
        Self {
            entries: std::array::from_fn(|_| AtomicPtr::new(ptr::null_mut())),
            _tracked: Tracked::new(),
        }
    }
}

/// The layout of a block of `len` slots (its hot halves, then its cold halves, then for a list's
/// first block the pointer to the directory of the later segments) and the byte offset of the
/// cold halves.
///
/// # Panics
/// If the block would not fit the address space (only blocks far beyond any memory).
fn block_layout(len: usize, first: bool) -> (Layout, usize) {
    let too_large = "record list segment larger than the address space";
    let hot = Layout::array::<Hot>(len).expect(too_large);
    let cold = Layout::array::<Cold>(len).expect(too_large);
    let (layout, cold_offset) = hot.extend(cold).expect(too_large);
    let layout = if first {
        let directory = Layout::new::<AtomicPtr<Directory>>();
        layout.extend(directory).expect(too_large).0
    } else {
        layout
    };
    (layout.pad_to_align(), cold_offset)
}

/// Where the directory pointer lies in a first block of `len` slots: after its cold halves,
/// aligned.
#[inline(always)]
const fn directory_offset(len: usize) -> usize {
    (cold_offset(len) + len * size_of::<Cold>())
        .next_multiple_of(align_of::<AtomicPtr<Directory>>())
}

/// The directory pointer in the first block at `first`, of `len` slots.
///
/// SAFETY: `first` must be a live first block from `new_block(len, true)`.
#[inline(always)]
unsafe fn directory_pointer(first: *mut Hot, len: usize) -> *mut AtomicPtr<Directory> {
    // SAFETY: the pointer lies `directory_offset(len)` bytes into the first block (checked
    // against `block_layout` by a test).
    unsafe {
        first
            .byte_add(directory_offset(len))
            .cast::<AtomicPtr<Directory>>()
    }
}

/// The cold half of slot `offset` in the block of `len` slots at `base`.
///
/// SAFETY: `base` must be a live block of `len` slots from `install`, and `offset` below `len`.
#[inline(always)]
unsafe fn cold(base: *mut Hot, len: usize, offset: usize) -> *mut Cold {
    // SAFETY: the cold halves start `cold_offset(len)` bytes into the allocation (checked
    // against `block_layout` by a test), and `offset` is within them (the caller's guarantee).
    unsafe { base.byte_add(cold_offset(len)).cast::<Cold>().add(offset) }
}

/// Where the cold halves of a block of `len` slots start: after its hot halves, rounded up to
/// the cold halves' alignment (what `Layout::extend` computes, without its overflow checks, which
/// `block_layout` made when the block was allocated).
#[inline(always)]
const fn cold_offset(len: usize) -> usize {
    (len * size_of::<Hot>()).next_multiple_of(align_of::<Cold>())
}

/// The list was full (only under `loom`, where capacity is shrunk).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ListFull;

/// An append-only, wait-free list of records. `repr(C)`: the head, the first block's pointer and
/// its length come first, where a node puts them on the cache line a walk reads.
#[repr(C)]
pub struct RecordList<O: Orderings> {
    /// Slots reserved so far (written or not).
    head: AtomicUsize,
    /// Segment 0, the first block: null, or an allocation of `block_layout(first_len, true)`
    /// holding `first_len` hot halves, as many cold ones, and the pointer to the [`Directory`] of
    /// the later segments (null until the list first outgrows this block).
    first: AtomicPtr<Hot>,
    /// The first block's slots: `segment_len(0)`, or a sealed list's length (module
    /// documentation, 5). Written only with `&mut self` (`compact`), so read plainly.
    first_len: usize,
    /// The list owns its segments (and, through them, `UnsafeCell`s: not auto-`Sync`).
    _owns: PhantomData<(Segment, O)>,
}

// SAFETY: the list hands out `&Key` and `&Record` only from slots whose state it loaded as live
// (or removed, which only a live slot becomes), and a slot's key and record are written only by the single thread that reserved its index,
// before that thread sets the flag; after that they are never written again. So a shared `&RecordList` never
// allows a write to race a read. Segments are freed only in `Drop` (`&mut self`).
unsafe impl<O: Orderings> Sync for RecordList<O> {}
// SAFETY: the list owns its segments outright; `Record` is `Send`.
unsafe impl<O: Orderings> Send for RecordList<O> {}

impl<O: Orderings> RecordList<O> {
    /// Bytes from the list's start to the end of the first block's length: what a scan of a list
    /// that fits its first block reads of the list itself.
    #[cfg(all(test, not(checker)))]
    pub(crate) const HOT_FIELDS_END: usize =
        std::mem::offset_of!(Self, first_len) + size_of::<usize>();

    /// An empty list (no segment allocated).
    pub fn new() -> Self {
        Self::with_first_len(segment_len(0))
    }

    /// An empty list whose first block, once allocated, holds `first_len` slots.
    fn with_first_len(first_len: usize) -> Self {
        Self {
            head: AtomicUsize::new(0),
            first: AtomicPtr::new(ptr::null_mut()),
            first_len,
            _owns: PhantomData,
        }
    }

    /// The block and offset of slot `index`, or `None` past the last segment: the first block's
    /// `first_len` slots, then segments 1, 2, ... as in [`locate`].
    #[inline(always)]
    fn place(&self, index: usize) -> Option<(usize, usize)> {
        if index < self.first_len {
            Some((0, index))
        } else {
            locate(index - self.first_len + segment_len(0))
        }
    }

    /// Whether slot `index` is the first of the second or a later segment past the first block:
    /// the push that reserved it opened that segment (one push for each, as indices are unique),
    /// and only such a push can bring the list to need a rebuild (module documentation, 5).
    #[inline]
    pub(crate) fn opens_segment(&self, index: usize) -> bool {
        matches!(self.place(index), Some((segment, 0)) if segment > 1)
    }

    /// How many slots block `segment` holds: the first block's `first_len`, or the segment's.
    #[inline(always)]
    fn block_len(&self, segment: usize) -> usize {
        if segment == 0 {
            self.first_len
        } else {
            segment_len(segment)
        }
    }

    /// The number of slots the list can hold.
    fn capacity(&self) -> usize {
        self.first_len + (capacity() - segment_len(0))
    }

    /// Appends `record` with its `key`; returns the index of its slot.
    #[inline]
    pub(crate) fn push_keyed(&self, key: Key, record: Record) -> Result<usize, ListFull> {
        // Relaxed (Reserve): the read-modify-write alone makes indices unique; nothing is published
        // through the head — readers learn a slot is written from its own flag.
        let index = self.head.fetch_add(1, ord::<O>(Site::Reserve));
        let (segment, offset) = self.place(index).ok_or(ListFull)?;
        // Every segment's pointer is found through the first segment, so it comes first.
        let first = self.segment(&self.first, 0);
        let base = if segment == 0 {
            first
        } else {
            let directory = self.directory(first);
            self.segment(&directory.entries[segment - 1], segment)
        };
        // SAFETY: `base` is a live block of `block_len(segment)` slots and `offset` is below that
        // length (from `place`); blocks are never freed while `&self` exists.
        let (hot, cold) = unsafe {
            (
                &*base.add(offset),
                &*cold(base, self.block_len(segment), offset),
            )
        };
        hot.key.with_mut(|cell| {
            // SAFETY: `index` came from the `fetch_add` above, so this thread is the only writer of
            // this slot ever; no reader touches it before the ready flag below is set.
            unsafe { cell.write(MaybeUninit::new(key)) }
        });
        cold.record.with_mut(|cell| {
            // SAFETY: as for the key: the only writer, before the flag.
            unsafe { cell.write(MaybeUninit::new(record)) }
        });
        if O::PUBLISH_SLOTS {
            // Release (SlotPublish): makes the key and record written above visible to any reader
            // whose Acquire load in `scan` sees `LIVE`. A plain store, not a read-modify-write:
            // no removal touches a slot before it is live, so nothing else can have written it.
            hot.state.store(LIVE, ord::<O>(Site::SlotPublish));
        }
        Ok(index)
    }

    /// Appends `record` with a key at accuracy 1 (for the models that exercise the list alone;
    /// the cache pushes with its own accuracy through `push_keyed`); returns its slot's index.
    #[cfg(any(all(test, not(checker)), feature = "loom"))]
    #[inline]
    pub fn push(&self, record: Record) -> Result<usize, ListFull> {
        self.push_keyed(Key::of(&record, 1.0), record)
    }

    /// The segment `segment`, allocating and installing it if it is missing.
    #[inline]
    fn segment(&self, pointer: &AtomicPtr<Hot>, segment: usize) -> *mut Hot {
        // Acquire (SegmentRead): pairs with the Release compare-and-swap in `install`, so the
        // segment's initialised (not-ready) slots, and the first segment's directory, are visible
        // before this thread writes one or reads the directory.
        let base = pointer.load(ord::<O>(Site::SegmentRead));
        if base.is_null() {
            self.install(pointer, segment)
        } else {
            base
        }
    }

    /// Allocates segment `segment` and tries once to install it; returns the installed one.
    #[cold]
    #[inline(never)]
    fn install(&self, pointer: &AtomicPtr<Hot>, segment: usize) -> *mut Hot {
        // SAFETY (of the closure's call): `publish_once` passes back `fresh` only when its
        // compare-and-swap failed, so the segment was never shared.
        let (len, first) = (self.block_len(segment), segment == 0);
        publish_once::<O, _>(pointer, new_block(len, first), |fresh| unsafe {
            free_block(fresh, len, first)
        })
    }

    /// The directory of the list whose live first segment is `first`, allocated and installed
    /// (one compare-and-swap, never retried) if it is missing.
    #[inline]
    fn directory(&self, first: *mut Hot) -> &Directory {
        // SAFETY: `first` is the list's live first block, of `first_len` slots, which lives as
        // long as `&self`.
        let pointer = unsafe { &*directory_pointer(first, self.first_len) };
        // Acquire (SegmentRead): pairs with the Release compare-and-swap in `publish_once`, so the
        // directory's null entries are visible before this thread reads or installs one.
        let existing = pointer.load(ord::<O>(Site::SegmentRead));
        let directory = if existing.is_null() {
            let fresh = Box::into_raw(Box::new(Directory::new()));
            // SAFETY (of the closure's call): `fresh` came from `Box::into_raw` just above and is
            // passed back only if it was never shared.
            publish_once::<O, _>(pointer, fresh, |fresh| {
                drop(unsafe { Box::from_raw(fresh) })
            })
        } else {
            existing
        };
        // SAFETY: a non-null directory pointer came from `Box::into_raw` and is freed only when
        // the list is dropped (`&mut self`), which `&self` rules out.
        unsafe { &*directory }
    }

    /// Calls `f` with every published record. Slots that are reserved but not yet written, or
    /// whose segment is not yet installed, are skipped.
    #[inline]
    pub fn for_each(&self, f: &mut impl FnMut(&Record)) {
        self.scan(|_| true, f);
    }

    /// Calls `f` with every published record whose key `admit` passes, in slot order; returns
    /// the number of slots read (their flags loaded: the keys examined, and any slot reserved but
    /// not yet written, which only a concurrent insert leaves; counting it keeps the scan's loop
    /// free of a counter). Slots that are reserved but not yet written, or whose segment is not
    /// yet installed, are skipped.
    #[inline]
    pub(crate) fn scan(&self, admit: impl Fn(&Key) -> bool, f: &mut impl FnMut(&Record)) -> u32 {
        self.visit(admit, &mut |_, _, record| f(record))
    }

    /// [`RecordList::scan`], calling `f` with each admitted live slot's state, key and record.
    #[inline(always)]
    fn visit(
        &self,
        admit: impl Fn(&Key) -> bool,
        f: &mut impl FnMut(&AtomicU8, &Key, &Record),
    ) -> u32 {
        // Relaxed (HeadRead): the head only bounds the scan. A stale value merely skips records
        // whose insert is concurrent with this scan; every slot read is guarded by its own flag.
        let reserved = self.head.load(ord::<O>(Site::HeadRead));
        if reserved == 0 {
            return 0;
        }
        // Acquire (SegmentRead): pairs with the Release in `install`; see `segment`. A null first
        // segment means no slot this thread may read: a writer installs the first segment before
        // any other (`push_keyed`).
        let first = self.first.load(ord::<O>(Site::SegmentRead));
        if first.is_null() {
            return 0;
        }
        // The common case, a list within its first block (four slots, or a sealed list's length).
        let first_len = self.first_len;
        if reserved <= first_len {
            // SAFETY: `first` is the live first block, of `first_len` slots, and `reserved` is
            // within it.
            unsafe { scan_segment::<O>(first, first_len, reserved, &admit, f) };
            return reserved as u32;
        }
        // SAFETY: `first` is the list's live first block, of `first_len` slots.
        let pointer = unsafe { &*directory_pointer(first, first_len) };
        // Acquire (SegmentRead): pairs with the Release in `directory`, as for a segment. A null
        // directory hides the later segments, whose slots were then written by inserts that do
        // not happen-before this scan (a writer installs the directory before its segment).
        let directory = pointer.load(ord::<O>(Site::SegmentRead));
        // SAFETY: a non-null directory is live for `&self`'s lifetime (see `directory`).
        let directory = unsafe { directory.as_ref() };
        let mut examined = 0;
        let mut remaining = reserved;
        let mut segment = 0;
        while remaining > 0 && segment < SEGMENTS {
            let slots = self.block_len(segment);
            let len = remaining.min(slots);
            let base = if segment == 0 {
                first
            } else if let Some(directory) = directory {
                // Acquire (SegmentRead): as for the first segment.
                directory.entries[segment - 1].load(ord::<O>(Site::SegmentRead))
            } else {
                break;
            };
            if !base.is_null() {
                // SAFETY: `base` is live block `segment`, of `slots` slots, and `len` is within it.
                unsafe { scan_segment::<O>(base, slots, len, &admit, f) };
                examined += len as u32;
            }
            remaining -= len;
            segment += 1;
        }
        examined
    }

    /// Removes every live record `select` takes: one compare-and-swap of its slot's state from
    /// live to removed, never retried (module documentation, 4). Returns how many this call
    /// removed (a record another removal took first is not counted here) and how many slots it
    /// examined: one pass over the slots reserved when it read the head, never a second.
    pub(crate) fn remove_where(&self, select: impl Fn(&Record) -> bool) -> (u32, u32) {
        let mut removed = 0;
        let examined = self.visit(|_| true, &mut |state, _, record| {
            if select(record) && take::<O>(state) {
                removed += 1;
            }
        });
        (removed, examined)
    }

    /// Reclaims the slots of removed records and the spare slots of a grown list: if any reserved
    /// slot is not live, or the list has opened two segments past its first block and its unused
    /// slots exceed its live records over [`SPARE_DIVISOR`], moves the live records, in slot
    /// order, into the first block of a fresh list that replaces this one (freeing every old
    /// block): their number of slots and a sixteenth, at least `segment_len(0)`. Returns the live
    /// count. `&mut self`: no reader or writer exists.
    pub(crate) fn compact(&mut self) -> usize {
        let mut live = 0;
        self.visit(|_| true, &mut |_, _, _| live += 1);
        let allocated = self.allocated();
        let two_segments = allocated >= self.first_len + segment_len(1) + segment_len(2);
        let grown = two_segments && (allocated - live) * SPARE_DIVISOR > live;
        if live < self.reserved() || grown {
            // Room for a sixteenth more: the next inserts land in the block, not in a segment
            // whose opening would have the next close copy the list again.
            let fresh = Self::with_first_len((live + live / SPARE_DIVISOR).max(segment_len(0)));
            self.visit(|_| true, &mut |_, key, record| {
                // The fresh list's first block has room for every live record.
                let pushed = fresh.push_keyed(*key, *record);
                debug_assert!(pushed.is_ok());
            });
            *self = fresh;
        }
        live
    }

    /// Slots reserved, live or not.
    pub(crate) fn reserved(&mut self) -> usize {
        // Relaxed: `&mut self`.
        self.head.load(Ordering::Relaxed).min(self.capacity())
    }

    /// Slots allocated, reserved or not: the first block's and every installed segment's.
    pub(crate) fn allocated(&mut self) -> usize {
        // Relaxed: `&mut self` — every other thread's accesses happen-before this.
        let first = self.first.load(Ordering::Relaxed);
        if first.is_null() {
            return 0;
        }
        // SAFETY: `first` is the live first block, of `first_len` slots.
        let pointer = unsafe { &*directory_pointer(first, self.first_len) };
        // Relaxed: as above.
        let directory = pointer.load(Ordering::Relaxed);
        // SAFETY: a non-null directory is live as long as the list (see `directory`).
        let later = unsafe { directory.as_ref() }.map_or(0, |directory| {
            (1..SEGMENTS)
                // Relaxed: as above.
                .filter(|&s| !directory.entries[s - 1].load(Ordering::Relaxed).is_null())
                .map(segment_len)
                .sum()
        });
        self.first_len + later
    }

    /// How many records are published (for statistics; `&mut self`, so nothing is in flight).
    pub fn published(&mut self) -> usize {
        let mut n = 0;
        self.for_each(&mut |_| n += 1);
        n
    }
}

/// Installs `fresh` (a segment or a directory, initialised and not yet shared) into the null
/// `pointer` with one compare-and-swap, never retried; returns what the pointer holds after it.
/// If another thread installed first, `fresh` goes to `free` and the winner's is returned.
fn publish_once<O: Orderings, T>(
    pointer: &AtomicPtr<T>,
    fresh: *mut T,
    free: impl FnOnce(*mut T),
) -> *mut T {
    match pointer.compare_exchange(
        ptr::null_mut(),
        fresh,
        // Release (SegmentPublish): publishes `fresh`'s initialisation to every thread that later
        // loads this pointer with Acquire. Nothing is read through the old null value, so the
        // success ordering needs no Acquire half.
        ord::<O>(Site::SegmentPublish),
        // Acquire (SegmentCasFailure): another thread installed first; the caller goes on to use
        // the winner's, whose initialisation must happen-before that.
        ord::<O>(Site::SegmentCasFailure),
    ) {
        Ok(_) => fresh,
        Err(winner) => {
            free(fresh);
            winner
        }
    }
}

/// Moves a live slot's `state` to removed; true for the call that did. One compare-and-swap,
/// never retried: if it fails, another removal took the slot (it was live when this thread read
/// its record, and only a removal changes a live slot).
#[inline]
fn take<O: Orderings>(state: &AtomicU8) -> bool {
    if O::REMOVE_BY_CAS {
        state
            .compare_exchange(
                LIVE,
                REMOVED,
                // Relaxed (SlotRemove): the compare-and-swap's atomicity is what the removal
                // needs: exactly one removal moves the slot, and only from live, so a removed
                // slot never becomes live again (the state's modification order is unwritten,
                // live, removed). It publishes nothing: no one reads the record of a removed
                // slot. A lookup that happens-after this store loads `REMOVED` by write-read
                // coherence, whatever the ordering; the record itself stays in place until
                // `compact` (with `&mut`).
                ord::<O>(Site::SlotRemove),
                // Relaxed: a failed removal reads nothing through the state.
                Ordering::Relaxed,
            )
            .is_ok()
    } else {
        // The loom-only `BlindRemove` policy: a load and a store in place of the
        // compare-and-swap. Two overlapping removals can then both count one record.
        // Relaxed: as above.
        if state.load(Ordering::Relaxed) == LIVE {
            state.store(REMOVED, Ordering::Relaxed);
            true
        } else {
            false
        }
    }
}

/// The number of slots a list whose first block is `segment_len(0)` can hold.
const fn capacity() -> usize {
    (1 << BASE_SHIFT) * ((1 << SEGMENTS) - 1)
}

/// Reads the first `len` slots of the block of `slots` slots at `base`: calls `f` with each live
/// slot's state, key and record whose key `admit` passes.
///
/// SAFETY: `base` must be a live block of `slots` slots of a list that outlives the call, and
/// `len` at most `slots`.
#[inline(always)]
unsafe fn scan_segment<O: Orderings>(
    base: *mut Hot,
    slots: usize,
    len: usize,
    admit: &impl Fn(&Key) -> bool,
    f: &mut impl FnMut(&AtomicU8, &Key, &Record),
) {
    // SAFETY: `len <= slots` hot halves lie at `base`, initialised by
    // `new_block` and live as long as the list (the caller's guarantee); they are only ever
    // accessed through `&` (the key through its `UnsafeCell`, the flag atomically).
    let hots = unsafe { std::slice::from_raw_parts(base.cast_const(), len) };
    for hot in hots {
        // Acquire (SlotRead): pairs with the Release store in `push_keyed`; seeing `LIVE` makes
        // the key and the record written before that store visible.
        if O::PUBLISH_SLOTS && hot.state.load(ord::<O>(Site::SlotRead)) != LIVE {
            continue;
        }
        // The key and the record are taken out of their cells' `with` as references, and the
        // prefilter and the visitor run outside those closures: a closure around them was
        // compiled as a call a key, about 30 instructions a key more than TRA's inlined loop
        // (`results/records-held/`). Loom records each read when `with` is entered, so a write
        // not ordered before it is still reported.
        // SAFETY: the slot was seen live, so the key was fully written and is never written
        // again while the list is shared (with `PUBLISH_SLOTS` off — loom's paper-literal
        // model — this is exactly the race loom must report); the reference lives no longer
        // than `hots`.
        let key: &Key = hot.key.with(|cell| unsafe { (*cell).assume_init_ref() });
        if !admit(key) {
            continue;
        }
        // SAFETY: `hot` is an element of `hots`, which starts at `base`: the offset is its index,
        // below `len`. Same block and offset as `hot`.
        let cold = unsafe {
            let offset = ptr::from_ref(hot).offset_from(base) as usize;
            &*cold(base, slots, offset)
        };
        // SAFETY: as for the key, under the same state (a removal leaves the record in place;
        // only `compact`, with `&mut`, frees it).
        let record: &Record = cold
            .record
            .with(|cell| unsafe { (*cell).assume_init_ref() });
        f(&hot.state, key, record);
    }
}

/// Allocates a block of `len` slots (a list's first block if `first`), every slot unwritten.
#[cfg_attr(feature = "loom", track_caller)]
fn new_block(len: usize, first: bool) -> *mut Hot {
    let (layout, _) = block_layout(len, first);
    // SAFETY: the layout has a non-zero size (every block has at least one slot of 32 + 128
    // bytes; under loom the halves are loom's, larger still).
    let base = unsafe { alloc::alloc(layout) }.cast::<Hot>();
    if base.is_null() {
        alloc::handle_alloc_error(layout);
    }
    for offset in 0..len {
        // SAFETY: both halves of slot `offset` lie inside the fresh allocation (`block_layout`)
        // and are written once here, before the pointer is shared.
        unsafe {
            base.add(offset).write(Hot::empty());
            cold(base, len, offset).write(Cold {
                record: UnsafeCell::new(MaybeUninit::uninit()),
            });
        }
    }
    if first {
        // SAFETY: the directory pointer lies inside the fresh first block (`block_layout`) and is
        // written once here, before the block is shared.
        unsafe { directory_pointer(base, len).write(AtomicPtr::new(ptr::null_mut())) };
    }
    base
}

/// Reclaims a block allocated by `new_block`.
///
/// SAFETY: `base` must come from `new_block(len, first)`, must not be in use by anyone else, and
/// must not be used afterwards.
unsafe fn free_block(base: *mut Hot, len: usize, first: bool) {
    let (layout, _) = block_layout(len, first);
    for offset in 0..len {
        // SAFETY: each half was initialised by `new_block` and is dropped once. `Key` and
        // `Record` are `Copy`: the `MaybeUninit` contents need no drop; the halves' own fields
        // (loom's cells and atomics, the leak tracker) do.
        unsafe {
            std::ptr::drop_in_place(base.add(offset));
            std::ptr::drop_in_place(cold(base, len, offset));
        }
    }
    if first {
        // SAFETY: initialised by `new_block(len, true)`, dropped once (the directory it points
        // to, if any, is the list's to free).
        unsafe { std::ptr::drop_in_place(directory_pointer(base, len)) };
    }
    // SAFETY: allocated by `new_block` with this layout.
    unsafe { alloc::dealloc(base.cast::<u8>(), layout) };
}

impl<O: Orderings> Default for RecordList<O> {
    fn default() -> Self {
        Self::new()
    }
}

impl<O: Orderings> Drop for RecordList<O> {
    fn drop(&mut self) {
        // Relaxed: `&mut self` — every other thread's accesses happen-before this drop.
        let first = self.first.load(Ordering::Relaxed);
        if first.is_null() {
            return;
        }
        // SAFETY: `first` is the live first block, of `first_len` slots.
        let pointer = unsafe { &*directory_pointer(first, self.first_len) };
        // Relaxed: as above.
        let directory = pointer.load(Ordering::Relaxed);
        if !directory.is_null() {
            // SAFETY: installed by `directory` from `Box::into_raw`, owned by this list alone.
            let directory = unsafe { Box::from_raw(directory) };
            for (index, entry) in directory.entries.iter().enumerate() {
                // Relaxed: as above.
                let base = entry.load(Ordering::Relaxed);
                if !base.is_null() {
                    // SAFETY: installed by `install` from `new_block(segment_len(index + 1),
                    // false)`, and nothing can use it after the list is dropped.
                    unsafe { free_block(base, segment_len(index + 1), false) };
                }
            }
        }
        // SAFETY: installed by `install` from `new_block(first_len, true)`, not used again.
        unsafe { free_block(first, self.first_len, true) };
    }
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::super::orderings::Minimal;
    use super::*;
    use glam::Vec3;

    #[test]
    fn locate_maps_indices_to_growing_segments() {
        // Segments of 4, 8, 16, ... slots.
        assert_eq!(locate(0), Some((0, 0)));
        assert_eq!(locate(3), Some((0, 3)));
        assert_eq!(locate(4), Some((1, 0)));
        assert_eq!(locate(11), Some((1, 7)));
        assert_eq!(locate(12), Some((2, 0)));
        assert_eq!(segment_len(2), 16);
        // The last slot is index 4 (2^50 - 1) - 1, and it is the last of the last segment;
        // `usize::MAX` (whose `+ 4` overflows) has none either.
        let last = 4 * ((1usize << 50) - 1) - 1;
        assert_eq!(
            locate(last),
            Some((SEGMENTS - 1, segment_len(SEGMENTS - 1) - 1))
        );
        assert_eq!(locate(last + 1), None);
        assert_eq!(locate(usize::MAX), None);
        // Consecutive indices are consecutive slots.
        let mut previous = locate(0).unwrap();
        for i in 1..10_000 {
            let here = locate(i).unwrap();
            if here.0 == previous.0 {
                assert_eq!(here.1, previous.1 + 1);
            } else {
                assert_eq!((here.0, here.1), (previous.0 + 1, 0));
                assert_eq!(previous.1 + 1, segment_len(previous.0));
            }
            previous = here;
        }
    }

    /// The leak tracker ([`crate::sync::Tracked`]) costs nothing outside loom: a slot's hot half
    /// is its key and flag in 32 bytes (two to a cache line), its cold half the 128-byte record,
    /// and the first segment, 4 slots and the directory pointer in 648 bytes, stays within glibc's
    /// per-thread cache of small blocks (see the module documentation).
    #[test]
    fn a_slot_is_a_32_byte_key_and_flag_and_a_record() {
        assert_eq!(size_of::<Hot>(), 32);
        assert_eq!(size_of::<Cold>(), size_of::<Record>());
        assert_eq!(size_of::<Record>(), 128);
        // The first segment: 4 hot halves, 4 records, the directory pointer, 648 bytes.
        assert_eq!(
            block_layout(4, true),
            (Layout::from_size_align(648, 8).unwrap(), 128)
        );
        assert_eq!(directory_offset(4) + 8, 648);
        assert_eq!(
            block_layout(8, false),
            (Layout::from_size_align(1280, 8).unwrap(), 256)
        );
        // A sealed first block of any length: the directory pointer is its last word.
        for len in (1..70).chain([1000, 4097]) {
            let (layout, cold) = block_layout(len, true);
            assert_eq!(cold_offset(len), cold, "len {len}");
            assert_eq!(directory_offset(len) + 8, layout.size(), "len {len}");
            assert_eq!(block_layout(len, false).1, cold, "len {len}");
        }
    }

    #[test]
    fn push_and_scan_across_segments() {
        let mut list = RecordList::<Minimal>::new();
        for i in 0..100 {
            let r = Record::new(Vec3::splat(i as f32), Vec3::Z, Vec3::ONE, 1.0);
            list.push(r).unwrap();
        }
        let mut seen = Vec::new();
        list.for_each(&mut |r| seen.push(r.position.x as usize));
        assert_eq!(seen, (0..100).collect::<Vec<_>>());
        assert_eq!(list.published(), 100);
    }

    fn record(i: usize) -> Record {
        Record::new(Vec3::splat(i as f32), Vec3::Z, Vec3::ONE, 1.0)
    }

    fn positions(list: &RecordList<Minimal>) -> Vec<usize> {
        let mut seen = Vec::new();
        list.for_each(&mut |r| seen.push(r.position.x as usize));
        seen
    }

    #[test]
    fn a_grown_list_is_sealed_into_one_block_and_grows_on_after_it() {
        let mut list = RecordList::<Minimal>::new();
        for i in 0..100 {
            list.push(record(i)).unwrap();
        }
        // Segments of 4, 8, 16, 32 and 64 slots: 124 allocated, 24 unused > 100 / 16.
        assert_eq!(list.allocated(), 124);
        assert_eq!(list.compact(), 100);
        // One block of 100 and a sixteenth (6).
        assert_eq!((list.first_len, list.allocated()), (106, 106));
        assert_eq!(positions(&list), (0..100).collect::<Vec<_>>());
        // A second close copies nothing.
        let first = list.first.load(Ordering::Relaxed);
        assert_eq!(list.compact(), 100);
        assert_eq!(list.first.load(Ordering::Relaxed), first);
        // The next six land in the block; the seventh opens a segment of 8 after it, and the list
        // is found in order.
        for i in 100..107 {
            assert_eq!(list.push(record(i)).unwrap(), i);
            assert!(!list.opens_segment(i));
        }
        assert_eq!(list.allocated(), 114);
        assert_eq!(positions(&list), (0..107).collect::<Vec<_>>());
        // One segment past the block: kept, whatever its unused slots.
        list.compact();
        assert_eq!(list.first.load(Ordering::Relaxed), first);
        assert_eq!((list.first_len, list.allocated()), (106, 114));
        for i in 107..115 {
            list.push(record(i)).unwrap();
        }
        // Slot 114 opened the second segment (16): 130 slots, 15 unused > 115 / 16: rebuilt.
        assert!(list.opens_segment(114));
        assert_eq!(list.allocated(), 130);
        assert_eq!(list.compact(), 115);
        assert_eq!((list.first_len, list.allocated()), (122, 122));
        assert_eq!(positions(&list), (0..115).collect::<Vec<_>>());
    }

    #[test]
    fn a_list_is_rebuilt_only_past_a_second_segment() {
        let mut list = RecordList::<Minimal>::new();
        list.push(record(7)).unwrap();
        let first = list.first.load(Ordering::Relaxed);
        // Three unused slots of four, but nothing past the first block: no copy.
        assert_eq!(list.compact(), 1);
        assert_eq!(list.first.load(Ordering::Relaxed), first);
        assert_eq!((list.first_len, list.allocated()), (4, 4));
        // Five records: segments of 4 and 8, 7 unused, but one segment past the block: kept.
        for i in 0..4 {
            list.push(record(i)).unwrap();
        }
        assert_eq!(list.compact(), 5);
        assert_eq!((list.first_len, list.allocated()), (4, 12));
        // Thirteen: segments of 4, 8 and 16, 15 unused > 13 / 16: rebuilt at 13 (no sixteenth).
        for i in 4..12 {
            list.push(record(i)).unwrap();
        }
        assert_eq!(list.compact(), 13);
        assert_eq!((list.first_len, list.allocated()), (13, 13));
        let mut want = vec![7];
        want.extend(0..12);
        assert_eq!(positions(&list), want);
        // Twenty-eight in 4 + 8 + 16: nothing unused, kept with its segments.
        let mut full = RecordList::<Minimal>::new();
        for i in 0..28 {
            full.push(record(i)).unwrap();
        }
        assert_eq!(full.compact(), 28);
        assert_eq!((full.first_len, full.allocated()), (4, 28));
    }

    /// A removed slot alone makes the close rebuild a list, even one within its first segment;
    /// and unused slots of exactly a sixteenth of the records are not "more than a sixteenth".
    #[test]
    fn a_removal_alone_rebuilds_and_a_sixteenth_exactly_does_not() {
        let mut list = RecordList::<Minimal>::new();
        for i in 0..3 {
            list.push(record(i)).unwrap();
        }
        let first = list.first.load(Ordering::Relaxed);
        assert_eq!(list.remove_where(|r| r.position.x == 1.0), (1, 3));
        assert_eq!(list.compact(), 2);
        assert_ne!(list.first.load(Ordering::Relaxed), first, "not rebuilt");
        assert_eq!((list.reserved(), list.allocated()), (2, 4));
        assert_eq!(positions(&list), vec![0, 2]);
        // A block of 10, then segments of 8 and 16: 34 slots, 32 records, 2 unused = 32 / 16.
        let mut list = RecordList::<Minimal>::with_first_len(10);
        for i in 0..32 {
            list.push(record(i)).unwrap();
        }
        assert_eq!(list.compact(), 32);
        assert_eq!((list.first_len, list.allocated()), (10, 34));
    }

    /// Grows a list by `batches`, closing a frame (`compact`) after each, and checks the bounds
    /// the module documentation (5) states: after each close the list's unused slots are at most a
    /// sixteenth of its records, or fewer than one segment of eight, and its records are all there
    /// in order. Returns the records and how many the rebuilds copied.
    fn grow_frame_by_frame(batches: &[usize]) -> (usize, usize) {
        let mut list = RecordList::<Minimal>::new();
        let (mut n, mut copied) = (0, 0);
        for &batch in batches {
            for _ in 0..batch {
                list.push(record(n)).unwrap();
                n += 1;
            }
            let before = list.first.load(Ordering::Relaxed);
            assert_eq!(list.compact(), n);
            if list.first.load(Ordering::Relaxed) != before {
                copied += n;
            }
            let unused = list.allocated() - n;
            assert!(
                unused * SPARE_DIVISOR <= n || unused < segment_len(1),
                "{unused} unused slots for {n} records"
            );
            assert_eq!(positions(&list), (0..n).collect::<Vec<_>>());
        }
        (n, copied)
    }

    /// A long list growing by a little every frame is copied seldom. Either half of the rule
    /// bounds the copying on its own: the sixteenth a rebuild leaves spare (the next inserts fill
    /// it before a segment opens), and waiting for a sixteenth unused before rebuilding. Seen
    /// failing with both halves taken out: the list is then copied every fifth frame.
    #[test]
    fn a_long_list_growing_a_little_each_frame_is_copied_seldom() {
        let mut batches = vec![1000];
        batches.extend([5; 120]);
        let (n, copied) = grow_frame_by_frame(&batches);
        assert!(copied <= 17 * n, "{copied} copies for {n} inserts");
    }

    proptest::proptest! {
        /// The same bounds over any growth, and the rebuilds' copying: at most 17 records copied
        /// for each record inserted (a rebuilt list of L records grows by at least L / 16 + 9
        /// before the next rebuild).
        #[test]
        fn between_frames_a_list_wastes_little_and_copies_a_bounded_amount(
            batches in proptest::collection::vec(0usize..300, 1..40)
        ) {
            let (n, copied) = grow_frame_by_frame(&batches);
            proptest::prop_assert!(copied <= 17 * n, "{} copies for {} inserts", copied, n);
        }
    }
}
