//! A flat triangle list for scenes too small for a BVH to pay: every ray tests every triangle,
//! eight at a time.
//!
//! A wide BVH spends a node visit (decoding eight child boxes, ordering them, a stack) to save
//! triangle tests. On the Cornell box's 32 triangles that bookkeeping costs more than the tests it
//! saves: the whole scene is four batches of eight triangles, and testing a batch is the same
//! straight-line arithmetic on eight lanes, which the compiler turns into vector instructions
//! (the arrays below are laid out lane-major for that). Which of the two a scene gets is
//! [`Traversal::for_triangles`]: below [`FLAT_MAX`] triangles, measured by the `rays` benchmark
//! (`benches/rays.rs`).
//!
//! The test is obvhs's `RtTriangle::intersect` (Möller and Trumbore's, on the same precomputed
//! edges and normal) written per lane, so both traversals return the same hits up to the order in
//! which floating-point sums are taken (`flat_and_bvh_agree` in `scene.rs`).

use glam::Vec3;
use obvhs::rt_triangle::RtTriangle;

/// Triangles a batch tests at once.
const LANES: usize = 8;

/// Up to this many triangles a scene is traversed flat; above, through its BVH: the count where
/// the flat list stops being faster than the BVH in `benches/rays.rs` (a closest hit and a
/// shadow ray each from inside a box of random triangles).
pub const FLAT_MAX: usize = 64;

/// How a scene answers ray queries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Traversal {
    /// obvhs's compressed wide BVH.
    Bvh,
    /// Every triangle, a batch of eight at a time ([`FlatTriangles`]).
    Flat,
}

impl Traversal {
    /// The faster traversal for a scene of `triangles` triangles.
    pub fn for_triangles(triangles: usize) -> Self {
        if triangles <= FLAT_MAX {
            Self::Flat
        } else {
            Self::Bvh
        }
    }

    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Bvh => "bvh",
            Self::Flat => "flat",
        }
    }
}

/// Eight triangles, each quantity lane-major (`v0[axis][lane]`). Padding lanes are all zero: a
/// zero normal makes the determinant zero, which the test rejects.
#[derive(Clone, Copy, Debug, Default)]
struct Batch {
    v0: [[f32; LANES]; 3],
    e1: [[f32; LANES]; 3],
    e2: [[f32; LANES]; 3],
    ng: [[f32; LANES]; 3],
}

impl Batch {
    /// Each lane's hit distance in `[0, t_max]`, infinite where the ray misses that triangle.
    /// Branch-free per lane (`&` on the comparisons, not `&&`) so the loop vectorises.
    #[inline(always)]
    fn distances(&self, o: Vec3, d: Vec3, t_max: f32) -> [f32; LANES] {
        let mut out = [f32::INFINITY; LANES];
        for (i, slot) in out.iter_mut().enumerate() {
            // c = v0 - o; r = d x c; as RtTriangle::intersect.
            let (cx, cy, cz) = (
                self.v0[0][i] - o.x,
                self.v0[1][i] - o.y,
                self.v0[2][i] - o.z,
            );
            let (rx, ry, rz) = (
                d.y * cz - d.z * cy,
                d.z * cx - d.x * cz,
                d.x * cy - d.y * cx,
            );
            let det = self.ng[0][i] * d.x + self.ng[1][i] * d.y + self.ng[2][i] * d.z;
            let inv = 1.0 / det;
            let u = (rx * self.e2[0][i] + ry * self.e2[1][i] + rz * self.e2[2][i]) * inv;
            let v = (rx * self.e1[0][i] + ry * self.e1[1][i] + rz * self.e1[2][i]) * inv;
            let w = 1.0 - u - v;
            let t = (self.ng[0][i] * cx + self.ng[1][i] * cy + self.ng[2][i] * cz) * inv;
            let inside = (det != 0.0) & (u >= 0.0) & (v >= 0.0) & (w >= 0.0);
            let ahead = (t >= 0.0) & (t <= t_max);
            *slot = if inside & ahead { t } else { f32::INFINITY };
        }
        out
    }
}

/// A scene's triangles in batches of eight, in the order of the slice they were made from (a
/// hit's index is that slice's index).
#[derive(Clone, Debug)]
pub struct FlatTriangles {
    batches: Vec<Batch>,
}

