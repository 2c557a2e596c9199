//! The paper's experiments and the `wfic` command line (`docs/experiments.md` describes each
//! experiment and how to run it).
//!
//! Every experiment is a schedule, an analysis and a report built on one harness
//! ([`harness`]): its statistics, its table type writing Markdown and CSV from one
//! specification, the provenance header every generated file carries (command, commit,
//! compiler, date, machine, and which thread and rank counts are oversubscribed: on a 2-core
//! machine, 4 threads measure time-slicing, not scaling), timing and progress, image metrics,
//! and the machine control a speed-up is set against. Plots are drawn by [`plot`].
//!
//! The experiments:
//!
//! * [`table1`]: Table 1 and Figure 1, every scene with an empty cache, TRA on one thread and
//!   each parallel scheme at each thread count, in interleaved rounds, with the machine control;
//! * [`animation`]: Figures 2 and 3, the camera orbit reusing the cache across frames;
//! * [`dynamic`]: a scene that moves, and what removing records buys against a fresh or a stale
//!   cache;
//! * [`distributed`]: one frame over MPI ranks exchanging records, against one process, ranks
//!   that share nothing, and Radiance's shared ambient file;
//! * [`radiance`]: wfic beside Radiance's own irradiance cache at matched settings, and the
//!   time ratio at equal error.
//!
//! [`paper`] holds the paper's Table 1; [`cli`], [`reproduce_cli`] and [`render_cli`] are the
//! command line.

#![cfg(not(checker))]

pub mod animation;
pub mod cli;
pub mod distributed;
pub mod dynamic;
pub mod harness;
pub mod paper;
pub mod plot;
pub mod radiance;
pub mod render_cli;
pub mod reproduce_cli;
pub mod table1;

pub use harness::{median, Machine};
