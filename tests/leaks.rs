//! Leaks, with real threads: a counting global allocator, and every scheme's cache built, raced on
//! by two threads and dropped, round after round; after each round the live allocations (blocks
//! and bytes) must be exactly what they were before the cache was built.
//!
//! WF is the scheme at risk: it owns its nodes and list segments through raw pointers, and the
//! loser of a child compare-and-swap frees its private subtree (`graft`), the loser of a segment
//! compare-and-swap its fresh segment (`install`). The WF rounds make both races happen and check
//! that they did: lost child races through the handles' `cas_failures`, lost segment races through
//! the allocator (a root list's segments beyond the first are the only allocations of their sizes,
//! so any such allocation beyond the segments the list ends up with is a loser's).
//!
//! Each round then removes every record before the cache is dropped: the two workers each remove
//! half the world's records during a second frame while looking up (WF reclaims when it closes:
//! lists compacted, emptied subtrees freed), and `IrradianceCache::remove` takes the rest. The
//! round checks that every record went and that only the root node is left while the cache lives;
//! the drop's baseline check then covers what reclamation freed.
//!
//! `#[global_allocator]` is per binary, hence this dedicated test binary; and it has no libtest
//! harness (`harness = false` in `Cargo.toml`): the checks run one after the other on the main
//! thread, so no other test and no harness thread allocates while a round is measured. Of
//! libtest's arguments it understands name filters (`cargo test --release -- counter`) and runs
//! nothing for `--ignored` or `--list`; the rest are ignored.
//!
//! Environment: `WFIC_LEAKS_ROUNDS` (rounds per scheme, default 300); `WFIC_LEAKS_YIELD=1` makes
//! every allocation of a WF round yield the processor, which puts the other worker inside the
//! window between a null read and the compare-and-swap on it (valgrind runs one thread at a time
//! and switches only every 100 000 blocks or at a system call, so without it no race is ever lost
//! there: `verify/valgrind-stress.sh` sets it); `WFIC_LEAKS_RACES=report` reports the races lost
//! without requiring any. With a single CPU available the races are reported only, too.

#[cfg(checker)]
fn main() {
    println!("leaks: real threads only: nothing to run under loom or shuttle");
}

#[cfg(not(checker))]
fn main() {
    real::main();
}

#[cfg(not(checker))]
mod common;

#[cfg(not(checker))]
mod real {
    use super::common::w;
    use glam::Vec3;
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::sync::Barrier;
    use std::thread;
    use wfic::cache::{
        CacheConfig, CacheHandle, CacheJob, Inserted, IrradianceCache, Scheme, WaitFree,
    };
    use wfic::ic::Record;
    use wfic::sync::unchecked::{AtomicU64, Ordering::Relaxed};
    use wfic::sync::AtomicUsize;

    /// The system allocator, counting.
    struct Counting;

