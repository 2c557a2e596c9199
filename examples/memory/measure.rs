//! Memory per record (issue 42, point 2): what each scheme's cache holds once `n` records of the
//! benches' scene-like workload are in it, counted by the process's global allocator, and where
//! those bytes go. Shared by `examples/memory/main.rs` (the measurement and its page) and
//! `tests/memory.rs` (its check); each binary gets its own counting allocator from this module
//! (a global allocator is per binary).
//!
//! **What is counted.** The allocator's live total (bytes as requested, and blocks) after the
//! inserts, minus the total before the cache was built: the cache's heap and nothing else, since
//! the records to insert and the tree shape used for attribution are made before the baseline,
//! and the inserts run on this thread alone. The cache value itself (a few hundred bytes on the
//! stack) is not heap and is not counted. Single-threaded inserts: no child or segment race is
//! lost, so WF's two policies hold the same tree; what a lost race allocates is freed at once
//! (`tests/leaks.rs`).
//!
//! **Attribution** ([`Split`]) is by `size_of` times counts. The counts come from the records'
//! tree shape, worked out from the public geometry alone (`verify/tree_shape.rs`: which node each
//! record is placed in, hence every list's length and the node count), cross-checked against the
//! cache's own statistics (`CacheStats::records`, `CacheStats::nodes`). The sizes come from the
//! layouts the cache documents and unit-tests (WF: `src/cache/wf/{mod,list}.rs`; the arena
//! octree: `src/cache/sequential.rs`) and, for the arena schemes' `Vec`s, from std's growth
//! (capacity doubling from 4). Nothing is a remainder: [`Split::unattributed`] is what the
//! measured total exceeds the sum by, and the test requires it to be zero.

#![allow(dead_code)]

use crate::tree_shape::TreeShape;
use std::alloc::{GlobalAlloc, Layout, System};
use std::collections::HashSet;
use std::mem::{align_of, size_of};
use wfic::cache::{CacheConfig, CacheHandle, CacheJob, CacheStats, IrradianceCache, Scheme};
use wfic::ic::{self, Key, Record, WorkerId};
use wfic::sync::unchecked::{AtomicU64, Ordering::Relaxed};

// ---------------------------------------------------------------------------------------------
// The counting allocator
// ---------------------------------------------------------------------------------------------

/// The system allocator, counting what is live (the idea of `tests/leaks.rs`'s, without its
/// race-watching).
pub struct Counting;

/// Blocks allocated and not yet freed.
static LIVE_BLOCKS: AtomicU64 = AtomicU64::new(0);
/// Bytes allocated (as requested) and not yet freed.
static LIVE_BYTES: AtomicU64 = AtomicU64::new(0);
/// What glibc's malloc would hold for the live blocks, by [`glibc_chunk`].
static LIVE_CHUNK_BYTES: AtomicU64 = AtomicU64::new(0);

/// The chunk glibc's malloc carves for a request of `size` bytes on a 64-bit target: the size
/// plus the 8-byte size field, rounded up to 16, at least 32 (`request2size` and `MINSIZE` in
/// glibc's `malloc.c`). An estimate: blocks above the mmap threshold (128 KiB at first) are
/// page-rounded mappings instead, and over-aligned requests pay more; neither is modelled.
pub const fn glibc_chunk(size: usize) -> u64 {
    let chunk = (size + 8).next_multiple_of(16);
    (if chunk < 32 { 32 } else { chunk }) as u64
}

fn count_allocation(size: usize) {
    // Relaxed: plain counters. The measurement runs on one thread, which reads them after its own
    // allocations (program order); no other thread allocates while a measurement runs.
    LIVE_BLOCKS.fetch_add(1, Relaxed);
    LIVE_BYTES.fetch_add(size as u64, Relaxed);
    LIVE_CHUNK_BYTES.fetch_add(glibc_chunk(size), Relaxed);
}

fn count_free(size: usize) {
    // Relaxed: as in `count_allocation`.
    LIVE_BLOCKS.fetch_sub(1, Relaxed);
    LIVE_BYTES.fetch_sub(size as u64, Relaxed);
    LIVE_CHUNK_BYTES.fetch_sub(glibc_chunk(size), Relaxed);
}

// SAFETY: every call is forwarded to `System` with the caller's arguments, unchanged; the
// counting only touches atomics and never allocates.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded under the caller's guarantees.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            count_allocation(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded under the caller's guarantees.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            count_allocation(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        count_free(layout.size());
        // SAFETY: forwarded under the caller's guarantees.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: forwarded under the caller's guarantees.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            // One block, moved or resized: counted as the old one freed and the new one made.
            count_free(layout.size());
            count_allocation(new_size);
        }
        p
    }
}

