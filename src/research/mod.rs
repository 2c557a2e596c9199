//! Research internals: what only the ordering study, the model checkers, the checker's own tests
//! and the benchmarks need. A renderer that uses the caches needs none of it, and nothing here is
//! part of the stable API: it changes when the study does.
//!
//! * [`lincheck`] — concurrent histories and their checkers: linearizability against a
//!   sequential specification (Wing & Gong, in Lowe's form), and the weaker set consistency that
//!   the wait-free cache is shown to satisfy.
//! * [`BruteForce`] — the oracle: every record in one list, every query a scan.
//! * [`Geometry`], [`Octant`], [`MAX_DEPTH`] — the loose octree's geometry that every scheme
//!   places records and prunes queries with, so tests can work out a tree's shape from its
//!   records without the caches' traversals.
//! * [`orderings`] — the memory-ordering policies beyond the minimal sound one (`SeqCst`
//!   everywhere, a fence on the read path, the minimal orderings with control dependencies
//!   spelled out) and, under loom only, the unsound weakenings the models expect to fail.
//! * [`workload`] — a synthetic renderer-like workload for the benchmarks and `wfic demo`.

pub mod lincheck;
mod oracle;
pub mod workload;

pub use crate::cache::octree::{Geometry, Octant, MAX_DEPTH};
pub use oracle::BruteForce;

/// Memory-ordering policies of the wait-free cache beyond [`crate::cache::wf::Minimal`], and the
/// atomic sites they assign orderings to. The unsound policies exist only under the `loom`
/// feature, so that no safe API outside a model can reach them.
pub mod orderings {
    #[cfg(feature = "loom")]
    pub use crate::cache::wf::orderings::{BlindRemove, PaperLiteral, Unhelped, Weakened};
    pub use crate::cache::wf::orderings::{MinimalControl, ReadFence, SeqCstEverywhere, Site};
}
