//! Irradiance-cache mathematics, free of any concurrency: the record, Ward's weight and validity
//! test, the clamped radius of influence, and weighted interpolation with gradients.
//!
//! References: G. Ward, F. Rubinstein, R. Clear, "A ray tracing solution for diffuse
//! interreflection", SIGGRAPH 1988 (the weight `w_i = 1 / (|x - x_i| / R_i + sqrt(1 - n . n_i))`,
//! validity `w_i > 1/a`, and the "in front" test); G. Ward, P. Heckbert, "Irradiance gradients",
//! Eurographics Rendering Workshop 1992 (first-order extrapolation with translational and rotational
//! gradients). The paper this crate studies (Dubla et al., §2.1) uses them unchanged.

mod record;
mod selection;

pub use record::{InsertError, Record, RecordId, WorkerId};
pub use selection::{Selection, SelectionError};

use glam::{DVec3, Vec3};

/// Floor on the weight's denominator, so a query exactly at a record (same point, same normal) gets
/// a large finite weight (10^6) instead of a division by zero.
pub const MIN_DENOMINATOR: f64 = 1e-6;

/// Ward's "in front" test tolerance, relative to the record's radius: a record whose position lies
/// more than this fraction of `R_i` in front of the shaded point's tangent plane is not used.
pub const BEHIND_TOLERANCE: f32 = 0.05;

/// Ward's weight of `record` for a query at `point` with unit normal `normal`:
/// `1 / (|x - x_i| / R_i + sqrt(1 - n . n_i))`, computed in `f64`.
pub fn ward_weight(record: &Record, point: Vec3, normal: Vec3) -> f64 {
    let distance = f64::from((point - record.position).length());
    let cos = f64::from(normal.dot(record.normal));
    let denominator = distance / f64::from(record.radius) + (1.0 - cos).max(0.0).sqrt();
    1.0 / denominator.max(MIN_DENOMINATOR)
}

/// True when `record` lies in front of the query point, so using it would bring light from
/// geometry the point cannot see (Ward 1988, eq. 7: `d_i = (x - x_i) . (n + n_i) / 2 < -tol`).
pub fn is_in_front(record: &Record, point: Vec3, normal: Vec3) -> bool {
    let d = (point - record.position).dot((normal + record.normal) * 0.5);
    d < -BEHIND_TOLERANCE * record.radius
}

/// How far from its position a record can be valid at accuracy `a`: `w > 1/a` needs
/// `|x - x_i| / R_i < a`, so `a * R_i` bounds the search; the octrees place records by it.
pub fn influence_radius(record: &Record, accuracy: f32) -> f32 {
    accuracy * record.radius
}

/// A record's weight if it is valid for the query (weight above `1/a`, not in front), else `None`.
pub fn valid_weight(record: &Record, point: Vec3, normal: Vec3, accuracy: f32) -> Option<f64> {
    let w = ward_weight(record, point, normal);
    (w > 1.0 / f64::from(accuracy) && !is_in_front(record, point, normal)).then_some(w)
}

/// The records among `records` that are valid for a query at `point` with `normal` at accuracy `a`
/// (none for a query that is not finite): the brute-force answer the oracles give.
pub fn valid_among<'r>(
    records: impl IntoIterator<Item = &'r Record>,
    point: Vec3,
    normal: Vec3,
    accuracy: f32,
) -> impl Iterator<Item = &'r Record> {
    let answerable = is_valid_query(point, normal);
    records
        .into_iter()
        .filter(move |r| answerable && valid_weight(r, point, normal, accuracy).is_some())
}

/// Clamps a harmonic mean distance to `[min, max]`; an infinite or NaN distance (the hemisphere saw
/// nothing) becomes `max`. This is the record radius the caches store.
pub fn clamp_radius(harmonic_mean: f32, min: f32, max: f32) -> f32 {
    if harmonic_mean.is_nan() {
        max
    } else {
        harmonic_mean.clamp(min, max)
    }
}

