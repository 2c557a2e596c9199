//! # wfic — sharing an irradiance cache between rendering threads
//!
//! An implementation and verification study of Dubla, Debattista, Santos and Chalmers,
//! *Wait-Free Shared-Memory Irradiance Cache* (EGPGV 2009): the sequential cache (TRA), a lock (LCK),
//! per-thread local writes merged at frame end (LW) and the wait-free octree (WF), behind one trait.
//!
//! Layers, each using only the ones above it:
//!
//! 1. [`sync`] — the only module naming atomics, `UnsafeCell`, threads and locks (std, loom or
//!    shuttle); [`rng`] — the crate's one random-number generator (SplitMix64).
//! 2. [`ic`] — irradiance-cache mathematics: records, Ward's weight, validity, interpolation.
//! 3. [`cache`] — the four schemes and the no-cache reference behind
//!    [`cache::IrradianceCache`], the frame protocol ([`cache::Frame`]) and the scheme list
//!    ([`cache::Scheme`]).
//! 4. [`lincheck`] — concurrent histories and their checkers: linearizability against a
//!    sequential specification, and set consistency.
//! 5. `render` — a compact renderer that drives the caches end to end (feature `renderer`, on
//!    by default; not built under the model checkers); [`workload`] — a synthetic renderer-like workload for the demo and the
//!    benchmarks.
//! 6. `experiment` — the paper's experiments (Table 1, Figures 1–3) as code: Markdown, CSV, PNG
//!    and SVG plots (feature `renderer`; not built under the model checkers).
//! 7. `main.rs` — the `wfic` command line.
//!
//! The paper mapped to the code, and every deviation from it, is in `paper-notes.md`.
#![warn(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]

pub mod cache;
pub mod ic;
pub mod lincheck;
pub mod rng;
pub mod sync;
pub mod workload;

/// The README's example, compiled and run as a doctest.
#[doc = include_str!("../README.md")]
#[cfg(all(doctest, not(checker)))]
pub struct ReadmeDoctests;
