//! The generic exhaustive client: every sequence of inserts, lookups and removals, for 2 threads
//! of 3 operations and for 3 threads of 2, run under loom on WF and judged against the stated
//! guarantees (docs/design.md, "The guarantees, in happens-before terms").
//!
//! The bespoke models (`loom_wf.rs`) each pin one race we thought of. This client does not choose:
//! it runs every combination of operation kinds, in three layouts of a two-level tree (root and
//! depth-1 children) that make the operations meet in one list, across a graft, and in disjoint
//! subtrees, and judges every execution loom generates by one set of rules.
//!
//! **Happens-before from the execution.** Each thread counts its finished operations in an atomic
//! of its own (a Release store after each operation) and, before each operation, loads the other
//! threads' counts (Acquire). A load that returns `k` is a synchronisation the execution made: the
//! first `k` operations of that thread happen-before this one. Those edges, program order and the
//! spawn edge (the preloaded record happens-before everything) are closed transitively; real time
//! plays no part. The cache's own synchronisation makes more edges than these; leaving them out
//! only weakens what is demanded, so a reported violation is never a false one.
//!
//! **The judge.** A removal returns a count, not which records it took. The judge therefore asks
//! whether some attribution of the taken records (every record inserted and absent after the
//! threads joined) to the removals explains the whole history: each removal's count met exactly,
//! each record taken by a removal that selects it and does not happen-before its insert, and then
//! guarantees 1, 2, 3, 6, 7 and 9 (and 8 and 10: every returned record whole, every insert stored)
//! hold. The numbers are design.md's. A history with no such attribution fails, with the rule
//! that failed last printed beside the history.
//!
//! **Bounds.** Without a preemption bound, 2 threads of 3 operations already take minutes for a
//! single plan (IL | IR: more than two minutes); with the whole set of plans that is days. The
//! whole sets therefore run with preemption bound 1, and the CI subset, 63 combinations, with
//! bound 2 (`WFIC_CLIENT_BOUND` sets another, `none` removes it); `one_plan` runs one combination.
//! To keep three threads within reach, the counts are lean: an insert loads none (nothing it does
//! depends on what happened before it) and a lookup stores none (so edges from a lookup to a later
//! operation of another thread are not seen), and with three threads each thread loads only the
//! next one's count (edges still chain through the third).
//!
//! `cargo test --features loom --test loom_client` runs the CI subset (every order of one insert,
//! one lookup and one removal on each of 2 threads, in each layout, at bound 2); `-- --ignored` runs every
//! combination and writes `results/loom-client/{two,three}-threads.{md,csv}` with the executions
//! per combination and in total.
#![cfg(feature = "loom")]

mod loom_common;

use glam::Vec3;
use loom_common::{config, expect_failure, root_record};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use wfic::cache::wf::{Minimal, Orderings};
use wfic::cache::{CacheHandle, CasFailure, Inserted, IrradianceCache, WaitFree};
use wfic::ic::{Record, Selection, WorkerId};
use wfic::sync::{thread, Arc, AtomicUsize, Ordering};

/// An operation kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    Insert,
    Lookup,
    Remove,
}

impl Kind {
    const ALL: [Kind; 3] = [Kind::Insert, Kind::Lookup, Kind::Remove];

    fn letter(self) -> char {
        match self {
            Kind::Insert => 'I',
            Kind::Lookup => 'L',
            Kind::Remove => 'R',
        }
    }
}

/// Where the operations act.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Layout {
    /// Every record in the root's list; every lookup and removal meets all of them.
    OneList,
    /// Every record in one depth-1 child that does not exist when the threads start: the first
    /// insert grafts it while the other threads' operations walk through the root to it.
    Graft,
    /// Thread `t`'s records, lookups and removals in depth-1 octant `t` alone: the threads meet
    /// only in the root (the preloaded record).
    Disjoint,
}

impl Layout {
    const ALL: [Layout; 3] = [Layout::OneList, Layout::Graft, Layout::Disjoint];

