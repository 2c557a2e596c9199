//! The shape a cache's octree must have, worked out from its stored records alone, and how much of
//! it a lookup at a point may touch. Shared by the loom and shuttle models; it uses only the public
//! geometry (`Cell::octant`, `Cell::child`, `Geometry::placement_depth`, `Geometry::loose_contains`),
//! never a cache's own traversal.
//!
//! The claim it rests on, for every scheme, while nothing has been removed, and again once the
//! frames that removed have closed (their reclamation prunes every node left off the surviving
//! records' paths; the shuttle removal workload checks exactly that): **a node exists iff it lies
//! on the root-to-placement path of some stored record.** Between a removal and its frame's close
//! a node can outlive its records. For inserts:
//! - TRA, LCK, and LW's local and global octrees (`Octree::insert_admitted`) create exactly the
//!   missing nodes on the path of the record they then store; LW's merge re-inserts every local
//!   record into the global octree through the same function.
//! - WF `Adopt`: a published subtree is the private chain `build_path` made for the inserting
//!   record, which sits at its bottom, so it is stored; a chain that lost its compare-and-swap is
//!   freed, never linked, and the walk goes on into the winner's child (grafting, at most, the
//!   rest of its own path below it, with its record at the bottom).
//! - WF `Discard`: the loser's chain and record are freed together; nothing of its path is linked
//!   but what other records' inserts linked.
//!
//! The models check the claim itself too: `CacheStats::nodes` equals [`TreeShape::nodes`].
//!
//! A lookup at `p` visits the root and, below it, each node whose loose cell holds `p` and whose
//! parent it visited. Loose cells nest, so that is every node whose loose cell holds `p`; counting
//! the nodes whose every ancestor also holds `p` says the same without relying on it. Without
//! removal the tree only grows, so a lookup made while inserts ran visits at most [`TreeShape::reach`] of the final
//! records' shape, and examines at most the records stored in those nodes; a lookup made when
//! nothing runs visits and examines exactly that.
#![allow(dead_code)]

use glam::Vec3;
use std::collections::HashMap;
use wfic::cache::Cell;
use wfic::cache::{CacheConfig, CacheHandle};
use wfic::ic::{self, Record, Selection};

/// Nodes visited and records examined by one lookup (or allowed for one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Work {
    /// Nodes visited.
    pub nodes: u64,
    /// Records read from those nodes' lists, valid or not.
    pub records: u64,
}

impl std::ops::Add for Work {
    type Output = Work;
    fn add(self, o: Work) -> Work {
        Work {
            nodes: self.nodes + o.nodes,
            records: self.records + o.records,
        }
    }
}

/// The nodes an octree holding a set of records must have.
#[derive(Clone, Debug)]
pub struct TreeShape {
    config: CacheConfig,
    /// Every node, by its path of octant indices from the root (the root is the empty path): its
    /// cell and the number of records placed in it.
    nodes: HashMap<Vec<usize>, (Cell, u64)>,
}

impl TreeShape {
    /// The shape of a tree holding exactly `records` (the root always exists).
    pub fn of<'a>(config: &CacheConfig, records: impl IntoIterator<Item = &'a Record>) -> Self {
        let geometry = config.geometry();
        let mut nodes = HashMap::new();
        nodes.insert(Vec::new(), (geometry.root, 0));
        for r in records {
            let depth = geometry.placement_depth(ic::influence_radius(r, config.accuracy()));
            let mut path = Vec::new();
            let mut cell = geometry.root;
            for _ in 0..depth {
                let octant = cell.octant(r.position);
                cell = cell.child(octant);
                path.push(octant.index());
                nodes.entry(path.clone()).or_insert((cell, 0));
            }
            nodes.get_mut(&path).expect("just made").1 += 1;
        }
        Self {
            config: *config,
            nodes,
        }
    }

    /// How many nodes the tree has, the root included.
    pub fn nodes(&self) -> usize {
        self.nodes.len()
    }

    /// The number of records placed in each node (in no particular order): the lengths of the
    /// tree's lists.
    pub fn list_lengths(&self) -> impl Iterator<Item = u64> + '_ {
        self.nodes.values().map(|&(_, records)| records)
    }

    /// The depth of the deepest node.
    pub fn depth(&self) -> usize {
        self.nodes.keys().map(Vec::len).max().unwrap_or(0)
    }

    /// What a lookup at `p` visits: the root, and every node whose loose cell, and every
    /// ancestor's below the root, holds `p`; and the records those nodes hold.
    pub fn reach(&self, p: Vec3) -> Work {
        let geometry = self.config.geometry();
        let mut work = Work::default();
        for (path, (_, records)) in &self.nodes {
            let reached = (1..=path.len()).all(|len| {
                let (cell, _) = &self.nodes[&path[..len]];
                geometry.loose_contains(cell, p)
            });
            if reached {
                work.nodes += 1;
                work.records += records;
            }
        }
        work
    }
}

