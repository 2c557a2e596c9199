//! Line-and-bar charts drawn with `plotters` into PNG and SVG: lines on a left axis, bars on an
//! optional right axis, shaded x ranges. Text is Noto Sans compiled into the binary
//! (`ttf-noto-sans`), so the plots need no system font and no fontconfig.

use image::RgbImage;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::Shift;
use plotters::prelude::{
    BitMapBackend, Cartesian2d, ChartBuilder, ChartContext, Color, DrawingArea, DrawingBackend,
    FontStyle, IntoDrawingArea, IntoFont, LineSeries, PathElement, RGBColor, Rectangle, SVGBackend,
    TextStyle,
};
use plotters::style::register_font;
use std::ops::Range;
use std::sync::OnceLock;

/// An RGB colour (a scheme's is [`wfic::cache::Scheme::colour`]).
pub type Colour = wfic::cache::Rgb8;

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

/// The family name the built-in font is registered under (the SVG names it too, so a viewer
/// without Noto Sans falls back to its own sans-serif).
const FONT: &str = "sans-serif";

// Text sizes in plotters' units (the bitmap backend draws an em of about size / 1.36 pixels,
// the SVG one of size / 1.24).
const HEADER_SIZE: f64 = 26.0;
const TITLE_SIZE: f64 = 26.0;
const TICK_SIZE: f64 = 22.0;
const DESC_SIZE: f64 = 21.0;
const LEGEND_SIZE: f64 = 22.0;
const NOTE_SIZE: f64 = 17.0;
const CAPTION_SIZE: f64 = 18.0;
/// Height of one header line in pixels.
const HEADER_LINE: u32 = 30;

const HEADER_COLOUR: Colour = [120, 40, 20];
const NOTE_COLOUR: Colour = [90, 90, 90];
const CAPTION_COLOUR: Colour = [150, 110, 40];

/// Registers the built-in font (regular and bold) with plotters, once per process.
fn register_fonts() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            for (style, bytes) in [
                (FontStyle::Normal, ttf_noto_sans::REGULAR),
                (FontStyle::Bold, ttf_noto_sans::BOLD),
            ] {
                register_font(FONT, style, bytes)
                    .map_err(|_| format!("the built-in font ({}) does not load", style.as_str()))?;
            }
            Ok(())
        })
        .clone()
}

fn rgb(c: Colour) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

fn text(size: f64, colour: Colour) -> TextStyle<'static> {
    (FONT, size).into_font().color(&rgb(colour))
}

fn err<E: std::fmt::Display>(e: E) -> String {
    format!("plot: {e}")
}

