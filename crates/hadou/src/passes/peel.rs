//! peel: the bake-free thickness of `thickness = "peel"` materials. Each frame the instances drawn
//! with a peel material are rasterized from the scene's first directional light, with the
//! light_id pass's orthographic view (`effects::translucency::LightView`) at the same map size
//! S = `light_map_size` (texels of a quarter of the material's `voxel_res` voxel where 1024
//! texels suffice), with no depth test and no culling: every fragment is one crossing of the light
//! ray through a texel's centre with a peel surface (the rasterizer samples at texel centres, and
//! its top-left rule gives a closed mesh's shared edges exactly one fragment), appended to that
//! texel's list:
//! - `peel_counts` (R32UI, S²): crossings of the texel's ray (`imageAtomicAdd`), cleared each frame;
//! - `peel_lists` (RG32UI, 4S × 2S): the first [`PEEL_K`] of them in arrival order, a
//!   [`PEEL_TILE`] block per texel, each (light-space depth z as f32 bits, instance id + 1 with
//!   bit 31 set where the light enters the solid: the face turns toward the light).
//!
//! The translucency pass then sorts P's texel's list and sums the inside intervals of P's own
//! instance up to z(P) (shaders/translucency.comp, `peel_thickness`; CPU twin
//! `effects::peel::peel_thickness`).
//!
//! **Why facing, not parity.** With the entering flag each crossing says on its own whether the
//! light goes in or out, and the depth of material is the winding number (entering +1, leaving −1)
//! being > 0, as `MeshBvh::inside_fraction` counts it: cavities (inward-facing shells) drop out,
//! overlapping closed parts of one mesh count once, and a crossing lost at a light silhouette
//! (the rasterizer and the mesh disagree on a texel centre lying on an edge) spoils one interval,
//! not every one after it as with parity.
//!
//! **K = 8.** A texel's list holds 8 crossings: the hollow ball of assets/scenes/translucency_peel.toml
//! needs 6 (outer shell and two cavities along the light), a closed mesh seen through needs 2 per
//! shell; 8 RG32UI entries are 64 B a texel, 64 MiB at 1024² (plus 4 MiB of counts). Lists of
//! overlapping peel instances share a texel's 8 entries.
//!
//! **Overflow is counted, never silent.** A texel with more than K crossings keeps its first K
//! (arrival order is not depth order: they are no prefix of the path) and its count says it
//! overflowed: the translucency pass gives its pixels TSM's thickness (`thickness = "tsm"`, the
//! light_id maps), and the frame's counters report it (`FrameStats::counter`):
//! `peel.overflowed_texels` (texels with more than K crossings; a warning is logged when it
//! changes), `peel.longest` (the longest list this frame, overflowed ones included, when longer
//! than K/2 = 4; 0 when every list holds at most 4: only the fuller lists pay a global atomic) and
//! `peel.texels` (texels with any crossing).
//!
//! Needs `fragmentStoresAndAtomics` (its fragment shader writes storage images and a buffer):
//! building the pass without it fails naming the feature. The pass and its images exist only for
//! scenes with an instance drawn with a peel material (registry: `needed`).

use crate::gpu::memory::MemoryLocation;

use super::translucency::LightViewData;
use super::{Binding, FrameContext, ImageUse, Pass, PassRecording, Reader};
use crate::effects::translucency::{light_map_size, light_map_size_in, LightView};
use crate::frame::FrameStats;
use crate::gpu::barriers::ImageAccess;
use crate::gpu::memory::Buffer;
use crate::gpu::pipeline::{create_graphics_pipeline, Blend, Bound, BufferRange, GraphicsDesc, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuError, GpuResult};
use crate::passes::gpu_structs::instance_records;
use crate::scene::{MaterialKind, Scene, ThicknessMode};
use crate::targets::Target;

/// Crossings a texel's list holds. Keep in sync with shaders/common/peel.glsl.
pub const PEEL_K: u32 = 8;
/// A texel's list is this block (x, y) of the lists image. Keep in sync with shaders/common/peel.glsl.
pub const PEEL_TILE: (u32, u32) = (4, 2);
/// Entry bit: the light enters the solid at this crossing.
pub const PEEL_ENTERING: u32 = 0x8000_0000;

/// The pass's counters (module docs).
pub const OVERFLOWED: &str = "peel.overflowed_texels";
pub const LONGEST: &str = "peel.longest";
pub const TEXELS: &str = "peel.texels";

/// Indices into the stats buffer. Keep in sync with STAT_* in shaders/peel.frag.
const STAT_OVERFLOWED: usize = 0;
const STAT_TEXELS: usize = 1;
const STAT_MAX: usize = 2;
const STAT_COUNT: usize = 3;

