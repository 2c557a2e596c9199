//! Memory-ordering policies for the wait-free cache: every atomic site of [`super`] takes its
//! ordering from a policy type, so the same code runs with the minimal sound orderings, with
//! `SeqCst` everywhere, or with a fence on the read path (what the paper avoided), and under loom
//! with one site weakened at a time to show which orderings are needed.
//!
//! The trait is sealed: outside `loom` builds only the three sound policies exist.

use crate::sync::Ordering::{self, Acquire, Relaxed, Release, SeqCst};

/// The atomic sites of the wait-free cache. The discriminant indexes [`Orderings::SITES`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Site {
    /// `fetch_add` on a list's head: reserves a slot index.
    Reserve = 0,
    /// Store of a slot's ready flag after its record is written.
    SlotPublish,
    /// Load of a slot's ready flag before its record is read.
    SlotRead,
    /// Load of a list's head by a reader (bounds the scan).
    HeadRead,
    /// Load of a segment pointer (writers and readers).
    SegmentRead,
    /// Successful compare-and-swap installing a new segment.
    SegmentPublish,
    /// Failed compare-and-swap on a segment pointer (another thread installed one).
    SegmentCasFailure,
    /// Load of a child pointer (writers and readers).
    ChildRead,
    /// Successful compare-and-swap publishing a privately built subtree.
    ChildPublish,
    /// Failed compare-and-swap on a child pointer (another thread published first).
    ChildCasFailure,
    /// `fetch_or` setting a child's bit in its parent's occupancy mask (by the thread that
    /// published the child, or by any insert that walks into it and finds the bit clear).
    MaskSet,
    /// Load of a node's occupancy mask by a lookup (which child pointers to load at all).
    MaskRead,
    /// Load of a node's occupancy mask by an insert about to mark a child (skips the `fetch_or`
    /// when the bit is already set).
    MaskTest,
    /// Load of a child pointer by a lookup, after its bit was seen in the mask.
    ChildFollow,
    /// Successful compare-and-swap of a slot's state from live to removed (a removal).
    SlotRemove,
}

impl Site {
    /// How many sites there are.
    pub const COUNT: usize = 15;

    /// Every site, in index order.
    pub const ALL: [Site; Site::COUNT] = [
        Site::Reserve,
        Site::SlotPublish,
        Site::SlotRead,
        Site::HeadRead,
        Site::SegmentRead,
        Site::SegmentPublish,
        Site::SegmentCasFailure,
        Site::ChildRead,
        Site::ChildPublish,
        Site::ChildCasFailure,
        Site::MaskSet,
        Site::MaskRead,
        Site::MaskTest,
        Site::ChildFollow,
        Site::SlotRemove,
    ];
}

mod sealed {
    pub trait Sealed {}
}

/// An ordering policy: one ordering per [`Site`], and whether lookups start with a fence.
pub trait Orderings: sealed::Sealed + Send + Sync + 'static {
    /// The policy's name in tables and benchmark ids.
    const NAME: &'static str;
    /// The ordering of each site, indexed by `Site as usize`.
    const SITES: [Ordering; Site::COUNT];
    /// A `SeqCst` fence at the start of every lookup.
    const READ_FENCE: bool = false;
    /// Whether writers publish slots and readers check the flag. Only the loom-only
    /// `PaperLiteral` policy clears it (readers then read every reserved slot, as Listing 6 does).
    const PUBLISH_SLOTS: bool = true;
    /// Whether an insert that walks into a published child marks it in the parent's occupancy
    /// mask when its publisher has not yet. Only the loom-only `Unhelped` policy clears it (then
    /// only the publisher marks), and loom must find the record a later lookup misses.
    const HELP_MARK: bool = true;
    /// Whether a removal moves a slot from live to removed with a compare-and-swap. Only the
    /// loom-only `BlindRemove` policy clears it (a load, then a store), and loom must find the
    /// record two overlapping removals both count.
    const REMOVE_BY_CAS: bool = true;
}

/// The ordering of `site` under policy `O` (a constant after inlining).
#[inline(always)]
pub(crate) const fn ord<O: Orderings>(site: Site) -> Ordering {
    O::SITES[site as usize]
}

/// The minimal sound policy: Release on every publication, Acquire on every load that is followed
/// by a read of what it points to (unless an earlier Acquire load already orders that read: a
/// lookup's child pointer, under the Acquire load of its bit), Relaxed where only atomicity is
/// needed. The argument for each site is at the site, in `list.rs` and `mod.rs`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Minimal;

/// `SeqCst` at every site.
#[derive(Clone, Copy, Debug, Default)]
pub struct SeqCstEverywhere;

/// [`Minimal`], plus a `SeqCst` fence at the start of every lookup: the read-path barrier the
/// paper avoided (§3.3).
#[derive(Clone, Copy, Debug, Default)]
pub struct ReadFence;

