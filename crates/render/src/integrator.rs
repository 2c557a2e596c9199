//! The integrator: direct light from area lights with shadow rays, plus one indirect diffuse bounce
//! whose irradiance comes from the cache (lookup, else a stratified hemisphere estimate that
//! becomes a record).
//!
//! **Convention** (no light is counted twice). A pixel's outgoing radiance at a diffuse point `x` is
//! `L_e(x) + albedo(x) / pi * (E_direct(x) + E_indirect(x))`, where
//! * `E_direct` is the irradiance from the emissive triangles, estimated by sampling points on
//!   them (emitter by power over distance, [`crate::lights`]) with one shadow ray each;
//! * `E_indirect` is the irradiance from *reflected* light only: a hemisphere ray that hits a
//!   surface `y` brings `L_i = albedo(y) / pi * E_direct(y)` (one light sample at `y`, stratified
//!   across the estimate's cells; [`NEAR_HIT_SAMPLES`] next to an emitter). The emission
//!   of a light the hemisphere ray happens to hit is *not* added, since `E_direct` already
//!   accounts for every light. There is no further bounce (no cache recursion).
//!
//! `E_indirect` is what [`wfic::ic::Record::irradiance`] holds, so `albedo * E / pi` is the
//! reflected radiance, as for the direct term.
//!
//! The hemisphere estimate uses Ward's stratified cosine-weighted sampling (`M` rings in
//! `sin^2 theta`, `N` sectors in `phi`, one jittered ray per cell) and gives, besides the irradiance
//! `E = pi / (M N) * sum L_jk`, the harmonic mean distance `M N / sum 1/r_jk` and the Ward &
//! Heckbert (1992) gradients computed from the same cells:
//! * rotational: `grad_r = pi / (M N) * sum_k v_k sum_j tan(theta_j) L_jk`, with `v_k` the tangent
//!   direction at `phi_k + pi/2`. It is the derivative for the crate's extrapolation
//!   `E + (n_i x n) . grad_r` ([`wfic::ic::extrapolate`]): `d/dn` of `int L max(0, n . w) dw` is
//!   `int L (n_i x w) dw` and `n_i x w = sin(theta) v(phi)`.
//! * translational: Ward & Heckbert's cell-boundary form, with `min(r)` of the two cells on each
//!   side of a boundary (`u_k` at the sector's centre, `v_k-` normal to its lower edge):
//!   `grad_t = sum_k [ u_k 2pi/N sum_{j>=1} sin(t_j-) cos^2(t_j-) / min(r) (L_jk - L_j-1,k)
//!                   + v_k- sum_j (sin(t_j+) - sin(t_j-)) / min(r) (L_jk - L_j,k-1) ]`.
//!   The ring term is Ward & Heckbert's. The sector term's coefficient is derived here from the
//!   projected solid angle: a sector edge at distance `r` moves by `dphi = dx / (r sin t)` and the
//!   cell's projected solid angle density is `cos t sin t dt dphi`, so the edge sweeps
//!   `dx / r * integral cos t dt = dx (sin t+ - sin t-) / r`. The form usually quoted,
//!   `(cos t- - cos t+) / (sin t_c r)`, weights grazing rings by an extra `1 / cos t` and so
//!   overestimates the gradient in front of a wall; the derived form agrees with central
//!   differences there (`translational_gradient_matches_finite_differences_next_to_a_wall`).

use super::camera::{Camera, View};
use super::lights::{DirectSampling, LightChoice, Sampled};
use super::sampler::{self, Rng, Stream};
use super::scene::Scene;
use super::settings::RenderSettings;
use glam::Vec3;
use std::f32::consts::{PI, TAU};
use std::time::{Duration, Instant};
use wfic::cache::CacheHandle;
use wfic::ic::{self, Record};

/// The strata of a hemisphere estimate: `theta` rings times `phi` sectors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strata {
    /// Rings (`M`), uniform in `sin^2 theta`.
    pub theta: u32,
    /// Sectors (`N`), uniform in `phi`.
    pub phi: u32,
}

impl Strata {
    /// About `rays` cells with `N ~ pi M` (Ward's proportion), at least 2 x 3 so both gradient
    /// terms have neighbours.
    pub fn for_rays(rays: u32) -> Self {
        let m = ((rays as f32 / PI).sqrt().round() as u32).max(2);
        let n = ((rays as f32 / m as f32).round() as u32).max(3);
        Self { theta: m, phi: n }
    }

    /// Rays one estimate traces.
    pub fn rays(&self) -> u32 {
        self.theta * self.phi
    }
}

impl RenderSettings {
    /// The strata of one irradiance estimate (here, beside [`Strata`], so the settings need not
    /// know the integrator).
    pub fn strata(&self) -> Strata {
        Strata::for_rays(self.rays_per_record)
    }
}

/// One hemisphere estimate: everything a record holds, before its radius is clamped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IrradianceSample {
    /// Indirect irradiance `E` (RGB).
    pub irradiance: Vec3,
    /// Harmonic mean distance of the hits (infinite when every ray escaped).
    pub harmonic_mean: f32,
    /// Translational gradient per channel.
    pub grad_t: [Vec3; 3],
    /// Rotational gradient per channel.
    pub grad_r: [Vec3; 3],
}

/// Counts rays by kind (in JSON as `primary_rays`, `shadow_rays` and `hemisphere_rays`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RayCounts {
    /// Camera rays.
    #[serde(rename = "primary_rays")]
    pub primary: u64,
    /// Shadow rays (direct light at primary hits and at hemisphere hits).
    #[serde(rename = "shadow_rays")]
    pub shadow: u64,
    /// Hemisphere rays of irradiance estimates.
    #[serde(rename = "hemisphere_rays")]
    pub hemisphere: u64,
}

impl std::ops::AddAssign for RayCounts {
    fn add_assign(&mut self, o: Self) {
        self.primary += o.primary;
        self.shadow += o.shadow;
        self.hemisphere += o.hemisphere;
    }
}

/// The facing side of a surface with wound normal `n` seen along `dir`.
#[inline]
pub fn facing(n: Vec3, dir: Vec3) -> Vec3 {
    if n.dot(dir) < 0.0 {
        n
    } else {
        -n
    }
}

/// A right-handed tangent frame `(t, b)` with `t x b = n`.
#[inline]
fn frame(n: Vec3) -> (Vec3, Vec3) {
    let t = n.any_orthonormal_vector();
    (t, n.cross(t))
}

/// The irradiance one light sample would bring to `origin` (unit facing normal `n`) were nothing
/// in the way, and whether it does: a point's emission times its geometry term over its density,
/// and whether its shadow ray is clear; a cone direction's emission times its cosine over its
/// density, and whether the first thing the ray meets is the emitter's front. Zero, with no
/// shadow ray, behind either surface.
#[inline]
fn contribution_parts(
    scene: &Scene,
    s: Sampled,
    origin: Vec3,
    n: Vec3,
    rays: &mut RayCounts,
) -> (Vec3, bool) {
    match s {
        Sampled::Point(s) => {
            let d = s.point - origin;
            let dist2 = d.length_squared();
            if dist2 <= 0.0 {
                return (Vec3::ZERO, false);
            }
            let dist = dist2.sqrt();
            let w = d / dist;
            let cos_x = n.dot(w);
            let cos_l = -s.normal.dot(w);
            if cos_x <= 0.0 || cos_l <= 0.0 {
                return (Vec3::ZERO, false);
            }
            rays.shadow += 1;
            let clear = scene.unoccluded(origin, w, dist * (1.0 - 1e-3));
            (s.emission * (cos_x * cos_l / (dist2 * s.pdf_area)), clear)
        }
        Sampled::Cone {
            dir,
            emission,
            pdf_dir,
            emitter,
            t_max,
        } => {
            let cos_x = n.dot(dir);
            if cos_x <= 0.0 || pdf_dir <= 0.0 {
                return (Vec3::ZERO, false);
            }
            rays.shadow += 1;
            let hit = scene.emitter_hit(origin, dir, t_max) == Some(emitter);
            (emission * (cos_x / pdf_dir), hit)
        }
    }
}

