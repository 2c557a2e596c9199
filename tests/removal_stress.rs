//! Real threads removing while others insert and look up, in every scheme, at 2 and at 8 workers
//! (8 oversubscribed on the 2-core CI machine, which only adds preemptions: these are correctness
//! tests): 10^6 operations a scheme and worker count (`WFIC_REMOVAL_STRESS_OPS`; the long run,
//! 10^7, is in docs/verification.md), 2 inserts to 1 removal to 10 lookups, every record a lookup
//! meets checked whole, genuine and not removed
//! before the lookup began (never resurrected; about half the lookups are at a record already
//! removed, and the count of those chances is asserted), and after the frame exactly the records
//! stored and not removed are left. Besides removing their own records, workers now and then
//! remove another worker's next record while it is being inserted (the removal meets the slot
//! reserved and unwritten, or the record, or nothing); where workers run at once both outcomes
//! must occur, and an owner whose removal takes nothing must find that a racer took its record.
#![cfg(not(checker))]

mod common;

use common::{with_scheme, Rng, SchemeCheck, AXES, SCHEMES};
use glam::Vec3;
use std::collections::HashSet;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use wfic::cache::{CacheConfig, CacheHandle, Inserted, IrradianceCache};
use wfic::ic::{Record, Selection};

/// The size of one run: workers, and per worker its inserts, removals (of its own earlier
/// records, one every other insert) and lookups (five an insert).
#[derive(Clone, Copy, Debug)]
struct Size {
    threads: u32,
    inserts: u64,
    removals: u64,
    lookups: u64,
    /// The records sit on a lattice of this many points per axis over the 10-unit world, at
    /// least one point a record; the points stay more than 0.05 apart, so a record's influence
    /// (at most [`ACCURACY`] * 0.5 = 0.05) holds no other record's centre, and a point selection
    /// at a record's centre takes exactly that record.
    lattice: u64,
}

impl Size {
    /// About `ops` operations in all over `threads` workers.
    fn new(threads: u32, ops: u64) -> Self {
        let unit = (ops / (13 * u64::from(threads))).max(8);
        let inserts = 2 * unit;
        let points = inserts * u64::from(threads);
        let lattice = (points as f64).cbrt().ceil() as u64 + 1;
        assert!(
            10.0 / lattice as f64 > 0.05,
            "{ops} operations need a lattice of {lattice} a side: too dense for one record a point"
        );
        Self {
            threads,
            inserts,
            removals: unit,
            lookups: 10 * unit,
            lattice,
        }
    }

    /// Every operation of the run.
    fn ops(self) -> u64 {
        u64::from(self.threads) * (self.inserts + self.removals + self.lookups)
    }
}

const ACCURACY: f32 = 0.1;

/// `WFIC_REMOVAL_STRESS_OPS`: the operations a scheme and worker count (default 10^6).
fn ops() -> u64 {
    std::env::var("WFIC_REMOVAL_STRESS_OPS").map_or(1_000_000, |v| {
        v.parse().expect("WFIC_REMOVAL_STRESS_OPS: a number")
    })
}

fn config() -> CacheConfig {
    CacheConfig::new(Vec3::ZERO, Vec3::splat(10.0), ACCURACY).unwrap()
}

/// Worker `worker`'s `seq`-th record: a pure function of the three, on its own lattice point.
fn record(size: Size, worker: u32, seq: u64) -> Record {
    let n = size.lattice;
    let k = seq * u64::from(size.threads) + u64::from(worker);
    let (i, j, l) = (k % n, (k / n) % n, k / (n * n));
    assert!(l < n, "lattice exhausted");
    let step = 10.0 / n as f32;
    let p = Vec3::new(i as f32 + 0.5, j as f32 + 0.5, l as f32 + 0.5) * step;
    let mut rng = Rng::new(k ^ 0xdead);
    Record::new(
        p,
        AXES[(k % 6) as usize],
        Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
        rng.range(0.2, 0.5),
    )
}

/// True when `r` is intact and exactly what its id says was inserted.
fn genuine(size: Size, r: &Record) -> bool {
    let id = r.id();
    if id.worker().index() >= size.threads || id.seq() >= size.inserts {
        return false;
    }
    let want = record(size, id.worker().index(), id.seq());
    r.is_intact()
        && r.position == want.position
        && r.normal == want.normal
        && r.irradiance == want.irradiance
        && r.radius == want.radius
}

