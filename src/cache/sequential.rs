//! TRA: the traditional sequential irradiance cache (paper §3, Listing 3), and the plain octree that
//! LCK and LW are built from.
//!
//! [`Octree`] is Listing 3's `IrradianceCache`: `insert` walks from the root, creating missing
//! children, to the node whose cell fits the record's influence radius and appends the record to
//! that node's list; a query visits every node whose loose cell holds the point (see
//! [`crate::research::Geometry`]). Nodes live in one arena (`Vec`), children are indices into it.
//!
//! [`Sequential`] is the TRA scheme: the octree owned by one worker at a time. Its handle holds the
//! octree's lock for the whole frame, so lookups and inserts pay nothing for it; a second worker
//! asking for a handle waits until the first one is finished. TRA is meant to run on one thread.

use super::deterministic::Visibility;
use super::frame::{collect_valid, HandleCore, Ledger, Local, Work};
use super::octree::{Cell, Octant};
use super::{
    CacheConfig, CacheHandle, CacheStats, FrameReport, Inserted, IrradianceCache, Scheme,
    WorkerStats,
};
use crate::ic::{InsertError, Interpolated, Key, Prefilter, Record, Selection, WorkerId};
use crate::sync::{unpoison, Mutex, MutexGuard};
use glam::Vec3;

/// Index of a node in the arena. The root is node 0, so 0 in a child slot means "no child".
type NodeIndex = u32;

/// A node: its children, and its records with their keys beside them (`keys[k]` is the key of
/// `records[k]`), so a walk reads a record only when its key passes the query's prefilter.
#[derive(Clone, Debug, Default)]
struct Node {
    children: [NodeIndex; 8],
    /// Bit `o` set when `children[o]` is a node.
    occupied: u8,
    keys: Vec<Key>,
    records: Vec<Record>,
}

/// A sequential loose octree of records.
#[derive(Clone, Debug)]
pub struct Octree {
    config: CacheConfig,
    nodes: Vec<Node>,
    len: usize,
}

