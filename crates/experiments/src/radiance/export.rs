//! A scene written as a Radiance user would model it: surfaces as triangles, but each light
//! source as the one primitive it is. A triangle mesh carries no primitives, so they are
//! recovered from the emitting triangles:
//!
//! - a **sphere** where a closed, edge-connected set of emitting triangles of one material has
//!   every vertex at one distance from its centre (within 2%) and every triangle facing away
//!   from it (a tessellated bulb). Its radius is the one whose sphere has the triangles' area,
//!   so it emits the same power;
//! - a **polygon** where edge-connected emitting triangles of one material lie in one plane and
//!   their outline is one loop (a ceiling panel split in two);
//! - the triangles themselves otherwise.
//!
//! Radiance samples every light source on its own (`-ds`, `-dt`, `-dc`), so a bulb left as 528
//! triangles costs it 528 sources a shading point; one `sphere` is what its users write. The
//! emitted power of the export (`pi L A` summed over the sources) is reported beside the scene's.

use glam::{DVec3, Vec3};
use std::collections::HashMap;
use std::io::{BufWriter, Write};
use std::path::Path;
use wfic_render::Scene;

/// One light source of the export.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// A sphere, emitting outwards.
    Sphere {
        /// The emitting material's index.
        material: usize,
        /// Centre.
        center: Vec3,
        /// Radius (the sphere of the triangles' area).
        radius: f32,
        /// The triangles it replaces.
        triangles: usize,
    },
    /// A planar polygon, corners in the triangles' winding.
    Polygon {
        /// The emitting material's index.
        material: usize,
        /// Corners.
        corners: Vec<Vec3>,
        /// The triangles it replaces.
        triangles: usize,
    },
}

impl Source {
    /// Its area.
    pub fn area(&self) -> f64 {
        match self {
            Self::Sphere { radius, .. } => 4.0 * std::f64::consts::PI * f64::from(*radius).powi(2),
            Self::Polygon { corners, .. } => newell(corners).length() * 0.5,
        }
    }

    fn material(&self) -> usize {
        match self {
            Self::Sphere { material, .. } | Self::Polygon { material, .. } => *material,
        }
    }
}

/// What an export wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct Export {
    /// Triangles written as `polygon`s (the surfaces).
    pub surface_triangles: usize,
    /// Emitting triangles of the scene.
    pub emitting_triangles: usize,
    /// The light sources they became.
    pub sources: Vec<Source>,
    /// The scene's emitted power, `pi L A` summed over its emitting triangles (RGB).
    pub scene_power: DVec3,
    /// The export's, summed over its sources.
    pub export_power: DVec3,
}

impl Export {
    /// Spheres among the sources.
    pub fn spheres(&self) -> usize {
        self.sources
            .iter()
            .filter(|s| matches!(s, Source::Sphere { .. }))
            .count()
    }

    /// The largest relative difference of the export's power from the scene's, over the
    /// channels that emit.
    pub fn power_error(&self) -> f64 {
        let (a, b) = (self.export_power, self.scene_power);
        [(a.x, b.x), (a.y, b.y), (a.z, b.z)]
            .iter()
            .filter(|(_, b)| *b > 0.0)
            .map(|(a, b)| (a / b - 1.0).abs())
            .fold(0.0, f64::max)
    }
}

/// The exact position of a vertex, as a key.
type Key = [u32; 3];

