//! The paper's experiments and the `wfic` command line: each experiment ([`table1`],
//! [`animation`], [`dynamic`], [`distributed`], [`radiance`], [`deterministic`]) is a schedule,
//! an analysis and a report on one [`harness`]; [`plot`] draws, [`paper`] holds the paper's Table 1. What each
//! runs and how to read it: `docs/experiments.md`.

#![cfg(not(checker))]

pub mod animation;
pub mod bounds;
pub mod cli;
pub mod deterministic;
pub mod direct;
pub mod distributed;
pub mod dynamic;
pub mod harness;
pub mod paper;
pub mod plot;
pub mod radiance;
pub mod render_cli;
pub mod reproduce_cli;
pub mod scaling;
pub mod table1;

pub use harness::{median, Machine};
