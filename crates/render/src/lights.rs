//! The scene's area lights and how a shading point chooses among them.
//!
//! Every emissive triangle is a light. Triangles that touch (share a corner) and emit the same
//! radiance form one **emitter**: a panel, a troffer, a tessellated bulb. At a point `x` with
//! facing normal `n`, each emitter gets a weight, zero only where it cannot reach `x`:
//!
//! - [`DirectSampling::Bounds`] (the default): the light-bounds importance (Conty Estevez and
//!   Kulla 2018; pbrt-v4's `LightBounds::Importance`): power over squared distance times bounds
//!   on the emitter's and the receiver's cosines, each widened by the angle the emitter's
//!   bounding sphere subtends (`importance`). A tessellated sphere ([`sphere_like`]) seen from
//!   outside its bounding sphere is sampled by a direction uniform in that sphere's cone
//!   ([`Sampled::Cone`]), whose shadow ray must meet the emitter first.
//! - [`DirectSampling::PowerOverDistance`] (the earlier estimator, kept as the baseline): power
//!   over squared distance, `Phi / max(d^2, r^2)` (`r` the emitter's bounding radius), zero for
//!   an emitter behind `x`'s tangent plane or with `x` behind it.
//!
//! Within an emitter: a triangle by power, then a point uniform in its area, unless the emitter
//! is coned or sampled by solid angle (below). The integrator either chooses an emitter per
//! sample by the weights ([`Lights::sample`]) or samples every emitter that can reach `x` on its
//! own ([`Lights::sample_emitter`]; `integrator::direct_irradiance`).
//!
//! Above [`MAX_WEIGHED`] emitters the per-point weights would cost more than they save, and the
//! choice falls back to power alone.
//!
//! **Near emitters by solid angle.** Next to an emitter ([`NEAR`]) a point uniform in its area
//! carries `1 / dist^2` that varies by more than 4x over it: one sample is noisy, and many are
//! needed for a quiet estimate. An emitter of at most
//! [`SOLID_ANGLE_MAX`] triangles is sampled by solid angle there instead: a triangle with
//! probability proportional to the solid angle it subtends (Van Oosterom and Strackee's formula,
//! in f32 where the emitter and the chosen triangle subtend at least [`F32_MIN`], else in f64;
//! zero for a triangle `x` is behind), then a direction uniform in that spherical
//! triangle (Arvo, "Stratified sampling of spherical triangles", SIGGRAPH 1995), and the point
//! where it meets the triangle. The density per unit area is `p_emitter |cos_l| / (s^2 Omega)`
//! (`Omega` the emitter's solid angle, `s` the distance), so a sample's contribution is
//! `L cos_x Omega / p_emitter`: the inverse square is gone from the noise. A triangle too small
//! for Arvo's construction in floating point ([`ARVO_MIN`]) is sampled by area inside, with the
//! density that says so: the estimate stays unbiased either way. Emitters of more triangles (the
//! office's bulb, 528) keep area sampling, and [`LightChoice::near`] tells the integrator so.
//!
//! **The control variate.** [`Lights::unoccluded_irradiance`]: an emitter's exact irradiance were
//! nothing in the way, the mean of its point samples' unoccluded contributions.

use super::colour::luminance;
use glam::{DVec3, Vec3};
use std::collections::HashMap;

/// Most emitters weighed per shading point; more fall back to choice by power.
pub const MAX_WEIGHED: usize = 64;

/// Most triangles of an emitter sampled by solid angle where it is near (module doc).
pub const SOLID_ANGLE_MAX: usize = 8;

/// Smallest solid angle (sr) of one triangle sampled by Arvo's construction; smaller ones are
/// sampled by area inside (module doc).
pub const ARVO_MIN: f64 = 1e-5;

/// An emissive triangle.
#[derive(Clone, Copy, Debug)]
pub struct Light {
    /// Corners in winding order.
    pub corners: [Vec3; 3],
    /// Emitting (unit) normal.
    pub normal: Vec3,
    /// Area.
    pub area: f32,
    /// Emitted radiance.
    pub emission: Vec3,
}

/// Touching emissive triangles of one radiance.
#[derive(Clone, Copy, Debug)]
struct Emitter {
    center: Vec3,
    radius: f32,
    power: f32,
    /// The normal every triangle shares, when they do.
    normal: Option<Vec3>,
    /// Every corner lies in the plane through `center` normal to `normal`.
    flat: bool,
    /// The cone that bounds the triangles' normals: its axis and the cosine of its half-angle
    /// (-1: every direction).
    axis: Vec3,
    cos_o: f32,
    /// A tessellated sphere ([`sphere_like`]): its centre and the radius bounding its corners.
    sphere: Option<(Vec3, f32)>,
    first: usize,
    count: usize,
}

/// How the direct light is sampled ([`crate::RenderSettings::direct`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DirectSampling {
    /// Emitters weighed by an importance with both cosines (pbrt-v4's light-bounds importance);
    /// where the samples are at least the emitters that can reach the point, every one of them
    /// gets its share, at least one; a tessellated sphere is sampled by directions in its cone.
    #[default]
    Bounds,
    /// The earlier estimator, kept as the baseline the measurements compare with: one choice
    /// of emitter per sample, by power over squared distance; spheres sampled by area.
    PowerOverDistance,
}

impl DirectSampling {
    /// The name, as the experiments print it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Bounds => "bounds",
            Self::PowerOverDistance => "power/d2",
        }
    }
}

/// A closed mesh of triangles around one centre: every corner within 2% of one distance from
/// it and every triangle facing away from it (a tessellated bulb).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereLike {
    /// The centre (the mean of the distinct corners).
    pub center: Vec3,
    /// The largest distance of a corner from the centre: the sphere holds every triangle.
    pub bound: f32,
    /// The radius of the sphere whose area the triangles have.
    pub area_radius: f32,
}

/// Whether `triangles` (corners in winding order) tessellate a sphere: at least 8 of them, every
/// edge shared by exactly two, every corner within 2% of the mean distance from the corners'
/// centre, every triangle's wound normal pointing away from it.
pub fn sphere_like(triangles: &[[Vec3; 3]]) -> Option<SphereLike> {
    use glam::DVec3;
    if triangles.len() < 8 {
        return None;
    }
    let key = |v: Vec3| v.to_array().map(f32::to_bits);
    let mut edges: HashMap<([u32; 3], [u32; 3]), u32> = HashMap::new();
    let mut corners: HashMap<[u32; 3], DVec3> = HashMap::new();
    for t in triangles {
        for e in 0..3 {
            let (a, b) = (key(t[e]), key(t[(e + 1) % 3]));
            *edges
                .entry(if a < b { (a, b) } else { (b, a) })
                .or_default() += 1;
            corners.insert(a, t[e].as_dvec3());
        }
    }
    if edges.values().any(|&n| n != 2) {
        return None;
    }
    let center = corners.values().sum::<DVec3>() / corners.len() as f64;
    let dist: Vec<f64> = corners.values().map(|v| v.distance(center)).collect();
    let mean = dist.iter().sum::<f64>() / dist.len() as f64;
    if dist.iter().any(|d| (d - mean).abs() > 0.02 * mean) {
        return None;
    }
    let mut area = 0.0;
    for t in triangles {
        let [a, b, c] = t.map(Vec3::as_dvec3);
        let n = (b - a).cross(c - a);
        if n.dot((a + b + c) / 3.0 - center) <= 0.0 {
            return None;
        }
        area += 0.5 * n.length();
    }
    Some(SphereLike {
        center: center.as_vec3(),
        bound: dist.iter().copied().fold(0.0, f64::max) as f32,
        area_radius: (area / (4.0 * std::f64::consts::PI)).sqrt() as f32,
    })
}

