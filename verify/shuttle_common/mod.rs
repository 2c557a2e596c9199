//! The shuttle harness: seeded random and PCT exploration, printed seeds, replay through the
//! environment, and failures saved as self-describing files that can be committed as regressions.
//!
//! * Every exploration prints `shuttle <test>: <scheduler> seed <seed>, <n> schedules`.
//! * `WFIC_SHUTTLE_SEED=<seed>` replaces the fresh seed of every exploration (the fixed regression
//!   seeds still run); `WFIC_SHUTTLE_FRESH=0` skips the fresh seed (only fixed seeds run).
//! * A failure is saved to `target/shuttle-failures/<test>-<scheduler>-<seed>.txt`: shuttle's
//!   version, the scheduler, the seed, the iteration budget, the test's parameters and shuttle's
//!   encoded schedule. `WFIC_SHUTTLE_REPLAY=<file>` replays that schedule in the test it names, and
//!   a file committed under `verify/shuttle-regressions/` is re-run from its seed every run (its
//!   encoded schedule goes stale when the code changes; the seed does not).
#![allow(dead_code)]

use std::fmt::Write as _;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use shuttle::scheduler::{PctScheduler, RandomScheduler, ReplayScheduler};
use shuttle::{Config, FailurePersistence, Runner};

/// Test threads of this binary share the process's panic hook, which shuttle replaces while it
/// runs. A test that *expects* a shuttle failure therefore runs alone: it takes this gate for
/// writing, every other exploration takes it for reading. (A std lock: this is test harness, not
/// code under test, and it is taken outside any shuttle execution.)
static GATE: std::sync::RwLock<()> = std::sync::RwLock::new(());

/// Held by an exploration that must not overlap a test expecting a failure.
pub fn shared() -> std::sync::RwLockReadGuard<'static, ()> {
    GATE.read()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Held by a test that expects a shuttle failure (it runs alone).
pub fn exclusive() -> std::sync::RwLockWriteGuard<'static, ()> {
    GATE.write()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A scheduler choice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sched {
    /// Uniformly random scheduling points.
    Random,
    /// Probabilistic concurrency testing with this bug depth.
    Pct(usize),
}

impl Sched {
    fn name(self) -> String {
        match self {
            Sched::Random => "random".into(),
            Sched::Pct(d) => format!("pct{d}"),
        }
    }

    fn parse(s: &str) -> Option<Self> {
        if s == "random" {
            Some(Sched::Random)
        } else {
            s.strip_prefix("pct")
                .and_then(|d| d.parse().ok())
                .map(Sched::Pct)
        }
    }
}

/// The version of shuttle this crate is locked to (read from Cargo.lock).
pub fn shuttle_version() -> String {
    let lock = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.lock"))
        .unwrap_or_default();
    let mut lines = lock.lines();
    while let Some(line) = lines.next() {
        if line == "name = \"shuttle\"" {
            if let Some(v) = lines.next().and_then(|l| l.strip_prefix("version = ")) {
                return v.trim_matches('"').to_string();
            }
        }
    }
    "unknown".into()
}

/// A fresh seed: from `WFIC_SHUTTLE_SEED`, else from the clock.
pub fn fresh_seed() -> u64 {
    if let Ok(s) = std::env::var("WFIC_SHUTTLE_SEED") {
        return s.trim().parse().expect("WFIC_SHUTTLE_SEED must be a u64");
    }
    let nanos = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64);
    nanos ^ (u64::from(std::process::id()) << 32)
}

fn failures_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("target/shuttle-failures")
}

/// One exploration: `iterations` schedules of `f` under `sched` seeded with `seed`. On failure the
/// schedule is saved (see the module docs) and the failure is re-raised with replay instructions.
pub fn explore<F>(test: &str, params: &str, sched: Sched, seed: u64, iterations: usize, f: F)
where
    F: Fn() + Send + Sync + 'static,
{
    eprintln!(
        "shuttle {test}: {} seed {seed}, {iterations} schedules ({params})",
        sched.name()
    );
    let scratch = failures_dir().join(format!("raw-{test}-{}-{seed}", sched.name()));
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(&scratch).expect("create the failure directory");
    let mut config = Config::new();
    config.failure_persistence = FailurePersistence::File(Some(scratch.clone()));
    config.max_time = Some(Duration::from_secs(240));
    config.silence_warnings = true;
    let result = catch_unwind(AssertUnwindSafe(|| match sched {
        Sched::Random => {
            Runner::new(RandomScheduler::new_from_seed(seed, iterations), config).run(f)
        }
        Sched::Pct(depth) => {
            Runner::new(PctScheduler::new_from_seed(seed, depth, iterations), config).run(f)
        }
    }));
    match result {
        Ok(_) => {
            let _ = std::fs::remove_dir_all(&scratch);
        }
        Err(payload) => {
            let schedule = std::fs::read_to_string(scratch.join("schedule000.txt"))
                .unwrap_or_else(|_| "<schedule not captured>".into());
            let file = failures_dir().join(format!("{test}-{}-{seed}.txt", sched.name()));
            let mut text = String::new();
            let _ = writeln!(
                text,
                "# wfic shuttle failure (commit under verify/shuttle-regressions/ to keep it)"
            );
            let _ = writeln!(text, "test: {test}");
            let _ = writeln!(text, "shuttle: {}", shuttle_version());
            let _ = writeln!(text, "scheduler: {}", sched.name());
            let _ = writeln!(text, "seed: {seed}");
            let _ = writeln!(text, "iterations: {iterations}");
            let _ = writeln!(text, "params: {params}");
            let _ = writeln!(
                text,
                "message: {}",
                panic_message(&*payload).replace('\n', " ")
            );
            let _ = writeln!(text, "schedule:\n{}", schedule.trim());
            std::fs::write(&file, text).expect("write the failure file");
            eprintln!(
                "shuttle {test} FAILED ({} seed {seed}). Saved to {}.\nReplay the schedule: \
                 WFIC_SHUTTLE_REPLAY={} cargo test --features shuttle --test <this test file> {test}\n\
                 Rerun the seed: WFIC_SHUTTLE_SEED={seed} cargo test --features shuttle {test}",
                sched.name(),
                file.display(),
                file.display()
            );
            std::panic::resume_unwind(payload);
        }
    }
}