/// What is live on the heap.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Live {
    pub blocks: u64,
    pub bytes: u64,
    /// glibc's chunks for those blocks, estimated ([`glibc_chunk`]).
    pub chunk_bytes: u64,
}

impl Live {
    /// The live totals now.
    pub fn now() -> Self {
        // Relaxed: see `count_allocation`.
        Self {
            blocks: LIVE_BLOCKS.load(Relaxed),
            bytes: LIVE_BYTES.load(Relaxed),
            chunk_bytes: LIVE_CHUNK_BYTES.load(Relaxed),
        }
    }

    /// What is live now beyond `baseline`.
    fn since(self, baseline: Live) -> Live {
        Live {
            blocks: self.blocks - baseline.blocks,
            bytes: self.bytes - baseline.bytes,
            chunk_bytes: self.chunk_bytes - baseline.chunk_bytes,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The measurement
// ---------------------------------------------------------------------------------------------

/// The schemes measured: every caching scheme of [`Scheme::CACHED`].
pub const SCHEMES: [Scheme; 6] = Scheme::CACHED;

/// The goal's yardstick: one record and the key stored beside it in every scheme's list (WF's
/// slot holds the key with its state byte in a 32-byte hot half, the 128-byte record in the cold
/// half; the arena octree keeps the keys in a `Vec<Key>` beside the `Vec<Record>`).
pub const RECORD_AND_KEY: usize = size_of::<Record>() + size_of::<Key>();

/// The goal: WF at most this many times [`RECORD_AND_KEY`] per record at 10^6 records.
pub const GOAL_RATIO: f64 = 1.25;

/// One cache's heap after `n` inserts.
#[derive(Clone, Copy, Debug)]
pub struct Measured {
    pub scheme: Scheme,
    pub n: usize,
    /// Live beyond the baseline after the inserts (handles dropped, frame closed).
    pub live: Live,
    /// The cache's own statistics after the inserts.
    pub stats: CacheStats,
}

impl Measured {
    pub fn bytes_per_record(&self) -> f64 {
        self.live.bytes as f64 / self.n as f64
    }

    pub fn ratio(&self) -> f64 {
        self.bytes_per_record() / RECORD_AND_KEY as f64
    }
}

/// Inserts `records` through one handle in one frame, then reads the live totals.
struct Fill<'a> {
    records: &'a [Record],
    baseline: Live,
}

impl CacheJob for Fill<'_> {
    type Output = (Live, CacheStats);

    fn run<C: IrradianceCache>(self, mut cache: C) -> (Live, CacheStats) {
        let frame = cache.frame();
        let mut handle = frame.handle_for(WorkerId::new(0));
        for r in self.records {
            handle.insert(*r).expect("a workload record refused");
        }
        drop(handle);
        frame.close();
        let live = Live::now().since(self.baseline);
        (live, cache.stats())
    }
}

/// Builds `scheme`'s cache over `config`, fills it with `records` and measures it; checks the
/// cache's heap is all freed when it is dropped.
pub fn measure(scheme: Scheme, config: CacheConfig, records: &[Record]) -> Measured {
    let baseline = Live::now();
    let (live, stats) = scheme.build(config, Fill { records, baseline });
    let after = Live::now();
    assert_eq!(
        after, baseline,
        "{scheme}: the heap did not return to its baseline once the cache was dropped"
    );
    Measured {
        scheme,
        n: records.len(),
        live,
        stats,
    }
}

// ---------------------------------------------------------------------------------------------
// Attribution
// ---------------------------------------------------------------------------------------------

/// Where a cache's bytes go, by `size_of` times counts (module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Split {
    /// The records themselves: `n` x `size_of::<Record>()`.
    pub records: u64,
    /// Their keys: `n` x `size_of::<Key>()`.
    pub keys: u64,
    /// What a used slot holds beside its key and record (WF: the state byte and the padding of the
    /// hot half to 32 bytes; the arena octree: nothing).
    pub slot_extra: u64,
    /// Capacity allocated and not used: WF's unreserved slots in allocated segments; the arena
    /// octree's `Vec` capacity beyond the length (key and record vectors, node arena).
    pub spare: u64,
    /// The nodes beyond the root (the root is in `fixed`).
    pub nodes: u64,
    /// List bookkeeping outside slots and nodes: WF's directory pointer in each first segment and
    /// the directories of later segments; nothing for the arena octree (its `Vec` headers are in
    /// its nodes).
    pub index: u64,
    /// The empty cache after a frame without inserts (the root, the ledger, ...), measured.
    pub fixed: u64,
}

