//! The paper's five scenes (Figure 4): the Cornell box from the published measurements, and
//! procedural stand-ins for Desk, Conference Room, Office and Sponza that keep their character —
//! enclosed rooms lit by area lights, many occluders, from about 10^3 to about 10^5 triangles and
//! different physical sizes. `paper-notes.md` (section "The renderer and its five scenes") documents each one and how it differs from the
//! original.

use super::camera::{Camera, Orbit};
use super::scene::{Material, MaterialId, Scene, SceneBuilder, SceneError};
use glam::{Mat3, Vec3};
use std::f32::consts::{PI, TAU};

/// The built-in scene names, in the paper's order.
pub const NAMES: [&str; 5] = ["cornell", "desk", "conference", "office", "sponza"];

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

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

/// The Cornell box, from the Cornell Program of Computer Graphics' published geometry
/// (<https://www.graphics.cornell.edu/online/box/data.html>), converted from millimetres to metres.
/// Reflectances are the usual RGB reductions of the measured spectra (as in Mitsuba's and pbrt's
/// versions); the light emits `(17, 12, 4)`. The camera is the published one (35 mm lens, 25 mm
/// film: a 39.3° field of view).
pub fn cornell() -> Result<Scene, SceneError> {
    let mut b = SceneBuilder::new();
    let white = b.material(Material::diffuse(v(0.725, 0.71, 0.68)));
    let red = b.material(Material::diffuse(v(0.63, 0.065, 0.05)));
    let green = b.material(Material::diffuse(v(0.14, 0.45, 0.091)));
    let light = b.material(Material::light(v(17.0, 12.0, 4.0)));
    let mm = |x: f32, y: f32, z: f32| v(x, y, z) * 0.001;
    let quad = |b: &mut SceneBuilder, q: [[f32; 3]; 4], m: MaterialId| {
        let p = q.map(|[x, y, z]| mm(x, y, z));
        b.quad(p[0], p[1], p[2], p[3], m);
    };
    // Floor, ceiling, back wall, right (green) and left (red) walls.
    quad(
        &mut b,
        [
            [552.8, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 559.2],
            [549.6, 0.0, 559.2],
        ],
        white,
    );
    quad(
        &mut b,
        [
            [556.0, 548.8, 0.0],
            [556.0, 548.8, 559.2],
            [0.0, 548.8, 559.2],
            [0.0, 548.8, 0.0],
        ],
        white,
    );
    quad(
        &mut b,
        [
            [549.6, 0.0, 559.2],
            [0.0, 0.0, 559.2],
            [0.0, 548.8, 559.2],
            [556.0, 548.8, 559.2],
        ],
        white,
    );
    quad(
        &mut b,
        [
            [0.0, 0.0, 559.2],
            [0.0, 0.0, 0.0],
            [0.0, 548.8, 0.0],
            [0.0, 548.8, 559.2],
        ],
        green,
    );
    quad(
        &mut b,
        [
            [552.8, 0.0, 0.0],
            [549.6, 0.0, 559.2],
            [556.0, 548.8, 559.2],
            [556.0, 548.8, 0.0],
        ],
        red,
    );
    // The light, 0.1 mm below the ceiling (as usually modelled), wound to face down.
    quad(
        &mut b,
        [
            [343.0, 548.7, 227.0],
            [343.0, 548.7, 332.0],
            [213.0, 548.7, 332.0],
            [213.0, 548.7, 227.0],
        ],
        light,
    );
    // Short block.
    for q in [
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
    ] {
        quad(&mut b, q, white);
    }
    // Tall block.
    for q in [
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
    ] {
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
    b.build("cornell", camera, orbit)
}

// ---------------------------------------------------------------------------------------------
// Procedural building blocks.

/// An axis-aligned box.
fn cuboid(b: &mut SceneBuilder, lo: Vec3, hi: Vec3, m: MaterialId) {
    oriented_box(b, (lo + hi) * 0.5, (hi - lo) * 0.5, 0.0, m);
}

/// A box centred at `c` with half extents `h`, turned by `yaw` radians about the vertical axis.
fn oriented_box(b: &mut SceneBuilder, c: Vec3, h: Vec3, yaw: f32, m: MaterialId) {
    let r = Mat3::from_rotation_y(yaw);
    let p = |sx: f32, sy: f32, sz: f32| c + r * (h * v(sx, sy, sz));
    let corners = [
        [
            p(-1., -1., -1.),
            p(1., -1., -1.),
            p(1., -1., 1.),
            p(-1., -1., 1.),
        ], // bottom
        [
            p(-1., 1., -1.),
            p(-1., 1., 1.),
            p(1., 1., 1.),
            p(1., 1., -1.),
        ], // top
        [
            p(-1., -1., -1.),
            p(-1., 1., -1.),
            p(1., 1., -1.),
            p(1., -1., -1.),
        ], // -z
        [
            p(-1., -1., 1.),
            p(1., -1., 1.),
            p(1., 1., 1.),
            p(-1., 1., 1.),
        ], // +z
        [
            p(-1., -1., -1.),
            p(-1., -1., 1.),
            p(-1., 1., 1.),
            p(-1., 1., -1.),
        ], // -x
        [
            p(1., -1., -1.),
            p(1., 1., -1.),
            p(1., 1., 1.),
            p(1., -1., 1.),
        ], // +x
    ];
    for [a, bb, c, d] in corners {
        b.quad(a, bb, c, d, m);
    }
}

/// A horizontal emitting rectangle at height `y`, facing down.
fn ceiling_light(b: &mut SceneBuilder, x: (f32, f32), z: (f32, f32), y: f32, m: MaterialId) {
    b.quad(
        v(x.0, y, z.0),
        v(x.1, y, z.0),
        v(x.1, y, z.1),
        v(x.0, y, z.1),
        m,
    );
}

/// A surface of revolution about the vertical axis through `base`: `profile` lists
/// `(radius, height)` from bottom to top; a zero radius closes the surface there.
fn lathe(b: &mut SceneBuilder, base: Vec3, profile: &[(f32, f32)], segments: u32, m: MaterialId) {
    let ring = |(r, y): (f32, f32), k: u32| {
        let a = TAU * k as f32 / segments as f32;
        base + v(r * a.cos(), y, r * a.sin())
    };
    for w in profile.windows(2) {
        for k in 0..segments {
            let (p0, p1) = (ring(w[0], k), ring(w[0], k + 1));
            let (q0, q1) = (ring(w[1], k), ring(w[1], k + 1));
            b.quad(p0, p1, q1, q0, m);
        }
    }
}

/// A closed cylinder.
fn cylinder(b: &mut SceneBuilder, base: Vec3, r: f32, h: f32, segments: u32, m: MaterialId) {
    lathe(
        b,
        base,
        &[(0.0, 0.0), (r, 0.0), (r, h), (0.0, h)],
        segments,
        m,
    );
}

/// A semicircular arch in the vertical plane through `center` spanned by `along` (unit,
/// horizontal), between radii `inner` and `outer`, `depth` thick across the plane.
#[allow(clippy::too_many_arguments)]
fn arch(
    b: &mut SceneBuilder,
    center: Vec3,
    along: Vec3,
    inner: f32,
    outer: f32,
    depth: f32,
    segments: u32,
    m: MaterialId,
) {
    let across = along.cross(Vec3::Y).normalize() * (depth * 0.5);
    let at = |r: f32, k: u32| {
        let a = PI * k as f32 / segments as f32;
        center + along * (r * a.cos()) + Vec3::Y * (r * a.sin())
    };
    for k in 0..segments {
        let (i0, i1, o0, o1) = (
            at(inner, k),
            at(inner, k + 1),
            at(outer, k),
            at(outer, k + 1),
        );
        // Front and back faces, inner (soffit) and outer (extrados) surfaces.
        b.quad(i0 + across, o0 + across, o1 + across, i1 + across, m);
        b.quad(i0 - across, i1 - across, o1 - across, o0 - across, m);
        b.quad(i0 - across, i0 + across, i1 + across, i1 - across, m);
        b.quad(o0 - across, o1 - across, o1 + across, o0 + across, m);
    }
}

/// A hanging cloth: a `nu` x `nv` grid over the rectangle `origin + s u + t v`, rippled along
/// `u x v` by `amplitude * sin(ripples * 2 pi s)`, growing towards the bottom (`t = 1`).
#[allow(clippy::too_many_arguments)]
fn drape(
    b: &mut SceneBuilder,
    origin: Vec3,
    u: Vec3,
    vv: Vec3,
    nu: u32,
    nv: u32,
    amplitude: f32,
    ripples: f32,
    m: MaterialId,
) {
    let normal = u.cross(vv).normalize();
    let at = |i: u32, j: u32| {
        let (s, t) = (i as f32 / nu as f32, j as f32 / nv as f32);
        origin + u * s + vv * t + normal * (amplitude * (0.3 + 0.7 * t) * (ripples * TAU * s).sin())
    };
    for j in 0..nv {
        for i in 0..nu {
            b.quad(at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1), m);
        }
    }
}

