//! The cost model of one effect: ms of its level 0 now (the scale) times each level's ratio to it.
//!
//! The scale follows the world (a wave that fills more of the screen costs more at every level);
//! the ratios are what a level saves, which depends on the scene far less. So a level not used
//! for a while is predicted from the scale measured at the level in use, not from a stale time.
//! - At level 0 every frame updates the scale.
//! - The first [`RATIO_FRAMES`] frames of a stay at another level update that level's ratio
//!   against the scale the stay began with (the world cannot be told from the level by one
//!   frame); later frames of the stay update the scale through the ratio.
//!
//! Updates are exponential moving averages with weight [`SMOOTHING`] (the first measurement
//! replaces the prior).
//!
//! A level not measured yet is predicted from its measured neighbours: between two, its ratio is
//! interpolated geometrically by where its hint lies between theirs (a wrong prior's scale, e.g.
//! a light map whose time falls with its area, is corrected by every level measured); past the
//! last one measured, that level's ratio times the hints' ratio. So a cheap level measured makes
//! the levels between it and level 0 look cheaper too, and the budget tries them.

use super::QualityLevel;

/// Frames at the start of a stay at a level that measure its ratio.
pub const RATIO_FRAMES: u32 = 3;
/// The weight of a new frame in the moving averages.
pub const SMOOTHING: f64 = 0.3;

/// One effect's levels and what was measured of them.
#[derive(Clone, Debug, PartialEq)]
pub struct EffectCosts {
    /// The effect's levels, exact first.
    pub levels: Vec<QualityLevel>,
    /// Cost of each level over level 0's (level 0: 1); the hint until measured.
    ratio: Vec<f64>,
    measured: Vec<bool>,
    /// ms of level 0 now; None until a frame was measured.
    scale: Option<f64>,
    /// The level of the current stay and how many frames of it were measured.
    stay: Option<(usize, u32)>,
}

fn blend(old: f64, new: f64) -> f64 {
    old + SMOOTHING * (new - old)
}

impl EffectCosts {
    /// A model with the levels' hints as ratios (normalized to level 0's) and nothing measured.
    pub fn new(levels: Vec<QualityLevel>) -> Self {
        let base = levels.first().map_or(1.0, |l| l.cost_hint);
        let ratio = levels.iter().map(|l| l.cost_hint / base).collect();
        let mut measured = vec![false; levels.len()];
        if let Some(m) = measured.first_mut() {
            *m = true;
        }
        EffectCosts { levels, ratio, measured, scale: None, stay: None }
    }

    /// Keeps what was measured of the levels that keep their name when the effect's levels change
    /// with the world (their errors may move: a translucent instance that moves changes the light
    /// map's texel).
    pub fn with_levels(&self, levels: Vec<QualityLevel>) -> Self {
        let mut next = EffectCosts::new(levels);
        if self.levels.first().map(|l| &l.name) == next.levels.first().map(|l| &l.name) {
            next.scale = self.scale;
            for (i, l) in next.levels.iter().enumerate() {
                if let Some(j) = self.levels.iter().position(|o| o.name == l.name) {
                    (next.ratio[i], next.measured[i]) = (self.ratio[j], self.measured[j]);
                }
            }
        }
        next
    }

    /// One finished frame: the effect's passes took `ms` at `level`.
    pub fn observe(&mut self, level: usize, ms: f64) {
        if level >= self.levels.len() || !(ms.is_finite() && ms >= 0.0) {
            return;
        }
        let frames = match self.stay {
            Some((l, n)) if l == level => n,
            _ => 0,
        };
        self.stay = Some((level, frames.saturating_add(1)));
        let Some(scale) = self.scale.filter(|s| *s > 0.0) else {
            self.scale = Some(ms / self.ratio[level]);
            return;
        };
        if level != 0 && frames < RATIO_FRAMES {
            let r = ms / scale;
            self.ratio[level] = if self.measured[level] { blend(self.ratio[level], r) } else { r };
            self.measured[level] = true;
        } else {
            self.scale = Some(blend(scale, ms / self.ratio[level]));
        }
    }

    /// Predicted ms at `level` (NaN before any frame).
    pub fn predicted(&self, level: usize) -> f64 {
        self.scale.map_or(f64::NAN, |s| s * self.ratio_of(level))
    }

