//! Loose-octree geometry shared by every cache, so that all of them place a record in the same node
//! and prune a query with the same test.
//!
//! A node at depth `d` owns a cubic cell of half-size `h_d = h_0 / 2^d`. A record whose influence
//! radius `rho = a * R_i` ([`crate::ic::influence_radius`]) is at most `h_d` is stored in the depth-`d`
//! node whose cell holds its position, at the deepest such depth (capped at [`MAX_DEPTH`]). Every
//! point where the record can be valid then lies within `h_d + rho <= 2 h_d` of the cell centre: in
//! the node's *loose* cell, twice the size of the cell. Loose cells nest, so a query visits the root
//! and, recursively, every child whose loose cell holds the query point, and meets every record that
//! can be valid for it. Records too large for the root cell stay in the root, which every query
//! visits.

use glam::{Vec3, Vec3A};

/// The deepest level a record is placed at. Deeper cells would be smaller than the numerical
/// slack the pruning test allows for, and gain nothing.
pub const MAX_DEPTH: u32 = 16;

/// Relative margin on the placement test: a record goes to depth `d` only if
/// `rho * (1 + PLACEMENT_MARGIN) <= h_d`.
const PLACEMENT_MARGIN: f32 = 1e-3;

/// One of a cell's eight children.
///
/// Invariant: the value is below 8; bit 0 is set for the +x half, bit 1 for +y, bit 2 for +z.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Octant(u8);

impl Octant {
    /// All eight octants.
    pub const ALL: [Octant; 8] = [
        Octant(0),
        Octant(1),
        Octant(2),
        Octant(3),
        Octant(4),
        Octant(5),
        Octant(6),
        Octant(7),
    ];

    /// The index into a node's children (below 8).
    pub fn index(self) -> usize {
        usize::from(self.0)
    }

    /// The octants whose bits are set in `mask`, lowest first (the order of [`Octant::ALL`]).
    #[inline]
    pub fn in_mask(mask: u8) -> impl Iterator<Item = Octant> {
        let mut left = mask;
        std::iter::from_fn(move || {
            (left != 0).then(|| {
                let o = left.trailing_zeros() as u8;
                left &= left - 1;
                Octant(o)
            })
        })
    }

    /// This octant's bit in a mask.
    #[inline]
    pub fn bit(self) -> u8 {
        1 << self.0
    }
}

/// `HOLDING[below | above << 3]`: the octants whose child cells hold a point, given per axis
/// whether the child below (bits 0–2 of the index) and the child above (bits 3–5) hold it on
/// that axis. An octant is in when, on each of the three axes, its side holds the point.
const HOLDING: [u8; 64] = {
    let mut table = [0u8; 64];
    let mut index = 0;
    while index < 64 {
        let mut mask = 0u8;
        let mut octant = 0;
        while octant < 8 {
            let mut inside = true;
            let mut axis = 0;
            while axis < 3 {
                let above = octant & (1 << axis) != 0;
                let side = if above { 3 + axis } else { axis };
                inside &= index & (1 << side) != 0;
                axis += 1;
            }
            if inside {
                mask |= 1 << octant;
            }
            octant += 1;
        }
        table[index] = mask;
        index += 1;
    }
    table
};

/// Per octant, the direction of its child's centre from the parent's (each component ±1).
const CHILD_SIGNS: [Vec3; 8] = {
    let mut signs = [Vec3::ZERO; 8];
    let mut o = 0;
    while o < 8 {
        let x = if o & 1 != 0 { 1.0 } else { -1.0 };
        let y = if o & 2 != 0 { 1.0 } else { -1.0 };
        let z = if o & 4 != 0 { 1.0 } else { -1.0 };
        signs[o] = Vec3::new(x, y, z);
        o += 1;
    }
    signs
};

/// A cubic cell of the octree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Centre of the cell.
    pub center: Vec3,
    /// Half the edge length.
    pub half: f32,
}

impl Cell {
    /// The octant of this cell that holds `p` (a point on a dividing plane goes to the + side).
    #[inline]
    pub fn octant(&self, p: Vec3) -> Octant {
        let bits = u8::from(p.x >= self.center.x)
            | (u8::from(p.y >= self.center.y) << 1)
            | (u8::from(p.z >= self.center.z) << 2);
        Octant(bits)
    }

    /// The child cell in octant `o`.
    #[inline]
    pub fn child(&self, o: Octant) -> Cell {
        let q = self.half * 0.5;
        // `±1 * q` is exactly `±q`.
        Cell {
            center: self.center + CHILD_SIGNS[o.index()] * q,
            half: q,
        }
    }

    /// True when `p` lies in the closed cell.
    pub fn contains(&self, p: Vec3) -> bool {
        (p - self.center).abs().max_element() <= self.half
    }
}

