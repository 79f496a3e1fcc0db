//! raster: instanced draws (one per mesh) with dynamic rendering into reverse-Z depth, HDR colour
//! and the G-buffer (normal, ids, view distance). Lambert + ambient under the directional lights.

use super::{Pass, PassInputs};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::memory::Memory;
use crate::gpu::pipeline::{
    binding, create_graphics_pipeline, write_set, Blend, Bound, DescriptorPool, GraphicsDesc, Pipeline,
};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene_gpu::SceneGpu;
use crate::targets::{Target, Targets};

pub struct RasterPass {
    pipeline: Pipeline,
    set: vk::DescriptorSet,
}

/// Colour attachments in shader location order.
const COLOR_TARGETS: [Target; 4] = [Target::Hdr, Target::Normal, Target::Ids, Target::Distance];

impl RasterPass {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let vertex = compiler.compile("raster.vert", &[])?;
        let fragment = compiler.compile("raster.frag", &[])?;
        let both = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let bindings = [
            binding(0, vk::DescriptorType::UNIFORM_BUFFER, both),
            binding(1, vk::DescriptorType::STORAGE_BUFFER, vk::ShaderStageFlags::VERTEX),
            binding(2, vk::DescriptorType::STORAGE_BUFFER, vk::ShaderStageFlags::VERTEX),
        ];
        let vertex_bindings = [vk::VertexInputBindingDescription::default()
            .binding(0)
            .stride(24)
            .input_rate(vk::VertexInputRate::VERTEX)];
        let vertex_attributes = [
            vk::VertexInputAttributeDescription::default()
                .location(0)
                .format(vk::Format::R32G32B32_SFLOAT)
                .offset(0),
            vk::VertexInputAttributeDescription::default()
                .location(1)
                .format(vk::Format::R32G32B32_SFLOAT)
                .offset(12),
        ];
        let color_formats = COLOR_TARGETS.map(Target::format);
        let pipeline = create_graphics_pipeline(
            ctx,
            &GraphicsDesc {
                name: "raster",
                vertex: &vertex,
                fragment: &fragment,
                bindings: &bindings,
                push_constant_bytes: 0,
                push_stages: vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
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
        Ok(RasterPass { pipeline, set: vk::DescriptorSet::null() })
    }
}

impl Pass for RasterPass {
    fn name(&self) -> &'static str {
        "raster"
    }

    fn uses(&self) -> Vec<(Target, ImageAccess)> {
        let mut uses: Vec<_> = COLOR_TARGETS.iter().map(|&t| (t, ImageAccess::COLOR_ATTACHMENT)).collect();
        uses.push((Target::Depth, ImageAccess::DEPTH_ATTACHMENT));
        uses
    }

    fn bind(
        &mut self,
        ctx: &GpuContext,
        pool: &DescriptorPool,
        scene_gpu: &SceneGpu,
        _: &Targets,
    ) -> GpuResult<()> {
        self.set = pool.allocate(ctx, self.pipeline.set_layout, "raster set")?;
        write_set(
            ctx,
            self.set,
            &[
                (0, Bound::Uniform(scene_gpu.uniforms.raw)),
                (1, Bound::Storage(scene_gpu.instances.raw)),
                (2, Bound::Storage(scene_gpu.materials.raw)),
            ],
        );
        Ok(())
    }

    fn record(&self, inputs: &PassInputs) {
        let rec = inputs.rec;
        let t = inputs.targets;
        let bg = inputs.scene.render.background.as_vec3();
        // Embedded: transparent background (composited over the game's colour); with the game's
        // depth imported, depth and distance are loaded, not cleared.
        let hdr_clear = if inputs.embedded { [0.0; 4] } else { [bg.x, bg.y, bg.z, 1.0] };
        let kept = |clear: vk::ClearValue| if inputs.depth_imported { None } else { Some(clear) };
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
        if !inputs.scene_gpu.draws.is_empty() {
            rec.bind_pipeline(&self.pipeline, self.set);
            for draw in &inputs.scene_gpu.draws {
                let mesh = &inputs.scene_gpu.meshes[draw.mesh];
                rec.draw_mesh(
                    &mesh.vertices,
                    &mesh.indices,
                    mesh.index_count,
                    draw.first_instance,
                    draw.instance_count,
                );
            }
        }
        rec.end_rendering();
    }

    fn destroy(&mut self, ctx: &GpuContext, _: &Memory) {
        self.pipeline.destroy(ctx);
    }
}
