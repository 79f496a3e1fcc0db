//! raster: instanced draws (one per mesh) with dynamic rendering into reverse-Z depth, HDR colour
//! and the G-buffer (normal, ids, view distance). Lambert + ambient under the directional lights,
//! plus the material's emission; alpha-masked fragments discarded. Meshes with glTF vertex
//! attributes (colours, texture coordinates) are drawn by a second pipeline, the same shaders
//! compiled with VERTEX_ATTRIBUTES and a second vertex buffer; every other mesh by the first,
//! which reads no attributes (its base colour is the albedo itself). Instances of a material with
//! textures (`scene_textures`) are drawn by a third pipeline, compiled with MATERIAL_TEXTURES too:
//! between its draws the material's texture set (set 1) and its coordinate maps (push constants)
//! are bound, one run of consecutive instances of a mesh per material.

use super::motion::MotionUniforms;
use super::{Binding, FrameContext, ImageUse, Pass, PassRecording};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::pipeline::{
    create_graphics_pipeline_with_sets, Blend, Bound, BufferRange, GraphicsDesc, Pipeline,
};
use crate::gpu::set_layout::SetLayout;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene_textures::{texture_set_layout, TexturePush};
use crate::targets::Target;

pub struct RasterPass {
    pipeline: Pipeline,
    /// For meshes with `GpuMesh::attributes`.
    attributed: Pipeline,
    /// For meshes with attributes whose instances' material has textures.
    textured: Pipeline,
    /// Set 1 of `textured` (the sets themselves are the scene's: `SceneTextures`).
    _texture_layout: SetLayout,
    /// Writes a temporal upscaler's motion too (MOTION): each vertex's previous position at
    /// vertex binding 2, the mesh's own vertices or, once deformed, its previous ones (per mesh,
    /// uploaded this frame).
    motion: bool,
    prev_vertices: Vec<Option<BufferRange>>,
}

/// Colour attachments in shader location order.
const COLOR_TARGETS: [Target; 4] = [Target::Hdr, Target::Normal, Target::Ids, Target::Distance];

impl RasterPass {
    /// The pass; with `motion`, a temporal upscaler's motion written too.
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler, motion: bool) -> GpuResult<Self> {
        let with = |defines: &[(&'static str, &'static str)]| {
            let mut all = defines.to_vec();
            if motion {
                all.push(("MOTION", "1"));
            }
            all
        };
        let (bindings, attributes) = crate::scene_gpu::vertex_input(true);
        let (bindings, attributes) = previous_positions(motion, bindings.to_vec(), attributes);
        let pipeline = Self::pipeline(ctx, compiler, "raster", &with(&[]), &bindings, &attributes, motion)?;
        let (bindings, attributes) = crate::scene_gpu::attributed_vertex_input();
        let (bindings, attributes) = previous_positions(motion, bindings.to_vec(), attributes);
        let defines = with(&[("VERTEX_ATTRIBUTES", "1")]);
        let attributed = Self::pipeline(
            ctx,
            compiler,
            "raster (vertex attributes)",
            &defines,
            &bindings,
            &attributes,
            motion,
        )?;
        let layout = texture_set_layout(ctx)?;
        let defines = with(&[("VERTEX_ATTRIBUTES", "1"), ("MATERIAL_TEXTURES", "1")]);
        let textured = Self::pipeline_with(
            ctx,
            compiler,
            "raster (textures)",
            &defines,
            (&bindings, &attributes),
            std::mem::size_of::<TexturePush>() as u32,
            (&[layout.raw], motion),
        )?;
        let prev_vertices = Vec::new();
        Ok(RasterPass { pipeline, attributed, textured, _texture_layout: layout, motion, prev_vertices })
    }

    fn color_targets(motion: bool) -> Vec<Target> {
        let mut all = COLOR_TARGETS.to_vec();
        if motion {
            all.push(Target::Motion);
        }
        all
    }

    fn pipeline(
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        name: &'static str,
        defines: &[(&str, &str)],
        vertex_bindings: &[vk::VertexInputBindingDescription],
        vertex_attributes: &[vk::VertexInputAttributeDescription],
        motion: bool,
    ) -> GpuResult<Pipeline> {
        Self::pipeline_with(
            ctx,
            compiler,
            name,
            defines,
            (vertex_bindings, vertex_attributes),
            0,
            (&[], motion),
        )
    }

    fn pipeline_with(
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        name: &'static str,
        defines: &[(&str, &str)],
        (vertex_bindings, vertex_attributes): (
            &[vk::VertexInputBindingDescription],
            &[vk::VertexInputAttributeDescription],
        ),
        push_constant_bytes: u32,
        (extra_sets, motion): (&[vk::DescriptorSetLayout], bool),
    ) -> GpuResult<Pipeline> {
        let vertex = compiler.compile("raster.vert", defines)?;
        let fragment = compiler.compile("raster.frag", defines)?;
        let color_formats: Vec<vk::Format> =
            Self::color_targets(motion).into_iter().map(Target::format).collect();
        create_graphics_pipeline_with_sets(
            ctx,
            &GraphicsDesc {
                name,
                vertex: &vertex,
                fragment: &fragment,
                push_constant_bytes,
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
            extra_sets,
        )
    }
}

