//! raster: instanced draws (one per mesh) with dynamic rendering into reverse-Z depth, HDR colour
//! and the G-buffer (normal, ids, view distance). Lambert + ambient under the directional lights,
//! plus the material's emission; alpha-masked fragments discarded. Meshes with glTF vertex
//! attributes (colours, texture coordinates) are drawn by a second pipeline, the same shaders
//! compiled with VERTEX_ATTRIBUTES and a second vertex buffer; every other mesh by the first,
//! which reads no attributes (its base colour is the albedo itself).

use super::{Binding, FrameContext, ImageUse, Pass, PassRecording};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::pipeline::{create_graphics_pipeline, Blend, Bound, GraphicsDesc, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::targets::Target;

pub struct RasterPass {
    pipeline: Pipeline,
    /// For meshes with `GpuMesh::attributes`.
    attributed: Pipeline,
}

/// Colour attachments in shader location order.
const COLOR_TARGETS: [Target; 4] = [Target::Hdr, Target::Normal, Target::Ids, Target::Distance];

impl RasterPass {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let (bindings, attributes) = crate::scene_gpu::vertex_input(true);
        let pipeline = Self::pipeline(ctx, compiler, "raster", &[], &bindings, &attributes)?;
        let (bindings, attributes) = crate::scene_gpu::attributed_vertex_input();
        let defines = [("VERTEX_ATTRIBUTES", "1")];
        let attributed =
            Self::pipeline(ctx, compiler, "raster (vertex attributes)", &defines, &bindings, &attributes)?;
        Ok(RasterPass { pipeline, attributed })
    }

    fn pipeline(
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        name: &'static str,
        defines: &[(&str, &str)],
        vertex_bindings: &[vk::VertexInputBindingDescription],
        vertex_attributes: &[vk::VertexInputAttributeDescription],
    ) -> GpuResult<Pipeline> {
        let vertex = compiler.compile("raster.vert", defines)?;
        let fragment = compiler.compile("raster.frag", defines)?;
        let color_formats = COLOR_TARGETS.map(Target::format);
        create_graphics_pipeline(
            ctx,
            &GraphicsDesc {
                name,
                vertex: &vertex,
                fragment: &fragment,
                push_constant_bytes: 0,
                vertex_bindings,
                vertex_attributes,
                color_formats: &color_formats,
                depth_format: Target::Depth.format(),
                // Reverse-Z: nearer is larger.
                depth_compare: vk::CompareOp::GREATER,
                // No culling: open meshes (planes) and mirrored instances must show both sides.
                cull_mode: vk::CullModeFlags::NONE,
                blend: Blend::Replace,
            },
        )
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
        vec![&self.pipeline, &self.attributed]
    }

    fn record(&self, pass: &PassRecording) {
        let rec = pass.rec;
        let t = pass.targets;
        let bg = (pass.scene.render.background * pass.pre_exposure).as_vec3();
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
        // The plain pipeline's draws, then those of meshes with vertex attributes.
        for (p, pipeline) in [&self.pipeline, &self.attributed].into_iter().enumerate() {
            let mut draws = pass
                .scene_gpu
                .draws
                .iter()
                .filter(|d| pass.scene_gpu.meshes[d.mesh].attributes.is_some() == (p == 1))
                .peekable();
            if draws.peek().is_none() {
                continue;
            }
            rec.bind_pipeline(pipeline, pass.set(p));
            for draw in draws {
                let mesh = &pass.scene_gpu.meshes[draw.mesh];
                if let Some(attributes) = &mesh.attributes {
                    rec.bind_vertex_buffer(1, attributes);
                }
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
