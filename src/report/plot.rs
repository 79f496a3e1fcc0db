//! Speed-against-error scatter plots as PNG, drawn into an RGBA buffer: axes (log10 where the
//! values span more than a decade and are all positive), one colour per series, a
//! label beside each point, and the Pareto front drawn as a staircase through its points (ringed).
//! Text uses the DejaVu Sans Mono font committed in assets/fonts (its licence beside it), so no
//! system font is read.

use ab_glyph::{Font, FontRef, PxScale, ScaleFont};

use super::pareto;

const FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSansMono.ttf");
const WIDTH: u32 = 1000;
const HEIGHT: u32 = 600;
const LEFT: f64 = 90.0;
const RIGHT: f64 = 300.0;
/// The legend's left edge: right of the room point labels may spill into.
const LEGEND_X: f64 = WIDTH as f64 - 170.0;
const TOP: f64 = 60.0;
const BOTTOM: f64 = 70.0;
const PALETTE: [[u8; 3]; 6] =
    [[31, 119, 180], [255, 127, 14], [44, 160, 44], [148, 103, 189], [140, 86, 75], [23, 190, 207]];
const FRONT: [u8; 3] = [200, 30, 30];
const INK: [u8; 3] = [30, 30, 30];
const GRID: [u8; 3] = [225, 225, 225];

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

struct Canvas {
    rgba: Vec<u8>,
    font: FontRef<'static>,
}

impl Canvas {
    fn blend(&mut self, x: i64, y: i64, c: [u8; 3], a: f32) {
        if x < 0 || y < 0 || x >= WIDTH as i64 || y >= HEIGHT as i64 {
            return;
        }
        let i = ((y as u32 * WIDTH + x as u32) * 4) as usize;
        for (dst, &src) in self.rgba[i..i + 3].iter_mut().zip(&c) {
            let old = *dst as f32;
            *dst = (old + (src as f32 - old) * a.clamp(0.0, 1.0)).round() as u8;
        }
    }

    fn rect(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, c: [u8; 3]) {
        for y in y0.round() as i64..y1.round() as i64 {
            for x in x0.round() as i64..x1.round() as i64 {
                self.blend(x, y, c, 1.0);
            }
        }
    }

    /// A line `width` pixels wide (distance test around the segment).
    fn line(&mut self, a: (f64, f64), b: (f64, f64), width: f64, c: [u8; 3]) {
        let (x0, x1) = (a.0.min(b.0) - width, a.0.max(b.0) + width);
        let (y0, y1) = (a.1.min(b.1) - width, a.1.max(b.1) + width);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len2 = (dx * dx + dy * dy).max(1e-12);
        for y in y0.floor() as i64..=y1.ceil() as i64 {
            for x in x0.floor() as i64..=x1.ceil() as i64 {
                let (px, py) = (x as f64 + 0.5 - a.0, y as f64 + 0.5 - a.1);
                let t = ((px * dx + py * dy) / len2).clamp(0.0, 1.0);
                let d = ((px - t * dx).powi(2) + (py - t * dy).powi(2)).sqrt();
                self.blend(x, y, c, (0.5 * width + 0.5 - d) as f32);
            }
        }
    }

    /// A disc (filled) or a ring of the given radius.
    fn circle(&mut self, centre: (f64, f64), r: f64, filled: bool, c: [u8; 3]) {
        for y in (centre.1 - r - 2.0) as i64..=(centre.1 + r + 2.0) as i64 {
            for x in (centre.0 - r - 2.0) as i64..=(centre.0 + r + 2.0) as i64 {
                let d = ((x as f64 + 0.5 - centre.0).powi(2) + (y as f64 + 0.5 - centre.1).powi(2)).sqrt();
                let a = if filled { r + 0.5 - d } else { 1.25 - (d - r).abs() };
                self.blend(x, y, c, a as f32);
            }
        }
    }

    fn text_width(&self, text: &str, px: f32) -> f64 {
        let scaled = self.font.as_scaled(PxScale::from(px));
        text.chars().map(|ch| scaled.h_advance(self.font.glyph_id(ch)) as f64).sum()
    }

    /// Text with its top-left corner at (x, y).
    fn text(&mut self, x: f64, y: f64, text: &str, px: f32, c: [u8; 3]) {
        let scale = PxScale::from(px);
        let ascent = self.font.as_scaled(scale).ascent();
        let mut pen = x as f32;
        for ch in text.chars() {
            let id = self.font.glyph_id(ch);
            let glyph = id.with_scale_and_position(scale, ab_glyph::point(pen, y as f32 + ascent));
            pen += self.font.as_scaled(scale).h_advance(id);
            if let Some(outline) = self.font.outline_glyph(glyph) {
                let b = outline.px_bounds();
                let mut hits = Vec::new();
                outline.draw(|gx, gy, cov| {
                    hits.push((b.min.x as i64 + gx as i64, b.min.y as i64 + gy as i64, cov))
                });
                for (px, py, cov) in hits {
                    self.blend(px, py, c, cov);
                }
            }
        }
    }
}