/// The irradiance one light sample brings to `origin` ([`contribution_parts`]).
#[inline]
fn contribution(scene: &Scene, s: Sampled, origin: Vec3, n: Vec3, rays: &mut RayCounts) -> Vec3 {
    match contribution_parts(scene, s, origin, n, rays) {
        (e, true) => e,
        (_, false) => Vec3::ZERO,
    }
}

/// The irradiance one light sample brings to `origin` (unit facing normal `n`), for the uniform
/// numbers `u` ([`Scene::light_sample`]) under the point's emitter probabilities `choice`.
#[inline]
fn light_contribution(
    scene: &Scene,
    choice: &LightChoice,
    origin: Vec3,
    n: Vec3,
    u: [f32; 3],
    rays: &mut RayCounts,
) -> Vec3 {
    match scene.light_sample(choice, u.map(|c| c.min(1.0 - f32::EPSILON))) {
        Some(s) => contribution(scene, s, origin, n, rays),
        None => Vec3::ZERO,
    }
}

/// Most emitters that reach a point for which [`direct_irradiance`] samples every one
/// ([`DirectSampling::Bounds`]); with more, one stratified choice among them per sample.
pub const EVERY_EMITTER_MAX: usize = 16;

/// Irradiance at `x` (unit facing normal `n`) from the scene's lights, from `samples` light
/// samples with one shadow ray each; `eps` is the ray offset.
///
/// Under [`DirectSampling::Bounds`], when at most [`EVERY_EMITTER_MAX`] emitters can reach `x`
/// and `samples` is at least their number, every one of them is sampled on its own: one sample
/// each, and the rest shared by the emitters' probabilities (largest remainders first), each
/// emitter's estimate the mean of its own samples. The sum over the emitters is unbiased for any
/// split, and no emitter that can light `x` goes unsampled. An emitter of a few triangles
/// sampled by point ([`crate::lights::CONTROL_MAX`]) has its samples' unoccluded irradiance
/// computed exactly ([`Scene::emitter_unoccluded`]) as their control variate: its estimate is
/// that irradiance less the mean of what its blocked samples would have brought, so only the
/// emitter's occlusion is left to noise, and a point that sees all of it gets it exactly.
/// Otherwise (and always under [`DirectSampling::PowerOverDistance`]) sample `i` takes the
/// `i`-th of `samples` strata of the emitter choice ([`crate::lights`]).
///
/// Either way the position on the light is stratified too: a cell of a `g x g` grid
/// (`g = ceil(sqrt(k)) <= 8` for `k` samples) drawn from a random permutation of the cells, so
/// the cell is independent of the light choice (a fixed mapping would tie lights to parts of the
/// grid and bias the estimate). Above 64 samples the position is not stratified.
#[allow(clippy::too_many_arguments)]
pub fn direct_irradiance(
    scene: &Scene,
    x: Vec3,
    n: Vec3,
    samples: u32,
    eps: f32,
    sampling: DirectSampling,
    rng: &mut Rng,
    rays: &mut RayCounts,
) -> Vec3 {
    let origin = x + n * eps;
    let choice = scene.light_choice(origin, n, sampling);
    let reachable = choice.reachable_count();
    if sampling == DirectSampling::Bounds
        && (1..=EVERY_EMITTER_MAX).contains(&reachable)
        && samples as usize >= reachable
    {
        let mut share = [(0usize, 0u32, 0.0f32); EVERY_EMITTER_MAX];
        let extra = samples as usize - reachable;
        let mut given = 0;
        for (slot, (k, p)) in share.iter_mut().zip(choice.reachable()) {
            let want = extra as f32 * p;
            let whole = want.floor() as u32;
            *slot = (k, 1 + whole, want - whole as f32);
            given += whole as usize;
        }
        let share = &mut share[..reachable];
        // The samples rounding left over go to the largest remainders (ties to the lower index).
        share.sort_by(|a, b| b.2.total_cmp(&a.2).then(a.0.cmp(&b.0)));
        for slot in share.iter_mut().take(extra.saturating_sub(given)) {
            slot.1 += 1;
        }
        let mut sum = Vec3::ZERO;
        for &(k, count, _) in share.iter() {
            // With the emitter's exact unoccluded irradiance (its control variate), the estimate
            // is that less the mean of what the blocked samples would have brought: unbiased, as
            // the samples' unoccluded mean is that irradiance, and exact where nothing blocks.
            let control = scene.emitter_unoccluded(&choice, k, origin, n);
            let mut cells = Cells64::new(count, rng);
            // Without a control: what the samples bring. With one: what the blocked ones lose.
            let mut own = Vec3::ZERO;
            for i in 0..count {
                let u = cells.next(i, count, rng);
                if let Some(s) =
                    scene.emitter_sample(&choice, k, u.map(|c| c.min(1.0 - f32::EPSILON)))
                {
                    let (e, clear) = contribution_parts(scene, s, origin, n, rays);
                    if clear != control.is_some() {
                        own += e;
                    }
                }
            }
            sum += match control {
                Some(exact) => exact - own / count as f32,
                None => own / count as f32,
            };
        }
        return sum;
    }
    let mut cells = Cells64::new(samples, rng);
    let mut sum = Vec3::ZERO;
    for i in 0..samples {
        let u = cells.next(i, samples, rng);
        sum += light_contribution(scene, &choice, origin, n, u, rays);
    }
    sum / samples.max(1) as f32
}

/// The stratification of [`direct_irradiance`]'s samples: sample `i` of `k` takes the `i`-th of
/// `k` strata of its first number, and a cell of a `g x g` grid for the other two, from a random
/// permutation of the cells. Up to 64 cells (8 x 8, the usual counts) are permuted on the stack;
/// more in a vector, since above 64 samples the shadow rays outweigh one allocation. (Until
/// this was split, counts above 64 drew the two numbers unstratified, and 128 samples erred
/// more than 64 on the desk and Sponza.)
struct Cells64 {
    g: usize,
    cells: [u8; 64],
    more: Vec<u16>,
    stratify: bool,
}

impl Cells64 {
    fn new(samples: u32, rng: &mut Rng) -> Self {
        let g = (samples as f32).sqrt().ceil().max(1.0) as usize;
        let mut cells = [0u8; 64];
        let mut more = Vec::new();
        // More than 65,536 cells (above the renderer's bound of 4,096 samples): unstratified.
        let stratify = g * g <= usize::from(u16::MAX) + 1;
        // A `k % (k + 1)` draw per cell, as before the split: renders of up to 64 samples keep
        // their random streams, and so their images.
        if g * g <= cells.len() {
            for (k, c) in cells.iter_mut().enumerate().take(g * g) {
                *c = k as u8;
            }
            for k in (1..g * g).rev() {
                let j = (rng.next_u64() % (k as u64 + 1)) as usize;
                cells.swap(k, j);
            }
        } else if stratify {
            more = (0..g * g).map(|k| k as u16).collect();
            for k in (1..more.len()).rev() {
                let j = (rng.next_u64() % (k as u64 + 1)) as usize;
                more.swap(k, j);
            }
        }
        Self {
            g,
            cells,
            more,
            stratify,
        }
    }

    /// The grid cell of sample `i` (`None`: unstratified).
    fn cell(&self, i: u32) -> Option<usize> {
        match (self.stratify, self.more.is_empty()) {
            (false, _) => None,
            (true, true) => Some(usize::from(self.cells[i as usize])),
            (true, false) => Some(usize::from(self.more[i as usize])),
        }
    }

