//! A renderer that already lives on a rayon pool adopts the wait-free cache: every pool thread
//! gets exactly one cache handle per frame (`Frame::run_on_pool`), takes image rows from a shared
//! counter and shades them through the renderer's worker loop (`wfic_render::work`); four frames
//! of the Cornell box orbit reuse the cache.
//!
//! `cargo run --release --example rayon_renderer -- [SIZE] [THREADS]`
// The renderer is compiled out under the model checkers (`cfg(checker)`, set by build.rs).
#[cfg(not(checker))]
mod app {
    use wfic::cache::{IrradianceCache, WaitFree};
    use wfic_render::integrator::PixelIntegrator;
    use wfic_render::work::{shade, Blocks, Counter, GridRows};
    use wfic_render::{scenes, Camera, Image, RenderSettings};

    pub fn main() {
        let mut args = std::env::args().skip(1);
        let size: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(96);
        let threads: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(2);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a rayon pool");

        let scene = scenes::cornell().expect("the Cornell box builds");
        let settings = RenderSettings::new(size, size).rays_per_record(128);
        let config = settings.cache_config(&scene).expect("scene bounds");
        let mut cache = WaitFree::adopt(config);
        for i in 0..4 {
            let camera = Camera::orbit(&scene, i as f32 / 4.0);
            let integrator = PixelIntegrator::new(&scene, &camera, &settings, config.accuracy());
            // Every row of the image, handed out by the renderer's atomic counter.
            let rows = GridRows::new(&settings, 1);
            let next_row = Counter::new(rows.count());
            let frame = cache.frame();
            // One closure call per pool thread, each with its own handle and worker id, running
            // the renderer's worker loop over the rows.
            let outputs = frame.run_on_pool(&pool, |handle, _worker| {
                shade(&integrator, &rows, &next_row, handle, |_| ())
            });
            let report = frame.close();
            let mut image = Image::new(size, size);
            let mut samples = 0;
            for out in outputs {
                samples += out.counters.ic_samples;
                out.paint(&rows, &mut image);
            }
            println!(
                "frame {i}: {samples} records computed, {} lookups ({} hits) on {} pool threads, \
                 {} records cached, mean radiance {:.3}",
                report.workers.lookups,
                report.workers.hits,
                pool.current_num_threads(),
                cache.stats().records,
                image.mean().length(),
            );
        }
    }
}

#[cfg(not(checker))]
fn main() {
    app::main();
}

#[cfg(checker)]
fn main() {}
