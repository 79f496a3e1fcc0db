//! hadou's own effects, registered through the same `Effect` API a game's effect uses, and the
//! core frame's raster. Their scene-file tables (`[[wave]]`, `[[metaballs]]`, translucent
//! `[[material]]`s) are still read by hadou's scene format into `Scene`'s own fields.
//!
//! Frame order: the raster first (it clears the G-buffer every later pass reads); metaballs right
//! after it, whose images they bind (on lavapipe a dispatch waits only for the render passes that
//! wrote what it binds, so after light_id it would overlap light_id's rasterizing and its
//! timestamps would straddle the wrong work); light_id (the light's view of translucent
//! instances), peel (the peel instances' crossing lists), translucency (reads what raster and
//! metaballs wrote), with motion vectors on the upscaler's `motion` pass (every surface drawn),
//! the energy wave last, adding on top.

use std::sync::Arc;

use super::{Effect, EffectPass, PassBuilder};
use crate::effects::energy_wave::EnergyWave;
use crate::effects::metaballs::Metaballs;
use crate::effects::upscaler::UpscalerInputs;
use crate::gpu::GpuResult;
use crate::passes::light_id::LightIdPass;
use crate::passes::peel::{self, PeelPass};
use crate::passes::pipeline_memo::PipelineMemo;
use crate::passes::raster::RasterPass;
use crate::passes::translucency::{self, TranslucencyPass, TranslucentData};
use crate::passes::Pass;
use crate::scene::{MaterialKind, Scene};

fn boxed(pass: impl Pass + 'static) -> Box<dyn Pass> {
    Box::new(pass)
}

/// The core frame's scene pass: the raster, always (with a temporal upscaler's motion when the
/// world wants it).
pub(super) fn core_passes() -> Vec<EffectPass> {
    let motion = |s: &Scene| if s.render.motion_vectors { "motion".to_string() } else { String::new() };
    vec![EffectPass::new(
        "raster",
        |_| true,
        |b| Ok(boxed(RasterPass::new(b.ctx, b.compiler, b.scene.render.motion_vectors)?)),
    )
    .with_variant(motion)]
}

pub(super) fn effects() -> Vec<Arc<dyn Effect>> {
    vec![
        Arc::new(Metaballs::default()),
        Arc::new(Translucency),
        Arc::new(UpscalerInputs),
        Arc::new(EnergyWave),
    ]
}

/// Seed 003: translucent materials, exp(−σ·d) with d from the thickness LUT, shadow maps or peel.
#[derive(Clone, Copy, Debug)]
pub struct Translucency;

fn translucent_data(b: &mut PassBuilder) -> GpuResult<Arc<TranslucentData>> {
    b.shared(TranslucentData::new)
}

/// The scene's pipeline memo: kept when the tables are replaced, so the passes rebuilt on the
/// new ones take their pipelines back (no compile in the frame that puts a bake in use).
fn memo(b: &mut PassBuilder) -> GpuResult<Arc<PipelineMemo>> {
    b.shared_untracked(|_, _, _| Ok(PipelineMemo::default()))
}

impl Effect for Translucency {
    fn name(&self) -> &'static str {
        "translucency"
    }

    /// Translucent materials are shaded as opaque ones of the same albedo.
    fn switch_off(&self, scene: &mut Scene) {
        for material in &mut scene.materials {
            if matches!(material.kind, MaterialKind::Translucent { .. }) {
                material.kind = MaterialKind::Lambert;
            }
        }
    }

    /// The light map's size, then TSM instead of the tables (`effects::translucency_budget`).
    fn quality_levels(&self, scene: &Scene) -> Vec<crate::budget::QualityLevel> {
        crate::effects::translucency_budget::budget_levels(scene)
    }

    fn passes(&self) -> Vec<EffectPass> {
        vec![
            EffectPass::new("light_id", translucency::needed, |b| {
                let data = translucent_data(b)?;
                let memo = memo(b)?;
                Ok(boxed(LightIdPass::new(b.ctx, b.compiler, &memo, data, b.scene)?))
            }),
            EffectPass::new("peel", peel::needed, |b| Ok(boxed(PeelPass::new(b.ctx, b.compiler, b.scene)?))),
            EffectPass::new("translucency", translucency::needed, |b| {
                let data = translucent_data(b)?;
                let (lut, peel) = (translucency::reads_lut(b.scene), peel::needed(b.scene));
                let memo = memo(b)?;
                Ok(boxed(TranslucencyPass::new(b.ctx, b.compiler, &memo, data, lut, peel)?))
            })
            // With or without the field's march and the peel lists.
            .with_variant(translucency::variant),
        ]
    }
}