    /// Where thread `t` looks up and removes.
    fn point(self, t: usize) -> Vec3 {
        match self {
            Layout::OneList => Vec3::splat(2.0),
            Layout::Graft => Vec3::splat(1.0),
            // (-,-,-), (+,+,+), (+,-,-): 0.6 from the box's faces, so no other octant's loose
            // cell ([-1, 3] or [1, 5] a side) holds the point.
            Layout::Disjoint => [Vec3::splat(0.6), Vec3::splat(3.4), Vec3::new(3.4, 0.6, 0.6)][t],
        }
    }

    /// The record of operation `j` of thread `t`, unique to it.
    fn record(self, t: usize, j: usize) -> Record {
        let shift = 0.05 * (1 + 3 * t + j) as f32;
        match self {
            Layout::OneList => root_record(shift),
            Layout::Graft | Layout::Disjoint => Record::new(
                self.point(t) + Vec3::new(shift, 0.0, 0.0),
                Vec3::Z,
                Vec3::new(1.0, 2.0, 3.0),
                0.8,
            ),
        }
    }
}

/// A removal's selection at `p`: every record whose influence reaches it.
fn at(p: Vec3) -> Selection {
    Selection::touching(p, p).expect("a finite point")
}

/// What one operation returned.
#[derive(Clone, Debug)]
enum Outcome {
    Inserted(Record, bool),
    Found(Vec<Record>),
    Removed(usize),
}

/// One operation of an execution: who, what, and the other threads' counts it saw first.
#[derive(Clone, Debug)]
struct Event {
    thread: usize,
    index: usize,
    kind: Kind,
    point: Vec3,
    outcome: Outcome,
    seen: Vec<usize>,
}

/// One execution's history: the events, thread by thread, and what was left after the join.
#[derive(Debug)]
struct History {
    layout: Layout,
    preload: Record,
    threads: Vec<Vec<Event>>,
    survivors: Vec<Record>,
}

/// Runs one execution of `plan` (a sequence of kinds per thread) on WF with policy `O`.
fn execute<O: Orderings>(layout: Layout, plan: &[Vec<Kind>]) -> History {
    let cache = Arc::new(WaitFree::<O>::new(config(), CasFailure::Adopt));
    let preload = root_record(-0.5);
    {
        let mut h = cache.handle(WorkerId::new(0));
        h.insert(preload).expect("the preloaded record");
    }
    let done: Arc<Vec<AtomicUsize>> = Arc::new(plan.iter().map(|_| AtomicUsize::new(0)).collect());
    let workers: Vec<_> = plan
        .iter()
        .cloned()
        .enumerate()
        .map(|(t, kinds)| {
            let (cache, done) = (cache.clone(), done.clone());
            thread::spawn(move || run_thread::<O>(&cache, &done, layout, t, &kinds))
        })
        .collect();
    let threads = workers.into_iter().map(|w| w.join().unwrap()).collect();
    let mut cache = Arc::try_unwrap(cache).unwrap_or_else(|_| panic!("threads joined"));
    History {
        layout,
        preload,
        threads,
        survivors: cache.snapshot(),
    }
}

fn run_thread<O: Orderings>(
    cache: &WaitFree<O>,
    done: &[AtomicUsize],
    layout: Layout,
    t: usize,
    kinds: &[Kind],
) -> Vec<Event> {
    let mut h = cache.handle(WorkerId::new(1 + t as u32));
    let point = layout.point(t);
    let mut events = Vec::new();
    for (j, &kind) in kinds.iter().enumerate() {
        // Acquire: pairs with the other threads' Release stores below; a count `k` seen here
        // makes their first `k` operations happen-before this one.
        let seen = done
            .iter()
            .enumerate()
            .map(|(u, d)| {
                if u == t {
                    j
                } else if kind == Kind::Insert || !watches(done.len(), t, u) {
                    0
                } else {
                    d.load(Ordering::Acquire)
                }
            })
            .collect();
        let outcome = match kind {
            Kind::Insert => {
                let r = layout.record(t, j);
                let stored = matches!(h.insert(r), Ok(Inserted::Stored(_)));
                Outcome::Inserted(r, stored)
            }
            Kind::Lookup => {
                let mut out = Vec::new();
                h.valid_records(point, Vec3::Z, &mut out);
                Outcome::Found(out)
            }
            Kind::Remove => Outcome::Removed(h.remove(&at(point))),
        };
        events.push(Event {
            thread: t,
            index: j,
            kind,
            point,
            outcome,
            seen,
        });
        // Release: this operation, and all before it on this thread, happen-before any
        // operation whose Acquire load above returns this count.
        if kind != Kind::Lookup {
            done[t].store(j + 1, Ordering::Release);
        }
    }
    events
}

