//! The film: an HDR RGB image, written once as a tone-mapped PNG, as a PFM and as a Radiance
//! `.hdr` (RGBE), plus the classic cache visualisation (record positions drawn over the render)
//! and the relative RMSE used to compare schemes.

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

    /// A 64-bit FNV-1a hash of the image's size and every channel's bit pattern, row-major, as 16
    /// hexadecimal digits: two images hash alike when they are bit-identical (and, but for a
    /// collision, only then), so runs can be compared by their statistics.
    pub fn hash(&self) -> String {
        let words = [self.width, self.height].into_iter().chain(
            self.pixels
                .iter()
                .flat_map(|p| p.to_array().map(f32::to_bits)),
        );
        format!("{:016x}", fnv1a(words))
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
    /// `max_luminance` only: with [`crate::Scene::min_emitter_luminance`] it leaves out the
    /// pixels that see an emitter, which otherwise dominate the denominator.
    pub fn relative_rmse_below(&self, reference: &Image, max_luminance: f32) -> Option<f64> {
        if (self.width, self.height) != (reference.width, reference.height) {
            return None;
        }
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for (a, b) in self.pixels.iter().zip(&reference.pixels) {
            if super::colour::luminance(*b) <= max_luminance {
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
            let l = super::colour::luminance(p);
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

    /// Writes the linear image as a Radiance HDR file (`#?RADIANCE`, RLE RGBE, rows top to bottom)
    /// with the `image` crate's encoder, for the HDR tools that do not read PFM.
    ///
    /// RGBE keeps 8 bits of mantissa under an exponent shared by the three channels: each channel
    /// comes back within 1/128 of the pixel's largest channel (truncated, not rounded). What RGBE
    /// cannot hold is clamped first: negative and NaN channels are written as 0, channels above
    /// 1e38 (+inf included) as 1e38, and a pixel whose largest channel is below 1e-38 as black.
    pub fn write_hdr(&self, path: &Path) -> io::Result<()> {
        let rgb: Vec<image::Rgb<f32>> = self.pixels.iter().map(|&p| rgbe_safe(p)).collect();
        let file = std::fs::File::create(path)
            .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
        let mut out = BufWriter::new(file);
        image::codecs::hdr::HdrEncoder::new(&mut out)
            .encode(&rgb, self.width as usize, self.height as usize)
            .map_err(|e| io::Error::other(format!("{}: {e}", path.display())))?;
        out.flush()
    }

    /// Reads a Radiance HDR file (such as one [`Image::write_hdr`] wrote) with the `image`
    /// crate's decoder.
    pub fn read_hdr(path: &Path) -> io::Result<Self> {
        let with_path = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
        let file =
            std::fs::File::open(path).map_err(|e| io::Error::new(e.kind(), with_path(&e)))?;
        let decoded = image::codecs::hdr::HdrDecoder::new(io::BufReader::new(file))
            .and_then(image::DynamicImage::from_decoder)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, with_path(&e)))?
            .into_rgb32f();
        Ok(Self {
            width: decoded.width(),
            height: decoded.height(),
            pixels: decoded.pixels().map(|p| Vec3::from_array(p.0)).collect(),
        })
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

/// `p` within what RGBE can hold (see [`Image::write_hdr`]): the `image` encoder's exponent
/// arithmetic assumes a finite, non-negative pixel whose largest channel is in [2^-127, 2^127).
fn rgbe_safe(p: Vec3) -> image::Rgb<f32> {
    let c = p
        .to_array()
        .map(|c| if c.is_nan() { 0.0 } else { c.clamp(0.0, 1e38) });
    if c.iter().all(|&c| c < 1e-38) {
        image::Rgb([0.0; 3])
    } else {
        image::Rgb(c)
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

/// FNV-1a (64-bit) over the little-endian bytes of `words`.
pub fn fnv1a(words: impl IntoIterator<Item = u32>) -> u64 {
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    words
        .into_iter()
        .flat_map(u32::to_le_bytes)
        .fold(0xcbf2_9ce4_8422_2325, |h, byte| {
            (h ^ u64::from(byte)).wrapping_mul(PRIME)
        })
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

    fn temp_path(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("wfic-film-{}-{name}", std::process::id()))
    }

    #[test]
    fn hdr_round_trip_within_rgbe_precision() {
        // 9 wide, so the encoder takes its run-length path (8 to 32768 pixels a row).
        let mut a = Image::new(9, 3);
        let grey = [0.5, 3.0, 1e4, 1e-3, 0.25, 7.75, 1.0, 123.456, 0.1];
        for (x, g) in grey.into_iter().enumerate() {
            a.set(x as u32, 0, Vec3::splat(g));
            a.set(x as u32, 1, Vec3::new(g, 0.9 * g, 0.8 * g));
            a.set(x as u32, 2, Vec3::new(0.5 * g, 2.0 * g, 0.01 * g));
        }
        a.set(8, 2, Vec3::ZERO);
        let path = temp_path("round.hdr");
        a.write_hdr(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let b = Image::read_hdr(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert!(bytes.starts_with(b"#?RADIANCE\n"), "no Radiance magic");
        assert_eq!((b.width(), b.height()), (9, 3));
        for y in 0..3 {
            for x in 0..9 {
                let (p, q) = (a.get(x, y), b.get(x, y));
                for c in 0..3 {
                    // Each channel within 1/128 of the pixel's largest channel...
                    let err = (p[c] - q[c]).abs();
                    assert!(
                        err <= p.max_element() / 128.0,
                        "({x}, {y}): {p} read as {q}"
                    );
                    // ...and so within 1% of itself where the channels are alike.
                    if y < 2 {
                        assert!(err < 0.01 * p[c], "({x}, {y}) channel {c}: {p} read as {q}");
                    }
                }
            }
        }
        assert_eq!(b.get(8, 2), Vec3::ZERO);
    }

    #[test]
    fn hdr_clamps_what_rgbe_cannot_hold() {
        let mut a = Image::new(4, 1);
        a.set(0, 0, Vec3::new(-1.0, 2.0, f32::NAN));
        a.set(1, 0, Vec3::new(f32::INFINITY, 1.0, 0.0));
        a.set(2, 0, Vec3::splat(1e-40));
        a.set(3, 0, Vec3::splat(f32::NEG_INFINITY));
        let path = temp_path("clamp.hdr");
        a.write_hdr(&path).unwrap();
        let b = Image::read_hdr(&path).unwrap();
        std::fs::remove_file(&path).ok();
        let p = b.get(0, 0);
        assert_eq!((p.x, p.z), (0.0, 0.0), "{p}");
        assert!((p.y - 2.0).abs() < 2.0 / 128.0, "{p}");
        let q = b.get(1, 0);
        assert!(q.x > 9e37 && q.x.is_finite(), "{q}");
        assert_eq!(b.get(2, 0), Vec3::ZERO);
        assert_eq!(b.get(3, 0), Vec3::ZERO);
    }

    #[test]
    fn hdr_errors_name_the_file() {
        let dir = temp_path("no-such-dir");
        let e = Image::new(2, 2).write_hdr(&dir.join("x.hdr")).unwrap_err();
        assert!(e.to_string().contains("no-such-dir"), "{e}");
        let e = Image::read_hdr(&dir.join("x.hdr")).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::NotFound);
        assert!(e.to_string().contains("x.hdr"), "{e}");
        // A PFM is not a Radiance file.
        let pfm = temp_path("not.hdr");
        Image::new(2, 2).write_pfm(&pfm).unwrap();
        let e = Image::read_hdr(&pfm).unwrap_err();
        std::fs::remove_file(&pfm).ok();
        assert_eq!(e.kind(), io::ErrorKind::InvalidData);
        assert!(e.to_string().contains("not.hdr"), "{e}");
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
