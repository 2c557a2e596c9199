//! Every numeric option of the command line and the range it takes: the one table the options'
//! parsers, their `--help` and `docs/command-line.md` are made from. The renderer's settings,
//! thread and frame counts and the MPI batches are bounded in [`wfic_render::limits`], where the
//! library checks them too; the experiments' own counts are bounded here.
//!
//! A value outside its range is refused while the command line is parsed, before any work:
//! clap's usage error, exit 2, naming the option, the value and the range. The resources a value
//! inside its range may still lack (threads the operating system will start, memory for the
//! frame) are checked by [`check_resources`] before the run starts.

use clap::Command;
use glam::Vec3;
use std::fmt::Display;
use std::str::FromStr;
use wfic_render::limits::{self, Limit};

/// A range, with the type of the option it bounds.
#[derive(Clone, Copy, Debug)]
pub enum Bound {
    /// A `u32` option.
    U32(Limit<u32>),
    /// A `u64` option.
    U64(Limit<u64>),
    /// A `usize` option.
    Usize(Limit<usize>),
    /// An `f32` option.
    F32(Limit<f32>),
    /// A point `x,y,z`, each coordinate in the range.
    Point(Limit<f32>),
}

impl Bound {
    /// The range in interval notation (for a point: each coordinate's).
    pub fn range(&self) -> String {
        match self {
            Self::U32(l) => l.range(),
            Self::U64(l) => l.range(),
            Self::Usize(l) => l.range(),
            Self::F32(l) | Self::Point(l) => l.range(),
        }
    }

    /// `arg` parsing into its type through this range, its help ending with the range.
    fn attach(self, arg: clap::Arg) -> clap::Arg {
        let note = match self {
            Self::Point(_) => format!("(each coordinate in {})", self.range()),
            _ => format!("(in {})", self.range()),
        };
        let help = arg
            .get_help()
            .map_or_else(|| note.clone(), |h| format!("{h} {note}"));
        let long = arg.get_long_help().map(|h| format!("{h}\n\n{note}"));
        let arg = match long {
            Some(long) => arg.help(help).long_help(long),
            None => arg.help(help),
        };
        match self {
            Self::U32(l) => arg.value_parser(move |s: &str| parse_in(s, l)),
            Self::U64(l) => arg.value_parser(move |s: &str| parse_in(s, l)),
            Self::Usize(l) => arg.value_parser(move |s: &str| parse_in(s, l)),
            Self::F32(l) => arg.value_parser(move |s: &str| parse_in(s, l)),
            Self::Point(l) => arg.value_parser(move |s: &str| parse_point(s, l)),
        }
    }
}

/// `s` as a `T` inside `limit`, or clap's message after "invalid value 'S' for '--OPTION'".
fn parse_in<T>(s: &str, limit: Limit<T>) -> Result<T, String>
where
    T: FromStr + Copy + PartialOrd + Display,
    T::Err: Display,
{
    let value = s
        .trim()
        .parse::<T>()
        .map_err(|e| format!("not a number in {} ({e})", limit.range()))?;
    limit
        .check(value)
        .map_err(|e| format!("{} is not in {}", s.trim(), e.range))
}

/// `x,y,z` with every coordinate inside `limit`.
pub fn parse_point(s: &str, limit: Limit<f32>) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').collect();
    let [x, y, z] = parts[..] else {
        return Err(format!(
            "expected three numbers `x,y,z`, each in {}, got `{s}`",
            limit.range()
        ));
    };
    let c = |p: &str| parse_in(p, limit);
    Ok(Vec3::new(c(x)?, c(y)?, c(z)?))
}

/// Runs an experiment repeats a setting.
pub const RUNS: Limit<usize> = Limit::closed("runs", "--runs", 1, 1000);
/// Paired runs of Table 1's compared columns.
pub const PAIRED_RUNS: Limit<usize> = Limit::closed("paired_runs", "--paired-runs", 1, 1000);
/// Passes of `reproduce dynamic`'s removal mode.
pub const PASSES: Limit<usize> = Limit::closed("passes", "--passes", 1, 100);
/// Removal tolerances, in multiples of the accuracy.
pub const TOLERANCE: Limit<f32> = Limit::open_min("tolerance", "--sweep", 0.0, 64.0);
/// Frames of `reproduce dynamic`'s slide: removal needs a frame after the first.
pub const SLIDE_FRAMES: Limit<usize> = Limit::closed("frames", "--frames", 2, 100_000);
/// Frames of `reproduce distributed`'s orbit (0 or 1: no orbit).
pub const ORBIT_FRAMES: Limit<usize> = Limit::closed("frames", "--frames", 0, 100_000);
/// Pixel stride of a brute-force reference grid.
pub const STRIDE: Limit<u32> = Limit::closed("stride", "--stride", 1, 64);
/// Ranks of an `mpirun` job the experiments start (on one machine).
pub const RANKS: Limit<usize> = Limit::closed("ranks", "--ranks", 1, 64);
/// The rank `render --fail-rank` makes fail (a hidden option of the failure tests).
pub const FAIL_RANK: Limit<u32> = Limit::closed("fail_rank", "--fail-rank", 0, 4095);
/// Hemisphere rays per record in `compare radiance`: Radiance samples at least 16 (`-ad`).
pub const RADIANCE_RAYS: Limit<u32> =
    Limit::closed("rays_per_record", "--rays-per-record", 16, 65_536);