/// About `target` round tick values from 0 to at least `max`: `(step, top)`.
fn nice_ticks(max: f64, target: u32) -> (f64, f64) {
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
fn tick_label(v: f64, step: f64) -> String {
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

/// The pieces of the polyline `points` inside `lo <= y <= hi`: a segment leaving the band is cut
/// where it crosses the edge, so a clipped value shows as a line running off the chart.
fn clip_polyline(points: &[(f64, f64)], lo: f64, hi: f64) -> Vec<Vec<(f64, f64)>> {
    let band = lo..=hi;
    let mut pieces = Vec::new();
    let mut current: Vec<(f64, f64)> = points
        .iter()
        .take(1)
        .filter(|p| band.contains(&p.1))
        .copied()
        .collect();
    for pair in points.windows(2) {
        let ((xa, ya), (xb, yb)) = (pair[0], pair[1]);
        // The part of the segment inside the band, as parameters t0 <= t1 in [0, 1].
        let dy = yb - ya;
        let (t0, t1) = if dy != 0.0 {
            let (ta, tb) = ((lo - ya) / dy, (hi - ya) / dy);
            (0.0f64.max(ta.min(tb)), 1.0f64.min(ta.max(tb)))
        } else if band.contains(&ya) {
            (0.0, 1.0)
        } else {
            (1.0, 0.0)
        };
        if t0 <= t1 {
            let at = |t: f64| (xa + t * (xb - xa), ya + t * dy);
            if current.is_empty() {
                current.push(at(t0));
            }
            current.push(at(t1));
        }
        // The piece ends where the line leaves the band.
        if (t0 > t1 || t1 < 1.0) && !current.is_empty() {
            pieces.push(std::mem::take(&mut current));
        }
    }
    if !current.is_empty() {
        pieces.push(current);
    }
    pieces
}

/// A linear axis from `lo` to `hi` (`lo < hi`) with ticks (and grid lines) exactly at `ticks`.
/// (plotters' `with_key_points` over its own `f64` axis would do, but maps to pixels by floor,
/// not by rounding as these figures always have.)
#[derive(Clone, Debug)]
struct Ticked {
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
}

impl Ticked {
    /// From 0 to `top`, a tick every `step`.
    fn from_zero(step: f64, top: f64) -> Self {
        let ticks = (0..).map(|i| f64::from(i) * step);
        Self {
            lo: 0.0,
            hi: top,
            ticks: ticks.take_while(|v| *v <= top + step * 1e-9).collect(),
        }
    }
}

impl Ranged for Ticked {
    type ValueType = f64;
    type FormatOption = DefaultFormatting;

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let t = (value - self.lo) / (self.hi - self.lo);
        limit.0 + (t * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        // Bold points only: no light grid lines between the ticks.
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }
}

/// Both axes of a panel.
type Axes = Cartesian2d<Ticked, Ticked>;

impl Panel {
    /// The x ticks: the given ones, or round steps over the range.
    fn ticks(&self) -> Vec<(f64, String)> {
        if !self.x_ticks.is_empty() {
            return self.x_ticks.clone();
        }
        let (x0, x1) = self.x_range;
        let span = if x1 > x0 { x1 - x0 } else { 1.0 };
        let (mut step, _) = nice_ticks(span, 8);
        if step >= 1.0 && step.fract() != 0.0 {
            // 2.5 is a round step for values, not for frame numbers.
            step *= 0.8;
        }
        let first = (x0 / step).ceil();
        (0..)
            .map(|i| (first + f64::from(i)) * step)
            .take_while(|x| *x <= x1 + step * 1e-9)
            .map(|x| (x, tick_label(x, step)))
            .collect()
    }

    /// Title, note and legend at the top of `area`; returns the height they take.
    fn draw_heading<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
    ) -> Result<i32, String> {
        let (w, _) = area.dim_in_pixel();
        let right_edge = w as i32 - 12;
        let mut y = 10;
        let title = (FONT, TITLE_SIZE, FontStyle::Bold).into_font();
        area.draw_text(&self.title, &title.color(&rgb(BLACK)), (12, y))
            .map_err(err)?;
        y += 30;
        if let Some(note) = &self.note {
            area.draw_text(note, &text(NOTE_SIZE, NOTE_COLOUR), (12, y))
                .map_err(err)?;
            y += 20;
        }
        if self.legend.is_empty() {
            return Ok(y + 4);
        }
        let style = text(LEGEND_SIZE, BLACK);
        let mut x = 12;
        for (label, colour) in &self.legend {
            let (tw, _) = area.estimate_text_size(label, &style).map_err(err)?;
            let entry = 20 + tw as i32 + 22;
            if x > 12 && x + entry - 22 > right_edge {
                x = 12;
                y += 26;
            }
            area.draw(&Rectangle::new(
                [(x, y + 1), (x + 14, y + 15)],
                rgb(*colour).filled(),
            ))
            .map_err(err)?;
            area.draw_text(label, &style, (x + 20, y)).map_err(err)?;
            x += entry;
        }
        Ok(y + 30)
    }

    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let top = self.draw_heading(area)?;
        let (_, plot_area) = area.split_vertically(top);
        let (x0, x1) = self.x_range;
        let x1 = if x1 > x0 { x1 } else { x0 + 1.0 };
        let ticks = self.ticks();
        let x_axis = Ticked {
            lo: x0,
            hi: x1,
            ticks: ticks.iter().map(|t| t.0).collect(),
        };

        let data_max = self
            .lines
            .iter()
            .flat_map(|l| l.points.iter().map(|p| p.1))
            .fold(0.0f64, f64::max);
        let (step, ymax) = nice_ticks(self.left_max.unwrap_or(data_max), 5);

        // The shaded ranges' captions sit in a tab above the chart, so no bar or line hides them.
        let caption_h = if self.shaded.is_empty() { 0 } else { 26 };
        let mut builder = ChartBuilder::on(&plot_area);
        builder
            .margin_top(4 + caption_h)
            .margin_bottom(6)
            .margin_left(16)
            .margin_right(if self.right_label.is_some() { 16 } else { 30 })
            .x_label_area_size(54)
            .y_label_area_size(90);
        if self.right_label.is_some() {
            builder.right_y_label_area_size(90);
        }
        // The bars' axis is set before anything is drawn: it takes the right label area over
        // from the left axis (which would otherwise label both sides).
        let bmax = self.bars.iter().map(|b| b.value).fold(0.0f64, f64::max);
        let (rstep, rmax) = nice_ticks(bmax, 5);
        let mut chart = builder
            .build_cartesian_2d(x_axis.clone(), Ticked::from_zero(step, ymax))
            .map_err(err)?
            .set_secondary_coord(x_axis, Ticked::from_zero(rstep, rmax));

        chart
            .draw_series(self.shaded.iter().map(|(a, b, _)| {
                Rectangle::new([(a.max(x0), ymax), (b.min(x1), 0.0)], rgb(SHADE).filled())
            }))
            .map_err(err)?;
        let x_label = |x: &f64| {
            ticks
                .iter()
                .find(|t| (t.0 - x).abs() <= 1e-9 * (x1 - x0))
                .map_or_else(|| tick_label(*x, 1.0), |t| t.1.clone())
        };
        let y_label = |v: &f64| tick_label(*v, step);
        chart
            .configure_mesh()
            .disable_x_mesh()
            .bold_line_style(rgb(GRID))
            .axis_style(rgb(BLACK))
            .label_style(text(TICK_SIZE, BLACK))
            .axis_desc_style(text(DESC_SIZE, BLACK))
            .x_desc(self.x_label.as_str())
            .y_desc(self.left_label.as_str())
            .x_label_formatter(&x_label)
            .y_label_formatter(&y_label)
            .draw()
            .map_err(err)?;

        if let Some(label) = &self.right_label {
            let r_label = |v: &f64| tick_label(*v, rstep);
            chart
                .configure_secondary_axes()
                .axis_style(rgb(BLACK))
                .label_style(text(TICK_SIZE, BLACK))
                .axis_desc_style(text(DESC_SIZE, BLACK))
                .y_desc(label.as_str())
                .y_label_formatter(&r_label)
                .draw()
                .map_err(err)?;
            let span = |b: &Bar| (b.x - b.width / 2.0, b.x + b.width / 2.0);
            chart
                .draw_secondary_series(self.bars.iter().map(|b| {
                    let (l, r) = span(b);
                    Rectangle::new([(l, b.value), (r, 0.0)], rgb(lighter(b.colour)).filled())
                }))
                .map_err(err)?;
            chart
                .draw_secondary_series(self.bars.iter().map(|b| {
                    let (l, r) = span(b);
                    PathElement::new(vec![(l, b.value), (r, b.value)], rgb(b.colour))
                }))
                .map_err(err)?;
        }
        self.draw_lines(&mut chart, ymax)?;
        self.draw_captions(area, &chart)
    }

    /// The lines, over everything but the captions, cut at the top of the left axis.
    fn draw_lines<DB: DrawingBackend>(
        &self,
        chart: &mut ChartContext<'_, DB, Axes>,
        ymax: f64,
    ) -> Result<(), String> {
        for line in &self.lines {
            let style = rgb(line.colour).filled().stroke_width(2);
            for piece in clip_polyline(&line.points, 0.0, ymax) {
                chart
                    .draw_series(LineSeries::new(piece, style))
                    .map_err(err)?;
            }
            if line.markers {
                let inside = line.points.iter().filter(|p| (0.0..=ymax).contains(&p.1));
                chart
                    .draw_series(LineSeries::new(inside.copied(), style).point_size(4))
                    .map_err(err)?;
            }
        }
        Ok(())
    }

    /// Each shaded range's caption, in a tab of shade just above the chart where the range starts.
    fn draw_captions<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        chart: &ChartContext<'_, DB, Axes>,
    ) -> Result<(), String> {
        let (bx, by) = area.get_base_pixel();
        let (x0, x1) = self.x_range;
        let y_top = chart.y_range().end;
        let style = text(CAPTION_SIZE, CAPTION_COLOUR);
        for (a, b, caption) in &self.shaded {
            let (l, t) = chart.backend_coord(&(a.max(x0), y_top));
            let (r, _) = chart.backend_coord(&(b.min(x1), y_top));
            let (l, r, t) = (l - bx, r - bx, t - by);
            let (tw, _) = area.estimate_text_size(caption, &style).map_err(err)?;
            let r = r.max(l + tw as i32 + 12);
            area.draw(&Rectangle::new([(l, t - 26), (r, t)], rgb(SHADE).filled()))
                .map_err(err)?;
            area.draw_text(caption, &style, (l + 6, t - 21))
                .map_err(err)?;
        }
        Ok(())
    }
}

