//! How a frame is rendered ([`RenderSettings`]) and where its workers run ([`Pool`]): plain
//! settings that the integrator, the render loops and the statistics read.

use super::scene::Scene;
use wfic::cache::{CacheConfig, ConfigError};

/// Where a frame's workers run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Pool {
    /// One scoped thread per worker, started for the frame ([`wfic::cache::Frame::run`]).
    #[default]
    Scoped,
    /// A rayon pool of as many threads, one cache handle per pool thread
    /// ([`wfic::cache::Frame::run_on_pool`]).
    Rayon,
}

impl Pool {
    /// The name, as `--pool` spells it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Scoped => "threads",
            Self::Rayon => "rayon",
        }
    }
}

/// How a frame is rendered: image size, sampling and the cache's radius clamps.
///
/// The record radius (Ward's `R_i`, the clamped harmonic mean distance) is clamped to
/// `[r_min, r_max]` with
/// `r_min = max(min_radius_pixels * footprint, min_radius_scene * diagonal)` and
/// `r_max = max(r_min, min(max_radius_pixels * footprint, max_radius_scene * diagonal))`, where
/// `footprint` is the side of one pixel at the shaded point and `diagonal` the scene's size. The
/// pixel bounds keep record density tied to what the image resolves (Tabellion & Lamorlette 2004,
/// Křivánek et al. 2008); the scene bounds keep records sane when the footprint is tiny (a wall
/// next to the eye) or huge (a far wall at a grazing angle).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Ward's accuracy `a` for the cache ([`RenderSettings::cache_config`]).
    pub accuracy: f32,
    /// Hemisphere rays per irradiance estimate (rounded to `M x N` strata).
    pub rays_per_record: u32,
    /// The smoothing `k` (at least 1): a pixel interpolates every record valid at accuracy
    /// `k a`, but a new record is computed only where none is valid at `a`. The records are the
    /// ones `k = 1` computes; each pixel averages more of them, so their sampling noise averages
    /// down, for some interpolation error (`docs/renderer.md`). 1, the default, is Ward's cache
    /// as the paper has it.
    pub smoothing: f32,
    /// Light samples (shadow rays) for the direct term at each primary hit. The default, 16,
    /// is the count at which the direct light's noise in the Cornell box falls below
    /// Radiance's deterministic sampling at its defaults, so the two renderers' images compare
    /// on their indirect light.
    pub light_samples: u32,
    /// Primary rays per pixel (stratified jitter, box filter). Each primary hit is shaded on its
    /// own, so each makes its own cache lookup, as in a renderer that antialiases. 1 shoots one
    /// ray through the pixel's centre.
    pub pixel_samples: u32,
    /// Lower radius clamp, in pixel footprints.
    pub min_radius_pixels: f32,
    /// Upper radius clamp, in pixel footprints.
    pub max_radius_pixels: f32,
    /// Lower radius clamp, as a fraction of the scene's diagonal.
    pub min_radius_scene: f32,
    /// Upper radius clamp, as a fraction of the scene's diagonal.
    pub max_radius_scene: f32,
    /// Side of the square tiles handed to workers, in pixels.
    pub tile_size: u32,
    /// Seed of every pixel's random streams.
    pub seed: u64,
    /// Hide the progress bar.
    pub quiet: bool,
    /// Where the workers run.
    pub pool: Pool,
    /// Render deterministic frames ([`crate::deterministic`]): the same image and records at any
    /// thread count and on either pool.
    pub deterministic: bool,
}

impl RenderSettings {
    /// Defaults for a `width` x `height` image.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            accuracy: 0.25,
            rays_per_record: 512,
            smoothing: 1.0,
            light_samples: 16,
            pixel_samples: 1,
            min_radius_pixels: 6.0,
            max_radius_pixels: 120.0,
            min_radius_scene: 0.002,
            max_radius_scene: 0.25,
            tile_size: 16,
            seed: 0x5eed,
            quiet: true,
            pool: Pool::Scoped,
            deterministic: false,
        }
    }

    /// Sets the accuracy.
    pub fn accuracy(mut self, a: f32) -> Self {
        self.accuracy = a;
        self
    }

    /// Sets the hemisphere rays per record.
    pub fn rays_per_record(mut self, rays: u32) -> Self {
        self.rays_per_record = rays;
        self
    }

    /// Sets the smoothing `k` ([`RenderSettings::smoothing`]).
    pub fn smoothing(mut self, k: f32) -> Self {
        self.smoothing = k;
        self
    }

    /// Sets the light samples per primary hit.
    pub fn light_samples(mut self, n: u32) -> Self {
        self.light_samples = n;
        self
    }

    /// Sets the primary rays per pixel.
    pub fn pixel_samples(mut self, n: u32) -> Self {
        self.pixel_samples = n;
        self
    }

    /// Sets the seed.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Shows (`false`) or hides (`true`) the progress bar.
    pub fn quiet(mut self, quiet: bool) -> Self {
        self.quiet = quiet;
        self
    }

    /// Runs the workers on `pool`.
    pub fn pool(mut self, pool: Pool) -> Self {
        self.pool = pool;
        self
    }

    /// A cache configuration for `scene`: its bounds enlarged by 1% of the diagonal on every
    /// side (so points on the outer walls are well inside), at the accuracy lookups interpolate
    /// at, `smoothing * accuracy`. A smoothing below 1 (or not finite) is refused.
    pub fn cache_config(&self, scene: &Scene) -> Result<CacheConfig, ConfigError> {
        if !(self.smoothing >= 1.0 && self.smoothing.is_finite()) {
            return Err(ConfigError::Smoothing(self.smoothing));
        }
        let (lo, hi) = scene.bounds();
        let margin = 0.01 * scene.diagonal();
        CacheConfig::new(lo - margin, hi + margin, self.accuracy * self.smoothing)
    }

    /// The radius clamps at a point whose pixel footprint is `footprint`, for a scene of size
    /// `diagonal`: `(r_min, r_max)` as documented on the type.
    pub fn radius_bounds(&self, footprint: f32, diagonal: f32) -> (f32, f32) {
        let r_min = (self.min_radius_pixels * footprint).max(self.min_radius_scene * diagonal);
        let r_max = (self.max_radius_pixels * footprint)
            .min(self.max_radius_scene * diagonal)
            .max(r_min);
        (r_min, r_max)
    }
}