/// The first-order estimate of `record`'s irradiance at `point` with `normal` (Ward & Heckbert):
/// `E_i + (n_i x n) . grad_r + (x - x_i) . grad_t`, per channel, clamped at zero.
pub fn extrapolate(record: &Record, point: Vec3, normal: Vec3) -> Vec3 {
    let rotation = record.normal.cross(normal);
    let offset = point - record.position;
    let e = record.irradiance;
    Vec3::new(
        e.x + rotation.dot(record.grad_r[0]) + offset.dot(record.grad_t[0]),
        e.y + rotation.dot(record.grad_r[1]) + offset.dot(record.grad_t[1]),
        e.z + rotation.dot(record.grad_r[2]) + offset.dot(record.grad_t[2]),
    )
    .max(Vec3::ZERO)
}

/// Relative margin by which a [`Key`]'s reach exceeds `a * R_i`, so that the prefilter never
/// refuses a record the exact test (in `f64`, from the same `f32` inputs) would take.
const REACH_MARGIN: f32 = 1e-3;

/// The part of a record that decides, for most records a lookup examines, that it is not valid:
/// its position, its normal and the square of the distance beyond which it cannot be valid
/// (`(a R_i)^2`, widened by a relative 10^-3). 28 bytes, against 128 for the whole record, so the
/// caches store keys apart from the records, two to a cache line, and read a record only when its
/// key passes the [`Prefilter`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Key {
    /// The record's position.
    pub position: Vec3,
    /// A bound on `|x - x_i|^2` for a valid record, at the cache's accuracy.
    pub reach_squared: f32,
    /// The record's normal.
    pub normal: Vec3,
}

impl Key {
    /// The key of `record` at accuracy `a`.
    pub fn of(record: &Record, accuracy: f32) -> Self {
        let reach = f64::from(influence_radius(record, accuracy));
        // Rounded in f64 and widened: `f32` rounding of the square is far inside the margin. A
        // reach so small that its square would be subnormal is raised to the smallest normal
        // square (a wider bound is still a bound); one too large becomes infinite, which admits
        // every distance.
        let squared = (reach * reach * f64::from(1.0 + REACH_MARGIN)) as f32;
        Self {
            position: record.position,
            reach_squared: squared.max(f32::MIN_POSITIVE),
            normal: record.normal,
        }
    }
}

/// A cheap test on a record's [`Key`] that refuses most records a lookup examines without reading
/// the rest of them, and never refuses one that [`valid_weight`] would take: validity needs
/// `|x - x_i| / R_i + sqrt(1 - n . n_i) < a` (Ward's weight above `1/a`), so both `|x - x_i| < a R_i`
/// and `n . n_i > 1 - a^2` are necessary. Both are tested with margins that cover the rounding of
/// `f32` against the exact test's `f64`, and a NaN passes (the exact test decides).
#[derive(Clone, Copy, Debug)]
pub struct Prefilter {
    point: Vec3,
    normal: Vec3,
    min_cos: f32,
}

impl Prefilter {
    /// The prefilter of a query at `point` with `normal`, at accuracy `a`.
    pub fn new(point: Vec3, normal: Vec3, accuracy: f32) -> Self {
        let a = f64::from(accuracy);
        Self {
            point,
            normal,
            // The exact test takes a record only if the same f32 dot product, widened to f64,
            // exceeds `1 - a^2` (its other term only adds). Rounding that bound to the nearest
            // f32 refuses no such dot product: no f32 lies strictly between the bound and its
            // rounding.
            min_cos: (1.0 - a * a) as f32,
        }
    }

    /// The query point.
    pub fn point(&self) -> Vec3 {
        self.point
    }

    /// False only when the record with this key cannot be valid for the query.
    #[inline(always)]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // the negated form is the point: NaN passes
    pub fn admits(&self, key: &Key) -> bool {
        // A NaN fails both comparisons, so it passes to the exact test.
        if (self.point - key.position).length_squared() > key.reach_squared {
            return false;
        }
        !(self.normal.dot(key.normal) < self.min_cos)
    }
}

/// The outcome of a successful lookup.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interpolated {
    /// The weighted average of the valid records' extrapolated irradiance.
    pub irradiance: Vec3,
    /// The sum of their weights.
    pub weight: f64,
    /// How many records were valid.
    pub records: u32,
    /// How many of them another worker computed (the paper's argument for sharing).
    pub foreign: u32,
    /// The largest of their weights: a renderer that interpolates at a wider accuracy than it
    /// places records at (its smoothing) asks whether some record is valid at the narrower one,
    /// which is this above `1 / a`.
    pub max_weight: f64,
}

