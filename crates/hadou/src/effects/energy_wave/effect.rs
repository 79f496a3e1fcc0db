//! The energy wave as an effect (`crate::effect`), registered like any other: it reads the
//! `[[wave]]` tables (file.rs) into its world data, `Waves`, kept in `Scene::effects`, and runs the
//! `energy_wave` pass while the world has a wave. `Scene::waves()` / `waves_mut()` are shorthands
//! for that data.

use super::file;
use crate::effect::{Effect, EffectPass, EffectState, QualityLevel, SceneFile};
use crate::passes::energy_wave::{variant, EnergyWavePass};
use crate::scene::file_schema::{Tables, WaveDef};
use crate::scene::{Scene, SceneError, Wave};

/// Seed 004: `[[wave]]`s, the closed-form line integral of an emissive volume along view rays.
#[derive(Clone, Copy, Debug)]
pub struct EnergyWave;

/// The energy wave's world data: the waves of the file (in file order), then those spawned.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Waves(pub Vec<Wave>);

/// The effect's name: its key in `Scene::effects`.
const NAME: &str = "energy_wave";

impl Effect for EnergyWave {
    fn name(&self) -> &'static str {
        NAME
    }

    fn tables(&self) -> &'static [&'static str] {
        &["wave"]
    }

    fn load(&self, file: &SceneFile) -> Result<Option<Box<dyn EffectState>>, SceneError> {
        let Some(defs) = file.table::<Tables<WaveDef>>("wave")? else { return Ok(None) };
        Ok(Some(Box::new(Waves(file::waves(file.ctx(), defs.get_ref())?))))
    }

    fn passes(&self) -> Vec<EffectPass> {
        vec![EffectPass::new(
            "energy_wave",
            |s| !s.waves().is_empty(),
            |b| {
                let v = variant(b.scene);
                let (tolerance, reactive) = (v.starts_with("tolerance"), v.ends_with("reactive"));
                Ok(Box::new(EnergyWavePass::new(b.ctx, b.compiler, tolerance, reactive)?))
            },
        )
        .with_variant(variant)]
    }

    /// The tolerance τ of every analytic wave without a cutoff ([`BUDGET_LEVELS`]): τ bounds the
    /// relative error of H per pixel (`tolerance.rs`, tested on hard rays). A wave with a cutoff
    /// (no relative bound near it) or ray-marched keeps its own setting; none of those: no levels.
    fn quality_levels(&self, scene: &Scene) -> Vec<QualityLevel> {
        if !scene.waves().iter().any(takes_budget) {
            return Vec::new();
        }
        BUDGET_LEVELS
            .iter()
            .map(|&(tolerance, hint)| {
                let name = if tolerance == 0.0 { "exact".to_string() } else { format!("τ={tolerance:e}") };
                QualityLevel::new(name, tolerance, hint)
            })
            .collect()
    }
}

/// The frame budget's levels: (tolerance, cost over the exact pass's before it is measured). The
/// priors are the seed's 512² speed-ups (docs/PERFORMANCE.md, "Energy wave with a tolerance").
pub const BUDGET_LEVELS: [(f64, f64); 4] = [(0.0, 1.0), (1e-4, 0.95), (1e-3, 0.8), (1e-2, 0.65)];

/// Whether the budget sets a wave's tolerance: analytic, without a cutoff.
fn takes_budget(wave: &Wave) -> bool {
    wave.method == crate::scene::WaveMethod::Analytic && wave.cutoff == 0.0
}

/// The tolerance a wave is evaluated at: the frame budget's level where it chose one and the
/// wave takes it, else the wave's own (`Wave::effective_tolerance`).
pub fn wave_tolerance(scene: &Scene, wave: &Wave) -> f64 {
    match scene.quality.level(NAME).and_then(|l| BUDGET_LEVELS.get(l)) {
        Some(&(tolerance, _)) if takes_budget(wave) => tolerance,
        _ => wave.effective_tolerance(),
    }
}

impl Scene {
    /// The energy waves (`[[wave]]` and spawned), in order; empty when the world has none.
    pub fn waves(&self) -> &[Wave] {
        self.effects.get::<Waves>().map_or(&[], |w| &w.0)
    }

    /// The waves, to change; the energy wave's data is added to the scene when it had none.
    pub fn waves_mut(&mut self) -> &mut Vec<Wave> {
        &mut self.effects.get_or_insert_with(NAME, Waves::default).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The budget's level sets the tolerance of analytic waves without a cutoff; a wave with a
    /// cutoff keeps its own (exact by default) and a scene of only such waves has no levels.
    #[test]
    fn budget_levels_set_the_tolerance_of_waves_that_take_it() {
        let mut scene = crate::builtin::scene("budget").unwrap();
        assert_eq!(EnergyWave.quality_levels(&scene).len(), BUDGET_LEVELS.len());
        let plain = scene.waves()[0].clone();
        let mut cut = plain.clone();
        cut.cutoff = 1.0;
        assert_eq!(wave_tolerance(&scene, &plain), plain.effective_tolerance());
        scene.quality.set(NAME, Some(3));
        assert_eq!(wave_tolerance(&scene, &plain), 1e-2);
        assert_eq!(wave_tolerance(&scene, &cut), 0.0);
        scene.waves_mut()[0] = cut;
        assert!(EnergyWave.quality_levels(&scene).is_empty());
    }
}
