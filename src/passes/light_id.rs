//! light_id: the translucent instances rendered from the scene's first directional light, with an
//! orthographic view fitted to their bounding sphere (`effects::translucency::LightView`), into
//! its own S² maps, S = `effects::translucency::light_map_size` (texels of at most a quarter of the
//! finest world voxel, 256 to 1024; independent of the frame's size, so the light's sampling does
//! not change with the output resolution):
//! - `light_ids` (RG32UI): (instance id + 1, surface voxel) of the first translucent surface the
//!   light reaches; the voxel is the nearest-grid lookup at the fragment's object-space position
//!   (`ThicknessLut::surface_voxel_at`; the translucency pass takes it as the first candidate for
//!   the path's entry end), `NO_LUT` for instances drawn with `thickness = "tsm"`; (0, 0) where
//!   the light crosses no translucent instance;
//! - `light_z` (R32F): that surface's light-space distance z = (p − C)·l + R (TSM's depth);
//! - `light_depth` (D32): the pass's own depth test (LESS, cleared to 1).
//!
//! Only translucent instances are drawn (opaque ones do not shadow the light), one draw per run of
//! consecutive translucent slots in the scene's instance table, with the faces turned away from
//! the light culled (translucent meshes are closed and outward-facing: the first surface along a
//! light ray faces the light; mirrored instances are drawn with the opposite culling). At 1024²
//! the maps take 16 MiB (8 + 4 + 4 bytes a texel). The `translucency` pass reads them.

use std::sync::Arc;

use super::translucency::{release, LightViewData, TranslucentData};
use super::{Pass, PassInputs};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::memory::Memory;
use crate::gpu::pipeline::{
    binding, create_graphics_pipeline, write_set, Blend, Bound, DescriptorPool, GraphicsDesc, Pipeline,
};
use crate::gpu::recorder::ColorTarget;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene_gpu::SceneGpu;
use crate::targets::{Target, Targets};

/// Colour attachments in shader location order.
const COLOR_TARGETS: [Target; 2] = [Target::LightIds, Target::LightZ];

pub struct LightIdPass {
    /// Culling the faces turned away from the light: for instances as meshed, and mirrored ones.
    pipeline: Pipeline,
    mirrored: Pipeline,
    set: vk::DescriptorSet,
    data: Option<Arc<TranslucentData>>,
    view: LightViewData,
}

impl LightIdPass {
    pub fn new(
        ctx: &GpuContext,
        memory: &Memory,
        compiler: &mut ShaderCompiler,
        data: Arc<TranslucentData>,
    ) -> GpuResult<Self> {
        let pipelines =
            Self::pipeline(ctx, compiler, false).and_then(|p| match Self::pipeline(ctx, compiler, true) {
                Ok(m) => Ok((p, m)),
                Err(e) => {
                    p.destroy(ctx);
                    Err(e)
                }
            });
        match pipelines {
            Ok((pipeline, mirrored)) => {
                let view = data.view_data();
                let set = vk::DescriptorSet::null();
                Ok(LightIdPass { pipeline, mirrored, set, data: Some(data), view })
            }
            Err(e) => {
                release(Some(data), ctx, memory);
                Err(e)
            }
        }
    }

    fn pipeline(ctx: &GpuContext, compiler: &mut ShaderCompiler, mirrored: bool) -> GpuResult<Pipeline> {
        let vertex = compiler.compile("light_id.vert", &[])?;
        let fragment = compiler.compile("light_id.frag", &[])?;
        let frag = vk::ShaderStageFlags::FRAGMENT;
        let bindings = [
            binding(0, vk::DescriptorType::STORAGE_BUFFER, vk::ShaderStageFlags::VERTEX),
            binding(1, vk::DescriptorType::UNIFORM_TEXEL_BUFFER, frag),
            binding(2, vk::DescriptorType::UNIFORM_TEXEL_BUFFER, frag),
            binding(3, vk::DescriptorType::UNIFORM_TEXEL_BUFFER, frag),
        ];
        // The scene's vertex buffers (position, normal); only the position is read.
        let vertex_bindings = [vk::VertexInputBindingDescription::default()
            .binding(0)
            .stride(24)
            .input_rate(vk::VertexInputRate::VERTEX)];
        let vertex_attributes = [vk::VertexInputAttributeDescription::default()
            .location(0)
            .format(vk::Format::R32G32B32_SFLOAT)
            .offset(0)];
        let color_formats = COLOR_TARGETS.map(Target::format);
        create_graphics_pipeline(
            ctx,
            &GraphicsDesc {
                name: if mirrored { "light_id mirrored" } else { "light_id" },
                vertex: &vertex,
                fragment: &fragment,
                bindings: &bindings,
                push_constant_bytes: std::mem::size_of::<LightViewData>() as u32,
                push_stages: vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
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

    fn uses(&self) -> Vec<(Target, ImageAccess)> {
        let mut uses: Vec<_> = COLOR_TARGETS.iter().map(|&t| (t, ImageAccess::COLOR_ATTACHMENT)).collect();
        uses.push((Target::LightDepth, ImageAccess::DEPTH_ATTACHMENT));
        uses
    }

    fn bind(
        &mut self,
        ctx: &GpuContext,
        pool: &DescriptorPool,
        scene_gpu: &SceneGpu,
        _: &Targets,
    ) -> GpuResult<()> {
        let Some(data) = &self.data else { return Ok(()) };
        self.set = pool.allocate(ctx, self.pipeline.set_layout, "light_id set")?;
        write_set(
            ctx,
            self.set,
            &[
                (0, Bound::Storage(scene_gpu.instances.raw)),
                (1, Bound::UniformTexel(data.grid.view)),
                (2, Bound::UniformTexel(data.records.view)),
                (3, Bound::UniformTexel(data.instances.view)),
            ],
        );
        Ok(())
    }

    fn record(&self, inputs: &PassInputs) {
        let Some(data) = &self.data else { return };
        let rec = inputs.rec;
        let ids = inputs.targets.image(Target::LightIds);
        let colors = [
            ColorTarget { image: ids, clear: vk::ClearColorValue { uint32: [0; 4] } },
            ColorTarget {
                image: inputs.targets.image(Target::LightZ),
                clear: vk::ClearColorValue { float32: [f32::INFINITY, 0.0, 0.0, 0.0] },
            },
        ];
        rec.begin_rendering(ids.extent, &colors, inputs.targets.image(Target::LightDepth), 1.0);
        if data.view.is_some() {
            let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
            for (pipeline, mirrored) in [(&self.pipeline, false), (&self.mirrored, true)] {
                let mut draws = data.draws.iter().filter(|d| d.mirrored == mirrored).peekable();
                if draws.peek().is_none() {
                    continue;
                }
                rec.bind_pipeline(pipeline, self.set);
                rec.push_constants(pipeline, stages, bytemuck::bytes_of(&self.view));
                for d in draws {
                    let mesh = &inputs.scene_gpu.meshes[d.mesh];
                    rec.draw_mesh(&mesh.vertices, &mesh.indices, mesh.index_count, d.first, d.count);
                }
            }
        }
        rec.end_rendering();
    }

    fn destroy(&mut self, ctx: &GpuContext, memory: &Memory) {
        self.pipeline.destroy(ctx);
        self.mirrored.destroy(ctx);
        release(self.data.take(), ctx, memory);
    }
}