/// The root of an octree and the constants its queries use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// The root cell.
    pub root: Cell,
    /// Accuracy `a` of the cache (records are placed by `a * R_i`).
    pub accuracy: f32,
    /// Absolute slack added to every loose-cell test, covering the rounding of cell centres.
    slack: f32,
}

impl Geometry {
    /// Geometry for a root cube and an accuracy (both already validated by the caller).
    pub fn new(root: Cell, accuracy: f32) -> Self {
        // About 80 ulps of the largest coordinate the tree computes.
        let slack = (root.center.abs().max_element() + root.half) * 1e-5;
        Self {
            root,
            accuracy,
            slack,
        }
    }

    /// The depth at which a record with influence radius `rho` is stored.
    pub fn placement_depth(&self, rho: f32) -> u32 {
        let mut depth = 0;
        let mut half = self.root.half;
        while depth < MAX_DEPTH && rho * (1.0 + PLACEMENT_MARGIN) <= half * 0.5 {
            half *= 0.5;
            depth += 1;
        }
        depth
    }

    /// The children of `cell` a query at `p` must visit, as a mask with bit `o` set for octant
    /// `o`: exactly the octants whose child cell `loose_contains` accepts, decided axis by axis
    /// with the same `f32` operations, four lanes at a time (`c + (-q)` is `c - q`, and a maximum
    /// over the axes is below a bound when each axis is), without building the eight cells. A
    /// walk then loads only the child pointers it will follow.
    #[inline]
    pub fn children_holding(&self, cell: &Cell, p: Vec3) -> u8 {
        let q = Vec3A::splat(cell.half * 0.5);
        let bound = Vec3A::splat(2.0 * (cell.half * 0.5) + self.slack);
        let (p, c) = (Vec3A::from(p), Vec3A::from(cell.center));
        // Bit `i` of `below` (`above`): the child on the - (+) side of axis `i` holds `p`.
        let below = (p - (c - q)).abs().cmple(bound).bitmask();
        let above = (p - (c + q)).abs().cmple(bound).bitmask();
        HOLDING[(below | above << 3) as usize]
    }

    /// The loose cell of the non-root node of `cell`, with the slack of [`Geometry::loose_contains`]:
    /// the cube that holds the influence sphere of every record stored there.
    #[inline]
    pub fn loose_bounds(&self, cell: &Cell) -> (Vec3, Vec3) {
        let reach = Vec3::splat(2.0 * cell.half + self.slack);
        (cell.center - reach, cell.center + reach)
    }

    /// True when a query at `p` must visit the node of `cell` (a non-root node).
    #[inline]
    pub fn loose_contains(&self, cell: &Cell, p: Vec3) -> bool {
        (p - cell.center).abs().max_element() <= 2.0 * cell.half + self.slack
    }
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;

    fn geometry() -> Geometry {
        Geometry::new(
            Cell {
                center: Vec3::ZERO,
                half: 8.0,
            },
            0.5,
        )
    }

    #[test]
    fn octants_and_children() {
        let root = geometry().root;
        let o = root.octant(Vec3::new(1.0, -1.0, 3.0));
        assert_eq!(o.index(), 0b101);
        let c = root.child(o);
        assert_eq!(c.center, Vec3::new(4.0, -4.0, 4.0));
        assert_eq!(c.half, 4.0);
        assert!(c.contains(Vec3::new(1.0, -1.0, 3.0)));
        // The dividing plane belongs to the + side.
        assert_eq!(root.octant(Vec3::ZERO).index(), 7);
    }

    #[test]
    fn placement_by_influence() {
        let g = geometry();
        assert_eq!(g.placement_depth(100.0), 0); // larger than the root: stays at the root
        assert_eq!(g.placement_depth(8.0), 0); // needs h >= 8: the root
        assert_eq!(g.placement_depth(4.0), 0); // 4 * (1 + margin) > 4: not depth 1
        assert_eq!(g.placement_depth(3.9), 1);
        assert_eq!(g.placement_depth(1.0), 2); // h_3 = 1 is too tight with the margin; h_2 = 2
        assert_eq!(g.placement_depth(1e-9), MAX_DEPTH);
    }

    #[test]
    fn a_record_is_reachable_from_everywhere_it_is_valid() {
        // Walk a record down to its node and check that every point within rho of it lies in the
        // loose cell of every node on the path.
        let g = geometry();
        let p = Vec3::new(3.3, -0.7, 5.9);
        let rho = 0.3;
        let depth = g.placement_depth(rho);
        let mut cells = vec![g.root];
        for _ in 0..depth {
            let cell = *cells.last().unwrap();
            cells.push(cell.child(cell.octant(p)));
        }
        assert!(cells.last().unwrap().contains(p));
        for dir in [
            Vec3::X,
            -Vec3::X,
            Vec3::Y,
            -Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::ONE.normalize(),
        ] {
            let q = p + dir * rho * 0.999;
            for cell in &cells[1..] {
                assert!(g.loose_contains(cell, q), "{q} escapes {cell:?}");
            }
        }
    }

