//! raster: instanced draws (one per mesh) with dynamic rendering into reverse-Z depth, HDR colour
//! and the G-buffer (normal, ids, view distance). Lambert + ambient under the directional lights.

use super::{Binding, FrameContext, ImageUse, Pass, PassRecording};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::pipeline::{create_graphics_pipeline, Blend, Bound, GraphicsDesc, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::targets::Target;

pub struct RasterPass {
    pipeline: Pipeline,
}

/// Colour attachments in shader location order.
const COLOR_TARGETS: [Target; 4] = [Target::Hdr, Target::Normal, Target::Ids, Target::Distance];

impl RasterPass {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let vertex = compiler.compile("raster.vert", &[])?;
        let fragment = compiler.compile("raster.frag", &[])?;
        let (vertex_bindings, vertex_attributes) = crate::scene_gpu::vertex_input(true);
        let color_formats = COLOR_TARGETS.map(Target::format);
        let pipeline = create_graphics_pipeline(
            ctx,
            &GraphicsDesc {
                name: "raster",
                vertex: &vertex,
                fragment: &fragment,
                push_constant_bytes: 0,
                vertex_bindings: &vertex_bindings,
                vertex_attributes: &vertex_attributes,
                color_formats: &color_formats,
                depth_format: Target::Depth.format(),
                // Reverse-Z: nearer is larger.
                depth_compare: vk::CompareOp::GREATER,
                // No culling: open meshes (planes) and mirrored instances must show both sides.
                cull_mode: vk::CullModeFlags::NONE,
                blend: Blend::Replace,
            },
        )?;
        Ok(RasterPass { pipeline })
    }
}

impl Pass for RasterPass {
    fn name(&self) -> &'static str {
        "raster"
    }

    fn images(&self) -> Vec<ImageUse> {
        let mut uses: Vec<_> =
            COLOR_TARGETS.iter().map(|&t| ImageUse::new(t, ImageAccess::COLOR_ATTACHMENT)).collect();
        uses.push(ImageUse::new(Target::Depth, ImageAccess::DEPTH_ATTACHMENT));
        uses
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        Ok(vec![
            Binding::Bound(Bound::Uniform(frame.uniforms)),
            Binding::Bound(Bound::Storage(frame.instances)),
            Binding::Bound(Bound::Storage(frame.materials)),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline]
    }

    fn record(&self, pass: &PassRecording) {
        let rec = pass.rec;
        let t = pass.targets;
        let bg = pass.scene.render.background.as_vec3();
        // Embedded: transparent background (composited over the game's colour); with the game's
        // depth imported, depth and distance are loaded, not cleared.
        let hdr_clear = if pass.embedded { [0.0; 4] } else { [bg.x, bg.y, bg.z, 1.0] };
        let kept = |clear: vk::ClearValue| if pass.depth_imported { None } else { Some(clear) };
        let color = |float32| Some(vk::ClearValue { color: vk::ClearColorValue { float32 } });
        let colors = [
            (t.image(Target::Hdr).view, color(hdr_clear)),
            (t.image(Target::Normal).view, color([0.0; 4])),
            (
                t.image(Target::Ids).view,
                Some(vk::ClearValue { color: vk::ClearColorValue { uint32: [0; 4] } }),
            ),
            (
                t.image(Target::Distance).view,
                kept(vk::ClearValue {
                    color: vk::ClearColorValue { float32: [f32::INFINITY, 0.0, 0.0, 0.0] },
                }),
            ),
        ];
        let depth_clear =
            vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 0.0, stencil: 0 } };
        rec.begin_rendering_views(t.extent, &colors, Some((t.image(Target::Depth).view, kept(depth_clear))));
        if !pass.scene_gpu.draws.is_empty() {
            rec.bind_pipeline(&self.pipeline, pass.set(0));
            for draw in &pass.scene_gpu.draws {
                let mesh = &pass.scene_gpu.meshes[draw.mesh];
                rec.draw_mesh(
                    mesh.vertex_buffer(),
                    &mesh.indices,
                    mesh.index_count,
                    draw.first_instance,
                    draw.instance_count,
                );
            }
        }
        rec.end_rendering();
    }
}
