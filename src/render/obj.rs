//! Wavefront OBJ and MTL loading: positions (`v`), faces (`f`, polygons fanned into triangles,
//! negative indices allowed), materials (`mtllib`, `usemtl`; in the MTL `newmtl`, `Kd` diffuse
//! colour, `Ke` emission). Everything else (texture coordinates, normals, groups, smoothing) is
//! read past. Errors name the file and the line.
//!
//! A hand-written reader rather than `tobj`: it is short, and it can say which line of which file
//! is wrong, which the issue asks for.

use super::camera::{Camera, Orbit};
use super::scene::{Material, MaterialId, Scene, SceneBuilder, SceneError};
use glam::Vec3;
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// Why an OBJ scene could not be loaded.
#[derive(Debug)]
pub struct ObjError {
    /// The file at fault.
    pub file: PathBuf,
    /// The line at fault (1-based), when there is one.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ObjError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{line}: {}", self.file.display(), self.message),
            None => write!(f, "{}: {}", self.file.display(), self.message),
        }
    }
}

impl std::error::Error for ObjError {}

fn err(file: &Path, line: Option<usize>, message: impl Into<String>) -> ObjError {
    ObjError {
        file: file.to_owned(),
        line,
        message: message.into(),
    }
}

fn read(file: &Path) -> Result<String, ObjError> {
    std::fs::read_to_string(file).map_err(|e| err(file, None, format!("cannot read: {e}")))
}

fn floats<const N: usize>(
    file: &Path,
    line: usize,
    what: &str,
    words: &mut std::str::SplitWhitespace<'_>,
) -> Result<[f32; N], ObjError> {
    let mut out = [0.0; N];
    for (i, o) in out.iter_mut().enumerate() {
        let w = words.next().ok_or_else(|| {
            err(
                file,
                Some(line),
                format!("`{what}` needs {N} numbers, found {i}"),
            )
        })?;
        *o = w
            .parse::<f32>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| err(file, Some(line), format!("`{w}` is not a finite number")))?;
    }
    Ok(out)
}