    /// Blocks allocated and not yet freed, by anyone in the process.
    static LIVE_BLOCKS: AtomicU64 = AtomicU64::new(0);
    /// Bytes allocated and not yet freed.
    static LIVE_BYTES: AtomicU64 = AtomicU64::new(0);
    /// Allocations made so far, and the size of the last one (for calibration, single-threaded).
    static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);
    static LAST_SIZE: AtomicU64 = AtomicU64::new(0);
    /// Bytes of one WF list slot while segment allocations are being tallied, else 0.
    static SLOT_BYTES: AtomicU64 = AtomicU64::new(0);
    /// Allocations shaped like a list segment of 8 or more slots (a power of two), while tallied.
    static SEGMENT_ALLOCATIONS: AtomicU64 = AtomicU64::new(0);
    /// Non-zero: every allocation yields the processor afterwards (`WFIC_LEAKS_YIELD=1`, WF rounds).
    static YIELD_AFTER_ALLOCATING: AtomicU64 = AtomicU64::new(0);

    fn count_allocation(size: usize) {
        let size = size as u64;
        // Relaxed: plain counters; every reader reads them after joining the threads that wrote.
        LIVE_BLOCKS.fetch_add(1, Relaxed);
        LIVE_BYTES.fetch_add(size, Relaxed);
        ALLOCATIONS.fetch_add(1, Relaxed);
        LAST_SIZE.store(size, Relaxed);
        let slot = SLOT_BYTES.load(Relaxed);
        if slot != 0 && size % slot == 0 && (size / slot).is_power_of_two() && size / slot >= 8 {
            SEGMENT_ALLOCATIONS.fetch_add(1, Relaxed);
        }
        if YIELD_AFTER_ALLOCATING.load(Relaxed) != 0 {
            // WF allocates a private path (`graft`) or a segment (`install`) between reading a
            // null pointer and its compare-and-swap on it: yielding there lets the other worker
            // run into the same window. Under valgrind, which switches threads only every 100 000
            // blocks or at a system call, this is what makes the races happen at all.
            // (`sched_yield`: no allocation.)
            std::thread::yield_now();
        }
    }

    fn count_free(size: usize) {
        LIVE_BLOCKS.fetch_sub(1, Relaxed);
        LIVE_BYTES.fetch_sub(size as u64, Relaxed);
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
                // One block moved or grown in place: the count of blocks is unchanged.
                LIVE_BYTES.fetch_add(new_size as u64, Relaxed);
                LIVE_BYTES.fetch_sub(layout.size() as u64, Relaxed);
            }
            p
        }
    }

    #[global_allocator]
    static GLOBAL: Counting = Counting;

    /// Live blocks and bytes.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    struct Live {
        blocks: u64,
        bytes: u64,
    }

    fn live() -> Live {
        Live {
            blocks: LIVE_BLOCKS.load(Relaxed),
            bytes: LIVE_BYTES.load(Relaxed),
        }
    }

    /// Asserts that live allocations are back to `before`.
    fn assert_back_to(before: Live, what: &str) {
        let after = live();
        assert!(
            after == before,
            "{what}: live allocations {} blocks / {} bytes, {:+} blocks / {:+} bytes against the \
             {} / {} before the cache was built: the cache leaked (or freed what it did not own)",
            after.blocks,
            after.bytes,
            after.blocks as i64 - before.blocks as i64,
            after.bytes as i64 - before.bytes as i64,
            before.blocks,
            before.bytes,
        );
    }

    fn env_rounds() -> u32 {
        std::env::var("WFIC_LEAKS_ROUNDS")
            .ok()
            .map(|v| v.parse().expect("WFIC_LEAKS_ROUNDS: a number of rounds"))
            .unwrap_or(300)
    }

    /// Whether the WF rounds must lose both kinds of race: yes, unless `WFIC_LEAKS_RACES=report`
    /// or this process may run on one CPU only (two threads then never run at once: pinned to
    /// one CPU with `taskset -c 0`, 400 rounds lost no race at all).
    fn yield_after_allocating() -> bool {
        std::env::var("WFIC_LEAKS_YIELD").is_ok_and(|v| v == "1")
    }

    fn races_required() -> bool {
        let cpus = thread::available_parallelism().map_or(1, |n| n.get());
        std::env::var("WFIC_LEAKS_RACES").map_or(true, |v| v != "report") && cpus >= 2
    }

    /// The world: a 16-unit box (root half-size 8.08) at accuracy 1.
    fn config() -> CacheConfig {
        CacheConfig::new(Vec3::ZERO, Vec3::splat(16.0), 1.0).unwrap()
    }

    /// Records per thread and round, of each kind.
    const PER_THREAD: u32 = 32;

    /// The `i`-th deep record of thread `t`: radius 0.3 stores it at depth 4 (half-size 0.505),
    /// inside a depth-3 cell (side 2.02) of its own among the deep records, in the same depth-4
    /// cell as thread `1 - t`'s `i`-th record: the two race to create the missing nodes on its
    /// path, down to four levels.
    fn deep(i: u32, t: u32) -> Record {
        let cell = |k: u32| -0.08 + (k as f32 + 0.5) * 2.02 + 0.25 + 0.01 * t as f32;
        let p = Vec3::new(cell(i % 8), cell(i / 8), cell((i * 5) % 8));
        Record::new(p, Vec3::Z, Vec3::ONE, 0.3)
    }

    /// The `i`-th root record of thread `t` (radius 100: stored in the root's list, which both
    /// threads grow: 2 x 32 records fill segments 0 to 4, of 4, 8, 16, 32 and 64 slots).
    fn root(i: u32, t: u32) -> Record {
        let p = Vec3::new(1.0 + 0.1 * i as f32, 8.0 + t as f32, 8.0);
        Record::new(p, Vec3::Z, Vec3::ONE, 100.0)
    }

    /// The root list's segments beyond the first once both threads are done (segments 1 to 4).
    const ROOT_SEGMENTS_BEYOND_THE_FIRST: u64 = 4;

    /// What one round saw.
    #[derive(Clone, Copy, Default, Debug)]
    struct Round {
        /// Child compare-and-swaps lost (the handles' `cas_failures`).
        lost_child_races: u64,
        /// Samples the `Discard` policy dropped.
        discarded: u64,
        /// Records stored, by the inserts' outcomes, and by the cache's statistics.
        stored: u64,
        records: u64,
        /// Records removed: by the workers during a second frame, then between frames.
        removed: u64,
        /// Records and nodes left once everything was removed (and the removing frame reclaimed).
        records_left: u64,
        nodes_left: u64,
    }

    /// One round on a fresh cache: two workers, lined up by a barrier and then a spinning start
    /// line, each insert their deep and root records in the same order (so the two race for every
    /// missing child and every segment), then look each up; the frame closes (LW merges there),
    /// and the cache is dropped when the job returns.
    struct RaceJob {
        /// Run the workers one after the other instead (no race: the control).
        sequential: bool,
    }

    impl CacheJob for RaceJob {
        type Output = Round;

        fn run<C: IrradianceCache>(self, mut cache: C) -> Round {
            let frame = cache.frame();
            let barrier = Barrier::new(if self.sequential { 1 } else { 2 });
            let start = AtomicUsize::new(0);
            let workers = if self.sequential { 1 } else { 2 };
            let worker = |t: u32| {
                barrier.wait();
                // Relaxed: a start line, not a synchronisation (the barrier orders the rest).
                start.fetch_add(1, wfic::sync::Ordering::Relaxed);
                while start.load(wfic::sync::Ordering::Relaxed) < workers {
                    std::hint::spin_loop();
                }
                // TRA's handle holds the whole cache: made after the barrier, so the second
                // worker waits for the first instead of deadlocking at the barrier.
                let mut handle = frame.handle_for(w(t));
                let mut round = Round::default();
                for i in 0..PER_THREAD {
                    for r in [deep(i, t), root(i, t)] {
                        match handle.insert(r).expect("record refused") {
                            Inserted::Stored(_) => round.stored += 1,
                            Inserted::Discarded(_) => round.discarded += 1,
                            Inserted::NotCached(_) => {}
                        }
                    }
                }
                for i in 0..PER_THREAD {
                    let r = deep(i, t);
                    std::hint::black_box(handle.lookup(r.position, r.normal));
                }
                round.lost_child_races = handle.stats().cas_failures;
                round
            };
            let (a, b) = if self.sequential {
                (worker(0), worker(1))
            } else {
                thread::scope(|s| {
                    let a = s.spawn(|| worker(0));
                    let b = s.spawn(|| worker(1));
                    (a.join().unwrap(), b.join().unwrap())
                })
            };
            frame.close();
            let records = cache.stats().records as u64;
            let removed = remove_everything(&mut cache, self.sequential);
            let emptied = cache.stats();
            Round {
                lost_child_races: a.lost_child_races + b.lost_child_races,
                discarded: a.discarded + b.discarded,
                stored: a.stored + b.stored,
                records,
                removed,
                records_left: emptied.records as u64,
                nodes_left: emptied.nodes as u64,
            }
        }
    }

    /// Removes every record of `cache`: a second frame in which each worker removes the records
    /// touching its half of the world while looking up (WF reclaims when the frame closes:
    /// compacting the lists, pruning the emptied subtrees), then, between frames, whatever is
    /// left (`IrradianceCache::remove`). Returns the records removed.
    fn remove_everything<C: IrradianceCache>(cache: &mut C, sequential: bool) -> u64 {
        let frame = cache.frame();
        let worker = |t: u32| {
            let (lo, hi) = if t == 0 {
                (Vec3::ZERO, Vec3::new(8.0, 16.0, 16.0))
            } else {
                (Vec3::new(8.0, 0.0, 0.0), Vec3::splat(16.0))
            };
            let half = wfic::ic::Selection::touching(lo, hi).expect("a box");
            let mut handle = frame.handle_for(w(t));
            handle.remove(&half);
            for i in 0..PER_THREAD {
                let r = deep(i, 1 - t);
                std::hint::black_box(handle.lookup(r.position, r.normal));
            }
        };
        if sequential {
            worker(0);
            worker(1);
        } else {
            // Joined explicitly: a scope's implicit join does not wait for the threads' own
            // last frees, which the counter would then see as live.
            thread::scope(|s| {
                let a = s.spawn(|| worker(0));
                let b = s.spawn(|| worker(1));
                a.join().unwrap();
                b.join().unwrap();
            });
        }
        // The frame's count: the workers' removals, and LW's from its global records at the merge.
        let in_frame = frame.close().workers.removed;
        in_frame + cache.remove(&wfic::ic::Selection::older_than(0)) as u64
    }

    /// The counter counts: a box leaked on purpose inside a window shows as one block of its size,
    /// and freeing it brings the count back.
    fn the_counter_sees_one_forgotten_box() {
        let before = live();
        let leaked = Box::into_raw(Box::new([7u8; 24]));
        assert_eq!(
            live(),
            Live {
                blocks: before.blocks + 1,
                bytes: before.bytes + 24
            },
            "the counting allocator did not see a 24-byte box"
        );
        // SAFETY: `leaked` came from `Box::into_raw` just above and is freed once.
        drop(unsafe { Box::from_raw(leaked) });
        assert_back_to(before, "a box and its free");
    }

    /// Finds a WF list slot's size from the allocator: with segment 0 (4 slots) full, the 5th
    /// insert into a list makes exactly two allocations, the directory of later segments and then
    /// segment 1 (8 slots); the 13th makes two, segment 2 (16 slots) and the handle's first note
    /// of a list grown past a second segment (for the frame's close to rebuild). Returns the slot
    /// size.
    fn slot_bytes() -> u64 {
        let before = live();
        let mut cache = WaitFree::adopt(config());
        let frame = cache.frame();
        let mut h = frame.handle_for(w(0));
        let mut insert_allocations = |i: u32| {
            let (n, bytes) = (ALLOCATIONS.load(Relaxed), live().bytes);
            h.insert(root(i, 0)).unwrap();
            (
                ALLOCATIONS.load(Relaxed) - n,
                LAST_SIZE.load(Relaxed),
                live().bytes - bytes,
            )
        };
        let mut sizes = Vec::with_capacity(16);
        for i in 0..16 {
            sizes.push(insert_allocations(i));
        }
        drop(h);
        frame.close();
        drop(cache);
        let (count, eight, _) = sizes[4];
        assert_eq!(
            count, 2,
            "the 5th insert must allocate the directory and segment 1 only"
        );
        assert_eq!(eight % 8, 0, "segment 1 holds 8 slots: {eight} bytes");
        let slot = eight / 8;
        let (count, _, grown) = sizes[12];
        assert_eq!(count, 2, "the 13th insert allocates segment 2 and a note");
        assert!(
            grown >= 16 * slot && grown - 16 * slot < slot,
            "the 13th insert allocates segment 2 (16 slots of {slot} bytes) and a note smaller than \
             a slot: {grown} bytes"
        );
        for (i, &(count, _, _)) in sizes.iter().enumerate() {
            if ![0, 4, 12].contains(&i) {
                assert_eq!(count, 0, "insert {} allocated", i + 1);
            }
        }
        assert!(
            slot >= std::mem::size_of::<Record>() as u64,
            "a slot of {slot} bytes"
        );
        drop(sizes);
        assert_back_to(before, "calibration");
        slot
    }

    /// Runs one round of `scheme` and checks the live allocations came back; returns the round
    /// and the segment-shaped allocations it made (counted for WF only).
    fn round(scheme: Scheme, sequential: bool, slot: u64, what: &str) -> (Round, u64) {
        let before = live();
        let watch = matches!(scheme, Scheme::Wf | Scheme::WfDiscard);
        SEGMENT_ALLOCATIONS.store(0, Relaxed);
        SLOT_BYTES.store(if watch { slot } else { 0 }, Relaxed);
        YIELD_AFTER_ALLOCATING.store(u64::from(watch && yield_after_allocating()), Relaxed);
        let r = scheme.build(config(), RaceJob { sequential });
        YIELD_AFTER_ALLOCATING.store(0, Relaxed);
        SLOT_BYTES.store(0, Relaxed);
        assert_back_to(before, what);
        let expected = match scheme {
            Scheme::None => 0,
            _ => r.stored,
        };
        assert_eq!(r.records, expected, "{what}: records in the cache");
        assert_eq!(r.removed, expected, "{what}: records removed");
        if scheme != Scheme::None {
            // Reclamation ran while the cache lived: the lists emptied and every node but the
            // root unlinked (freed, or the baseline check after the drop fails).
            assert_eq!(
                (r.records_left, r.nodes_left),
                (0, 1),
                "{what}: records and nodes left after removing everything"
            );
        }
        assert_eq!(
            r.stored + r.discarded,
            match scheme {
                Scheme::None => 0,
                _ => u64::from(4 * PER_THREAD),
            },
            "{what}: inserts"
        );
        (r, SEGMENT_ALLOCATIONS.load(Relaxed))
    }

    /// Every scheme, round after round on fresh caches: the live allocations return to the
    /// baseline each time. For WF, both kinds of race are lost in some rounds.
    fn every_scheme_frees_everything(slot: u64) {
        let rounds = env_rounds();
        for scheme in Scheme::ALL {
            let name = scheme.name();
            let wf = matches!(scheme, Scheme::Wf | Scheme::WfDiscard);
            // The control, also a warm-up (thread spawning's one-time allocations): one worker
            // after the other, so no race; for WF the root list's segments beyond the first are
            // then the only segment-shaped allocations.
            let (control, segments) =
                round(scheme, true, slot, &format!("{name}: sequential control"));
            assert_eq!(control.lost_child_races, 0, "{name}: a race without a race");
            if wf {
                assert_eq!(
                    segments, ROOT_SEGMENTS_BEYOND_THE_FIRST,
                    "{name}: segment-shaped allocations without a race"
                );
            }
            let (mut lost_child, mut lost_segment, mut discarded) = (0, 0, 0);
            // At least `rounds` rounds; for WF, more (up to 20 times as many) until both kinds of
            // race have been lost, so that a loaded machine takes longer instead of failing.
            let mut i = 0;
            while i < rounds
                || (wf
                    && races_required()
                    && (lost_child == 0 || lost_segment == 0)
                    && i < 20 * rounds)
            {
                let (r, segments) = round(scheme, false, slot, &format!("{name}: round {i}"));
                lost_child += r.lost_child_races;
                discarded += r.discarded;
                if wf {
                    assert!(
                        segments >= ROOT_SEGMENTS_BEYOND_THE_FIRST,
                        "{name}: {segments}"
                    );
                    lost_segment += segments - ROOT_SEGMENTS_BEYOND_THE_FIRST;
                }
                i += 1;
            }
            println!(
                "{name}: {i} rounds, allocations back to the baseline after each; \
                 lost child races {lost_child}, lost segment races {lost_segment}, \
                 discarded {discarded}"
            );
            match scheme {
                Scheme::Wf | Scheme::WfDiscard => {
                    if races_required() {
                        assert!(lost_child > 0, "{name}: no child race was lost");
                        assert!(lost_segment > 0, "{name}: no segment race was lost");
                    }
                    if scheme == Scheme::WfDiscard {
                        assert_eq!(discarded, lost_child, "{name}: one discard per lost race");
                    } else {
                        assert_eq!(discarded, 0, "{name}: Adopt discarded");
                    }
                }
                _ => assert_eq!(lost_child, 0, "{name}: compare-and-swaps outside WF"),
            }
        }
    }

    /// The name filters among libtest-style arguments (`cargo test -- NAME`), and whether the
    /// run asks for ignored tests or a list only (this binary has neither: it then runs nothing).
    fn filters() -> (Vec<String>, bool) {
        const TAKES_VALUE: [&str; 6] = [
            "--test-threads",
            "--skip",
            "--color",
            "--format",
            "--logfile",
            "-Z",
        ];
        let mut names = Vec::new();
        let mut nothing = false;
        let mut args = std::env::args().skip(1);
        while let Some(arg) = args.next() {
            if TAKES_VALUE.contains(&arg.as_str()) {
                args.next();
            } else if arg == "--ignored" || arg == "--list" {
                nothing = true;
            } else if !arg.starts_with('-') {
                names.push(arg);
            }
        }
        (names, nothing)
    }

    /// Runs the checks in order, on this thread (those whose name contains a filter, if any).
    pub fn main() {
        let (names, nothing) = filters();
        let selected = |name: &str| {
            !nothing && (names.is_empty() || names.iter().any(|f| name.contains(f.as_str())))
        };
        if !races_required() {
            println!(
                "leaks: WF races are reported, not required (WFIC_LEAKS_RACES=report, or one CPU)"
            );
        }
        let run = |name: &str, f: &dyn Fn()| {
            if selected(name) {
                println!("leaks: {name} ...");
                f();
                println!("leaks: {name} ok");
            }
        };
        run(
            "the_counter_sees_one_forgotten_box",
            &the_counter_sees_one_forgotten_box,
        );
        run("every_scheme_frees_everything", &|| {
            let slot = slot_bytes();
            println!("leaks: a WF list slot is {slot} bytes (from the allocator)");
            every_scheme_frees_everything(slot)
        });
    }
}