/// One valid record's part of an interpolation ([`Accumulator::weigh`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contribution {
    weight: f64,
    value: DVec3,
    foreign: bool,
}

/// Accumulates valid records for one query; every cache and the brute-force oracle use it, so they
/// decide validity and sum contributions with the same arithmetic.
#[derive(Clone, Debug)]
pub struct Accumulator {
    prefilter: Prefilter,
    point: Vec3,
    normal: Vec3,
    accuracy: f32,
    asker: Option<WorkerId>,
    weight: f64,
    sum: DVec3,
    records: u32,
    foreign: u32,
    max_weight: f64,
}

impl Accumulator {
    /// A query at `point` with unit `normal`, at accuracy `a`, asked by `asker` (for the count of
    /// foreign records; `None` counts none as foreign).
    pub fn new(point: Vec3, normal: Vec3, accuracy: f32, asker: Option<WorkerId>) -> Self {
        Self {
            prefilter: Prefilter::new(point, normal, accuracy),
            point,
            normal,
            accuracy,
            asker,
            weight: 0.0,
            sum: DVec3::ZERO,
            records: 0,
            foreign: 0,
            max_weight: 0.0,
        }
    }

    /// The query point.
    pub fn point(&self) -> Vec3 {
        self.point
    }

    /// The query's [`Prefilter`]: a record whose key it refuses would not be taken by [`Self::add`].
    #[inline]
    pub fn prefilter(&self) -> &Prefilter {
        &self.prefilter
    }

    /// Takes `record` into the average if it is valid for this query; returns whether it was.
    #[inline]
    pub fn add(&mut self, record: &Record) -> bool {
        match self.weigh(record) {
            Some(c) => {
                self.take(c);
                true
            }
            None => false,
        }
    }

    /// What `record` would add to the average, if it is valid for this query: for a caller that
    /// orders the valid records before summing them ([`Self::take`]).
    #[inline]
    pub fn weigh(&self, record: &Record) -> Option<Contribution> {
        let weight = valid_weight(record, self.point, self.normal, self.accuracy)?;
        Some(Contribution {
            weight,
            value: weight * extrapolate(record, self.point, self.normal).as_dvec3(),
            foreign: self.asker.is_some_and(|me| record.id().worker() != me),
        })
    }

    /// Adds a contribution [`Self::weigh`] gave: exactly what [`Self::add`] adds for its record.
    #[inline]
    pub fn take(&mut self, c: Contribution) {
        self.weight += c.weight;
        self.max_weight = self.max_weight.max(c.weight);
        self.sum += c.value;
        self.records += 1;
        self.foreign += u32::from(c.foreign);
    }

    /// The interpolated irradiance, or `None` when no record was valid.
    pub fn finish(&self) -> Option<Interpolated> {
        (self.records > 0).then(|| Interpolated {
            irradiance: (self.sum / self.weight).as_vec3(),
            weight: self.weight,
            records: self.records,
            foreign: self.foreign,
            max_weight: self.max_weight,
        })
    }
}