/// The counters: cleared by a clear command, then added to by the fragments.
const COUNTS_ACCESS: ImageAccess = ImageAccess {
    stage: vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::CLEAR.as_raw() | vk::PipelineStageFlags2::FRAGMENT_SHADER.as_raw(),
    ),
    access: vk::AccessFlags2::from_raw(
        vk::AccessFlags2::TRANSFER_WRITE.as_raw()
            | vk::AccessFlags2::SHADER_STORAGE_READ.as_raw()
            | vk::AccessFlags2::SHADER_STORAGE_WRITE.as_raw(),
    ),
    layout: vk::ImageLayout::GENERAL,
};
const LISTS_ACCESS: ImageAccess = ImageAccess {
    stage: vk::PipelineStageFlags2::FRAGMENT_SHADER,
    access: vk::AccessFlags2::SHADER_STORAGE_WRITE,
    layout: vk::ImageLayout::GENERAL,
};

/// Whether an instance's material is translucent with `thickness = "peel"`.
pub fn is_peel(scene: &Scene, instance: usize) -> bool {
    let material = scene.instances[instance].material;
    matches!(scene.materials[material].kind, MaterialKind::Translucent { thickness: ThicknessMode::Peel, .. })
}

/// Whether the scene needs the peel pass: an instance is drawn with a peel material.
pub fn needed(scene: &Scene) -> bool {
    (0..scene.instances.len()).any(|i| is_peel(scene, i))
}

/// The translucency pass reads the lists only when the scene has them (its variant).
pub fn variant(scene: &Scene) -> String {
    if needed(scene) {
        "peel".into()
    } else {
        String::new()
    }
}

/// The lists image's size for S² light maps.
pub fn lists_extent(map_size: u32) -> vk::Extent2D {
    vk::Extent2D { width: map_size * PEEL_TILE.0, height: map_size * PEEL_TILE.1 }
}

/// Bytes of the pass's images for S² light maps (counts and lists).
pub fn image_bytes(map_size: u32) -> u64 {
    let texels = u64::from(map_size) * u64::from(map_size);
    texels * 4 + texels * u64::from(PEEL_K) * 8
}

/// One instanced draw: a run of consecutive peel slots of one mesh in the instance table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PeelDraw {
    pub mesh: usize,
    pub first: u32,
    pub count: u32,
}

/// The runs of peel instances in the scene's instance table (grouped by mesh).
pub fn draw_runs(scene: &Scene) -> Vec<PeelDraw> {
    let (records, ranges) = instance_records(scene);
    let mut runs: Vec<PeelDraw> = Vec::new();
    for (mesh, &(first, count)) in ranges.iter().enumerate() {
        for slot in first..first + count {
            if !is_peel(scene, records[slot as usize].ids[0] as usize) {
                continue;
            }
            match runs.last_mut() {
                Some(r) if r.mesh == mesh && r.first + r.count == slot => r.count += 1,
                _ => runs.push(PeelDraw { mesh, first: slot, count: 1 }),
            }
        }
    }
    runs
}

pub struct PeelPass {
    pipeline: Pipeline,
    /// Per frame slot: the device's counters of the frame last recorded in it (host-readable).
    stats: Vec<Buffer>,
    // This frame's light view, draws and map size (instances move, meshes deform).
    view: LightViewData,
    lit: bool,
    draws: Vec<PeelDraw>,
    size: u32,
    /// The last overflow count warned about (a frame repeating it does not warn again).
    warned: std::sync::atomic::AtomicU64,
}

impl PeelPass {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler, scene: &Scene) -> GpuResult<Self> {
        if !ctx.fragment_stores_and_atomics {
            return Err(GpuError::MissingFeature {
                device: ctx.info.name.clone(),
                feature: "fragmentStoresAndAtomics (needed by thickness = \"peel\"; a game enables it in \
                          VkPhysicalDeviceFeatures and says so in EnabledFeatures)",
            });
        }
        let vertex = compiler.compile("peel.vert", &[])?;
        let fragment = compiler.compile("peel.frag", &[])?;
        // The scene's vertex buffers (position, normal); only the position is read.
        let (vertex_bindings, vertex_attributes) = crate::scene_gpu::vertex_input(false);
        let pipeline = create_graphics_pipeline(
            ctx,
            &GraphicsDesc {
                name: "peel",
                vertex: &vertex,
                fragment: &fragment,
                push_constant_bytes: std::mem::size_of::<LightViewData>() as u32,
                vertex_bindings: &vertex_bindings,
                vertex_attributes: &vertex_attributes,
                // No attachments: the fragments write only the lists.
                color_formats: &[],
                depth_format: vk::Format::UNDEFINED,
                depth_compare: vk::CompareOp::ALWAYS,
                // Every crossing counts, facing both ways.
                cull_mode: vk::CullModeFlags::NONE,
                blend: Blend::Replace,
            },
        )?;
        Ok(PeelPass {
            pipeline,
            stats: Vec::new(),
            view: LightViewData::default(),
            lit: false,
            draws: Vec::new(),
            // The first frame's size, so `Renderer::prepare` makes the images at it.
            size: light_map_size(scene),
            warned: Default::default(),
        })
    }

    /// The counters of the frame last recorded in `slot` (after it finished): overflowed texels,
    /// texels with a crossing, the longest list.
    fn counts(&self, slot: usize) -> [u64; STAT_COUNT] {
        let Some(words) = self.stats.get(slot).and_then(|b| b.mapped()) else { return [0; STAT_COUNT] };
        std::array::from_fn(|i| {
            u32::from_le_bytes(words[4 * i..4 * i + 4].try_into().unwrap_or([0; 4])) as u64
        })
    }
}

