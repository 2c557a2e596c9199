//! A compact, real renderer that drives wfic's irradiance caches end to end: the workload the
//! caches are measured under. `docs/renderer.md` describes it at length.
//!
//! One module per job, as pbrt-v4 organises a renderer:
//!
//! * [`scene`] — triangles, diffuse materials, emissive triangles, the BVH (obvhs);
//! * [`scenes`] — the paper's five scenes, all real models: the Cornell box from the published
//!   data, Sponza, the Conference Room, the Office and its Desk view, compiled in from `scenes/`
//!   (`scenes/README.md` gives their origins);
//! * [`lights`] — the area lights grouped into emitters, chosen per point by power over distance;
//! * [`colour`] — luminance and the sRGB curve, shared by the modules that weigh or decode colours;
//! * [`obj`] — Wavefront OBJ/MTL loading, from the file system or any [`obj::FileResolver`];
//! * [`camera`] — pinhole camera and the orbit of the paper's animations;
//! * [`sampler`] — per-pixel deterministic random numbers;
//! * [`integrator`] — per-sample radiance (`Li`): direct light and one indirect diffuse bounce
//!   through the cache (lookup, else a hemisphere estimate with limited gradients, inserted);
//! * [`film`] — the HDR image, PNG/PFM output, the record overlay, relative RMSE;
//! * [`work`] — the work sources (an atomic counter, a fed queue) and the one worker loop every
//!   render runs;
//! * [`deterministic`] — frames whose image and records do not depend on the schedule;
//! * [`parallel`] — a frame's tiles shaded by the workers of one cache frame, on scoped threads
//!   or a rayon pool, and the reference grid;
//! * `distributed` (feature `mpi`) — one frame over the ranks of an MPI job;
//! * [`stats`] — what a frame counts, and its JSON forms.
//!
// The example is a doctest only where the renderer is built (not under the model checkers).
#![cfg_attr(
    not(checker),
    doc = r#"
```no_run
use wfic::cache::WaitFree;
use wfic_render::{scenes, Camera, RenderSettings};

let scene = scenes::cornell().unwrap();
let settings = RenderSettings::new(128, 128);
let config = settings.cache_config(&scene).unwrap();
let mut cache = WaitFree::adopt(config);
for frame in 0..4 {
    let camera = Camera::orbit(&scene, frame as f32 / 4.0);
    let out = wfic_render::render_frame(&scene, &camera, &settings, &mut cache, 2);
    println!("frame {frame}: {:.3} s, {} records computed", out.stats.seconds, out.stats.ic_samples);
}
```
"#
)]
//!
//! The renderer has no `unsafe` code: the cache is its only shared mutable state, apart from the
//! work sources (a Relaxed atomic counter from [`wfic::sync`], or a queue under a lock) and the
//! progress bar.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// Under the core's model checkers (features `loom`, `shuttle`: `cfg(checker)`, set by the
// workspace's build.rs) the renderer is not built: their primitives work inside models only.
#![cfg(not(checker))]

pub mod camera;
pub mod colour;
pub mod deterministic;
#[cfg(feature = "mpi")]
pub mod distributed;
pub mod film;
pub mod flat;
pub mod integrator;
pub mod lights;
pub mod limits;
pub mod obj;
pub mod parallel;
pub mod sampler;
pub mod scene;
pub mod scenes;
pub mod settings;
pub mod stats;
pub mod work;

pub use camera::{Camera, Orbit};
pub use film::Image;
pub use parallel::{
    render_frame, render_orbit, render_reference, render_reference_grid, render_with_scheme,
    FrameResult,
};
pub use scene::{Material, Scene, SceneBuilder, SceneError};
pub use settings::{Pool, RenderSettings, SettingsError};
pub use stats::FrameStats;