/// Radiance's ambient resolution `-ar`.
pub const RESOLUTION: Limit<u32> = Limit::closed("resolution", "--resolution", 1, 65_536);
/// Renders of each setting `compare radiance` measures.
pub const REPEATS: Limit<u32> = Limit::closed("repeats", "--repeats", 1, 100);
/// Shading points of a `demo` frame.
pub const POINTS: Limit<u64> = Limit::closed("points", "--points", 1, 1_000_000_000);
/// Busy-work iterations standing in for a `demo` record's hemisphere.
pub const WORK: Limit<u32> = Limit::closed("work", "--work", 0, 1_000_000);

/// The sampling and size options every experiment shares, under `path`.
macro_rules! sampled {
    ($path:expr) => {
        [
            ($path, "width", Bound::U32(limits::WIDTH)),
            ($path, "height", Bound::U32(limits::HEIGHT)),
            (
                $path,
                "rays_per_record",
                Bound::U32(limits::RAYS_PER_RECORD),
            ),
            ($path, "spp", Bound::U32(limits::PIXEL_SAMPLES)),
            ($path, "light_samples", Bound::U32(limits::LIGHT_SAMPLES)),
        ]
    };
}

/// Every numeric option: the subcommand's path, the argument's id (its field's name), its
/// range.
pub fn table() -> Vec<(&'static [&'static str], &'static str, Bound)> {
    use Bound::{Point, Usize, F32, U32, U64};
    const RENDER: &[&str] = &["render"];
    const DEMO: &[&str] = &["demo"];
    const TABLE1: &[&str] = &["reproduce", "table1"];
    const ANIMATION: &[&str] = &["reproduce", "animation"];
    const DYNAMIC: &[&str] = &["reproduce", "dynamic"];
    const DISTRIBUTED: &[&str] = &["reproduce", "distributed"];
    const DETERMINISTIC: &[&str] = &["reproduce", "deterministic"];
    const RADIANCE: &[&str] = &["compare", "radiance"];
    let mut t = vec![
        (RENDER, "threads", Usize(limits::THREADS)),
        (RENDER, "accuracy", F32(limits::ACCURACY)),
        (RENDER, "smoothing", F32(limits::SMOOTHING)),
        (RENDER, "seed", U64(limits::SEED)),
        (RENDER, "eye", Point(limits::COORDINATE)),
        (RENDER, "target", Point(limits::COORDINATE)),
        (RENDER, "orbit", F32(limits::ORBIT)),
        (RENDER, "batch_records", Usize(limits::BATCH_RECORDS)),
        (RENDER, "batch_ms", U64(limits::BATCH_MS)),
        (RENDER, "frames", Usize(limits::FRAMES)),
        (RENDER, "fail_rank", U32(FAIL_RANK)),
        (DEMO, "threads", Usize(limits::THREADS)),
        (DEMO, "points", U64(POINTS)),
        (DEMO, "frames", Usize(limits::FRAMES)),
        (DEMO, "accuracy", F32(limits::ACCURACY)),
        (DEMO, "work", U32(WORK)),
        (TABLE1, "threads", Usize(limits::THREADS)),
        (TABLE1, "runs", Usize(RUNS)),
        (TABLE1, "paired_runs", Usize(PAIRED_RUNS)),
        (ANIMATION, "frames", Usize(limits::FRAMES)),
        (ANIMATION, "threads", Usize(limits::THREADS)),
        (DYNAMIC, "frames", Usize(SLIDE_FRAMES)),
        (DYNAMIC, "threads", Usize(limits::THREADS)),
        (DYNAMIC, "passes", Usize(PASSES)),
        (DYNAMIC, "sweep", F32(TOLERANCE)),
        (DISTRIBUTED, "width", U32(limits::WIDTH)),
        (DISTRIBUTED, "height", U32(limits::HEIGHT)),
        (DISTRIBUTED, "rays_per_record", U32(limits::RAYS_PER_RECORD)),
        (DISTRIBUTED, "accuracy", F32(limits::ACCURACY)),
        (DISTRIBUTED, "light_samples", U32(limits::LIGHT_SAMPLES)),
        (DISTRIBUTED, "runs", Usize(RUNS)),
        (DISTRIBUTED, "batches", Usize(limits::BATCH_RECORDS)),
        (DISTRIBUTED, "batch_records", Usize(limits::BATCH_RECORDS)),
        (DISTRIBUTED, "batch_ms", U64(limits::BATCH_MS)),
        (DISTRIBUTED, "frames", Usize(ORBIT_FRAMES)),
        (DETERMINISTIC, "threads", Usize(limits::THREADS)),
        (DETERMINISTIC, "runs", Usize(RUNS)),
        (DETERMINISTIC, "stride", U32(STRIDE)),
        (DETERMINISTIC, "ranks", Usize(RANKS)),
        (RADIANCE, "width", U32(limits::WIDTH)),
        (RADIANCE, "height", U32(limits::HEIGHT)),
        (RADIANCE, "rays_per_record", U32(RADIANCE_RAYS)),
        (RADIANCE, "accuracy", F32(limits::ACCURACY)),
        (RADIANCE, "resolution", U32(RESOLUTION)),
        (RADIANCE, "repeats", U32(REPEATS)),
    ];
    t.extend(sampled!(RENDER));
    for path in [TABLE1, ANIMATION, DYNAMIC, DETERMINISTIC] {
        t.extend(sampled!(path));
    }
    t
}

