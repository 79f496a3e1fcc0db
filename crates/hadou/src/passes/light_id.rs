//! light_id: the translucent instances rendered from the scene's first directional light, with an
//! orthographic view fitted to their bounding sphere (`effects::translucency::LightView`), into
//! its own S² maps, S = `effects::translucency::light_map_size` (texels of at most a quarter of the
//! finest world voxel where 4096 texels suffice, 256 to 4096; independent of the frame's size, so
//! the light's sampling does not change with the output resolution; made again each frame as
//! instances move):
//! - `light_ids` (R32UI): instance id + 1 of the first translucent surface the light reaches, 0
//!   where the light crosses no translucent instance;
//! - `light_z` (R32F): that surface's light-space distance z = (p − C)·l + R (TSM's depth);
//! - `light_depth` (D32): the pass's own depth test (LESS, cleared to 1).
//!
//! Only translucent instances are drawn (opaque ones do not shadow the light), one draw per run of
//! consecutive translucent slots in the scene's instance table, with the faces turned away from
//! the light culled (translucent meshes are closed and outward-facing: the first surface along a
//! light ray faces the light; mirrored instances are drawn with the opposite culling). The maps
//! take 12 bytes a texel (12 MiB at 1024², 192 MiB at 4096²). The `translucency` pass reads them.

use std::sync::Arc;

use super::pipeline_memo::PipelineMemo;
use super::translucency::{LightDraw, LightViewData, TranslucentData, TranslucentFrame};
use super::{Binding, FrameContext, ImageUse, Pass, PassRecording};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::pipeline::{create_graphics_pipeline, Blend, Bound, GraphicsDesc, Pipeline};
use crate::gpu::recorder::ColorTarget;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::targets::Target;

/// Colour attachments in shader location order.
const COLOR_TARGETS: [Target; 2] = [Target::LightIds, Target::LightZ];

pub struct LightIdPass {
    /// Culling the faces turned away from the light: for instances as meshed, and mirrored ones.
    pipeline: Arc<Pipeline>,
    mirrored: Arc<Pipeline>,
    data: Arc<TranslucentData>,
    // This frame's light view, draws and map size (instances move).
    view: LightViewData,
    lit: bool,
    draws: Vec<LightDraw>,
    /// The maps' side in texels (`light_map_size`).
    size: u32,
}

impl LightIdPass {
    /// Its pipelines come from `memo` (made there the first time): a pass rebuilt on new tables
    /// compiles nothing.
    pub fn new(
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        memo: &PipelineMemo,
        data: Arc<TranslucentData>,
        scene: &crate::scene::Scene,
    ) -> GpuResult<Self> {
        let pipeline = memo.get_or_make("light_id", || Self::pipeline(ctx, compiler, false))?;
        let mirrored = memo.get_or_make("light_id mirrored", || Self::pipeline(ctx, compiler, true))?;
        // The light's radiance is not used here: any pre-exposure.
        let bounds = crate::effects::tonemap::mesh_bounds(scene);
        let now = TranslucentFrame::new(scene, &bounds, &data, 1.0);
        let (view, lit, draws, size) = (now.view_data, now.view.is_some(), now.draws, now.map_size);
        Ok(LightIdPass { pipeline, mirrored, data, view, lit, draws, size })
    }

    fn pipeline(ctx: &GpuContext, compiler: &mut ShaderCompiler, mirrored: bool) -> GpuResult<Pipeline> {
        let vertex = compiler.compile("light_id.vert", &[])?;
        let fragment = compiler.compile("light_id.frag", &[])?;
        // The scene's vertex buffers (position, normal); only the position is read.
        let (vertex_bindings, vertex_attributes) = crate::scene_gpu::vertex_input(false);
        let color_formats = COLOR_TARGETS.map(Target::format);
        create_graphics_pipeline(
            ctx,
            &GraphicsDesc {
                name: if mirrored { "light_id mirrored" } else { "light_id" },
                vertex: &vertex,
                fragment: &fragment,
                push_constant_bytes: std::mem::size_of::<LightViewData>() as u32,
                vertex_bindings: &vertex_bindings,
                vertex_attributes: &vertex_attributes,
                color_formats: &color_formats,
                depth_format: Target::LightDepth.format(),
                depth_compare: vk::CompareOp::LESS,
                // Translucent meshes are closed with outward faces (the scene checks it), so the
                // first surface along a light ray faces the light: cull the others. The light's
                // (right, up, dir) frame is left-handed, so faces toward the light wind clockwise
                // in framebuffer space: "back" to Vulkan's counter-clockwise front face.
                cull_mode: if mirrored { vk::CullModeFlags::BACK } else { vk::CullModeFlags::FRONT },
                blend: Blend::Replace,
            },
        )
    }
}

impl Pass for LightIdPass {
    fn name(&self) -> &'static str {
        "light_id"
    }

    fn images(&self) -> Vec<ImageUse> {
        let extent = Some(vk::Extent2D { width: self.size, height: self.size });
        let mut uses: Vec<_> = COLOR_TARGETS
            .iter()
            .map(|&t| ImageUse { target: t, access: ImageAccess::COLOR_ATTACHMENT, extent })
            .collect();
        uses.push(ImageUse { target: Target::LightDepth, access: ImageAccess::DEPTH_ATTACHMENT, extent });
        uses
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        // Instances may have moved: this frame's light view, draws and map size.
        let bounds = frame.scene_gpu.mesh_bounds();
        let now = TranslucentFrame::new(frame.scene, &bounds, &self.data, frame.pre_exposure);
        (self.view, self.lit, self.draws, self.size) =
            (now.view_data, now.view.is_some(), now.draws, now.map_size);
        Ok(vec![Binding::Bound(Bound::Storage(frame.instances))])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&*self.pipeline, &*self.mirrored]
    }

    fn record(&self, pass: &PassRecording) {
        let rec = pass.rec;
        let ids = pass.targets.image(Target::LightIds);
        let colors = [
            ColorTarget { view: ids.view, clear: vk::ClearColorValue { uint32: [0; 4] } },
            ColorTarget {
                view: pass.targets.image(Target::LightZ).view,
                clear: vk::ClearColorValue { float32: [f32::INFINITY, 0.0, 0.0, 0.0] },
            },
        ];
        rec.begin_rendering(ids.extent, &colors, pass.targets.image(Target::LightDepth).view, 1.0);
        if self.lit {
            for (i, (pipeline, mirrored)) in
                [(&self.pipeline, false), (&self.mirrored, true)].into_iter().enumerate()
            {
                let mut draws = self.draws.iter().filter(|d| d.mirrored == mirrored).peekable();
                if draws.peek().is_none() {
                    continue;
                }
                rec.bind_pipeline(pipeline, pass.set(i));
                rec.push_constants(pipeline, bytemuck::bytes_of(&self.view));
                for d in draws {
                    let mesh = &pass.scene_gpu.meshes[d.mesh];
                    rec.draw_mesh(mesh.vertex_buffer(), &mesh.indices, mesh.index_count, d.first, d.count);
                }
            }
        }
        rec.end_rendering();
    }
}
