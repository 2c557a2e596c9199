//! The paper's five scenes (Figure 4), all real models: the Cornell box from the published
//! measurements; Sponza (Marko Dabrovic's atrium), the Conference Room (Grynberg and Ward's
//! room, in Kenzie Lamar's triangulation) and the Office (Greg Ward's, from the Radiance
//! distribution), converted by `scenes/tools/` and compiled in from `scenes/`; and Desk, the
//! Radiance office's desk through the office's own `close` view (no public copy of the paper's
//! Desk is known). `scenes/README.md` gives each model's origin, credit or licence, triangle
//! count and conversion command; [`INFO`] says which scenes are real ([`SceneSource`]).

use super::camera::{Camera, Orbit};
use super::obj;
use super::scene::{Material, MaterialId, Scene, SceneBuilder, SceneError};
use glam::Vec3;

/// The built-in scene names, in the paper's order.
pub const NAMES: [&str; 5] = ["cornell", "desk", "conference", "office", "sponza"];

/// Where a built-in scene comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneSource {
    /// The published model (or, for the Cornell box, its published measurements).
    Real,
    /// A procedural stand-in where no public copy of the model is known.
    StandIn,
}

impl SceneSource {
    /// `real` or `stand-in`, as the statistics JSON and every table print it.
    pub fn name(self) -> &'static str {
        match self {
            SceneSource::Real => "real",
            SceneSource::StandIn => "stand-in",
        }
    }
}

/// What `wfic scenes` lists about a built-in scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneInfo {
    /// The name `--scene` takes.
    pub name: &'static str,
    /// Real model or stand-in.
    pub source: SceneSource,
    /// The model, its authors and where our copy comes from (`scenes/README.md` has the rest).
    pub origin: &'static str,
}

/// The built-in scenes, in [`NAMES`]' order.
pub const INFO: [SceneInfo; 5] = [
    SceneInfo {
        name: "cornell",
        source: SceneSource::Real,
        origin: "Cornell box, the Cornell Program of Computer Graphics' published measurements",
    },
    SceneInfo {
        name: "desk",
        source: SceneSource::Real,
        origin: "Greg Ward's office (Radiance distribution), its `close` view of the desk",
    },
    SceneInfo {
        name: "conference",
        source: SceneSource::Real,
        origin: "Grynberg & Ward's conference room, Kenzie Lamar's triangulation (taqu/BoundingVolumeHierarchy)",
    },
    SceneInfo {
        name: "office",
        source: SceneSource::Real,
        origin: "Greg Ward's office, Radiance distribution (LBNL-ETA/Radiance obj/office)",
    },
    SceneInfo {
        name: "sponza",
        source: SceneSource::Real,
        origin: "Marko Dabrovic's Sponza (YangYuchu/cg), sp_* materials (kevinriehm/dabrovic-sponza)",
    },
];

/// The [`SceneInfo`] of built-in scene `name`.
pub fn info(name: &str) -> Option<&'static SceneInfo> {
    INFO.iter().find(|i| i.name == name)
}

/// The folder name the built-in scene files are read under (compiled into the binary, so the
/// `wfic` binary needs no files beside it): `<built-in>/sponza.obj.gz` and so on.
pub const BUILT_IN: &str = "<built-in>";

/// The converted real models (`scenes/`, see its README), compiled in.
const FILES: &[(&str, &[u8])] = &[
    (
        "sponza.obj.gz",
        include_bytes!("../../../scenes/sponza.obj.gz"),
    ),
    ("sponza.mtl", include_bytes!("../../../scenes/sponza.mtl")),
    (
        "conference.obj.gz",
        include_bytes!("../../../scenes/conference.obj.gz"),
    ),
    (
        "conference.mtl",
        include_bytes!("../../../scenes/conference.mtl"),
    ),
    (
        "office.obj.gz",
        include_bytes!("../../../scenes/office.obj.gz"),
    ),
    ("office.mtl", include_bytes!("../../../scenes/office.mtl")),
];

