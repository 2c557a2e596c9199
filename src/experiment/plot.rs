//! Small line-and-bar charts drawn straight into an RGB image (no plotting crate, no system font):
//! enough for Figure 1 (time as lines on the left axis, speed-up as bars on the right axis) and
//! Figures 2–3 (time and new samples per frame).

use super::font;
use image::{Rgb, RgbImage};
use std::path::Path;

/// An RGB colour.
pub type Colour = [u8; 3];

/// Colours for the schemes, in [`crate::render::cli::Scheme::ALL`] order where it matters.
pub const PALETTE: [Colour; 7] = [
    [60, 60, 60],    // tra: dark grey
    [214, 39, 40],   // lck: red
    [255, 127, 14],  // lck-rw: orange
    [31, 119, 180],  // lw: blue
    [44, 160, 44],   // wf: green
    [148, 103, 189], // wf-discard: purple
    [140, 86, 75],   // none: brown
];

const WHITE: Colour = [255, 255, 255];
const BLACK: Colour = [0, 0, 0];
const GRID: Colour = [225, 225, 225];
const SHADE: Colour = [244, 236, 220];

/// A polyline with a marker at every point, on the left axis.
#[derive(Clone, Debug)]
pub struct Line {
    /// Legend text.
    pub label: String,
    /// Colour.
    pub colour: Colour,
    /// `(x, y)` points in data units.
    pub points: Vec<(f64, f64)>,
    /// Draw a square at each point.
    pub markers: bool,
}

/// A bar on the right axis, from 0 to `value`, centred on `x`, `width` data units wide.
#[derive(Clone, Debug)]
pub struct Bar {
    /// Centre.
    pub x: f64,
    /// Width in x units.
    pub width: f64,
    /// Height in right-axis units.
    pub value: f64,
    /// Colour (drawn lighter than the lines of the same colour).
    pub colour: Colour,
}

/// One chart: axes, grid, lines (left axis), bars (right axis), shaded x ranges.
#[derive(Clone, Debug, Default)]
pub struct Panel {
    /// Title above the chart.
    pub title: String,
    /// The x range shown.
    pub x_range: (f64, f64),
    /// Tick positions and labels on the x axis (empty: automatic numeric ticks).
    pub x_ticks: Vec<(f64, String)>,
    /// x axis label.
    pub x_label: String,
    /// Left axis label.
    pub left_label: String,
    /// Top of the left axis (`None`: from the lines).
    pub left_max: Option<f64>,
    /// Lines on the left axis.
    pub lines: Vec<Line>,
    /// Right axis label (`None`: no right axis).
    pub right_label: Option<String>,
    /// Bars on the right axis.
    pub bars: Vec<Bar>,
    /// x ranges shaded, with a caption (e.g. oversubscribed thread counts).
    pub shaded: Vec<(f64, f64, String)>,
    /// Legend entries.
    pub legend: Vec<(String, Colour)>,
    /// A note printed under the title.
    pub note: Option<String>,
}

/// A figure: header lines and panels in a grid.
#[derive(Clone, Debug)]
pub struct Figure {
    /// Lines of text at the top (title, machine, oversubscription).
    pub header: Vec<String>,
    /// The panels, row by row.
    pub panels: Vec<Panel>,
    /// Panels per row.
    pub columns: usize,
    /// Size of one panel in pixels.
    pub panel_size: (u32, u32),
}

const SCALE: u32 = 2;
const LINE_H: u32 = (font::HEIGHT + 4) * SCALE;

/// Draws `text` with its top-left corner at `(x, y)`.
pub fn draw_text(img: &mut RgbImage, x: i64, y: i64, text: &str, colour: Colour, scale: u32) {
    let mut cx = x;
    for c in text.chars() {
        let g = font::glyph(c)
            .or_else(|| font::glyph('?'))
            .unwrap_or([0; 7]);
        for (row, bits) in g.iter().enumerate() {
            for col in 0..font::WIDTH {
                if bits & (1 << (font::WIDTH - 1 - col)) != 0 {
                    fill_rect(
                        img,
                        cx + i64::from(col * scale),
                        y + row as i64 * i64::from(scale),
                        i64::from(scale),
                        i64::from(scale),
                        colour,
                    );
                }
            }
        }
        cx += i64::from((font::WIDTH + 1) * scale);
    }
}