impl Octree {
    /// An empty octree.
    pub fn new(config: CacheConfig) -> Self {
        Self {
            config,
            nodes: vec![Node::default()],
            len: 0,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &CacheConfig {
        &self.config
    }

    /// Records stored.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when no record is stored.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Nodes, the root included.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Every record, node by node.
    pub fn records(&self) -> impl Iterator<Item = &Record> {
        self.nodes.iter().flat_map(|n| n.records.iter())
    }

    /// Stores an admitted record (validated and sealed, inside the bounds); returns the number of
    /// levels walked.
    pub(crate) fn insert_admitted(&mut self, record: Record) -> u32 {
        let depth = self.config.depth_of(&record);
        let mut cell = self.config.root();
        let mut node = 0usize;
        for _ in 0..depth {
            let octant = cell.octant(record.position);
            cell = cell.child(octant);
            let child = self.nodes[node].children[octant.index()];
            node = if child != 0 {
                child as usize
            } else {
                let fresh = self.nodes.len();
                let index = NodeIndex::try_from(fresh).expect("octree exceeds 2^32 nodes");
                self.nodes.push(Node::default());
                self.nodes[node].children[octant.index()] = index;
                self.nodes[node].occupied |= octant.bit();
                fresh
            };
        }
        let node = &mut self.nodes[node];
        node.keys.push(Key::of(&record, self.config.accuracy()));
        node.records.push(record);
        self.len += 1;
        depth
    }

    /// Calls `f` with every record stored in a node that a query at `point` visits (a superset of
    /// the valid ones); returns the number of nodes visited.
    pub fn visit(&self, point: Vec3, f: &mut impl FnMut(&Record)) -> u32 {
        self.walk(point, |_| true, f).nodes
    }

    /// Calls `f` with every record stored in a node that a query visits and whose key `pre`
    /// admits (a superset of the valid ones, a subset of what [`Octree::visit`] shows, in the same
    /// order); returns the number of nodes visited. What a lookup reads, without its arithmetic.
    pub fn visit_admitted(&self, pre: &Prefilter, f: &mut impl FnMut(&Record)) -> u32 {
        self.walk(pre.point(), |k| pre.admits(k), f).nodes
    }

    /// Visits the nodes a query at `point` must visit, depth first, children in octant order, and
    /// calls `f` with each record there whose key `admit` passes, in list order; returns the nodes
    /// visited and the keys examined.
    #[inline]
    pub(crate) fn walk(
        &self,
        point: Vec3,
        admit: impl Fn(&Key) -> bool,
        f: &mut impl FnMut(&Record),
    ) -> Work {
        let mut work = Work::default();
        self.walk_node(0, self.config.root(), point, &admit, f, &mut work);
        work
    }

    fn walk_node(
        &self,
        index: usize,
        cell: Cell,
        point: Vec3,
        admit: &impl Fn(&Key) -> bool,
        f: &mut impl FnMut(&Record),
        work: &mut Work,
    ) {
        let node = &self.nodes[index];
        work.nodes += 1;
        work.records += node.keys.len() as u32;
        for (key, record) in node.keys.iter().zip(&node.records) {
            if admit(key) {
                f(record);
            }
        }
        if node.occupied != 0 {
            let mask = node.occupied & self.config.geometry().children_holding(&cell, point);
            for octant in Octant::in_mask(mask) {
                let child = node.children[octant.index()] as usize;
                self.walk_node(child, cell.child(octant), point, admit, f, work);
            }
        }
    }

    /// Removes every record `selection` takes out in frame `now` (frames closed so far); returns
    /// how many, and the nodes visited and records examined. Visits only the nodes whose loose
    /// cell the selection may reach (the root always: it keeps the records too large for any
    /// cell); keeps the order of the others.
    pub(crate) fn remove(&mut self, selection: &Selection, now: u64) -> (usize, Work) {
        let accuracy = self.config.accuracy();
        let geometry = *self.config.geometry();
        let mut removed = 0;
        let mut work = Work::default();
        let mut pending = vec![(0usize, self.config.root())];
        while let Some((index, cell)) = pending.pop() {
            if index != 0 {
                let (lo, hi) = geometry.loose_bounds(&cell);
                if !selection.may_select_within(lo, hi) {
                    continue;
                }
            }
            let node = &mut self.nodes[index];
            let before = node.records.len();
            work += Work {
                nodes: 1,
                records: before as u32,
            };
            let mut kept = 0;
            for i in 0..before {
                if !selection.selects(&node.records[i], accuracy, now) {
                    node.records[kept] = node.records[i];
                    node.keys[kept] = node.keys[i];
                    kept += 1;
                }
            }
            node.records.truncate(kept);
            node.keys.truncate(kept);
            removed += before - kept;
            for octant in Octant::in_mask(node.occupied) {
                pending.push((node.children[octant.index()] as usize, cell.child(octant)));
            }
        }
        self.len -= removed;
        (removed, work)
    }

    /// Frees the nodes that removals left with no record below them, and renumbers the rest in
    /// breadth-first order: afterwards the octree has exactly the nodes its records' paths need,
    /// as if built afresh from them. `O(nodes)`: the schemes call it when a frame with removals
    /// closes, not at every removal.
    pub fn prune(&mut self) {
        /// Unlinks the empty subtrees below node `i`; true when `i`'s own subtree is empty.
        fn unlink_empty(nodes: &mut [Node], i: usize) -> bool {
            let mut empty = nodes[i].records.is_empty();
            for octant in Octant::in_mask(nodes[i].occupied) {
                let child = nodes[i].children[octant.index()] as usize;
                if unlink_empty(nodes, child) {
                    nodes[i].children[octant.index()] = 0;
                    nodes[i].occupied &= !octant.bit();
                } else {
                    empty = false;
                }
            }
            empty
        }
        unlink_empty(&mut self.nodes, 0);
        let mut old: Vec<Option<Node>> = std::mem::take(&mut self.nodes)
            .into_iter()
            .map(Some)
            .collect();
        let mut nodes = vec![old[0].take().expect("the root")];
        let mut next = 0;
        while next < nodes.len() {
            for octant in Octant::in_mask(nodes[next].occupied) {
                let child = nodes[next].children[octant.index()] as usize;
                let index = NodeIndex::try_from(nodes.len()).expect("fewer nodes than before");
                nodes.push(old[child].take().expect("each node has one parent"));
                nodes[next].children[octant.index()] = index;
            }
            next += 1;
        }
        self.nodes = nodes;
    }

    /// Moves the records out, leaving an octree with no nodes that must only be dropped (what a
    /// dropped LW handle does with its local octree).
    fn take_all(&mut self) -> Self {
        Self {
            config: self.config,
            nodes: std::mem::take(&mut self.nodes),
            len: std::mem::take(&mut self.len),
        }
    }

    /// Validates and stores a record without a handle (for single-threaded use: oracles, merges,
    /// tests). The record keeps the id and check field it has.
    pub fn insert(&mut self, record: Record) -> Result<(), InsertError> {
        self.config.check(&record)?;
        self.insert_admitted(record);
        Ok(())
    }
}

impl Local for Octree {
    fn take(&mut self) -> Self {
        self.take_all()
    }
}

/// TRA: the sequential cache (Listing 3). One worker at a time.
#[derive(Debug)]
pub struct Sequential {
    config: CacheConfig,
    tree: Mutex<Octree>,
    ledger: Ledger<()>,
    stats: CacheStats,
}

impl Sequential {
    /// An empty cache.
    pub fn new(config: CacheConfig) -> Self {
        Self {
            config,
            tree: Mutex::new(Octree::new(config)),
            ledger: Ledger::new(),
            stats: CacheStats::default(),
        }
    }

    fn tree_mut(&mut self) -> &mut Octree {
        unpoison(self.tree.get_mut())
    }
}

/// A TRA worker: holds the octree for the whole frame.
#[derive(Debug)]
#[must_use = "a handle does nothing unless it is used"]
pub struct SeqHandle<'c> {
    tree: MutexGuard<'c, Octree>,
    core: HandleCore<'c, ()>,
}

impl IrradianceCache for Sequential {
    type Handle<'c> = SeqHandle<'c>;

