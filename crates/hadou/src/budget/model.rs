//! The cost model of one effect: each level's own measured time, and a prediction for the levels
//! not measured yet.
//!
//! - A level's cost is a moving average (weight [`SMOOTHING`]) of the effect's passes' time in
//!   the frames recorded at that level, leaving out the first [`SETTLE_FRAMES`] of each stay
//!   (a level that just changed a pass's variant, or the material table, pays for it once).
//!   The level in use follows the world frame by frame; a level not in use keeps what it cost
//!   when it was last used, and is measured again when the budget goes back to it. (Predicting
//!   the others from the one in use through ratios was tried: one badly measured ratio then
//!   moved every prediction, and the budget went back and forth between levels on lavapipe.)
//! - A level never measured is predicted from its measured neighbours: between two, its cost is
//!   interpolated geometrically by where its hint lies between theirs; past the last one
//!   measured, that level's cost times the hints' ratio. So one cheap level measured makes the
//!   levels between it and level 0 look cheaper too, and the budget tries them (a wrong prior,
//!   e.g. a light map whose time falls with its area, is corrected by every level measured).

use super::QualityLevel;

/// Frames at the start of each stay at a level that are not measured.
pub const SETTLE_FRAMES: u32 = 1;
/// The weight of a new frame in the moving averages.
pub const SMOOTHING: f64 = 0.3;

/// One effect's levels and what was measured of them.
#[derive(Clone, Debug, PartialEq)]
pub struct EffectCosts {
    /// The effect's levels, exact first.
    pub levels: Vec<QualityLevel>,
    /// Each level's smoothed ms, once measured.
    ms: Vec<Option<f64>>,
    /// The level of the current stay and how many of its frames came back.
    stay: Option<(usize, u32)>,
}

fn blend(old: Option<f64>, new: f64) -> f64 {
    old.map_or(new, |o| o + SMOOTHING * (new - o))
}

impl EffectCosts {
    /// A model with nothing measured.
    pub fn new(levels: Vec<QualityLevel>) -> Self {
        let ms = vec![None; levels.len()];
        EffectCosts { levels, ms, stay: None }
    }

    /// Keeps what was measured of the levels that keep their name when the effect's levels change
    /// with the world (their errors may move: a translucent instance that moves changes the light
    /// map's texel).
    pub fn with_levels(&self, levels: Vec<QualityLevel>) -> Self {
        let mut next = EffectCosts::new(levels);
        for (i, l) in next.levels.iter().enumerate() {
            if let Some(j) = self.levels.iter().position(|o| o.name == l.name) {
                next.ms[i] = self.ms[j];
            }
        }
        next.stay = self
            .stay
            .filter(|(l, _)| next.levels.get(*l).map(|x| &x.name) == self.levels.get(*l).map(|x| &x.name));
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
        // The first frames at a level settle; a level never measured takes its first frame.
        if frames >= SETTLE_FRAMES || self.ms.iter().all(Option::is_none) {
            self.ms[level] = Some(blend(self.ms[level], ms));
        }
    }

    /// Predicted ms at `level` (NaN before any level was measured).
    pub fn predicted(&self, level: usize) -> f64 {
        if let Some(ms) = self.ms[level] {
            return ms;
        }
        let hint = |l: usize| self.levels[l].cost_hint;
        let below = (0..level).rev().find_map(|l| self.ms[l].map(|ms| (l, ms)));
        let above = (level + 1..self.levels.len()).find_map(|l| self.ms[l].map(|ms| (l, ms)));
        match (below, above) {
            (Some((b, mb)), Some((a, ma))) => {
                let span = (hint(a) / hint(b)).ln();
                let t = (hint(level) / hint(b)).ln() / span;
                if t.is_finite() && span != 0.0 {
                    mb * (ma / mb).powf(t.clamp(0.0, 1.0))
                } else {
                    mb * hint(level) / hint(b)
                }
            }
            (Some((b, mb)), None) => mb * hint(level) / hint(b),
            (None, Some((a, ma))) => ma * hint(level) / hint(a),
            (None, None) => f64::NAN,
        }
    }

    /// Whether level `level` was measured.
    pub fn is_measured(&self, level: usize) -> bool {
        self.ms[level].is_some()
    }

    /// Whether any level was measured.
    pub fn has_scale(&self) -> bool {
        self.ms.iter().any(Option::is_some)
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
        // The first frame at level 1 settles; the next is measured.
        m.observe(1, 30.0);
        assert!(!m.is_measured(1));
        m.observe(1, 8.0);
        assert!(m.is_measured(1));
        assert_eq!((m.predicted(0), m.predicted(1)), (10.0, 8.0));
    }

    #[test]
    fn the_level_in_use_follows_the_world_and_the_others_keep_their_cost() {
        let mut m = EffectCosts::new(levels());
        m.observe(0, 10.0);
        m.observe(1, 8.0);
        // The world doubles in cost while level 1 is in use.
        for _ in 0..40 {
            m.observe(1, 16.0);
        }
        assert!((m.predicted(1) - 16.0).abs() < 1e-3);
        assert_eq!(m.predicted(0), 10.0, "level 0 is measured again when used again");
        m.observe(0, 20.0);
        m.observe(0, 20.0);
        assert!((m.predicted(0) - 13.0).abs() < 1e-9);
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
        m.observe(3, 99.0);
        m.observe(3, 2.7);
        let r = |l: usize| m.predicted(l) / 30.0;
        let t = |h: f64| h.ln() / 0.55f64.ln();
        assert!((r(1) - 0.09f64.powf(t(0.75))).abs() < 1e-12, "{}", r(1));
        assert!((r(2) - 0.09f64.powf(t(0.6))).abs() < 1e-12);
        assert!(r(0) > r(1) && r(1) > r(2) && r(2) > r(3));
        // Past the last measured level: its cost times the hints' ratio.
        let mut m = EffectCosts::new(vec![
            QualityLevel::new("0", 0.0, 1.0),
            QualityLevel::new("1", 1e-3, 0.5),
            QualityLevel::new("2", 1e-2, 0.25),
        ]);
        m.observe(0, 10.0);
        m.observe(1, 8.0);
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
        m.observe(1, 1.0);
        let mut more = levels();
        more.push(QualityLevel::new("faster", 1e-1, 0.25));
        let next = m.with_levels(more);
        assert!(next.is_measured(1) && !next.is_measured(2));
        // Level 2, past the last measured (1: 1 ms, hint ½), at 1 × 0.25 / 0.5.
        assert_eq!((next.predicted(1), next.predicted(2)), (1.0, 0.5));
    }
}
