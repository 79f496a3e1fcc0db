//! motion: a temporal upscaler's inputs, completed after every pass that draws a surface and
//! before the energy wave (shaders/motion.comp). The raster writes its instances' motion itself
//! (from their vertices' previous positions, `raster`), and so does an effect that draws surfaces
//! (ids above the instances': the metaballs pass, `metaballs_motion`, from the balls of each
//! pixel's tile); this pass gives every pixel with no surface of hadou's the motion of a still
//! point (the game's depth; the sky: of the direction), the composition mask (translucent
//! surfaces) and clears the reactive mask, which the energy wave then writes. It knows no effect.

use glam::DMat4;

use super::gpu_structs::mat4_f32;
use super::{Binding, FrameContext, Pass, PassRecording};
use crate::gpu::pipeline::{create_compute_pipeline, Bound, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::targets::Target;

/// Keep in sync with `MotionUniforms` in shaders/common/motion.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MotionUniforms {
    /// This frame's view-projection and the previous frame's, both without the jitter, each
    /// composed in f64 with T(origin) (`MotionFrame::origin`, the camera's position): they map
    /// positions relative to the camera, so that far from the world's origin no f32 product
    /// cancels (a direction, w = 0, maps as before).
    pub view_proj: [[f32; 4]; 4],
    pub prev_view_proj: [[f32; 4]; 4],
    /// x: the scene's instances (ids above them are effects' surfaces), y, z, w: 0.
    pub counts: [u32; 4],
}

crate::gpu::layout::gpu_layout!(MotionUniforms as "MotionUniforms" { view_proj, prev_view_proj, counts });

impl MotionUniforms {
    /// The frame's (identity matrices without motion inputs: a frame recorded on its own).
    pub fn of(frame: &FrameContext) -> MotionUniforms {
        let (now, before) = frame.motion.map_or((DMat4::IDENTITY, DMat4::IDENTITY), |m| {
            let origin = DMat4::from_translation(m.origin);
            (m.view_proj * origin, m.prev_view_proj * origin)
        });
        MotionUniforms {
            view_proj: mat4_f32(now),
            prev_view_proj: mat4_f32(before),
            counts: [frame.scene.instances.len() as u32, 0, 0, 0],
        }
    }
}

pub struct MotionPass {
    pipeline: Pipeline,
    extent: vk::Extent2D,
}

impl MotionPass {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let spirv = compiler.compile("motion.comp", &[])?;
        Ok(MotionPass {
            pipeline: create_compute_pipeline(ctx, "motion", &spirv, 0)?,
            extent: vk::Extent2D::default(),
        })
    }
}

impl Pass for MotionPass {
    fn name(&self) -> &'static str {
        "motion"
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        self.extent = frame.extent;
        let uniforms = MotionUniforms::of(frame);
        Ok(vec![
            Binding::Bound(Bound::Uniform(frame.uniforms)),
            Binding::Bound(Bound::Storage(frame.materials)),
            Binding::read(Target::Distance),
            Binding::read(Target::Ids),
            Binding::read_write(Target::Motion),
            Binding::write(Target::Reactive),
            Binding::write(Target::Composition),
            Binding::Bound(Bound::Uniform(frame.upload(&[uniforms])?)),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline]
    }

    fn record(&self, pass: &PassRecording) {
        pass.rec.bind_pipeline(&self.pipeline, pass.set(0));
        pass.rec.dispatch_2d(self.extent.width, self.extent.height, (8, 8));
    }
}