/// The bytes of built-in file `path` (`<built-in>/NAME`), or `None` for any other path.
pub fn built_in_file(path: &std::path::Path) -> Option<&'static [u8]> {
    let rest = path.strip_prefix(BUILT_IN).ok()?;
    FILES
        .iter()
        .find(|(name, _)| rest == std::path::Path::new(name))
        .map(|&(_, bytes)| bytes)
}

/// The built-in scene files as the OBJ reader sees them ([`obj::FileResolver`]): the files
/// compiled into the binary, under [`BUILT_IN`]; any other path is not found.
#[derive(Clone, Copy, Debug, Default)]
pub struct Embedded;

impl obj::FileResolver for Embedded {
    fn read(&self, path: &std::path::Path) -> std::io::Result<std::borrow::Cow<'static, [u8]>> {
        built_in_file(path)
            .map(std::borrow::Cow::Borrowed)
            .ok_or_else(|| {
                std::io::Error::new(std::io::ErrorKind::NotFound, "not a built-in scene file")
            })
    }
}

/// The built-in scene called `name`, or `None` for an unknown name.
pub fn by_name(name: &str) -> Option<Result<Scene, SceneError>> {
    Some(match name {
        "cornell" => cornell(),
        "desk" => desk(),
        "conference" => conference(),
        "office" => office(),
        "sponza" => sponza(),
        _ => return None,
    })
}

/// Builds built-in scene `name`, or says what is wrong: an unknown name (with the known ones)
/// or a scene that does not build (named).
pub fn load(name: &str) -> Result<Scene, String> {
    by_name(name)
        .ok_or_else(|| {
            format!(
                "unknown scene `{name}` (expected one of: {})",
                NAMES.join(", ")
            )
        })?
        .map_err(|e| format!("{name}: {e}"))
}

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

/// The Cornell box, from the Cornell Program of Computer Graphics' published geometry
/// (<https://www.graphics.cornell.edu/online/box/data.html>), converted from millimetres to metres.
/// Reflectances are the usual RGB reductions of the measured spectra (as in Mitsuba's and pbrt's
/// versions); the light emits `(17, 12, 4)`. The camera is the published one (35 mm lens, 25 mm
/// film: a 39.3° field of view).
pub fn cornell() -> Result<Scene, SceneError> {
    cornell_with_short_block_at(Vec3::ZERO, "cornell")
}

/// The short block's corners in the published Cornell box, in millimetres: its bounds are
/// `x` 82..290, `y` 0..165, `z` 65..272.
const SHORT_BLOCK_MM: ([f32; 3], [f32; 3]) = ([82.0, 0.0, 65.0], [290.0, 165.0, 272.0]);

/// How far the short block of `cornell-moving` slides over its animation (metres): 240 mm towards
/// the red wall and 60 mm towards the open front, from its published place to about 20 mm short
/// of the red wall and 5 mm short of the front edge. The diagonal keeps its back corner in front
/// of the tall block's front face all the way (the face runs from (265, 296) to (423, 247) mm in
/// x, z; the corner moves from (240, 272) to (480, 212)).
pub const CORNELL_SLIDE: Vec3 = Vec3::new(0.24, 0.0, -0.06);

/// The short block's bounds (metres) when it is moved by `offset`.
pub fn short_block_bounds(offset: Vec3) -> (Vec3, Vec3) {
    let (lo, hi) = SHORT_BLOCK_MM;
    (
        Vec3::from(lo) * 0.001 + offset,
        Vec3::from(hi) * 0.001 + offset,
    )
}