/// A sampled point on a light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// The point.
    pub point: Vec3,
    /// The light's emitting normal.
    pub normal: Vec3,
    /// Emitted radiance.
    pub emission: Vec3,
    /// Probability density of the sample per unit area (emitter and triangle choice included).
    pub pdf_area: f32,
}

/// A light sample: a point on an emitter, or a direction in a sphere's cone whose shadow ray
/// finds the point (and whether the emitter is what it meets first).
#[derive(Clone, Copy, Debug)]
pub enum Sampled {
    /// A point, with its density per unit area.
    Point(LightSample),
    /// A direction uniform in the cone that bounds emitter `emitter` (a tessellated sphere) seen
    /// from the shading point, with its density per unit solid angle: the light arrives along it
    /// when the first thing the ray meets is a front face of that emitter.
    Cone {
        /// Unit direction from the shading point.
        dir: Vec3,
        /// The emitter's radiance.
        emission: Vec3,
        /// Density per unit solid angle (emitter choice included).
        pdf_dir: f32,
        /// The emitter the ray must meet.
        emitter: u32,
        /// How far the ray can meet it: to the far side of its bounding sphere.
        t_max: f32,
    },
}

/// The lights of a scene, grouped into emitters.
#[derive(Clone, Debug)]
pub struct Lights {
    /// Triangles, emitter by emitter.
    lights: Vec<Light>,
    /// Per triangle: the cumulative share of its emitter's power, up to and including it.
    within: Vec<f32>,
    emitters: Vec<Emitter>,
    /// Cumulative share of the total power per emitter (the fallback choice).
    by_power: Vec<f32>,
    /// The emitter of each light as [`Lights::new`] was given them.
    emitter_of: Vec<u32>,
}

/// The emitter probabilities at one shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightChoice {
    /// Cumulative, normalised; empty when no emitter can light the point.
    cdf: [f32; MAX_WEIGHED],
    len: usize,
    /// Choice by power ([`Lights::by_power`]) instead of `cdf`.
    by_power: bool,
    /// Some emitter that can light the point is near it ([`NEAR`]) and is sampled by area.
    near: bool,
    /// Bit `k`: emitter `k` is near and sampled by solid angle ([`SOLID_ANGLE_MAX`]).
    by_solid_angle: u64,
    /// The shading point.
    x: Vec3,
    /// How the point's light is sampled.
    sampling: DirectSampling,
}

/// An emitter is near a point when its farthest point may be more than this many times as far as
/// its nearest (bounds: `d + r` against `max(d - r, h)`, `d` the distance to its centre, `r` its
/// bounding radius, `h` the distance to its plane when it is flat): one point sample's
/// `1 / dist^2` then varies by more than 4x over the emitter.
pub const NEAR: f32 = 2.0;

impl LightChoice {
    /// No emitter can light the point (what [`Lights::choice_into`] overwrites).
    pub const fn empty() -> Self {
        Self {
            cdf: [0.0; MAX_WEIGHED],
            len: 0,
            by_power: false,
            near: false,
            by_solid_angle: 0,
            x: Vec3::ZERO,
            sampling: DirectSampling::Bounds,
        }
    }

    /// The emitters that can reach the point with their probabilities (none under the
    /// fallback choice by power, which weighs every emitter everywhere).
    pub fn reachable(&self) -> impl Iterator<Item = (usize, f32)> + '_ {
        let cdf = if self.by_power {
            &[][..]
        } else {
            &self.cdf[..self.len]
        };
        cdf.iter().enumerate().filter_map(|(k, &c)| {
            let p = c - if k == 0 { 0.0 } else { cdf[k - 1] };
            (p > 0.0).then_some((k, p))
        })
    }

    /// How many emitters can reach the point (0 under the fallback choice by power).
    pub fn reachable_count(&self) -> usize {
        self.reachable().count()
    }

    /// How the point's light is sampled.
    pub fn sampling(&self) -> DirectSampling {
        self.sampling
    }

    /// True when an emitter that can light the point is near it ([`NEAR`]) and too large to be
    /// sampled by solid angle ([`SOLID_ANGLE_MAX`]): single light samples are noisy there, and
    /// the integrator takes more.
    pub fn near(&self) -> bool {
        self.near
    }

    /// True when some emitter is sampled by solid angle at this point.
    pub fn by_solid_angle(&self) -> bool {
        self.by_solid_angle != 0
    }
}

/// The two spherical-triangle routines, written once and generated for `f64` (`DVec3`) and for
/// `f32` (`Vec3`): the light sampler takes `f32` where a triangle subtends enough solid angle for
/// it ([`F32_MIN`]) and `f64` below.
///
/// * `solid_angle(a, b, c)`: the solid angle of the triangle `a b c` seen from the origin, corners
///   relative to it (Van Oosterom and Strackee, 1983): `tan(Omega / 2) = |a . (b x c)| /
///   (|a||b||c| + (a.b)|c| + (a.c)|b| + (b.c)|a|)`.
/// * `arvo(a, b, c, area, u1, u2)`: a direction uniform in the spherical triangle of the unit
///   vectors `a b c` of solid angle `area` for `u1, u2` in `[0, 1)` (Arvo 1995): `u1` chooses the
///   sub-triangle `a b c'` of area `u1` times the whole, `u2` the point on the arc from `b` to
///   `c'`, its `1 - cos` from `b` uniform. `None` when the construction fails in floating point.
///   The area is the caller's `solid_angle`, which it has for the choice of triangle anyway:
///   Arvo's own `alpha + beta + gamma - pi` would cost two more arc cosines and cancels where the
///   triangle is small.
macro_rules! spherical_triangle {
    ($solid_angle:ident, $arvo:ident, $v:ty, $f:ty) => {
        fn $solid_angle(a: $v, b: $v, c: $v) -> $f {
            let (la, lb, lc) = (a.length(), b.length(), c.length());
            let num = a.dot(b.cross(c)).abs();
            let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
            // atan2 keeps the half angle in (0, pi) when the denominator is negative (Omega > pi).
            2.0 * num.atan2(den)
        }

        fn $arvo(a: $v, b: $v, c: $v, area: $f, u1: $f, u2: $f) -> Option<$v> {
            // The angle alpha at a between the great circles to b and to c, through its cosine
            // and sine alone: the unit normals of the two planes through a are alpha apart, and
            // alpha is in [0, pi], so its sine is the length of their cross product. Then sin and
            // cos of `sub - alpha` by the difference formulas: one sin_cos, no arc cosine.
            let (n1, n2) = (a.cross(b).normalize(), a.cross(c).normalize());
            let cos_alpha = n1.dot(n2).clamp(-1.0, 1.0);
            let sin_alpha = n1.cross(n2).length().min(1.0);
            let cos_c = a.dot(b);
            let (sin_sub, cos_sub) = (u1 * area).sin_cos();
            let s = sin_sub * cos_alpha - cos_sub * sin_alpha;
            let t = cos_sub * cos_alpha + sin_sub * sin_alpha;
            let u = t - cos_alpha;
            let v = s + sin_alpha * cos_c;
            let q = ((v * t - u * s) * cos_alpha - v) / ((v * s + u * t) * sin_alpha);
            let q = q.clamp(-1.0, 1.0);
            let c1 = q * a + (1.0 - q * q).max(0.0).sqrt() * (c - c.dot(a) * a).normalize();
            let z = 1.0 - u2 * (1.0 - c1.dot(b));
            let w = z * b + (1.0 - z * z).max(0.0).sqrt() * (c1 - c1.dot(b) * b).normalize();
            w.is_finite().then_some(w)
        }
    };
}

spherical_triangle!(solid_angle, arvo, glam::DVec3, f64);
spherical_triangle!(solid_angle_f32, arvo_f32, Vec3, f32);