/// Whether thread `t` of `threads` loads thread `u`'s count: every other thread's with two
/// threads; with three, only the next one's (a ring: edges still chain through the third).
fn watches(threads: usize, t: usize, u: usize) -> bool {
    threads <= 2 || u == (t + 1) % threads
}

/// The history's operations in one list, and which happens-before which (transitively closed).
struct Order<'h> {
    events: Vec<&'h Event>,
    hb: Vec<Vec<bool>>,
}

impl<'h> Order<'h> {
    fn of(history: &'h History) -> Self {
        let events: Vec<&Event> = history.threads.iter().flatten().collect();
        let n = events.len();
        let mut hb = vec![vec![false; n]; n];
        for (a, x) in events.iter().enumerate() {
            for (b, y) in events.iter().enumerate() {
                hb[a][b] = if x.thread == y.thread {
                    x.index < y.index
                } else {
                    y.seen[x.thread] > x.index
                };
            }
        }
        for k in 0..n {
            for a in 0..n {
                for b in 0..n {
                    if hb[a][k] && hb[k][b] {
                        hb[a][b] = true;
                    }
                }
            }
        }
        Self { events, hb }
    }
}

/// A record inserted in the history: its insert (`None`: the preload, which happens-before all).
struct Known {
    record: Record,
    insert: Option<usize>,
}

fn same(a: &Record, b: &Record) -> bool {
    a.position == b.position && a.irradiance == b.irradiance
}

/// What the judge knows of one history once the plain checks have passed.
struct Judge<'h> {
    order: Order<'h>,
    records: Vec<Known>,
    /// Which records survived the join.
    live: Vec<bool>,
    /// The removals' events.
    removals: Vec<usize>,
}

/// Judges `history`; `Err` names the rule that no attribution of the taken records satisfies.
fn judge(history: &History) -> Result<(), String> {
    Judge::new(history)?.attribute()
}

impl<'h> Judge<'h> {
    /// The checks that need no attribution: guarantees 10 (every insert stored), 1 and 8 (every
    /// record returned whole, inserted, by an insert the lookup does not happen-before, and once)
    /// and 9 (the survivors whole and single; the counts add up to the records gone).
    fn new(history: &'h History) -> Result<Self, String> {
        let order = Order::of(history);
        let mut records = vec![Known {
            record: history.preload,
            insert: None,
        }];
        for (i, e) in order.events.iter().enumerate() {
            if let Outcome::Inserted(r, stored) = e.outcome {
                if !stored {
                    return Err(format!("guarantee 10: insert {} was not stored", name(e)));
                }
                records.push(Known {
                    record: r,
                    insert: Some(i),
                });
            }
        }
        let index_of = |r: &Record| {
            records
                .iter()
                .position(|x| same(&x.record, r))
                .filter(|_| r.is_intact())
        };
        for (i, e) in order.events.iter().enumerate() {
            let Outcome::Found(found) = &e.outcome else {
                continue;
            };
            for (k, r) in found.iter().enumerate() {
                let Some(x) = index_of(r) else {
                    return Err(format!(
                        "guarantee 1: {} returned a torn or phantom record",
                        name(e)
                    ));
                };
                if records[x].insert.is_some_and(|ins| order.hb[i][ins]) {
                    return Err(format!(
                        "guarantee 1: {} returned a record inserted after it",
                        name(e)
                    ));
                }
                if found[..k].iter().any(|f| same(f, r)) {
                    return Err(format!("guarantee 8: {} returned a record twice", name(e)));
                }
            }
        }
        let mut live = vec![false; records.len()];
        for r in &history.survivors {
            match index_of(r) {
                Some(x) if !live[x] => live[x] = true,
                _ => return Err("guarantee 9: a torn, phantom or doubled record survived".into()),
            }
        }
        let removals: Vec<usize> = (0..order.events.len())
            .filter(|&i| order.events[i].kind == Kind::Remove)
            .collect();
        let judge = Self {
            order,
            records,
            live,
            removals,
        };
        let counted: usize = judge.removals.iter().map(|&i| judge.count(i)).sum();
        let gone = judge.live.iter().filter(|l| !**l).count();
        if counted != gone {
            return Err(format!(
                "guarantee 9: the removals counted {counted}, but {gone} records are gone"
            ));
        }
        Ok(judge)
    }