    /// The level's ratio: measured, or from its measured neighbours (see the module docs).
    fn ratio_of(&self, level: usize) -> f64 {
        if self.measured[level] {
            return self.ratio[level];
        }
        let hint = |l: usize| self.levels[l].cost_hint;
        // Level 0 is always measured (ratio 1), so a measured level below exists.
        let below = (0..level).rev().find(|&l| self.measured[l]).unwrap_or(0);
        let above = (level + 1..self.levels.len()).find(|&l| self.measured[l]);
        let from_below = self.ratio[below] * hint(level) / hint(below);
        let Some(above) = above else { return from_below };
        let span = (hint(above) / hint(below)).ln();
        let t = (hint(level) / hint(below)).ln() / span;
        if !(t.is_finite() && span != 0.0) {
            return from_below;
        }
        let t = t.clamp(0.0, 1.0);
        self.ratio[below] * (self.ratio[above] / self.ratio[below]).powf(t)
    }

    /// Whether level `level`'s ratio was measured.
    pub fn is_measured(&self, level: usize) -> bool {
        self.measured[level]
    }

    /// Whether any frame was measured.
    pub fn has_scale(&self) -> bool {
        self.scale.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn levels() -> Vec<QualityLevel> {
        vec![QualityLevel::new("exact", 0.0, 1.0), QualityLevel::new("fast", 1e-2, 0.5)]
    }

    #[test]
    fn the_hint_predicts_until_the_level_is_measured() {
        let mut m = EffectCosts::new(levels());
        assert!(m.predicted(0).is_nan());
        m.observe(0, 10.0);
        assert_eq!((m.predicted(0), m.predicted(1)), (10.0, 5.0));
        assert!(!m.is_measured(1));
        // At level 1 the pass takes 8 ms: the ratio is 0.8, the scale stays 10.
        m.observe(1, 8.0);
        assert!(m.is_measured(1));
        assert!((m.predicted(1) - 8.0).abs() < 1e-12 && (m.predicted(0) - 10.0).abs() < 1e-12);
    }

    #[test]
    fn the_scale_follows_the_world_at_a_level_not_in_use() {
        let mut m = EffectCosts::new(levels());
        m.observe(0, 10.0);
        for _ in 0..RATIO_FRAMES {
            m.observe(1, 8.0);
        }
        // The world doubles in cost while level 1 is in use: level 0's prediction doubles too.
        for _ in 0..40 {
            m.observe(1, 16.0);
        }
        assert!((m.predicted(0) - 20.0).abs() < 1e-3, "{}", m.predicted(0));
        assert!((m.predicted(1) - 16.0).abs() < 1e-3);
    }

    #[test]
    fn a_level_not_measured_lies_between_its_measured_neighbours() {
        let levels = vec![
            QualityLevel::new("0", 0.0, 1.0),
            QualityLevel::new("1", 1e-3, 0.75),
            QualityLevel::new("2", 1e-2, 0.6),
            QualityLevel::new("3", 1e-1, 0.55),
        ];
        let mut m = EffectCosts::new(levels);
        m.observe(0, 30.0);
        // The cheapest level turns out at 0.09 of level 0, far under its prior of 0.55: the
        // levels between follow, in the hints' geometric proportion.
        m.observe(3, 2.7);
        let r = |l: usize| m.predicted(l) / 30.0;
        let t = |h: f64| h.ln() / 0.55f64.ln();
        assert!((r(1) - 0.09f64.powf(t(0.75))).abs() < 1e-12, "{}", r(1));
        assert!((r(2) - 0.09f64.powf(t(0.6))).abs() < 1e-12);
        assert!(r(0) > r(1) && r(1) > r(2) && r(2) > r(3));
        // Past the last measured level: its ratio times the hints'.
        let mut m = EffectCosts::new(vec![
            QualityLevel::new("0", 0.0, 1.0),
            QualityLevel::new("1", 1e-3, 0.5),
            QualityLevel::new("2", 1e-2, 0.25),
        ]);
        m.observe(0, 10.0);
        m.observe(1, 8.0);
        assert!((m.predicted(2) - 4.0).abs() < 1e-12);
    }

    #[test]
    fn bad_times_and_levels_are_ignored_and_known_levels_kept() {
        let mut m = EffectCosts::new(levels());
        m.observe(0, f64::NAN);
        m.observe(7, 3.0);
        assert!(!m.has_scale());
        m.observe(0, 4.0);
        m.observe(1, 1.0);
        let mut more = levels();
        more.push(QualityLevel::new("faster", 1e-1, 0.25));
        let next = m.with_levels(more);
        assert!(next.is_measured(1) && !next.is_measured(2));
        // Level 2, past the last measured (1: ratio ¼, hint ½), at ¼ × 0.25 / 0.5.
        assert_eq!((next.predicted(1), next.predicted(2)), (1.0, 0.5));
    }
}