impl Split {
    pub fn total(&self) -> u64 {
        self.records
            + self.keys
            + self.slot_extra
            + self.spare
            + self.nodes
            + self.index
            + self.fixed
    }
}

/// A WF node, as `src/cache/wf/mod.rs` lays it out and its unit test pins: the occupancy mask
/// (padded to a word), the list's head, first-block pointer and first-block length, eight child
/// pointers.
pub const WF_NODE: usize = size_of::<usize>() + 3 * size_of::<usize>() + size_of::<[usize; 8]>();
/// A WF slot's hot half: the key and the state byte, padded to the key's alignment.
pub const WF_HOT: usize = (size_of::<Key>() + 1).next_multiple_of(align_of::<Key>());
/// A WF slot: its hot half and its record (`list.rs`).
pub const WF_SLOT: usize = WF_HOT + size_of::<Record>();
/// The first segment's slots; each later segment doubles (`list.rs`, `BASE_SHIFT`).
pub const WF_FIRST_SEGMENT: u64 = 4;
/// A list past its first block is rebuilt as one block at the frame's close when its unused slots
/// exceed its records over this (`list.rs`, `SPARE_DIVISOR`).
pub const WF_SPARE_DIVISOR: u64 = 16;
/// The directory of a list's later segments: one pointer for each of segments 1 to 49 (`list.rs`,
/// `SEGMENTS`), allocated when a list first outgrows its first segment.
pub const WF_DIRECTORY: usize = 49 * size_of::<usize>();

/// A node of the arena octree (`src/cache/sequential.rs`): eight `u32` child indices, the mask
/// byte, the key and record vectors, padded to a word.
pub const ARENA_NODE: usize =
    (size_of::<[u32; 8]>() + 1 + 2 * size_of::<Vec<u8>>()).next_multiple_of(align_of::<usize>());

/// The slots a WF list of `len` records holds once the frame that filled it closed: the segments
/// it grew, unless it opened two or more past its first segment with more than a sixteenth of
/// them unused, when the frame's close rebuilt it as one block of `len` slots and a sixteenth
/// (`list.rs`, 5).
pub fn wf_capacity(len: u64) -> u64 {
    if wf_rebuilt(len) {
        len + len / WF_SPARE_DIVISOR
    } else {
        wf_grown_capacity(len)
    }
}

/// Whether the frame's close rebuilt a WF list of `len` records, grown in that frame, as one block.
pub fn wf_rebuilt(len: u64) -> bool {
    let grown = wf_grown_capacity(len);
    // Segments of 4, 8 and 16: the second past the first segment opened.
    grown >= WF_FIRST_SEGMENT * 7 && (grown - len) * WF_SPARE_DIVISOR > len
}

/// The slots a WF list of `len` records has allocated within a frame: whole segments of 4, 8,
/// 16, ...
pub fn wf_grown_capacity(len: u64) -> u64 {
    let (mut capacity, mut segment) = (0, WF_FIRST_SEGMENT);
    while capacity < len {
        capacity += segment;
        segment *= 2;
    }
    capacity
}

/// A `Vec` grown by `push` from empty to `len` elements of at most 1 KiB: std's amortised
/// growth, doubling from 4 (`RawVec::grow_amortized`, `MIN_NON_ZERO_CAP`).
pub fn vec_capacity(len: u64) -> u64 {
    if len == 0 {
        0
    } else {
        len.next_power_of_two().max(4)
    }
}

/// The arena octree's node vector: `vec![root]` (capacity 1), then pushed.
fn arena_capacity(nodes: u64) -> u64 {
    if nodes <= 1 {
        1
    } else {
        vec_capacity(nodes)
    }
}

/// Attributes `scheme`'s bytes for the records whose tree is `shape` (`n` records in all), with
/// `fixed` the empty cache's bytes.
pub fn attribute(scheme: Scheme, n: u64, shape: &TreeShape, fixed: u64) -> Split {
    let nodes = shape.nodes() as u64;
    let mut split = Split {
        records: n * size_of::<Record>() as u64,
        keys: n * size_of::<Key>() as u64,
        fixed,
        ..Split::default()
    };
    match scheme {
        Scheme::Wf | Scheme::WfDiscard => {
            split.slot_extra = n * (WF_HOT - size_of::<Key>()) as u64;
            split.nodes = (nodes - 1) * WF_NODE as u64;
            for len in shape.list_lengths().filter(|&len| len > 0) {
                split.spare += (wf_capacity(len) - len) * WF_SLOT as u64;
                split.index += size_of::<usize>() as u64;
                if len > WF_FIRST_SEGMENT && !wf_rebuilt(len) {
                    split.index += WF_DIRECTORY as u64;
                }
            }
        }
        Scheme::Tra | Scheme::Lck | Scheme::LckRw | Scheme::Lw => {
            split.nodes = (nodes - 1) * ARENA_NODE as u64;
            split.spare = (arena_capacity(nodes) - nodes) * ARENA_NODE as u64;
            let per = (size_of::<Key>() + size_of::<Record>()) as u64;
            for len in shape.list_lengths() {
                split.spare += (vec_capacity(len) - len) * per;
            }
        }
        Scheme::None => unreachable!("the reference stores nothing"),
    }
    split
}

