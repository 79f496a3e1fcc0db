//! A sky glow drawn by a full-screen **graphics** pass, to show an effect need not be compute: no
//! scene-file table (the game inserts its data with `Renderer::insert_effect`), one fragment
//! shader (glow.frag) built by `PassBuilder::fullscreen_pipeline` into hadou's `hdr` with
//! additive blending, and its f64 twin (`Glow::radiance`).

use glam::DVec3;
use hadou::effect::{
    Binding, Blend, Bound, Effect, EffectPass, FrameContext, GpuResult, ImageAccess, ImageUse, Pass,
    PassBuilder, PassRecording, Pipeline, Target,
};
use hadou::scene::Scene;

/// The glow's world data.
#[derive(Clone, Debug, PartialEq)]
pub struct Glow {
    /// Where the glow is brightest (any non-zero length).
    pub direction: DVec3,
    /// Linear RGB radiance towards `direction`, each channel in 0..=65504.
    pub color: DVec3,
}

impl Glow {
    /// The f64 twin of glow.frag: the radiance added where the unit ray `u` sees no surface.
    pub fn radiance(&self, u: DVec3) -> DVec3 {
        self.color * u.dot(self.direction.normalize()).max(0.0).powi(2)
    }

    fn is_valid(&self) -> bool {
        let unit = self.direction.normalize_or_zero();
        self.direction.is_finite()
            && unit != DVec3::ZERO
            && self.color.is_finite()
            && self.color.min_element() >= 0.0
            && self.color.max_element() <= 65504.0
    }
}

/// The effect: `Effects::builtin().with(SkyGlow)`, then `insert_effect("sky_glow", Glow { .. })`.
#[derive(Clone, Copy, Debug)]
pub struct SkyGlow;

impl Effect for SkyGlow {
    fn name(&self) -> &'static str {
        "sky_glow"
    }

    fn passes(&self) -> Vec<EffectPass> {
        vec![EffectPass::new(
            "sky_glow",
            |s| s.effects.get::<Glow>().is_some(),
            |b| Ok(Box::new(GlowPass::new(b)?)),
        )]
    }

    fn check(&self, scene: &Scene) -> Result<(), String> {
        match scene.effects.get::<Glow>() {
            Some(glow) if !glow.is_valid() => {
                Err(format!("a finite non-zero direction and a colour in 0..=65504 (found {glow:?})"))
            }
            _ => Ok(()),
        }
    }
}

/// Push constants of glow.frag.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GlowParams {
    /// rgb: pre-exposed radiance.
    pub color: [f32; 4],
    /// xyz: the unit direction.
    pub direction: [f32; 4],
}

impl GlowParams {
    /// What the shader is given for `glow` in a frame pre-exposed by `pre_exposure`.
    pub fn new(glow: &Glow, pre_exposure: f64) -> Self {
        let (c, s) = (glow.color * pre_exposure, glow.direction.normalize());
        GlowParams {
            color: [c.x as f32, c.y as f32, c.z as f32, 0.0],
            direction: [s.x as f32, s.y as f32, s.z as f32, 0.0],
        }
    }
}

struct GlowPass {
    pipeline: Pipeline,
    params: GlowParams,
}

impl GlowPass {
    fn new(b: &mut PassBuilder) -> GpuResult<Self> {
        let push = std::mem::size_of::<GlowParams>() as u32;
        let pipeline =
            b.fullscreen_pipeline("sky_glow", include_str!("glow.frag"), push, Target::Hdr, Blend::Add)?;
        Ok(GlowPass { pipeline, params: GlowParams::default() })
    }
}

impl Pass for GlowPass {
    fn name(&self) -> &'static str {
        "sky_glow"
    }

    // The render target is no binding: declared here. The distance is declared by its binding.
    fn images(&self) -> Vec<ImageUse> {
        vec![ImageUse::new(Target::Hdr, ImageAccess::COLOR_ATTACHMENT)]
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        if let Some(glow) = frame.scene.effects.get::<Glow>() {
            self.params = GlowParams::new(glow, frame.pre_exposure);
        }
        let distance = ImageUse::new(Target::Distance, ImageAccess::FRAGMENT_READ);
        Ok(vec![Binding::Image(distance), Binding::Bound(Bound::Uniform(frame.uniforms))])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline]
    }

    fn record(&self, pass: &PassRecording) {
        let rec = pass.rec;
        let hdr = pass.targets.image(Target::Hdr);
        rec.begin_rendering_views(pass.targets.extent, &[(hdr.view, None)], None);
        rec.bind_pipeline(&self.pipeline, pass.set(0));
        rec.push_constants(&self.pipeline, bytemuck::bytes_of(&self.params));
        rec.draw_fullscreen();
        rec.end_rendering();
    }
}