/// Fills the rectangle at `(x, y)` of size `w` x `h`, clipped to the image.
pub fn fill_rect(img: &mut RgbImage, x: i64, y: i64, w: i64, h: i64, colour: Colour) {
    let (iw, ih) = (i64::from(img.width()), i64::from(img.height()));
    for py in y.max(0)..(y + h).min(ih) {
        for px in x.max(0)..(x + w).min(iw) {
            img.put_pixel(px as u32, py as u32, Rgb(colour));
        }
    }
}

/// A line `thick` pixels wide from `a` to `b` (Bresenham, a square brush), clipped to the image.
pub fn draw_line(img: &mut RgbImage, a: (i64, i64), b: (i64, i64), colour: Colour, thick: i64) {
    let (mut x, mut y) = a;
    let (dx, dy) = ((b.0 - a.0).abs(), -(b.1 - a.1).abs());
    let (sx, sy) = (
        if a.0 < b.0 { 1 } else { -1 },
        if a.1 < b.1 { 1 } else { -1 },
    );
    let mut err = dx + dy;
    loop {
        fill_rect(img, x - thick / 2, y - thick / 2, thick, thick, colour);
        if (x, y) == b {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

/// About `target` round tick values from 0 to at least `max`: `(step, top)`.
pub fn nice_ticks(max: f64, target: u32) -> (f64, f64) {
    let max = if max.is_finite() && max > 0.0 {
        max
    } else {
        1.0
    };
    let raw = max / f64::from(target.max(1));
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    (step, (max / step).ceil() * step)
}

/// A tick label: as few decimals as the step needs.
pub fn tick_label(v: f64, step: f64) -> String {
    let decimals = (0..6)
        .find(|&d| {
            let scaled = step * 10f64.powi(d);
            (scaled - scaled.round()).abs() < 1e-6 * scaled.max(1.0)
        })
        .unwrap_or(6) as usize;
    format!("{v:.decimals$}")
}

fn lighter(c: Colour) -> Colour {
    c.map(|v| (u16::from(v) + 2 * 255).div_euclid(3) as u8)
}

impl Panel {
    fn draw(&self, img: &mut RgbImage, ox: i64, oy: i64, w: i64, h: i64) {
        let s = i64::from(SCALE);
        let line_h = i64::from(LINE_H);
        let mut top = oy + 8;
        draw_text(img, ox + 10, top, &self.title, BLACK, SCALE);
        top += line_h;
        if let Some(note) = &self.note {
            draw_text(img, ox + 10, top, note, [90, 90, 90], 1);
            top += line_h / 2 + 2;
        }
        // Legend, wrapped.
        let (mut lx, mut ly) = (ox + 10, top);
        for (label, colour) in &self.legend {
            let lw = i64::from(font::text_width(label, SCALE)) + 14 * s;
            if lx + lw > ox + w - 10 {
                lx = ox + 10;
                ly += line_h;
            }
            fill_rect(img, lx, ly + 2 * s, 8 * s / 2, 5 * s / 2 + 1, *colour);
            draw_text(img, lx + 6 * s, ly, label, BLACK, SCALE);
            lx += lw;
        }
        top = ly + line_h + 4;
        let left = ox + 80;
        let right = ox + w - if self.right_label.is_some() { 80 } else { 20 };
        let bottom = oy + h - 60;
        if bottom <= top + 20 || right <= left + 20 {
            return;
        }
        let (x0, x1) = self.x_range;
        let span = if x1 > x0 { x1 - x0 } else { 1.0 };
        let px = |x: f64| left + ((x - x0) / span * (right - left) as f64).round() as i64;

        for (a, b, _) in &self.shaded {
            let (pa, pb) = (px(*a).max(left), px(*b).min(right));
            fill_rect(img, pa, top, pb - pa, bottom - top, SHADE);
        }

        // Left axis.
        let data_max = self
            .lines
            .iter()
            .flat_map(|l| l.points.iter().map(|p| p.1))
            .fold(0.0f64, f64::max);
        let (step, ymax) = nice_ticks(self.left_max.unwrap_or(data_max), 5);
        let py =
            |y: f64| bottom - ((y / ymax).clamp(0.0, 1.0) * (bottom - top) as f64).round() as i64;
        let mut v = 0.0;
        while v <= ymax + step * 1e-9 {
            let y = py(v);
            draw_line(img, (left, y), (right, y), GRID, 1);
            let label = tick_label(v, step);
            let tw = i64::from(font::text_width(&label, SCALE));
            draw_text(img, left - 8 - tw, y - 7, &label, BLACK, SCALE);
            v += step;
        }
        // Axis titles, under the bottom-left and bottom-right corners.
        draw_text(img, left - 70, bottom + 34, &self.left_label, BLACK, 1);

        // Bars on the right axis.
        if let Some(label) = &self.right_label {
            let bmax = self.bars.iter().map(|b| b.value).fold(0.0f64, f64::max);
            let (rstep, rmax) = nice_ticks(bmax, 5);
            let ry = |y: f64| {
                bottom - ((y / rmax).clamp(0.0, 1.0) * (bottom - top) as f64).round() as i64
            };
            for bar in &self.bars {
                let (a, b) = (px(bar.x - bar.width / 2.0), px(bar.x + bar.width / 2.0));
                let y = ry(bar.value);
                fill_rect(img, a, y, (b - a).max(1), bottom - y, lighter(bar.colour));
                draw_line(img, (a, y), (b, y), bar.colour, 1);
            }
            let mut v = 0.0;
            while v <= rmax + rstep * 1e-9 {
                let y = ry(v);
                draw_line(img, (right, y), (right + 5, y), BLACK, 1);
                draw_text(img, right + 8, y - 7, &tick_label(v, rstep), BLACK, SCALE);
                v += rstep;
            }
            let tw = i64::from(font::text_width(label, 1));
            draw_text(img, ox + w - 6 - tw, bottom + 34, label, BLACK, 1);
            draw_line(img, (right, top), (right, bottom), BLACK, 1);
        }

        // x axis.
        let ticks: Vec<(f64, String)> = if self.x_ticks.is_empty() {
            let (mut xs, _) = nice_ticks(span, 8);
            if xs >= 1.0 && xs.fract() != 0.0 {
                // 2.5 is a round step for values, not for frame numbers.
                xs *= 0.8;
            }
            let mut t = Vec::new();
            let mut x = (x0 / xs).ceil() * xs;
            while x <= x1 + xs * 1e-9 {
                t.push((x, tick_label(x, xs)));
                x += xs;
            }
            t
        } else {
            self.x_ticks.clone()
        };
        for (x, label) in &ticks {
            let p = px(*x);
            draw_line(img, (p, bottom), (p, bottom + 5), BLACK, 1);
            let tw = i64::from(font::text_width(label, SCALE));
            draw_text(img, p - tw / 2, bottom + 9, label, BLACK, SCALE);
        }
        let tw = i64::from(font::text_width(&self.x_label, SCALE));
        draw_text(
            img,
            (left + right) / 2 - tw / 2,
            bottom + 32,
            &self.x_label,
            BLACK,
            SCALE,
        );
        draw_line(img, (left, top), (left, bottom), BLACK, 1);
        draw_line(img, (left, bottom), (right, bottom), BLACK, 1);

        // Lines last, over the bars.
        for line in &self.lines {
            let pts: Vec<(i64, i64)> = line.points.iter().map(|&(x, y)| (px(x), py(y))).collect();
            for pair in pts.windows(2) {
                draw_line(img, pair[0], pair[1], line.colour, 2);
            }
            if line.markers {
                for &(x, y) in &pts {
                    fill_rect(img, x - 4, y - 4, 9, 9, line.colour);
                }
            }
        }
        // Captions of the shaded ranges on top of everything, on their own patch of shade, so
        // tall bars do not hide them.
        for (a, _, caption) in &self.shaded {
            let pa = px(*a).max(left);
            let tw = i64::from(font::text_width(caption, 1));
            fill_rect(img, pa + 2, top + 2, tw + 4, 12, SHADE);
            draw_text(img, pa + 4, top + 4, caption, [150, 110, 40], 1);
        }
    }
}

impl Figure {
    /// Renders the figure.
    pub fn render(&self) -> RgbImage {
        let cols = self.columns.max(1);
        let rows = self.panels.len().div_ceil(cols).max(1);
        let (pw, ph) = self.panel_size;
        let header_h = self.header.len() as u32 * LINE_H + 16;
        let mut img =
            RgbImage::from_pixel(pw * cols as u32, header_h + ph * rows as u32, Rgb(WHITE));
        for (i, line) in self.header.iter().enumerate() {
            let colour = if i == 0 { BLACK } else { [120, 40, 20] };
            draw_text(
                &mut img,
                10,
                8 + (i as u32 * LINE_H) as i64,
                line,
                colour,
                SCALE,
            );
        }
        for (i, panel) in self.panels.iter().enumerate() {
            let (c, r) = ((i % cols) as u32, (i / cols) as u32);
            panel.draw(
                &mut img,
                i64::from(c * pw),
                i64::from(header_h + r * ph),
                i64::from(pw),
                i64::from(ph),
            );
        }
        img
    }

    /// Renders the figure and writes it as a PNG.
    pub fn write_png(&self, path: &Path) -> Result<(), String> {
        self.render()
            .save(path)
            .map_err(|e| format!("{}: {e}", path.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_ticks_round_up_to_a_round_step() {
        assert_eq!(nice_ticks(3.2, 5), (1.0, 4.0));
        assert_eq!(nice_ticks(0.47, 5), (0.1, 0.5));
        assert_eq!(nice_ticks(7.0, 5), (2.0, 8.0));
        assert_eq!(nice_ticks(0.0, 5), (0.2, 1.0));
        assert_eq!(tick_label(0.5, 0.1), "0.5");
        assert_eq!(tick_label(2.5, 2.5), "2.5");
        assert_eq!(tick_label(4.0, 1.0), "4");
    }

    #[test]
    fn a_panel_draws_its_lines_bars_and_shading_in_their_colours() {
        let fig = Figure {
            header: vec!["TEST".into(), "2 cores".into()],
            panels: vec![Panel {
                title: "cornell".into(),
                x_range: (0.0, 4.0),
                x_ticks: vec![(1.0, "1".into()), (2.0, "2".into())],
                x_label: "threads".into(),
                left_label: "time (s)".into(),
                lines: vec![Line {
                    label: "wf".into(),
                    colour: [0, 200, 0],
                    points: vec![(1.0, 2.0), (3.0, 1.0)],
                    markers: true,
                }],
                right_label: Some("speed-up".into()),
                bars: vec![Bar {
                    x: 2.0,
                    width: 0.5,
                    value: 1.9,
                    colour: [0, 0, 200],
                }],
                shaded: vec![(3.0, 4.0, "oversubscribed".into())],
                legend: vec![("wf".into(), [0, 200, 0])],
                ..Panel::default()
            }],
            columns: 1,
            panel_size: (500, 400),
        };
        let img = fig.render();
        assert_eq!(img.width(), 500);
        let count = |c: Colour| img.pixels().filter(|p| p.0 == c).count();
        assert!(count([0, 200, 0]) > 50, "line and markers drawn");
        assert!(count(lighter([0, 0, 200])) > 200, "bar drawn");
        assert!(count(SHADE) > 1000, "oversubscribed range shaded");
        assert!(count(BLACK) > 500, "text and axes drawn");
    }
}