/// A benchmark control: [`Minimal`]'s orderings under another type. The compiler emits a second,
/// identical copy of the cache's code for it, placed elsewhere in the binary, so comparing it with
/// [`Minimal`] measures what code placement alone does to a timing (`benches/orderings.rs`).
#[derive(Clone, Copy, Debug, Default)]
pub struct MinimalControl;

impl sealed::Sealed for Minimal {}
impl sealed::Sealed for MinimalControl {}
impl sealed::Sealed for SeqCstEverywhere {}
impl sealed::Sealed for ReadFence {}

const MINIMAL: [Ordering; Site::COUNT] = [
    Relaxed, // Reserve
    Release, // SlotPublish
    Acquire, // SlotRead
    Relaxed, // HeadRead
    Acquire, // SegmentRead
    Release, // SegmentPublish
    Acquire, // SegmentCasFailure
    Acquire, // ChildRead
    Release, // ChildPublish
    Acquire, // ChildCasFailure
    Release, // MaskSet
    Acquire, // MaskRead
    Relaxed, // MaskTest
    Relaxed, // ChildFollow
    Relaxed, // SlotRemove
];

impl Orderings for Minimal {
    const NAME: &'static str = "minimal";
    const SITES: [Ordering; Site::COUNT] = MINIMAL;
}

impl Orderings for MinimalControl {
    const NAME: &'static str = "minimal-control";
    const SITES: [Ordering; Site::COUNT] = MINIMAL;
}

impl Orderings for SeqCstEverywhere {
    const NAME: &'static str = "seqcst";
    const SITES: [Ordering; Site::COUNT] = [SeqCst; Site::COUNT];
}

impl Orderings for ReadFence {
    const NAME: &'static str = "read-fence";
    const SITES: [Ordering; Site::COUNT] = MINIMAL;
    const READ_FENCE: bool = true;
}

/// Listing 6 as printed: no publication flag; readers read every slot below the head. Loom only:
/// it is the race the paper shipped, and loom must catch it.
#[cfg(feature = "loom")]
#[derive(Clone, Copy, Debug, Default)]
pub struct PaperLiteral;

#[cfg(feature = "loom")]
impl sealed::Sealed for PaperLiteral {}

#[cfg(feature = "loom")]
impl Orderings for PaperLiteral {
    const NAME: &'static str = "paper-literal";
    const SITES: [Ordering; Site::COUNT] = MINIMAL;
    const PUBLISH_SLOTS: bool = false;
}

/// [`Minimal`], but an insert walking into a published child leaves marking it to the child's
/// publisher. Loom only: the record it stores below a child not yet marked is invisible to a
/// lookup that happens-after the insert, and loom must find that.
#[cfg(feature = "loom")]
#[derive(Clone, Copy, Debug, Default)]
pub struct Unhelped;

#[cfg(feature = "loom")]
impl sealed::Sealed for Unhelped {}

#[cfg(feature = "loom")]
impl Orderings for Unhelped {
    const NAME: &'static str = "unhelped";
    const SITES: [Ordering; Site::COUNT] = MINIMAL;
    const HELP_MARK: bool = false;
}

/// [`Minimal`], but a removal checks that a slot is live and then stores "removed", where the
/// shipped code makes one compare-and-swap. Loom only: two removals of one record can then both
/// take it, and loom must find the record counted twice.
#[cfg(feature = "loom")]
#[derive(Clone, Copy, Debug, Default)]
pub struct BlindRemove;

#[cfg(feature = "loom")]
impl sealed::Sealed for BlindRemove {}

#[cfg(feature = "loom")]
impl Orderings for BlindRemove {
    const NAME: &'static str = "blind-remove";
    const SITES: [Ordering; Site::COUNT] = MINIMAL;
    const REMOVE_BY_CAS: bool = false;
}

/// [`Minimal`] with the site numbered `SITE` weakened to `Relaxed`. Loom only: each instance is a
/// candidate the ordering study asks loom to refute.
#[cfg(feature = "loom")]
#[derive(Clone, Copy, Debug, Default)]
pub struct Weakened<const SITE: usize>;

#[cfg(feature = "loom")]
impl<const SITE: usize> sealed::Sealed for Weakened<SITE> {}

#[cfg(feature = "loom")]
impl<const SITE: usize> Orderings for Weakened<SITE> {
    const NAME: &'static str = "weakened";
    const SITES: [Ordering; Site::COUNT] = {
        let mut sites = MINIMAL;
        sites[SITE] = Relaxed;
        sites
    };
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;

    #[test]
    fn sites_are_indexed_in_order() {
        for (i, site) in Site::ALL.iter().enumerate() {
            assert_eq!(*site as usize, i);
        }
        assert_eq!(ord::<Minimal>(Site::Reserve), Relaxed);
        assert_eq!(ord::<Minimal>(Site::SlotPublish), Release);
        assert_eq!(ord::<SeqCstEverywhere>(Site::HeadRead), SeqCst);
        assert_eq!(ord::<Minimal>(Site::MaskSet), Release);
        assert_eq!(ord::<Minimal>(Site::ChildFollow), Relaxed);
    }
}
