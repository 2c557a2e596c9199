//! # wfic — sharing an irradiance cache between rendering threads
//!
//! The four schemes of Dubla, Debattista, Santos and Chalmers, *Wait-Free Shared-Memory
//! Irradiance Cache* (EGPGV 2009) behind one trait, [`cache::IrradianceCache`]: the sequential
//! cache (TRA, [`cache::Sequential`]), a lock (LCK, [`cache::Locked`]), per-thread local writes
//! merged at the frame's end (LW, [`cache::LocalWrite`]) and the wait-free octree (WF,
//! [`cache::WaitFree`]), with the no-cache reference ([`cache::NoCache`]).
//!
//! This crate is the core a renderer embeds. Modules, each using only the ones above it:
//!
//! 1. [`sync`] — the only module naming atomics, `UnsafeCell`, threads and locks (std, or loom's
//!    or shuttle's under the features of those names, so the models check the code that ships);
//!    [`rng`] — a small deterministic generator (SplitMix64).
//! 2. [`ic`] — irradiance-cache mathematics: records, Ward's weight and validity test, the
//!    clamped radius, gradients, weighted interpolation, removal selections.
//! 3. [`cache`] — the schemes, the frame protocol ([`cache::Frame`]: one handle per worker id,
//!    every handle's state back to the cache, the frame closed once) and the scheme list
//!    ([`cache::Scheme`]).
//! 4. [`research`] — what only the checkers, the ordering study and the benchmarks need: the
//!    linearizability and set-consistency checkers, the brute-force oracle, the octree geometry,
//!    the extra ordering policies and a synthetic workload. No stability promise.
//!
//! Features: `rayon` (`cache::Frame::run_on_pool`); `loom` and `shuttle` swap the [`sync`]
//! primitives for a model checker's (one at a time). The renderer (`wfic-render`) and the
//! experiments with the `wfic` command line (`wfic-experiments`) are the workspace's member
//! crates and use only this crate's public API. The design, the proofs and the paper mapped to
//! the code are in the repository's `docs/` and `paper-notes.md`.
#![warn(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]

pub mod cache;
pub mod ic;
pub mod research;
pub mod rng;
pub mod sync;

/// The README's example, compiled and run as a doctest.
#[doc = include_str!("../README.md")]
#[cfg(all(doctest, not(checker)))]
pub struct ReadmeDoctests;