/// The solid-angle sampler of [`Lights::sample_solid_angle`] in one float width (`$v`, `$f`,
/// with that width's [`spherical_triangle`] routines): `Err(TooNarrow)` when the emitter or the
/// chosen triangle subtends less than `$narrow` (the caller then takes the wider width).
macro_rules! solid_angle_sampler {
    ($name:ident, $solid_angle:ident, $arvo:ident, $v:ty, $f:ty, $narrow:expr) => {
        fn $name(
            &self,
            e: &Emitter,
            x: Vec3,
            p_emitter: f32,
            u: [f32; 3],
        ) -> Result<Option<Option<LightSample>>, TooNarrow> {
            let narrow: $f = $narrow;
            let tris = &self.lights[e.first..e.first + e.count];
            let xv = <$v>::from(x.to_array().map(<$f>::from));
            let rel = |p: Vec3| <$v>::from(p.to_array().map(<$f>::from)) - xv;
            let mut omega: [$f; SOLID_ANGLE_MAX] = [0.0; SOLID_ANGLE_MAX];
            let mut total: $f = 0.0;
            for (o, l) in omega.iter_mut().zip(tris) {
                // One-sided: a triangle x is behind (or in the plane of) sends nothing to x.
                if l.normal.dot(x - l.corners[0]) > 0.0 {
                    let [a, b, c] = l.corners.map(rel);
                    *o = $solid_angle(a, b, c);
                }
                total += *o;
            }
            if narrow > 0.0 && !(total >= narrow && total.is_finite()) {
                return Err(TooNarrow);
            }
            if !(total > 0.0 && total.is_finite()) {
                return Ok(None);
            }
            let target = <$f>::from(u[0]) * total;
            let mut acc = 0.0;
            let mut t = 0;
            for (k, &o) in omega[..tris.len()].iter().enumerate() {
                if o > 0.0 {
                    t = k;
                    if acc + o > target {
                        break;
                    }
                }
                acc += o;
            }
            if omega[t] < narrow {
                return Err(TooNarrow);
            }
            let l = &tris[t];
            let p_tri = omega[t] / total;
            if f64::from(omega[t]) < ARVO_MIN {
                // Too small for Arvo in floating point: uniform in area inside, density
                // p_tri / area.
                let (s, w) = (u[1].sqrt(), u[2]);
                let [a, b, c] = l.corners;
                return Ok(Some(Some(LightSample {
                    point: a * (1.0 - s) + b * (s * (1.0 - w)) + c * (s * w),
                    normal: l.normal,
                    emission: l.emission,
                    pdf_area: p_emitter * (p_tri as f32) / l.area,
                })));
            }
            let [a, b, c] = l.corners.map(|p| rel(p).normalize());
            let Some(w) = $arvo(a, b, c, omega[t], <$f>::from(u[1]), <$f>::from(u[2])) else {
                return Ok(Some(None));
            };
            // Where the direction meets the triangle's plane.
            let nl = <$v>::from(l.normal.to_array().map(<$f>::from));
            let cos_l = nl.dot(w);
            let dist = nl.dot(rel(l.corners[0])) / cos_l;
            if !(dist > 0.0 && dist.is_finite()) {
                return Ok(Some(None));
            }
            let point = xv + w * dist;
            // Per unit solid angle p_emitter * p_tri / omega_t = p_emitter / total; per unit area
            // times |cos_l| / dist^2.
            let pdf_area = <$f>::from(p_emitter) * cos_l.abs() / (dist * dist * total);
            Ok(Some(Some(LightSample {
                point: Vec3::from(point.to_array().map(|c| c as f32)),
                normal: l.normal,
                emission: l.emission,
                pdf_area: pdf_area as f32,
            })))
        }
    };
}

/// A solid-angle sample that wants a wider float than the one tried.
struct TooNarrow;

/// The earlier weight: power over squared distance, zero where no point of the emitter lies
/// above `x`'s tangent plane or `x` lies behind every point of a flat emitter (`d` from `x` to
/// the emitter's centre).
fn power_over_distance(e: &Emitter, d: Vec3, n: Vec3) -> f32 {
    let behind_x = n.dot(d) <= -e.radius;
    let behind_light = match (e.flat, e.normal) {
        (true, Some(nl)) => nl.dot(-d) <= 0.0,
        (false, Some(nl)) => nl.dot(-d) <= -e.radius,
        _ => false,
    };
    if behind_x || behind_light {
        return 0.0;
    }
    e.power / d.length_squared().max(e.radius * e.radius).max(1e-12)
}

/// `cos(max(0, theta_a - theta_b))` from the cosines and sines of both angles (in `[0, pi]`):
/// the cosine of how far angle `a` exceeds `b`, 1 when it does not.
#[inline]
fn cos_beyond(cos_a: f32, sin_a: f32, cos_b: f32, sin_b: f32) -> (f32, f32) {
    if cos_a >= cos_b {
        return (1.0, 0.0);
    }
    (
        cos_a * cos_b + sin_a * sin_b,
        (sin_a * cos_b - cos_a * sin_b).max(0.0),
    )
}

/// The light-bounds importance of emitter `e` at `x` with facing normal `n` (Conty Estevez and
/// Kulla 2018, as pbrt-v4's `LightBounds::Importance` states it): power over squared distance,
/// times a bound on the emitter's cosine (the angle from its normals' cone to `x`, less the
/// angle the emitter's bounding sphere subtends) and a bound on the receiver's (the angle from
/// `n` to the emitter, less the same). Zero only where no point of the emitter can send light to
/// `x`'s hemisphere; the emitters here emit from their front, into a half-angle of 90 degrees.
fn importance(e: &Emitter, x: Vec3, n: Vec3) -> f32 {
    let d = x - e.center;
    let d2 = d.length_squared();
    let dist = d2.sqrt();
    if dist <= e.radius {
        // Inside the bounding sphere: every direction may carry light.
        return e.power / (e.radius * e.radius).max(1e-12);
    }
    let wi = d / dist;
    let sin_b = e.radius / dist;
    let cos_b = (1.0 - sin_b * sin_b).max(0.0).sqrt();
    // The emitter's side: the angle from the normals' cone's axis to x, beyond the cone and the
    // bounding angle.
    let cos_w = e.axis.dot(wi);
    let cos_e = if e.cos_o <= -1.0 {
        1.0
    } else {
        let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
        let sin_o = (1.0 - e.cos_o * e.cos_o).max(0.0).sqrt();
        let (c, s) = cos_beyond(cos_w, sin_w, e.cos_o, sin_o);
        cos_beyond(c, s, cos_b, sin_b).0
    };
    if cos_e <= 0.0 {
        return 0.0;
    }
    // The receiver's side: the angle from n to the emitter, beyond the bounding angle.
    let cos_i = -n.dot(wi);
    let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
    let cos_r = cos_beyond(cos_i, sin_i, cos_b, sin_b).0;
    if cos_r <= 0.0 {
        return 0.0;
    }
    e.power * cos_e * cos_r / d2
}

/// For a tessellated sphere seen from outside its bounding sphere: the unit direction from `x` to
/// its centre, `1 - cos` of the half-angle the bounding sphere subtends, and the distance to the
/// sphere's far side (no ray in the cone meets the emitter beyond it).
#[inline]
fn cone_of(e: &Emitter, x: Vec3) -> Option<(Vec3, f32, f32)> {
    let (c, r) = e.sphere?;
    let d = c - x;
    let d2 = d.length_squared();
    let sin2 = r * r / d2;
    // Inside (or nearly on) the bounding sphere, or a NaN: no cone.
    if sin2.is_nan() || sin2 >= 0.999 {
        return None;
    }
    // 1 - cos = sin^2 / (1 + cos), without the cancellation of 1 - cos for small cones.
    let one_minus_cos = sin2 / (1.0 + (1.0 - sin2).sqrt());
    let dist = d2.sqrt();
    Some((d / dist, one_minus_cos, (dist + r) * (1.0 + 1e-4)))
}