impl TreeShape {
    /// What a removal of `selection` visits: the root, and every node whose loose cell, and every
    /// ancestor's below the root, the selection may reach (`Selection::may_select_within`); and
    /// the slots those nodes hold. Removed records keep their slots and their nodes until the
    /// frame closes, so for a removal made before that, `of` is given every record inserted.
    pub fn removal_reach(&self, selection: &Selection) -> Work {
        let geometry = self.config.geometry();
        let mut work = Work::default();
        for (path, (_, records)) in &self.nodes {
            let reached = (1..=path.len()).all(|len| {
                let (lo, hi) = geometry.loose_bounds(&self.nodes[&path[..len]].0);
                selection.may_select_within(lo, hi)
            });
            if reached {
                work.nodes += 1;
                work.records += records;
            }
        }
        work
    }
}

/// Checks one removal that did `did` against the shape's `allowed`: within it while inserts
/// could still grow the tree (`quiescent` false), equal to it when nothing ran beside it. A
/// removal that rescans a list another thread grew examines more slots than the list ends with;
/// one that does not prune visits nodes its selection cannot reach.
pub fn check_removal(what: &str, did: Work, allowed: Work, quiescent: bool) {
    if quiescent {
        assert_eq!(
            did, allowed,
            "{what}: a quiescent removal did {did:?}, the inserted records' tree gives {allowed:?}"
        );
    } else {
        assert!(
            did.nodes <= allowed.nodes && did.records <= allowed.records,
            "{what}: a removal did {did:?}, more than the final tree allows ({allowed:?})"
        );
    }
}

/// `remove` of `selection` through `h`; returns what it took and the work the handle counted for
/// it (the difference of its summed counters across the call).
pub fn counted_removal(h: &mut impl CacheHandle, selection: &Selection) -> (usize, Work) {
    let before = *h.stats();
    let removed = h.remove(selection);
    let after = *h.stats();
    assert_eq!(
        after.removed - before.removed,
        removed as u64,
        "the handle miscounted"
    );
    let did = Work {
        nodes: after.removal_nodes - before.removal_nodes,
        records: after.removal_records - before.removal_records,
    };
    (removed, did)
}

/// Checks one lookup at `p` that did `did` against the shape `allowed`: within it while the tree
/// could still grow (`quiescent` false), equal to it when nothing ran (`quiescent` true).
pub fn check_lookup(what: &str, p: Vec3, did: Work, allowed: Work, quiescent: bool) {
    if quiescent {
        assert_eq!(
            did, allowed,
            "{what}: a quiescent lookup at {p} did {did:?}, the stored records' tree gives {allowed:?}"
        );
    } else {
        assert!(
            did.nodes <= allowed.nodes && did.records <= allowed.records,
            "{what}: a lookup at {p} did {did:?}, more than the final tree allows ({allowed:?})"
        );
    }
}

/// `valid_records` at `p` with normal `normal` through `h`, into `out`; returns the work the handle
/// counted for it (the difference of its summed counters across the call). Checks that the call
/// was not counted as a lookup and that the handle's maxima cover it.
pub fn counted_lookup(
    h: &mut impl CacheHandle,
    p: Vec3,
    normal: Vec3,
    out: &mut Vec<Record>,
) -> Work {
    let before = *h.stats();
    h.valid_records(p, normal, out);
    let after = *h.stats();
    assert_eq!(
        (after.lookups, after.hits),
        (before.lookups, before.hits),
        "valid_records counted as a lookup"
    );
    let did = Work {
        nodes: after.lookup_nodes - before.lookup_nodes,
        records: after.lookup_records - before.lookup_records,
    };
    assert!(
        u64::from(after.max_lookup_nodes) >= did.nodes
            && u64::from(after.max_lookup_records) >= did.records,
        "the handle's maxima miss a traversal of {did:?}"
    );
    did
}
