//! The ranges the renderer's numbers may take, each written once: the fields of
//! [`RenderSettings`](crate::RenderSettings) (which [`RenderSettings::validate`] checks), the
//! thread and frame counts the render functions take, and the MPI exchange's batches. The `wfic`
//! command line parses its options against these same [`Limit`]s and prints them in `--help`.
//!
//! The bounds are of two kinds. Some are where a value stops making sense (an accuracy above
//! [`CacheConfig::MAX_ACCURACY`], a sample count of 0). The others are resources, set so that a
//! value inside them cannot exhaust the machine before the run starts: every thread started at
//! once, a framebuffer of every pixel, a record's hemisphere of rays held per worker.
//!
//! [`RenderSettings::validate`]: crate::RenderSettings::validate

use std::fmt;
use wfic::cache::CacheConfig;

/// An interval a numeric setting must lie in: `[min, max]`, or `(min, max]` when `open_min`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limit<T> {
    /// The setting's name in the library (a [`RenderSettings`](crate::RenderSettings) field or a
    /// render function's argument).
    pub setting: &'static str,
    /// The `wfic` option that sets it, if one does.
    pub option: Option<&'static str>,
    /// The least value (excluded when `open_min`).
    pub min: T,
    /// The greatest value.
    pub max: T,
    /// `min` itself is outside the range.
    pub open_min: bool,
}

impl<T: Copy + PartialOrd + fmt::Display> Limit<T> {
    /// `[min, max]`.
    pub const fn closed(setting: &'static str, option: &'static str, min: T, max: T) -> Self {
        Self {
            setting,
            option: Some(option),
            min,
            max,
            open_min: false,
        }
    }

    /// `(min, max]`.
    pub const fn open_min(setting: &'static str, option: &'static str, min: T, max: T) -> Self {
        Self {
            setting,
            option: Some(option),
            min,
            max,
            open_min: true,
        }
    }

    /// The same range for a setting no option sets.
    pub const fn library_only(self) -> Self {
        Self {
            option: None,
            ..self
        }
    }

    /// Whether `value` lies in the range (NaN never does).
    pub fn contains(&self, value: T) -> bool {
        let above = if self.open_min {
            value > self.min
        } else {
            value >= self.min
        };
        above && value <= self.max
    }

    /// `value`, or the error naming the setting, the value and the range.
    ///
    /// # Errors
    /// [`OutOfRange`] when `value` is outside.
    pub fn check(&self, value: T) -> Result<T, OutOfRange> {
        if self.contains(value) {
            Ok(value)
        } else {
            Err(OutOfRange {
                setting: self.setting,
                option: self.option,
                value: value.to_string(),
                range: self.range(),
            })
        }
    }

    /// The range in interval notation: `[1, 4096]`, `(0, 2]`.
    pub fn range(&self) -> String {
        let open = if self.open_min { '(' } else { '[' };
        format!("{open}{}, {}]", self.min, self.max)
    }
}

/// A value outside its [`Limit`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutOfRange {
    /// The setting's name in the library.
    pub setting: &'static str,
    /// The option that sets it, if one does.
    pub option: Option<&'static str>,
    /// The value refused, as written.
    pub value: String,
    /// The range it had to lie in, with any rule that joins it to another setting.
    pub range: String,
}

impl OutOfRange {
    /// The message as the command line gives it: the option's name instead of the field's.
    pub fn for_option(&self) -> String {
        format!(
            "{} {} is not in {}",
            self.option.unwrap_or(self.setting),
            self.value,
            self.range
        )
    }
}

impl fmt::Display for OutOfRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {} is not in {}",
            self.setting, self.value, self.range
        )
    }
}

impl std::error::Error for OutOfRange {}

/// Image width in pixels.
pub const WIDTH: Limit<u32> = Limit::closed("width", "--width", 1, 16_384);
/// Image height in pixels.
pub const HEIGHT: Limit<u32> = Limit::closed("height", "--height", 1, 16_384);
/// Pixels of a frame, `width x height`: 2^26, an 8192 x 8192 image (8K video frames fit). A
/// frame holds its linear image, each worker's tile results and the PNG, HDR and overlay
/// encodings at once: [`frame_bytes`].
pub const PIXELS: Limit<u64> = Limit::closed("width x height", "--width x --height", 1, 1 << 26);
/// Ward's accuracy `a`: what [`CacheConfig::new`] takes.
pub const ACCURACY: Limit<f32> =
    Limit::open_min("accuracy", "--accuracy", 0.0, CacheConfig::MAX_ACCURACY);
/// The smoothing `k`; also `k x accuracy` may not exceed [`CacheConfig::MAX_ACCURACY`], the
/// accuracy lookups interpolate at.
pub const SMOOTHING: Limit<f32> = Limit::closed("smoothing", "--smoothing", 1.0, 64.0);
/// Hemisphere rays per record: each worker holds one record's rays (12 bytes a ray) at a time.
/// Radiance users raise `-ad` to a few thousand.
pub const RAYS_PER_RECORD: Limit<u32> =
    Limit::closed("rays_per_record", "--rays-per-record", 1, 65_536);