/// What the workers share besides the cache: per worker, how many of its inserts have returned;
/// per record, the removal epoch at which its removal returned (0: not removed, [`PENDING`]:
/// removed, its epoch being taken); and the epoch counter itself.
///
/// A removal, once it returns, stores `PENDING`, then takes its epoch `e` (the counter's
/// increment), then stores `e`. A lookup that read the counter at `before >= e` happens-after
/// the increment, so after the `PENDING` store: it cannot read the record's state as 0, and if it
/// reads `PENDING` it waits for `e` and judges by it. So every record whose removal's epoch is at
/// most `before` is judged, none by a state not yet written.
struct Shared {
    size: Size,
    inserted: Vec<AtomicU64>,
    gone: Vec<AtomicU64>,
    epoch: AtomicU64,
    /// Per record: taken by another worker's removal racing its insert (see `race`).
    raced: Vec<AtomicBool>,
}

/// A record's state between its removal's return and its epoch.
const PENDING: u64 = u64::MAX;

impl Shared {
    fn slot(&self, worker: u32, seq: u64) -> usize {
        (seq * u64::from(self.size.threads) + u64::from(worker)) as usize
    }
}

struct Outcome {
    stored: Vec<u64>,
    removed: Vec<u64>,
    lookups: u64,
    met: u64,
    /// Lookups at a record whose removal had returned before they began: each a chance to see
    /// it resurrected.
    chances: u64,
    /// Removals of another worker's next record, racing its insert: how many were made, and the
    /// records they took.
    races: u64,
    taken: Vec<(u32, u64)>,
}

struct RemovalStress(Size);

impl SchemeCheck for RemovalStress {
    fn check<C: IrradianceCache>(&mut self, mut cache: C) {
        let scheme = cache.scheme().name();
        let size = self.0;
        let records = size.inserts * u64::from(size.threads);
        let shared = Shared {
            size,
            inserted: (0..size.threads).map(|_| AtomicU64::new(0)).collect(),
            gone: (0..records).map(|_| AtomicU64::new(0)).collect(),
            epoch: AtomicU64::new(0),
            raced: (0..records).map(|_| AtomicBool::new(false)).collect(),
        };
        let frame = cache.frame();
        let outcomes = frame.run(size.threads as usize, |h, worker| {
            work(h, worker.index(), &shared, scheme)
        });
        let report = frame.close();

        let own: u64 = outcomes.iter().map(|o| o.removed.len() as u64).sum();
        let taken: HashSet<(u32, u64)> = outcomes.iter().flat_map(|o| o.taken.clone()).collect();
        let removed = own + taken.len() as u64;
        assert_eq!(
            report.workers.removed, removed,
            "{scheme}: removals counted"
        );
        // Removals racing another worker's insert of the record they select: both outcomes, where
        // workers run at once (TRA runs them one after another; LW's in-frame records are private
        // to their worker, so another's removal never takes one).
        let races: u64 = outcomes.iter().map(|o| o.races).sum();
        if !matches!(scheme, "tra" | "lw") {
            assert!(
                !taken.is_empty() && (taken.len() as u64) < races,
                "{scheme}: of {races} removals racing an insert, {} took the record: the race \
                 was not run both ways",
                taken.len()
            );
        }
        let threads = u64::from(size.threads);
        assert!(
            removed >= size.removals * threads * 9 / 10,
            "{scheme}: {removed} removals"
        );
        let lookups: u64 = outcomes.iter().map(|o| o.lookups).sum();
        assert_eq!(lookups, size.lookups * threads, "{scheme}: lookups");
        assert_eq!(report.workers.lookups, lookups, "{scheme}: lookups counted");
        let met: u64 = outcomes.iter().map(|o| o.met).sum();
        // A lookup aims at a record of a random worker; about half the records are alive. LW's
        // workers see only their own records during the frame: a worker's share of those.
        let least = if scheme == "lw" {
            lookups / (4 * threads)
        } else {
            lookups / 10
        };
        assert!(met >= least, "{scheme}: lookups met only {met} records");
        // Lookups at a record already removed: every removed record is a few lookups' target.
        let chances: u64 = outcomes.iter().map(|o| o.chances).sum();
        assert!(
            chances >= lookups / 20,
            "{scheme}: only {chances} lookups were at a record removed before they began"
        );
        eprintln!(
            "{scheme}, {} workers, {} operations: {removed} removals, {lookups} lookups meeting \
             {met} records, checked; {chances} of them at a record already removed; {races} \
             removals raced an insert and took {} records",
            size.threads,
            size.ops(),
            taken.len()
        );

        // Exactly the stored records that were not removed are left.
        let mut want = HashSet::new();
        for (worker, o) in outcomes.iter().enumerate() {
            let gone: HashSet<u64> = o.removed.iter().copied().collect();
            want.extend(
                o.stored
                    .iter()
                    .filter(|s| !gone.contains(s) && !taken.contains(&(worker as u32, **s)))
                    .map(|&s| (worker as u32, s)),
            );
        }
        let left = cache.snapshot();
        assert!(
            left.iter().all(|r| genuine(size, r)),
            "{scheme}: a torn or forged record left"
        );
        let got: HashSet<(u32, u64)> = left
            .iter()
            .map(|r| (r.id().worker().index(), r.id().seq()))
            .collect();
        assert_eq!(got.len(), left.len(), "{scheme}: a record left twice");
        assert_eq!(got, want, "{scheme}: survivors");
    }
}