/// Replays an encoded schedule. After the failing step the schedule may run out while the other
/// tasks unwind; that is allowed, so the failure reported is the original one.
pub fn replay<F>(schedule: &str, f: F)
where
    F: Fn() + Send + Sync + 'static,
{
    let mut scheduler = ReplayScheduler::new_from_encoded(schedule);
    scheduler.set_allow_incomplete();
    let mut config = Config::new();
    config.silence_warnings = true;
    Runner::new(scheduler, config).run(f);
}

/// The text of a panic payload.
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| (*s).to_string()))
        .unwrap_or_else(|| "<non-string panic>".into())
}

/// A saved failure, parsed.
#[derive(Debug)]
pub struct SavedFailure {
    /// The test that failed.
    pub test: String,
    /// Its scheduler.
    pub sched: Sched,
    /// Its seed.
    pub seed: u64,
    /// Its iteration budget.
    pub iterations: usize,
    /// The failure message.
    pub message: String,
    /// Shuttle's encoded schedule.
    pub schedule: String,
}

/// Parses a failure file written by [`explore`].
pub fn load_failure(path: &Path) -> SavedFailure {
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let field = |name: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(&format!("{name}: ")))
            .unwrap_or_else(|| panic!("{}: no `{name}:` line", path.display()))
            .to_string()
    };
    let schedule = text
        .split_once("schedule:\n")
        .map(|(_, s)| s.trim().to_string())
        .unwrap_or_else(|| panic!("{}: no schedule", path.display()));
    SavedFailure {
        test: field("test"),
        sched: Sched::parse(&field("scheduler")).expect("scheduler name"),
        seed: field("seed").parse().expect("seed"),
        iterations: field("iterations").parse().expect("iterations"),
        message: field("message"),
        schedule,
    }
}

/// Replays the schedule of a saved failure of `test`; returns the panic message it reproduced, or
/// `None` if the schedule ran to completion.
pub fn replay_failure<F>(saved: &SavedFailure, f: F) -> Option<String>
where
    F: Fn() + Send + Sync + 'static,
{
    let schedule = saved.schedule.clone();
    let result = catch_unwind(AssertUnwindSafe(|| replay(&schedule, f)));
    result.err().map(|p| panic_message(&*p))
}

/// Re-runs the seeded exploration a saved failure came from (same test, scheduler, seed and
/// budget); returns the failure message, or `None` if it now passes. Unlike an encoded schedule,
/// which goes stale as soon as the code's schedule points change, a seed stays meaningful: it is
/// how committed regressions are kept.
pub fn rerun_seed<F>(saved: &SavedFailure, f: F) -> Option<String>
where
    F: Fn() + Send + Sync + 'static,
{
    let result = catch_unwind(AssertUnwindSafe(|| {
        explore(
            &saved.test,
            "regression rerun",
            saved.sched,
            saved.seed,
            saved.iterations,
            f,
        )
    }));
    result.err().map(|p| panic_message(&*p))
}

/// Runs `f` with the fixed regression seeds, a fresh seed (unless `WFIC_SHUTTLE_FRESH=0`), or, when
/// `WFIC_SHUTTLE_REPLAY` names a failure of this test, only that schedule.
pub fn explore_all<F>(
    test: &str,
    params: &str,
    sched: Sched,
    fixed: &[u64],
    iterations: usize,
    f: F,
) where
    F: Fn() + Send + Sync + Clone + 'static,
{
    let _gate = shared();
    if let Ok(path) = std::env::var("WFIC_SHUTTLE_REPLAY") {
        let saved = load_failure(Path::new(&path));
        if saved.test == test {
            eprintln!("shuttle {test}: replaying {path}");
            replay(&saved.schedule, f);
        }
        return;
    }
    for &seed in fixed {
        explore(test, params, sched, seed, iterations, f.clone());
    }
    if std::env::var("WFIC_SHUTTLE_FRESH").as_deref() != Ok("0") {
        explore(test, params, sched, fresh_seed(), iterations, f);
    }
}
