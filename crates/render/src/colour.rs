//! Colour maths shared by the scene, the lights, the film and the OBJ reader: luminance and the
//! sRGB transfer curve. A leaf module (it names no other module of the renderer), so every
//! module that weighs or encodes a colour can use it without depending on another.

use glam::Vec3;

/// Rec. 709 luminance of a linear RGB colour: how bright it looks, for weighing lights by power
/// and for measures over images.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// The linear value of an sRGB-encoded channel, clamped to [0, 1] first: texture colours are
/// stored encoded, and the renderer shades in linear light.
pub fn srgb_to_linear(s: f32) -> f32 {
    let s = s.clamp(0.0, 1.0);
    if s <= 0.040_45 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn luminance_weighs_green_most_and_sums_to_one() {
        assert_eq!(luminance(Vec3::ZERO), 0.0);
        assert!((luminance(Vec3::ONE) - 1.0).abs() < 1e-6);
        assert!(luminance(Vec3::Y) > luminance(Vec3::X));
        assert!(luminance(Vec3::X) > luminance(Vec3::Z));
    }

    #[test]
    fn srgb_decoding_is_continuous_and_clamped() {
        assert_eq!(srgb_to_linear(-1.0), 0.0);
        assert_eq!(srgb_to_linear(2.0), 1.0);
        let (below, above) = (srgb_to_linear(0.040_45), srgb_to_linear(0.040_46));
        assert!((above - below).abs() < 1e-5);
    }
}
