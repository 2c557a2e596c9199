//! The film: an HDR RGB image, written once as a tone-mapped PNG and as a PFM, plus the classic
//! cache visualisation (record positions drawn over the render) and the relative RMSE used to
//! compare schemes.

use glam::{Vec2, Vec3};
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// A linear-radiance RGB image, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    width: u32,
    height: u32,
    pixels: Vec<Vec3>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![Vec3::ZERO; width as usize * height as usize],
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Pixel `(x, y)`.
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    /// Sets pixel `(x, y)`.
    pub fn set(&mut self, x: u32, y: u32, v: Vec3) {
        self.pixels[(y * self.width + x) as usize] = v;
    }

    /// All pixels, row-major.
    pub fn pixels(&self) -> &[Vec3] {
        &self.pixels
    }

    /// Mean of the pixels.
    pub fn mean(&self) -> Vec3 {
        self.pixels.iter().copied().sum::<Vec3>() / self.pixels.len().max(1) as f32
    }

    /// Relative RMSE against `reference`: `sqrt(sum |a - b|^2 / sum |b|^2)` over every pixel and
    /// channel (in `f64`). `None` when the sizes differ.
    pub fn relative_rmse(&self, reference: &Image) -> Option<f64> {
        if (self.width, self.height) != (reference.width, reference.height) {
            return None;
        }
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for (a, b) in self.pixels.iter().zip(&reference.pixels) {
            num += f64::from((*a - *b).length_squared());
            den += f64::from(b.length_squared());
        }
        Some(if den > 0.0 {
            (num / den).sqrt()
        } else {
            num.sqrt()
        })
    }

    /// [`Image::relative_rmse`] over the pixels whose reference luminance is at most
    /// `max_luminance` only: with [`crate::render::Scene::min_emitter_luminance`] it leaves out the
    /// pixels that see an emitter, which otherwise dominate the denominator.
    pub fn relative_rmse_below(&self, reference: &Image, max_luminance: f32) -> Option<f64> {
        if (self.width, self.height) != (reference.width, reference.height) {
            return None;
        }
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for (a, b) in self.pixels.iter().zip(&reference.pixels) {
            if super::scene::luminance(*b) <= max_luminance {
                num += f64::from((*a - *b).length_squared());
                den += f64::from(b.length_squared());
            }
        }
        Some(if den > 0.0 {
            (num / den).sqrt()
        } else {
            num.sqrt()
        })
    }

    /// The exposure tone mapping uses: Reinhard's key, mapping the log-average luminance to
    /// 0.22, so large bright emitters in view do not darken the rest of the picture.
    pub fn auto_exposure(&self) -> f32 {
        let (mut sum, mut n) = (0.0f64, 0usize);
        for &p in &self.pixels {
            let l = super::scene::luminance(p);
            if l.is_finite() && l > 0.0 {
                sum += f64::from(l).ln();
                n += 1;
            }
        }
        if n == 0 {
            return 1.0;
        }
        let key = (sum / n as f64).exp() as f32;
        0.22 / key.max(1e-12)
    }

    /// 8-bit sRGB after scaling by `exposure` and clamping, row-major RGB.
    pub fn to_srgb8(&self, exposure: f32) -> Vec<u8> {
        let encode = |c: f32| {
            let c = (c * exposure).clamp(0.0, 1.0);
            let s = if c <= 0.003_130_8 {
                12.92 * c
            } else {
                1.055 * c.powf(1.0 / 2.4) - 0.055
            };
            (s * 255.0 + 0.5) as u8
        };
        self.pixels
            .iter()
            .flat_map(|p| [encode(p.x), encode(p.y), encode(p.z)])
            .collect()
    }

    /// Writes a tone-mapped PNG.
    pub fn write_png(&self, path: &Path, exposure: f32) -> io::Result<()> {
        image::save_buffer(
            path,
            &self.to_srgb8(exposure),
            self.width,
            self.height,
            image::ColorType::Rgb8,
        )
        .map_err(|e| io::Error::other(format!("{}: {e}", path.display())))
    }

    /// Writes the linear image as a little-endian PFM (rows bottom to top, as PFM requires).
    pub fn write_pfm(&self, path: &Path) -> io::Result<()> {
        let mut out = BufWriter::new(std::fs::File::create(path)?);
        write!(out, "PF\n{} {}\n-1.0\n", self.width, self.height)?;
        for y in (0..self.height).rev() {
            for x in 0..self.width {
                for c in self.get(x, y).to_array() {
                    out.write_all(&c.to_le_bytes())?;
                }
            }
        }
        out.flush()
    }

    /// Reads a PFM written by [`Image::write_pfm`] (little-endian RGB).
    pub fn read_pfm(path: &Path) -> io::Result<Self> {
        let bytes = std::fs::read(path)?;
        let bad = |m: &str| {
            io::Error::new(
                io::ErrorKind::InvalidData,
                format!("{}: {m}", path.display()),
            )
        };
        let mut fields = Vec::new();
        let mut at = 0;
        while fields.len() < 4 {
            let start = at;
            while at < bytes.len() && !bytes[at].is_ascii_whitespace() {
                at += 1;
            }
            fields.push(String::from_utf8_lossy(&bytes[start..at]).into_owned());
            at += 1;
        }
        if fields[0] != "PF" || fields[3] != "-1.0" {
            return Err(bad("not a little-endian RGB PFM"));
        }
        let w: u32 = fields[1].parse().map_err(|_| bad("bad width"))?;
        let h: u32 = fields[2].parse().map_err(|_| bad("bad height"))?;
        let need = w as usize * h as usize * 12;
        if bytes.len() < at + need {
            return Err(bad("truncated"));
        }
        let mut img = Image::new(w, h);
        let mut floats = bytes[at..at + need]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]));
        for y in (0..h).rev() {
            for x in 0..w {
                let mut next = || floats.next().unwrap_or(0.0);
                let v = Vec3::new(next(), next(), next());
                img.set(x, y, v);
            }
        }
        Ok(img)
    }

    /// The tone-mapped render, darkened, with a dot at each of `points` (image positions),
    /// coloured by `colour`: Ward's classic picture of where the records are.
    pub fn overlay(&self, exposure: f32, points: &[(Vec2, Vec3)]) -> Vec<u8> {
        let mut rgb: Vec<u8> = self
            .to_srgb8(exposure)
            .into_iter()
            .map(|c| (u16::from(c) * 3 / 5) as u8)
            .collect();
        let (w, h) = (self.width as i64, self.height as i64);
        for &(p, colour) in points {
            let (cx, cy) = (p.x as i64, p.y as i64);
            for dy in -1..=1i64 {
                for dx in -1..=1i64 {
                    let (x, y) = (cx + dx, cy + dy);
                    if (0..w).contains(&x) && (0..h).contains(&y) {
                        let i = ((y * w + x) * 3) as usize;
                        for (c, v) in colour.to_array().into_iter().enumerate() {
                            rgb[i + c] = (v.clamp(0.0, 1.0) * 255.0) as u8;
                        }
                    }
                }
            }
        }
        rgb
    }

    /// Writes [`Image::overlay`] as a PNG.
    pub fn write_overlay_png(
        &self,
        path: &Path,
        exposure: f32,
        points: &[(Vec2, Vec3)],
    ) -> io::Result<()> {
        image::save_buffer(
            path,
            &self.overlay(exposure, points),
            self.width,
            self.height,
            image::ColorType::Rgb8,
        )
        .map_err(|e| io::Error::other(format!("{}: {e}", path.display())))
    }
}