/// `command` with every bounded option parsing through its range and printing it in its help.
///
/// # Panics
/// If the table names an option the command does not have (a test runs this on the real
/// command line).
pub fn apply(mut command: Command) -> Command {
    for (path, id, bound) in table() {
        command = apply_at(command, path, id, bound);
    }
    command
}

fn apply_at(command: Command, path: &[&str], id: &'static str, bound: Bound) -> Command {
    match path {
        [] => command.mut_arg(id, |a| bound.attach(a)),
        [first, rest @ ..] => command.mut_subcommand(*first, |c| apply_at(c, rest, id, bound)),
    }
}

/// The table as Markdown, for `docs/command-line.md`: one row an option.
pub fn markdown() -> String {
    let mut rows = vec![
        "| command | option | range |".to_owned(),
        "|---|---|---|".to_owned(),
    ];
    let mut table = table();
    table.sort_by_key(|(path, id, _)| (*path, *id));
    for (path, id, bound) in table {
        let note = match bound {
            Bound::Point(_) => format!("each coordinate in `{}`", bound.range()),
            _ => format!("`{}`", bound.range()),
        };
        rows.push(format!(
            "| `wfic {}` | `--{}` | {note} |",
            path.join(" "),
            id.replace('_', "-"),
        ));
    }
    rows.join("\n") + "\n"
}

/// Refuses, before any work, a run the machine cannot hold: `threads` threads at once (each is
/// started, then all are released), or a `width x height` frame larger than the memory the
/// system reports free ([`limits::frame_bytes`]; where it reports none, that check is skipped).
///
/// # Errors
/// A message naming the option and what is short.
pub fn check_resources(threads: usize, size: Option<(u32, u32)>) -> Result<(), String> {
    start_threads(threads).map_err(|(i, e)| {
        format!(
            "--threads {threads}: the system started only {i} threads ({e}); give fewer threads"
        )
    })?;
    match size {
        Some(size) => check_memory(size, available_memory()),
        None => Ok(()),
    }
}

/// Refuses a `width x height` frame larger than `free` bytes ([`limits::frame_bytes`]); `None`:
/// the system reports no free memory, and nothing is refused.
///
/// # Errors
/// A message naming the size, what it needs and what is free.
pub fn check_memory((w, h): (u32, u32), free: Option<u64>) -> Result<(), String> {
    let need = limits::frame_bytes(w, h);
    match free {
        Some(free) if need > free => Err(format!(
            "--width {w} --height {h}: the frame needs about {:.1} GiB, and the system has \
             {:.1} GiB free; give a smaller image",
            need as f64 / GIB,
            free as f64 / GIB
        )),
        _ => Ok(()),
    }
}

const GIB: f64 = (1u64 << 30) as f64;

/// Starts `n` threads that wait until all have started (or one could not), then lets them
/// finish: `Err((started, error))` when the system refused thread `started`.
fn start_threads(n: usize) -> Result<(), (usize, std::io::Error)> {
    use std::sync::{Condvar, Mutex};
    let go = (Mutex::new(false), Condvar::new());
    std::thread::scope(|s| {
        let mut result = Ok(());
        for i in 0..n {
            let spawned = std::thread::Builder::new().spawn_scoped(s, || {
                let (lock, cv) = &go;
                let mut released = lock.lock().unwrap_or_else(|e| e.into_inner());
                while !*released {
                    released = cv.wait(released).unwrap_or_else(|e| e.into_inner());
                }
            });
            if let Err(e) = spawned {
                result = Err((i, e));
                break;
            }
        }
        let (lock, cv) = &go;
        *lock.lock().unwrap_or_else(|e| e.into_inner()) = true;
        cv.notify_all();
        result
    })
}

/// `MemAvailable` from `/proc/meminfo`, in bytes (`None` where there is no such file).
fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_larger_than_the_free_memory_is_refused_by_its_size() {
        let gib = 1u64 << 30;
        let e = check_memory((8192, 8192), Some(gib)).unwrap_err();
        assert!(
            e.contains("--width 8192 --height 8192") && e.contains("3.0 GiB"),
            "{e}"
        );
        assert_eq!(check_memory((4096, 4096), Some(gib)), Ok(()));
        assert_eq!(check_memory((8192, 8192), None), Ok(()));
    }

    #[test]
    fn a_few_threads_start() {
        assert_eq!(check_resources(8, None), Ok(()));
    }
}
