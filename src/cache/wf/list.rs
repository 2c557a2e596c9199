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
//!    frees its own segment and uses the winner's. With `B = 4` and 62 segments every `usize` index
//!    has a slot, so the list is bounded by memory, not by a constant. (`B = 4` keeps the first
//!    segment, 4 × 136 bytes, inside glibc's per-thread cache of small blocks (at most 1 032
//!    bytes); with `B = 8` a 1 088-byte segment missed it and a WF insert creating a node cost
//!    3.2 times more: 500 ns against 154 ns in `insert/wf`.) Under `loom` the segments
//!    are shrunk to `2, 4, 8` slots so three inserts reach a segment boundary; the logic is the same.
//!
//! Every operation is wait-free: a push is one `fetch_add`, at most one segment compare-and-swap
//! (never retried: if it fails, somebody else's segment is as good), one write and one store; a
//! scan reads at most `head` slots.

use super::orderings::{ord, Orderings, Site};
use crate::ic::Record;
use crate::sync::{AtomicBool, AtomicPtr, AtomicUsize, Ordering, Tracked, UnsafeCell};
use std::marker::PhantomData;
use std::mem::MaybeUninit;
use std::ptr;

/// log2 of the first segment's size (4 slots).
#[cfg(not(feature = "loom"))]
const BASE_SHIFT: u32 = 2;
/// log2 of the first segment's size: shrunk under loom so segment boundaries are reached in a few
/// inserts. This shouldn't change the logic, only how soon the model meets it.
#[cfg(feature = "loom")]
const BASE_SHIFT: u32 = 1;

/// Number of segments: enough for every `usize` index.
#[cfg(not(feature = "loom"))]
pub(crate) const SEGMENTS: usize = (usize::BITS - BASE_SHIFT) as usize;
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

/// One record and its publication flag.
struct Slot {
    /// Set (Release) once `record` is fully written; never cleared.
    ready: AtomicBool,
    /// Written once by the thread that reserved the slot, before `ready` is set.
    record: UnsafeCell<MaybeUninit<Record>>,
    /// Under loom, a slot never freed — so a segment never freed — fails the model (`Allocation
    /// leaked.`); zero-sized elsewhere.
    _tracked: Tracked,
}

impl Slot {
    /// An unwritten slot. Under loom a leak report names the caller's line (in `install`).
    #[cfg_attr(feature = "loom", track_caller)]
    fn empty() -> Self {
        Self {
            ready: AtomicBool::new(false),
            record: UnsafeCell::new(MaybeUninit::uninit()),
            _tracked: Tracked::new(),
        }
    }
}

/// The list was full (only under `loom`, where capacity is shrunk).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ListFull;

/// An append-only, wait-free list of records.
pub struct RecordList<O: Orderings> {
    /// Slots reserved so far (written or not).
    head: AtomicUsize,
    /// Segment `s`: null, or the first of `segment_len(s)` slots, allocated as a boxed slice.
    segments: [AtomicPtr<Slot>; SEGMENTS],
    /// The list owns its segments (and, through them, `UnsafeCell`s: not auto-`Sync`).
    _owns: PhantomData<(Box<[Slot]>, O)>,
}

// SAFETY: the list hands out `&Record` only from slots whose ready flag it loaded as set, and a
// slot's record is written only by the single thread that reserved its index, before that thread
// sets the flag; after that the record is never written again. So a shared `&RecordList` never
// allows a write to race a read. Segments are freed only in `Drop` (`&mut self`).
unsafe impl<O: Orderings> Sync for RecordList<O> {}
// SAFETY: the list owns its segments outright; `Record` is `Send`.
unsafe impl<O: Orderings> Send for RecordList<O> {}

impl<O: Orderings> RecordList<O> {
    /// An empty list (no segment allocated).
    pub fn new() -> Self {
        Self {
            head: AtomicUsize::new(0),
            segments: std::array::from_fn(|_| AtomicPtr::new(ptr::null_mut())),
            _owns: PhantomData,
        }
    }

    /// Appends `record`; returns the index of its slot.
    #[inline]
    pub fn push(&self, record: Record) -> Result<usize, ListFull> {
        // Relaxed (Reserve): the read-modify-write alone makes indices unique; nothing is published
        // through the head — readers learn a slot is written from its own flag.
        let index = self.head.fetch_add(1, ord::<O>(Site::Reserve));
        let (segment, offset) = locate(index).ok_or(ListFull)?;
        let base = self.segment(segment);
        // SAFETY: `base` is a live segment of `segment_len(segment)` slots and `offset` is below
        // that length (from `locate`); segments are never freed while `&self` exists.
        let slot = unsafe { &*base.add(offset) };
        slot.record.with_mut(|cell| {
            // SAFETY: `index` came from the `fetch_add` above, so this thread is the only writer of
            // this slot ever; no reader touches it before the ready flag below is set.
            unsafe { cell.write(MaybeUninit::new(record)) }
        });
        if O::PUBLISH_SLOTS {
            // Release (SlotPublish): makes the record written above visible to any reader whose
            // Acquire load in `for_each` sees `true`.
            slot.ready.store(true, ord::<O>(Site::SlotPublish));
        }
        Ok(index)
    }

    /// The segment `segment`, allocating and installing it if it is missing.
    #[inline]
    fn segment(&self, segment: usize) -> *mut Slot {
        // Acquire (SegmentRead): pairs with the Release compare-and-swap in `install`, so the
        // segment's initialised (not-ready) slots are visible before this thread writes one.
        let base = self.segments[segment].load(ord::<O>(Site::SegmentRead));
        if base.is_null() {
            self.install(segment)
        } else {
            base
        }
    }