    fn hb(&self, a: usize, b: usize) -> bool {
        self.order.hb[a][b]
    }

    fn event(&self, i: usize) -> &Event {
        self.order.events[i]
    }

    /// Removal `i`'s count.
    fn count(&self, i: usize) -> usize {
        match self.event(i).outcome {
            Outcome::Removed(n) => n,
            _ => 0,
        }
    }

    /// Whether operation `i`'s selection (at its point) takes record `x`.
    fn selects(&self, i: usize, x: usize) -> bool {
        at(self.event(i).point).selects(&self.records[x].record, config().accuracy(), 0)
    }

    /// Whether record `x` is valid at lookup `i`'s point.
    fn valid(&self, i: usize, x: usize) -> bool {
        let r = &self.records[x].record;
        wfic::ic::valid_weight(r, self.event(i).point, Vec3::Z, config().accuracy()).is_some()
    }

    /// Whether lookup `i` returned record `x`.
    fn returned(&self, i: usize, x: usize) -> bool {
        match &self.event(i).outcome {
            Outcome::Found(found) => found.iter().any(|f| same(f, &self.records[x].record)),
            _ => false,
        }
    }

    /// Whether record `x`'s insert happens-before operation `i` (the preload's always does).
    fn inserted_before(&self, x: usize, i: usize) -> bool {
        self.records[x].insert.map_or(true, |ins| self.hb(ins, i))
    }

    /// Guarantees 2, 3 and 6 for lookup `i`, given who took what.
    fn check_lookup(&self, i: usize, taker: &[Option<usize>]) -> Result<(), String> {
        let e = self.event(i);
        for (x, took) in taker.iter().enumerate() {
            // Out of reach of `i`'s obligations if a removal not happening-after `i` took it.
            let may_be_gone = took.is_some_and(|y| !self.hb(i, y));
            let missed = self.valid(i, x) && !self.returned(i, x) && !may_be_gone;
            if self.returned(i, x) && took.is_some_and(|y| self.hb(y, i)) {
                return Err(format!(
                    "guarantee 6: {} returned a record a removal before it took",
                    name(e)
                ));
            }
            if missed && self.inserted_before(x, i) {
                return Err(format!(
                    "guarantee 2: {} missed a record whose insert happened-before it",
                    name(e)
                ));
            }
            let earlier = (0..i)
                .any(|k| self.event(k).thread == e.thread && self.hb(k, i) && self.returned(k, x));
            if missed && earlier {
                return Err(format!(
                    "guarantee 3: {} missed a record an earlier lookup of its thread returned",
                    name(e)
                ));
            }
        }
        Ok(())
    }

    /// Guarantee 7 for removal `i`: every selected record whose insert happens-before it is
    /// taken, by it or by a removal that does not happen after it.
    fn check_removal(&self, i: usize, taker: &[Option<usize>]) -> Result<(), String> {
        for (x, took) in taker.iter().enumerate() {
            if self.selects(i, x) && self.inserted_before(x, i) {
                let left = self.live[x] || took.is_some_and(|y| self.hb(i, y));
                if left {
                    return Err(format!(
                        "guarantee 7: {} left a record whose insert happened-before it",
                        name(self.event(i))
                    ));
                }
            }
        }
        Ok(())
    }

    /// Every rule that depends on the attribution `taker` (record to the removal that took it).
    fn check(&self, taker: &[Option<usize>]) -> Result<(), String> {
        for i in 0..self.order.events.len() {
            match self.event(i).kind {
                Kind::Lookup => self.check_lookup(i, taker)?,
                Kind::Remove => self.check_removal(i, taker)?,
                Kind::Insert => {}
            }
        }
        Ok(())
    }