impl FlatTriangles {
    /// The batches of `tris`, the last padded with triangles that never hit.
    pub fn new(tris: &[RtTriangle]) -> Self {
        let mut batches = vec![Batch::default(); tris.len().div_ceil(LANES)];
        for (i, t) in tris.iter().enumerate() {
            let (b, lane) = (&mut batches[i / LANES], i % LANES);
            for axis in 0..3 {
                b.v0[axis][lane] = t.v0[axis];
                b.e1[axis][lane] = t.e1[axis];
                b.e2[axis][lane] = t.e2[axis];
                b.ng[axis][lane] = t.ng[axis];
            }
        }
        Self { batches }
    }

    /// The nearest hit of the unit ray `o + t d` with `t` in `[0, t_max]`: its distance and the
    /// triangle's index, or `None`.
    #[inline]
    pub fn closest(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, u32)> {
        // The nearest per lane across batches (vertical, vectorised), then across lanes.
        let mut near = [f32::INFINITY; LANES];
        let mut index = [u32::MAX; LANES];
        for (k, b) in self.batches.iter().enumerate() {
            let t = b.distances(o, d, t_max);
            for i in 0..LANES {
                let closer = t[i] < near[i];
                near[i] = if closer { t[i] } else { near[i] };
                index[i] = if closer {
                    (k * LANES + i) as u32
                } else {
                    index[i]
                };
            }
        }
        let mut best = (f32::INFINITY, u32::MAX);
        for i in 0..LANES {
            if near[i] < best.0 {
                best = (near[i], index[i]);
            }
        }
        (best.1 != u32::MAX).then_some(best)
    }

    /// True when some triangle meets the unit ray `o + t d` for `t` in `[0, t_max]`.
    #[inline]
    pub fn occluded(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        self.batches.iter().any(|b| {
            b.distances(o, d, t_max)
                .iter()
                .fold(false, |any, &t| any | (t < f32::INFINITY))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    fn rt(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> RtTriangle {
        RtTriangle::new(Vec3A::from(a), Vec3A::from(b), Vec3A::from(c))
    }

    #[test]
    fn the_nearest_of_stacked_triangles_in_any_batch_is_found() {
        // Eleven unit triangles stacked along z at z = 11 - k (two batches, the second padded):
        // the nearest to a ray from the origin along +z is the last one, in the second batch.
        let tris: Vec<RtTriangle> = (0..11)
            .map(|k| {
                let z = 11.0 - k as f32;
                rt([-1.0, -1.0, z], [1.0, -1.0, z], [0.0, 1.0, z])
            })
            .collect();
        let flat = FlatTriangles::new(&tris);
        let (t, id) = flat
            .closest(Vec3::ZERO, Vec3::Z, f32::INFINITY)
            .expect("the stack is in front");
        assert_eq!((t, id), (1.0, 10));
        // Bounded short of the nearest: nothing.
        assert_eq!(flat.closest(Vec3::ZERO, Vec3::Z, 0.5), None);
        assert!(!flat.occluded(Vec3::ZERO, Vec3::Z, 0.5));
        assert!(flat.occluded(Vec3::ZERO, Vec3::Z, 1.5));
        // Beside the stack, or pointing away: no hit, and the padding lanes never hit.
        assert_eq!(flat.closest(Vec3::new(5.0, 0.0, 0.0), Vec3::Z, 100.0), None);
        assert_eq!(flat.closest(Vec3::ZERO, -Vec3::Z, 100.0), None);
        assert!(!flat.occluded(Vec3::ZERO, -Vec3::Z, 100.0));
    }

    #[test]
    fn the_scene_size_picks_the_traversal() {
        assert_eq!(Traversal::for_triangles(32), Traversal::Flat);
        assert_eq!(Traversal::for_triangles(FLAT_MAX), Traversal::Flat);
        assert_eq!(Traversal::for_triangles(FLAT_MAX + 1), Traversal::Bvh);
        // The names label `benches/rays.rs`'s results (`rays/flat/N`, `rays/bvh/N`).
        assert_eq!(
            (Traversal::Flat.name(), Traversal::Bvh.name()),
            ("flat", "bvh")
        );
    }
}
