//! The frame budget in the renderer (`crate::budget`): its setting, the frames it measures and
//! the levels it puts on the scene.

use std::collections::VecDeque;

use super::Renderer;
use crate::budget::choose::decide;
use crate::budget::model::{EffectCosts, SMOOTHING};
use crate::budget::{
    BudgetStatus, EffectBudget, LevelCost, QualityChoice, QualityLevel, BUDGET_RANGE_MS, DECIDE_EVERY,
};
use crate::frame::{FrameStats, PassTiming};
use crate::Error;

/// One effect with levels: its passes (whose times are its cost) and its model.
#[derive(Clone, Debug)]
struct Modelled {
    name: &'static str,
    passes: Vec<&'static str>,
    costs: EffectCosts,
}

/// The budget's state (`Renderer::set_frame_budget`, `budget_status`).
#[derive(Clone, Debug, Default)]
pub(super) struct FrameBudget {
    /// `set_frame_budget` / `RendererOptions::frame_budget_ms`; None: the scene's `budget_ms`.
    own_ms: Option<f64>,
    effects: Vec<Modelled>,
    /// The passes that offer no level, smoothed ms.
    fixed_ms: Option<f64>,
    /// The levels each frame not yet measured was recorded with (by effect name).
    recorded: VecDeque<(u64, Vec<(&'static str, usize)>)>,
    frames_measured: u64,
    /// The frame the last decision was made before.
    decided_at: Option<u64>,
}

/// How many recorded frames' levels are kept for frames not yet reported finished.
const RECORDED_KEPT: usize = 64;

impl FrameBudget {
    pub(super) fn new(own_ms: Option<f64>) -> Self {
        FrameBudget { own_ms, ..Default::default() }
    }

    /// Forgets what was measured (a new scene), keeping the setting.
    fn reset(&mut self) {
        *self = FrameBudget::new(self.own_ms);
    }

    /// One finished frame's timings, measured against the levels it was recorded with.
    pub(super) fn observe(&mut self, frame: u64, stats: &FrameStats) {
        while self.recorded.front().is_some_and(|(f, _)| *f < frame) {
            self.recorded.pop_front();
        }
        let Some((_, levels)) = self.recorded.pop_front().filter(|(f, _)| *f == frame) else { return };
        let charged = charged_ms(&stats.passes);
        let pass_ms = |name: &str| -> f64 {
            // A frame's later views name their passes "view N/pass".
            let base = |p: &PassTiming| p.name.rsplit('/').next() == Some(name);
            stats.passes.iter().zip(&charged).filter(|(p, _)| base(p)).map(|(_, ms)| ms).sum()
        };
        let mut modelled = 0.0;
        for e in &mut self.effects {
            let Some(&(_, level)) = levels.iter().find(|(n, _)| *n == e.name) else { continue };
            let ms: f64 = e.passes.iter().map(|p| pass_ms(p)).sum();
            e.costs.observe(level, ms);
            modelled += ms;
        }
        let fixed = (stats.gpu_frame_ms - modelled).max(0.0);
        if fixed.is_finite() {
            self.fixed_ms = Some(self.fixed_ms.map_or(fixed, |f| f + SMOOTHING * (fixed - f)));
        }
        self.frames_measured += 1;
    }
}

/// Each pass's time with the idle time before it since the previous pass ended: the barriers and
/// clears of its images run there (measured on lavapipe: 4 of the 43 ms of assets/scenes/
/// budget.toml's frame lay between passes at the 3,584² light map, 0.5 at 512²), so a level that
/// shrinks a pass's images is credited with them.
fn charged_ms(passes: &[PassTiming]) -> Vec<f64> {
    let mut end = 0.0f64;
    passes
        .iter()
        .map(|p| {
            let idle = (p.start_ms - end).max(0.0);
            end = end.max(p.start_ms + p.gpu_ms);
            p.gpu_ms + idle
        })
        .collect()
}

impl Renderer {
    /// Sets the GPU time per frame, in ms, that the frame budget fits the effects' levels into
    /// (`crate::budget`); `None` turns it off (every effect back to its own settings) unless the
    /// scene gives `[render] budget_ms`. A budget overrides the scene's. Refused outside
    /// [`BUDGET_RANGE_MS`].
    pub fn set_frame_budget(&mut self, budget_ms: Option<f64>) -> Result<(), Error> {
        if let Some(ms) = budget_ms {
            if !BUDGET_RANGE_MS.contains(&ms) {
                return Err(Error::InvalidUpdate {
                    what: format!("frame budget {ms} ms"),
                    expected: "a number of milliseconds in [0.001, 1000000]".into(),
                });
            }
        }
        self.budget.own_ms = budget_ms;
        if self.budget_ms().is_none() {
            self.budget.reset();
            let cleared = self.loaded.as_mut().is_some_and(|l| {
                let had = !l.scene.quality.is_empty();
                l.scene.quality.clear();
                had
            });
            if cleared {
                self.sync_passes()?;
            }
        }
        Ok(())
    }

    /// The budget in force: `set_frame_budget`'s, else the scene's `[render] budget_ms`.
    pub fn budget_ms(&self) -> Option<f64> {
        self.budget.own_ms.or_else(|| self.loaded.as_ref().and_then(|l| l.scene.render.budget_ms))
    }

    /// What the frame budget measured and chose (None without a budget or a scene): each effect's
    /// levels with their predicted cost and error, the level in use, the predicted frame.
    pub fn budget_status(&self) -> Option<BudgetStatus> {
        let budget_ms = self.budget_ms()?;
        let scene = &self.loaded.as_ref()?.scene;
        let fixed_ms = self.budget.fixed_ms.unwrap_or(f64::NAN);
        let effects: Vec<EffectBudget> = (self.budget.effects.iter())
            .map(|e| EffectBudget {
                name: e.name,
                chosen: scene.quality.level(e.name).unwrap_or(0).min(e.costs.levels.len() - 1),
                levels: (e.costs.levels.iter().enumerate())
                    .map(|(i, l)| LevelCost {
                        name: l.name.clone(),
                        error: l.error,
                        predicted_ms: e.costs.predicted(i),
                        measured: e.costs.is_measured(i),
                    })
                    .collect(),
            })
            .collect();
        let predicted_ms = fixed_ms + effects.iter().map(|e| e.levels[e.chosen].predicted_ms).sum::<f64>();
        Some(BudgetStatus {
            budget_ms,
            predicted_ms,
            fixed_ms,
            fits: predicted_ms <= budget_ms,
            frames_measured: self.budget.frames_measured,
            effects,
        })
    }

    /// Forgets the budget's measurements (a new scene).
    pub(super) fn reset_budget(&mut self) {
        self.budget.reset();
    }

    /// Before recording frame `next_frame`: with a budget, re-decides the levels every
    /// `DECIDE_EVERY` frames (the first time, every effect with levels starts at level 0 to be
    /// measured), applies a change, and remembers the levels the frame is recorded with.
    pub(super) fn apply_budget(&mut self) -> Result<(), Error> {
        let Some(budget) = self.budget_ms() else { return Ok(()) };
        let frame = self.next_frame;
        if self.budget.decided_at.is_none_or(|d| frame >= d + DECIDE_EVERY) {
            self.model_effects()?;
            let measured =
                self.budget.fixed_ms.is_some() && self.budget.effects.iter().all(|e| e.costs.has_scale());
            // Until every effect was measured the levels stay, and are asked for again next time
            // (not every frame: an effect's levels may walk the scene's meshes).
            self.budget.decided_at = Some(frame);
            let current = self.levels_in_use();
            let next = if measured {
                let options: Vec<Vec<(f64, f64)>> = (self.budget.effects.iter())
                    .map(|e| {
                        let levels = e.costs.levels.iter().enumerate();
                        levels.map(|(i, l)| (e.costs.predicted(i), l.error)).collect()
                    })
                    .collect();
                let choice = decide(budget, self.budget.fixed_ms.unwrap_or(0.0), &options, &current);
                choice.levels
            } else {
                current
            };
            let mut chosen = QualityChoice::default();
            for (e, &l) in self.budget.effects.iter().zip(&next) {
                chosen.set(e.name, Some(l));
            }
            if let Some(l) = self.loaded.as_mut().filter(|l| l.scene.quality != chosen) {
                l.scene.quality = chosen;
                // The material table may follow a level (translucency's TSM).
                l.tables_dirty = true;
                self.sync_passes()?;
            }
        }
        let levels = self.levels_in_use();
        let levels = self.budget.effects.iter().zip(levels).map(|(e, l)| (e.name, l)).collect();
        // A frame number recorded before and not submitted (an error) is recorded again.
        while self.budget.recorded.back().is_some_and(|(f, _)| *f >= frame) {
            self.budget.recorded.pop_back();
        }
        self.budget.recorded.push_back((frame, levels));
        while self.budget.recorded.len() > RECORDED_KEPT {
            self.budget.recorded.pop_front();
        }
        Ok(())
    }

    /// The modelled effects' levels on the scene (0 for one the budget has not chosen yet).
    fn levels_in_use(&self) -> Vec<usize> {
        let quality = self.loaded.as_ref().map(|l| &l.scene.quality);
        (self.budget.effects.iter())
            .map(|e| {
                let level = quality.and_then(|q| q.level(e.name));
                level.filter(|&l| l < e.costs.levels.len()).unwrap_or(0)
            })
            .collect()
    }

    /// The effects with levels for the world as it is now, each with its model (kept where the
    /// levels did not change).
    fn model_effects(&mut self) -> Result<(), Error> {
        let Some(loaded) = &self.loaded else { return Ok(()) };
        let mut effects = Vec::new();
        for effect in self.effects.iter() {
            let levels = effect.quality_levels(&loaded.scene);
            if levels.is_empty() {
                continue;
            }
            QualityLevel::check(&levels).map_err(|why| Error::InvalidUpdate {
                what: format!("the quality levels of effect {:?}", effect.name()),
                expected: why,
            })?;
            let costs = match self.budget.effects.iter().find(|m| m.name == effect.name()) {
                Some(m) if m.costs.levels == levels => m.costs.clone(),
                Some(m) => m.costs.with_levels(levels),
                None => EffectCosts::new(levels),
            };
            let passes = effect.passes().iter().map(|p| p.name).collect();
            effects.push(Modelled { name: effect.name(), passes, costs });
        }
        self.budget.effects = effects;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pass_is_charged_the_idle_time_before_it() {
        let pass =
            |name: &str, start_ms: f64, gpu_ms: f64| PassTiming { name: name.into(), start_ms, gpu_ms };
        // raster 0–2, 1 ms idle, light_id 3–9, translucency overlapping its end (8–10).
        let passes = [pass("raster", 0.0, 2.0), pass("light_id", 3.0, 6.0), pass("translucency", 8.0, 2.0)];
        assert_eq!(charged_ms(&passes), [2.0, 7.0, 2.0]);
        assert!(charged_ms(&[]).is_empty());
    }
}