/// What each scheme's list lengths look like: the lists holding records, and the mean length.
pub fn lists(shape: &TreeShape) -> (u64, f64) {
    let (mut lists, mut records) = (0, 0);
    for len in shape.list_lengths().filter(|&len| len > 0) {
        lists += 1;
        records += len;
    }
    (lists, records as f64 / lists.max(1) as f64)
}

// ---------------------------------------------------------------------------------------------
// Radiance's ambient record, for comparison
// ---------------------------------------------------------------------------------------------

/// The maximum number of spectral samples of Radiance's `SCOLOR` (`MAXCSAMP` in
/// `src/common/color.h`, commit bcffc2b5: 24 by default).
pub const RADIANCE_MAXCSAMP: usize = 24;
/// The samples Radiance stores by default (`NCSAMP`, that is `CNDX[EXP]`, initialised to 3 in
/// `src/common/color.c`): RGB.
pub const RADIANCE_NCSAMP: usize = 3;

/// A layout mirror of Radiance's `AMBVAL` (`struct ambrec`, `src/rt/ambient.h` of
/// LBNL-ETA/Radiance at commit bcffc2b5): field types and order as declared there, with C's
/// alignment rules through `repr(C)`. Only `size_of` is taken: nothing is stored in it.
#[repr(C)]
pub struct RadianceAmbVal {
    /// `struct ambrec *next`: the next record in the octree node's list.
    next: *const RadianceAmbVal,
    /// `float pos[3]`.
    pos: [f32; 3],
    /// `int32 ndir`, `int32 udir`: the encoded normal and u direction.
    ndir: i32,
    udir: i32,
    /// `short lvl` (two bytes of padding follow, before the float).
    lvl: i16,
    /// `float weight`.
    weight: f32,
    /// `float rad[2]`, `float gpos[2]`, `float gdir[2]`.
    rad: [f32; 2],
    gpos: [f32; 2],
    gdir: [f32; 2],
    /// `uint32 corral`.
    corral: u32,
    /// `SCOLOR val`: `COLORV` (float) times `MAXCSAMP`, declared last so that an allocation can
    /// stop after the samples in use.
    val: [f32; RADIANCE_MAXCSAMP],
}

/// A layout mirror of Radiance's `AMBTREE` (`struct ambtree`, same file): the node's record list
/// and its eight children, allocated together.
#[repr(C)]
pub struct RadianceAmbTree {
    alist: *const RadianceAmbVal,
    kid: *const RadianceAmbTree,
}

/// `sizeof(AMBVAL)` on x86-64.
pub const RADIANCE_AMBVAL: usize = size_of::<RadianceAmbVal>();
/// What Radiance mallocs per record: `AVSIZE` in `src/rt/ambient.c` (same commit),
/// `sizeof(AMBVAL) - sizeof(SCOLOR) + sizeof(COLORV) * NCSAMP`.
pub const RADIANCE_AVSIZE: usize =
    RADIANCE_AMBVAL - size_of::<[f32; RADIANCE_MAXCSAMP]>() + RADIANCE_NCSAMP * size_of::<f32>();
/// One `newambtree()`: the eight children of a node, allocated together and zeroed.
pub const RADIANCE_KIDS: usize = 8 * size_of::<RadianceAmbTree>();
/// `newambtree()` takes its groups of eight from blocks of `ATALLOCSZ` = 512 groups.
pub const RADIANCE_POOL_GROUPS: u64 = 512;

