//! The frame budget (issue 22 item 4): a GPU time per frame, and each effect's setting picked to
//! fit it with the least error.
//!
//! An effect offers **quality levels** (`Effect::quality_levels`): its settings from the most
//! exact to the cheapest, each with the bound on the relative error of what the effect draws at
//! that level and a prior guess of its cost. The renderer (`Renderer::set_frame_budget`)
//!
//! 1. **measures** each effect's passes every finished frame and keeps a cost model per effect
//!    ([`model::EffectCosts`]): each level's own time, the level in use following the world
//!    frame by frame (a wave that grows on screen costs more), a level never used predicted from
//!    its measured neighbours and the effect's prior;
//! 2. **decides** every [`DECIDE_EVERY`] frames ([`choose::choose`]): the levels whose predicted
//!    sum, with the passes that offer no level, fits the budget with the least summed error bound;
//!    nothing fits: the cheapest levels, and the status says so;
//! 3. **applies** the levels through [`QualityChoice`] on the scene, which the effects read
//!    (`Scene::quality`); a pass whose variant changes is built (once: parked passes are kept).
//!
//! Errors of different effects are summed as they are stated: each a bound on the relative error
//! of that effect's own output (the wave's H, translucency's transmittance), so the sum bounds no
//! single pixel's error. It is the objective, and every level's bound is listed in the status.

pub mod choose;
pub mod model;

use std::collections::BTreeMap;

/// Frames between two decisions (a decision needs its levels' frames measured, which come back
/// `frames_in_flight` frames later; the first frames at a new level measure it).
pub const DECIDE_EVERY: u64 = 8;

/// A budget must be a finite number of milliseconds in this range.
pub const BUDGET_RANGE_MS: std::ops::RangeInclusive<f64> = 0.001..=1.0e6;

/// One setting an effect offers the frame budget (`Effect::quality_levels`, level 0 first: the
/// most exact).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct QualityLevel {
    /// Shown in `BudgetStatus` and the report (`"τ=1e-3"`).
    pub name: String,
    /// The bound on the relative error of the effect's output at this level (0: exact up to f32),
    /// finite and ≥ 0, not decreasing from one level to the next.
    pub error: f64,
    /// The level's cost as a share of level 0's before it is measured (the model's prior), > 0.
    pub cost_hint: f64,
}

impl QualityLevel {
    /// A level named `name` with error bound `error` and prior relative cost `cost_hint`.
    pub fn new(name: impl Into<String>, error: f64, cost_hint: f64) -> Self {
        QualityLevel { name: name.into(), error, cost_hint }
    }

    /// Whether a list of levels is one the budget takes: errors finite, ≥ 0 and not decreasing,
    /// hints finite and > 0 (an empty list: the effect offers none).
    pub fn check(levels: &[QualityLevel]) -> Result<(), String> {
        for (i, l) in levels.iter().enumerate() {
            if !(l.error.is_finite() && l.error >= 0.0) {
                return Err(format!(
                    "level {i} ({}) has error {}: finite and >= 0 expected",
                    l.name, l.error
                ));
            }
            if !(l.cost_hint.is_finite() && l.cost_hint > 0.0) {
                return Err(format!(
                    "level {i} ({}) has cost hint {}: finite and > 0 expected",
                    l.name, l.cost_hint
                ));
            }
            if i > 0 && l.error < levels[i - 1].error {
                return Err(format!(
                    "level {i} ({}) is more exact than level {}: levels go from exact to cheap",
                    l.name,
                    i - 1
                ));
            }
        }
        Ok(())
    }
}

/// The levels the frame budget chose, by effect name (`Scene::quality`); an effect without an
/// entry uses its own settings (the scene's, the game's). Set by hand on a scene loaded without a
/// budget, it pins levels (the report measures each effect's front so); with a budget, the budget
/// overwrites it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct QualityChoice(BTreeMap<String, usize>);

impl QualityChoice {
    /// The level chosen for `effect`, if the budget chose one.
    pub fn level(&self, effect: &str) -> Option<usize> {
        self.0.get(effect).copied()
    }

    /// Chooses `level` for `effect` (`None`: its own settings again).
    pub fn set(&mut self, effect: &str, level: Option<usize>) {
        match level {
            Some(l) => self.0.insert(effect.to_string(), l),
            None => self.0.remove(effect),
        };
    }

    /// Whether no level is chosen.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Every choice dropped: each effect uses its own settings.
    pub fn clear(&mut self) {
        self.0.clear();
    }
}

/// What the frame budget decided last and what it predicts (`Renderer::budget_status`).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct BudgetStatus {
    /// The budget, ms of GPU time per frame.
    pub budget_ms: f64,
    /// The predicted GPU frame at the chosen levels: the passes without levels (measured) plus
    /// each effect's predicted cost.
    pub predicted_ms: f64,
    /// The measured cost of the passes that offer no level (the raster, metaballs, ...).
    pub fixed_ms: f64,
    /// Whether `predicted_ms` fits the budget. False right after a decision: even the cheapest
    /// levels do not fit; between decisions: the levels in use stopped fitting, and the next
    /// decision moves them.
    pub fits: bool,
    /// Frames measured so far.
    pub frames_measured: u64,
    /// Each effect with levels, in registration order.
    pub effects: Vec<EffectBudget>,
}

impl BudgetStatus {
    /// The summed error bound of the chosen levels (the objective the budget minimizes).
    pub fn error(&self) -> f64 {
        self.effects.iter().map(|e| e.levels[e.chosen].error).sum()
    }
}

/// One effect in [`BudgetStatus`].
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct EffectBudget {
    /// `Effect::name`.
    pub name: &'static str,
    /// The level in use.
    pub chosen: usize,
    /// Every level with its predicted cost: the effect's (cost, error) front.
    pub levels: Vec<LevelCost>,
}

/// A level with its predicted cost (`EffectBudget::levels`).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct LevelCost {
    /// `QualityLevel::name`.
    pub name: String,
    /// `QualityLevel::error`.
    pub error: f64,
    /// Predicted ms of the effect's passes at this level (`model::EffectCosts::predicted`:
    /// measured, or from its measured neighbours and the hints); NaN before any frame was
    /// measured.
    pub predicted_ms: f64,
    /// Whether this level was measured (else it is predicted from its neighbours and the prior).
    pub measured: bool,
}
