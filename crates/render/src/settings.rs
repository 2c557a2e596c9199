//! How a frame is rendered ([`RenderSettings`]) and where its workers run ([`Pool`]): plain
//! settings that the integrator, the render loops and the statistics read.

pub use super::lights::DirectSampling;
use super::limits::{self, OutOfRange};
use super::scene::Scene;
use std::fmt;
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
    /// How the direct light is sampled ([`DirectSampling`]; the default samples every emitter
    /// that can reach a point, by the light-bounds importance, spheres by cone).
    pub direct: DirectSampling,
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
            direct: DirectSampling::Bounds,
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

    /// Checks every field against its range in [`crate::limits`]: the image's sides and its
    /// pixels, the accuracy, the smoothing (and `smoothing x accuracy` at most
    /// [`CacheConfig::MAX_ACCURACY`]), the sample counts, the tile size and the radius clamps.
    /// The render functions panic on settings this refuses.
    ///
    /// # Errors
    /// The first field out of its range, named with the value and the range.
    pub fn validate(&self) -> Result<(), OutOfRange> {
        limits::WIDTH.check(self.width)?;
        limits::HEIGHT.check(self.height)?;
        let pixels = u64::from(self.width) * u64::from(self.height);
        limits::PIXELS.check(pixels).map_err(|e| OutOfRange {
            value: format!("{} x {} = {pixels}", self.width, self.height),
            ..e
        })?;
        limits::ACCURACY.check(self.accuracy)?;
        limits::SMOOTHING.check(self.smoothing)?;
        if self.smoothing * self.accuracy > CacheConfig::MAX_ACCURACY {
            return Err(OutOfRange {
                setting: limits::SMOOTHING.setting,
                option: limits::SMOOTHING.option,
                value: self.smoothing.to_string(),
                range: format!(
                    "[1, {}] (smoothing x accuracy at most {})",
                    CacheConfig::MAX_ACCURACY / self.accuracy,
                    CacheConfig::MAX_ACCURACY
                ),
            });
        }
        limits::RAYS_PER_RECORD.check(self.rays_per_record)?;
        limits::LIGHT_SAMPLES.check(self.light_samples)?;
        limits::PIXEL_SAMPLES.check(self.pixel_samples)?;
        limits::TILE_SIZE.check(self.tile_size)?;
        for r in [self.min_radius_pixels, self.max_radius_pixels] {
            limits::RADIUS_PIXELS.check(r)?;
        }
        for r in [self.min_radius_scene, self.max_radius_scene] {
            limits::RADIUS_SCENE.check(r)?;
        }
        Ok(())
    }

    /// A cache configuration for `scene`: its bounds enlarged by 1% of the diagonal on every
    /// side (so points on the outer walls are well inside), at the accuracy lookups interpolate
    /// at, `smoothing * accuracy`.
    ///
    /// # Errors
    /// Settings [`RenderSettings::validate`] refuses, or a scene whose bounds are not finite.
    pub fn cache_config(&self, scene: &Scene) -> Result<CacheConfig, SettingsError> {
        self.validate().map_err(SettingsError::Range)?;
        let (lo, hi) = scene.bounds();
        let margin = 0.01 * scene.diagonal();
        CacheConfig::new(lo - margin, hi + margin, self.accuracy * self.smoothing)
            .map_err(SettingsError::Cache)
    }

    /// Panics with `invalid render settings: ...` unless [`RenderSettings::validate`] accepts
    /// these settings and `threads` (0 counts as 1) is within [`limits::THREADS`]: what every
    /// render function does first.
    pub(crate) fn assert_valid(&self, threads: usize) {
        if let Err(e) = self
            .validate()
            .and_then(|()| limits::THREADS.check(threads.max(1)).map(|_| ()))
        {
            panic!("invalid render settings: {e}");
        }
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

/// Why [`RenderSettings::cache_config`] gave no configuration.
#[derive(Clone, Debug, PartialEq)]
pub enum SettingsError {
    /// A setting out of its range.
    Range(OutOfRange),
    /// The cache refused the configuration (a scene whose bounds are not finite).
    Cache(ConfigError),
}

impl fmt::Display for SettingsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Range(e) => e.fmt(f),
            Self::Cache(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for SettingsError {}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field's edges pass and one step beyond fails, naming the field.
    #[test]
    fn validate_admits_every_edge_and_names_the_field_beyond_it() {
        let ok = RenderSettings::new(16, 16);
        assert_eq!(ok.validate(), Ok(()));
        type Edit = fn(&mut RenderSettings, bool);
        let edits: [(&str, Edit); 10] = [
            ("width", |s, out| {
                s.width = if out { 16_385 } else { 16_384 }
            }),
            ("height", |s, out| s.height = if out { 0 } else { 1 }),
            ("accuracy", |s, out| {
                s.accuracy = if out { 2.000_001 } else { 2.0 }
            }),
            ("smoothing", |s, out| {
                s.smoothing = if out { 0.999 } else { 1.0 }
            }),
            ("rays_per_record", |s, out| {
                s.rays_per_record = if out { 65_537 } else { 65_536 }
            }),
            ("light_samples", |s, out| {
                s.light_samples = if out { 0 } else { 4096 }
            }),
            ("pixel_samples", |s, out| {
                s.pixel_samples = if out { 4097 } else { 1 }
            }),
            ("tile_size", |s, out| {
                s.tile_size = if out { 0 } else { 1024 }
            }),
            ("radius in pixels", |s, out| {
                s.max_radius_pixels = if out { f32::NAN } else { 1.0e6 }
            }),
            ("radius in scene", |s, out| {
                s.min_radius_scene = if out { 0.0 } else { 1.0 }
            }),
        ];
        for (field, edit) in edits {
            let mut s = ok.clone();
            edit(&mut s, false);
            assert_eq!(s.validate(), Ok(()), "{field} at its edge");
            edit(&mut s, true);
            assert_eq!(s.validate().unwrap_err().setting, field);
        }
    }

    /// The errors of a cache configuration name the setting or the scene's bounds.
    #[test]
    fn a_settings_error_says_which_setting() {
        let e = SettingsError::Range(RenderSettings::new(0, 4).validate().unwrap_err());
        assert_eq!(e.to_string(), "width 0 is not in [1, 16384]");
        let bad = CacheConfig::new(glam::Vec3::ZERO, glam::Vec3::ZERO, 0.5).unwrap_err();
        assert!(SettingsError::Cache(bad).to_string().contains("bounds"));
        assert_eq!(Pool::Scoped.name(), "threads");
        assert_eq!(Pool::Rayon.name(), "rayon");
    }

    /// The pixel count is bounded beyond each side's, and the smoothing jointly with the
    /// accuracy, both with a message that says which rule.
    #[test]
    fn the_joint_rules_name_both_values() {
        let big = RenderSettings::new(8192, 8193);
        assert_eq!(
            big.validate().unwrap_err().for_option(),
            "--width x --height 8192 x 8193 = 67117056 is not in [1, 67108864]"
        );
        assert_eq!(RenderSettings::new(8192, 8192).validate(), Ok(()));
        let wide = RenderSettings::new(4, 4).accuracy(1.0).smoothing(2.5);
        assert_eq!(
            wide.validate().unwrap_err().to_string(),
            "smoothing 2.5 is not in [1, 2] (smoothing x accuracy at most 2)"
        );
        assert_eq!(
            RenderSettings::new(4, 4)
                .accuracy(1.0)
                .smoothing(2.0)
                .validate(),
            Ok(())
        );
    }
}