    /// Searches the attributions of the records gone: each to a removal that selects it and
    /// does not happen-before its insert, every removal's count met. `Ok` at the first one under
    /// which every rule holds; else the last rule that failed.
    fn attribute(&self) -> Result<(), String> {
        let gone: Vec<usize> = (0..self.records.len()).filter(|&x| !self.live[x]).collect();
        let mut taker = vec![None; self.records.len()];
        let mut left: Vec<usize> = self.removals.iter().map(|&i| self.count(i)).collect();
        let mut last =
            String::from("guarantee 9: no removal could have taken a record that is gone");
        if self.search(&gone, &mut taker, &mut left, &mut last) {
            Ok(())
        } else {
            Err(last)
        }
    }

    fn search(
        &self,
        gone: &[usize],
        taker: &mut [Option<usize>],
        left: &mut [usize],
        last: &mut String,
    ) -> bool {
        let Some((&x, rest)) = gone.split_first() else {
            return match self.check(taker) {
                Ok(()) => true,
                Err(e) => {
                    *last = e;
                    false
                }
            };
        };
        for (r, &i) in self.removals.iter().enumerate() {
            let may_take =
                self.selects(i, x) && self.records[x].insert.map_or(true, |ins| !self.hb(i, ins));
            if left[r] > 0 && may_take {
                left[r] -= 1;
                taker[x] = Some(i);
                if self.search(rest, taker, left, last) {
                    return true;
                }
                taker[x] = None;
                left[r] += 1;
            }
        }
        false
    }
}

fn name(e: &Event) -> String {
    format!("{}{} of thread {}", e.kind.letter(), e.index + 1, e.thread)
}

impl History {
    /// The history, one line an operation, for a failure's message.
    fn render(&self) -> String {
        let mut s = format!(
            "layout {:?}; preloaded {:?}\n",
            self.layout, self.preload.position
        );
        for e in self.threads.iter().flatten() {
            let what = match &e.outcome {
                Outcome::Inserted(r, stored) => {
                    format!("insert {:?} (stored: {stored})", r.position)
                }
                Outcome::Found(found) => format!(
                    "lookup at {:?} -> {:?}",
                    e.point,
                    found.iter().map(|r| r.position).collect::<Vec<_>>()
                ),
                Outcome::Removed(n) => format!("remove at {:?} -> {n}", e.point),
            };
            let _ = writeln!(s, "  {}: {what}; saw counts {:?}", name(e), e.seen);
        }
        let _ = write!(
            s,
            "  survivors: {:?}",
            self.survivors
                .iter()
                .map(|r| r.position)
                .collect::<Vec<_>>()
        );
        s
    }
}

/// Runs `plan` in `layout` under loom with policy `O`, judging every execution; returns how many
/// executions loom ran.
fn explore<O: Orderings>(layout: Layout, plan: &[Vec<Kind>], bound: Option<usize>) -> usize {
    let runs = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let counter = runs.clone();
    let plan = plan.to_vec();
    let mut builder = loom::model::Builder::new();
    builder.preemption_bound = bound;
    builder.check(move || {
        // A std atomic: invisible to loom, it only counts executions.
        counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let history = execute::<O>(layout, &plan);
        if let Err(rule) = judge(&history) {
            panic!("{rule}\n{}", history.render());
        }
    });
    runs.load(std::sync::atomic::Ordering::Relaxed)
}

/// The preemption bound of the whole sets.
const BOUND: usize = 1;

/// The preemption bound of the CI subset: smaller, so it can afford more.
const CI_BOUND: usize = 2;

/// The preemption bound: `WFIC_CLIENT_BOUND` if set (`none` for none), else `default` (the
/// module documentation says why there is one).
fn bound(default: usize) -> Option<usize> {
    match std::env::var("WFIC_CLIENT_BOUND").as_deref() {
        Ok("none") => None,
        Ok(n) => Some(n.parse().expect("WFIC_CLIENT_BOUND: a number or none")),
        Err(_) => Some(default),
    }
}