impl Pass for RasterPass {
    fn name(&self) -> &'static str {
        "raster"
    }

    fn images(&self) -> Vec<ImageUse> {
        let mut uses: Vec<_> = Self::color_targets(self.motion)
            .into_iter()
            .map(|t| ImageUse::new(t, ImageAccess::COLOR_ATTACHMENT))
            .collect();
        uses.push(ImageUse::new(Target::Depth, ImageAccess::DEPTH_ATTACHMENT));
        uses
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let mut bindings = vec![
            Binding::Bound(Bound::Uniform(frame.uniforms)),
            Binding::Bound(Bound::Storage(frame.instances)),
            Binding::Bound(Bound::Storage(frame.materials)),
        ];
        if self.motion {
            // A deformed mesh's previous vertices, uploaded for this frame; others read their own.
            let meshes = &frame.scene_gpu.meshes;
            let mut prev = Vec::with_capacity(meshes.len());
            for m in meshes {
                prev.push(match m.previous_vertices() {
                    Some(bytes) => Some(frame.upload(bytes)?),
                    None => None,
                });
            }
            self.prev_vertices = prev;
            let models = match frame.motion {
                Some(m) => m.models,
                // A frame without a previous one: its own models twice (no motion).
                None => {
                    let models: Vec<[[f32; 4]; 4]> =
                        frame.scene_gpu.instance_table().iter().flat_map(|i| [i.model, i.model]).collect();
                    frame.upload(&models)?
                }
            };
            let uniforms = MotionUniforms::of(frame);
            bindings.push(Binding::Bound(Bound::Uniform(frame.upload(&[uniforms])?)));
            bindings.push(Binding::Bound(Bound::Storage(models)));
        }
        Ok(bindings)
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline, &self.attributed, &self.textured]
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
        let mut colors = colors.to_vec();
        if self.motion {
            colors.push((t.image(Target::Motion).view, color([0.0; 4])));
        }
        let depth_clear =
            vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 0.0, stencil: 0 } };
        rec.begin_rendering_views(t.extent, &colors, Some((t.image(Target::Depth).view, kept(depth_clear))));
        // The plain pipeline's draws, then those of meshes with vertex attributes, then those of
        // textured materials' instances (on meshes with attributes), one run per material.
        let gpu = pass.scene_gpu;
        let runs = |d: &crate::scene_gpu::Draw| texture_runs(gpu, d);
        for (p, pipeline) in [&self.pipeline, &self.attributed, &self.textured].into_iter().enumerate() {
            let mut draws = gpu
                .draws
                .iter()
                .flat_map(|d| {
                    let attributed = gpu.meshes[d.mesh].attributes.is_some();
                    let split =
                        if attributed { runs(d) } else { vec![(None, d.first_instance, d.instance_count)] };
                    split.into_iter().map(move |(set, first, count)| (d.mesh, set, first, count))
                })
                .filter(|&(mesh, set, ..)| {
                    let attributed = gpu.meshes[mesh].attributes.is_some();
                    p == if !attributed {
                        0
                    } else if set.is_none() {
                        1
                    } else {
                        2
                    }
                })
                .peekable();
            if draws.peek().is_none() {
                continue;
            }
            rec.bind_pipeline(pipeline, pass.set(p));
            let mut bound = None;
            for (m, set, first, count) in draws {
                if let Some(i) = set.filter(|&i| bound != Some(i)) {
                    let (descriptors, push) = gpu.textures.set(i);
                    rec.bind_set(pipeline, 1, descriptors);
                    rec.push_constants(pipeline, bytemuck::bytes_of(push));
                    bound = Some(i);
                }
                let mesh = &gpu.meshes[m];
                if let Some(attributes) = &mesh.attributes {
                    rec.bind_vertex_buffer(1, attributes);
                }
                if self.motion {
                    match self.prev_vertices.get(m).copied().flatten() {
                        Some(prev) => rec.bind_vertex_range(2, prev.buffer, prev.offset),
                        None => rec.bind_vertex_buffer(2, mesh.vertex_buffer()),
                    }
                }
                rec.draw_mesh(mesh.vertex_buffer(), &mesh.indices, mesh.index_count, first, count);
            }
        }
        rec.end_rendering();
    }
}

/// The instances of draw `d` as runs of consecutive instances with the same texture set (None:
/// untextured): (set, first instance, count). A scene without textures gets the draw itself.
fn texture_runs(
    gpu: &crate::scene_gpu::SceneGpu,
    d: &crate::scene_gpu::Draw,
) -> Vec<(Option<usize>, u32, u32)> {
    if gpu.textures.is_empty() {
        return vec![(None, d.first_instance, d.instance_count)];
    }
    let table = gpu.instance_table();
    let mut runs: Vec<(Option<usize>, u32, u32)> = Vec::new();
    for i in d.first_instance..d.first_instance + d.instance_count {
        let set = gpu.textures.set_of(table[i as usize].ids[1]);
        match runs.last_mut() {
            Some((s, _, count)) if *s == set => *count += 1,
            _ => runs.push((set, i, 1)),
        }
    }
    runs
}

/// With `motion`, vertex binding 2 and location 7: each vertex's previous position, read from a
/// buffer laid out as binding 0's (position, normal: 24 bytes).
fn previous_positions(
    motion: bool,
    mut bindings: Vec<vk::VertexInputBindingDescription>,
    mut attributes: Vec<vk::VertexInputAttributeDescription>,
) -> (Vec<vk::VertexInputBindingDescription>, Vec<vk::VertexInputAttributeDescription>) {
    if motion {
        bindings.push(
            vk::VertexInputBindingDescription::default()
                .binding(2)
                .stride(24)
                .input_rate(vk::VertexInputRate::VERTEX),
        );
        attributes.push(
            vk::VertexInputAttributeDescription::default()
                .binding(2)
                .location(7)
                .format(vk::Format::R32G32B32_SFLOAT)
                .offset(0),
        );
    }
    (bindings, attributes)
}
