//! Deterministic random numbers: a SplitMix64 stream per pixel and purpose.
//!
//! Every pixel's numbers depend only on the frame seed, the pixel's coordinates and a stream
//! number, never on the thread that renders it or the order tiles are taken in, so the same
//! settings give the same samples under every scheme and thread count: schemes are compared on
//! the same samples, and a render can be reproduced.

/// What a stream of random numbers is used for; each gets its own independent sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stream {
    /// Light samples for the direct term at the pixel's primary hit.
    Direct = 1,
    /// Hemisphere directions (and the light samples at their hits) of the pixel's irradiance
    /// estimate, whether it becomes a cache record or (scheme `none`) is used once.
    Hemisphere = 2,
    /// The position of each of the pixel's samples inside the pixel (stratified jitter).
    Position = 3,
}

pub use wfic::rng::{mix64, Rng};

/// The Weyl increment, for deriving stream states.
const STREAM_GAMMA: u64 = 0x9e37_79b9_7f4a_7c15;

/// The stream `stream` of pixel `(x, y)` for frame seed `seed`.
pub fn for_pixel(seed: u64, x: u32, y: u32, stream: Stream) -> Rng {
    let key = mix64(seed ^ mix64((u64::from(y) << 32) | u64::from(x)));
    Rng::new(mix64(key ^ (stream as u64).wrapping_mul(STREAM_GAMMA)))
}

/// The stream `stream` of sample `sample` of pixel `(x, y)`. Sample 0 is the pixel's own
/// stream ([`for_pixel`]), so one sample per pixel draws exactly the pixel's numbers; every other
/// sample gets independent streams.
pub fn for_sample(seed: u64, x: u32, y: u32, sample: u32, stream: Stream) -> Rng {
    let pixel = for_pixel(seed, x, y, stream);
    if sample == 0 {
        return pixel;
    }
    // The pixel's stream state, mixed with the sample number.
    Rng::new(mix64(pixel.state() ^ mix64(u64::from(sample))))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u64> = {
            let mut r = for_pixel(7, 3, 4, Stream::Direct);
            (0..4).map(|_| r.next_u64()).collect()
        };
        let b: Vec<u64> = {
            let mut r = for_pixel(7, 3, 4, Stream::Direct);
            (0..4).map(|_| r.next_u64()).collect()
        };
        assert_eq!(a, b);
        let mut c = for_pixel(7, 3, 4, Stream::Hemisphere);
        let mut d = for_pixel(7, 4, 3, Stream::Direct);
        assert_ne!(a[0], c.next_u64());
        assert_ne!(a[0], d.next_u64());
        let mut e = for_sample(7, 3, 4, 0, Stream::Direct);
        assert_eq!(a[0], e.next_u64(), "sample 0 is the pixel's own stream");
        let mut f = for_sample(7, 3, 4, 1, Stream::Direct);
        let mut g = for_sample(7, 3, 4, 2, Stream::Direct);
        let (f0, g0) = (f.next_u64(), g.next_u64());
        assert!(f0 != a[0] && g0 != a[0] && f0 != g0);
    }
}