impl Figure {
    fn header_height(&self) -> u32 {
        self.header.len() as u32 * HEADER_LINE + 16
    }

    /// Rows and columns of panels.
    fn grid(&self) -> (usize, usize) {
        let cols = self.columns.max(1);
        (self.panels.len().div_ceil(cols).max(1), cols)
    }

    /// The figure's size in pixels.
    pub fn size(&self) -> (u32, u32) {
        let (rows, cols) = self.grid();
        let (pw, ph) = self.panel_size;
        (pw * cols as u32, self.header_height() + ph * rows as u32)
    }

    /// Draws the figure on `backend`, which must be [`Self::size`] large.
    fn paint<DB: DrawingBackend>(&self, backend: DB) -> Result<(), String> {
        register_fonts()?;
        let root = backend.into_drawing_area();
        root.fill(&rgb(WHITE)).map_err(err)?;
        for (i, line) in self.header.iter().enumerate() {
            let colour = if i == 0 { BLACK } else { HEADER_COLOUR };
            let y = 10 + (i as u32 * HEADER_LINE) as i32;
            root.draw_text(line, &text(HEADER_SIZE, colour), (12, y))
                .map_err(err)?;
        }
        let (_, body) = root.split_vertically(self.header_height());
        for (panel, cell) in self.panels.iter().zip(body.split_evenly(self.grid())) {
            panel.draw(&cell)?;
        }
        root.present().map_err(err)
    }