/// A room's shell: floor, ceiling and four walls of the box `lo..hi`, each split into a grid of
/// `cells` x `cells` quads (so BVH leaves stay small next to the rest of the geometry).
fn shell(
    b: &mut SceneBuilder,
    lo: Vec3,
    hi: Vec3,
    floor: MaterialId,
    ceiling: MaterialId,
    walls: [MaterialId; 4],
) {
    let d = hi - lo;
    let grid = |b: &mut SceneBuilder, o: Vec3, u: Vec3, w: Vec3, m: MaterialId| {
        let n = 4;
        for j in 0..n {
            for i in 0..n {
                let p = |a: u32, c: u32| o + u * (a as f32 / n as f32) + w * (c as f32 / n as f32);
                b.quad(p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1), m);
            }
        }
    };
    grid(b, lo, v(d.x, 0.0, 0.0), v(0.0, 0.0, d.z), floor);
    grid(
        b,
        v(lo.x, hi.y, lo.z),
        v(0.0, 0.0, d.z),
        v(d.x, 0.0, 0.0),
        ceiling,
    );
    grid(b, lo, v(0.0, d.y, 0.0), v(d.x, 0.0, 0.0), walls[0]); // z = lo
    grid(
        b,
        v(lo.x, lo.y, hi.z),
        v(d.x, 0.0, 0.0),
        v(0.0, d.y, 0.0),
        walls[1],
    ); // z = hi
    grid(b, lo, v(0.0, 0.0, d.z), v(0.0, d.y, 0.0), walls[2]); // x = lo
    grid(
        b,
        v(hi.x, lo.y, lo.z),
        v(0.0, d.y, 0.0),
        v(0.0, 0.0, d.z),
        walls[3],
    ); // x = hi
}