fn work<H: CacheHandle>(h: &mut H, me: u32, shared: &Shared, scheme: &str) -> Outcome {
    let size = shared.size;
    let mut rng = Rng::new(u64::from(me) * 7919 + 1);
    let mut out = Outcome {
        stored: Vec::new(),
        removed: Vec::new(),
        lookups: 0,
        met: 0,
        chances: 0,
        races: 0,
        taken: Vec::new(),
    };
    let mut alive: Vec<u64> = Vec::new();
    let mut found = Vec::new();
    let lookups_per_insert = size.lookups / size.inserts;
    for seq in 0..size.inserts {
        let r = record(size, me, seq);
        match h.insert(r).expect("valid record") {
            Inserted::Stored(id) => {
                assert_eq!(id.seq(), seq, "{scheme}: ids count inserts");
                out.stored.push(seq);
                alive.push(seq);
            }
            Inserted::Discarded(_) => {}
            Inserted::NotCached(_) => unreachable!("every scheme here stores"),
        }
        // Release: a reader that loads this count with Acquire happens-after the insert.
        shared.inserted[me as usize].store(seq + 1, Ordering::Release);

        // Every other insert, remove one of this worker's own live records: a point selection at
        // its centre takes exactly it (its insert returned, so it happens-before the removal).
        if seq % (size.inserts / size.removals) == 1 && !alive.is_empty() {
            let k = rng.below(alive.len() as u64) as usize;
            let victim = alive.swap_remove(k);
            let p = record(size, me, victim).position;
            let n = h.remove(&Selection::touching(p, p).unwrap());
            // LW removes its own local records at once, as the others remove theirs. A record
            // may be gone already, taken by another worker's racing removal.
            if n == 0 {
                await_raced(shared, me, victim, scheme);
            } else {
                assert_eq!(n, 1, "{scheme}: the removal of r{me}.{victim} took {n}");
                out.removed.push(victim);
                mark_gone(shared, me, victim);
            }
        }
        // Now and then, remove another worker's next record, racing its insert: the removal
        // meets the slot reserved and not yet written, or the record, or nothing.
        if seq % 16 == 5 {
            race(h, me, seq, shared, &mut out);
        }

        for _ in 0..lookups_per_insert {
            // Near a record of a random worker whose insert has returned.
            // (This worker's own when that one has inserted nothing yet: TRA runs its workers
            // one after another.)
            let mut other = rng.below(u64::from(size.threads)) as u32;
            // Acquire: pairs with the Release store after the insert.
            let mut done = shared.inserted[other as usize].load(Ordering::Acquire);
            if done == 0 {
                other = me;
                // Acquire: as above (this worker's own store: it has inserted `seq + 1`).
                done = shared.inserted[me as usize].load(Ordering::Acquire);
            }
            let target_seq = rng.below(done);
            let target = record(size, other, target_seq);
            // Acquire: see `Shared`; every removal whose epoch is at most `before` happens-before
            // this lookup, which must not meet its record.
            let before = shared.epoch.load(Ordering::Acquire);
            // Acquire: as below (a record still `PENDING` is not counted: a chance only where
            // the verdict is sure).
            let target_gone = shared.gone[shared.slot(other, target_seq)].load(Ordering::Acquire);
            if target_gone != 0 && target_gone != PENDING && target_gone <= before {
                out.chances += 1;
            }
            let q = target.position + Vec3::splat(0.01);
            found.clear();
            // The interpolation itself is the agreement tests' business; here, its traversal.
            let _ = h.lookup(q, target.normal);
            out.lookups += 1;
            h.valid_records(q, target.normal, &mut found);
            for f in &found {
                assert!(
                    genuine(size, f),
                    "{scheme}: a torn or forged record {:?}",
                    f.id()
                );
                let (fw, fs) = (f.id().worker().index(), f.id().seq());
                // Acquire: pairs with the remover's Release stores (see `Shared`).
                let state = &shared.gone[shared.slot(fw, fs)];
                let mut gone = state.load(Ordering::Acquire);
                while gone == PENDING {
                    std::thread::yield_now();
                    // Acquire: as above.
                    gone = state.load(Ordering::Acquire);
                }
                assert!(
                    gone == 0 || gone > before,
                    "{scheme}: r{fw}.{fs}, removed at epoch {gone}, found by a lookup that began at {before}"
                );
                out.met += 1;
            }
        }
    }
    out
}