    /// The uniform numbers of sample `i` of `samples`.
    fn next(&mut self, i: u32, samples: u32, rng: &mut Rng) -> [f32; 3] {
        let g = self.g;
        let (r1, r2) = (rng.next_f32(), rng.next_f32());
        let (u1, u2) = match self.cell(i) {
            Some(c) => (
                ((c % g) as f32 + r1) / g as f32,
                ((c / g) as f32 + r2) / g as f32,
            ),
            None => (r1, r2),
        };
        let u0 = (i as f32 + rng.next_f32()) / samples as f32;
        [u0, u1, u2]
    }
}

/// Light samples at a hemisphere hit next to an emitter sampled by area ([`LightChoice::near`]:
/// one of more than [`crate::lights::SOLID_ANGLE_MAX`] triangles); elsewhere one.
/// Emitters of fewer triangles are sampled by solid angle there, and one sample suffices.
pub const NEAR_HIT_SAMPLES: u32 = 16;

/// Shuffles `items` into a uniformly random order (Fisher-Yates).
fn shuffle<T>(items: &mut [T], rng: &mut Rng) {
    for k in (1..items.len()).rev() {
        // Multiply-shift, not `%`: a 64-bit division per cell costs a visible share of a record.
        let j = rng.below(k as u64 + 1) as usize;
        items.swap(k, j);
    }
}

/// `(sin x, cos x)` for `|x| <= pi / 6` by their Taylor series to `x^7` and `x^8`: the
/// truncation is below `x^9 / 9! < 1e-8`, under f32's rounding. Horner's rule with the
/// coefficients as constants: no call into libm and no division.
#[inline]
fn sin_cos_small(x: f32) -> (f32, f32) {
    const S: [f32; 3] = [-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0];
    const C: [f32; 4] = [-1.0 / 2.0, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0];
    let x2 = x * x;
    let sin = x * (1.0 + x2 * (S[0] + x2 * (S[1] + x2 * S[2])));
    let cos = 1.0 + x2 * (C[0] + x2 * (C[1] + x2 * (C[2] + x2 * C[3])));
    (sin, cos)
}

/// Ward's stratified hemisphere estimate at `x` with unit facing normal `n` (see the module doc).
///
/// The light sample at each hemisphere hit is the earlier estimator's,
/// [`DirectSampling::PowerOverDistance`], whatever the frame's `direct` setting: the records are
/// what the cache experiments measure, and they stay the records every committed cache result
/// was measured on (`docs/tried-and-dropped.md` has the light-bounds estimator tried there).
pub fn sample_irradiance(
    scene: &Scene,
    x: Vec3,
    n: Vec3,
    strata: Strata,
    eps: f32,
    rng: &mut Rng,
    rays: &mut RayCounts,
) -> IrradianceSample {
    let hemisphere = Hemisphere::new(n, strata);
    let cells = hemisphere.sample(scene, x, eps, rng, rays);
    let count = (hemisphere.m * hemisphere.nn) as f32;
    let irradiance = cells.radiance.iter().copied().sum::<Vec3>() * (PI / count);
    let harmonic_mean = if cells.inv_dist_sum > 0.0 {
        (f64::from(count) / cells.inv_dist_sum) as f32
    } else {
        f32::INFINITY
    };
    let (grad_r, grad_t) = hemisphere.gradients(&cells, count);
    IrradianceSample {
        irradiance,
        harmonic_mean,
        grad_t,
        grad_r,
    }
}

/// The strata of one hemisphere estimate around a normal: `m` rings by `nn` sectors, in the
/// tangent frame `t`, `b`, `n`.
struct Hemisphere {
    t: Vec3,
    b: Vec3,
    n: Vec3,
    m: usize,
    nn: usize,
    /// A sector's width in azimuth.
    dphi: f32,
    /// Per sector, the sine and cosine of its centre's azimuth.
    centre: Vec<(f32, f32)>,
}

/// What the hemisphere rays found, per cell, ring-major: cell (j, k) at `j * N + k`.
struct Cells {
    /// The reflected radiance each cell's ray brought (zero for a ray that escaped).
    radiance: Vec<Vec3>,
    /// The distance to each cell's hit (infinite for a ray that escaped).
    dist: Vec<f32>,
    /// The sum of the inverse hit distances, for the harmonic mean.
    inv_dist_sum: f64,
}

impl Hemisphere {
    fn new(n: Vec3, strata: Strata) -> Self {
        let (m, nn) = (strata.theta as usize, strata.phi as usize);
        let (t, b) = frame(n);
        // Azimuth phi = dphi (k + r), r uniform in [0, 1), is the sector's centre turned by
        // dphi (r - 1/2): its sine and cosine come from the centre's, computed once per sector,
        // and the turn's (at most half a sector) from a short series when there are 6 sectors or
        // more.
        let dphi = TAU / nn as f32;
        let centre: Vec<(f32, f32)> = (0..nn)
            .map(|k| (dphi * (k as f32 + 0.5)).sin_cos())
            .collect();
        Self {
            t,
            b,
            n,
            m,
            nn,
            dphi,
            centre,
        }
    }

    /// Traces one jittered ray per cell from `x` (offset by `eps` along the normal) and takes one
    /// light sample at each hit.
    fn sample(
        &self,
        scene: &Scene,
        x: Vec3,
        eps: f32,
        rng: &mut Rng,
        rays: &mut RayCounts,
    ) -> Cells {
        let (m, nn, t, b, n) = (self.m, self.nn, self.t, self.b, self.n);
        let origin = x + n * eps;
        let mut out = Cells {
            radiance: vec![Vec3::ZERO; m * nn],
            dist: vec![f32::INFINITY; m * nn],
            inv_dist_sum: 0.0,
        };
        // The light samples at the hits, one per cell, are stratified across the cells: cell c
        // takes stratum choice[c] of the light choice (u[0]) and stratum spot[c] of an M x N grid
        // over the point on the light (u[1], u[2]), from two independent permutations. Each
        // sample is still uniform on its own (the estimate stays unbiased), but the estimate's
        // samples cover the lights evenly instead of clumping: with one light sample per hit,
        // clumping makes most of a record's noise.
        let cells = m * nn;
        let mut choice: Vec<u32> = (0..cells as u32).collect();
        shuffle(&mut choice, rng);
        // The grid cells themselves, (ring, sector), shuffled: no division per hit to find them.
        let mut spot: Vec<(u32, u32)> = (0..m as u32)
            .flat_map(|a| (0..nn as u32).map(move |b| (a, b)))
            .collect();
        shuffle(&mut spot, rng);
        let (inv_m, inv_nn, inv_cells) = (1.0 / m as f32, 1.0 / nn as f32, 1.0 / cells as f32);
        let series = nn >= 6;
        // One emitter table for every hit, overwritten at each (Lights::choice_into).
        let mut lights = LightChoice::empty();
        for j in 0..m {
            for (k, &(sin_c, cos_c)) in self.centre.iter().enumerate() {
                let u = ((j as f32 + rng.next_f32()) * inv_m).min(1.0);
                let turn = self.dphi * (rng.next_f32() - 0.5);
                let (sin_d, cos_d) = if series {
                    sin_cos_small(turn)
                } else {
                    turn.sin_cos()
                };
                let (sin_t, cos_t) = (u.sqrt(), (1.0 - u).max(0.0).sqrt());
                let (sin_p, cos_p) = (sin_c * cos_d + cos_c * sin_d, cos_c * cos_d - sin_c * sin_d);
                // Unit to rounding: t, b, n are orthonormal and sin^2 + cos^2 = 1 for both angles.
                let w = t * (cos_p * sin_t) + b * (sin_p * sin_t) + n * cos_t;
                rays.hemisphere += 1;
                if let Some(hit) = scene.intersect(origin, w, f32::INFINITY) {
                    let y = origin + w * hit.t;
                    let ny = facing(hit.normal, w);
                    // Reflected light only: the lights' own emission is in E_direct (module doc).
                    let c = j * nn + k;
                    let (a, b) = spot[c];
                    // light_contribution keeps each below 1.
                    let u = [
                        (choice[c] as f32 + rng.next_f32()) * inv_cells,
                        (a as f32 + rng.next_f32()) * inv_m,
                        (b as f32 + rng.next_f32()) * inv_nn,
                    ];
                    let oy = y + ny * eps;
                    let sampling = DirectSampling::PowerOverDistance;
                    scene.light_choice_into(oy, ny, sampling, &mut lights);
                    // Next to an emitter sampled by area one sample's `1 / d^2` varies by more
                    // than 4x over it: take NEAR_HIT_SAMPLES there.
                    let ed = if lights.near() {
                        let near = NEAR_HIT_SAMPLES;
                        direct_irradiance(scene, y, ny, near, eps, sampling, rng, rays)
                    } else {
                        light_contribution(scene, &lights, oy, ny, u, rays)
                    };
                    out.radiance[j * nn + k] = hit.material.albedo * ed * (1.0 / PI);
                    out.dist[j * nn + k] = hit.t;
                    out.inv_dist_sum += 1.0 / f64::from(hit.t.max(eps));
                }
            }
        }
        out
    }