/// An office chair at `p` facing `yaw`: five-star base, gas column, seat, back.
fn chair(
    b: &mut SceneBuilder,
    p: Vec3,
    yaw: f32,
    segments: u32,
    seat: MaterialId,
    metal: MaterialId,
) {
    for k in 0..5 {
        let a = yaw + TAU * k as f32 / 5.0;
        let arm = v(a.cos(), 0.0, a.sin());
        oriented_box(
            b,
            p + arm * 0.17 + v(0.0, 0.06, 0.0),
            v(0.17, 0.015, 0.02),
            -a,
            metal,
        );
        cylinder(b, p + arm * 0.32, 0.025, 0.05, segments / 2, metal);
    }
    cylinder(b, p + v(0.0, 0.07, 0.0), 0.025, 0.36, segments, metal);
    lathe(
        b,
        p + v(0.0, 0.42, 0.0),
        &[
            (0.0, 0.0),
            (0.2, 0.0),
            (0.24, 0.03),
            (0.24, 0.07),
            (0.0, 0.08),
        ],
        segments,
        seat,
    );
    let back = Mat3::from_rotation_y(yaw) * v(-0.23, 0.0, 0.0);
    oriented_box(
        b,
        p + back + v(0.0, 0.78, 0.0),
        v(0.03, 0.25, 0.21),
        -yaw,
        seat,
    );
}

/// A simple four-legged table with top `lo..hi` (`hi.y` its height).
fn table(b: &mut SceneBuilder, lo: Vec3, hi: Vec3, top: MaterialId, legs: MaterialId) {
    let t = 0.04;
    cuboid(b, v(lo.x, hi.y - t, lo.z), hi, top);
    for (x, z) in [
        (lo.x + 0.05, lo.z + 0.05),
        (hi.x - 0.1, lo.z + 0.05),
        (lo.x + 0.05, hi.z - 0.1),
        (hi.x - 0.1, hi.z - 0.1),
    ] {
        cuboid(b, v(x, lo.y, z), v(x + 0.05, hi.y - t, z + 0.05), legs);
    }
}

// ---------------------------------------------------------------------------------------------
// The stand-ins.