    fn scheme(&self) -> Scheme {
        Scheme::Tra
    }

    fn config(&self) -> &CacheConfig {
        &self.config
    }

    fn handle(&self, worker: WorkerId) -> SeqHandle<'_> {
        // Registered before the lock is taken, so a duplicate id panics instead of waiting for
        // the holder of the octree (its own thread, perhaps) forever.
        let core = HandleCore::new(&self.ledger, worker, ());
        SeqHandle {
            // A worker that panicked with the handle poisons the lock; the octree is whole at
            // every unwind point, so the next worker carries on with it.
            tree: unpoison(self.tree.lock()),
            core,
        }
    }

    fn end_frame(&mut self) -> FrameReport {
        let report = self.ledger.close_frame(&mut self.stats).1;
        if report.workers.removed > 0 {
            self.tree_mut().prune();
        }
        report
    }

    fn remove(&mut self, selection: &Selection) -> usize {
        let now = self.stats.frames;
        let tree = self.tree_mut();
        let (removed, work) = tree.remove(selection, now);
        if removed > 0 {
            tree.prune();
        }
        self.stats.totals.count_removal(removed, work)
    }

    fn snapshot(&mut self) -> Vec<Record> {
        self.tree_mut().records().copied().collect()
    }

    fn stats(&mut self) -> CacheStats {
        let (records, nodes) = {
            let tree = self.tree_mut();
            (tree.len(), tree.node_count())
        };
        CacheStats {
            records,
            nodes,
            ..self.stats
        }
    }
}