    /// The mask agrees with building each child and testing its loose cell, at random cells and
    /// points (many of them near a boundary, where rounding could tell two computations apart),
    /// and lists octants lowest first.
    #[test]
    fn children_holding_is_the_loose_test_of_each_child() {
        let g = geometry();
        let mut rng = crate::rng::Rng::new(7);
        let mut seen = [0usize; 9];
        for _ in 0..200_000 {
            let mut cell = g.root;
            for _ in 0..rng.below(10) {
                cell = cell.child(Octant::ALL[rng.below(8) as usize]);
            }
            // Points across the parent's loose cell, a third of them snapped to a child boundary.
            let mut p = cell.center
                + Vec3::new(
                    rng.range(-2.0, 2.0),
                    rng.range(-2.0, 2.0),
                    rng.range(-2.0, 2.0),
                ) * cell.half;
            if rng.below(3) == 0 {
                let q = cell.half * 0.5;
                p.x = cell.center.x + [-3.0, -1.0, 1.0, 3.0][rng.below(4) as usize] * q;
            }
            let mask = g.children_holding(&cell, p);
            for o in Octant::ALL {
                assert_eq!(
                    mask & o.bit() != 0,
                    g.loose_contains(&cell.child(o), p),
                    "{cell:?} {p} octant {o:?}"
                );
            }
            seen[mask.count_ones() as usize] += 1;
            let listed: Vec<usize> = Octant::in_mask(mask).map(Octant::index).collect();
            let expected: Vec<usize> = (0..8).filter(|&i| mask & (1 << i) != 0).collect();
            assert_eq!(listed, expected);
        }
        // Every count of children that the geometry allows (0, 1, 2, 4, 8) was met.
        for k in [0, 1, 2, 4, 8] {
            assert!(seen[k] > 0, "{seen:?}");
        }
    }

    /// The loose cell is exactly twice the cell (plus the slack), on every axis and on both sides:
    /// a visit that is too wide costs work the tree-shape bounds cannot see (they prune with this
    /// same test), and one that is too narrow misses records.
    #[test]
    fn a_loose_cell_is_twice_the_cell() {
        let g = geometry(); // root half 8 at the origin: slack 8e-5
        let cell = g.root.child(Octant(0)).child(Octant(7)); // centre (-2, -2, -2), half 2
        assert_eq!((cell.center, cell.half), (Vec3::splat(-2.0), 2.0));
        for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
            for side in [1.0, -1.0] {
                let at = |d: f32| cell.center + axis * side * d;
                assert!(
                    g.loose_contains(&cell, at(4.0)),
                    "{axis} {side}: the boundary"
                );
                assert!(
                    g.loose_contains(&cell, at(4.00005)),
                    "{axis} {side}: within the slack"
                );
                assert!(
                    !g.loose_contains(&cell, at(4.001)),
                    "{axis} {side}: past the slack"
                );
            }
        }
        // A small cell (half 0.25): twice is 0.5, not 2 + 0.25.
        let small = Cell {
            center: Vec3::ZERO,
            half: 0.25,
        };
        assert!(g.loose_contains(&small, Vec3::new(0.5, 0.0, 0.0)));
        assert!(!g.loose_contains(&small, Vec3::new(0.51, 0.0, 0.0)));
        assert!(!g.loose_contains(&small, Vec3::new(1.0, 0.0, 0.0)));
    }

    /// `loose_bounds` is the cube `loose_contains` accepts, slack included: a removal that skips
    /// the nodes whose bounds miss its selection skips no node a record it takes may be in.
    #[test]
    fn loose_bounds_are_the_cube_loose_contains_accepts() {
        let g = geometry(); // slack 8e-5
        let cells = [
            g.root.child(Octant(0)).child(Octant(7)), // half 2
            Cell {
                center: Vec3::new(0.5, -0.25, 0.0),
                half: 0.25,
            },
        ];
        for cell in cells {
            let (lo, hi) = g.loose_bounds(&cell);
            for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
                for side in [1.0, -1.0] {
                    for d in [
                        0.0,
                        2.0 * cell.half,
                        2.0 * cell.half + 5e-5,
                        2.0 * cell.half + 1e-3,
                    ] {
                        let p = cell.center + axis * side * d;
                        let inside = p.cmpge(lo).all() && p.cmple(hi).all();
                        assert_eq!(
                            inside,
                            g.loose_contains(&cell, p),
                            "half {}, {axis} {side} at {d}: bounds {lo}..{hi}",
                            cell.half
                        );
                    }
                }
            }
        }
    }
}
