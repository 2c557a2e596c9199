//! Renders scenes with every scheme and the `none` reference and prints the relative RMSE and
//! timings: `cargo run --release --example compare -- [SIZE] [THREADS] [SCENE...]`.
//!
//! Environment: `RAYS` and `ACC` set the rays per record and the accuracy, `SCHEMES` the schemes
//! (comma-separated, default `wf`), `REF_RAYS` the reference's rays per record, `NOISE` adds a
//! second reference with another seed, `DIFF` lists the worst pixels, `OUT` names a folder for
//! the PNGs.
// The renderer is compiled out under the model checkers (`cfg(checker)`, set by build.rs).
#[cfg(not(checker))]
mod app {
    use wfic::cache::Scheme;
    use wfic_render::{render_with_scheme, FrameResult, Image};
    use wfic_render::{scenes, RenderSettings};

    /// What to render, from the arguments and the environment.
    struct Options {
        size: u32,
        threads: usize,
        names: Vec<String>,
        rays: u32,
        accuracy: f32,
        schemes: Vec<Scheme>,
    }

    fn env<T: std::str::FromStr>(name: &str) -> Option<T> {
        std::env::var(name).ok().and_then(|s| s.parse().ok())
    }

    impl Options {
        fn parse() -> Self {
            let mut args = std::env::args().skip(1);
            let size: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(256);
            let threads: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1);
            let names: Vec<String> = args.collect();
            let names = if names.is_empty() {
                scenes::NAMES.iter().map(|s| s.to_string()).collect()
            } else {
                names
            };
            let defaults = RenderSettings::new(1, 1);
            let schemes: Vec<Scheme> = match std::env::var("SCHEMES") {
                Ok(s) => s
                    .split(',')
                    .map(|n| Scheme::from_name(n).expect("scheme"))
                    .collect(),
                Err(_) => vec![Scheme::Wf],
            };
            Self {
                size,
                threads,
                names,
                rays: env("RAYS").unwrap_or(defaults.rays_per_record),
                accuracy: env("ACC").unwrap_or(defaults.accuracy),
                schemes,
            }
        }
    }

    pub fn main() {
        let options = Options::parse();
        for name in &options.names {
            compare(name, &options);
        }
    }

    /// The reference of scene `name` and a frame of every scheme, with their errors.
    fn compare(name: &str, o: &Options) {
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
        let settings = RenderSettings::new(o.size, o.size)
            .rays_per_record(o.rays)
            .accuracy(o.accuracy);
        let config = settings.cache_config(&scene).unwrap();
        let camera = scene.camera();
        // REF_RAYS: a reference with more rays per estimate (less noise of its own).
        let ref_settings = match env("REF_RAYS") {
            Some(r) => settings.clone().rays_per_record(r),
            None => settings.clone(),
        };
        let (reference, _) = render_with_scheme(
            Scheme::None,
            &scene,
            &camera,
            &ref_settings,
            config,
            o.threads,
        );
        println!(
            "  none       {:7.3} s  {:8} samples  {:.3e} hemisphere rays/s/core",
            reference.stats.seconds,
            reference.stats.ic_samples,
            reference.stats.hemisphere_rays_per_second()
        );
        let white = 0.99 * scene.min_emitter_luminance();
        if std::env::var("NOISE").is_ok() {
            // Two references with independent seeds: their difference is pure Monte Carlo noise.
            let other = settings.clone().seed(settings.seed + 1);
            let (again, _) =
                render_with_scheme(Scheme::None, &scene, &camera, &other, config, o.threads);
            println!(
                "  none vs none (other seed): rmse {:.4} (without emitter pixels {:.4})",
                again.image.relative_rmse(&reference.image).unwrap(),
                again
                    .image
                    .relative_rmse_below(&reference.image, white)
                    .unwrap()
            );
        }
        write_png(&reference.image, &format!("{name}-none.png"));
        for &scheme in &o.schemes {
            let (frame, _) =
                render_with_scheme(scheme, &scene, &camera, &settings, config, o.threads);
            report(&frame, &reference.image, white);
            if std::env::var("DIFF").is_ok() {
                print_worst(&frame.image, &reference.image, o.size);
            }
            write_png(&frame.image, &format!("{name}-{}.png", frame.stats.scheme));
        }
    }

    /// One line on `frame` against `reference`; `white` bounds the pixels that are not emitters.
    fn report(frame: &FrameResult, reference: &Image, white: f32) {
        let rmse = frame.image.relative_rmse(reference).unwrap();
        let unclipped = frame.image.relative_rmse_below(reference, white).unwrap();
        let s = &frame.stats;
        println!(
            "  {:10} {:7.3} s  {:8} samples  rmse {:.4} (without emitter pixels {:.4})  hits {}/{}  sharing {:.3}  discarded {}  {:.3e} rays/s/core",
            s.scheme, s.seconds, s.ic_samples, rmse, unclipped, s.hits, s.lookups, s.sharing, s.discarded,
            s.hemisphere_rays_per_second()
        );
    }

    /// The 8 pixels of `image` farthest from `reference`, with their share of the squared error.
    fn print_worst(image: &Image, reference: &Image, size: u32) {
        let mut errs: Vec<(f32, u32, u32)> = Vec::new();
        for y in 0..size {
            for x in 0..size {
                let d = (image.get(x, y) - reference.get(x, y)).length_squared();
                errs.push((d, x, y));
            }
        }
        let total: f32 = errs.iter().map(|e| e.0).sum();
        errs.sort_by(|a, b| b.0.total_cmp(&a.0));
        for &(d, x, y) in errs.iter().take(8) {
            println!(
                "    ({x},{y}) share {:.3} wf {} ref {}",
                d / total,
                image.get(x, y),
                reference.get(x, y)
            );
        }
    }

    /// Writes `image` as `file` in the folder `OUT` names, if it names one.
    fn write_png(image: &Image, file: &str) {
        if let Ok(dir) = std::env::var("OUT") {
            let e = image.auto_exposure();
            image
                .write_png(&std::path::Path::new(&dir).join(file), e)
                .unwrap();
        }
    }
}

fn main() {
    #[cfg(not(checker))]
    app::main();
}