    /// Ward and Heckbert's rotational and translational gradients from the cells (module doc);
    /// `cells` is the number of cells.
    fn gradients(&self, found: &Cells, cells: f32) -> ([Vec3; 3], [Vec3; 3]) {
        let (m, nn, t, b, dphi) = (self.m, self.nn, self.t, self.b, self.dphi);
        let (radiance, dist) = (&found.radiance, &found.dist);
        let dir = |phi: f32| {
            let (s, c) = phi.sin_cos();
            t * c + b * s
        };
        // sin of the lower edge of ring j: the rings are uniform in sin^2 theta, so
        // sin(theta_j-) is sqrt(j / M) and cos(theta_j-) is sqrt(1 - j / M), no trigonometry
        // needed.
        let sin_lo: Vec<f32> = (0..=m).map(|j| (j as f32 / m as f32).sqrt()).collect();
        let mut grad_r = [Vec3::ZERO; 3];
        let mut grad_t = [Vec3::ZERO; 3];
        let add = |g: &mut [Vec3; 3], d: Vec3, l: Vec3| {
            g[0] += d * l.x;
            g[1] += d * l.y;
            g[2] += d * l.z;
        };
        // Rotational: tan of ring j's centre angle, times the cell's share.
        let tan_c: Vec<f32> = (0..m)
            .map(|j| {
                let u_c = (j as f32 + 0.5) / m as f32;
                (u_c / (1.0 - u_c)).sqrt() * PI / cells
            })
            .collect();
        for (k, &(sin_c, cos_c)) in self.centre.iter().enumerate() {
            let phi_lo = dphi * k as f32;
            // The sector's centre direction and the one a quarter turn on.
            let u_k = t * cos_c + b * sin_c;
            let v_k = b * cos_c - t * sin_c;
            let v_lo = dir(phi_lo + 0.5 * PI);
            let prev = (k + nn - 1) % nn;
            for j in 0..m {
                let cell = j * nn + k;
                let l = radiance[cell];
                add(&mut grad_r, v_k, l * tan_c[j]);
                // Translational, ring boundary between j - 1 and j.
                if j > 0 {
                    let s = sin_lo[j];
                    let c2 = 1.0 - s * s;
                    let r = dist[cell].min(dist[cell - nn]);
                    if r.is_finite() {
                        let coef = TAU / nn as f32 * s * c2 / r;
                        add(&mut grad_t, u_k, (l - radiance[cell - nn]) * coef);
                    }
                }
                // Translational, sector boundary between k - 1 and k.
                let r = dist[cell].min(dist[j * nn + prev]);
                if r.is_finite() {
                    let coef = (sin_lo[j + 1] - sin_lo[j]) / r;
                    add(&mut grad_t, v_lo, (l - radiance[j * nn + prev]) * coef);
                }
            }
        }
        (grad_r, grad_t)
    }
}

// ---------------------------------------------------------------------------------------------
// Per-sample radiance through the cache (pbrt-v4's `Li`) and per-pixel sampling
// ---------------------------------------------------------------------------------------------

/// What one worker counts for itself while it shades.
#[derive(Clone, Copy, Debug, Default)]
pub struct SampleCounters {
    /// Rays traced, by kind.
    pub rays: RayCounts,
    /// Irradiance estimates computed.
    pub ic_samples: u64,
    /// Time spent in hemisphere sampling.
    pub hemisphere: Duration,
}

impl std::ops::AddAssign for SampleCounters {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.ic_samples += o.ic_samples;
        self.hemisphere += o.hemisphere;
    }
}

/// The integrator of one frame: the scene seen through one view with one set of settings, and
/// the accuracy records are placed at (for the gradient limit and, under smoothing, the test
/// that a lookup found a record valid at it). Read-only, shared by the workers.
pub struct PixelIntegrator<'a> {
    scene: &'a Scene,
    view: View,
    settings: &'a RenderSettings,
    strata: Strata,
    eps: f32,
    diagonal: f32,
    accuracy: f32,
    /// `1 / accuracy`: a lookup answers the pixel only if some record's weight is above it.
    reuse_weight: f64,
}

impl<'a> PixelIntegrator<'a> {
    /// The integrator for `scene` seen by `camera` with `settings`, feeding a cache of accuracy
    /// `accuracy` (the interpolation's: [`RenderSettings::cache_config`] makes it
    /// `smoothing * a`, and records are placed at `accuracy / smoothing`).
    pub fn new(
        scene: &'a Scene,
        camera: &Camera,
        settings: &'a RenderSettings,
        accuracy: f32,
    ) -> Self {
        let placed = accuracy / settings.smoothing;
        Self {
            scene,
            view: camera.view(settings.width, settings.height),
            settings,
            strata: settings.strata(),
            eps: 1e-4 * scene.diagonal(),
            diagonal: scene.diagonal(),
            accuracy: placed,
            reuse_weight: 1.0 / f64::from(placed),
        }
    }

    /// The radiance of pixel `(px, py)`: the mean of its `pixel_samples` primary rays, placed
    /// by stratified jitter on the most nearly square `cols x rows` grid with `cols * rows`
    /// equal to the count (a single ray goes through the centre).
    pub fn pixel<H: CacheHandle>(
        &self,
        px: u32,
        py: u32,
        handle: &mut H,
        counters: &mut SampleCounters,
    ) -> Vec3 {
        let n = self.settings.pixel_samples.max(1);
        if n == 1 {
            return self.li(px, py, 0, (0.5, 0.5), handle, counters);
        }
        let (cols, rows) = strata_grid(n);
        let mut pos = sampler::for_pixel(self.settings.seed, px, py, Stream::Position);
        let mut sum = Vec3::ZERO;
        for s in 0..n {
            let (i, j) = (s % cols, s / cols);
            let u = (i as f32 + pos.next_f32()) / cols as f32;
            let v = (j as f32 + pos.next_f32()) / rows as f32;
            sum += self.li(px, py, s, (u, v), handle, counters);
        }
        sum / n as f32
    }

    /// `Li`: the radiance along one primary ray through `(px + offset.0, py + offset.1)`, sample
    /// `sample` of its pixel: emission, direct light, and the indirect irradiance from the cache
    /// (a lookup; on a miss a hemisphere estimate, its gradients limited, inserted as a record).
    pub fn li<H: CacheHandle>(
        &self,
        px: u32,
        py: u32,
        sample: u32,
        offset: (f32, f32),
        handle: &mut H,
        counters: &mut SampleCounters,
    ) -> Vec3 {
        let scene = self.scene;
        let dir = self
            .view
            .direction(px as f32 + offset.0, py as f32 + offset.1);
        counters.rays.primary += 1;
        let Some(hit) = scene.intersect(self.view.eye(), dir, f32::INFINITY) else {
            return Vec3::ZERO;
        };
        let x = self.view.eye() + dir * hit.t;
        let n = facing(hit.normal, dir);
        let mut radiance = if hit.normal.dot(dir) < 0.0 {
            hit.material.emission
        } else {
            Vec3::ZERO
        };
        let mut rng = sampler::for_sample(self.settings.seed, px, py, sample, Stream::Direct);
        let direct = direct_irradiance(
            scene,
            x,
            n,
            self.settings.light_samples,
            self.eps,
            self.settings.direct,
            &mut rng,
            &mut counters.rays,
        );
        let stream = sampler::for_sample(self.settings.seed, px, py, sample, Stream::Hemisphere);
        let indirect = self.indirect(x, n, (hit.t, dir), stream, handle, counters);
        radiance += hit.material.albedo * (direct + indirect) * (1.0 / PI);
        radiance
    }
}