/// Desk: a 4 m x 2.7 m x 3.5 m study with a desk, a monitor, an (unlit) desk lamp, an office chair and a
/// bookshelf full of books, lit by a ceiling panel and a window (an emitting panel in the right wall). About 3 x 10^3 triangles.
pub fn desk() -> Result<Scene, SceneError> {
    let mut b = SceneBuilder::new();
    let wall = b.material(Material::diffuse(v(0.75, 0.72, 0.66)));
    let blue_wall = b.material(Material::diffuse(v(0.35, 0.45, 0.65)));
    let floor = b.material(Material::diffuse(v(0.45, 0.32, 0.2)));
    let ceiling = b.material(Material::diffuse(v(0.8, 0.8, 0.8)));
    let wood = b.material(Material::diffuse(v(0.55, 0.38, 0.22)));
    let dark = b.material(Material::diffuse(v(0.08, 0.08, 0.09)));
    let metal = b.material(Material::diffuse(v(0.5, 0.5, 0.52)));
    let fabric = b.material(Material::diffuse(v(0.6, 0.12, 0.1)));
    let rug = b.material(Material::diffuse(v(0.2, 0.35, 0.25)));
    let panel = b.material(Material::light(v(9.0, 8.7, 8.0)));
    let window = b.material(Material::light(v(5.0, 5.5, 6.5)));
    let palette = [
        b.material(Material::diffuse(v(0.7, 0.15, 0.1))),
        b.material(Material::diffuse(v(0.15, 0.3, 0.6))),
        b.material(Material::diffuse(v(0.8, 0.7, 0.3))),
        b.material(Material::diffuse(v(0.2, 0.5, 0.25))),
        b.material(Material::diffuse(v(0.85, 0.85, 0.8))),
    ];
    shell(
        &mut b,
        Vec3::ZERO,
        v(4.0, 2.7, 3.5),
        floor,
        ceiling,
        [wall, blue_wall, wall, wall],
    );
    ceiling_light(&mut b, (1.5, 2.5), (1.2, 2.0), 2.69, panel);
    // Desk against the back wall, with a drawer block.
    table(&mut b, v(1.2, 0.0, 2.7), v(2.9, 0.75, 3.45), wood, wood);
    cuboid(&mut b, v(2.45, 0.0, 2.75), v(2.85, 0.7, 3.4), wood);
    // Monitor and keyboard.
    cuboid(&mut b, v(1.65, 0.95, 3.25), v(2.35, 1.35, 3.29), dark);
    cuboid(&mut b, v(1.97, 0.75, 3.27), v(2.03, 0.95, 3.3), metal);
    cylinder(&mut b, v(2.0, 0.75, 3.28), 0.1, 0.01, 32, metal);
    cuboid(&mut b, v(1.75, 0.75, 2.9), v(2.2, 0.77, 3.05), dark);
    // Desk lamp (unlit): base, pole, shade.
    let lamp = v(2.65, 0.75, 3.15);
    lathe(
        &mut b,
        lamp,
        &[(0.0, 0.0), (0.09, 0.0), (0.09, 0.02), (0.0, 0.03)],
        32,
        metal,
    );
    cylinder(&mut b, lamp, 0.012, 0.42, 16, metal);
    lathe(
        &mut b,
        lamp + v(0.0, 0.3, 0.0),
        &[(0.14, 0.0), (0.12, 0.06), (0.06, 0.16), (0.0, 0.17)],
        48,
        fabric,
    );
    // Daylight through a window in the right wall: an emitter wound to face into the room (-x).
    let wx = 4.0 - 0.005;
    b.quad(
        v(wx, 1.0, 0.8),
        v(wx, 1.0, 2.2),
        v(wx, 2.2, 2.2),
        v(wx, 2.2, 0.8),
        window,
    );
    // Office chair in front of the desk.
    chair(&mut b, v(2.0, 0.0, 2.35), -0.5 * PI, 24, fabric, metal);
    // Bookshelf against the left wall: sides, shelves, books.
    let (sx0, sx1, sz0, sz1) = (0.02, 0.37, 0.6, 2.0);
    cuboid(&mut b, v(sx0, 0.0, sz0), v(sx1, 2.0, sz0 + 0.03), wood);
    cuboid(&mut b, v(sx0, 0.0, sz1 - 0.03), v(sx1, 2.0, sz1), wood);
    for (i, y) in [0.05f32, 0.45, 0.85, 1.25, 1.65].into_iter().enumerate() {
        cuboid(&mut b, v(sx0, y - 0.03, sz0), v(sx1, y, sz1), wood);
        // Books along z: build along x then swap by placing thin boxes along z.
        let mut z = sz0 + 0.04;
        let mut k = 17 + i as u32 * 31;
        while z < sz1 - 0.08 {
            k = k.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            let w = 0.02 + (k >> 16) as f32 % 30.0 * 0.001;
            let h = 0.2 + (k >> 8) as f32 % 100.0 * 0.001;
            let m = palette[(k >> 4) as usize % palette.len()];
            cuboid(&mut b, v(sx0 + 0.04, y, z), v(sx1 - 0.02, y + h, z + w), m);
            z += w + 0.004;
        }
    }
    cuboid(&mut b, v(1.0, 0.0, 1.2), v(3.0, 0.01, 2.6), rug);
    // A waste bin and a plant pot.
    lathe(
        &mut b,
        v(3.3, 0.0, 3.2),
        &[
            (0.0, 0.0),
            (0.13, 0.0),
            (0.16, 0.32),
            (0.15, 0.32),
            (0.12, 0.02),
            (0.0, 0.02),
        ],
        32,
        metal,
    );
    lathe(
        &mut b,
        v(0.6, 0.0, 3.1),
        &[(0.0, 0.0), (0.15, 0.0), (0.2, 0.35), (0.0, 0.35)],
        32,
        wood,
    );
    lathe(
        &mut b,
        v(0.6, 0.35, 3.1),
        &[(0.0, 0.0), (0.3, 0.2), (0.25, 0.5), (0.1, 0.8), (0.0, 0.9)],
        24,
        palette[3],
    );
    let camera = Camera::look_at(v(2.2, 1.55, 0.25), v(1.7, 0.85, 3.0), Vec3::Y, 62.0);
    let orbit = Orbit {
        center: v(2.0, 1.5, 1.75),
        radius: 1.0,
        look_height: 0.9,
        vfov_degrees: 65.0,
    };
    b.build("desk", camera, orbit)
}