fn key(v: Vec3) -> Key {
    [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
}

fn dv(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

/// Twice the area vector of a closed polygon (Newell's method).
fn newell(corners: &[Vec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (i, a) in corners.iter().enumerate() {
        let b = corners[(i + 1) % corners.len()];
        n += dv(*a).cross(dv(b));
    }
    n
}

/// Union-find over triangle indices.
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// The groups of `tris` (indices into `all`) that share an edge, transitively.
fn edge_components(all: &[[Vec3; 3]], tris: &[usize]) -> Vec<Vec<usize>> {
    let mut parent: Vec<usize> = (0..tris.len()).collect();
    let mut by_edge: HashMap<(Key, Key), usize> = HashMap::new();
    for (slot, &t) in tris.iter().enumerate() {
        let v = all[t];
        for e in 0..3 {
            let (a, b) = (key(v[e]), key(v[(e + 1) % 3]));
            let edge = if a < b { (a, b) } else { (b, a) };
            match by_edge.get(&edge) {
                Some(&other) => {
                    let (x, y) = (find(&mut parent, slot), find(&mut parent, other));
                    parent[x] = y;
                }
                None => {
                    by_edge.insert(edge, slot);
                }
            }
        }
    }
    let mut groups: HashMap<usize, Vec<usize>> = HashMap::new();
    for (slot, &t) in tris.iter().enumerate() {
        groups.entry(find(&mut parent, slot)).or_default().push(t);
    }
    let mut out: Vec<Vec<usize>> = groups.into_values().collect();
    out.sort();
    out
}

/// The sphere `group` tessellates ([`wfic_render::lights::sphere_like`]): its centre and the
/// radius of the sphere of its area.
fn as_sphere(all: &[[Vec3; 3]], group: &[usize]) -> Option<(Vec3, f32)> {
    let corners: Vec<[Vec3; 3]> = group.iter().map(|&t| all[t]).collect();
    wfic_render::lights::sphere_like(&corners).map(|s| (s.center, s.area_radius))
}

/// The triangles of `group` split by plane: unit normal within 1e-4, offset within 1e-5 of the
/// group's size.
fn by_plane(all: &[[Vec3; 3]], group: &[usize]) -> Vec<Vec<usize>> {
    let mut planes: Vec<(DVec3, f64, Vec<usize>)> = Vec::new();
    for &t in group {
        let [a, b, c] = all[t].map(dv);
        let n = (b - a).cross(c - a).normalize_or_zero();
        let d = n.dot(a);
        let scale = a.abs().max_element().max(1.0);
        match planes
            .iter_mut()
            .find(|(m, e, _)| m.distance(n) < 1e-4 && (e - d).abs() < 1e-5 * scale)
        {
            Some((_, _, tris)) => tris.push(t),
            None => planes.push((n, d, vec![t])),
        }
    }
    planes.into_iter().map(|(_, _, t)| t).collect()
}

/// The outline of coplanar, edge-connected triangles as one loop of corners in their winding
/// (collinear corners dropped), or `None` when it is not one loop (a hole, a pinch).
fn outline(all: &[[Vec3; 3]], tris: &[usize]) -> Option<Vec<Vec3>> {
    let mut directed: HashMap<(Key, Key), usize> = HashMap::new();
    let mut at: HashMap<Key, Vec3> = HashMap::new();
    for &t in tris {
        let v = all[t];
        for e in 0..3 {
            let (a, b) = (key(v[e]), key(v[(e + 1) % 3]));
            *directed.entry((a, b)).or_default() += 1;
            at.insert(a, v[e]);
        }
    }
    // The boundary: edges no neighbour walks the other way.
    let mut next: HashMap<Key, Key> = HashMap::new();
    for (&(a, b), &n) in &directed {
        if n != 1 || directed.contains_key(&(b, a)) {
            continue;
        }
        if next.insert(a, b).is_some() {
            return None;
        }
    }
    let start = *next.keys().min()?;
    let mut loop_ = vec![start];
    let mut k = next[&start];
    while k != start {
        if loop_.len() > next.len() {
            return None;
        }
        loop_.push(k);
        k = *next.get(&k)?;
    }
    if loop_.len() != next.len() {
        return None;
    }
    let pts: Vec<Vec3> = loop_.iter().map(|k| at[k]).collect();
    let n = pts.len();
    let corners: Vec<Vec3> = (0..n)
        .filter(|&i| {
            let (p, c, q) = (dv(pts[(i + n - 1) % n]), dv(pts[i]), dv(pts[(i + 1) % n]));
            (c - p).cross(q - c).length() > 1e-9 * (c - p).length() * (q - c).length()
        })
        .map(|i| pts[i])
        .collect();
    (corners.len() >= 3).then_some(corners)
}

/// The light sources of `scene`: every emitting triangle in exactly one.
pub fn sources(scene: &Scene) -> Vec<Source> {
    let tris = scene.triangles();
    let all: Vec<[Vec3; 3]> = tris.iter().map(|(v, _)| *v).collect();
    let mut by_material: Vec<Vec<usize>> = vec![Vec::new(); scene.materials().len()];
    for (i, (_, m)) in tris.iter().enumerate() {
        if scene.materials()[*m as usize].is_emissive() {
            by_material[*m as usize].push(i);
        }
    }
    let mut out = Vec::new();
    for (material, emitting) in by_material.iter().enumerate() {
        for group in edge_components(&all, emitting) {
            if let Some((center, radius)) = as_sphere(&all, &group) {
                out.push(Source::Sphere {
                    material,
                    center,
                    radius,
                    triangles: group.len(),
                });
                continue;
            }
            for plane in by_plane(&all, &group) {
                for piece in edge_components(&all, &plane) {
                    match outline(&all, &piece) {
                        Some(corners) => out.push(Source::Polygon {
                            material,
                            corners,
                            triangles: piece.len(),
                        }),
                        None => out.extend(piece.iter().map(|&t| Source::Polygon {
                            material,
                            corners: all[t].to_vec(),
                            triangles: 1,
                        })),
                    }
                }
            }
        }
    }
    out
}

/// Writes `scene` as a Radiance scene file: one `plastic` (no specular: Lambertian) or `light`
/// per material, one `polygon` per surface triangle, and its light sources as [`sources`] finds
/// them. Corners keep wfic's winding (Radiance's front side, from which a `light` emits, is the
/// one the right-hand rule points to, as in wfic).
///
/// # Errors
/// The file cannot be written.
pub fn write_rad(scene: &Scene, path: &Path) -> Result<Export, String> {
    let tris = scene.triangles();
    let materials = scene.materials();
    let sources = sources(scene);
    let mut scene_power = DVec3::ZERO;
    let mut surface_triangles = 0;
    for ([a, b, c], m) in &tris {
        let m = &materials[*m as usize];
        if m.is_emissive() {
            let area = 0.5 * (dv(*b) - dv(*a)).cross(dv(*c) - dv(*a)).length();
            scene_power += std::f64::consts::PI * area * m.emission.as_dvec3();
        } else {
            surface_triangles += 1;
        }
    }
    let export_power = sources
        .iter()
        .map(|s| std::f64::consts::PI * s.area() * materials[s.material()].emission.as_dvec3())
        .sum();
    let write = || -> std::io::Result<()> {
        let mut w = BufWriter::new(std::fs::File::create(path)?);
        let (name, version) = (scene.name(), env!("CARGO_PKG_VERSION"));
        writeln!(
            w,
            "# {name} exported by wfic {version}: {} triangles, {} light sources",
            tris.len(),
            sources.len()
        )?;
        for (i, m) in materials.iter().enumerate() {
            let (kind, args) = if m.is_emissive() {
                let e = m.emission;
                ("light", format!("3 {} {} {}", e.x, e.y, e.z))
            } else {
                let a = m.albedo;
                ("plastic", format!("5 {} {} {} 0 0", a.x, a.y, a.z))
            };
            writeln!(w, "void {kind} m{i}\n0\n0\n{args}\n")?;
        }
        let corners = |pts: &[Vec3]| -> String {
            pts.iter()
                .map(|p| format!("{} {} {}", p.x, p.y, p.z))
                .collect::<Vec<_>>()
                .join(" ")
        };
        for (k, (v, m)) in tris.iter().enumerate() {
            if !materials[*m as usize].is_emissive() {
                writeln!(w, "m{m} polygon t{k}\n0\n0\n9 {}", corners(v))?;
            }
        }
        for (k, s) in sources.iter().enumerate() {
            match s {
                Source::Sphere {
                    material,
                    center: c,
                    radius,
                    ..
                } => writeln!(
                    w,
                    "m{material} sphere s{k}\n0\n0\n4 {} {} {} {radius}",
                    c.x, c.y, c.z
                )?,
                Source::Polygon {
                    material,
                    corners: p,
                    ..
                } => writeln!(
                    w,
                    "m{material} polygon s{k}\n0\n0\n{} {}",
                    3 * p.len(),
                    corners(p)
                )?,
            }
        }
        w.flush()
    };
    write().map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(Export {
        surface_triangles,
        emitting_triangles: tris.len() - surface_triangles,
        sources,
        scene_power,
        export_power,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use wfic_render::camera::{Camera, Orbit};
    use wfic_render::scene::{Material, SceneBuilder};

    /// A floor, a bulb tessellated as a latitude/longitude sphere (24 x 12, facing out, as the
    /// office's conversion makes them) and a ceiling panel of two triangles.
    fn lamp_scene() -> Scene {
        let mut b = SceneBuilder::new();
        let white = b.material(Material::diffuse(Vec3::splat(0.5)));
        let bulb = b.material(Material::light(Vec3::splat(500.0)));
        let panel = b.material(Material::light(Vec3::new(75.0, 70.0, 60.0)));
        let v = Vec3::new;
        b.quad(
            v(-2.0, 0.0, -2.0),
            v(-2.0, 0.0, 2.0),
            v(2.0, 0.0, 2.0),
            v(2.0, 0.0, -2.0),
            white,
        );
        b.sphere(v(0.3, 1.0, -0.2), 0.0317, 24, 12, bulb);
        b.quad(
            v(-0.5, 2.0, -0.5),
            v(0.5, 2.0, -0.5),
            v(0.5, 2.0, 0.5),
            v(-0.5, 2.0, 0.5),
            panel,
        );
        let orbit = Orbit {
            center: Vec3::ZERO,
            radius: 1.0,
            look_height: 0.0,
            vfov_degrees: 40.0,
        };
        b.build(
            "lamp",
            Camera::look_at(v(0.0, 1.0, 3.0), Vec3::ZERO, Vec3::Y, 40.0),
            orbit,
        )
        .unwrap()
    }

    /// `(sphere count, polygon corner counts)` of a written scene file's light sources, and
    /// their power `pi L A`, read back from the file's text.
    fn read_back(text: &str) -> (usize, Vec<usize>, DVec3) {
        let tokens: Vec<&str> = text
            .lines()
            .filter(|l| !l.starts_with('#'))
            .flat_map(str::split_whitespace)
            .collect();
        let mut lights: HashMap<&str, DVec3> = HashMap::new();
        let (mut spheres, mut polygons, mut power) = (0, Vec::new(), DVec3::ZERO);
        let mut i = 0;
        while i < tokens.len() {
            let (modifier, kind, name) = (tokens[i], tokens[i + 1], tokens[i + 2]);
            let n: usize = tokens[i + 5].parse().unwrap();
            let args: Vec<f64> = tokens[i + 6..i + 6 + n]
                .iter()
                .map(|t| t.parse().unwrap())
                .collect();
            i += 6 + n;
            match (kind, lights.get(modifier)) {
                ("light", _) => {
                    lights.insert(name, DVec3::new(args[0], args[1], args[2]));
                }
                ("sphere", Some(l)) => {
                    spheres += 1;
                    power +=
                        std::f64::consts::PI * 4.0 * std::f64::consts::PI * args[3] * args[3] * *l;
                }
                ("polygon", Some(l)) => {
                    let corners: Vec<Vec3> = args
                        .chunks(3)
                        .map(|c| DVec3::from_slice(c).as_vec3())
                        .collect();
                    polygons.push(corners.len());
                    power += std::f64::consts::PI * 0.5 * newell(&corners).length() * *l;
                }
                _ => {}
            }
        }
        (spheres, polygons, power)
    }

    #[test]
    fn a_tessellated_bulb_becomes_one_sphere_and_a_split_panel_one_polygon_of_equal_power() {
        let scene = lamp_scene();
        let path = std::env::temp_dir().join(format!("wfic-export-{}.rad", std::process::id()));
        let export = write_rad(&scene, &path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(export.emitting_triangles, 24 * 12 * 2 - 2 * 24 + 2);
        assert_eq!(export.surface_triangles, 2);
        let (spheres, polygons, power) = read_back(&text);
        assert_eq!((spheres, polygons), (1, vec![4]), "{:?}", export.sources);
        let Source::Sphere { center, radius, .. } = export.sources[0] else {
            panic!("{:?}", export.sources[0]);
        };
        assert!(
            center.distance(Vec3::new(0.3, 1.0, -0.2)) < 1e-4,
            "{center}"
        );
        // The sphere of the inscribed triangles' area is a little smaller than the true one.
        assert!(radius < 0.0317 && radius > 0.0317 * 0.98, "{radius}");
        // The power the file emits, read back from it, is the scene's.
        let ratio = power / export.scene_power;
        assert!((ratio - DVec3::ONE).abs().max_element() < 0.01, "{ratio}");
        assert!(export.power_error() < 1e-6, "{}", export.power_error());
    }

    /// The built-in scenes' emitters become the light sources their models have: the office's
    /// two panels and the lamp's bulb, the conference room's twelve troffers, one quad in
    /// the Cornell box and one in Sponza; the power is kept within 1%.
    #[test]
    fn the_built_in_scenes_export_their_emitters_as_their_models_have_them() {
        for (name, spheres, polygons) in [
            ("cornell", 0, 1),
            ("desk", 1, 2),
            ("conference", 0, 12),
            ("sponza", 0, 1),
        ] {
            let scene = wfic_render::scenes::load(name).unwrap();
            let path =
                std::env::temp_dir().join(format!("wfic-export-{name}-{}.rad", std::process::id()));
            let export = write_rad(&scene, &path).unwrap();
            std::fs::remove_file(&path).ok();
            assert_eq!(
                (export.spheres(), export.sources.len() - export.spheres()),
                (spheres, polygons),
                "{name}: {:?}",
                export.sources
            );
            assert!(
                export.power_error() < 0.01,
                "{name}: {}",
                export.power_error()
            );
        }
    }
}