impl PixelIntegrator<'_> {
    /// The indirect irradiance at `x` with normal `n`, seen along `dir` at distance `t`: a cache
    /// lookup; on a miss, a hemisphere estimate from `rng`, its gradients limited, inserted as a
    /// record (stored, discarded by WF `Discard`, not cached by the reference, or refused: the
    /// estimate is returned either way; a refusal is counted by the handle, `rejected`).
    fn indirect<H: CacheHandle>(
        &self,
        x: Vec3,
        n: Vec3,
        (t, dir): (f32, Vec3),
        mut rng: sampler::Rng,
        handle: &mut H,
        counters: &mut SampleCounters,
    ) -> Vec3 {
        // Without smoothing every record a lookup finds weighs above 1 / a; with it, the pixel
        // takes the wider average only where some record is valid at `a` itself, so the records
        // computed are the ones Ward's cache computes.
        let found = handle
            .lookup(x, n)
            .filter(|f| f.max_weight > self.reuse_weight);
        if let Some(found) = found {
            return found.irradiance;
        }
        let start = Instant::now();
        let s = sample_irradiance(
            self.scene,
            x,
            n,
            self.strata,
            self.eps,
            &mut rng,
            &mut counters.rays,
        );
        counters.hemisphere += start.elapsed();
        counters.ic_samples += 1;
        let footprint = self.view.footprint(t, dir);
        let (r_min, r_max) = self.settings.radius_bounds(footprint, self.diagonal);
        let (radius, grad_t) = limit_gradient(&s, r_min, r_max, self.accuracy);
        let record = Record::new(x, n, s.irradiance, radius).with_gradients(grad_t, s.grad_r);
        let _ = handle.insert(record);
        s.irradiance
    }

    /// A pretrace of pixel `(px, py)` in pass `pass` of a deterministic frame: the primary hit
    /// of the ray through the pixel's centre gets its irradiance from the cache, or a new record
    /// computed from a stream of its own (the seed, the pixel and the pass). Nothing is shaded;
    /// the records seed the later passes.
    pub fn pretrace<H: CacheHandle>(
        &self,
        (px, py): (u32, u32),
        pass: u32,
        handle: &mut H,
        counters: &mut SampleCounters,
    ) {
        let dir = self.view.direction(px as f32 + 0.5, py as f32 + 0.5);
        counters.rays.primary += 1;
        if let Some(hit) = self.scene.intersect(self.view.eye(), dir, f32::INFINITY) {
            let x = self.view.eye() + dir * hit.t;
            let n = facing(hit.normal, dir);
            // Sample numbers from the top down: no pixel shades that many samples.
            let stream = sampler::for_sample(
                self.settings.seed,
                px,
                py,
                u32::MAX - pass,
                Stream::Hemisphere,
            );
            self.indirect(x, n, (hit.t, dir), stream, handle, counters);
        }
    }
}

/// The most nearly square grid `(cols, rows)` with `cols * rows == n` and `cols >= rows`
/// (`n` prime gives `(n, 1)`).
fn strata_grid(n: u32) -> (u32, u32) {
    let mut rows = (n as f64).sqrt() as u32;
    while rows > 1 && n % rows != 0 {
        rows -= 1;
    }
    let rows = rows.max(1);
    (n / rows, rows)
}