/// Most triangles of an emitter whose unoccluded irradiance the integrator computes exactly, as
/// the control variate of its samples ([`Lights::unoccluded_irradiance`]); the quads and panels
/// of the scenes here have two.
pub const CONTROL_MAX: usize = SOLID_ANGLE_MAX;

/// `integral of cos(n, w) dw` over the part of triangle `corners` (relative to the shading point)
/// above the plane normal to `n`: the triangle clipped to the point's upper hemisphere, then
/// Lambert's formula for a polygon, half the sum over its edges of the angle the edge subtends
/// times `n` dotted with the unit normal of the plane through the edge and the point. In `f64`:
/// for a small or far triangle the edge terms are of first order in its angular size and their
/// sum of second, and an `f32` version tried here erred by 0.3% to far more on random small
/// triangles at scene-sized coordinates. `None` when a corner (or a clipped one) is at the point.
pub(crate) fn projected_solid_angle(corners: [DVec3; 3], n: DVec3) -> Option<f64> {
    // Sutherland-Hodgman against one plane: a triangle becomes at most a quadrilateral.
    let mut poly = [DVec3::ZERO; 4];
    let mut m = 0;
    for i in 0..3 {
        let (a, b) = (corners[i], corners[(i + 1) % 3]);
        let (da, db) = (n.dot(a), n.dot(b));
        if da >= 0.0 {
            poly[m] = a;
            m += 1;
        }
        if (da >= 0.0) != (db >= 0.0) {
            poly[m] = a + (b - a) * (da / (da - db));
            m += 1;
        }
    }
    if m < 3 {
        return Some(0.0);
    }
    for p in &mut poly[..m] {
        let len2 = p.length_squared();
        if len2 < 1e-24 {
            return None;
        }
        *p /= len2.sqrt();
    }
    let mut sum = 0.0;
    for i in 0..m {
        let (a, b) = (poly[i], poly[(i + 1) % m]);
        let c = a.cross(b);
        let len = c.length();
        if len > 0.0 {
            sum += len.atan2(a.dot(b)) * n.dot(c) / len;
        }
    }
    Some(0.5 * sum.abs())
}

/// Smallest solid angle (sr) an emitter and the triangle chosen in it subtend for the sampler to
/// work in `f32`; below, `f64`. At `1e-2` sr the triangle spans about a tenth of a radian, where
/// `f32`'s rounding (`6e-8`) moves a sampled direction by about `1e-6` of that span.
pub const F32_MIN: f32 = 1e-2;