/// Every sequence of `ops` kinds.
fn sequences(ops: usize) -> Vec<Vec<Kind>> {
    let mut out = vec![Vec::new()];
    for _ in 0..ops {
        out = out
            .into_iter()
            .flat_map(|s| {
                Kind::ALL.iter().map(move |&k| {
                    let mut s = s.clone();
                    s.push(k);
                    s
                })
            })
            .collect();
    }
    out
}

/// Every plan of `threads` threads of `ops` operations, up to the order of the threads (the
/// layouts treat the threads alike but for where they act, which the judge does not depend on):
/// the sequences taken as a multiset, in non-decreasing order.
fn plans(threads: usize, ops: usize) -> Vec<Vec<Vec<Kind>>> {
    let all = sequences(ops);
    let mut out = vec![Vec::new()];
    for _ in 0..threads {
        out = out
            .into_iter()
            .flat_map(|p: Vec<Vec<Kind>>| {
                let from = p
                    .last()
                    .map_or(0, |s| all.iter().position(|a| a == s).unwrap());
                all[from..].iter().map(move |s| {
                    let mut p = p.clone();
                    p.push(s.clone());
                    p
                })
            })
            .collect();
    }
    out
}

fn label(plan: &[Vec<Kind>]) -> String {
    plan.iter()
        .map(|s| s.iter().map(|k| k.letter()).collect::<String>())
        .collect::<Vec<_>>()
        .join(" | ")
}

/// Runs every plan of `threads` x `ops` that `keep` admits in every layout; returns the
/// executions per (layout, plan).
fn run_all(
    threads: usize,
    ops: usize,
    bound: Option<usize>,
    keep: impl Fn(&[Vec<Kind>]) -> bool,
) -> BTreeMap<(Layout, String), usize> {
    let mut out = BTreeMap::new();
    for layout in Layout::ALL {
        for plan in plans(threads, ops).into_iter().filter(|p| keep(p)) {
            let n = explore::<Minimal>(layout, &plan, bound);
            eprintln!("{layout:?} {}: {n} executions", label(&plan));
            out.insert((layout, label(&plan)), n);
        }
    }
    out
}

/// The CI subset: the 2 x 3 plans in which each thread makes one insert, one lookup and one
/// removal, in any order (21 plans up to the threads' order), in every layout.
#[test]
fn two_threads_of_three_operations_ci_subset() {
    let start = std::time::Instant::now();
    let counts = run_all(2, 3, bound(CI_BOUND), ci_plan);
    let total: usize = counts.values().sum();
    eprintln!(
        "CI subset: {} combinations, {total} executions in {:.0} s",
        counts.len(),
        start.elapsed().as_secs_f64()
    );
    assert_eq!(counts.len(), 3 * 21, "the subset changed");
}

/// Whether a 2 x 3 plan is in the CI subset.
fn ci_plan(p: &[Vec<Kind>]) -> bool {
    p.iter().all(|s| {
        let mut sorted = s.clone();
        sorted.sort();
        sorted == Kind::ALL
    })
}

/// Every plan of 2 threads of 3 operations, in every layout; writes
/// `results/loom-client/two-threads.{md,csv}`.
#[test]
#[ignore = "the whole set, a long run (docs/verification.md)"]
fn every_plan_of_two_threads_of_three_operations() {
    sweep("two-threads", 2, 3);
}

/// Every plan of 3 threads of 2 operations, in every layout; writes
/// `results/loom-client/three-threads.{md,csv}`.
#[test]
#[ignore = "the whole set, a long run (docs/verification.md)"]
fn every_plan_of_three_threads_of_two_operations() {
    sweep("three-threads", 3, 2);
}

/// One row of a sweep's CSV: the executions of one combination, and the commit that ran it.
struct Row {
    executions: usize,
    commit: String,
}

