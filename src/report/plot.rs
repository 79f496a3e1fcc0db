//! Speed-against-error scatter plots as PNG, drawn with `plotters` into an RGB bitmap: axes (log10
//! where the values span more than a decade and are all positive), one colour per series, a label
//! beside each point, and the Pareto front drawn as a staircase through its points (ringed).
//! Text goes through plotters' `ab_glyph` font support with the DejaVu Sans Mono font committed in
//! assets/fonts (its licence beside it), so no system font is read.

use plotters::backend::BitMapBackend;
use plotters::coord::Shift;
use plotters::prelude::{
    Circle, DrawingArea, IntoDrawingArea, IntoFont, PathElement, RGBColor, Rectangle, ShapeStyle, Text,
};
use plotters::style::{FontStyle, TextStyle};

use super::pareto;

const FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSansMono.ttf");
/// The name the font is registered under with plotters.
const FONT: &str = "hadou-report-mono";
const WIDTH: u32 = 1000;
const HEIGHT: u32 = 600;
const LEFT: f64 = 90.0;
const RIGHT: f64 = 300.0;
/// The legend's left edge: right of the room point labels may spill into.
const LEGEND_X: f64 = WIDTH as f64 - 170.0;
const TOP: f64 = 60.0;
const BOTTOM: f64 = 70.0;
const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(23, 190, 207),
];
const FRONT: RGBColor = RGBColor(200, 30, 30);
const INK: RGBColor = RGBColor(30, 30, 30);
const GRID: RGBColor = RGBColor(225, 225, 225);
const PAPER: RGBColor = RGBColor(255, 255, 255);

#[derive(Clone, Debug, PartialEq)]
pub struct PlotPoint {
    pub label: String,
    pub x: f64,
    pub y: f64,
    /// Index into `Plot::series`.
    pub series: usize,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Plot {
    /// File stem: `<id>.png`.
    pub id: String,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<String>,
    pub points: Vec<PlotPoint>,
}

/// One axis: data range → pixel range, linear or log10.
struct Axis {
    log: bool,
    lo: f64,
    hi: f64,
}

impl Axis {
    fn fit(values: &[f64]) -> Axis {
        let v: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let (min, max) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
        if v.is_empty() {
            return Axis { log: false, lo: 0.0, hi: 1.0 };
        }
        if min > 0.0 && max / min > 10.0 {
            return Axis {
                log: true,
                lo: min.log10().floor(),
                hi: max.log10().ceil().max(min.log10().floor() + 1.0),
            };
        }
        let (lo, hi) = if max > min {
            (min, max)
        } else {
            (min - 0.5 * min.abs().max(1.0), max + 0.5 * max.abs().max(1.0))
        };
        let pad = 0.08 * (hi - lo);
        Axis { log: false, lo: if lo >= 0.0 { (lo - pad).max(0.0) } else { lo - pad }, hi: hi + pad }
    }

    /// 0..1 along the axis.
    fn unit(&self, v: f64) -> f64 {
        let v = if self.log { v.max(1e-300).log10() } else { v };
        (v - self.lo) / (self.hi - self.lo)
    }

    /// (value, label) tick marks.
    fn ticks(&self) -> Vec<(f64, String)> {
        if self.log {
            let decades = (self.hi - self.lo).round() as i32;
            let mut out = Vec::new();
            for e in self.lo as i32..=self.hi as i32 {
                let steps: &[f64] = if decades <= 2 { &[1.0, 2.0, 5.0] } else { &[1.0] };
                for &m in steps {
                    let v = m * 10f64.powi(e);
                    if v.log10() <= self.hi + 1e-9 {
                        out.push((v, format!("{v:.0e}")));
                    }
                }
            }
            return out;
        }
        let raw = (self.hi - self.lo) / 6.0;
        let mag = 10f64.powf(raw.log10().floor());
        let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag);
        let mut out = Vec::new();
        let mut v = (self.lo / step).ceil() * step;
        while v <= self.hi + 1e-9 * step {
            let decimals = (-step.log10().floor()).max(0.0) as usize;
            out.push((v, format!("{v:.decimals$}")));
            v += step;
        }
        out
    }
}