impl CacheHandle for SeqHandle<'_> {
    fn worker(&self) -> WorkerId {
        self.core.worker
    }

    fn frame(&self) -> u64 {
        self.core.frame
    }

    #[inline]
    fn lookup(&mut self, point: Vec3, normal: Vec3) -> Option<Interpolated> {
        let mut acc = self.core.begin_lookup(self.tree.config(), point, normal)?;
        let pre = *acc.prefilter();
        let work = self.tree.walk(point, |k| pre.admits(k), &mut |r| {
            acc.add(r);
        });
        self.core.end_lookup(&acc, work)
    }

    fn lookup_visible(
        &mut self,
        point: Vec3,
        normal: Vec3,
        visible: Visibility,
    ) -> Option<Interpolated> {
        let tree = &*self.tree;
        self.core
            .lookup_visible(tree.config(), point, normal, visible, |pre, _, f| {
                tree.walk(pre.point(), |k| pre.admits(k), &mut |r| f(r))
            })
    }

    fn insert(&mut self, record: Record) -> Result<Inserted, InsertError> {
        let record = self.core.admit(self.tree.config(), record)?;
        let steps = self.tree.insert_admitted(record);
        Ok(self.core.inserted(Inserted::Stored(record.id()), steps))
    }

    fn remove(&mut self, selection: &Selection) -> usize {
        let (removed, work) = self.tree.remove(selection, self.core.frame);
        self.core.stats.count_removal(removed, work)
    }

    fn valid_records(&mut self, point: Vec3, normal: Vec3, out: &mut Vec<Record>) {
        let tree = &*self.tree;
        let work = collect_valid(tree.config(), point, normal, out, |pre, f| {
            tree.walk(pre.point(), |k| pre.admits(k), &mut |r| f(r))
        });
        self.core.traversed(work);
    }

    fn stats(&self) -> &WorkerStats {
        &self.core.stats
    }
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;
    use crate::ic::RecordId;

    fn config() -> CacheConfig {
        // Root: centre (4, 4, 4), half 4.04; at a = 0.5 a record of radius 2 (influence 1) goes to
        // depth 2 (half 1.01).
        CacheConfig::new(Vec3::ZERO, Vec3::splat(8.0), 0.5).unwrap()
    }

    fn record(p: Vec3, seq: u64) -> Record {
        Record::new(p, Vec3::Z, Vec3::ONE, 2.0).sealed(RecordId::new(WorkerId::new(0), 0, seq))
    }

    /// The plain octree, counted by hand: nodes made only where a path is missing, shared where
    /// it exists; a query visits the root and the loose cells that hold it, and sees the records
    /// stored there.
    #[test]
    fn the_octree_makes_shares_and_visits_nodes() {
        let mut tree = Octree::new(config());
        assert!(tree.is_empty());
        assert_eq!((tree.len(), tree.node_count()), (0, 1));
        assert_eq!(config().depth_of(&record(Vec3::ONE, 0)), 2);

        // Depth 2: root -> child -> grandchild, two new nodes.
        assert_eq!(tree.insert_admitted(record(Vec3::splat(1.0), 0)), 2);
        assert!(!tree.is_empty());
        assert_eq!((tree.len(), tree.node_count()), (1, 3));
        // The same grandchild's cell: no new node.
        tree.insert(record(Vec3::splat(1.5), 1)).unwrap();
        assert_eq!((tree.len(), tree.node_count()), (2, 3));
        // The same child, another grandchild: one new node.
        tree.insert(record(Vec3::new(3.0, 1.0, 1.0), 2)).unwrap();
        assert_eq!((tree.len(), tree.node_count()), (3, 4));
        // Another child of the root: two new nodes.
        tree.insert(record(Vec3::splat(7.0), 3)).unwrap();
        assert_eq!((tree.len(), tree.node_count()), (4, 6));
        // Refused input changes nothing.
        assert!(tree.insert(record(Vec3::splat(9.0), 4)).is_err());
        assert_eq!((tree.len(), tree.node_count()), (4, 6));

        // A query at (1.2, 1.2, 1.2) lies in the loose cells of the root, of the (-,-,-) child
        // (centre 1.98 on each axis, half 2.02) and of both its grandchildren (centres (0.97,
        // 0.97, 0.97) and (2.99, 0.97, 0.97), half 1.01), not in that of the (+,+,+) child
        // (centre 6.02, 4.82 away on each axis, more than 4.04): 4 nodes, and the 3 records
        // stored in them.
        let mut seen = Vec::new();
        let nodes = tree.visit(Vec3::splat(1.2), &mut |r| seen.push(r.id().seq()));
        seen.sort_unstable();
        assert_eq!((nodes, seen), (4, vec![0, 1, 2]));
        let mut ids: Vec<u64> = tree.records().map(|r| r.id().seq()).collect();
        ids.sort_unstable();
        assert_eq!(ids, [0, 1, 2, 3]);
    }

    /// `visit_admitted` walks the same nodes as `visit` and shows, in the same order, only the
    /// records whose keys the prefilter admits: the reach is `a R` = 0.5 * 2 = 1, and of the three
    /// records in the visited nodes two lie within 0.42 of the query, the third 1.82 away.
    #[test]
    fn visit_admitted_shows_the_admitted_records_of_the_same_nodes() {
        let mut tree = Octree::new(config());
        tree.insert(record(Vec3::splat(1.0), 0)).unwrap();
        tree.insert(record(Vec3::new(1.5, 1.0, 1.0), 1)).unwrap();
        tree.insert(record(Vec3::new(3.0, 1.0, 1.0), 2)).unwrap();
        let q = Vec3::splat(1.2);
        let mut all = Vec::new();
        let nodes = tree.visit(q, &mut |r| all.push(r.id().seq()));
        let pre = Prefilter::new(q, Vec3::Z, config().accuracy());
        let mut admitted = Vec::new();
        let admitted_nodes = tree.visit_admitted(&pre, &mut |r| admitted.push(r.id().seq()));
        assert_eq!(admitted_nodes, nodes);
        assert_eq!(all, [0, 1, 2]);
        assert_eq!(admitted, [0, 1]);
    }
}
