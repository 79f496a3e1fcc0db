//! A temporal upscaler's inputs (FSR 2, DLSS, a game's own TAA) as an effect: with motion vectors
//! on (`Renderer::set_motion_vectors`) its `motion` pass (crate::passes::motion) completes the
//! `motion`, `reactive` and `composition` images after the surfaces are drawn. The raster and the
//! energy wave write their own parts (variants they are built in when the world wants them).

use crate::effect::{Effect, EffectPass};
use crate::passes::motion::MotionPass;

/// The effect; registered between translucency and the energy wave (its pass reads every surface,
/// and the wave's glow writes the reactive mask after it).
#[derive(Clone, Copy, Debug)]
pub struct UpscalerInputs;

impl Effect for UpscalerInputs {
    fn name(&self) -> &'static str {
        "upscaler_inputs"
    }

    fn passes(&self) -> Vec<EffectPass> {
        vec![EffectPass::new(
            "motion",
            |s| s.render.motion_vectors,
            |b| Ok(Box::new(MotionPass::new(b.ctx, b.compiler)?)),
        )]
    }
}