/// The plot area in pixels and the two axes: data → pixel.
struct Frame {
    ax: Axis,
    ay: Axis,
    w: f64,
    h: f64,
}

impl Frame {
    fn fit(plot: &Plot) -> Frame {
        let xs: Vec<f64> = plot.points.iter().map(|p| p.x).collect();
        let ys: Vec<f64> = plot.points.iter().map(|p| p.y).collect();
        let (w, h) = (WIDTH as f64 - LEFT - RIGHT, HEIGHT as f64 - TOP - BOTTOM);
        Frame { ax: Axis::fit(&xs), ay: Axis::fit(&ys), w, h }
    }

    fn to_px(&self, x: f64, y: f64) -> (f64, f64) {
        (LEFT + self.ax.unit(x) * self.w, TOP + (1.0 - self.ay.unit(y)) * self.h)
    }
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
type Drawn = Result<(), String>;

fn px(p: (f64, f64)) -> (i32, i32) {
    (p.0.round() as i32, p.1.round() as i32)
}

fn style(px: f64) -> TextStyle<'static> {
    (FONT, px).into_font().color(&INK)
}

fn width(area: &Area, text: &str, size: f64) -> f64 {
    area.estimate_text_size(text, &style(size)).map_or(0.0, |(w, _)| w as f64)
}

/// Text with its top-left corner (the top of a capital) at (x, y). plotters' ab_glyph text puts
/// the baseline half an em below the position it is given; DejaVu's capitals rise 0.73 em above
/// the baseline, so the position is moved down by 0.73 − 0.5 of the size.
fn text(area: &Area, x: f64, y: f64, s: &str, size: f64) -> Drawn {
    let at = px((x, y + 0.23 * size));
    area.draw(&Text::new(s.to_string(), at, style(size))).map_err(|e| e.to_string())
}

fn line(area: &Area, a: (f64, f64), b: (f64, f64), stroke: u32, c: RGBColor) -> Drawn {
    let s = ShapeStyle { color: c.into(), filled: false, stroke_width: stroke };
    area.draw(&PathElement::new(vec![px(a), px(b)], s)).map_err(|e| e.to_string())
}

fn rect(area: &Area, a: (f64, f64), b: (f64, f64), c: RGBColor) -> Drawn {
    let s = ShapeStyle { color: c.into(), filled: true, stroke_width: 0 };
    area.draw(&Rectangle::new([px(a), px(b)], s)).map_err(|e| e.to_string())
}

/// A disc (`ring` false) or a ring 2 px wide.
fn dot(area: &Area, at: (f64, f64), r: f64, ring: bool, c: RGBColor) -> Drawn {
    let s = ShapeStyle { color: c.into(), filled: !ring, stroke_width: if ring { 2 } else { 0 } };
    area.draw(&Circle::new(px(at), r.round() as i32, s)).map_err(|e| e.to_string())
}

/// Registers the committed font with plotters once per process.
fn register_font() -> Drawn {
    static REGISTERED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *REGISTERED
        .get_or_init(|| plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok());
    if ok {
        Ok(())
    } else {
        Err("the committed font assets/fonts/DejaVuSansMono.ttf does not parse".into())
    }
}

/// The plot as RGBA8 pixels (WIDTH × HEIGHT, row 0 at the top).
pub fn render(plot: &Plot) -> Result<(u32, u32, Vec<u8>), String> {
    register_font()?;
    let mut rgb = vec![0u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let area = BitMapBackend::with_buffer(&mut rgb, (WIDTH, HEIGHT)).into_drawing_area();
        area.fill(&PAPER).map_err(|e| e.to_string())?;
        draw(&area, plot)?;
        area.present().map_err(|e| e.to_string())?;
    }
    let rgba = rgb.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect();
    Ok((WIDTH, HEIGHT, rgba))
}