/// A distinct, saturated colour for worker `i` in overlays.
pub fn worker_colour(i: u32) -> Vec3 {
    const PALETTE: [Vec3; 8] = [
        Vec3::new(1.0, 0.2, 0.2),
        Vec3::new(0.2, 1.0, 0.2),
        Vec3::new(0.3, 0.5, 1.0),
        Vec3::new(1.0, 1.0, 0.2),
        Vec3::new(1.0, 0.3, 1.0),
        Vec3::new(0.2, 1.0, 1.0),
        Vec3::new(1.0, 0.6, 0.1),
        Vec3::new(1.0, 1.0, 1.0),
    ];
    PALETTE[(i % 8) as usize]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rmse_of_a_scaled_image() {
        let mut a = Image::new(3, 2);
        for (i, p) in a.pixels.iter_mut().enumerate() {
            *p = Vec3::splat(i as f32 + 1.0);
        }
        let mut b = a.clone();
        b.pixels.iter_mut().for_each(|p| *p *= 1.1);
        assert!((b.relative_rmse(&a).unwrap() - 0.1).abs() < 1e-6);
        assert_eq!(a.relative_rmse(&a), Some(0.0));
        assert_eq!(a.relative_rmse(&Image::new(2, 3)), None);
    }

    #[test]
    fn pfm_round_trip() {
        let mut a = Image::new(4, 3);
        a.set(1, 2, Vec3::new(0.5, 2.0, -1.0));
        a.set(3, 0, Vec3::new(1e5, 0.0, 3.25));
        let path = std::env::temp_dir().join(format!("wfic-film-{}.pfm", std::process::id()));
        a.write_pfm(&path).unwrap();
        let b = Image::read_pfm(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(a, b);
    }

    #[test]
    fn srgb_encoding_endpoints() {
        let mut a = Image::new(2, 1);
        a.set(1, 0, Vec3::splat(10.0));
        assert_eq!(a.to_srgb8(1.0), vec![0, 0, 0, 255, 255, 255]);
        a.set(0, 0, Vec3::splat(0.5));
        assert_eq!(a.to_srgb8(1.0)[0], 188);
    }

    #[test]
    fn overlay_marks_the_records() {
        let mut a = Image::new(8, 8);
        a.pixels.iter_mut().for_each(|p| *p = Vec3::splat(0.5));
        let plain = a.overlay(1.0, &[]);
        let marked = a.overlay(1.0, &[(Vec2::new(4.5, 2.5), Vec3::new(1.0, 0.0, 0.0))]);
        let at = |rgb: &[u8], x: usize, y: usize| [rgb[(y * 8 + x) * 3], rgb[(y * 8 + x) * 3 + 1]];
        assert_eq!(at(&marked, 4, 2), [255, 0]);
        assert_eq!(at(&marked, 5, 3), [255, 0], "a 3 x 3 dot");
        assert_eq!(at(&marked, 0, 7), at(&plain, 0, 7));
        // The render under the dots is darkened, so the dots stand out.
        assert!(plain[0] < a.to_srgb8(1.0)[0]);
    }
}
