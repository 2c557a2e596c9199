//! A renderer that already lives on a rayon pool adopts the wait-free cache: every pool thread
//! gets exactly one cache handle per frame (`Frame::run_on_pool`), takes image rows from a shared
//! counter and shades them through the crate's integrator; four frames of the Cornell box orbit
//! reuse the cache.
//!
//! `cargo run --release --example rayon_renderer -- [SIZE] [THREADS]`
// The renderer is compiled out under the model checkers (`cfg(checker)`, set by build.rs).
#[cfg(not(checker))]
mod app {
    use std::sync::atomic::{AtomicU32, Ordering};
    use wfic::cache::{IrradianceCache, WaitFree};
    use wfic_render::integrator::{PixelIntegrator, SampleCounters};
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
            let next_row = AtomicU32::new(0);
            let frame = cache.frame();
            // One closure call per pool thread, each with its own handle and worker id.
            let rows = frame.run_on_pool(&pool, |handle, _worker| {
                let mut counters = SampleCounters::default();
                let mut rows = Vec::new();
                loop {
                    // Relaxed: the counter only hands each row to one thread; the pixels come
                    // back through `run_on_pool`'s return value.
                    let y = next_row.fetch_add(1, Ordering::Relaxed);
                    if y >= size {
                        break;
                    }
                    let row: Vec<_> = (0..size)
                        .map(|x| integrator.pixel(x, y, handle, &mut counters))
                        .collect();
                    rows.push((y, row));
                }
                (rows, counters.ic_samples)
            });
            let report = frame.close();
            let mut image = Image::new(size, size);
            let mut samples = 0;
            for (thread_rows, computed) in rows {
                samples += computed;
                for (y, row) in thread_rows {
                    for (x, p) in row.into_iter().enumerate() {
                        image.set(x as u32, y, p);
                    }
                }
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