/// A model of Radiance's ambient octree over the same records (not a measurement of Radiance):
/// `avinsert` descends from the scene cube (size `s`, here the cache's root cube) while
/// `s * OCTSCALE / 2 > rad[1] * ambacc` (`OCTSCALE` = 1), allocating a node's eight children
/// when it first descends through it. Assumed: `rad[1] * ambacc` is this workload's `a R` (the
/// influence radius) and the scene cube is the root cube. Returns the nodes that have children
/// (one `newambtree` group each).
pub fn radiance_groups(config: &CacheConfig, records: &[Record]) -> u64 {
    let root = config.root();
    let mut interior = HashSet::new();
    for r in records {
        let rho = ic::influence_radius(r, config.accuracy());
        let mut cell = root;
        let mut size = 2.0 * root.half;
        // A node is its depth and its path, three bits a level.
        let (mut depth, mut path) = (0u32, 0u128);
        while size * 0.5 > rho {
            interior.insert((depth, path));
            let octant = cell.octant(r.position);
            cell = cell.child(octant);
            size *= 0.5;
            depth += 1;
            path = path << 3 | octant.index() as u128;
            assert!(depth < 40, "the Radiance model went too deep");
        }
    }
    interior.len() as u64
}

/// Radiance's model bytes for `n` records in a tree of `groups` child groups: the records as
/// malloc'd (`AVSIZE` each), the groups' pool blocks as malloc'd, and glibc's chunks for both.
pub fn radiance_bytes(n: u64, groups: u64) -> (u64, u64) {
    let pool_blocks = groups.div_ceil(RADIANCE_POOL_GROUPS);
    let pool = pool_blocks * RADIANCE_POOL_GROUPS * RADIANCE_KIDS as u64;
    let requested = n * RADIANCE_AVSIZE as u64 + pool;
    let block = RADIANCE_POOL_GROUPS as usize * RADIANCE_KIDS;
    let chunks = n * glibc_chunk(RADIANCE_AVSIZE) + pool_blocks * glibc_chunk(block);
    (requested, chunks)
}

/// The tree shape of `records` in a cache over `config` (made before any baseline is taken).
pub fn shape(config: &CacheConfig, records: &[Record]) -> TreeShape {
    TreeShape::of(config, records)
}

// ---------------------------------------------------------------------------------------------
// WF's lists under other growth policies (a model, for the page's "where the bytes go")
// ---------------------------------------------------------------------------------------------

/// A growth policy for a WF list: the slots it holds allocated for `len` records.
pub struct Policy {
    pub name: &'static str,
    pub capacity: fn(u64) -> u64,
}

/// Segments of 4, 4, 8, 8, 16, 16, ... slots: each size twice.
fn capacity_each_size_twice(len: u64) -> u64 {
    let (mut capacity, mut segment, mut second) = (0, WF_FIRST_SEGMENT, false);
    while capacity < len {
        capacity += segment;
        if second {
            segment *= 2;
        }
        second = !second;
    }
    capacity
}

/// A first segment of 4 slots, then segments of 8.
fn capacity_fixed_eight(len: u64) -> u64 {
    if len <= WF_FIRST_SEGMENT {
        WF_FIRST_SEGMENT
    } else {
        WF_FIRST_SEGMENT + (len - WF_FIRST_SEGMENT).div_ceil(8) * 8
    }
}

/// Segments of 4, 8, 16, 32 slots, then 32 each: doubling capped at 32.
fn capacity_capped_32(len: u64) -> u64 {
    let (mut capacity, mut segment) = (0, WF_FIRST_SEGMENT);
    while capacity < len {
        capacity += segment;
        segment = (segment * 2).min(32);
    }
    capacity
}

/// Every list that grew rebuilt at the frame's close into one block of exactly its length.
fn capacity_exact(len: u64) -> u64 {
    len
}

/// The policies the page compares, the built one first.
pub const POLICIES: [Policy; 6] = [
    Policy {
        name: "as built: segments of 4, 8, 16, ... slots; rebuilt at the frame's close past a \
               second segment and a sixteenth unused, as one block and a sixteenth",
        capacity: wf_capacity,
    },
    Policy {
        name: "segments of 4, 8, 16, ... slots, never rebuilt (as during a frame)",
        capacity: wf_grown_capacity,
    },
    Policy {
        name: "segments of 4, 4, 8, 8, 16, 16, ... slots",
        capacity: capacity_each_size_twice,
    },
    Policy {
        name: "segments of 4, 8, 16, 32 slots, then 32 each",
        capacity: capacity_capped_32,
    },
    Policy {
        name: "a first segment of 4, then segments of 8",
        capacity: capacity_fixed_eight,
    },
    Policy {
        name: "every list rebuilt to its length when a frame closes, however little unused",
        capacity: capacity_exact,
    },
];

/// WF's spare slot bytes for the lists of `shape` under `policy`.
pub fn wf_spare(shape: &TreeShape, policy: &Policy) -> u64 {
    shape
        .list_lengths()
        .filter(|&len| len > 0)
        .map(|len| ((policy.capacity)(len) - len) * WF_SLOT as u64)
        .sum()
}