/// `cornell-moving` at `t` in `[0, 1]` of its animation: the Cornell box with the short block
/// slid `t * CORNELL_SLIDE` along the floor (everything else, the camera
/// included, as in [`cornell`]). The scene a dynamic cache must keep up with: the records the
/// block's old and new places touch become wrong.
pub fn cornell_moving(t: f32) -> Result<Scene, SceneError> {
    if !(0.0..=1.0).contains(&t) {
        return Err(SceneError::Load(format!(
            "cornell-moving: t = {t} is outside the animation's [0, 1]"
        )));
    }
    cornell_with_short_block_at(CORNELL_SLIDE * t, "cornell-moving")
}

/// A quadrilateral of the published Cornell box: its corners in millimetres, in the published
/// order (which winds it to face into the room).
type Quad = [[f32; 3]; 4];

/// The Cornell box's surfaces.
#[derive(Clone, Copy)]
enum Surface {
    White,
    Red,
    Green,
    Light,
}

/// The room: floor, ceiling, back wall, right (green) and left (red) walls, and the light, 0.1 mm
/// below the ceiling (as usually modelled), wound to face down.
const ROOM: [(Quad, Surface); 6] = [
    (
        [
            [552.8, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 559.2],
            [549.6, 0.0, 559.2],
        ],
        Surface::White,
    ),
    (
        [
            [556.0, 548.8, 0.0],
            [556.0, 548.8, 559.2],
            [0.0, 548.8, 559.2],
            [0.0, 548.8, 0.0],
        ],
        Surface::White,
    ),
    (
        [
            [549.6, 0.0, 559.2],
            [0.0, 0.0, 559.2],
            [0.0, 548.8, 559.2],
            [556.0, 548.8, 559.2],
        ],
        Surface::White,
    ),
    (
        [
            [0.0, 0.0, 559.2],
            [0.0, 0.0, 0.0],
            [0.0, 548.8, 0.0],
            [0.0, 548.8, 559.2],
        ],
        Surface::Green,
    ),
    (
        [
            [552.8, 0.0, 0.0],
            [549.6, 0.0, 559.2],
            [556.0, 548.8, 559.2],
            [556.0, 548.8, 0.0],
        ],
        Surface::Red,
    ),
    (
        [
            [343.0, 548.7, 227.0],
            [343.0, 548.7, 332.0],
            [213.0, 548.7, 332.0],
            [213.0, 548.7, 227.0],
        ],
        Surface::Light,
    ),
];

/// The short block's five faces (its top first), where the published box has it.
const SHORT_BLOCK: [Quad; 5] = [
    [
        [130.0, 165.0, 65.0],
        [82.0, 165.0, 225.0],
        [240.0, 165.0, 272.0],
        [290.0, 165.0, 114.0],
    ],
    [
        [290.0, 0.0, 114.0],
        [290.0, 165.0, 114.0],
        [240.0, 165.0, 272.0],
        [240.0, 0.0, 272.0],
    ],
    [
        [130.0, 0.0, 65.0],
        [130.0, 165.0, 65.0],
        [290.0, 165.0, 114.0],
        [290.0, 0.0, 114.0],
    ],
    [
        [82.0, 0.0, 225.0],
        [82.0, 165.0, 225.0],
        [130.0, 165.0, 65.0],
        [130.0, 0.0, 65.0],
    ],
    [
        [240.0, 0.0, 272.0],
        [240.0, 165.0, 272.0],
        [82.0, 165.0, 225.0],
        [82.0, 0.0, 225.0],
    ],
];

/// The tall block's five faces (its top first).
const TALL_BLOCK: [Quad; 5] = [
    [
        [423.0, 330.0, 247.0],
        [265.0, 330.0, 296.0],
        [314.0, 330.0, 456.0],
        [472.0, 330.0, 406.0],
    ],
    [
        [423.0, 0.0, 247.0],
        [423.0, 330.0, 247.0],
        [472.0, 330.0, 406.0],
        [472.0, 0.0, 406.0],
    ],
    [
        [472.0, 0.0, 406.0],
        [472.0, 330.0, 406.0],
        [314.0, 330.0, 456.0],
        [314.0, 0.0, 456.0],
    ],
    [
        [314.0, 0.0, 456.0],
        [314.0, 330.0, 456.0],
        [265.0, 330.0, 296.0],
        [265.0, 0.0, 296.0],
    ],
    [
        [265.0, 0.0, 296.0],
        [265.0, 330.0, 296.0],
        [423.0, 330.0, 247.0],
        [423.0, 0.0, 247.0],
    ],
];