/// Runs every plan of `threads` x `ops` in every layout at [`BOUND`], resuming: a combination
/// already in `results/loom-client/{stem}.csv` (run at the same bound) is not run again. Each
/// combination's row is appended as it finishes and the page rewritten, so a sweep stopped at
/// any point leaves a true, partial page; run again, it goes on where it stopped.
fn sweep(stem: &str, threads: usize, ops: usize) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("results/loom-client");
    std::fs::create_dir_all(&dir).expect("results/loom-client");
    let csv = dir.join(format!("{stem}.csv"));
    let bound = bound(BOUND);
    let bound_text = bound.map_or("none".to_owned(), |b| b.to_string());
    let mut rows: BTreeMap<(Layout, String), Row> = BTreeMap::new();
    if let Ok(text) = std::fs::read_to_string(&csv) {
        for line in text.lines().skip(1) {
            let f: Vec<&str> = line.split(',').collect();
            let layout = Layout::ALL.into_iter().find(|l| format!("{l:?}") == f[0]);
            if let (Some(layout), true) = (layout, f[3] == bound_text) {
                let executions = f[2].parse().expect("a count");
                let commit = f[4].to_owned();
                rows.insert((layout, f[1].to_owned()), Row { executions, commit });
            }
        }
    }
    let commit = output_of("git", &["rev-parse", "--short", "HEAD"]);
    let all = plans(threads, ops);
    let total = Layout::ALL.len() * all.len();
    let start = std::time::Instant::now();
    // Plan by plan, each in every layout: a sweep stopped part-way covers every layout alike.
    for plan in &all {
        for layout in Layout::ALL {
            let key = (layout, label(plan));
            if rows.contains_key(&key) {
                continue;
            }
            let executions = explore::<Minimal>(layout, plan, bound);
            eprintln!("{layout:?} {}: {executions} executions", key.1);
            let commit = commit.clone();
            rows.insert(key, Row { executions, commit });
            let mut text = String::from("layout,plan,executions,bound,commit\n");
            for ((l, p), r) in &rows {
                let _ = writeln!(text, "{l:?},{p},{},{bound_text},{}", r.executions, r.commit);
            }
            std::fs::write(&csv, text).expect("the CSV");
            write_page(stem, threads, ops, total, &rows, start.elapsed());
        }
    }
}

/// The output of `cmd args`, trimmed (empty if it cannot run).
fn output_of(cmd: &str, args: &[&str]) -> String {
    std::process::Command::new(cmd)
        .args(args)
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        .unwrap_or_default()
}

/// Writes a sweep's page: how far it got, the totals per layout, the largest combinations and
/// where the run was made.
fn write_page(
    stem: &str,
    threads: usize,
    ops: usize,
    total: usize,
    rows: &BTreeMap<(Layout, String), Row>,
    took: std::time::Duration,
) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("results/loom-client");
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|c| {
            c.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or_default().trim().to_owned())
        })
        .unwrap_or_default();
    let executions: usize = rows.values().map(|r| r.executions).sum();
    let mut commits: Vec<&str> = rows.values().map(|r| r.commit.as_str()).collect();
    commits.sort_unstable();
    commits.dedup();
    let bound = bound(BOUND).map_or("none".to_owned(), |b| b.to_string());
    let state = if rows.len() == total {
        "complete".to_owned()
    } else {
        format!("**partial**: {} of {total} combinations so far", rows.len())
    };
    let mut md = format!(
        "# The generic loom client: {threads} threads of {ops} operations\n\n\
         Generated by `cargo test --release --features loom --test loom_client -- --ignored` \
         (`verify/loom_client.rs`; how to read it: \
         [docs/verification.md](../../docs/verification.md#the-generic-client)). A sweep resumes \
         from `{stem}.csv`, which holds every combination's executions and the commit that ran it.\n\n\
         - {state}; every execution judged, none failed\n\
         - commits {}; {}; page written {}\n\
         - machine: {cpu}, {} cores; this stretch of the sweep took {:.0} s (wall)\n\
         - preemption bound {bound}; policy `Minimal`, `Adopt`\n\n\
         | layout | combinations | executions |\n|---|---:|---:|\n",
        commits.join(", "),
        output_of("rustc", &["--version"]),
        output_of("date", &["-u", "+%Y-%m-%d %H:%M UTC"]),
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        took.as_secs_f64(),
    );
    for layout in Layout::ALL {
        let of: Vec<usize> = rows
            .iter()
            .filter(|((l, _), _)| *l == layout)
            .map(|(_, r)| r.executions)
            .collect();
        let _ = writeln!(
            md,
            "| {layout:?} | {} | {} |",
            of.len(),
            of.iter().sum::<usize>()
        );
    }
    let _ = writeln!(md, "| **all** | **{}** | **{executions}** |\n", rows.len());
    let mut largest: Vec<_> = rows.iter().collect();
    largest.sort_by_key(|(_, r)| std::cmp::Reverse(r.executions));
    md.push_str("The ten largest combinations:\n\n");
    md.push_str("| layout | plan | executions |\n|---|---|---:|\n");
    for ((layout, plan), r) in largest.into_iter().take(10) {
        let _ = writeln!(
            md,
            "| {layout:?} | `{}` | {} |",
            plan.replace(" | ", " / "),
            r.executions
        );
    }
    std::fs::write(dir.join(format!("{stem}.md")), md).expect("the page");
}