/// Conference Room: a 12 m x 3.2 m x 8 m room with a long rounded table, 20 office chairs, a
/// coffered ceiling with six light panels, a screen and a sideboard. About 3 x 10^4 triangles.
pub fn conference() -> Result<Scene, SceneError> {
    let mut b = SceneBuilder::new();
    let wall = b.material(Material::diffuse(v(0.7, 0.66, 0.58)));
    let wood_wall = b.material(Material::diffuse(v(0.45, 0.3, 0.18)));
    let carpet = b.material(Material::diffuse(v(0.25, 0.22, 0.35)));
    let ceiling = b.material(Material::diffuse(v(0.82, 0.82, 0.8)));
    let wood = b.material(Material::diffuse(v(0.5, 0.3, 0.15)));
    let seat = b.material(Material::diffuse(v(0.12, 0.25, 0.5)));
    let metal = b.material(Material::diffuse(v(0.55, 0.55, 0.58)));
    let screen = b.material(Material::diffuse(v(0.9, 0.9, 0.9)));
    let panel = b.material(Material::light(v(6.0, 6.0, 5.6)));
    let (w, h, d) = (12.0, 3.2, 8.0);
    shell(
        &mut b,
        Vec3::ZERO,
        v(w, h, d),
        carpet,
        ceiling,
        [wall, wall, wood_wall, wall],
    );
    // Coffers: beams across the ceiling.
    for i in 1..6 {
        let x = w * i as f32 / 6.0;
        cuboid(&mut b, v(x - 0.1, h - 0.3, 0.0), v(x + 0.1, h, d), ceiling);
    }
    for i in 1..4 {
        let z = d * i as f32 / 4.0;
        cuboid(&mut b, v(0.0, h - 0.3, z - 0.1), v(w, h, z + 0.1), ceiling);
    }
    for (x, z) in [
        (3.0, 2.67),
        (6.0, 2.67),
        (9.0, 2.67),
        (3.0, 5.33),
        (6.0, 5.33),
        (9.0, 5.33),
    ] {
        ceiling_light(
            &mut b,
            (x - 0.6, x + 0.6),
            (z - 0.45, z + 0.45),
            h - 0.32,
            panel,
        );
    }
    // The table: a slab with round ends, on two pedestals.
    let (tx0, tx1, tz, half) = (3.0, 9.0, 4.0, 0.9);
    let top = 0.76;
    cuboid(
        &mut b,
        v(tx0, top - 0.05, tz - half),
        v(tx1, top, tz + half),
        wood,
    );
    for x in [tx0, tx1] {
        lathe(
            &mut b,
            v(x, top - 0.05, tz),
            &[(0.0, 0.0), (half, 0.0), (half, 0.05), (0.0, 0.05)],
            96,
            wood,
        );
        lathe(
            &mut b,
            v(x, 0.0, tz),
            &[
                (0.0, 0.0),
                (0.5, 0.0),
                (0.5, 0.05),
                (0.15, 0.1),
                (0.15, top - 0.05),
                (0.0, top - 0.05),
            ],
            64,
            wood,
        );
    }
    // Chairs: eight on each long side, two at each end.
    for i in 0..8 {
        let x = tx0 + 0.4 + i as f32 * (tx1 - tx0 - 0.8) / 7.0;
        chair(
            &mut b,
            v(x, 0.0, tz - half - 0.45),
            0.5 * PI,
            48,
            seat,
            metal,
        );
        chair(
            &mut b,
            v(x, 0.0, tz + half + 0.45),
            -0.5 * PI,
            48,
            seat,
            metal,
        );
    }
    for s in [-1.0f32, 1.0] {
        chair(
            &mut b,
            v(tx0 - half - 0.5, 0.0, tz + s * 0.45),
            0.0,
            48,
            seat,
            metal,
        );
        chair(
            &mut b,
            v(tx1 + half + 0.5, 0.0, tz + s * 0.45),
            PI,
            48,
            seat,
            metal,
        );
    }
    // Screen on the far wall, sideboard with glasses on the near wall.
    cuboid(&mut b, v(w - 0.05, 0.9, 2.5), v(w - 0.02, 2.4, 5.5), screen);
    cuboid(&mut b, v(0.02, 0.0, 1.5), v(0.5, 0.9, 6.5), wood);
    for i in 0..24 {
        let z = 1.7 + i as f32 * 0.2;
        lathe(
            &mut b,
            v(0.25, 0.9, z),
            &[
                (0.0, 0.0),
                (0.035, 0.0),
                (0.035, 0.01),
                (0.005, 0.02),
                (0.005, 0.08),
                (0.04, 0.12),
                (0.045, 0.2),
                (0.0, 0.19),
            ],
            24,
            screen,
        );
    }
    let camera = Camera::look_at(v(1.0, 1.9, 0.6), v(8.5, 0.6, 5.5), Vec3::Y, 60.0);
    let orbit = Orbit {
        center: v(6.0, 1.8, 4.0),
        radius: 2.5,
        look_height: 0.8,
        vfov_degrees: 65.0,
    };
    b.build("conference", camera, orbit)
}

