//! End-to-end render benchmark: a small Cornell box frame with an empty cache, per scheme
//! (the paper's still-image experiment, Table 1, in miniature). Threads: 1 for TRA, 2 otherwise
//! (the machine has 2 cores).
//!
//! `render_pool/*` renders the same WF frame at 2 threads on both pools (`--pool threads`: scoped
//! threads started for the frame; `--pool rayon`: a rayon pool, one cache handle per pool
//! thread), alternating, so their ratio is measured in one run.
// The renderer is compiled out under the model checkers (`cfg(checker)`, set by build.rs).
#[cfg(not(checker))]
mod bench {
    use criterion::{criterion_group, Criterion};
    use wfic::cache::Scheme;
    use wfic_render::{render_with_scheme, scenes, Pool, RenderSettings};

    fn cornell(c: &mut Criterion) {
        let scene = scenes::cornell().expect("cornell builds");
        let settings = RenderSettings::new(128, 128);
        let config = settings.cache_config(&scene).expect("config");
        let camera = scene.camera();
        let mut group = c.benchmark_group("render_cornell_128");
        group.sample_size(10);
        for scheme in Scheme::ALL {
            let threads = if scheme == Scheme::Tra { 1 } else { 2 };
            group.bench_function(format!("{}/{threads}t", scheme.name()), |b| {
                b.iter(|| render_with_scheme(scheme, &scene, &camera, &settings, config, threads))
            });
        }
        group.finish();
    }

    fn pools(c: &mut Criterion) {
        let scene = scenes::cornell().expect("cornell builds");
        let camera = scene.camera();
        let mut group = c.benchmark_group("render_pool");
        group.sample_size(10);
        for scheme in [Scheme::Wf, Scheme::Lck] {
            for pool in [Pool::Scoped, Pool::Rayon] {
                let settings = RenderSettings::new(128, 128).pool(pool);
                let config = settings.cache_config(&scene).expect("config");
                group.bench_function(format!("{}/{}/2t", scheme.name(), pool.name()), |b| {
                    b.iter(|| render_with_scheme(scheme, &scene, &camera, &settings, config, 2))
                });
            }
        }
        group.finish();
    }

    criterion_group!(benches, cornell, pools);
}

#[cfg(not(checker))]
criterion::criterion_main!(bench::benches);

#[cfg(checker)]
fn main() {}