    /// Allocates segment `segment` and tries once to install it; returns the installed one.
    #[cold]
    #[inline(never)]
    fn install(&self, segment: usize) -> *mut Slot {
        let fresh: Box<[Slot]> = (0..segment_len(segment)).map(|_| Slot::empty()).collect();
        let fresh = Box::into_raw(fresh).cast::<Slot>();
        match self.segments[segment].compare_exchange(
            ptr::null_mut(),
            fresh,
            // Release (SegmentPublish): publishes the slots' initialisation to every thread that
            // later loads this pointer with Acquire. Nothing is read through the old null value,
            // so the success ordering needs no Acquire half.
            ord::<O>(Site::SegmentPublish),
            // Acquire (SegmentCasFailure): another thread installed a segment first; we are about
            // to write into it, so its initialisation must happen-before our write.
            ord::<O>(Site::SegmentCasFailure),
        ) {
            Ok(_) => fresh,
            Err(winner) => {
                // SAFETY: `fresh` came from `Box::into_raw` of a slice of exactly this length just
                // above, and was never shared (the compare-and-swap failed).
                drop(unsafe { free_segment(fresh, segment) });
                winner
            }
        }
    }

    /// Calls `f` with every published record. Slots that are reserved but not yet written, or
    /// whose segment is not yet installed, are skipped.
    #[inline]
    pub fn for_each(&self, f: &mut impl FnMut(&Record)) {
        // Relaxed (HeadRead): the head only bounds the scan. A stale value merely skips records
        // whose insert is concurrent with this scan; every slot read is guarded by its own flag.
        let reserved = self.head.load(ord::<O>(Site::HeadRead));
        if reserved == 0 {
            return;
        }
        let mut remaining = reserved;
        for segment in 0..SEGMENTS {
            let len = remaining.min(segment_len(segment));
            // Acquire (SegmentRead): pairs with the Release in `install`; see `segment`.
            let base = self.segments[segment].load(ord::<O>(Site::SegmentRead));
            if !base.is_null() {
                for offset in 0..len {
                    // SAFETY: `offset < len <= segment_len(segment)`, the segment is live for
                    // `&self`'s lifetime.
                    let slot = unsafe { &*base.add(offset) };
                    read_slot::<O>(slot, f);
                }
            }
            remaining -= len;
            if remaining == 0 {
                break;
            }
        }
    }

    /// How many records are published (for statistics; `&mut self`, so nothing is in flight).
    pub fn published(&mut self) -> usize {
        let mut n = 0;
        self.for_each(&mut |_| n += 1);
        n
    }
}

#[inline(always)]
fn read_slot<O: Orderings>(slot: &Slot, f: &mut impl FnMut(&Record)) {
    // Acquire (SlotRead): pairs with the Release store in `push`; seeing `true` makes the whole
    // record written before that store visible here.
    if !O::PUBLISH_SLOTS || slot.ready.load(ord::<O>(Site::SlotRead)) {
        slot.record.with(|cell| {
            // SAFETY: the flag was seen set, so the record was fully written and is never written
            // again (with `PUBLISH_SLOTS` off — loom's paper-literal model — this is exactly the
            // race loom must report).
            f(unsafe { (*cell).assume_init_ref() })
        });
    }
}

/// Reclaims a segment allocated by `install`.
///
/// SAFETY: `base` must come from `Box::into_raw` of a `Box<[Slot]>` of `segment_len(segment)`
/// slots, and must not be used afterwards.
unsafe fn free_segment(base: *mut Slot, segment: usize) -> Box<[Slot]> {
    // SAFETY: guaranteed by the caller.
    unsafe { Box::from_raw(ptr::slice_from_raw_parts_mut(base, segment_len(segment))) }
}

impl<O: Orderings> Default for RecordList<O> {
    fn default() -> Self {
        Self::new()
    }
}

impl<O: Orderings> Drop for RecordList<O> {
    fn drop(&mut self) {
        for (segment, pointer) in self.segments.iter().enumerate() {
            // Relaxed: `&mut self` — every other thread's accesses happen-before this drop.
            let base = pointer.load(Ordering::Relaxed);
            if !base.is_null() {
                // SAFETY: installed by `install` from a boxed slice of this segment's length, and
                // nothing can use it after the list is dropped. `Record` is `Copy`: the slots'
                // `MaybeUninit` contents need no drop.
                drop(unsafe { free_segment(base, segment) });
            }
        }
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
        // Every index up to the top of the address space has a slot.
        let (segment, offset) = locate(usize::MAX - 4).unwrap();
        assert_eq!(segment, SEGMENTS - 1);
        assert!(offset < segment_len(segment));
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

    /// The leak tracker ([`crate::sync::Tracked`]) costs nothing outside loom: a slot is its flag
    /// and its record, 136 bytes on 64-bit targets (so the first segment, 4 slots, stays within
    /// glibc's per-thread cache of small blocks; see the module documentation).
    #[test]
    fn a_slot_is_its_flag_and_its_record() {
        use std::mem::size_of;
        assert_eq!(
            size_of::<Slot>(),
            size_of::<(AtomicBool, UnsafeCell<MaybeUninit<Record>>)>()
        );
        #[cfg(target_pointer_width = "64")]
        assert_eq!(size_of::<Slot>(), 136);
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
}
