//! The experiment harness every experiment is built on: an experiment is a schedule (what to
//! render or run, in which order), an analysis (statistics and checks on what was measured)
//! and a report (Markdown, CSV and plots), and everything below those three lives here.
//!
//! * [`stats`]: the one median, means, ranges and spreads, the paired-ratio interval timing
//!   checks are judged on, a least-squares line;
//! * [`table`]: one table specification writing both Markdown and CSV;
//! * [`provenance`]: the machine, and the header (command, commit, compiler, date, machine,
//!   oversubscribed counts) on every generated file;
//! * [`measure`]: repeating a setting, timing a render or an external command, progress;
//! * [`metrics`]: image error against a reference over masked pixels;
//! * [`control`]: the machine control a speed-up is set against;
//! * [`check`]: checks and their verdicts.

pub mod check;
pub mod control;
pub mod measure;
pub mod metrics;
pub mod provenance;
pub mod stats;
pub mod table;

pub use check::{Check, Verdict};
pub use provenance::{write_file, Machine, Output, Provenance};
pub use stats::median;

/// Threads `scheme` runs on when the parallel schemes run on `threads`: TRA always on one.
pub fn threads_of(scheme: wfic::cache::Scheme, threads: usize) -> usize {
    if scheme == wfic::cache::Scheme::Tra {
        1
    } else {
        threads
    }
}
