//! Scenes: triangles with diffuse materials, emissive triangles as area lights, and the BVH
//! (obvhs's compressed wide BVH, built once per scene) that answers closest-hit and shadow queries;
//! a scene of at most [`super::flat::FLAT_MAX`] triangles answers them from a flat list instead
//! ([`super::flat`]).

use super::camera::{Camera, Orbit};
/// Rec. 709 luminance, here because scenes and their users weigh colours by it (defined in
/// [`super::colour`], which the lights use too).
pub use super::colour::luminance;
use super::flat::{FlatTriangles, Traversal};
use super::lights::{DirectSampling, Light, LightChoice, Lights, Sampled};
use glam::{Vec3, Vec3A};
use obvhs::cwbvh::{builder::build_cwbvh_from_tris, CwBvh};
use obvhs::ray::{Ray, RayHit};
use obvhs::rt_triangle::RtTriangle;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use std::fmt;
use std::time::Duration;

/// A diffuse (Lambertian) material, optionally emissive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Diffuse reflectance per channel, in `[0, 1)`.
    pub albedo: Vec3,
    /// Emitted radiance per channel (one-sided: towards the triangle's winding normal).
    pub emission: Vec3,
}

impl Material {
    /// A non-emissive diffuse material.
    pub const fn diffuse(albedo: Vec3) -> Self {
        Self {
            albedo,
            emission: Vec3::ZERO,
        }
    }

    /// An emitter with radiance `emission` and a dark diffuse albedo.
    pub const fn light(emission: Vec3) -> Self {
        Self {
            albedo: Vec3::splat(0.78),
            emission,
        }
    }

    /// True when the material emits light.
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}

/// Index of a material in a scene.
pub type MaterialId = u32;

/// Why a scene could not be built.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneError {
    /// No triangle with a non-zero area.
    Empty(String),
    /// A vertex is not finite.
    NonFinite(String),
    /// No emissive triangle: nothing lights the scene.
    NoLights(String),
    /// A built-in scene's file could not be read (the message names the file and line).
    Load(String),
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Empty(name) => write!(f, "scene `{name}` has no triangles"),
            Self::NonFinite(name) => write!(f, "scene `{name}` has a vertex that is not finite"),
            Self::NoLights(name) => write!(
                f,
                "scene `{name}` has no emissive triangle (material with emission): nothing lights it"
            ),
            Self::Load(why) => write!(f, "{why}"),
        }
    }
}

impl std::error::Error for SceneError {}

/// Collects triangles and materials; [`SceneBuilder::build`] makes the BVH.
#[derive(Clone, Debug, Default)]
pub struct SceneBuilder {
    triangles: Vec<[Vec3; 3]>,
    material_of: Vec<MaterialId>,
    materials: Vec<Material>,
}

