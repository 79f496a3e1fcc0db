//! The game's own temporal resolve (a simple TAA, on the CPU for the headless frames): each pixel
//! blends the new frame into its history fetched where hadou's motion vectors say the pixel's
//! surface was in the previous frame (`Aov::Motion`), the history clamped to the new frame's 3×3
//! neighbourhood first (what keeps a wrong or missing history from leaving a trail), and not
//! taken at all where the history pixel moved unlike the pixel (a surface uncovered this frame:
//! the motion vectors tell). Linear colour; the frames are the game's sRGB target.

/// How much of each new frame goes into the history.
pub const BLEND: f32 = 0.1;

pub struct Taa {
    pub width: u32,
    pub height: u32,
    /// Clamp the history to the new frame's neighbourhood (on by default; off, a wrong history
    /// shows as it is: what the trail test measures).
    pub clamp: bool,
    /// Linear RGB, the last resolve (None before the first frame).
    history: Option<Vec<[f32; 3]>>,
    /// The motion the last frame came with: a history pixel that moved unlike the pixel now
    /// fetching it was another surface (a disocclusion), and is not taken.
    history_motion: Option<Vec<f32>>,
}

/// Pixels by which a history pixel's motion may differ from the pixel fetching it.
pub const MOTION_REJECT: f32 = 1.0;

fn linear(c: u8) -> f32 {
    let c = f32::from(c) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// An sRGB RGBA8 frame in linear RGB.
pub fn to_linear(rgba: &[u8]) -> Vec<[f32; 3]> {
    rgba.chunks_exact(4).map(|p| [linear(p[0]), linear(p[1]), linear(p[2])]).collect()
}

impl Taa {
    pub fn new(width: u32, height: u32) -> Taa {
        Taa { width, height, clamp: true, history: None, history_motion: None }
    }

    /// Resolves `frame` (linear RGB) with `motion` (pixels to the previous frame, two values a
    /// pixel; None: the history is taken where the pixel is, as without motion vectors).
    pub fn resolve(&mut self, frame: &[[f32; 3]], motion: Option<&[f32]>) -> &[[f32; 3]] {
        let (w, h) = (self.width as i64, self.height as i64);
        let before = std::mem::replace(&mut self.history_motion, motion.map(<[f32]>::to_vec));
        let Some(history) = self.history.take() else {
            return self.history.insert(frame.to_vec());
        };
        let at = |img: &[[f32; 3]], x: i64, y: i64| img[(y.clamp(0, h - 1) * w + x.clamp(0, w - 1)) as usize];
        let mut out = Vec::with_capacity(frame.len());
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let (mx, my) = motion.map_or((0.0, 0.0), |m| (m[2 * i], m[2 * i + 1]));
                // The history bilinearly at the pixel's centre in the previous frame.
                let (px, py) = (x as f32 + 0.5 + mx - 0.5, y as f32 + 0.5 + my - 0.5);
                let (x0, y0) = (px.floor(), py.floor());
                let (fx, fy) = (px - x0, py - y0);
                let (x0, y0) = (x0 as i64, y0 as i64);
                let inside = px >= -0.5 && py >= -0.5 && px <= w as f32 - 0.5 && py <= h as f32 - 0.5;
                // The history pixel nearest where this one was: did it move as this one did?
                let same = before.as_ref().is_none_or(|b| {
                    let k = ((py + 0.5).floor() as i64).clamp(0, h - 1) * w
                        + ((px + 0.5).floor() as i64).clamp(0, w - 1);
                    let k = k as usize;
                    (b[2 * k] - mx).abs() <= MOTION_REJECT && (b[2 * k + 1] - my).abs() <= MOTION_REJECT
                });
                let old: [f32; 3] = std::array::from_fn(|c| {
                    let top = at(&history, x0, y0)[c] * (1.0 - fx) + at(&history, x0 + 1, y0)[c] * fx;
                    let bottom =
                        at(&history, x0, y0 + 1)[c] * (1.0 - fx) + at(&history, x0 + 1, y0 + 1)[c] * fx;
                    top * (1.0 - fy) + bottom * fy
                });
                // Clamped to the new frame's neighbourhood.
                let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let p = at(frame, x + dx, y + dy);
                        for c in 0..3 {
                            lo[c] = lo[c].min(p[c]);
                            hi[c] = hi[c].max(p[c]);
                        }
                    }
                }
                let new = frame[i];
                let blend = if inside && same { BLEND } else { 1.0 };
                out.push(std::array::from_fn(|c| {
                    let old = if self.clamp { old[c].clamp(lo[c], hi[c]) } else { old[c] };
                    old + (new[c] - old) * blend
                }));
            }
        }
        self.history.insert(out)
    }
}

/// Pixels of `resolved` outside the range of `frame`'s 3×3 neighbourhood by more than `margin`
/// in a channel: colour the history brought from elsewhere (a trail, a ghost).
pub fn ghosts(resolved: &[[f32; 3]], frame: &[[f32; 3]], width: u32, height: u32, margin: f32) -> usize {
    let (w, h) = (width as i64, height as i64);
    let at = |x: i64, y: i64| frame[(y.clamp(0, h - 1) * w + x.clamp(0, w - 1)) as usize];
    (0..h * w)
        .filter(|&i| {
            let (x, y) = (i % w, i / w);
            (0..3).any(|c| {
                let near = (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy)));
                let (lo, hi) = near.fold((f32::MAX, f32::MIN), |(lo, hi), (dx, dy)| {
                    let v = at(x + dx, y + dy)[c];
                    (lo.min(v), hi.max(v))
                });
                let v = resolved[i as usize][c];
                v < lo - margin || v > hi + margin
            })
        })
        .count()
}