/// The Cornell box with its short block moved by `offset` (metres), named `name`.
fn cornell_with_short_block_at(offset: Vec3, name: &str) -> Result<Scene, SceneError> {
    let mut b = SceneBuilder::new();
    let white = b.material(Material::diffuse(v(0.725, 0.71, 0.68)));
    let red = b.material(Material::diffuse(v(0.63, 0.065, 0.05)));
    let green = b.material(Material::diffuse(v(0.14, 0.45, 0.091)));
    let light = b.material(Material::light(v(17.0, 12.0, 4.0)));
    let mm = |x: f32, y: f32, z: f32| v(x, y, z) * 0.001;
    let quad = |b: &mut SceneBuilder, q: Quad, m: MaterialId| {
        let p = q.map(|[x, y, z]| mm(x, y, z));
        b.quad(p[0], p[1], p[2], p[3], m);
    };
    for (q, surface) in ROOM {
        let m = match surface {
            Surface::White => white,
            Surface::Red => red,
            Surface::Green => green,
            Surface::Light => light,
        };
        quad(&mut b, q, m);
    }
    for q in SHORT_BLOCK {
        let p = q.map(|[x, y, z]| mm(x, y, z) + offset);
        b.quad(p[0], p[1], p[2], p[3], white);
    }
    for q in TALL_BLOCK {
        quad(&mut b, q, white);
    }
    let camera = Camera::look_at(
        mm(278.0, 273.0, -800.0),
        mm(278.0, 273.0, 0.0),
        Vec3::Y,
        39.3077,
    );
    let orbit = Orbit {
        // Above the tall block (330 mm), so no position of the circle is inside it.
        center: mm(278.0, 420.0, 280.0),
        radius: 0.17,
        look_height: 0.15,
        vfov_degrees: 70.0,
    };
    b.build(name, camera, orbit)
}

// ---------------------------------------------------------------------------------------------
// The real models, converted by the scripts in `scenes/tools/` (see `scenes/README.md`) and
// compiled in.

/// Loads built-in file `file` (an `.obj.gz` and its MTL) with `camera` and `orbit`.
fn real(name: &str, file: &str, camera: Camera, orbit: Orbit) -> Result<Scene, SceneError> {
    let path = std::path::Path::new(BUILT_IN).join(file);
    let b =
        obj::load_builder_from(&path, &Embedded).map_err(|e| SceneError::Load(e.to_string()))?;
    b.build(name, camera, orbit)
}

/// Desk: Greg Ward's office from the Radiance distribution (the same model as [`office`]),
/// seen through the office's own `close` view (`obj/office/closeup.vp`): the desk with its
/// lamp, books and mug. No public copy of the paper's Desk scene is known; this is the nearest
/// real model. The view is Radiance's (27.5° x 39.9°); on a square image its 39.9° becomes the
/// vertical field of view, so the whole width of the Radiance view is kept.
pub fn desk() -> Result<Scene, SceneError> {
    let u = OFFICE_UNIT;
    let eye = v(-6.94171, 28.0803, -12.3719) * u;
    let camera = Camera::look_at(eye, eye + v(-0.487983, -0.243991, 0.838058), Vec3::Y, 39.9);
    real("desk", "office.obj.gz", camera, office_orbit())
}

/// Metres per unit of the Radiance office: 3 inches (its furniture is modelled in inches and
/// placed at a third of its size), so the room is 4.57 m x 2.71 m x 4.57 m.
const OFFICE_UNIT: f32 = 0.0762;