impl SceneBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a material and returns its id.
    pub fn material(&mut self, m: Material) -> MaterialId {
        self.materials.push(m);
        (self.materials.len() - 1) as MaterialId
    }

    /// Adds a triangle; its winding normal `(b - a) x (c - a)` is the side an emitter lights.
    pub fn triangle(&mut self, a: Vec3, b: Vec3, c: Vec3, m: MaterialId) {
        self.triangles.push([a, b, c]);
        self.material_of.push(m);
    }

    /// Adds the quad `a b c d` (corners in order) as two triangles.
    pub fn quad(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3, m: MaterialId) {
        self.triangle(a, b, c, m);
        self.triangle(a, c, d, m);
    }

    /// Adds a sphere as a latitude/longitude grid of `segments` sectors by `bands` rings, facing
    /// out, its corners on the sphere (inscribed): `2 segments (bands - 1)` triangles (a bulb as
    /// the office's conversion tessellates them, 24 by 12).
    pub fn sphere(&mut self, center: Vec3, radius: f32, segments: u32, bands: u32, m: MaterialId) {
        let point = |band: u32, seg: u32| {
            let theta = std::f32::consts::PI * band as f32 / bands as f32;
            let phi = std::f32::consts::TAU * (seg % segments) as f32 / segments as f32;
            if band == 0 || band == bands {
                // The poles exactly, so their triangles share one corner.
                return center + Vec3::Y * (radius * theta.cos());
            }
            let (s, c) = theta.sin_cos();
            center + radius * Vec3::new(s * phi.cos(), c, s * phi.sin())
        };
        for band in 0..bands {
            for seg in 0..segments {
                let (a, b) = (point(band, seg), point(band, seg + 1));
                let (c, d) = (point(band + 1, seg + 1), point(band + 1, seg));
                if band != 0 {
                    self.triangle(a, b, c, m);
                }
                if band != bands - 1 {
                    self.triangle(a, c, d, m);
                }
            }
        }
    }

    /// Triangles added so far.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The bounding box of the triangles so far.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.triangles.iter().flatten().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        )
    }

    /// True when some triangle uses an emissive material.
    pub fn has_lights(&self) -> bool {
        self.material_of
            .iter()
            .any(|&m| self.materials[m as usize].is_emissive())
    }

    /// Builds the scene: drops zero-area triangles, builds the BVH, lists the lights.
    pub fn build(self, name: &str, camera: Camera, orbit: Orbit) -> Result<Scene, SceneError> {
        let mut triangles = Vec::with_capacity(self.triangles.len());
        let mut material_of = Vec::with_capacity(self.triangles.len());
        for (t, &m) in self.triangles.iter().zip(&self.material_of) {
            if !t.iter().all(|p| p.is_finite()) {
                return Err(SceneError::NonFinite(name.to_owned()));
            }
            if (t[1] - t[0]).cross(t[2] - t[0]).length_squared() > 0.0 {
                triangles.push(Triangle {
                    v0: t[0].into(),
                    v1: t[1].into(),
                    v2: t[2].into(),
                });
                material_of.push(m);
            }
        }
        if triangles.is_empty() {
            return Err(SceneError::Empty(name.to_owned()));
        }
        // obvhs's slowest build (large triangles split into several boxes, every node considered
        // for reinsertion) traces the real scenes' frames a few percent faster than its medium
        // build, for about a second more of loading on the largest scene. A scene traversed flat
        // keeps the medium build: its splits would repeat triangles in the flat list.
        let params = if Traversal::for_triangles(triangles.len()) == Traversal::Flat {
            BvhBuildParams::medium_build()
        } else {
            BvhBuildParams::very_slow_build()
        };
        let bvh = build_cwbvh_from_tris(&triangles, params, &mut Duration::default());
        // Lay the triangles out in the BVH's leaf order, so a leaf's primitive index is the
        // triangle's index (obvhs's cornell_box example does the same).
        let tris: Vec<Tri> = bvh
            .primitive_indices
            .iter()
            .map(|&i| {
                let t = triangles[i as usize];
                let (a, b, c) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
                let cross = (b - a).cross(c - a);
                Tri {
                    geometry: t,
                    normal: cross.normalize(),
                    material: material_of[i as usize],
                }
            })
            .collect();
        let rt: Vec<RtTriangle> = tris.iter().map(|t| RtTriangle::from(&t.geometry)).collect();
        let (lo, hi) = triangles.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), t| {
                let lo = lo.min(t.v0.into()).min(t.v1.into()).min(t.v2.into());
                let hi = hi.max(t.v0.into()).max(t.v1.into()).max(t.v2.into());
                (lo, hi)
            },
        );
        // Lights: every emissive triangle of the *input* (not the BVH copy, which may repeat a
        // triangle under spatial splits), grouped into emitters ([`Lights`]).
        let mut lights = Vec::new();
        let mut light_of = vec![u32::MAX; triangles.len()];
        for (i, (t, &m)) in triangles.iter().zip(&material_of).enumerate() {
            let mat = self.materials[m as usize];
            if mat.is_emissive() {
                light_of[i] = lights.len() as u32;
                let (a, b, c) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
                let cross = (b - a).cross(c - a);
                lights.push(Light {
                    corners: [a, b, c],
                    normal: cross.normalize(),
                    area: 0.5 * cross.length(),
                    emission: mat.emission,
                });
            }
        }
        if lights.is_empty() {
            return Err(SceneError::NoLights(name.to_owned()));
        }
        let lights = Lights::new(lights);
        let emitter_of = bvh
            .primitive_indices
            .iter()
            .map(|&i| match light_of[i as usize] {
                u32::MAX => u32::MAX,
                l => lights.emitter_of(l as usize),
            })
            .collect();
        Ok(Scene {
            emitter_of,
            name: name.to_owned(),
            input_triangles: triangles.len(),
            tris,
            flat: (Traversal::for_triangles(rt.len()) == Traversal::Flat)
                .then(|| FlatTriangles::new(&rt)),
            rt,
            materials: self.materials,
            bvh,
            lights,
            bounds: (lo, hi),
            camera,
            orbit,
        })
    }
}