    /// Renders the figure into an RGB image.
    pub fn render(&self) -> Result<RgbImage, String> {
        let (w, h) = self.size();
        let mut buf = vec![0u8; w as usize * h as usize * 3];
        self.paint(BitMapBackend::with_buffer(&mut buf, (w, h)))?;
        RgbImage::from_raw(w, h, buf).ok_or_else(|| "plot: buffer of the wrong size".to_owned())
    }

    /// Renders the figure as an SVG document (text as text, in the viewer's sans-serif).
    pub fn render_svg(&self) -> Result<String, String> {
        let mut svg = String::new();
        self.paint(SVGBackend::with_string(&mut svg, self.size()))?;
        Ok(svg)
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
    fn a_polyline_is_cut_where_it_leaves_the_band() {
        // Inside throughout: one piece, unchanged.
        let pts = [(0.0, 1.0), (1.0, 2.0), (2.0, 1.5)];
        assert_eq!(clip_polyline(&pts, 0.0, 4.0), vec![pts.to_vec()]);
        // Starts above the top (frame 0 clipped): the piece starts where it enters.
        assert_eq!(
            clip_polyline(&[(0.0, 8.0), (1.0, 2.0), (2.0, 2.0)], 0.0, 4.0),
            vec![vec![(2.0 / 3.0, 4.0), (1.0, 2.0), (2.0, 2.0)]]
        );
        // A spike in the middle: two pieces, each ending / starting on the edge.
        assert_eq!(
            clip_polyline(&[(0.0, 2.0), (1.0, 6.0), (2.0, 2.0)], 0.0, 4.0),
            vec![vec![(0.0, 2.0), (0.5, 4.0)], vec![(1.5, 4.0), (2.0, 2.0)]]
        );
        // Entirely outside: nothing.
        assert!(clip_polyline(&[(0.0, 5.0), (1.0, 6.0)], 0.0, 4.0).is_empty());
        assert!(clip_polyline(&[], 0.0, 4.0).is_empty());
    }

    fn test_figure() -> Figure {
        Figure {
            header: vec!["TEST FIGURE".into(), "2 cores".into()],
            panels: vec![Panel {
                title: "cornell".into(),
                x_range: (0.0, 4.0),
                x_ticks: vec![(1.0, "1".into()), (2.0, "2".into()), (3.0, "3*".into())],
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
                shaded: vec![(2.5, 4.0, "oversubscribed".into())],
                legend: vec![("wf-legend".into(), [0, 200, 0])],
                note: Some("a note".into()),
                ..Panel::default()
            }],
            columns: 1,
            panel_size: (500, 400),
        }
    }

    #[test]
    fn a_panel_draws_its_lines_bars_shading_and_text_where_they_belong() {
        let fig = test_figure();
        let img = fig.render().unwrap();
        assert_eq!(
            (img.width(), img.height()),
            (500, 2 * HEADER_LINE + 16 + 400)
        );
        assert_eq!(fig.size(), (img.width(), img.height()));
        let count = |c: Colour| img.pixels().filter(|p| p.0 == c).count();
        assert!(count([0, 0, 200]) > 5, "bar edge drawn");
        assert!(count(lighter([0, 0, 200])) > 1000, "bar drawn");
        assert!(count(SHADE) > 5000, "oversubscribed range shaded");

        // The line runs from x = 1 to x = 3 of 0..4 and falls from 2 to 1: its pixels span the
        // middle half of the chart, and its left end is higher (smaller y) than its right end.
        let green: Vec<(u32, u32)> = img
            .enumerate_pixels()
            .filter(|(_, _, p)| p.0 == [0, 200, 0])
            .map(|(x, y, _)| (x, y))
            .collect();
        let header = 2 * HEADER_LINE + 16;
        let (chart, legend): (Vec<_>, Vec<_>) = green
            .into_iter()
            .partition(|p: &(u32, u32)| p.1 > header + 110);
        assert!(!legend.is_empty(), "legend swatch drawn");
        assert!(chart.len() > 100, "line and markers drawn: {}", chart.len());
        let left = chart.iter().min_by_key(|p| p.0).unwrap();
        let right = chart.iter().max_by_key(|p| p.0).unwrap();
        assert!(left.0 > 100 && left.0 < 250, "{left:?}");
        assert!(right.0 > 280 && right.0 < 420, "{right:?}");
        assert!(left.1 + 40 < right.1, "{left:?} {right:?}");
        // The bar, around x = 2, sits between the line's ends.
        let bar_xs: Vec<u32> = img
            .enumerate_pixels()
            .filter(|(_, _, p)| p.0 == lighter([0, 0, 200]))
            .map(|(x, _, _)| x)
            .collect();
        let (bl, br) = (bar_xs.iter().min().unwrap(), bar_xs.iter().max().unwrap());
        assert!(*bl > left.0 && *br < right.0, "bar {bl}..{br}");

        // Text is drawn from the built-in font: dark pixels in the header band, and the
        // anti-aliasing leaves grey ones too.
        let dark_in_header = img
            .enumerate_pixels()
            .filter(|(_, y, p)| *y < HEADER_LINE && p.0.iter().all(|&v| v < 80))
            .count();
        assert!(dark_in_header > 100, "header text drawn: {dark_in_header}");
        let grey = img
            .pixels()
            .filter(|p| p.0[0] == p.0[1] && p.0[1] == p.0[2] && (100..200).contains(&p.0[0]))
            .count();
        assert!(grey > 100, "anti-aliased text: {grey}");
    }

    #[test]
    fn the_svg_has_the_texts_and_shapes() {
        let svg = test_figure().render_svg().unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..80]);
        assert!(
            svg.contains(r#"width="500" height="476""#),
            "{}",
            &svg[..200]
        );
        for text in [
            "TEST FIGURE",
            "2 cores",
            "cornell",
            "a note",
            "wf-legend",
            "oversubscribed",
            "threads",
            "time (s)",
            "speed-up",
            "3*",
        ] {
            assert!(
                svg.contains(&format!(">\n{text}\n</text>")),
                "{text} missing"
            );
        }
        assert!(svg.contains("#F4ECDC"), "shade rectangle");
        assert!(svg.contains("#00C800"), "line colour");
        assert!(svg.contains(r#"font-family="sans-serif""#));
    }

    #[test]
    fn a_figure_without_right_axis_or_data_still_renders() {
        let fig = Figure {
            header: vec![],
            panels: vec![Panel::default(), Panel::default()],
            columns: 2,
            panel_size: (300, 200),
        };
        let img = fig.render().unwrap();
        assert_eq!((img.width(), img.height()), (600, 216));
        fig.render_svg().unwrap();
    }
}
