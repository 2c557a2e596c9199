//! Image metrics: an image's error against a reference over the pixels that matter (those that
//! see a non-emitting surface, on the reference's grid), and the masked mean luminance.

use wfic_render::film::Image;
use wfic_render::scene::luminance;
use wfic_render::{RenderSettings, Scene};

/// Which pixels see a non-emitting surface through `settings`' pixel centres and lie on the
/// reference grid, one pixel of each `stride` x `stride` block (`stride` 1: every pixel).
pub fn surface_mask(scene: &Scene, settings: &RenderSettings, stride: u32) -> Vec<bool> {
    let view = scene.camera().view(settings.width, settings.height);
    let mut mask = Vec::with_capacity((settings.width * settings.height) as usize);
    for y in 0..settings.height {
        for x in 0..settings.width {
            let d = view.direction(x as f32 + 0.5, y as f32 + 0.5);
            let on_grid = x % stride == stride / 2 && y % stride == stride / 2;
            mask.push(
                on_grid
                    && scene
                        .intersect(view.eye(), d, f32::INFINITY)
                        .is_some_and(|h| !h.material.is_emissive()),
            );
        }
    }
    mask
}

/// An image's error against a reference over the masked pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImageError {
    /// `sqrt(sum (L - L_ref)^2 / sum L_ref^2)` of luminance.
    pub rel_rmse: f64,
    /// Mean of `|L - L_ref| / L_ref` over the pixels whose `L_ref` is at least 1% of the
    /// masked pixels' mean (darker ones, mostly noise of the reference, would dominate it).
    pub mean_rel: f64,
}

/// [`ImageError`] of `img` against `reference` over the pixels `mask` selects.
pub fn image_error(img: &Image, reference: &Image, mask: &[bool]) -> ImageError {
    let floor = 0.01 * masked_mean(reference, mask);
    let (mut num, mut den, mut rel, mut n) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    for ((a, b), &m) in img.pixels().iter().zip(reference.pixels()).zip(mask) {
        if !m {
            continue;
        }
        let (la, lb) = (f64::from(luminance(*a)), f64::from(luminance(*b)));
        num += (la - lb) * (la - lb);
        den += lb * lb;
        if lb > floor && lb > 0.0 {
            rel += (la - lb).abs() / lb;
            n += 1;
        }
    }
    ImageError {
        rel_rmse: if den > 0.0 { (num / den).sqrt() } else { 0.0 },
        mean_rel: if n > 0 { rel / n as f64 } else { 0.0 },
    }
}

/// Mean luminance over the masked pixels.
pub fn masked_mean(img: &Image, mask: &[bool]) -> f64 {
    let masked = img.pixels().iter().zip(mask).filter(|(_, &m)| m);
    super::stats::mean(masked.map(|(p, _)| f64::from(luminance(*p))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn the_error_is_relative_to_the_reference_and_skips_masked_pixels() {
        let mut a = Image::new(2, 1);
        let mut b = Image::new(2, 1);
        a.set(0, 0, Vec3::splat(1.1));
        b.set(0, 0, Vec3::splat(1.0));
        // The second pixel is far off but masked out.
        a.set(1, 0, Vec3::splat(9.0));
        b.set(1, 0, Vec3::splat(1.0));
        let e = image_error(&a, &b, &[true, false]);
        assert!((e.rel_rmse - 0.1).abs() < 1e-5, "{e:?}");
        assert!((e.mean_rel - 0.1).abs() < 1e-5, "{e:?}");
        let all = image_error(&a, &b, &[true, true]);
        assert!(all.rel_rmse > 1.0, "{all:?}");
        assert!((masked_mean(&a, &[false, true]) - 9.0).abs() < 1e-4);
    }

    #[test]
    fn the_mask_keeps_surfaces_on_the_grid() {
        let scene = wfic_render::scenes::cornell().unwrap();
        let s = RenderSettings::new(8, 8);
        let every = surface_mask(&scene, &s, 1);
        let grid = surface_mask(&scene, &s, 2);
        assert!(every.iter().filter(|&&m| m).count() > 32, "{every:?}");
        // The grid keeps one pixel in four, and only pixels the full mask keeps.
        assert!(grid.iter().zip(&every).all(|(g, e)| !g || *e));
        assert!(grid.iter().filter(|&&m| m).count() <= 16);
        assert!(grid[9] == every[9] && !grid[0]);
    }
}