impl Camera {
    /// The camera at time `t` (turns) of `scene`'s orbit. See [`Camera::on_orbit`]. (Here, with
    /// the scene, so the camera module need not know scenes.)
    pub fn orbit(scene: &Scene, t: f32) -> Self {
        Self::on_orbit(scene.orbit(), t)
    }
}

#[derive(Clone, Copy, Debug)]
struct Tri {
    geometry: Triangle,
    normal: Vec3,
    material: MaterialId,
}

/// A ray's closest hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the (unit) ray.
    pub t: f32,
    /// Unit geometric normal, as wound (not flipped towards the ray).
    pub normal: Vec3,
    /// The surface's material.
    pub material: Material,
}

/// A scene ready to render: triangles in BVH order, materials, lights, bounds, a default camera.
pub struct Scene {
    name: String,
    input_triangles: usize,
    tris: Vec<Tri>,
    /// Per triangle of `tris`, the emitter it belongs to (`u32::MAX`: it emits nothing).
    emitter_of: Vec<u32>,
    /// The same triangles with their edges and normal precomputed for intersection (obvhs's
    /// `RtTriangle`), apart from `tris` so traversal reads 64 bytes a triangle and no more.
    rt: Vec<RtTriangle>,
    materials: Vec<Material>,
    /// The triangles in batches (`rt`'s order) when the scene is traversed flat.
    flat: Option<FlatTriangles>,
    bvh: CwBvh,
    lights: Lights,
    bounds: (Vec3, Vec3),
    camera: Camera,
    orbit: Orbit,
}

impl fmt::Debug for Scene {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Scene")
            .field("name", &self.name)
            .field("triangles", &self.input_triangles)
            .field("lights", &self.lights.triangles().len())
            .field("bounds", &self.bounds)
            .finish_non_exhaustive()
    }
}

impl Scene {
    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Every triangle with a non-zero area once, as its corners (in winding order) and its
    /// material's index in [`Scene::materials`]: what an exporter to another renderer needs
    /// (`wfic compare radiance`). In BVH leaf order, not input order.
    pub fn triangles(&self) -> Vec<([Vec3; 3], MaterialId)> {
        // The BVH's leaves may list a triangle more than once (spatial splits): keep the first.
        let mut seen = vec![false; self.input_triangles];
        let mut out = Vec::with_capacity(self.input_triangles);
        for (t, &i) in self.tris.iter().zip(&self.bvh.primitive_indices) {
            if !std::mem::replace(&mut seen[i as usize], true) {
                let g = t.geometry;
                out.push(([g.v0.into(), g.v1.into(), g.v2.into()], t.material));
            }
        }
        out
    }

    /// Triangles with a non-zero area.
    pub fn triangle_count(&self) -> usize {
        self.input_triangles
    }

    /// How rays find triangles: flat for a scene of at most [`crate::flat::FLAT_MAX`]
    /// triangles, else the BVH ([`Traversal::for_triangles`]).
    pub fn traversal(&self) -> Traversal {
        if self.flat.is_some() {
            Traversal::Flat
        } else {
            Traversal::Bvh
        }
    }

    /// The same scene traversed by `traversal` whatever its size: for the benchmark that sets
    /// [`crate::flat::FLAT_MAX`] and the test that holds both to the same hits.
    pub fn with_traversal(mut self, traversal: Traversal) -> Self {
        self.flat = match traversal {
            Traversal::Flat => Some(FlatTriangles::new(&self.rt)),
            Traversal::Bvh => None,
        };
        self
    }

    /// Emissive triangles.
    pub fn light_count(&self) -> usize {
        self.lights.triangles().len()
    }

    /// The smallest luminance an emitter has: a diffuse surface lit by the scene reflects less than
    /// this (its albedo is below 1), so pixels above it see an emitter.
    pub fn min_emitter_luminance(&self) -> f32 {
        self.lights
            .triangles()
            .iter()
            .map(|l| luminance(l.emission))
            .fold(f32::INFINITY, f32::min)
    }