/// The generic client finds a bug it was not written for: the paper-literal list (no slot
/// state) read a reserved but unwritten slot, caught by loom as a data race, in plain
/// insert-and-lookup plans.
#[test]
fn the_client_catches_the_paper_literal_list() {
    use wfic::research::orderings::PaperLiteral;
    let message = expect_failure(|| {
        explore_inner::<PaperLiteral>(Layout::OneList, &[vec![Kind::Insert], vec![Kind::Lookup]]);
    });
    assert!(
        message.contains("Causality violation"),
        "expected loom's causality report, got: {message}"
    );
}

/// A removal that loads and then stores a slot's state (`BlindRemove`) double-counts when two
/// removals meet a record: guarantee 9, by the judge.
#[test]
fn the_client_catches_a_blind_removal() {
    use wfic::research::orderings::BlindRemove;
    let message = expect_failure(|| {
        explore_inner::<BlindRemove>(Layout::OneList, &[vec![Kind::Remove], vec![Kind::Remove]]);
    });
    assert!(
        message.contains("guarantee 9"),
        "expected the judge's guarantee 9, got: {message}"
    );
}

/// Without helping (`Unhelped`), an insert into a child its publisher has not yet marked is
/// missed by its own thread's next lookup: guarantee 2, by the judge.
#[test]
fn the_client_catches_an_unhelped_insert() {
    use wfic::research::orderings::Unhelped;
    let message = expect_failure(|| {
        explore_inner::<Unhelped>(
            Layout::Graft,
            &[vec![Kind::Insert], vec![Kind::Insert, Kind::Lookup]],
        );
    });
    assert!(
        message.contains("guarantee 2"),
        "expected the judge's guarantee 2, got: {message}"
    );
}

/// One execution's body, for a model run by [`expect_failure`].
fn explore_inner<O: Orderings>(layout: Layout, plan: &[Vec<Kind>]) {
    let history = execute::<O>(layout, plan);
    if let Err(rule) = judge(&history) {
        panic!("{rule}\n{}", history.render());
    }
}

/// One plan, named in `WFIC_CLIENT_PLAN` (threads' sequences separated by `|`, e.g. `IRL|IIL`) and
/// `WFIC_CLIENT_LAYOUT` (`OneList`, `Graft` or `Disjoint`): for looking at one combination.
#[test]
#[ignore = "set WFIC_CLIENT_PLAN (and WFIC_CLIENT_LAYOUT) to run one combination"]
fn one_plan() {
    let plan: Vec<Vec<Kind>> = std::env::var("WFIC_CLIENT_PLAN")
        .expect("WFIC_CLIENT_PLAN")
        .split('|')
        .map(|s| {
            s.trim()
                .chars()
                .map(|c| match c {
                    'I' => Kind::Insert,
                    'L' => Kind::Lookup,
                    'R' => Kind::Remove,
                    _ => panic!("WFIC_CLIENT_PLAN: {c} is not I, L or R"),
                })
                .collect()
        })
        .collect();
    let layout = match std::env::var("WFIC_CLIENT_LAYOUT").as_deref() {
        Ok("Graft") => Layout::Graft,
        Ok("Disjoint") => Layout::Disjoint,
        _ => Layout::OneList,
    };
    let start = std::time::Instant::now();
    let n = explore::<Minimal>(layout, &plan, bound(CI_BOUND));
    eprintln!(
        "{layout:?} {}: {n} executions in {:.1} s",
        label(&plan),
        start.elapsed().as_secs_f64()
    );
}