fn office_orbit() -> Orbit {
    Orbit {
        center: v(0.0, 2.55, 0.0),
        radius: 1.35,
        look_height: 2.1,
        vfov_degrees: 60.0,
    }
}

/// Office: Greg Ward's office model from the Radiance distribution (`obj/office`, the scene
/// files `office.rif` lists), seen through its `norm` view. The window's glass is dropped (the
/// scene has no sky, so it is an opening onto black); patterns and specular parts become their
/// material's diffuse colour (`scenes/README.md`).
pub fn office() -> Result<Scene, SceneError> {
    let u = OFFICE_UNIT;
    let eye = v(8.0, 36.0, -27.0) * u;
    let camera = Camera::look_at(eye, eye + v(-0.560723, -0.233635, 0.794358), Vec3::Y, 39.9);
    real("office", "office.obj.gz", camera, office_orbit())
}

/// Conference Room: Anat Grynberg and Greg Ward's conference room, as Kenzie Lamar's
/// triangulated re-creation (331,179 triangles), scaled to Ward's stated room size; the mesh
/// has no materials or lights, so both are ours (`scenes/README.md`).
pub fn conference() -> Result<Scene, SceneError> {
    let camera = Camera::look_at(v(6.7, 1.488, -1.34), v(0.0, 1.488, -1.34), Vec3::Y, 60.0);
    let orbit = Orbit {
        center: v(2.141, 1.5, -0.576),
        radius: 2.6,
        look_height: 0.9,
        vfov_degrees: 60.0,
    };
    real("conference", "conference.obj.gz", camera, orbit)
}

/// Sponza: Marko Dabrovic's atrium (66,454 triangles, the paper's), with its `sp_*` materials
/// mapped onto the 2001 OBJ's groups by hand and a skylight of ours over the open roof
/// (`scenes/README.md`).
pub fn sponza() -> Result<Scene, SceneError> {
    let camera = Camera::look_at(v(-10.0, 1.7, 0.0), v(10.0, 3.5, 0.0), Vec3::Y, 60.0);
    let orbit = Orbit {
        center: v(0.0, 1.8, 0.0),
        radius: 2.0,
        look_height: 2.5,
        vfov_degrees: 60.0,
    };
    real("sponza", "sponza.obj.gz", camera, orbit)
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;

    /// `cornell-moving` moves exactly the short block's ten triangles, by the slide, and
    /// `short_block_bounds` bounds them: the bounds the dynamic experiment removes around are
    /// the block's, not a guess.
    #[test]
    fn the_moving_cornell_box_moves_the_short_block_and_its_bounds_hold_it() {
        let key = |t: &[Vec3; 3]| t.map(|p| (p * 1e4).round().as_ivec3().to_array());
        let still: Vec<_> = cornell()
            .unwrap()
            .triangles()
            .iter()
            .map(|(t, _)| key(t))
            .collect();
        let moved = cornell_moving(1.0).unwrap().triangles();
        let (lo, hi) = short_block_bounds(CORNELL_SLIDE);
        let mut shifted = 0;
        for (t, _) in &moved {
            if still.contains(&key(t)) {
                continue;
            }
            shifted += 1;
            let back = t.map(|p| p - CORNELL_SLIDE);
            assert!(still.contains(&key(&back)), "{t:?} is no slid triangle");
            for p in t {
                assert!(
                    p.cmpge(lo - 1e-5).all() && p.cmple(hi + 1e-5).all(),
                    "{p} outside the block's bounds {lo}..{hi}"
                );
            }
        }
        assert_eq!(shifted, 10, "the short block's five quads");
        assert_eq!(moved.len(), still.len());
        assert!(cornell_moving(1.01).is_err() && cornell_moving(-0.1).is_err());
        assert_eq!(cornell_moving(0.0).unwrap().name(), "cornell-moving");
    }
}