impl Lights {
    /// Groups `lights` into emitters. Empty when `lights` is.
    pub fn new(lights: Vec<Light>) -> Self {
        // Union-find over shared corners of equal radiance.
        let mut parent: Vec<usize> = (0..lights.len()).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        let mut corner = HashMap::new();
        for (i, l) in lights.iter().enumerate() {
            for c in l.corners {
                let key = (
                    c.to_array().map(f32::to_bits),
                    l.emission.to_array().map(f32::to_bits),
                );
                let j = *corner.entry(key).or_insert(i);
                let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                parent[a.max(b)] = a.min(b);
            }
        }
        let mut order: Vec<usize> = (0..lights.len()).collect();
        let roots: Vec<usize> = (0..lights.len()).map(|i| root(&mut parent, i)).collect();
        order.sort_by_key(|&i| (roots[i], i));
        let lights: Vec<Light> = order.iter().map(|&i| lights[i]).collect();
        let roots: Vec<usize> = order.iter().map(|&i| roots[i]).collect();

        let mut emitters = Vec::new();
        let mut within = vec![0.0; lights.len()];
        let mut start = 0;
        while start < lights.len() {
            let mut end = start;
            while end < lights.len() && roots[end] == roots[start] {
                end += 1;
            }
            let group = &lights[start..end];
            let (lo, hi) = group.iter().flat_map(|l| l.corners).fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), p| (lo.min(p), hi.max(p)),
            );
            let center = 0.5 * (lo + hi);
            let radius = group
                .iter()
                .flat_map(|l| l.corners)
                .map(|p| p.distance(center))
                .fold(0.0, f32::max);
            let power: f64 = group
                .iter()
                .map(|l| f64::from(luminance(l.emission) * l.area))
                .sum();
            let mut acc = 0.0f64;
            for (k, l) in group.iter().enumerate() {
                acc += f64::from(luminance(l.emission) * l.area);
                within[start + k] = (acc / power) as f32;
            }
            within[end - 1] = 1.0;
            let n0 = group[0].normal;
            let normal = group
                .iter()
                .all(|l| l.normal.dot(n0) > 0.9999)
                .then_some(n0);
            let flat = normal.is_some_and(|nl| {
                group
                    .iter()
                    .flat_map(|l| l.corners)
                    .all(|p| nl.dot(p - center).abs() <= 1e-5 * radius.max(1e-12))
            });
            // The normals' cone: around their area-weighted mean, as wide as the farthest one
            // (every direction when they cancel, as a sphere's do).
            let sum: Vec3 = group.iter().map(|l| l.normal * l.area).sum();
            let axis = sum.normalize_or_zero();
            let cos_o = if axis == Vec3::ZERO {
                -1.0
            } else {
                group
                    .iter()
                    .map(|l| l.normal.dot(axis))
                    .fold(1.0f32, f32::min)
                    .max(-1.0)
            };
            let corners: Vec<[Vec3; 3]> = group.iter().map(|l| l.corners).collect();
            let sphere = sphere_like(&corners).map(|s| (s.center, s.bound));
            emitters.push(Emitter {
                center,
                radius,
                power: power as f32,
                normal,
                flat,
                axis,
                cos_o,
                sphere,
                first: start,
                count: end - start,
            });
            start = end;
        }
        let total: f64 = emitters.iter().map(|e| f64::from(e.power)).sum();
        let mut acc = 0.0f64;
        let mut by_power: Vec<f32> = emitters
            .iter()
            .map(|e| {
                acc += f64::from(e.power);
                (acc / total) as f32
            })
            .collect();
        if let Some(last) = by_power.last_mut() {
            *last = 1.0;
        }
        let mut emitter_of = vec![0u32; lights.len()];
        for (k, e) in emitters.iter().enumerate() {
            for &i in &order[e.first..e.first + e.count] {
                emitter_of[i] = k as u32;
            }
        }
        Self {
            lights,
            within,
            emitters,
            by_power,
            emitter_of,
        }
    }

    /// The emitter of light `i`, numbered as [`Lights::new`] was given them.
    pub fn emitter_of(&self, i: usize) -> u32 {
        self.emitter_of[i]
    }

    /// The emissive triangles, emitter by emitter.
    pub fn triangles(&self) -> &[Light] {
        &self.lights
    }

    /// Emitters (groups of touching emissive triangles of one radiance).
    pub fn emitter_count(&self) -> usize {
        self.emitters.len()
    }

    /// True when there is no light.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// The emitter probabilities at `x` with unit facing normal `n`, sampled as `sampling` says.
    pub fn choice(&self, x: Vec3, n: Vec3, sampling: DirectSampling) -> LightChoice {
        let mut choice = LightChoice::empty();
        self.choice_into(x, n, sampling, &mut choice);
        choice
    }

    /// [`Lights::choice`] written into `choice`, whose earlier contents are overwritten: a caller
    /// that chooses at many points (one per hemisphere hit) keeps one and neither clears nor
    /// copies its 64-entry table each time.
    pub fn choice_into(
        &self,
        x: Vec3,
        n: Vec3,
        sampling: DirectSampling,
        choice: &mut LightChoice,
    ) {
        self.weigh_into(x, n, sampling, sampling == DirectSampling::Bounds, choice);
    }

    fn weigh_into(
        &self,
        x: Vec3,
        n: Vec3,
        sampling: DirectSampling,
        by_importance: bool,
        choice: &mut LightChoice,
    ) {
        choice.len = 0;
        choice.by_power = self.emitters.len() > MAX_WEIGHED;
        choice.near = false;
        choice.by_solid_angle = 0;
        choice.x = x;
        choice.sampling = sampling;
        if choice.by_power {
            return;
        }
        let mut total = 0.0f32;
        for (k, e) in self.emitters.iter().enumerate() {
            let d = e.center - x;
            // With one emitter only whether it can reach x matters, and the cheaper test of
            // the two (both are zero only where it cannot) answers that.
            let weight = if by_importance && self.emitters.len() > 1 {
                importance(e, x, n)
            } else {
                power_over_distance(e, d, n)
            };
            if weight > 0.0 {
                total += weight;
                let dist = d.length();
                let plane = match (e.flat, e.normal) {
                    (true, Some(nl)) => nl.dot(-d).abs(),
                    _ => 0.0,
                };
                let nearest = (dist - e.radius).max(plane);
                let coned = sampling == DirectSampling::Bounds && cone_of(e, x).is_some();
                if dist + e.radius > NEAR * nearest && !coned {
                    // MAX_WEIGHED <= 64: k fits the bit set.
                    if e.count <= SOLID_ANGLE_MAX {
                        choice.by_solid_angle |= 1 << k;
                    } else {
                        choice.near = true;
                    }
                }
            }
            choice.cdf[k] = total;
        }
        if total > 0.0 && total.is_finite() {
            choice.len = self.emitters.len();
            for c in &mut choice.cdf[..choice.len] {
                *c /= total;
            }
            choice.cdf[choice.len - 1] = 1.0;
        }
    }

    /// The irradiance emitter `k` would bring to `x` (unit facing normal `n`) if nothing blocked
    /// it: its radiance times the projected solid angle of each of its triangles that `x` is in
    /// front of, clipped to `x`'s upper hemisphere. It is the mean of what
    /// [`Lights::sample_emitter`]'s point samples would bring unoccluded (a sample's emission
    /// times its geometry term over its density, zero behind either surface), so the integrator
    /// uses it as their control variate. `None` where that does not hold or it is not worth its
    /// cost: an emitter sampled by cone at `x`, one of more than [`CONTROL_MAX`] triangles, or a
    /// corner at `x`.
    pub fn unoccluded_irradiance(
        &self,
        choice: &LightChoice,
        k: usize,
        x: Vec3,
        n: Vec3,
    ) -> Option<Vec3> {
        let e = &self.emitters[k];
        let coned = choice.sampling == DirectSampling::Bounds && cone_of(e, x).is_some();
        if e.count > CONTROL_MAX || coned {
            return None;
        }
        let (xd, nd) = (x.as_dvec3(), n.as_dvec3());
        let mut sum = 0.0f64;
        for l in &self.lights[e.first..e.first + e.count] {
            let rel = l.corners.map(|c| c.as_dvec3() - xd);
            // One-sided: only a triangle whose emitting side faces x.
            if l.normal.as_dvec3().dot(rel[0]) >= 0.0 {
                continue;
            }
            sum += projected_solid_angle(rel, nd)?;
        }
        Some(self.lights[e.first].emission * sum as f32)
    }

    /// The light point for the uniform numbers `u` in `[0, 1)^3` under `choice`: `u[0]` chooses
    /// the emitter and then its triangle, `u[1]` and `u[2]` the point in the triangle (or the
    /// direction in a sphere's cone), so stratifying `u` stratifies the samples. `None` when no
    /// emitter can light the point.
    #[inline]
    pub fn sample(&self, choice: &LightChoice, u: [f32; 3]) -> Option<Sampled> {
        let cdf: &[f32] = if choice.by_power {
            &self.by_power
        } else {
            &choice.cdf[..choice.len]
        };
        let k = cdf
            .partition_point(|&c| c <= u[0])
            .min(cdf.len().checked_sub(1)?);
        let lo = if k == 0 { 0.0 } else { cdf[k - 1] };
        let p_emitter = cdf[k] - lo;
        if p_emitter <= 0.0 {
            return None;
        }
        // Reuse u[0] inside the emitter's interval for the triangle.
        let v = ((u[0] - lo) / p_emitter).clamp(0.0, 1.0 - f32::EPSILON);
        self.sample_emitter(choice, k, p_emitter, [v, u[1], u[2]])
    }

    /// A sample of emitter `k` alone for the uniform numbers `u`, its density multiplied by
    /// `p_emitter` (1: the emitter is sampled for itself, not chosen): a direction in its cone
    /// when it is a tessellated sphere seen from outside its bounding sphere (under
    /// [`DirectSampling::Bounds`]), else by solid angle where it is near and small enough, else a
    /// triangle by power and a point uniform in its area.
    #[inline]
    pub fn sample_emitter(
        &self,
        choice: &LightChoice,
        k: usize,
        p_emitter: f32,
        u: [f32; 3],
    ) -> Option<Sampled> {
        let e = &self.emitters[k];
        if choice.sampling == DirectSampling::Bounds {
            if let Some((axis, one_minus_cos, t_max)) = cone_of(e, choice.x) {
                // Uniform in the cone: 1 - cos(theta) uniform in [0, 1 - cos(theta_max)].
                let t = u[1] * one_minus_cos;
                let cos = 1.0 - t;
                let sin = (t * (2.0 - t)).max(0.0).sqrt();
                let (sp, cp) = (std::f32::consts::TAU * u[2]).sin_cos();
                let (a, b) = axis.any_orthonormal_pair();
                let dir = (a * (cp * sin) + b * (sp * sin) + axis * cos).normalize();
                return Some(Sampled::Cone {
                    dir,
                    emission: self.lights[e.first].emission,
                    pdf_dir: p_emitter / (std::f32::consts::TAU * one_minus_cos),
                    emitter: k as u32,
                    t_max,
                });
            }
        }
        if choice.by_solid_angle >> k & 1 == 1 {
            if let Some(s) = self.sample_solid_angle(e, choice.x, p_emitter, u) {
                return s.map(Sampled::Point);
            }
        }
        let within = &self.within[e.first..e.first + e.count];
        let t = within.partition_point(|&c| c <= u[0]).min(e.count - 1);
        let p_tri = within[t] - if t == 0 { 0.0 } else { within[t - 1] };
        let l = &self.lights[e.first + t];
        let (s, w) = (u[1].sqrt(), u[2]);
        let [a, b, c] = l.corners;
        Some(Sampled::Point(LightSample {
            point: a * (1.0 - s) + b * (s * (1.0 - w)) + c * (s * w),
            normal: l.normal,
            emission: l.emission,
            pdf_area: p_emitter * p_tri / l.area,
        }))
    }

    /// A point of emitter `e` (chosen with probability `p_emitter`) sampled by solid angle from
    /// `x` (module doc): `u[0]` chooses the triangle, `u[1]` and `u[2]` the direction in it.
    /// `None` when the emitter subtends no measurable solid angle (the caller samples by area);
    /// `Some(None)` when this one direction failed in floating point. In `f32` when the emitter
    /// and the chosen triangle subtend at least [`F32_MIN`], else in `f64`.
    fn sample_solid_angle(
        &self,
        e: &Emitter,
        x: Vec3,
        p_emitter: f32,
        u: [f32; 3],
    ) -> Option<Option<LightSample>> {
        self.sample_solid_angle_f32(e, x, p_emitter, u)
            .unwrap_or_else(|TooNarrow| {
                self.sample_solid_angle_f64(e, x, p_emitter, u)
                    .unwrap_or_else(|TooNarrow| unreachable!("f64 takes every width"))
            })
    }

    solid_angle_sampler!(
        sample_solid_angle_f64,
        solid_angle,
        arvo,
        glam::DVec3,
        f64,
        0.0
    );
    solid_angle_sampler!(
        sample_solid_angle_f32,
        solid_angle_f32,
        arvo_f32,
        Vec3,
        f32,
        F32_MIN
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The point of a sample that is one (these tests sample no sphere by cone).
    fn point(s: Sampled) -> LightSample {
        match s {
            Sampled::Point(p) => p,
            Sampled::Cone { .. } => panic!("a cone sample"),
        }
    }

    fn tri(a: Vec3, b: Vec3, c: Vec3, e: f32) -> Light {
        let cross = (b - a).cross(c - a);
        Light {
            corners: [a, b, c],
            normal: cross.normalize(),
            area: 0.5 * cross.length(),
            emission: Vec3::splat(e),
        }
    }

    /// Two downward unit squares (two triangles each) at y = 1, one at x = 0 and one at x = 10,
    /// plus a third square touching the first but brighter (a separate emitter).
    fn three() -> Lights {
        let v = Vec3::new;
        let square = |x: f32, e: f32| {
            [
                tri(
                    v(x, 1.0, 0.0),
                    v(x + 1.0, 1.0, 0.0),
                    v(x + 1.0, 1.0, 1.0),
                    e,
                ),
                tri(v(x, 1.0, 0.0), v(x + 1.0, 1.0, 1.0), v(x, 1.0, 1.0), e),
            ]
        };
        let mut all = Vec::new();
        all.extend(square(0.0, 1.0));
        all.extend(square(10.0, 1.0));
        all.extend(square(1.0, 2.0));
        // Wound (a, a + x, a + x + z): the normal points down (-y).
        Lights::new(all)
    }

    #[test]
    fn touching_triangles_of_one_radiance_form_one_emitter() {
        let lights = three();
        assert_eq!(lights.triangles().len(), 6);
        assert_eq!(lights.emitter_count(), 3, "{:?}", lights.emitters);
        for e in &lights.emitters {
            assert_eq!(e.count, 2);
            assert!(e.normal.is_some_and(|n| n.y < -0.99));
        }
    }

    #[test]
    fn the_near_emitter_is_chosen_and_an_unreachable_one_never() {
        let lights = three();
        // Under the first square: the far one (x = 10) gets about 1/100 of its share.
        let c = lights.choice(
            Vec3::new(0.5, 0.0, 0.5),
            Vec3::Y,
            DirectSampling::PowerOverDistance,
        );
        let p = |k: usize| c.cdf[k] - if k == 0 { 0.0 } else { c.cdf[k - 1] };
        let (first, far, bright) = (p(0), p(1), p(2));
        let total = first + far + bright;
        assert!((total - 1.0).abs() < 1e-5);
        assert!(first > 0.4 && far < 0.02, "{first} {far} {bright}");
        // Facing down, below every light: nothing can light the point.
        let none = lights.choice(
            Vec3::new(0.5, 0.0, 0.5),
            -Vec3::Y,
            DirectSampling::PowerOverDistance,
        );
        assert!(lights.sample(&none, [0.3, 0.5, 0.5]).map(point).is_none());
        // Above the lights (behind them): nothing either.
        let above = lights.choice(
            Vec3::new(0.5, 2.0, 0.5),
            -Vec3::Y,
            DirectSampling::PowerOverDistance,
        );
        assert!(lights.sample(&above, [0.3, 0.5, 0.5]).map(point).is_none());
    }

    /// A downward `n x n` grid of unit-square cells (two triangles each) at `y = 1` over
    /// `[0, n]^2`: one emitter of `2 n^2` triangles.
    fn grid(n: usize) -> Lights {
        let v = Vec3::new;
        let mut all = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let (x, z) = (i as f32 / n as f32, j as f32 / n as f32);
                let h = 1.0 / n as f32;
                all.push(tri(
                    v(x, 1.0, z),
                    v(x + h, 1.0, z),
                    v(x + h, 1.0, z + h),
                    1.0,
                ));
                all.push(tri(
                    v(x, 1.0, z),
                    v(x + h, 1.0, z + h),
                    v(x, 1.0, z + h),
                    1.0,
                ));
            }
        }
        Lights::new(all)
    }

    #[test]
    fn near_means_the_inverse_square_varies_over_the_emitter() {
        let lights = three();
        // Just below the first square's edge (x = 0), 5 cm down: near, and two triangles are
        // sampled by solid angle, not flagged for more samples.
        let c = lights.choice(
            Vec3::new(-0.05, 0.95, 0.5),
            Vec3::X,
            DirectSampling::PowerOverDistance,
        );
        assert!(c.by_solid_angle() && !c.near());
        // The same square split into 18 triangles (> SOLID_ANGLE_MAX) keeps area sampling: near.
        let c = grid(3).choice(
            Vec3::new(-0.05, 0.95, 0.5),
            Vec3::X,
            DirectSampling::PowerOverDistance,
        );
        assert!(c.near() && !c.by_solid_angle());
        // 10 below a unit square: 1 / dist^2 varies by a few percent over it.
        let far = Lights::new(lights.triangles()[..2].to_vec());
        let c = far.choice(
            Vec3::new(0.5, -9.0, 0.5),
            Vec3::Y,
            DirectSampling::PowerOverDistance,
        );
        assert!(!c.near() && !c.by_solid_angle());
        // A point in the plane of a flat emitter, beside it, cannot see its lit side: no weight.
        let side = far.choice(
            Vec3::new(3.0, 1.0, 0.5),
            -Vec3::X,
            DirectSampling::PowerOverDistance,
        );
        assert!(far.sample(&side, [0.5, 0.5, 0.5]).map(point).is_none());
    }

    /// Samples of `lights` from `x` under `c` on a stratified grid of `u` (4 choices of triangle
    /// times `n x n` directions), each held to the density `1 / total` per steradian that
    /// sampling uniform in a solid angle of `total` gives.
    fn stratified_samples(
        lights: &Lights,
        c: &LightChoice,
        x: Vec3,
        total: f64,
        n: usize,
    ) -> Vec<LightSample> {
        let mut out = Vec::with_capacity(4 * n * n);
        for (i, j) in (0..n).flat_map(|i| (0..n).map(move |j| (i, j))) {
            for k in 0..4 {
                let u = [
                    (k as f32 + 0.5) / 4.0,
                    (i as f32 + 0.5) / n as f32,
                    (j as f32 + 0.5) / n as f32,
                ];
                let s = lights
                    .sample(c, u)
                    .map(point)
                    .expect("the emitter lights x");
                let d = s.point - x;
                let per_sr = f64::from(s.pdf_area) * f64::from(d.length_squared())
                    / f64::from(s.normal.dot(d.normalize()).abs());
                assert!(
                    (per_sr * total - 1.0).abs() < 1e-3,
                    "density {per_sr} per sr, expected {}",
                    1.0 / total
                );
                out.push(s);
            }
        }
        out
    }

    #[test]
    fn solid_angle_samples_are_uniform_over_the_emitter() {
        // Close under a corner of the unit square: by area, the samples would crowd the far
        // side in solid angle; by solid angle, each region gets its solid-angle share.
        let square = grid(1);
        let x = Vec3::new(0.1, 0.9, 0.15);
        let c = square.choice(x, Vec3::Y, DirectSampling::PowerOverDistance);
        assert!(c.by_solid_angle());
        // Over a steradian: the f32 sampler takes it.
        let e = &square.emitters[0];
        assert!(square.sample_solid_angle_f32(e, x, 1.0, [0.5; 3]).is_ok());
        let rel = |p: Vec3| (p - x).as_dvec3();
        let v = Vec3::new;
        let omega_of = |a: Vec3, b: Vec3, cc: Vec3| solid_angle(rel(a), rel(b), rel(cc));
        let total = omega_of(v(0.0, 1.0, 0.0), v(1.0, 1.0, 0.0), v(1.0, 1.0, 1.0))
            + omega_of(v(0.0, 1.0, 0.0), v(1.0, 1.0, 1.0), v(0.0, 1.0, 1.0));
        // The quarter square nearest x: x, z < 0.5 (a quarter of the area, most of the angle).
        let quarter = omega_of(v(0.0, 1.0, 0.0), v(0.5, 1.0, 0.0), v(0.5, 1.0, 0.5))
            + omega_of(v(0.0, 1.0, 0.0), v(0.5, 1.0, 0.5), v(0.0, 1.0, 0.5));
        let share = quarter / total;
        assert!(share > 0.5, "{share}");
        let samples = stratified_samples(&square, &c, x, total, 96);
        for s in &samples {
            assert!((s.point.y - 1.0).abs() < 1e-5, "{:?}", s.point);
            assert!(s.point.x > -1e-5 && s.point.x < 1.0 + 1e-5, "{:?}", s.point);
            assert!(s.point.z > -1e-5 && s.point.z < 1.0 + 1e-5, "{:?}", s.point);
        }
        let inside = samples
            .iter()
            .filter(|s| s.point.x < 0.5 && s.point.z < 0.5)
            .count();
        let seen = inside as f64 / samples.len() as f64;
        assert!(
            (seen - share).abs() < 0.01,
            "{seen} of the samples in the quarter holding {share} of the solid angle"
        );
    }

    /// A strip 10 long and 1 mm wide, 0.5 below its middle, subtends about 4e-3 sr: too little
    /// for the f32 sampler, so f64 samples it, and its samples must be as uniform in solid angle
    /// as the square's in f32 (the middle metre holds its solid-angle share of them).
    #[test]
    fn a_narrow_emitter_is_sampled_in_f64_uniformly_in_solid_angle() {
        let v = Vec3::new;
        let (w, len) = (1e-3f32, 10.0f32);
        let strip = |x0: f32, x1: f32| {
            [
                tri(v(x0, 1.0, 0.0), v(x1, 1.0, 0.0), v(x1, 1.0, w), 1.0),
                tri(v(x0, 1.0, 0.0), v(x1, 1.0, w), v(x0, 1.0, w), 1.0),
            ]
        };
        let lights = Lights::new(strip(0.0, len).to_vec());
        let x = v(0.5 * len, 0.5, 0.5 * w);
        let c = lights.choice(x, Vec3::Y, DirectSampling::PowerOverDistance);
        assert!(c.by_solid_angle());
        let e = &lights.emitters[0];
        assert!(lights.sample_solid_angle_f32(e, x, 1.0, [0.5; 3]).is_err());
        let omega = |t: [Light; 2]| {
            t.iter()
                .map(|l| {
                    let [a, b, cc] = l.corners.map(|p| (p - x).as_dvec3());
                    solid_angle(a, b, cc)
                })
                .sum::<f64>()
        };
        let total = omega(strip(0.0, len));
        assert!(total > 1e-3 && total < f64::from(F32_MIN), "{total} sr");
        let share = omega(strip(4.5, 5.5)) / total;
        let samples = stratified_samples(&lights, &c, x, total, 64);
        for s in &samples {
            assert!(s.point.x > -1e-4 && s.point.x < len + 1e-4, "{:?}", s.point);
        }
        let inside = samples
            .iter()
            .filter(|s| (4.5..5.5).contains(&s.point.x))
            .count();
        let seen = inside as f64 / samples.len() as f64;
        assert!((seen - share).abs() < 0.01, "{seen} against {share}");
    }

    #[test]
    fn solid_angle_sampling_removes_the_inverse_square_from_the_noise() {
        // 5 cm under the centre of the unit square, facing it: the irradiance is the form
        // factor's, and the per-sample spread by solid angle is a fraction of that by area.
        let x = Vec3::new(0.5, 0.95, 0.5);
        let stats = |lights: &Lights| {
            let c = lights.choice(x, Vec3::Y, DirectSampling::PowerOverDistance);
            let (mut sum, mut sum2, n) = (0.0f64, 0.0f64, 1 << 16);
            let mut rng = wfic::rng::Rng::new(7);
            for _ in 0..n {
                let u = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
                let s = lights
                    .sample(&c, u)
                    .map(point)
                    .expect("the square lights x");
                let d = s.point - x;
                let w = d.normalize();
                let e = f64::from(w.y * -s.normal.dot(w) / (d.length_squared() * s.pdf_area));
                sum += e;
                sum2 += e * e;
            }
            let mean = sum / f64::from(n);
            (
                mean,
                (sum2 / f64::from(n) - mean * mean).max(0.0).sqrt() / mean,
            )
        };
        // The form factor from a point to a parallel a x b rectangle centred above at height h,
        // four corner rectangles of (a/2) x (b/2).
        let corner = |a: f64, b: f64, h: f64| {
            let (x, y) = (a / h, b / h);
            let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
            ((x / sx) * (y / sx).atan() + (y / sy) * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
        };
        let exact = 4.0 * corner(0.5, 0.5, 0.05) * std::f64::consts::PI;
        let (by_angle, spread_angle) = stats(&grid(1));
        let (by_area, spread_area) = stats(&grid(3));
        assert!(grid(3)
            .choice(x, Vec3::Y, DirectSampling::PowerOverDistance)
            .near());
        for (name, e) in [("solid angle", by_angle), ("area", by_area)] {
            assert!(
                (e / exact - 1.0).abs() < 0.05,
                "{name}: {e} against {exact}"
            );
        }
        assert!(
            spread_angle < 0.2 * spread_area,
            "relative spread {spread_angle} by solid angle, {spread_area} by area"
        );
    }

    #[test]
    fn a_triangle_too_small_for_arvo_is_sampled_by_area_with_its_share_of_the_solid_angle() {
        // One emitter: a unit triangle, and a sliver of 1e-6 m^2 touching its corner (same
        // radiance). From x, close under the big one, the emitter is near and sampled by solid
        // angle, but the sliver subtends less than ARVO_MIN: a sample that chooses it lands
        // uniformly in its area, with density p_tri / area, p_tri its share of the solid angle.
        let v = Vec3::new;
        let lights = Lights::new(vec![
            tri(v(0.0, 1.0, 0.0), v(1.0, 1.0, 0.0), v(1.0, 1.0, 1.0), 1.0),
            tri(
                v(1.0, 1.0, 0.0),
                v(1.002, 1.0, 0.0),
                v(1.002, 1.0, 0.001),
                1.0,
            ),
        ]);
        assert_eq!(lights.emitter_count(), 1);
        let x = Vec3::new(0.6, 0.9, 0.3);
        let c = lights.choice(x, Vec3::Y, DirectSampling::PowerOverDistance);
        assert!(c.by_solid_angle());
        let rel = |p: Vec3| (p - x).as_dvec3();
        let omega =
            |l: &Light| solid_angle(rel(l.corners[0]), rel(l.corners[1]), rel(l.corners[2]));
        let tris = lights.triangles();
        let total: f64 = tris.iter().map(omega).sum();
        let (k, sliver) = tris
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.area.total_cmp(&b.1.area))
            .unwrap();
        let omega_s = omega(sliver);
        assert!(omega_s > 0.0 && omega_s < ARVO_MIN, "{omega_s} sr");
        // The triangle choice walks the emitter's triangles in order: the sliver's interval is at
        // the start or at the end of [0, 1).
        let p_s = omega_s / total;
        let u0 = if k == 0 { 0.5 * p_s } else { 1.0 - 0.5 * p_s } as f32;
        for i in 0..16 {
            for j in 0..16 {
                let u = [u0, (i as f32 + 0.5) / 16.0, (j as f32 + 0.5) / 16.0];
                let s = lights
                    .sample(&c, u)
                    .map(point)
                    .expect("the emitter lights x");
                assert!(
                    s.point.x >= 1.0 - 1e-6
                        && s.point.x <= 1.002 + 1e-6
                        && s.point.z <= 0.001 + 1e-6,
                    "not on the sliver: {:?}",
                    s.point
                );
                let expected = p_s / f64::from(sliver.area);
                let rel_err = (f64::from(s.pdf_area) / expected - 1.0).abs();
                assert!(
                    rel_err < 1e-3,
                    "density {} per m^2 on the sliver, expected {expected}",
                    s.pdf_area
                );
            }
        }
    }

    #[test]
    fn samples_land_on_the_chosen_triangle_with_its_density() {
        let lights = three();
        // Far enough below that no emitter is near (each is sampled by area).
        let c = lights.choice(
            Vec3::new(0.5, -0.5, 0.5),
            Vec3::Y,
            DirectSampling::PowerOverDistance,
        );
        assert!(!c.near() && !c.by_solid_angle());
        let mut seen = [0usize; 3];
        let n = 3000;
        for i in 0..n {
            let u0 = (i as f32 + 0.5) / n as f32;
            let s = lights.sample(&c, [u0, 0.4, 0.6]).map(point).unwrap();
            assert!((s.point.y - 1.0).abs() < 1e-6);
            let k = (s.point.x.floor() as usize).min(10);
            let k = match k {
                0 => 0,
                10 => 1,
                _ => 2,
            };
            seen[k] += 1;
            // Emitters of area 1 split into triangles of area 1/2 chosen by power: the density per
            // area is the emitter's probability.
            let p = c.cdf[k] - if k == 0 { 0.0 } else { c.cdf[k - 1] };
            assert!((s.pdf_area - p).abs() < 1e-4, "{} vs {p}", s.pdf_area);
        }
        let p0 = c.cdf[0];
        assert!((seen[0] as f32 / n as f32 - p0).abs() < 2.0 / n as f32 + 1e-3);
    }

    /// The exact unoccluded irradiance ([`Lights::unoccluded_irradiance`]): below a corner of a
    /// unit square at height 1, the parallel-rectangle form factor; half under the square with
    /// the normal along it, so that the horizon cuts the square in two, a brute-force sum over
    /// its cells of `L cos_x cos_l / d^2`; and nothing for a point behind it.
    #[test]
    fn unoccluded_irradiance_is_the_exact_integral_clipped_to_the_horizon() {
        let lights = three();
        // The first square: [0, 1] x [0, 1] at y = 1, facing down, radiance 1.
        let k = lights.emitter_of(0) as usize;
        let exact = |x: Vec3, n: Vec3| {
            let choice = lights.choice(x, n, DirectSampling::Bounds);
            lights.unoccluded_irradiance(&choice, k, x, n).unwrap().x as f64
        };
        // F = (1 / 2 pi) [X / sqrt(1 + X^2) atan(Y / sqrt(1 + X^2)) + (X <-> Y)], X = Y = 1 / h,
        // under the corner (1, 1, 1), near and far.
        for h in [0.75f64, 20.0] {
            let x = 1.0 / h;
            let s = x / (1.0 + x * x).sqrt();
            let want = 2.0 * s * s.atan() / 2.0;
            let corner = exact(Vec3::new(1.0, 1.0 - h as f32, 1.0), Vec3::Y);
            assert!(
                (corner / want - 1.0).abs() < 1e-5,
                "h = {h}: {corner} vs {want}"
            );
        }
        // The horizon through the square's middle (only x > 0.5 lights the point), then along
        // its diagonal, the edge its two triangles share: one triangle lies on and above the
        // horizon, and clipping the other leaves two vertices repeated, a polygon of no area.
        let diagonal = DVec3::new(1.0, 0.0, -1.0).normalize();
        for (x, n) in [
            (DVec3::new(0.5, 0.0, 0.3), DVec3::X),
            (DVec3::new(0.5, 0.0, 0.5), diagonal),
        ] {
            let cells = 1000;
            let mut brute = 0.0;
            for i in 0..cells {
                for j in 0..cells {
                    let p = DVec3::new(
                        (i as f64 + 0.5) / cells as f64,
                        1.0,
                        (j as f64 + 0.5) / cells as f64,
                    );
                    let d = p - x;
                    let d2 = d.length_squared();
                    let w = d / d2.sqrt();
                    let (cos_x, cos_l) = (n.dot(w), w.y);
                    if cos_x > 0.0 {
                        brute += cos_x * cos_l / d2 / (cells * cells) as f64;
                    }
                }
            }
            let cut = exact(x.as_vec3(), n.as_vec3());
            assert!((cut / brute - 1.0).abs() < 1e-3, "at {x}: {cut} vs {brute}");
        }
        // Above the square, which emits downwards: nothing.
        assert_eq!(exact(Vec3::new(0.5, 2.0, 0.5), -Vec3::Y), 0.0);
    }

    /// Which emitters have the control: a flat fan of [`CONTROL_MAX`] triangles does, one of
    /// more does not, and a tessellated bulb (an octahedron: eight triangles) only where it is not
    /// sampled by cone, so not under [`DirectSampling::Bounds`] from outside it.
    #[test]
    fn the_control_is_for_few_triangles_sampled_by_point() {
        let v = Vec3::new;
        let fan = |k: usize| {
            let c = v(0.5, 1.0, 0.5);
            let p = |i: usize| {
                let t = std::f32::consts::TAU * i as f32 / k as f32;
                c + v(t.cos(), 0.0, t.sin()) * 0.5
            };
            // Wound (c, p_i, p_i+1): facing down, towards the points below.
            Lights::new((0..k).map(|i| tri(c, p(i), p(i + 1), 1.0)).collect())
        };
        let (x, n) = (v(0.3, 0.0, 0.2), Vec3::Y);
        for (k, has) in [(CONTROL_MAX, true), (CONTROL_MAX + 1, false)] {
            let lights = fan(k);
            assert_eq!(lights.emitter_count(), 1);
            let choice = lights.choice(x, n, DirectSampling::Bounds);
            let control = lights.unoccluded_irradiance(&choice, 0, x, n);
            assert_eq!(control.is_some(), has, "{k} triangles");
        }
        let r = 0.1;
        let c = v(0.0, 5.0, 0.0);
        let mut bulb = Vec::new();
        for sx in [1.0f32, -1.0] {
            for sy in [1.0f32, -1.0] {
                for sz in [1.0f32, -1.0] {
                    let (a, b, d) = (
                        c + v(sx * r, 0.0, 0.0),
                        c + v(0.0, sy * r, 0.0),
                        c + v(0.0, 0.0, sz * r),
                    );
                    // Outward: swap two corners where the octant's orientation flips.
                    bulb.push(if sx * sy * sz > 0.0 {
                        tri(a, b, d, 1.0)
                    } else {
                        tri(a, d, b, 1.0)
                    });
                }
            }
        }
        let lights = Lights::new(bulb);
        assert_eq!(lights.emitter_count(), 1);
        let x = Vec3::ZERO;
        for (sampling, has) in [
            (DirectSampling::Bounds, false),
            (DirectSampling::PowerOverDistance, true),
        ] {
            let choice = lights.choice(x, n, sampling);
            let control = lights.unoccluded_irradiance(&choice, 0, x, n);
            assert_eq!(control.is_some(), has, "the bulb under {sampling:?}");
        }
    }
}