/// Office: a 10 m x 3 m x 7 m open-plan office with six cubicles (partitions, desks, chairs,
/// monitors, filing cabinets), structural columns, a window wall with mullions and four light
/// panels. About 10^4 triangles.
pub fn office() -> Result<Scene, SceneError> {
    let mut b = SceneBuilder::new();
    let wall = b.material(Material::diffuse(v(0.78, 0.78, 0.74)));
    let floor = b.material(Material::diffuse(v(0.35, 0.35, 0.38)));
    let ceiling = b.material(Material::diffuse(v(0.85, 0.85, 0.85)));
    let partition = b.material(Material::diffuse(v(0.55, 0.6, 0.45)));
    let desk_top = b.material(Material::diffuse(v(0.75, 0.68, 0.55)));
    let metal = b.material(Material::diffuse(v(0.45, 0.45, 0.48)));
    let dark = b.material(Material::diffuse(v(0.06, 0.06, 0.07)));
    let seat = b.material(Material::diffuse(v(0.55, 0.3, 0.08)));
    let panel = b.material(Material::light(v(7.0, 7.0, 6.8)));
    let (w, h, d) = (10.0, 3.0, 7.0);
    shell(
        &mut b,
        Vec3::ZERO,
        v(w, h, d),
        floor,
        ceiling,
        [wall, wall, wall, wall],
    );
    for (x, z) in [(2.5, 2.0), (7.5, 2.0), (2.5, 5.0), (7.5, 5.0)] {
        ceiling_light(
            &mut b,
            (x - 0.6, x + 0.6),
            (z - 0.3, z + 0.3),
            h - 0.01,
            panel,
        );
    }
    // Window wall (z = d): sill, head, mullions.
    cuboid(&mut b, v(0.0, 0.0, d - 0.25), v(w, 0.9, d), wall);
    cuboid(&mut b, v(0.0, 2.4, d - 0.25), v(w, h, d), wall);
    for i in 0..=20 {
        let x = w * i as f32 / 20.0;
        cuboid(
            &mut b,
            v(x - 0.03, 0.9, d - 0.1),
            v(x + 0.03, 2.4, d),
            metal,
        );
    }
    // Columns.
    for x in [3.33f32, 6.67] {
        lathe(
            &mut b,
            v(x, 0.0, 3.5),
            &[
                (0.0, 0.0),
                (0.28, 0.0),
                (0.25, 0.1),
                (0.22, 0.2),
                (0.22, h - 0.2),
                (0.26, h),
                (0.0, h),
            ],
            48,
            wall,
        );
    }
    // Cubicles: three along x, two rows.
    for row in 0..2 {
        let z0 = if row == 0 { 0.3 } else { 4.2 };
        for col in 0..3 {
            let x0 = 0.6 + col as f32 * 3.1;
            let (x1, z1) = (x0 + 2.6, z0 + 2.2);
            // Partitions (back and one side), with a top rail.
            let back_z = if row == 0 { z0 } else { z1 - 0.05 };
            cuboid(
                &mut b,
                v(x0, 0.0, back_z),
                v(x1, 1.4, back_z + 0.05),
                partition,
            );
            cuboid(&mut b, v(x0, 0.0, z0), v(x0 + 0.05, 1.4, z1), partition);
            cuboid(
                &mut b,
                v(x0, 1.4, back_z - 0.01),
                v(x1, 1.43, back_z + 0.06),
                metal,
            );
            // L-shaped desk.
            let dz = if row == 0 { z0 + 0.05 } else { z1 - 0.8 };
            table(
                &mut b,
                v(x0 + 0.05, 0.0, dz),
                v(x1 - 0.1, 0.73, dz + 0.75),
                desk_top,
                metal,
            );
            table(
                &mut b,
                v(x0 + 0.05, 0.0, z0 + 0.8),
                v(x0 + 0.8, 0.73, z1 - 0.8),
                desk_top,
                metal,
            );
            // Two monitors, a keyboard, a filing cabinet, a chair.
            let mz = if row == 0 { dz + 0.1 } else { dz + 0.6 };
            for k in 0..2 {
                let mx = x0 + 0.8 + k as f32 * 0.65;
                cuboid(&mut b, v(mx, 0.9, mz), v(mx + 0.55, 1.25, mz + 0.04), dark);
                cylinder(&mut b, v(mx + 0.27, 0.73, mz + 0.02), 0.08, 0.17, 24, metal);
            }
            cuboid(
                &mut b,
                v(x0 + 1.0, 0.73, dz + 0.35),
                v(x0 + 1.45, 0.75, dz + 0.5),
                dark,
            );
            cuboid(
                &mut b,
                v(x1 - 0.6, 0.0, dz + 0.05),
                v(x1 - 0.15, 0.65, dz + 0.65),
                metal,
            );
            let yaw = if row == 0 { -0.5 * PI } else { 0.5 * PI };
            let cz = if row == 0 { dz + 1.2 } else { dz - 0.45 };
            chair(&mut b, v(x0 + 1.3, 0.0, cz), yaw, 32, seat, metal);
        }
    }
    let camera = Camera::look_at(v(0.4, 2.2, 3.5), v(9.0, 0.5, 3.2), Vec3::Y, 70.0);
    let orbit = Orbit {
        center: v(5.0, 2.0, 3.5),
        radius: 1.0,
        look_height: 0.9,
        vfov_degrees: 70.0,
    };
    b.build("office", camera, orbit)
}