/// Reads the materials of an MTL file into `out` (name -> material).
fn read_mtl(file: &Path, out: &mut HashMap<String, Material>) -> Result<(), ObjError> {
    let text = read(file)?;
    let mut current: Option<String> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let mut words = raw.split_whitespace();
        let Some(key) = words.next() else { continue };
        match key {
            "newmtl" => {
                let name = words.collect::<Vec<_>>().join(" ");
                if name.is_empty() {
                    return Err(err(file, Some(line), "`newmtl` without a name"));
                }
                out.insert(name.clone(), Material::diffuse(Vec3::splat(0.7)));
                current = Some(name);
            }
            "Kd" | "Ke" => {
                let name = current
                    .as_ref()
                    .ok_or_else(|| err(file, Some(line), format!("`{key}` before any `newmtl`")))?;
                let [r, g, b] = floats::<3>(file, line, key, &mut words)?;
                let c = Vec3::new(r, g, b);
                if c.min_element() < 0.0 {
                    return Err(err(
                        file,
                        Some(line),
                        format!("`{key}` has a negative channel"),
                    ));
                }
                let m = out.get_mut(name).expect("inserted at newmtl");
                if key == "Kd" {
                    // A diffuse reflectance of 1 or more would not conserve energy.
                    m.albedo = c.min(Vec3::splat(0.95));
                } else {
                    m.emission = c;
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Resolves an OBJ index (1-based, or negative from the end) against `count` vertices so far.
fn resolve(word: &str, count: usize, file: &Path, line: usize) -> Result<usize, ObjError> {
    let first = word.split('/').next().unwrap_or("");
    let i: i64 = first
        .parse()
        .map_err(|_| err(file, Some(line), format!("`{word}` is not a vertex index")))?;
    let index = if i > 0 {
        i - 1
    } else if i < 0 {
        count as i64 + i
    } else {
        -1
    };
    if index < 0 || index >= count as i64 {
        return Err(err(
            file,
            Some(line),
            format!("vertex index {i} is out of range ({count} vertices so far)"),
        ));
    }
    Ok(index as usize)
}

/// Loads an OBJ file (and the MTL files it names, relative to it) into a scene builder.
pub fn load_builder(file: &Path) -> Result<SceneBuilder, ObjError> {
    let text = read(file)?;
    let dir = file.parent().unwrap_or(Path::new("."));
    let mut b = SceneBuilder::new();
    let default = b.material(Material::diffuse(Vec3::splat(0.7)));
    let mut library: HashMap<String, Material> = HashMap::new();
    let mut ids: HashMap<String, MaterialId> = HashMap::new();
    let mut current = default;
    let mut positions: Vec<Vec3> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let raw = raw.split('#').next().unwrap_or("");
        let mut words = raw.split_whitespace();
        let Some(key) = words.next() else { continue };
        match key {
            "v" => {
                let [x, y, z] = floats::<3>(file, line, "v", &mut words)?;
                positions.push(Vec3::new(x, y, z));
            }
            "f" => {
                let corners = words
                    .map(|w| resolve(w, positions.len(), file, line))
                    .collect::<Result<Vec<_>, _>>()?;
                if corners.len() < 3 {
                    return Err(err(
                        file,
                        Some(line),
                        format!("a face needs at least 3 vertices, found {}", corners.len()),
                    ));
                }
                for k in 1..corners.len() - 1 {
                    b.triangle(
                        positions[corners[0]],
                        positions[corners[k]],
                        positions[corners[k + 1]],
                        current,
                    );
                }
            }
            "mtllib" => {
                let names: Vec<&str> = words.collect();
                if names.is_empty() {
                    return Err(err(file, Some(line), "`mtllib` without a file name"));
                }
                for name in names {
                    read_mtl(&dir.join(name), &mut library).map_err(|mut e| {
                        e.message = format!("{} (named by {}:{line})", e.message, file.display());
                        e
                    })?;
                }
            }
            "usemtl" => {
                let name = words.collect::<Vec<_>>().join(" ");
                current = match ids.get(&name) {
                    Some(&id) => id,
                    None => {
                        let m = *library.get(&name).ok_or_else(|| {
                            err(
                                file,
                                Some(line),
                                format!("material `{name}` is not defined by any mtllib"),
                            )
                        })?;
                        let id = b.material(m);
                        ids.insert(name, id);
                        id
                    }
                };
            }
            "vt" | "vn" | "vp" | "g" | "o" | "s" | "l" | "p" => {}
            other => {
                return Err(err(
                    file,
                    Some(line),
                    format!("unknown statement `{other}`"),
                ));
            }
        }
    }
    if b.triangle_count() == 0 {
        return Err(err(file, None, "no faces: the file holds no triangles"));
    }
    Ok(b)
}

/// Loads an OBJ scene. When no material emits, a light panel is added under the top of the
/// bounding box (30% of the horizontal extent, facing down), so scenes exported without
/// emission (Crytek's Sponza) still render; the default camera stands inside the bounds at a
/// fifth of the longer horizontal axis, looking along it.
pub fn load(file: &Path) -> Result<Scene, ObjError> {
    let mut b = load_builder(file)?;
    let (lo, hi) = b.bounds();
    let size = hi - lo;
    let centre = (lo + hi) * 0.5;
    if !b.has_lights() {
        let m = b.material(Material::light(Vec3::splat(10.0)));
        let (hx, hz) = (size.x * 0.15, size.z * 0.15);
        let y = hi.y - 0.02 * size.y.max(1e-3);
        let (x0, x1, z0, z1) = (centre.x - hx, centre.x + hx, centre.z - hz, centre.z + hz);
        b.quad(
            Vec3::new(x0, y, z0),
            Vec3::new(x1, y, z0),
            Vec3::new(x1, y, z1),
            Vec3::new(x0, y, z1),
            m,
        );
    }
    let axis = if size.x >= size.z { Vec3::X } else { Vec3::Z };
    let reach = size.dot(axis) * 0.3;
    let eye = centre - axis * reach - Vec3::Y * size.y * 0.2;
    let camera = Camera::look_at(eye, centre + axis * reach, Vec3::Y, 60.0);
    let orbit = Orbit {
        center: centre - Vec3::Y * size.y * 0.2,
        radius: 0.2 * size.x.min(size.z),
        look_height: centre.y - size.y * 0.3,
        vfov_degrees: 65.0,
    };
    let name = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "obj".to_owned());
    b.build(&name, camera, orbit)
        .map_err(|e: SceneError| err(file, None, e.to_string()))
}