/// Marks `worker`'s record `seq` removed (see `Shared`): `PENDING`, then its epoch.
fn mark_gone(shared: &Shared, worker: u32, seq: u64) {
    let gone = &shared.gone[shared.slot(worker, seq)];
    // Release: ordered before the increment below (program order, and the increment is a
    // release), so a lookup that reads its epoch or later reads this or what follows.
    gone.store(PENDING, Ordering::Release);
    // AcqRel: the increment happens-after the removal and the store above, and a lookup that
    // loads this value or a later one (Acquire; the increments form one release sequence)
    // happens-after both.
    let e = shared.epoch.fetch_add(1, Ordering::AcqRel) + 1;
    // Release: a lookup that reads `PENDING` waits for this value.
    gone.store(e, Ordering::Release);
}

/// Removes the record another worker inserts next, racing that insert: a point selection at its
/// centre takes it or nothing. A record taken is marked gone and raced, so its owner, whose own
/// removal of it will then take nothing, knows why.
fn race<H: CacheHandle>(h: &mut H, me: u32, seq: u64, shared: &Shared, out: &mut Outcome) {
    let threads = shared.size.threads;
    let other = (me + 1 + (seq as u32 / 16) % (threads - 1)) % threads;
    // Acquire: the count of the other worker's inserts that have returned; its next is in
    // flight or about to be.
    let next = shared.inserted[other as usize].load(Ordering::Acquire);
    if next >= shared.size.inserts {
        return;
    }
    let p = record(shared.size, other, next).position;
    out.races += 1;
    if h.remove(&Selection::touching(p, p).unwrap()) == 1 {
        out.taken.push((other, next));
        mark_gone(shared, other, next);
        // Release: the owner's Acquire load that sees this happens-after the marks above.
        shared.raced[shared.slot(other, next)].store(true, Ordering::Release);
    }
}

/// The owner's removal of its record `seq` took nothing: another worker's racing removal must
/// have taken it. Waits (at most ten seconds) for that worker to say so.
fn await_raced(shared: &Shared, me: u32, seq: u64, scheme: &str) {
    let start = std::time::Instant::now();
    // Acquire: pairs with the racer's Release store.
    while !shared.raced[shared.slot(me, seq)].load(Ordering::Acquire) {
        assert!(
            start.elapsed().as_secs() < 10,
            "{scheme}: the removal of r{me}.{seq} took nothing, and no other removal took it"
        );
        std::thread::yield_now();
    }
}

#[test]
fn every_scheme_removes_while_others_insert_and_look_up() {
    for threads in [2, 8] {
        let size = Size::new(threads, ops());
        for scheme in SCHEMES {
            with_scheme(scheme, config(), &mut RemovalStress(size));
        }
    }
}