/// The plot as RGBA8 pixels (WIDTH × HEIGHT, row 0 at the top).
pub fn render(plot: &Plot) -> (u32, u32, Vec<u8>) {
    let font = FontRef::try_from_slice(FONT_BYTES).expect("the committed font parses");
    let mut cv = Canvas { rgba: vec![255; (WIDTH * HEIGHT * 4) as usize], font };
    let xs: Vec<f64> = plot.points.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = plot.points.iter().map(|p| p.y).collect();
    let (ax, ay) = (Axis::fit(&xs), Axis::fit(&ys));
    let (w, h) = (WIDTH as f64 - LEFT - RIGHT, HEIGHT as f64 - TOP - BOTTOM);
    let to_px = |x: f64, y: f64| (LEFT + ax.unit(x) * w, TOP + (1.0 - ay.unit(y)) * h);
    cv.text(LEFT, 12.0, &plot.title, 18.0, INK);
    for (v, label) in ax.ticks() {
        let px = LEFT + ax.unit(v) * w;
        cv.line((px, TOP), (px, TOP + h), 1.0, GRID);
        let tw = cv.text_width(&label, 13.0);
        cv.text(px - tw / 2.0, TOP + h + 6.0, &label, 13.0, INK);
    }
    for (v, label) in ay.ticks() {
        let py = TOP + (1.0 - ay.unit(v)) * h;
        cv.line((LEFT, py), (LEFT + w, py), 1.0, GRID);
        let tw = cv.text_width(&label, 13.0);
        cv.text(LEFT - tw - 6.0, py - 8.0, &label, 13.0, INK);
    }
    cv.rect(LEFT, TOP + h, LEFT + w, TOP + h + 1.5, INK);
    cv.rect(LEFT - 1.5, TOP, LEFT, TOP + h, INK);
    let scale = |a: &Axis| if a.log { " (log scale)" } else { "" };
    let xl = format!("{}{}", plot.x_label, scale(&ax));
    let tw = cv.text_width(&xl, 14.0);
    cv.text(LEFT + (w - tw) / 2.0, TOP + h + 30.0, &xl, 14.0, INK);
    cv.text(LEFT - 80.0, TOP - 22.0, &format!("{}{}", plot.y_label, scale(&ay)), 14.0, INK);

    let pts: Vec<(f64, f64)> = plot.points.iter().map(|p| (p.x, p.y)).collect();
    let front = pareto::front(&pts);
    for pair in front.windows(2) {
        let (a, b) = (to_px(pts[pair[0]].0, pts[pair[0]].1), to_px(pts[pair[1]].0, pts[pair[1]].1));
        cv.line(a, (b.0, a.1), 2.0, FRONT);
        cv.line((b.0, a.1), b, 2.0, FRONT);
    }
    // Labels right of their points, moved up or down past labels already placed (points that
    // nearly coincide would print over each other).
    let mut placed: Vec<(f64, f64, f64, f64)> = Vec::new();
    for (i, p) in plot.points.iter().enumerate() {
        if !(p.x.is_finite() && p.y.is_finite()) {
            continue;
        }
        let at = to_px(p.x, p.y);
        cv.circle(at, 4.5, true, PALETTE[p.series % PALETTE.len()]);
        if front.contains(&i) {
            cv.circle(at, 8.0, false, FRONT);
        }
        let tw = cv.text_width(&p.label, 12.0);
        let overlaps = |y: f64| {
            placed.iter().any(|r| at.0 + 9.0 < r.2 && r.0 < at.0 + 9.0 + tw && y < r.3 && r.1 < y + 14.0)
        };
        let y = [-16.0, 2.0, -32.0, 18.0, -48.0, 34.0, -64.0, 50.0]
            .iter()
            .map(|dy| at.1 + dy)
            .find(|&y| !overlaps(y))
            .unwrap_or(at.1 - 16.0);
        placed.push((at.0 + 9.0, y, at.0 + 9.0 + tw, y + 14.0));
        cv.text(at.0 + 9.0, y, &p.label, 12.0, INK);
    }
    let lx = LEGEND_X;
    let mut ly = TOP;
    for (k, name) in plot.series.iter().enumerate() {
        cv.circle((lx + 6.0, ly + 8.0), 4.5, true, PALETTE[k % PALETTE.len()]);
        cv.text(lx + 18.0, ly, name, 13.0, INK);
        ly += 22.0;
    }
    cv.circle((lx + 6.0, ly + 8.0), 8.0, false, FRONT);
    cv.text(lx + 18.0, ly, "Pareto front", 13.0, INK);
    let unplotted = plot.points.iter().filter(|p| !(p.x.is_finite() && p.y.is_finite())).count();
    if unplotted > 0 {
        cv.text(lx, ly + 24.0, &format!("{unplotted} non-finite not drawn"), 12.0, INK);
    }
    (WIDTH, HEIGHT, cv.rgba)
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

    #[test]
    fn renders_points_and_the_front() {
        let plot = Plot {
            id: "p".into(),
            title: "t".into(),
            x_label: "ms".into(),
            y_label: "err".into(),
            series: vec!["a".into(), "b".into()],
            points: vec![
                PlotPoint { label: "fast".into(), x: 1.0, y: 1.0, series: 0 },
                PlotPoint { label: "slow".into(), x: 100.0, y: 1e-6, series: 1 },
                PlotPoint { label: "nan".into(), x: f64::NAN, y: 1.0, series: 1 },
            ],
        };
        let (w, h, rgba) = render(&plot);
        assert_eq!(rgba.len(), (w * h * 4) as usize);
        // Something was drawn in the series' and the front's colours.
        let has = |c: [u8; 3]| rgba.chunks_exact(4).any(|p| p[..3] == c);
        assert!(has(PALETTE[0]) && has(PALETTE[1]) && has(FRONT));
    }
}