    /// Each emissive triangle's centroid and emitting (unit) normal.
    pub fn emitters(&self) -> impl Iterator<Item = (Vec3, Vec3)> + '_ {
        self.lights
            .triangles()
            .iter()
            .map(|l| ((l.corners[0] + l.corners[1] + l.corners[2]) / 3.0, l.normal))
    }

    /// Total area of the emissive triangles.
    pub fn light_area(&self) -> f32 {
        self.lights.triangles().iter().map(|l| l.area).sum()
    }

    /// Axis-aligned bounds `(min, max)`.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// Length of the bounds' diagonal: the scene's size.
    pub fn diagonal(&self) -> f32 {
        (self.bounds.1 - self.bounds.0).length()
    }

    /// The default camera.
    pub fn camera(&self) -> Camera {
        self.camera
    }

    /// The orbit for animations.
    pub fn orbit(&self) -> &Orbit {
        &self.orbit
    }

    /// Replaces the default camera.
    pub fn set_camera(&mut self, camera: Camera) {
        self.camera = camera;
    }

    /// The materials.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// The closest hit along the unit ray `origin + t dir`, `t` in `(0, t_max)`.
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
        self.nearest(origin, dir, t_max).map(|(t, id)| {
            let tri = &self.tris[id as usize];
            Hit {
                t,
                normal: tri.normal,
                material: self.materials[tri.material as usize],
            }
        })
    }

    /// The distance and the index (in `tris`' order) of the nearest triangle the unit ray meets.
    #[inline]
    fn nearest(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<(f32, u32)> {
        if let Some(flat) = &self.flat {
            flat.closest(origin, dir, t_max)
        } else {
            let ray = Ray::new(Vec3A::from(origin), Vec3A::from(dir), 0.0, t_max);
            let mut hit = RayHit::none();
            self.bvh
                .ray_traverse(ray, &mut hit, |r, id| self.rt[id].intersect(r))
                .then_some((hit.t, hit.primitive_id))
        }
    }

    /// True when nothing blocks the unit ray `origin + t dir` for `t` in `(0, t_max)`.
    #[inline]
    pub fn unoccluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        if let Some(flat) = &self.flat {
            return !flat.occluded(origin, dir, t_max);
        }
        let ray = Ray::new(Vec3A::from(origin), Vec3A::from(dir), 0.0, t_max);
        self.bvh
            .ray_traverse_miss(ray, |r, id| self.rt[id].intersect(r))
    }

    /// The emitter probabilities at `x` with unit facing normal `n` ([`Lights::choice`]).
    #[inline]
    pub fn light_choice(&self, x: Vec3, n: Vec3, sampling: DirectSampling) -> LightChoice {
        self.lights.choice(x, n, sampling)
    }

    /// [`Scene::light_choice`] written into `choice` ([`Lights::choice_into`]).
    #[inline]
    pub fn light_choice_into(
        &self,
        x: Vec3,
        n: Vec3,
        sampling: DirectSampling,
        choice: &mut LightChoice,
    ) {
        self.lights.choice_into(x, n, sampling, choice)
    }

    /// The light sample for the uniform numbers `u` in `[0, 1)^3` under `choice`
    /// ([`Lights::sample`]); `None` when no emitter can light the point.
    #[inline]
    pub fn light_sample(&self, choice: &LightChoice, u: [f32; 3]) -> Option<Sampled> {
        self.lights.sample(choice, u)
    }

    /// A sample of emitter `k` alone ([`Lights::sample_emitter`]).
    #[inline]
    pub fn emitter_sample(&self, choice: &LightChoice, k: usize, u: [f32; 3]) -> Option<Sampled> {
        self.lights.sample_emitter(choice, k, 1.0, u)
    }

    /// Emitter `k`'s irradiance at `x` were nothing in the way ([`Lights::unoccluded_irradiance`]).
    #[inline]
    pub fn emitter_unoccluded(
        &self,
        choice: &LightChoice,
        k: usize,
        x: Vec3,
        n: Vec3,
    ) -> Option<Vec3> {
        self.lights.unoccluded_irradiance(choice, k, x, n)
    }

    /// The emitter whose front face the unit ray `origin + t dir`, `t < t_max`, meets first, if
    /// what it meets first is an emitter's front face.
    #[inline]
    pub fn emitter_hit(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<u32> {
        let (_, id) = self.nearest(origin, dir, t_max)?;
        let tri = &self.tris[id as usize];
        let emitter = self.emitter_of[id as usize];
        (emitter != u32::MAX && tri.normal.dot(dir) < 0.0).then_some(emitter)
    }

    /// Emitters: touching emissive triangles of one radiance.
    pub fn emitter_count(&self) -> usize {
        self.lights.emitter_count()
    }
}