/// True when a query point and normal can be answered at all (finite point, finite non-zero
/// normal). Lookups with anything else return nothing.
pub fn is_valid_query(point: Vec3, normal: Vec3) -> bool {
    point.is_finite() && normal.is_finite() && normal.length_squared() > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(position: Vec3, e: f32, radius: f32) -> Record {
        Record::new(position, Vec3::Z, Vec3::splat(e), radius)
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-6 * b.abs().max(1.0)
    }

    #[test]
    fn weight_by_hand() {
        let r = rec(Vec3::ZERO, 1.0, 1.0);
        // Distance 0.5, same normal: 1 / (0.5 / 1 + 0) = 2.
        assert!(close(
            ward_weight(&r, Vec3::new(0.5, 0.0, 0.0), Vec3::Z),
            2.0
        ));
        // Distance 0.5 at radius 2: 1 / 0.25 = 4.
        let r2 = rec(Vec3::ZERO, 1.0, 2.0);
        assert!(close(
            ward_weight(&r2, Vec3::new(0.0, 0.5, 0.0), Vec3::Z),
            4.0
        ));
        // Same point, normal tilted so n . n_i = 0.75: 1 / sqrt(0.25) = 2.
        let tilted = Vec3::new((1.0f32 - 0.75 * 0.75).sqrt(), 0.0, 0.75);
        assert!(close(ward_weight(&r, Vec3::ZERO, tilted), 2.0));
        // Both: distance 0.25 and n . n_i = 0.75: 1 / (0.25 + 0.5) = 4/3.
        assert!(close(
            ward_weight(&r, Vec3::new(0.25, 0.0, 0.0), tilted),
            4.0 / 3.0
        ));
        // Exactly at the record: the floor on the denominator keeps it finite.
        assert!(close(
            ward_weight(&r, Vec3::ZERO, Vec3::Z),
            1.0 / MIN_DENOMINATOR
        ));
    }

    #[test]
    fn validity_against_accuracy() {
        let r = rec(Vec3::ZERO, 1.0, 1.0);
        let x = Vec3::new(0.5, 0.0, 0.0); // weight 2
        assert_eq!(valid_weight(&r, x, Vec3::Z, 0.6), Some(2.0)); // 2 > 1/0.6
        assert_eq!(valid_weight(&r, x, Vec3::Z, 0.4), None); // 2 < 2.5
        assert_eq!(valid_weight(&r, x, Vec3::Z, 0.5), None); // 2 = 1/0.5 is not above
        assert!(close(f64::from(influence_radius(&r, 0.4)), 0.4));
        // Opposite normal: sqrt(1 - (-1)) = sqrt 2 > any accuracy below sqrt 2.
        assert_eq!(valid_weight(&r, Vec3::ZERO, -Vec3::Z, 1.0), None);
    }

    #[test]
    fn in_front_test() {
        let r = rec(Vec3::ZERO, 1.0, 1.0);
        // The query point sits 0.2 below the record's plane: the record is in front of it.
        assert!(is_in_front(&r, Vec3::new(0.1, 0.0, -0.2), Vec3::Z));
        assert_eq!(
            valid_weight(&r, Vec3::new(0.1, 0.0, -0.2), Vec3::Z, 1.0),
            None
        );
        // 0.04 below is within the tolerance of 0.05 R.
        assert!(!is_in_front(&r, Vec3::new(0.1, 0.0, -0.04), Vec3::Z));
        // Above the plane is never in front.
        assert!(!is_in_front(&r, Vec3::new(0.1, 0.0, 0.3), Vec3::Z));
    }

    #[test]
    fn clamping() {
        assert_eq!(clamp_radius(0.01, 0.1, 10.0), 0.1);
        assert_eq!(clamp_radius(50.0, 0.1, 10.0), 10.0);
        assert_eq!(clamp_radius(3.0, 0.1, 10.0), 3.0);
        assert_eq!(clamp_radius(f32::INFINITY, 0.1, 10.0), 10.0);
        assert_eq!(clamp_radius(f32::NAN, 0.1, 10.0), 10.0);
    }

    #[test]
    fn interpolation_by_hand() {
        let a = rec(Vec3::new(-0.5, 0.0, 0.0), 1.0, 1.0);
        let b = rec(Vec3::new(0.5, 0.0, 0.0), 3.0, 1.0);
        // Both at distance 0.5 -> weight 2 each -> plain average 2.
        let mut acc = Accumulator::new(Vec3::ZERO, Vec3::Z, 0.6, None);
        assert!(acc.add(&a) && acc.add(&b));
        let out = acc.finish().unwrap();
        assert!((out.irradiance - Vec3::splat(2.0)).abs().max_element() < 1e-6);
        assert!(close(out.weight, 4.0));
        assert_eq!(out.records, 2);

        // A translational gradient of 1 per unit x on `a`: it extrapolates 1 + 0.5 = 1.5 at the
        // origin, so the average becomes (1.5 + 3) / 2 = 2.25.
        let a_grad = a.with_gradients([Vec3::X; 3], [Vec3::ZERO; 3]);
        let mut acc = Accumulator::new(Vec3::ZERO, Vec3::Z, 0.6, None);
        acc.add(&a_grad);
        acc.add(&b);
        assert!(
            (acc.finish().unwrap().irradiance - Vec3::splat(2.25))
                .abs()
                .max_element()
                < 1e-6
        );

        // Unequal weights: query at x = -0.25 gives distances 0.25 and 0.75 -> weights 4 and 4/3:
        // (4 * 1 + 4/3 * 3) / (16/3) = 8 / (16/3) = 1.5.
        let mut acc = Accumulator::new(Vec3::new(-0.25, 0.0, 0.0), Vec3::Z, 0.9, None);
        acc.add(&a);
        acc.add(&b);
        let out = acc.finish().unwrap();
        assert!((out.irradiance - Vec3::splat(1.5)).abs().max_element() < 1e-6);
        assert!(close(out.weight, 16.0 / 3.0));
        // The largest weight is the nearer record's, whichever came first.
        assert!(close(out.max_weight, 4.0));
        let mut acc = Accumulator::new(Vec3::new(-0.25, 0.0, 0.0), Vec3::Z, 0.9, None);
        acc.add(&b);
        acc.add(&a);
        assert!(close(acc.finish().unwrap().max_weight, 4.0));
    }

    #[test]
    fn rotational_gradient_by_hand() {
        // n_i = Z, n = (s, 0, c): n_i x n = (0, s, 0). A rotational gradient (0, 1, 0) adds s.
        let s = 0.6f32;
        let n = Vec3::new(s, 0.0, 0.8);
        let r = rec(Vec3::ZERO, 1.0, 1.0).with_gradients([Vec3::ZERO; 3], [Vec3::Y; 3]);
        assert!(
            (extrapolate(&r, Vec3::ZERO, n) - Vec3::splat(1.0 + s))
                .abs()
                .max_element()
                < 1e-6
        );
        // A gradient that would drive the estimate negative is clamped at zero.
        let r = rec(Vec3::ZERO, 0.1, 1.0).with_gradients([Vec3::X * -1.0; 3], [Vec3::ZERO; 3]);
        assert_eq!(extrapolate(&r, Vec3::X, Vec3::Z), Vec3::ZERO);
    }

    #[test]
    fn no_valid_record_means_no_answer() {
        let far = rec(Vec3::new(5.0, 0.0, 0.0), 1.0, 1.0);
        let mut acc = Accumulator::new(Vec3::ZERO, Vec3::Z, 0.5, None);
        assert!(!acc.add(&far));
        assert_eq!(acc.finish(), None);
    }

    #[test]
    fn foreign_records_are_counted() {
        let mut mine = rec(Vec3::ZERO, 1.0, 1.0);
        mine.seal(RecordId::new(WorkerId::new(0), 0, 0));
        let mut theirs = rec(Vec3::X * 0.1, 1.0, 1.0);
        theirs.seal(RecordId::new(WorkerId::new(1), 0, 0));
        let mut acc = Accumulator::new(Vec3::ZERO, Vec3::Z, 0.5, Some(WorkerId::new(0)));
        acc.add(&mine);
        acc.add(&theirs);
        let out = acc.finish().unwrap();
        assert_eq!((out.records, out.foreign), (2, 1));
    }

    #[test]
    fn in_front_by_hand_away_from_the_origin() {
        // A record at (1, 2, 3) facing +z, radius 2: the tolerance is 0.05 * 2 = 0.1 below its
        // plane. Placing it off the origin makes `x - x_i` differ from `x + x_i`.
        let r = rec(Vec3::new(1.0, 2.0, 3.0), 1.0, 2.0);
        // 0.05 below: inside 0.1 R-relative tolerance (it would be outside a tolerance of 0.05 / R).
        assert!(!is_in_front(&r, Vec3::new(1.5, 2.0, 2.95), Vec3::Z));
        // 0.15 below: in front.
        assert!(is_in_front(&r, Vec3::new(1.5, 2.0, 2.85), Vec3::Z));
        // 0.2 above: never in front.
        assert!(!is_in_front(&r, Vec3::new(1.5, 2.0, 3.2), Vec3::Z));
        // The averaged normal (n + n_i) / 2, not a product of components: with n = n_i = Z the
        // signed distance of a point 0.075 below is -0.075, beyond the tolerance of 0.05 at R = 1.
        let unit = rec(Vec3::ZERO, 1.0, 1.0);
        assert!(is_in_front(&unit, Vec3::new(0.0, 0.0, -0.075), Vec3::Z));
        // Tilted normals: n = (0.6, 0, 0.8), n_i = Z, so (n + n_i) / 2 = (0.3, 0, 0.9). The point
        // (-0.2, 0, 0) has signed distance -0.06 (in front at tolerance 0.05), although it lies in
        // the record's own plane.
        let n = Vec3::new(0.6, 0.0, 0.8);
        assert!(is_in_front(&unit, Vec3::new(-0.2, 0.0, 0.0), n));
        assert!(!is_in_front(&unit, Vec3::new(-0.1, 0.0, 0.0), n));
        // Exactly at the tolerance (d = -0.05 = -0.05 R, every product exact): not in front, the
        // test is strict.
        assert!(!is_in_front(&unit, Vec3::new(0.0, 0.0, -0.05), Vec3::Z));
    }

    #[test]
    fn influence_radius_scales_with_the_record_radius() {
        let r = rec(Vec3::ZERO, 1.0, 2.0);
        assert!(close(f64::from(influence_radius(&r, 0.4)), 0.8));
        let r = rec(Vec3::ZERO, 1.0, 0.5);
        assert!(close(f64::from(influence_radius(&r, 0.4)), 0.2));
    }

    #[test]
    fn valid_among_keeps_exactly_the_valid_records() {
        let records = [
            rec(Vec3::new(0.5, 0.0, 0.0), 1.0, 1.0), // weight 2 > 1/0.6: valid
            rec(Vec3::new(5.0, 0.0, 0.0), 1.0, 1.0), // far: weight 0.2
            rec(Vec3::new(0.0, 0.25, 0.0), 2.0, 1.0), // weight 4: valid
            rec(Vec3::new(0.0, 0.0, 0.3), 3.0, 1.0), // in front (0.3 above the query's plane)
        ];
        let found: Vec<f32> = valid_among(&records, Vec3::ZERO, Vec3::Z, 0.6)
            .map(|r| r.irradiance.x)
            .collect();
        assert_eq!(found, vec![1.0, 2.0]);
        // A query that cannot be answered finds nothing, however close the records.
        let nan = Vec3::new(f32::NAN, 0.0, 0.0);
        assert_eq!(valid_among(&records, nan, Vec3::Z, 0.6).count(), 0);
        assert_eq!(
            valid_among(&records, Vec3::ZERO, Vec3::ZERO, 0.6).count(),
            0
        );
    }

    #[test]
    fn accumulator_keeps_its_query_point() {
        let p = Vec3::new(1.0, -2.0, 0.5);
        assert_eq!(Accumulator::new(p, Vec3::Z, 0.5, None).point(), p);
    }

    #[test]
    fn foreign_counts_other_workers_only() {
        // One record of the asker, two of another worker: two foreign, not one.
        let sealed = |x: f32, worker: u32, seq: u64| {
            rec(Vec3::X * x, 1.0, 1.0).sealed(RecordId::new(WorkerId::new(worker), 0, seq))
        };
        let mut acc = Accumulator::new(Vec3::ZERO, Vec3::Z, 0.5, Some(WorkerId::new(3)));
        assert!(acc.add(&sealed(0.0, 3, 0)));
        assert!(acc.add(&sealed(0.1, 4, 0)));
        assert!(acc.add(&sealed(-0.1, 4, 1)));
        let out = acc.finish().unwrap();
        assert_eq!((out.records, out.foreign), (3, 2));
        // Without an asker nothing is foreign.
        let mut acc = Accumulator::new(Vec3::ZERO, Vec3::Z, 0.5, None);
        acc.add(&sealed(0.1, 4, 0));
        assert_eq!(acc.finish().unwrap().foreign, 0);
    }

    #[test]
    fn query_validation() {
        assert!(is_valid_query(Vec3::ZERO, Vec3::Z));
        assert!(!is_valid_query(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Z));
        assert!(!is_valid_query(Vec3::ZERO, Vec3::ZERO));
        assert!(!is_valid_query(Vec3::ZERO, Vec3::splat(f32::INFINITY)));
    }

    /// The prefilter never refuses a record the exact test takes, at the edges where rounding
    /// decides: queries at distances a hair inside and outside `a R_i` with the record's normal,
    /// and queries at the record's point with normals tilted to a hair either side of
    /// `sqrt(1 - cos) = a`, over many radii, accuracies and places; and it refuses every record
    /// clearly out of reach (it is a filter, not a pass-through).
    #[test]
    fn the_prefilter_never_refuses_a_valid_record() {
        let mut rng = crate::rng::Rng::new(0x9f1);
        let (mut valid, mut invalid, mut far) = (0u32, 0u32, 0u32);
        for case in 0..200_000 {
            let a = [0.05, 0.1, 0.25, 0.3, 0.5, 0.7, 1.0, 2.0][case % 8];
            let radius = 10f32.powf(rng.range(-3.0, 2.0));
            let position = Vec3::new(
                rng.range(-50.0, 50.0),
                rng.range(-50.0, 50.0),
                rng.range(-50.0, 50.0),
            );
            let normal = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
            .try_normalize()
            .unwrap_or(Vec3::Z);
            let r = Record::new(position, normal, Vec3::ONE, radius);
            let key = Key::of(&r, a);
            let tangent = normal.any_orthonormal_vector();
            let (point, query_normal) = match case % 4 {
                // Along the tangent plane, at a distance within 10^-5 of a R either way.
                0 => {
                    let d = a * radius * (1.0 + rng.range(-1e-5, 1e-5));
                    (position + tangent * d, normal)
                }
                // At the record, the normal tilted to within 10^-5 of the bound either way.
                1 => {
                    let s = a * (1.0 + rng.range(-1e-6, 1e-6)); // sqrt(1 - cos)
                    let cos = (1.0 - s * s).max(-1.0);
                    let sin = (1.0 - cos * cos).max(0.0).sqrt();
                    (position, normal * cos + tangent * sin)
                }
                // Both terms at once: a share `u` of the bound from the distance, the rest from the
                // tilt, summing to within 10^-6 of `a` either way.
                2 => {
                    let u = rng.next_f32();
                    let edge = 1.0 + rng.range(-1e-6, 1e-6);
                    let s = (1.0 - u) * a * edge;
                    let cos = (1.0 - s * s).max(-1.0);
                    let sin = (1.0 - cos * cos).max(0.0).sqrt();
                    let along = tangent.cross(normal);
                    (
                        position + along * (u * a * radius * edge),
                        normal * cos + tangent * sin,
                    )
                }
                // Anywhere within three reaches; the record's normal or a random one.
                _ => {
                    let offset = Vec3::new(
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                    );
                    let n = if rng.below(2) == 0 {
                        normal
                    } else {
                        normal.lerp(-tangent, rng.next_f32()).normalize()
                    };
                    (position + offset * 3.0 * a * radius, n)
                }
            };
            let pre = Prefilter::new(point, query_normal, a);
            let exact = valid_weight(&r, point, query_normal, a).is_some();
            if exact {
                valid += 1;
                assert!(
                    pre.admits(&key),
                    "case {case}: a {a}, record {r:?}, query {point} {query_normal}"
                );
            } else {
                invalid += 1;
            }
            // Clearly out of reach (1% past a R): refused without the exact test.
            if point.distance(position) > 1.01 * a * radius {
                far += 1;
                assert!(!pre.admits(&key), "case {case}: a far record was admitted");
            }
        }
        // Both sides of both edges were met, and many records were far.
        assert!(
            valid > 40_000 && invalid > 40_000,
            "{valid} valid, {invalid} invalid"
        );
        assert!(far > 20_000, "{far} far");
    }

    /// A record too small or too large for `f32` squares still gets a reach that bounds it.
    #[test]
    fn keys_of_extreme_radii_still_bound_the_reach() {
        let tiny = Record::new(Vec3::ZERO, Vec3::Z, Vec3::ONE, 1e-30);
        assert_eq!(Key::of(&tiny, 0.5).reach_squared, f32::MIN_POSITIVE);
        let huge = Record::new(Vec3::ZERO, Vec3::Z, Vec3::ONE, 1e30);
        assert_eq!(Key::of(&huge, 0.5).reach_squared, f32::INFINITY);
        // At the tiny record's own point the exact test takes it; the prefilter must too.
        let pre = Prefilter::new(Vec3::ZERO, Vec3::Z, 0.5);
        assert!(valid_weight(&tiny, Vec3::ZERO, Vec3::Z, 0.5).is_some());
        assert!(pre.admits(&Key::of(&tiny, 0.5)));
    }
}
