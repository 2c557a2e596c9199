//! Ray queries against a flat triangle list and against the BVH, by scene size: the crossover
//! that sets `wfic_render::flat::FLAT_MAX`.
//!
//! Each scene is `n` random triangles (edges up to about a tenth of the box) inside a closed unit box
//! of twelve, one of its faces an emitter, as the Cornell box is built; the queries are 1 024
//! rays from random points inside the box in random directions, each a closest-hit query and a
//! shadow query to half its hit distance, the mix a hemisphere estimate makes. `rays/N/flat`
//! against `rays/N/bvh` in one run gives the ratio at each size.
// The renderer is compiled out under the model checkers (`cfg(checker)`, set by build.rs).
#[cfg(not(checker))]
mod bench {
    use criterion::{criterion_group, BenchmarkId, Criterion};
    use glam::Vec3;
    use std::hint::black_box;
    use wfic::rng::Rng;
    use wfic_render::flat::Traversal;
    use wfic_render::{Camera, Material, Orbit, Scene, SceneBuilder};

    /// `extra` random triangles in a closed unit box (12 triangles, the top one lit).
    fn soup(extra: usize) -> Scene {
        let mut b = SceneBuilder::new();
        let white = b.material(Material::diffuse(Vec3::splat(0.7)));
        let light = b.material(Material::light(Vec3::splat(10.0)));
        let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        // The unit cube's corner k at (k & 1, k >> 1 & 1, k >> 2 & 1); six faces wound inwards,
        // the top one (y = 1) emitting downwards.
        let corner = |k: usize| c((k & 1) as f32, (k >> 1 & 1) as f32, (k >> 2 & 1) as f32);
        let faces = [
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
            [0, 2, 3, 1],
            [4, 5, 7, 6],
        ];
        for (f, [p, q, r, s]) in faces.into_iter().enumerate() {
            let m = if f == 1 { light } else { white };
            b.quad(corner(p), corner(q), corner(r), corner(s), m);
        }
        let mut rng = Rng::new(extra as u64 + 1);
        let point = |rng: &mut Rng| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        for _ in 0..extra {
            let a = 0.1 + 0.8 * point(&mut rng);
            let d1 = (point(&mut rng) - 0.5) * 0.16;
            let d2 = (point(&mut rng) - 0.5) * 0.16;
            b.triangle(a, a + d1, a + d2, white);
        }
        let camera = Camera::look_at(c(0.5, 0.5, -1.0), c(0.5, 0.5, 0.5), Vec3::Y, 40.0);
        let orbit = Orbit {
            center: c(0.5, 0.5, 0.5),
            radius: 0.2,
            look_height: 0.4,
            vfov_degrees: 60.0,
        };
        b.build("soup", camera, orbit).expect("the soup builds")
    }

    fn queries() -> Vec<(Vec3, Vec3)> {
        let mut rng = Rng::new(3);
        (0..1024)
            .map(|_| {
                let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.9 + 0.05;
                let d = loop {
                    let v = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
                    if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
                        break v.normalize();
                    }
                };
                (o, d)
            })
            .collect()
    }

    fn rays(c: &mut Criterion) {
        let rays = queries();
        let mut group = c.benchmark_group("rays");
        group.sample_size(20);
        for extra in [4, 20, 52, 84, 116, 244] {
            let scene = soup(extra);
            let n = scene.triangle_count();
            for traversal in [Traversal::Flat, Traversal::Bvh] {
                let scene = soup(extra).with_traversal(traversal);
                group.bench_with_input(BenchmarkId::new(traversal.name(), n), &scene, |b, s| {
                    b.iter(|| {
                        let mut lit = 0u32;
                        for &(o, d) in &rays {
                            if let Some(h) = s.intersect(o, d, f32::INFINITY) {
                                lit += u32::from(s.unoccluded(o, d, 0.5 * h.t));
                            }
                        }
                        black_box(lit)
                    })
                });
            }
        }
        group.finish();
    }

    criterion_group!(benches, rays);
}

#[cfg(not(checker))]
criterion::criterion_main!(bench::benches);

#[cfg(checker)]
fn main() {}
