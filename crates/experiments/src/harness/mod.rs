//! What every experiment (a schedule, an analysis and a report) is built on: statistics, tables,
//! provenance, measurement, image metrics, the machine control and checks. See
//! `docs/experiments.md#how-results-are-measured-and-labelled`.

pub mod check;
pub mod control;
pub mod measure;
pub mod metrics;
pub mod provenance;
pub mod stats;
pub mod table;

pub use check::{Check, Verdict};
pub use provenance::{Machine, Output, Provenance};
pub use stats::median;

/// Threads `scheme` runs on when the parallel schemes run on `threads`: TRA always on one.
pub fn threads_of(scheme: wfic::cache::Scheme, threads: usize) -> usize {
    if scheme == wfic::cache::Scheme::Tra {
        1
    } else {
        threads
    }
}