/// Sponza: a 30 m x 14 m x 12 m atrium after Crytek's Sponza — two storeys of arcades (columns
/// with bases and capitals, round arches), balconies with balustrades, hanging drapes and plant
/// vases, closed by a roof with a large skylight panel. About 10^5 triangles.
pub fn sponza() -> Result<Scene, SceneError> {
    let mut b = SceneBuilder::new();
    let stone = b.material(Material::diffuse(v(0.62, 0.57, 0.48)));
    let floor = b.material(Material::diffuse(v(0.5, 0.46, 0.4)));
    let roof = b.material(Material::diffuse(v(0.4, 0.38, 0.35)));
    let red = b.material(Material::diffuse(v(0.6, 0.1, 0.08)));
    let green = b.material(Material::diffuse(v(0.12, 0.4, 0.15)));
    let blue = b.material(Material::diffuse(v(0.12, 0.2, 0.5)));
    let terracotta = b.material(Material::diffuse(v(0.6, 0.3, 0.15)));
    let plant = b.material(Material::diffuse(v(0.15, 0.35, 0.08)));
    let sky = b.material(Material::light(v(14.0, 13.0, 11.0)));
    let (w, h, d) = (30.0, 14.0, 12.0);
    shell(
        &mut b,
        Vec3::ZERO,
        v(w, h, d),
        floor,
        roof,
        [stone, stone, stone, stone],
    );
    ceiling_light(&mut b, (6.0, 24.0), (4.0, 8.0), h - 0.05, sky);
    let (inner_z, outer_z) = ([3.0f32, 9.0], [0.0f32, 12.0]);
    let column = |b: &mut SceneBuilder, base: Vec3, height: f32, r: f32| {
        let c = height - 0.6;
        lathe(
            b,
            base,
            &[
                (0.0, 0.0),
                (r * 1.6, 0.0),
                (r * 1.6, 0.25),
                (r * 1.3, 0.3),
                (r * 1.15, 0.45),
                (r, 0.6),
                (r * 0.95, c * 0.5),
                (r * 0.88, c),
                (r * 1.1, c + 0.1),
                (r * 1.5, c + 0.35),
                (r * 1.6, c + 0.6),
                (0.0, height),
            ],
            48,
            stone,
        );
    };
    for (side, &z) in inner_z.iter().enumerate() {
        let out = outer_z[side];
        let (slab_lo, slab_hi) = if side == 0 {
            (out, z + 0.4)
        } else {
            (z - 0.4, out)
        };
        // Ground storey: columns every 3 m, arches between them.
        for i in 0..9 {
            column(&mut b, v(3.0 + 3.0 * i as f32, 0.0, z), 3.5, 0.3);
        }
        for i in 0..8 {
            let cx = 4.5 + 3.0 * i as f32;
            arch(&mut b, v(cx, 3.5, z), Vec3::X, 1.0, 1.5, 0.8, 32, stone);
            cuboid(
                &mut b,
                v(cx - 1.5, 3.5, z - 0.4),
                v(cx - 1.0, 5.0, z + 0.4),
                stone,
            );
        }
        cuboid(&mut b, v(25.5, 3.5, z - 0.4), v(w, 5.0, z + 0.4), stone);
        cuboid(&mut b, v(0.0, 3.5, z - 0.4), v(3.5, 5.0, z + 0.4), stone);
        // Balcony slab and balustrade.
        cuboid(
            &mut b,
            v(0.0, 5.0, slab_lo.min(slab_hi)),
            v(w, 5.3, slab_hi.max(slab_lo)),
            stone,
        );
        let edge = if side == 0 { z + 0.3 } else { z - 0.3 };
        for i in 0..90 {
            let x = 1.0 + i as f32 * 0.31;
            lathe(
                &mut b,
                v(x, 5.3, edge),
                &[
                    (0.0, 0.0),
                    (0.08, 0.0),
                    (0.05, 0.15),
                    (0.09, 0.4),
                    (0.04, 0.75),
                    (0.08, 0.9),
                    (0.0, 0.9),
                ],
                12,
                stone,
            );
        }
        cuboid(
            &mut b,
            v(0.5, 6.2, edge - 0.12),
            v(w - 0.5, 6.32, edge + 0.12),
            stone,
        );
        // Upper storey: slimmer columns and arches, then a solid wall to the roof.
        for i in 0..9 {
            column(&mut b, v(3.0 + 3.0 * i as f32, 5.3, z), 3.2, 0.22);
        }
        for i in 0..8 {
            let cx = 4.5 + 3.0 * i as f32;
            arch(&mut b, v(cx, 8.5, z), Vec3::X, 1.1, 1.5, 0.6, 32, stone);
        }
        cuboid(
            &mut b,
            v(0.0, 8.5, z - 0.3),
            v(w, 8.5 + 0.01, z + 0.3),
            stone,
        );
        cuboid(&mut b, v(0.0, 10.0, z - 0.3), v(w, h, z + 0.3), stone);
        // Drapes hanging from the balcony between the lower arches.
        let palette = [red, green, blue];
        for i in 0..4 {
            let x = 4.5 + 6.0 * i as f32 + 0.9;
            let zz = if side == 0 { z + 0.55 } else { z - 0.55 };
            drape(
                &mut b,
                v(x - 0.9, 6.1, zz),
                v(1.8, 0.0, 0.0),
                v(0.0, -4.2, 0.0),
                40,
                60,
                0.12,
                5.0,
                palette[(i + side) % 3],
            );
        }
        // Vases with plants along the courtyard side.
        for i in 0..8 {
            let x = 4.5 + 3.0 * i as f32;
            let zz = if side == 0 { z + 0.9 } else { z - 0.9 };
            lathe(
                &mut b,
                v(x, 0.0, zz),
                &[
                    (0.0, 0.0),
                    (0.25, 0.0),
                    (0.2, 0.1),
                    (0.35, 0.4),
                    (0.4, 0.7),
                    (0.3, 0.85),
                    (0.35, 0.9),
                    (0.0, 0.9),
                ],
                32,
                terracotta,
            );
            lathe(
                &mut b,
                v(x, 0.9, zz),
                &[(0.0, 0.0), (0.5, 0.15), (0.6, 0.5), (0.35, 0.9), (0.0, 1.1)],
                32,
                plant,
            );
        }
    }
    let camera = Camera::look_at(v(1.0, 1.7, 6.0), v(29.0, 5.0, 6.0), Vec3::Y, 65.0);
    let orbit = Orbit {
        center: v(15.0, 2.0, 6.0),
        radius: 2.0,
        look_height: 3.0,
        vfov_degrees: 70.0,
    };
    b.build("sponza", camera, orbit)
}