/// The record's radius and translational gradient, limited as Křivánek et al. (2006, "Making
/// radiance and irradiance caching practical") advise, so a record never extrapolates wildly:
/// * the radius is at most `E_c / |grad_t[c]|` for every channel (where irradiance changes fast,
///   records are closer together), then clamped to `[r_min, r_max]` ([`ic::clamp_radius`]);
/// * if a channel's gradient would still change it by more than its own value across the
///   record's reach `a R`, that gradient is scaled down to exactly that.
pub fn limit_gradient(
    s: &IrradianceSample,
    r_min: f32,
    r_max: f32,
    accuracy: f32,
) -> (f32, [Vec3; 3]) {
    let mut hmd = s.harmonic_mean;
    for c in 0..3 {
        let g = s.grad_t[c].length();
        if g > 0.0 {
            hmd = hmd.min(s.irradiance[c] / g);
        }
    }
    let radius = ic::clamp_radius(hmd, r_min, r_max);
    let reach = accuracy * radius;
    let mut grad_t = s.grad_t;
    for (c, g) in grad_t.iter_mut().enumerate() {
        let change = g.length() * reach;
        if change > s.irradiance[c] {
            *g *= s.irradiance[c] / change;
        }
    }
    (radius, grad_t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes;

    /// The direct light's samples are stratified at every count the renderer takes: the `k`
    /// samples take `k` distinct cells of the `g x g` grid, below 64 samples and above it
    /// alike, and each sample's two numbers lie in its cell.
    #[test]
    fn light_samples_take_distinct_cells_at_every_count() {
        let mut rng = Rng::new(11);
        for samples in [1u32, 2, 8, 16, 63, 64, 65, 128, 1000, 1024, 4096] {
            let mut cells = Cells64::new(samples, &mut rng);
            let g = cells.g;
            assert!(g * g >= samples as usize && (g - 1) * (g - 1) < samples as usize);
            let mut seen = std::collections::HashSet::new();
            for i in 0..samples {
                let c = cells.cell(i);
                let c = c.unwrap_or_else(|| panic!("{samples} samples: sample {i} unstratified"));
                assert!(
                    c < g * g && seen.insert(c),
                    "{samples} samples: cell {c} twice"
                );
                let [_, u1, u2] = cells.next(i, samples, &mut rng);
                let (x, y) = ((c % g) as f32 / g as f32, (c / g) as f32 / g as f32);
                let side = 1.0 / g as f32 + 1e-6;
                assert!((x..x + side).contains(&u1) && (y..y + side).contains(&u2));
            }
        }
        // Where the grid has more cells than samples, which go unused is random: each cell is
        // taken as often as any other (else the numbers would not be uniform, and the estimate
        // biased). 65 and 1000 samples leave 16 of 81 and 24 of 1024 cells unused.
        for (samples, draws) in [(65u32, 4000), (1000, 400)] {
            let g = (samples as f32).sqrt().ceil() as usize;
            let mut taken = vec![0u32; g * g];
            for _ in 0..draws {
                let cells = Cells64::new(samples, &mut rng);
                for i in 0..samples {
                    taken[cells.cell(i).expect("stratified")] += 1;
                }
            }
            let expect = f64::from(draws) * f64::from(samples) / (g * g) as f64;
            for (c, &n) in taken.iter().enumerate() {
                let off = (f64::from(n) - expect).abs() / expect;
                assert!(
                    off < 0.1,
                    "{samples} samples: cell {c} taken {n} times, not {expect}"
                );
            }
        }
    }

    #[test]
    fn the_shuffle_reaches_every_order_of_three_evenly() {
        // Fisher-Yates draws j in 0..=k; drawing in 0..k (Sattolo's cycles) never leaves an item
        // in place and reaches 2 of the 6 orders.
        let mut counts = std::collections::HashMap::new();
        let mut rng = Rng::new(7);
        for _ in 0..6000 {
            let mut v = [0u8, 1, 2];
            shuffle(&mut v, &mut rng);
            *counts.entry(v).or_insert(0u32) += 1;
        }
        assert_eq!(counts.len(), 6, "orders reached: {counts:?}");
        assert!(
            counts.values().all(|&c| (850..1150).contains(&c)),
            "{counts:?}"
        );
    }

    #[test]
    fn the_short_series_matches_libm_over_half_a_sector() {
        // 6 sectors or more turn by at most pi / 6; the series must agree with libm to f32
        // rounding there (the last coefficient a factor 10 off errs by 1e-6 at the ends).
        let mut worst = 0.0f32;
        for i in 0..=10_000 {
            let x = (i as f32 / 5_000.0 - 1.0) * std::f32::consts::FRAC_PI_6;
            let (s, c) = sin_cos_small(x);
            let (s0, c0) = x.sin_cos();
            worst = worst.max((s - s0).abs()).max((c - c0).abs());
        }
        assert!(worst < 4.0 * f32::EPSILON, "series off libm by {worst}");
    }

    #[test]
    fn strata_grids_are_as_square_as_the_count_allows() {
        assert_eq!(strata_grid(1), (1, 1));
        assert_eq!(strata_grid(4), (2, 2));
        assert_eq!(strata_grid(6), (3, 2));
        assert_eq!(strata_grid(7), (7, 1));
        assert_eq!(strata_grid(16), (4, 4));
        for n in 1..200 {
            let (c, r) = strata_grid(n);
            assert_eq!(c * r, n);
            assert!(c >= r);
        }
    }

    /// Mean of `n` independent estimates at `x`, and the mean gradients.
    fn estimate(scene: &Scene, x: Vec3, n: Vec3, seeds: u64) -> IrradianceSample {
        let mut acc = IrradianceSample {
            irradiance: Vec3::ZERO,
            harmonic_mean: 0.0,
            grad_t: [Vec3::ZERO; 3],
            grad_r: [Vec3::ZERO; 3],
        };
        let mut rays = RayCounts::default();
        for s in 0..seeds {
            let mut rng = Rng::new(s);
            let e = sample_irradiance(
                scene,
                x,
                n,
                Strata::for_rays(1024),
                1e-4,
                &mut rng,
                &mut rays,
            );
            acc.irradiance += e.irradiance / seeds as f32;
            for c in 0..3 {
                acc.grad_t[c] += e.grad_t[c] / seeds as f32;
                acc.grad_r[c] += e.grad_r[c] / seeds as f32;
            }
        }
        acc
    }

    #[test]
    fn rotational_gradient_predicts_a_tilt() {
        // On the Cornell box's back wall, 8 cm from the green wall (x = 0): tilting the normal
        // towards the green wall raises the green irradiance, as the rotational gradient says.
        let scene = scenes::cornell().unwrap();
        let x = Vec3::new(0.08, 0.4, 0.5591);
        let n = -Vec3::Z;
        let seeds = 128;
        let here = estimate(&scene, x, n, seeds);
        let tilt = Vec3::new(-0.1, 0.0, -1.0).normalize();
        let tilted = estimate(&scene, x, tilt, seeds);
        let measured = tilted.irradiance.y - here.irradiance.y;
        let predicted = n.cross(tilt).dot(here.grad_r[1]);
        assert!(measured > 0.0, "tilting towards the green wall: {measured}");
        assert!(
            (predicted - measured).abs() < 0.3 * measured.abs(),
            "rotational: predicted {predicted}, measured {measured}"
        );
    }

    /// A floor at y = 0 and a red wall of height `h` at x = 1 (infinite in z), lit by a panel
    /// above the floor at x < 0.
    fn wall_scene(h: f32) -> Scene {
        use crate::scene::{Material, SceneBuilder};
        let mut b = SceneBuilder::new();
        let white = b.material(Material::diffuse(Vec3::splat(0.5)));
        let red = b.material(Material::diffuse(Vec3::new(0.8, 0.0, 0.0)));
        let light = b.material(Material::light(Vec3::splat(10.0)));
        let big = 50.0;
        let v = Vec3::new;
        b.quad(
            v(1.0, 0.0, -big),
            v(1.0, h, -big),
            v(1.0, h, big),
            v(1.0, 0.0, big),
            red,
        );
        b.quad(
            v(-1.0, 3.0, -1.0),
            v(0.0, 3.0, -1.0),
            v(0.0, 3.0, 1.0),
            v(-1.0, 3.0, 1.0),
            light,
        );
        with_floor(b, "wall", white, big, Vec3::ZERO)
    }

    #[test]
    fn translational_gradient_matches_finite_differences_next_to_a_wall() {
        // Central differences of E against the gradient on the floor in front of the red wall,
        // for a tall and a low wall (the wall's top edge is the boundary that moves).
        for (h, x) in [(1.0f32, 0.5f32), (0.3, 0.5), (0.3, 0.8)] {
            let scene = wall_scene(h);
            let dx = 0.05;
            let seeds = 8;
            let at = |x: f32| estimate(&scene, Vec3::new(x, 0.0, 0.0), Vec3::Y, seeds);
            let here = at(x);
            let measured = (at(x + dx).irradiance.x - at(x - dx).irradiance.x) / (2.0 * dx);
            let predicted = here.grad_t[0].x;
            assert!(measured > 0.0);
            assert!(
                (predicted - measured).abs() < 0.25 * measured,
                "h {h}, x {x}: predicted {predicted}, measured {measured}"
            );
            // Symmetric along z: no gradient across.
            assert!(
                here.grad_t[0].z.abs() < 0.05 * measured,
                "{}",
                here.grad_t[0]
            );
        }
    }

    /// Adds a floor at y = 0 (half-size `big`, material `floor`) and builds the scene with a camera
    /// at `eye` looking along +x.
    fn with_floor(
        mut b: crate::scene::SceneBuilder,
        name: &str,
        floor: crate::scene::MaterialId,
        big: f32,
        eye: Vec3,
    ) -> Scene {
        use crate::camera::{Camera, Orbit};
        let v = Vec3::new;
        b.quad(
            v(-big, 0.0, -big),
            v(-big, 0.0, big),
            v(big, 0.0, big),
            v(big, 0.0, -big),
            floor,
        );
        let orbit = Orbit {
            center: Vec3::ZERO,
            radius: 1.0,
            look_height: 0.0,
            vfov_degrees: 40.0,
        };
        b.build(name, Camera::look_at(eye, Vec3::X, Vec3::Y, 40.0), orbit)
            .unwrap()
    }

    #[test]
    fn choice_by_distance_is_unbiased_between_two_emitters() {
        use crate::scene::{Material, SceneBuilder};
        // A near 1 x 1 emitter 0.5 above the point and a far, brighter 2 x 2 one 3 above and 4 to
        // the side, both facing down: the emitters are chosen by power over distance, not by
        // power, so the estimate must still average to the quadrature of both.
        let mut b = SceneBuilder::new();
        let near = b.material(Material::light(Vec3::ONE));
        let far = b.material(Material::light(Vec3::splat(4.0)));
        let floor = b.material(Material::diffuse(Vec3::splat(0.5)));
        let v = Vec3::new;
        let down = |b: &mut SceneBuilder, x0: f32, z0: f32, s: f32, y: f32, m| {
            b.quad(
                v(x0, y, z0),
                v(x0 + s, y, z0),
                v(x0 + s, y, z0 + s),
                v(x0, y, z0 + s),
                m,
            )
        };
        down(&mut b, -0.5, -0.5, 1.0, 0.5, near);
        down(&mut b, 3.0, -1.0, 2.0, 3.0, far);
        let scene = with_floor(b, "two", floor, 50.0, Vec3::Y * 0.2);
        assert_eq!(scene.emitter_count(), 2);
        // Midpoint quadrature of L cos cos / d^2 over each square.
        let quad = |x0: f32, z0: f32, s: f32, y: f32, l: f32| {
            let k = 400;
            let da = (s / k as f32) * (s / k as f32);
            let mut e = 0.0f64;
            for i in 0..k {
                for j in 0..k {
                    let p = v(
                        x0 + s * (i as f32 + 0.5) / k as f32,
                        y,
                        z0 + s * (j as f32 + 0.5) / k as f32,
                    );
                    let d2 = p.length_squared();
                    let cos = y / d2.sqrt();
                    e += f64::from(l * cos * cos / d2 * da);
                }
            }
            e as f32
        };
        let expected = quad(-0.5, -0.5, 1.0, 0.5, 1.0) + quad(3.0, -1.0, 2.0, 3.0, 4.0);
        let mut rng = Rng::new(11);
        let mut rays = RayCounts::default();
        let both = [DirectSampling::Bounds, DirectSampling::PowerOverDistance];
        for (samples, sampling) in [1, 8].into_iter().flat_map(|n| both.map(|s| (n, s))) {
            let calls = 65_536 / samples;
            let mean = (0..calls)
                .map(|_| {
                    direct_irradiance(
                        &scene,
                        Vec3::ZERO,
                        Vec3::Y,
                        samples,
                        1e-4,
                        sampling,
                        &mut rng,
                        &mut rays,
                    )
                    .x
                })
                .sum::<f32>()
                / calls as f32;
            assert!(
                (mean - expected).abs() < 0.01 * expected,
                "{samples} samples, {sampling:?}: {mean} vs {expected}"
            );
        }
    }

    /// The irradiance at the origin (normal +y) from the front faces of `triangles` of radiance
    /// `l`, each wholly above the horizon and unoccluded: Lambert's contour formula,
    /// `E = l / 2 |sum over edges of theta_i n . (v_i x v_(i+1)) / |v_i x v_(i+1)||`, in f64.
    fn lambert(triangles: &[[Vec3; 3]], l: f64) -> f64 {
        use glam::DVec3;
        let mut e = 0.0;
        for t in triangles {
            let v = t.map(|p| p.as_dvec3());
            let normal = (v[1] - v[0]).cross(v[2] - v[0]);
            if normal.dot(-v[0]) <= 0.0 {
                continue; // back face
            }
            let mut sum = 0.0;
            for i in 0..3 {
                let (a, b) = (v[i].normalize(), v[(i + 1) % 3].normalize());
                let c = a.cross(b);
                sum += a.dot(b).clamp(-1.0, 1.0).acos() * c.normalize().dot(DVec3::Y);
            }
            e += 0.5 * l * sum.abs();
        }
        e
    }

    /// The mean of `calls` direct-light estimates at the origin (normal +y) with `samples`
    /// samples each, and the variance of one estimate.
    fn direct_mean(
        scene: &Scene,
        samples: u32,
        sampling: DirectSampling,
        calls: u32,
        seed: u64,
    ) -> (f64, f64) {
        let (mean, var, _) = direct_at(scene, Vec3::ZERO, Vec3::Y, samples, sampling, calls, seed);
        (mean, var)
    }

    /// [`direct_mean`] at `x` with normal `n`, and the shadow rays the estimates cast.
    fn direct_at(
        scene: &Scene,
        x: Vec3,
        n: Vec3,
        samples: u32,
        sampling: DirectSampling,
        calls: u32,
        seed: u64,
    ) -> (f64, f64, u64) {
        let mut rng = Rng::new(seed);
        let mut rays = RayCounts::default();
        let (mut sum, mut sq) = (0.0f64, 0.0f64);
        for _ in 0..calls {
            let e = direct_irradiance(scene, x, n, samples, 1e-4, sampling, &mut rng, &mut rays);
            sum += f64::from(e.x);
            sq += f64::from(e.x) * f64::from(e.x);
        }
        let mean = sum / f64::from(calls);
        (mean, sq / f64::from(calls) - mean * mean, rays.shadow)
    }

    /// A bulb of radiance 10 (a sphere of 48 x 24 triangles, radius 0.1) at height 1 over a
    /// floor, and the bulb's material.
    fn bulb_over_a_floor() -> (Scene, crate::scene::MaterialId) {
        use crate::scene::{Material, SceneBuilder};
        let mut b = SceneBuilder::new();
        let bulb = b.material(Material::light(Vec3::splat(10.0)));
        let floor = b.material(Material::diffuse(Vec3::splat(0.5)));
        b.sphere(Vec3::new(0.0, 1.0, 0.0), 0.1, 48, 24, bulb);
        (
            with_floor(b, "bulb", floor, 10.0, Vec3::new(0.0, 0.5, 2.0)),
            bulb,
        )
    }

    /// A bulb over a plane: a sphere of 48 x 24 triangles, radiance 10, radius 0.1 at height 1.
    /// Both estimators' means match Lambert's exact irradiance of its front faces (itself
    /// within 1% of the true sphere's `pi L (r / h)^2`), and the cone sampler's variance is a
    /// small fraction of area sampling's.
    #[test]
    fn a_sphere_light_over_a_plane_matches_its_exact_irradiance() {
        let (scene, bulb) = bulb_over_a_floor();
        let tris: Vec<[Vec3; 3]> = scene
            .triangles()
            .into_iter()
            .filter(|(_, m)| *m == bulb)
            .map(|(t, _)| t)
            .collect();
        let exact = lambert(&tris, 10.0);
        let sphere = std::f64::consts::PI * 10.0 * 0.01;
        assert!((exact / sphere - 1.0).abs() < 0.01, "{exact} vs {sphere}");
        let bounds = DirectSampling::Bounds;
        let (cone, cone_var, shadow) = direct_at(&scene, Vec3::ZERO, Vec3::Y, 4, bounds, 20_000, 1);
        // The whole cone is above the horizon: one shadow ray a sample.
        assert_eq!(shadow, 4 * 20_000);
        let (area, area_var) = direct_mean(&scene, 4, DirectSampling::PowerOverDistance, 20_000, 2);
        for (name, mean) in [("cone", cone), ("area", area)] {
            assert!(
                (mean / exact - 1.0).abs() < 0.01,
                "{name}: {mean} vs {exact}"
            );
        }
        assert!(
            cone_var < 0.2 * area_var,
            "cone {cone_var} vs area {area_var}"
        );
    }

    /// The same bulb seen from a point level with its centre (normal +y): the horizon cuts it in
    /// two. The cone sampler's mean matches the exact irradiance of the upper halves of its front
    /// faces, the triangles clipped to the horizon (`lights::projected_solid_angle`): directions
    /// below the horizon bring nothing, even where they meet the bulb.
    #[test]
    fn a_bulb_cut_by_the_horizon_lights_a_point_by_its_upper_half() {
        let (scene, bulb) = bulb_over_a_floor();
        let (x, n) = (Vec3::new(0.0, 1.0, -1.0), Vec3::Y);
        let origin = (x + n * 1e-4).as_dvec3();
        let exact: f64 = scene
            .triangles()
            .into_iter()
            .filter(|(_, m)| *m == bulb)
            .map(|(t, _)| t.map(|c| c.as_dvec3() - origin))
            .filter(|r| (r[1] - r[0]).cross(r[2] - r[0]).dot(r[0]) < 0.0)
            .map(|r| 10.0 * crate::lights::projected_solid_angle(r, n.as_dvec3()).unwrap())
            .sum();
        let (mean, _, _) = direct_at(&scene, x, n, 4, DirectSampling::Bounds, 20_000, 5);
        assert!((mean / exact - 1.0).abs() < 0.01, "{mean} vs {exact}");
    }

    /// Two quad emitters and an occluder: a panel above the origin with a smaller grey quad
    /// between them, and a panel beside it that crosses the origin's horizon (its centre in the
    /// tangent plane: only its upper half lights the origin). Against a brute-force integral over
    /// both panels with a shadow ray per cell, each estimator's mean agrees at 1, 2 and 8 samples
    /// (one choice of emitter per sample at 1, every emitter sampled at 2 and 8).
    #[test]
    fn two_quads_with_an_occluder_between_match_a_brute_force_integral() {
        use crate::scene::{Material, SceneBuilder};
        let mut b = SceneBuilder::new();
        let top = b.material(Material::light(Vec3::splat(4.0)));
        let side = b.material(Material::light(Vec3::splat(6.0)));
        let grey = b.material(Material::diffuse(Vec3::splat(0.5)));
        let v = Vec3::new;
        // Facing down, 1 above.
        b.quad(
            v(-0.5, 1.0, -0.5),
            v(0.5, 1.0, -0.5),
            v(0.5, 1.0, 0.5),
            v(-0.5, 1.0, 0.5),
            top,
        );
        // Facing -x, at x = 1.5, y from -0.5 to 0.5.
        b.quad(
            v(1.5, -0.5, -0.5),
            v(1.5, -0.5, 0.5),
            v(1.5, 0.5, 0.5),
            v(1.5, 0.5, -0.5),
            side,
        );
        // The occluder, facing down at y = 0.5, covering a corner of the top panel's view.
        b.quad(
            v(-0.4, 0.5, -0.4),
            v(0.0, 0.5, -0.4),
            v(0.0, 0.5, 0.0),
            v(-0.4, 0.5, 0.0),
            grey,
        );
        let orbit = crate::camera::Orbit {
            center: Vec3::ZERO,
            radius: 1.0,
            look_height: 0.0,
            vfov_degrees: 40.0,
        };
        let camera = crate::camera::Camera::look_at(v(0.0, 0.2, 3.0), Vec3::ZERO, Vec3::Y, 40.0);
        let scene = b.build("quads", camera, orbit).unwrap();
        // Brute force: 400 x 400 cells on each panel, the cell's centre seen through a shadow ray.
        let panel = |corner: Vec3, du: Vec3, dv: Vec3, normal: Vec3, l: f64| {
            let cells = 400;
            let area = f64::from(du.cross(dv).length()) / f64::from(cells * cells);
            let mut e = 0.0;
            for i in 0..cells {
                for j in 0..cells {
                    let p = corner
                        + du * ((i as f32 + 0.5) / cells as f32)
                        + dv * ((j as f32 + 0.5) / cells as f32);
                    let d = p - Vec3::Y * 1e-4;
                    let dist = d.length();
                    let w = d / dist;
                    let (cos_x, cos_l) = (w.y, -normal.dot(w));
                    if cos_x > 0.0
                        && cos_l > 0.0
                        && scene.unoccluded(Vec3::Y * 1e-4, w, dist * (1.0 - 1e-3))
                    {
                        e += l * f64::from(cos_x * cos_l / (dist * dist)) * area;
                    }
                }
            }
            e
        };
        let choice = scene.light_choice(Vec3::Y * 1e-4, Vec3::Y, DirectSampling::Bounds);
        assert_eq!(
            choice.reachable_count(),
            2,
            "both panels can light the origin"
        );
        let expected = panel(v(-0.5, 1.0, -0.5), Vec3::X, Vec3::Z, -Vec3::Y, 4.0)
            + panel(v(1.5, -0.5, -0.5), Vec3::Y, Vec3::Z, -Vec3::X, 6.0);
        for sampling in [DirectSampling::Bounds, DirectSampling::PowerOverDistance] {
            for samples in [1, 2, 8] {
                let (mean, _) = direct_mean(
                    &scene,
                    samples,
                    sampling,
                    160_000 / samples,
                    u64::from(samples),
                );
                assert!(
                    (mean / expected - 1.0).abs() < 0.01,
                    "{sampling:?}, {samples} samples: {mean} vs {expected}"
                );
            }
        }
    }

    /// A 4 x 4 emitter of radiance 1 one unit above the origin, centred, over a floor, and its
    /// irradiance at the origin: four 2 x 2 corner rectangles, each with the parallel-rectangle
    /// form factor F = (1 / 2 pi) [X / sqrt(1 + X^2) atan(Y / sqrt(1 + X^2)) + (X <-> Y)],
    /// X = Y = 2; E = pi * L * 4F.
    fn square_over_a_floor() -> (Scene, f32) {
        use crate::scene::{Material, SceneBuilder};
        let mut b = SceneBuilder::new();
        let light = b.material(Material::light(Vec3::ONE));
        let floor = b.material(Material::diffuse(Vec3::splat(0.5)));
        let v = Vec3::new;
        let (a, big) = (2.0f32, 100.0);
        b.quad(
            v(-a, 1.0, -a),
            v(a, 1.0, -a),
            v(a, 1.0, a),
            v(-a, 1.0, a),
            light,
        );
        let scene = with_floor(b, "square", floor, big, Vec3::Y * 0.5);
        let x = a / (1.0 + a * a).sqrt();
        let corner = (2.0 * x * (a / (1.0 + a * a).sqrt()).atan()) / (2.0 * PI);
        (scene, PI * 4.0 * corner)
    }

    /// Nothing between the origin and the square: under the light-bounds estimator the control
    /// variate makes every estimate the exact irradiance, whatever the seed and the count.
    #[test]
    fn an_emitter_seen_whole_is_estimated_exactly() {
        let (scene, expected) = square_over_a_floor();
        let mut rays = RayCounts::default();
        let mut first = None;
        for seed in 0..20 {
            let mut rng = Rng::new(seed);
            for samples in [1, 2, 16] {
                let e = direct_irradiance(
                    &scene,
                    Vec3::ZERO,
                    Vec3::Y,
                    samples,
                    1e-4,
                    DirectSampling::Bounds,
                    &mut rng,
                    &mut rays,
                )
                .x;
                // The same to f32's rounding every time; the analytic value to within what the
                // ray offset (1e-4 towards the square) changes.
                let first = *first.get_or_insert(e);
                assert!(
                    (e / first - 1.0).abs() < 1e-6,
                    "seed {seed}, {samples} samples: {e} against {first}"
                );
                assert!((e / expected - 1.0).abs() < 1e-4, "{e} vs {expected}");
            }
        }
    }

    #[test]
    fn direct_irradiance_matches_the_form_factor_of_a_square() {
        let (scene, expected) = square_over_a_floor();
        let mut rng = Rng::new(3);
        let mut rays = RayCounts::default();
        // Averaged over many pixels, both the stratified path (up to 64 samples) and the plain
        // one (more) are unbiased.
        let both = [DirectSampling::Bounds, DirectSampling::PowerOverDistance];
        for (samples, sampling) in [1, 2, 8, 64, 100]
            .into_iter()
            .flat_map(|n| both.map(|s| (n, s)))
        {
            let calls = 65_536 / samples;
            let before = rays.shadow;
            let mean = (0..calls)
                .map(|_| {
                    let e = direct_irradiance(
                        &scene,
                        Vec3::ZERO,
                        Vec3::Y,
                        samples,
                        1e-4,
                        sampling,
                        &mut rng,
                        &mut rays,
                    );
                    e.x
                })
                .sum::<f32>()
                / calls as f32;
            assert!(
                (mean - expected).abs() < 0.015 * expected,
                "{samples} samples, {sampling:?}: {mean} vs {expected}"
            );
            assert_eq!(rays.shadow - before, u64::from(calls * samples));
        }
        // Facing away from the emitter: nothing.
        let bounds = DirectSampling::Bounds;
        let e = direct_irradiance(
            &scene,
            Vec3::ZERO,
            -Vec3::Y,
            64,
            1e-4,
            bounds,
            &mut rng,
            &mut rays,
        );
        assert_eq!(e, Vec3::ZERO);
        // Just under the emitter looking down: every hemisphere ray hits the floor at distance
        // 1 / cos(theta), and the mean of cos(theta) under cosine-weighted sampling is 2/3, so
        // the harmonic mean distance is 3/2.
        let s = sample_irradiance(
            &scene,
            Vec3::new(0.0, 0.999, 0.0),
            -Vec3::Y,
            Strata::for_rays(1024),
            1e-4,
            &mut rng,
            &mut rays,
        );
        assert!(
            (s.harmonic_mean - 1.5 * 0.999).abs() < 0.02,
            "{}",
            s.harmonic_mean
        );
        assert!(s.irradiance.x > 0.0);
    }
}
