//! Records computed on a real scene, for the `records_held` bench of the core crate (which cannot
//! depend on the renderer): renders a built-in scene with WF at each accuracy given and writes the
//! records the cache holds afterwards, with the camera's own lookup points, to
//! `target/records-held/real-SCENE-aACC.bin` (not committed).
//!
//! ```sh
//! cargo run --release -p wfic-render --example dump_records -- [SCENE] [SIZE] [ACC...]
//! ```
//!
//! Defaults: `conference`, a 1024 x 1024 image, accuracies 0.4 0.2 0.1 0.05. The renderer's
//! defaults otherwise (radius clamps in pixel footprints and in scene diagonals), except 32 rays
//! per record and one light sample, for speed: the records' irradiance is noisier, their
//! positions, normals and radii (all the cache's cost depends on) are the renderer's own. `RAYS`
//! and `THREADS` override.
//!
//! The file, little-endian: the magic `WFICRECS`, a `u32` version (1), the cache's accuracy and
//! bounds (`f32`: a, min xyz, max xyz, as `RenderSettings::cache_config` sets them), the record
//! and query counts (`u64` each); then per record 28 `f32` (position, normal, irradiance, radius,
//! `grad_t`, `grad_r`), per query 6 `f32` (the primary hit point and its normal facing the eye, at
//! 16 384 pixel positions uniform over the image, drawn with a fixed seed: the same at every
//! accuracy).

// The renderer is compiled out under the model checkers (`cfg(checker)`, set by build.rs).
#[cfg(not(checker))]
mod app {
    use glam::Vec3;
    use std::io::Write;
    use std::time::Instant;
    use wfic::cache::Scheme;
    use wfic::ic::Record;
    use wfic::rng::Rng;
    use wfic_render::integrator::facing;
    use wfic_render::{render_with_scheme, scenes, RenderSettings};

    /// Lookup points written beside the records.
    const QUERIES: usize = 16_384;

    fn env<T: std::str::FromStr>(name: &str) -> Option<T> {
        std::env::var(name).ok().and_then(|s| s.parse().ok())
    }

    pub fn main() {
        let args: Vec<String> = std::env::args().skip(1).collect();
        let name = args.first().map_or("conference", String::as_str);
        let size: u32 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1024);
        let mut accuracies: Vec<f32> = args[2.min(args.len())..]
            .iter()
            .map(|s| s.parse().expect("an accuracy"))
            .collect();
        if accuracies.is_empty() {
            accuracies = vec![0.4, 0.2, 0.1, 0.05];
        }
        let rays: u32 = env("RAYS").unwrap_or(32);
        let threads: usize = env("THREADS").unwrap_or(2);
        let scene = scenes::load(name).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(2);
        });
        let camera = scene.camera();
        let queries = queries(&scene, size);
        let dir =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/records-held");
        std::fs::create_dir_all(&dir).expect("target/records-held");
        for a in accuracies {
            let settings = RenderSettings::new(size, size)
                .accuracy(a)
                .rays_per_record(rays)
                .light_samples(1);
            let config = settings.cache_config(&scene).expect("settings");
            let start = Instant::now();
            let (_, records) =
                render_with_scheme(Scheme::Wf, &scene, &camera, &settings, config, threads);
            let (lo, hi) = scene.bounds();
            let margin = 0.01 * scene.diagonal();
            let path = dir.join(format!("real-{name}-a{a}.bin"));
            write(
                &path,
                config.accuracy(),
                lo - margin,
                hi + margin,
                &records,
                &queries,
            );
            println!(
                "{name} {size}x{size} a={a}: {} records in {:.1} s -> {}",
                records.len(),
                start.elapsed().as_secs_f64(),
                path.display()
            );
        }
    }

    /// The primary hits at `QUERIES` pixel positions uniform over the image (emitters and misses
    /// skipped), with their normals facing the eye, as the renderer looks them up.
    fn queries(scene: &wfic_render::Scene, size: u32) -> Vec<(Vec3, Vec3)> {
        let view = scene.camera().view(size, size);
        let mut rng = Rng::new(0x9e7);
        let mut out = Vec::with_capacity(QUERIES);
        while out.len() < QUERIES {
            let (x, y) = (rng.next_f32() * size as f32, rng.next_f32() * size as f32);
            let dir = view.direction(x, y);
            let Some(hit) = scene.intersect(view.eye(), dir, f32::INFINITY) else {
                continue;
            };
            if hit.material.is_emissive() {
                continue;
            }
            out.push((view.eye() + dir * hit.t, facing(hit.normal, dir)));
        }
        out
    }

    fn write(
        path: &std::path::Path,
        accuracy: f32,
        lo: Vec3,
        hi: Vec3,
        records: &[Record],
        queries: &[(Vec3, Vec3)],
    ) {
        let mut out = Vec::with_capacity(64 + records.len() * 112 + queries.len() * 24);
        out.extend_from_slice(b"WFICRECS");
        out.extend_from_slice(&1u32.to_le_bytes());
        let f = |v: f32, out: &mut Vec<u8>| out.extend_from_slice(&v.to_le_bytes());
        for v in [accuracy, lo.x, lo.y, lo.z, hi.x, hi.y, hi.z] {
            f(v, &mut out);
        }
        out.extend_from_slice(&(records.len() as u64).to_le_bytes());
        out.extend_from_slice(&(queries.len() as u64).to_le_bytes());
        for r in records {
            let mut vs = vec![r.position, r.normal, r.irradiance];
            vs.extend(r.grad_t.iter().chain(&r.grad_r).copied());
            for (i, v) in vs.iter().enumerate() {
                for c in v.to_array() {
                    f(c, &mut out);
                }
                if i == 2 {
                    f(r.radius, &mut out);
                }
            }
        }
        for (p, n) in queries {
            for c in p.to_array().into_iter().chain(n.to_array()) {
                f(c, &mut out);
            }
        }
        let mut file = std::fs::File::create(path).expect("create");
        file.write_all(&out).expect("write");
    }
}

#[cfg(not(checker))]
fn main() {
    app::main();
}

#[cfg(checker)]
fn main() {}