fn draw(area: &Area, plot: &Plot) -> Drawn {
    let f = Frame::fit(plot);
    let (ax, ay, w, h) = (&f.ax, &f.ay, f.w, f.h);
    text(area, LEFT, 12.0, &plot.title, 18.0)?;
    for (v, label) in ax.ticks() {
        let x = LEFT + ax.unit(v) * w;
        line(area, (x, TOP), (x, TOP + h), 1, GRID)?;
        text(area, x - width(area, &label, 13.0) / 2.0, TOP + h + 6.0, &label, 13.0)?;
    }
    for (v, label) in ay.ticks() {
        let y = TOP + (1.0 - ay.unit(v)) * h;
        line(area, (LEFT, y), (LEFT + w, y), 1, GRID)?;
        text(area, LEFT - width(area, &label, 13.0) - 6.0, y - 8.0, &label, 13.0)?;
    }
    rect(area, (LEFT, TOP + h), (LEFT + w, TOP + h + 2.0), INK)?;
    rect(area, (LEFT - 2.0, TOP), (LEFT, TOP + h), INK)?;
    let scale = |a: &Axis| if a.log { " (log scale)" } else { "" };
    let xl = format!("{}{}", plot.x_label, scale(ax));
    text(area, LEFT + (w - width(area, &xl, 14.0)) / 2.0, TOP + h + 30.0, &xl, 14.0)?;
    text(area, LEFT - 80.0, TOP - 22.0, &format!("{}{}", plot.y_label, scale(ay)), 14.0)?;

    let pts: Vec<(f64, f64)> = plot.points.iter().map(|p| (p.x, p.y)).collect();
    let front = pareto::front(&pts);
    for pair in front.windows(2) {
        let (a, b) = (f.to_px(pts[pair[0]].0, pts[pair[0]].1), f.to_px(pts[pair[1]].0, pts[pair[1]].1));
        line(area, a, (b.0, a.1), 2, FRONT)?;
        line(area, (b.0, a.1), b, 2, FRONT)?;
    }
    // Labels right of their points, moved up or down past labels already placed (points that
    // nearly coincide would print over each other).
    let mut placed: Vec<(f64, f64, f64, f64)> = Vec::new();
    for (i, p) in plot.points.iter().enumerate() {
        if !(p.x.is_finite() && p.y.is_finite()) {
            continue;
        }
        let at = f.to_px(p.x, p.y);
        dot(area, at, 4.5, false, PALETTE[p.series % PALETTE.len()])?;
        if front.contains(&i) {
            dot(area, at, 8.0, true, FRONT)?;
        }
        let tw = width(area, &p.label, 12.0);
        let overlaps = |y: f64| {
            placed.iter().any(|r| at.0 + 9.0 < r.2 && r.0 < at.0 + 9.0 + tw && y < r.3 && r.1 < y + 14.0)
        };
        let y = [-16.0, 2.0, -32.0, 18.0, -48.0, 34.0, -64.0, 50.0]
            .iter()
            .map(|dy| at.1 + dy)
            .find(|&y| !overlaps(y))
            .unwrap_or(at.1 - 16.0);
        placed.push((at.0 + 9.0, y, at.0 + 9.0 + tw, y + 14.0));
        text(area, at.0 + 9.0, y, &p.label, 12.0)?;
    }
    let lx = LEGEND_X;
    let mut ly = TOP;
    for (k, name) in plot.series.iter().enumerate() {
        dot(area, (lx + 6.0, ly + 8.0), 4.5, false, PALETTE[k % PALETTE.len()])?;
        text(area, lx + 18.0, ly, name, 13.0)?;
        ly += 22.0;
    }
    dot(area, (lx + 6.0, ly + 8.0), 8.0, true, FRONT)?;
    text(area, lx + 18.0, ly, "Pareto front", 13.0)?;
    let unplotted = plot.points.iter().filter(|p| !(p.x.is_finite() && p.y.is_finite())).count();
    if unplotted > 0 {
        text(area, lx, ly + 24.0, &format!("{unplotted} non-finite not drawn"), 12.0)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_pick_log_only_for_wide_positive_ranges() {
        let a = Axis::fit(&[1e-7, 2.0]);
        assert!(a.log && a.lo == -7.0 && a.hi == 1.0);
        assert!((a.unit(1e-3) - 0.5).abs() < 1e-12);
        assert!(!Axis::fit(&[0.0, 5.0]).log);
        assert!(!Axis::fit(&[2.0, 3.0]).log);
        let one = Axis::fit(&[4.0]);
        assert!(one.lo < 4.0 && one.hi > 4.0);
        assert!(Axis::fit(&[1.0, 100.0]).ticks().len() >= 3);
        assert!(Axis::fit(&[0.0, 7.0]).ticks().iter().any(|(v, _)| *v == 2.0));
    }

    /// The PNG decodes at WIDTH × HEIGHT; every series-coloured pixel lies on a data point's disc or
    /// a legend dot (so points are drawn where their data is, nowhere else); each point's centre
    /// has its series' colour, each front point its ring; an empty corner is paper.
    #[test]
    fn png_has_the_size_and_pixels_where_the_data_is() {
        let plot = Plot {
            id: "p".into(),
            title: "t".into(),
            x_label: "ms".into(),
            y_label: "err".into(),
            series: vec!["a".into(), "b".into()],
            points: vec![
                PlotPoint { label: "fast".into(), x: 1.0, y: 1.0, series: 0 },
                PlotPoint { label: "mid".into(), x: 10.0, y: 3.0, series: 0 },
                PlotPoint { label: "slow".into(), x: 100.0, y: 1e-6, series: 1 },
                PlotPoint { label: "nan".into(), x: f64::NAN, y: 1.0, series: 1 },
            ],
        };
        let (w, h, rgba) = render(&plot).unwrap();
        let png = hadou::output::encode_png("p.png".as_ref(), w, h, &rgba).unwrap();
        let img = image::load_from_memory(&png).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (WIDTH, HEIGHT));
        let rgb = |c: RGBColor| image::Rgb([c.0, c.1, c.2]);
        let f = Frame::fit(&plot);
        let centres: Vec<(f64, f64)> = plot.points[..3].iter().map(|p| f.to_px(p.x, p.y)).collect();
        let legend: Vec<(f64, f64)> = (0..2).map(|k| (LEGEND_X + 6.0, TOP + 8.0 + 22.0 * k as f64)).collect();
        for (x, y, c) in img.enumerate_pixels() {
            if PALETTE[..2].iter().any(|p| rgb(*p) == *c) {
                // The disc's radius 4.5 rounds to 5: a pixel centre lies within 5 + ½√2 of it.
                let near = |p: &(f64, f64)| (x as f64 - p.0).hypot(y as f64 - p.1) <= 5.8;
                assert!(centres.iter().chain(&legend).any(near), "series colour at ({x}, {y})");
            }
        }
        for (p, at) in plot.points.iter().zip(&centres) {
            let (x, y) = (at.0.round() as u32, at.1.round() as u32);
            assert_eq!(*img.get_pixel(x, y), rgb(PALETTE[p.series]), "{}", p.label);
        }
        // "fast" and "slow" are on the front, "mid" (slower and worse than "fast") is not. Rings are
        // looked for away from the staircase: above "fast" (it leaves rightwards), left of "slow"
        // (it arrives from above).
        let ring = |at: &(f64, f64), (dx, dy): (f64, f64)| {
            (0..16).any(|k| {
                let d = 4.0 + 0.5 * k as f64;
                *img.get_pixel((at.0 + d * dx).round() as u32, (at.1 + d * dy).round() as u32) == rgb(FRONT)
            })
        };
        let (up, left) = ((0.0, -1.0), (-1.0, 0.0));
        assert!(ring(&centres[0], up) && ring(&centres[2], left));
        assert!(!ring(&centres[1], up) && !ring(&centres[1], left));
        assert_eq!(*img.get_pixel(WIDTH - 5, HEIGHT - 5), rgb(PAPER));
    }
}
