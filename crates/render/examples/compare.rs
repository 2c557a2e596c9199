//! Renders scenes with every scheme and the `none` reference and prints the relative RMSE and
//! timings: `cargo run --release --example compare -- [SIZE] [THREADS] [SCENE...]`.
// The renderer is compiled out under the model checkers (`cfg(checker)`, set by build.rs).
#[cfg(not(checker))]
mod app {
    use wfic::cache::Scheme;
    use wfic_render::render_with_scheme;
    use wfic_render::{scenes, RenderSettings};

    pub fn main() {
        let mut args = std::env::args().skip(1);
        let size: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(256);
        let threads: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1);
        let names: Vec<String> = args.collect();
        let names: Vec<&str> = if names.is_empty() {
            scenes::NAMES.to_vec()
        } else {
            names.iter().map(String::as_str).collect()
        };
        let rays: u32 = std::env::var("RAYS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(RenderSettings::new(1, 1).rays_per_record);
        let acc: f32 = std::env::var("ACC")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(RenderSettings::new(1, 1).accuracy);
        let schemes: Vec<Scheme> = match std::env::var("SCHEMES") {
            Ok(s) => s
                .split(',')
                .map(|n| Scheme::from_name(n).expect("scheme"))
                .collect(),
            Err(_) => vec![Scheme::Wf],
        };
        for name in names {
            let t = std::time::Instant::now();
            let scene = scenes::by_name(name).expect("known scene").expect("builds");
            println!(
                "{name}: {} triangles, {} light triangles (area {:.3}), diagonal {:.2}, built in {:.2} s",
                scene.triangle_count(),
                scene.light_count(),
                scene.light_area(),
                scene.diagonal(),
                t.elapsed().as_secs_f64()
            );
            let settings = RenderSettings::new(size, size)
                .rays_per_record(rays)
                .accuracy(acc);
            let config = settings.cache_config(&scene).unwrap();
            let camera = scene.camera();
            // REF_RAYS: a reference with more rays per estimate (less noise of its own).
            let ref_settings = match std::env::var("REF_RAYS").ok().and_then(|s| s.parse().ok()) {
                Some(r) => settings.clone().rays_per_record(r),
                None => settings.clone(),
            };
            let (reference, _) = render_with_scheme(
                Scheme::None,
                &scene,
                &camera,
                &ref_settings,
                config,
                threads,
            );
            println!(
                "  none       {:7.3} s  {:8} samples  {:.3e} hemisphere rays/s/core",
                reference.stats.seconds,
                reference.stats.ic_samples,
                reference.stats.hemisphere_rays_per_second()
            );
            if std::env::var("NOISE").is_ok() {
                // Two references with independent seeds: their difference is pure Monte Carlo noise.
                let other = settings.clone().seed(settings.seed + 1);
                let (again, _) =
                    render_with_scheme(Scheme::None, &scene, &camera, &other, config, threads);
                let white = 0.99 * scene.min_emitter_luminance();
                println!(
                    "  none vs none (other seed): rmse {:.4} (without emitter pixels {:.4})",
                    again.image.relative_rmse(&reference.image).unwrap(),
                    again
                        .image
                        .relative_rmse_below(&reference.image, white)
                        .unwrap()
                );
            }
            if let Ok(dir) = std::env::var("OUT") {
                let e = reference.image.auto_exposure();
                reference
                    .image
                    .write_png(
                        &std::path::Path::new(&dir).join(format!("{name}-none.png")),
                        e,
                    )
                    .unwrap();
            }
            for &scheme in &schemes {
                let (frame, _) =
                    render_with_scheme(scheme, &scene, &camera, &settings, config, threads);
                let rmse = frame.image.relative_rmse(&reference.image).unwrap();
                let white = 0.99 * scene.min_emitter_luminance();
                let unclipped = frame
                    .image
                    .relative_rmse_below(&reference.image, white)
                    .unwrap();
                let s = &frame.stats;
                println!(
                    "  {:10} {:7.3} s  {:8} samples  rmse {:.4} (without emitter pixels {:.4})  hits {}/{}  sharing {:.3}  discarded {}  {:.3e} rays/s/core",
                    s.scheme, s.seconds, s.ic_samples, rmse, unclipped, s.hits, s.lookups, s.sharing, s.discarded,
                    s.hemisphere_rays_per_second()
                );
                if std::env::var("DIFF").is_ok() {
                    let mut errs: Vec<(f32, u32, u32)> = Vec::new();
                    for y in 0..size {
                        for x in 0..size {
                            let d = (frame.image.get(x, y) - reference.image.get(x, y))
                                .length_squared();
                            errs.push((d, x, y));
                        }
                    }
                    let total: f32 = errs.iter().map(|e| e.0).sum();
                    errs.sort_by(|a, b| b.0.total_cmp(&a.0));
                    for &(d, x, y) in errs.iter().take(8) {
                        println!(
                            "    ({x},{y}) share {:.3} wf {} ref {}",
                            d / total,
                            frame.image.get(x, y),
                            reference.image.get(x, y)
                        );
                    }
                }
                if let Ok(dir) = std::env::var("OUT") {
                    let e = frame.image.auto_exposure();
                    frame
                        .image
                        .write_png(
                            &std::path::Path::new(&dir).join(format!("{name}-{}.png", s.scheme)),
                            e,
                        )
                        .unwrap();
                }
            }
        }
    }
}

fn main() {
    #[cfg(not(checker))]
    app::main();
}