/// Light samples per primary hit.
pub const LIGHT_SAMPLES: Limit<u32> = Limit::closed("light_samples", "--light-samples", 1, 4096);
/// Primary rays per pixel.
pub const PIXEL_SAMPLES: Limit<u32> = Limit::closed("pixel_samples", "--spp", 1, 4096);
/// Side of a tile in pixels.
pub const TILE_SIZE: Limit<u32> = Limit::closed("tile_size", "", 1, 1024).library_only();
/// The radius clamps in pixel footprints.
pub const RADIUS_PIXELS: Limit<f32> =
    Limit::open_min("radius in pixels", "", 0.0, 1.0e6).library_only();
/// The radius clamps as fractions of the scene's diagonal.
pub const RADIUS_SCENE: Limit<f32> =
    Limit::open_min("radius in scene", "", 0.0, 1.0).library_only();
/// Worker threads of one process: all of them run at once, so all of them must start (see
/// `Frame::run` in the cache). Far below what a machine holds, far above its cores.
pub const THREADS: Limit<usize> = Limit::closed("threads", "--threads", 1, 1024);
/// Frames of one run (an orbit, an animation).
pub const FRAMES: Limit<usize> = Limit::closed("frames", "--frames", 1, 100_000);
/// The orbit camera's time in turns.
pub const ORBIT: Limit<f32> = Limit::closed("orbit time", "--orbit", -1000.0, 1000.0);
/// Each coordinate of a camera position or target, in scene units (the built-in scenes span a
/// few to a few tens of units).
pub const COORDINATE: Limit<f32> = Limit::closed("coordinate", "--eye/--target", -1.0e6, 1.0e6);
/// The seed of the random streams: any 64-bit value.
pub const SEED: Limit<u64> = Limit::closed("seed", "--seed", 0, u64::MAX);
/// Records a rank gathers before an exchange round (its send buffer holds as many).
pub const BATCH_RECORDS: Limit<usize> =
    Limit::closed("batch_records", "--batch-records", 1, 1 << 20);
/// Milliseconds between a rank's exchange rounds at most, up to an hour (`reproduce
/// distributed`'s batch sweep sets ten minutes, a timer that never fires in a frame).
pub const BATCH_MS: Limit<u64> = Limit::closed("batch_ms", "--batch-ms", 0, 3_600_000);

/// Bytes a frame of `width x height` holds at its peak, whatever the scheme: the linear image
/// and the workers' tile results (a colour each, 12 bytes a pixel apiece), then the tone-mapped
/// PNG, the record overlay and the HDR file's encoding. The command line refuses a size whose
/// frame would not fit the memory the machine has free.
pub fn frame_bytes(width: u32, height: u32) -> u64 {
    u64::from(width) * u64::from(height) * FRAME_BYTES_PER_PIXEL
}

/// What [`frame_bytes`] counts a pixel: `wfic render`'s peak resident memory grows by 36-37
/// bytes a pixel from 512 x 512 to 4096 x 4096 (`/usr/bin/time`'s maximum), and 48 leaves a
/// margin.
const FRAME_BYTES_PER_PIXEL: u64 = 48;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_range_admits_its_edges_and_refuses_beyond_them_and_nan() {
        assert!(WIDTH.contains(1) && WIDTH.contains(16_384));
        assert!(!WIDTH.contains(0) && !WIDTH.contains(16_385));
        assert!(ACCURACY.contains(2.0) && ACCURACY.contains(f32::MIN_POSITIVE));
        for bad in [
            0.0,
            -0.0,
            2.000_001,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ] {
            assert!(!ACCURACY.contains(bad), "{bad}");
        }
        assert!(SEED.contains(0) && SEED.contains(u64::MAX));
    }

    #[test]
    fn a_frame_counts_48_bytes_a_pixel() {
        assert_eq!(frame_bytes(8192, 8192), 3 << 30);
        assert_eq!(frame_bytes(1, 1), 48);
        assert_eq!(frame_bytes(16_384, 1), 48 * 16_384);
    }

    #[test]
    fn an_error_names_the_setting_or_the_option_the_value_and_the_range() {
        let e = PIXEL_SAMPLES.check(0).unwrap_err();
        assert_eq!(e.to_string(), "pixel_samples 0 is not in [1, 4096]");
        assert_eq!(e.for_option(), "--spp 0 is not in [1, 4096]");
        let e = ACCURACY.check(f32::NAN).unwrap_err();
        assert_eq!(e.for_option(), "--accuracy NaN is not in (0, 2]");
        let e = TILE_SIZE.check(0).unwrap_err();
        assert_eq!(e.for_option(), "tile_size 0 is not in [1, 1024]");
    }
}