impl Pass for PeelPass {
    fn name(&self) -> &'static str {
        "peel"
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let scene = frame.scene;
        let bounds = frame.scene_gpu.mesh_bounds();
        let view = LightView::fit_with(scene, &bounds);
        self.lit = view.is_some();
        self.view = view.as_ref().map(LightViewData::new).unwrap_or_default();
        self.draws = draw_runs(scene);
        self.size = light_map_size_in(scene, &bounds, view.as_ref());
        let limit = frame.ctx.limits.max_image_dimension2_d;
        if self.size * PEEL_TILE.0 > limit {
            return Err(GpuError::DeviceLimit {
                what: "peel lists image".into(),
                limit: "maxImageDimension2D",
                needed: u64::from(self.size * PEEL_TILE.0),
                max: u64::from(limit),
                message: format!(
                    "{}² light maps need a {}-texel-wide list image; the device's maxImageDimension2D is {limit}",
                    self.size,
                    self.size * PEEL_TILE.0
                ),
            });
        }
        // The slot's counters: its previous frame has finished and was reported.
        while self.stats.len() <= frame.slot {
            let name = format!("peel stats {}", self.stats.len());
            let (size, usage) = ((4 * STAT_COUNT) as u64, vk::BufferUsageFlags::STORAGE_BUFFER);
            self.stats.push(frame.memory.create_buffer(
                frame.ctx,
                &name,
                size,
                usage,
                MemoryLocation::GpuToCpu,
            )?);
        }
        let stats = &mut self.stats[frame.slot];
        stats.write(0, &[0u8; 4 * STAT_COUNT])?;
        let map = Some(vk::Extent2D { width: self.size, height: self.size });
        Ok(vec![
            Binding::Bound(Bound::Storage(frame.instances)),
            Binding::Image(ImageUse { target: Target::PeelCounts, access: COUNTS_ACCESS, extent: map }),
            Binding::Image(ImageUse {
                target: Target::PeelLists,
                access: LISTS_ACCESS,
                extent: Some(lists_extent(self.size)),
            }),
            Binding::Written(BufferRange::whole(stats.raw), Reader::Host),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline]
    }

    fn record(&self, pass: &PassRecording) {
        let rec = pass.rec;
        let counts = pass.targets.image(Target::PeelCounts);
        rec.clear_general_image(&counts, vk::ClearColorValue { uint32: [0; 4] });
        rec.clear_to_fragment_barrier();
        rec.begin_rendering_views(counts.extent, &[], None);
        if self.lit && !self.draws.is_empty() {
            rec.bind_pipeline(&self.pipeline, pass.set(0));
            rec.push_constants(&self.pipeline, bytemuck::bytes_of(&self.view));
            for d in &self.draws {
                let mesh = &pass.scene_gpu.meshes[d.mesh];
                rec.draw_mesh(mesh.vertex_buffer(), &mesh.indices, mesh.index_count, d.first, d.count);
            }
        }
        rec.end_rendering();
    }

    fn finished(&self, slot: usize, stats: &mut FrameStats) {
        let c = self.counts(slot);
        stats.add(OVERFLOWED, c[STAT_OVERFLOWED]);
        stats.add(TEXELS, c[STAT_TEXELS]);
        stats.max(LONGEST, c[STAT_MAX]);
        let last = self.warned.swap(c[STAT_OVERFLOWED], std::sync::atomic::Ordering::Relaxed);
        if c[STAT_OVERFLOWED] > 0 && c[STAT_OVERFLOWED] != last {
            log::warn!(
                "peel: {} light-map texels cross more than {PEEL_K} peel surfaces (longest list {}): their \
                 pixels get the shadow-map (tsm) thickness",
                c[STAT_OVERFLOWED],
                c[STAT_MAX]
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shader's constants are the ones above.
    #[test]
    fn glsl_constants_match() {
        let glsl = include_str!("../../../../shaders/common/peel.glsl");
        for (name, value) in [("PEEL_K", PEEL_K), ("PEEL_TILE_X", PEEL_TILE.0), ("PEEL_TILE_Y", PEEL_TILE.1)]
        {
            assert!(glsl.contains(&format!("#define {name} {value}u")), "{name}");
        }
        assert!(glsl.contains(&format!("#define PEEL_ENTERING 0x{PEEL_ENTERING:x}u")));
        assert_eq!(PEEL_K, PEEL_TILE.0 * PEEL_TILE.1);
        assert_eq!(image_bytes(1024), 68 << 20);
    }
}
