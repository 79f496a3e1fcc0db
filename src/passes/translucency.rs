//! translucency (seed 003): for each pixel whose surface is a translucent instance, the world
//! thickness d of material the light of the scene's first directional light crossed to reach it,
//! written to the `thickness` target (+inf elsewhere), and HDR += w·L·albedo·exp(−σ·d) per channel
//! on top of the raster's Lambert (L: the light's colour × intensity; w = max(n·l, 0) with n the
//! G-buffer normal, `effects::translucency::exit_weight`). Runs after the raster, the
//! `light_id` pass and the metaballs, before the energy wave. CPU twin: `effects::translucency`.
//!
//! # Per pixel
//!
//! Only the pixels that can show a translucent instance run this: the screen bounds of the corners
//! of the translucent instances' transformed mesh boxes (`Camera::pixel_bounds`, the whole frame
//! when a corner is nearer than the near plane). A one-line variant of the shader (FILL_ONLY)
//! first writes +inf thickness over the frame when the bounds are not all of it. Lavapipe runs
//! every line of a shader for each 8-lane group whatever its branches take, so an early return
//! would not have saved the work.
//!
//! The shaded point P = camera + u·distance (the pixel ray as `Camera::pixel_ray` builds it, the
//! raster's `distance`). Projected into the light's view (`effects::translucency::LightView`) it
//! falls in texel t of the light_id maps, which hold the instance and the surface voxel of the
//! first translucent surface the light reaches there, and that surface's light-space distance
//! z(entry). The texel used is t itself when it holds P's instance, else the nearest of its 8
//! neighbours that does (P at the silhouette seen from the light). With
//! tsm = max(z(P) − z(entry), 0):
//! - `thickness = "tsm"`: d = tsm (translucent shadow maps: cavities and gaps count as material).
//! - `thickness = "peel"` (built with WITH_PEEL when the scene has it): d = the inside intervals of
//!   P's instance on the crossing list of P's texel t (the `peel` pass), up to z(P); an overflowed
//!   list takes the TSM path below (src/passes/peel.rs).
//! - `thickness = "lut"`: the light's entry point a = P − l·tsm lies on P's own light ray; with
//!   b = P, both taken to object space by M⁻¹, d = |M(b − a)| − (1 − f(i, j))·|M(c_j − c_i)|,
//!   clamped to [0, tsm] (`effects::translucency::lut_thickness`): the path less the gaps the
//!   table knows on the segment between the centres c_i, c_j of the surface voxels at its ends.
//!   Each end's voxel is the best of 4 nearest-grid lookups, at the end and 0.5, 1, 1.5 voxels
//!   further along the path into the material: the one whose centre lies nearest the path
//!   (`path_end_voxel`; for the entry end the light map's voxel is the first lookup).
//!
//!   Why not f·|M(b − a)| (`world_thickness_between`) with the plain lookups: surface-voxel
//!   centres lie up to a voxel below the surface and ~1.3 voxels beside the path, so the table's
//!   segment misses part of a thin wall (the bottle's glass is 1.4 voxels thick) and crosses
//!   cavity rims the path does not. Measured on the seed's objects under rotated, non-uniformly
//!   scaled instances when this method was chosen (the scenes of tests/gpu_translucency.rs; the
//!   plain-lookup variant is no longer built), p95 of the error in voxels: bottle 2.0 → 0.69,
//!   cavity cube 1.26 → 0.86.
//!
//! **Fallbacks** (no texel of P's instance in the 3×3 block): when texel t holds another instance,
//! the light crossed that one first: d = max(z(P) − z(t), 0), TSM's distance from its surface (the
//! gap and the other instance count as material); when t holds none, P lies at a silhouette seen
//! from the light: d = 0. Without a directional light, d = +inf and nothing is added. Metaball
//! groups (instance ids past the scene's instances) are not translucent here. Opaque instances do
//! not shadow the light (the raster has no shadows either).
//!
//! # GPU data (built once at scene load, shared with `light_id`)
//!
//! Every (mesh, voxel_res) drawn by an instance whose material is translucent with
//! `thickness = "lut"` is baked through `BakeCache` (`effects::bake_cache`; the device's
//! maxImageDimension2D is the bake's texture limit) and packed into:
//! - **LUT image**, `R8_UNORM`, sampled with `texelFetch` (NEAREST sampler): the tables one after
//!   the other in one texel numbering (no descriptor indexing on lavapipe, so one image for all
//!   meshes). Table m's pair (i, j) is texel `base_m + pair_index(i, j, N_m)`, texel k at
//!   `(k mod W, k / W)` with `W = min(total, 4096, limit)` and `H = ceil(total / W)` (W becomes the
//!   limit when H would exceed it): for one table exactly its `LutLayout`. Bytes = W·H, about
//!   Σ N_m(N_m + 1)/2. A total above limit² texels is refused, naming maxImageDimension2D.
//! - **nearest grids**, storage buffer of u32: every table's `nearest_grid` (dims.x·dims.y·dims.z
//!   words, x fastest), one after the other: 4 bytes a grid voxel.
//! - **surface-voxel centres**, storage buffer of vec4 (object space, w = 0): 16 bytes a surface
//!   voxel.
//! - **`LutRecord`** per table (48 bytes): origin + voxel edge, dims + N, the grid word offset, the
//!   first texel, the first centre.
//! - **`TranslucentInstance`** per scene instance, scene order (144 bytes): M and M⁻¹ (from the f64
//!   transform), the table index (`NO_LUT` for TSM or opaque instances), a translucent flag.
//!
//! For assets/scenes/translucency.toml: a 4096×7280 table image (29.8 MB: ring 60³ 5760 surface
//! voxels 16.6 MB, hollow cube 25³ 3458 voxels 6.0 MB, bottle 56³ 3806 voxels 7.2 MB), 0.5 MB of
//! grids, 0.2 MB of centres; plus the light_id maps (16 MiB at 1024², `light_map_size`).

use std::sync::Arc;

use glam::DVec3;

use super::{Binding, FrameContext, ImageUse, Pass, PassRecording};
use crate::effects::bake_cache::BakeCache;
use crate::effects::thickness_lut::{bake, BakeOptions, ThicknessLut, LUT_WIDTH};
use crate::effects::translucency::{light_map_size, LightView};
use crate::gpu::barriers::ImageAccess;
use crate::gpu::memory::{Image, Memory};
use crate::gpu::pipeline::{create_compute_pipeline, Bound, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::texel_buffer::{TexelBuffer, Texels};
use crate::gpu::upload::{stage_image, Sampler};
use crate::gpu::{vk, GpuContext, GpuError, GpuResult};
use crate::passes::gpu_structs::{instance_records, mat4_f32};
use crate::scene::camera::PixelRect;
use crate::scene::{MaterialKind, Scene, ThicknessMode};
use crate::targets::Target;

/// `TranslucentInstance::info.x` of an instance without a table.
pub const NO_LUT: u32 = u32::MAX;

/// One baked table. Keep in sync with `LutRecord` in shaders/common/translucency.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LutRecord {
    /// xyz: object-space minimum corner of voxel (0, 0, 0); w: voxel edge.
    pub origin: [f32; 4],
    /// xyz: grid voxels; w: surface voxels N.
    pub dims: [u32; 4],
    /// x: first word of the nearest grid; y: first texel of the table; z: first surface-voxel centre.
    pub offsets: [u32; 4],
}

/// Per scene instance. Keep in sync with `TranslucentInstance` in shaders/common/translucency.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TranslucentInstance {
    pub model: [[f32; 4]; 4],
    pub inverse_model: [[f32; 4]; 4],
    /// x: `LutRecord` index or `NO_LUT`; y: 1 when the material is translucent.
    pub info: [u32; 4],
}

/// The light's view: light_id's push constants (size checked against the shader at pipeline
/// creation) and a member of `TranslucencyParams`; `LightViewData` in shaders/common/translucency.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LightViewData {
    /// xyz: centre; w: radius.
    pub centre: [f32; 4],
    pub right: [f32; 4],
    pub up: [f32; 4],
    /// xyz: the unit direction the light travels.
    pub dir: [f32; 4],
}

/// The translucency pass's uniforms (size checked against shaders/translucency.comp when bound).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TranslucencyParams {
    /// xyz: camera right × tan(fov/2) × aspect.
    pub right: [f32; 4],
    /// xyz: image up × tan(fov/2).
    pub up: [f32; 4],
    pub forward: [f32; 4],
    /// xyz: camera position.
    pub camera: [f32; 4],
    /// rgb: the first light's colour × intensity; w: 1 when the scene has a light.
    pub radiance: [f32; 4],
    pub view: LightViewData,
    /// Frame width, height, light map size, scene instances.
    pub dims: [u32; 4],
    /// x: LUT image width.
    pub lut: [u32; 4],
    /// The pixels [x, z) × [y, w) the main dispatch covers (`translucent_pixels`).
    pub rect: [u32; 4],
}

const _: () = {
    assert!(std::mem::size_of::<LutRecord>() == 48);
    assert!(std::mem::size_of::<TranslucentInstance>() == 144);
    assert!(std::mem::offset_of!(TranslucentInstance, info) == 128);
    assert!(std::mem::size_of::<LightViewData>() == 64);
    assert!(std::mem::size_of::<TranslucencyParams>() == 192);
    assert!(std::mem::offset_of!(TranslucencyParams, view) == 80);
    assert!(std::mem::offset_of!(TranslucencyParams, dims) == 144);
};

fn v4(v: glam::DVec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

impl LightViewData {
    pub fn new(view: &LightView) -> Self {
        LightViewData {
            centre: v4(view.centre, view.radius as f32),
            right: v4(view.right, 0.0),
            up: v4(view.up, 0.0),
            dir: v4(view.dir, 0.0),
        }
    }
}

/// The size of the packed table image for `total` texels under a `limit`-texel side, or an error
/// naming the limit.
pub fn atlas_extent(total: u64, limit: u32) -> GpuResult<vk::Extent2D> {
    let limit64 = limit.max(1) as u64;
    let mut width = total.clamp(1, (LUT_WIDTH as u64).min(limit64));
    let mut height = total.div_ceil(width).max(1);
    if height > limit64 {
        width = limit64;
        height = total.div_ceil(width);
    }
    if height > limit64 {
        return Err(GpuError::Limit {
            what: "translucency LUT image".into(),
            message: format!(
                "the scene's thickness tables hold {total} texels, more than a {limit}×{limit} image \
                 (the device's maxImageDimension2D is {limit}); lower the materials' voxel_res"
            ),
        });
    }
    Ok(vk::Extent2D { width: width as u32, height: height as u32 })
}

/// What was baked for one table, for logs and reports.
#[derive(Clone, Debug)]
pub struct LutSummary {
    pub mesh: String,
    pub res: u32,
    pub surface_voxels: u32,
    /// Bytes of its table (N(N+1)/2) and of its nearest grid.
    pub table_bytes: u64,
    pub grid_bytes: u64,
}

/// The scene's baked translucency data on the GPU, shared by `light_id` and `translucency`: what
/// does not change when instances move (the tables are in object space, exact under any affine
/// transform). What does — the light's view, the instance matrices, the light draws — is a
/// `TranslucentFrame`, made each frame.
pub struct TranslucentData {
    pub tables: Vec<LutSummary>,
    /// The (mesh, voxel_res) of each table, in table order.
    pub keys: Vec<(usize, u32)>,
    pub lut_image: Image,
    pub sampler: Sampler,
    // Read as texel buffers (see gpu::texel_buffer for why): the nearest grids (one uint per
    // texel), the LutRecords (3 four-uint texels each) and the surface-voxel centres (1).
    pub grid: TexelBuffer,
    pub records: TexelBuffer,
    pub centres: TexelBuffer,
}

/// What the translucent instances look like this frame, from the scene's current transforms and
/// lights.
pub struct TranslucentFrame {
    /// The first light's view fitted to the translucent instances; `None` without a light.
    pub view: Option<LightView>,
    pub view_data: LightViewData,
    /// The first light's colour × intensity.
    pub radiance: glam::DVec3,
    /// Runs of translucent instances in the scene's instance table, for the light_id pass.
    pub draws: Vec<LightDraw>,
    /// Per scene instance (`instance_table`).
    pub instances: Vec<TranslucentInstance>,
    /// The light maps' side (`light_map_size`).
    pub map_size: u32,
}

impl TranslucentFrame {
    pub fn new(scene: &Scene, data: &TranslucentData) -> Self {
        let view = LightView::fit(scene);
        let view_data = view.as_ref().map(LightViewData::new).unwrap_or(LightViewData {
            centre: [0.0, 0.0, 0.0, 1.0],
            right: [1.0, 0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0, 0.0],
            dir: [0.0, 0.0, 1.0, 0.0],
        });
        TranslucentFrame {
            view,
            view_data,
            radiance: scene.lights.first().map_or(glam::DVec3::ZERO, |l| l.color * l.intensity),
            draws: draw_runs(scene),
            instances: instance_table(scene, &data.keys),
            map_size: light_map_size(scene),
        }
    }
}

/// Host-side contents of `TranslucentData`'s buffers and image.
pub(crate) struct Packed {
    tables: Vec<LutSummary>,
    keys: Vec<(usize, u32)>,
    atlas: Vec<u8>,
    extent: vk::Extent2D,
    grid: Vec<u32>,
    records: Vec<LutRecord>,
    centres: Vec<[f32; 4]>,
}

fn translucent_mode(scene: &Scene, instance: usize) -> Option<(u32, ThicknessMode)> {
    match scene.materials[scene.instances[instance].material].kind {
        MaterialKind::Translucent { voxel_res, thickness, .. } => Some((voxel_res, thickness)),
        MaterialKind::Lambert => None,
    }
}

fn bake_table(
    scene: &Scene,
    mesh: usize,
    res: u32,
    limit: u32,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> GpuResult<ThicknessLut> {
    let m = &scene.meshes[mesh];
    let options = BakeOptions { max_texture_dim: limit, ..BakeOptions::default() };
    let none = progress;
    let baked = match BakeCache::from_env() {
        Some(cache) => cache.get_or_bake(&m.mesh, res, &options, none).map(|c| {
            log::info!(
                "thickness LUT of mesh \"{}\" at {res}³: {:?} in {:.2} s",
                m.name,
                c.outcome,
                c.seconds
            );
            c.lut
        }),
        None => bake(&m.mesh, res, &options, none).map(|(lut, _)| lut),
    };
    // Name where the resolution was asked for: the voxel_res of a material this mesh is drawn with.
    let at = scene
        .instances
        .iter()
        .filter(|i| i.mesh == mesh)
        .map(|i| &scene.materials[i.material])
        .find(|mat| matches!(mat.kind, MaterialKind::Translucent { voxel_res, .. } if voxel_res == res))
        .map_or(String::new(), |mat| {
            format!("{}: voxel_res of material \"{}\": ", mat.voxel_res_at, mat.name)
        });
    baked.map_err(|e| GpuError::Limit {
        what: format!("{at}thickness LUT of mesh \"{}\" at {res}³", m.name),
        message: e.to_string(),
    })
}

/// The (mesh, voxel_res) of every table the scene's LUT instances need, in first-use order.
fn table_keys(scene: &Scene) -> Vec<(usize, u32)> {
    let mut keys: Vec<(usize, u32)> = Vec::new();
    for (id, inst) in scene.instances.iter().enumerate() {
        if let Some((res, ThicknessMode::Lut)) = translucent_mode(scene, id) {
            if !keys.contains(&(inst.mesh, res)) {
                keys.push((inst.mesh, res));
            }
        }
    }
    keys
}

/// Per scene instance, its transform and table as the passes read them (`TranslucentInstance`),
/// for this frame's transforms; at least one record (an empty table still binds).
pub fn instance_table(scene: &Scene, keys: &[(usize, u32)]) -> Vec<TranslucentInstance> {
    let mut instances: Vec<TranslucentInstance> = scene
        .instances
        .iter()
        .enumerate()
        .map(|(id, inst)| {
            let mode = translucent_mode(scene, id);
            let lut = match mode {
                Some((res, ThicknessMode::Lut)) => {
                    keys.iter().position(|k| *k == (inst.mesh, res)).map_or(NO_LUT, |k| k as u32)
                }
                _ => NO_LUT,
            };
            TranslucentInstance {
                model: mat4_f32(inst.transform.matrix),
                inverse_model: mat4_f32(inst.transform.inverse),
                info: [lut, u32::from(mode.is_some()), 0, 0],
            }
        })
        .collect();
    if instances.is_empty() {
        let zero = [[0.0; 4]; 4];
        instances.push(TranslucentInstance { model: zero, inverse_model: zero, info: [NO_LUT, 0, 0, 0] });
    }
    instances
}

fn pack(scene: &Scene, limit: u32) -> GpuResult<Packed> {
    pack_keys(scene, table_keys(scene), limit, &|_, _| {})
}

/// The tables of `keys` (mesh, voxel_res), baked through the cache, packed as the passes read
/// them; `progress(done, total)` of each bake in turn. Runs on any thread (run-time bakes).
pub(crate) fn pack_keys(
    scene: &Scene,
    keys: Vec<(usize, u32)>,
    limit: u32,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> GpuResult<Packed> {
    let (mut tables, mut grid, mut records, mut texels) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut centres: Vec<[f32; 4]> = Vec::new();
    for &(mesh, res) in &keys {
        let lut = bake_table(scene, mesh, res, limit, progress)?;
        let n = lut.surface_count() as u64;
        let pairs = n * (n + 1) / 2;
        records.push(LutRecord {
            origin: v4(lut.origin, lut.voxel_size as f32),
            dims: [lut.dims[0], lut.dims[1], lut.dims[2], n as u32],
            offsets: [grid.len() as u32, texels.len() as u32, centres.len() as u32, 0],
        });
        if texels.len() as u64 + pairs > u32::MAX as u64 {
            // The image limit below refuses this too; the u32 offsets must not wrap before.
            return Err(GpuError::Limit {
                what: "translucency LUT image".into(),
                message: format!("more than 2³² texels (maxImageDimension2D is {limit})"),
            });
        }
        texels.extend_from_slice(&lut.data[..pairs as usize]);
        grid.extend_from_slice(&lut.nearest_grid);
        centres.extend(lut.surface_centres_f32());
        tables.push(LutSummary {
            mesh: scene.meshes[mesh].name.clone(),
            res,
            surface_voxels: n as u32,
            table_bytes: pairs,
            grid_bytes: lut.nearest_grid.len() as u64 * 4,
        });
    }
    let extent = atlas_extent(texels.len() as u64, limit)?;
    texels.resize(extent.width as usize * extent.height as usize, 0);
    if records.is_empty() {
        records.push(LutRecord::default());
    }
    Ok(Packed { tables, keys, atlas: texels, extent, grid, records, centres })
}

/// One instanced draw of the light_id pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightDraw {
    pub mesh: usize,
    /// Slots in the scene's instance table (`gpu_structs::instance_records` order).
    pub first: u32,
    pub count: u32,
    /// The instances' transforms mirror (det < 0): their triangles wind the other way.
    pub mirrored: bool,
}

/// Runs of consecutive translucent slots of one mesh and one handedness in the scene's instance
/// table.
pub fn draw_runs(scene: &Scene) -> Vec<LightDraw> {
    let (records, ranges) = instance_records(scene);
    let mut runs: Vec<LightDraw> = Vec::new();
    for (mesh, &(first, count)) in ranges.iter().enumerate() {
        for slot in first..first + count {
            let id = records[slot as usize].ids[0] as usize;
            if translucent_mode(scene, id).is_none() {
                continue;
            }
            let mirrored = scene.instances[id].transform.matrix.determinant() < 0.0;
            match runs.last_mut() {
                Some(r) if r.mesh == mesh && r.mirrored == mirrored && r.first + r.count == slot => {
                    r.count += 1
                }
                _ => runs.push(LightDraw { mesh, first: slot, count: 1, mirrored }),
            }
        }
    }
    runs
}

impl TranslucentData {
    /// Bakes (through the cache) and uploads everything the two passes read.
    pub fn new(ctx: &GpuContext, memory: &Memory, scene: &Scene) -> GpuResult<Self> {
        Self::from_packed(ctx, memory, pack(scene, ctx.limits.max_image_dimension2_d)?)
    }

    /// Uploads tables packed already, the LUT image by a one-off copy waited for (at load).
    pub(crate) fn from_packed(ctx: &GpuContext, memory: &Memory, packed: Packed) -> GpuResult<Self> {
        let (data, copy) = Self::staged(ctx, memory, packed)?;
        copy.submit_once(ctx)?;
        Ok(data)
    }

    /// Tables packed already (`pack_keys`, e.g. by a run-time bake), with the copy that fills the
    /// LUT image still to record (into a frame's command buffer before any pass reads it).
    pub(crate) fn staged(
        ctx: &GpuContext,
        memory: &Memory,
        packed: Packed,
    ) -> GpuResult<(Self, crate::gpu::upload::ImageCopy)> {
        let (word, quad) = (Texels::U32, Texels::U32x4);
        let texels =
            |name: &str, bytes: &[u8], texels| TexelBuffer::from_bytes(ctx, memory, name, bytes, texels);
        let grid = texels("translucency nearest grids", bytemuck::cast_slice(&packed.grid), word)?;
        let records = texels("translucency lut records", bytemuck::cast_slice(&packed.records), quad)?;
        let centres = texels("translucency centres", bytemuck::cast_slice(&packed.centres), quad)?;
        let format = vk::Format::R8_UNORM;
        let (lut_image, copy) =
            stage_image(ctx, memory, "translucency lut", packed.extent, format, 1, &packed.atlas)?;
        let sampler = Sampler::nearest(ctx, "translucency lut sampler")?;
        let (table_bytes, grid_bytes): (u64, u64) =
            packed.tables.iter().fold((0, 0), |(t, g), s| (t + s.table_bytes, g + s.grid_bytes));
        log::info!(
            "translucency: {} tables, LUT image {}x{} R8_UNORM ({} bytes, {table_bytes} used), grids {grid_bytes} \
             bytes, centres {} bytes",
            packed.tables.len(),
            packed.extent.width,
            packed.extent.height,
            packed.atlas.len(),
            packed.centres.len() * 16
        );
        let data = TranslucentData {
            tables: packed.tables,
            keys: packed.keys,
            lut_image,
            sampler,
            grid,
            records,
            centres,
        };
        Ok((data, copy))
    }
}

/// Whether the scene needs the light_id and translucency passes: an instance is translucent.
pub fn needed(scene: &Scene) -> bool {
    (0..scene.instances.len()).any(|i| translucent_mode(scene, i).is_some())
}

pub struct TranslucencyPass {
    pipeline: Pipeline,
    /// The FILL_ONLY variant: +inf thickness over the frame, for the pixels outside `rect`.
    fill: Pipeline,
    /// The pixels that can show a translucent instance this frame; `None`: none can.
    rect: Option<PixelRect>,
    extent: vk::Extent2D,
    data: Arc<TranslucentData>,
    /// Built with WITH_PEEL: reads the peel pass's lists (bindings 14, 15).
    peel: bool,
}

impl TranslucencyPass {
    pub fn new(
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        data: Arc<TranslucentData>,
        peel: bool,
    ) -> GpuResult<Self> {
        let with_peel: &[(&str, &str)] = if peel { &[("WITH_PEEL", "1")] } else { &[] };
        let spirv = compiler.compile("translucency.comp", with_peel)?;
        let fill_spirv = compiler.compile("translucency.comp", &[("FILL_ONLY", "1")])?;
        let pipeline = create_compute_pipeline(ctx, "translucency", &spirv, 0)?;
        let fill = create_compute_pipeline(ctx, "translucency fill", &fill_spirv, 0)?;
        Ok(TranslucencyPass { pipeline, fill, rect: None, extent: vk::Extent2D::default(), data, peel })
    }
}

/// The pixels whose rays can meet a translucent instance: the screen bounds of the corners of
/// their transformed mesh boxes (`Camera::pixel_bounds`; the box's hull holds the mesh). Only
/// these run the per-pixel thickness work.
fn translucent_pixels(scene: &Scene, extent: vk::Extent2D) -> Option<PixelRect> {
    let corners: Vec<DVec3> = (0..scene.instances.len())
        .filter(|&k| translucent_mode(scene, k).is_some())
        .flat_map(|k| {
            let inst = &scene.instances[k];
            let (lo, hi) = scene.meshes[inst.mesh].mesh.bounds();
            (0..8).map(move |c| {
                let p = DVec3::new([lo.x, hi.x][c & 1], [lo.y, hi.y][(c >> 1) & 1], [lo.z, hi.z][c >> 2]);
                inst.transform.transform_point(p)
            })
        })
        .collect();
    scene.camera.pixel_bounds(&corners, extent.width, extent.height)
}

impl Pass for TranslucencyPass {
    fn name(&self) -> &'static str {
        "translucency"
    }

    fn images(&self) -> Vec<ImageUse> {
        let peel =
            [Target::PeelCounts, Target::PeelLists].map(|t| ImageUse::new(t, ImageAccess::COMPUTE_READ));
        let peel = peel.into_iter().filter(|_| self.peel);
        vec![
            ImageUse::new(Target::Ids, ImageAccess::COMPUTE_READ),
            ImageUse::new(Target::Distance, ImageAccess::COMPUTE_READ),
            ImageUse::new(Target::Normal, ImageAccess::COMPUTE_READ),
            ImageUse::new(Target::Hdr, ImageAccess::COMPUTE_READ_WRITE),
            ImageUse::new(Target::LightIds, ImageAccess::COMPUTE_READ),
            ImageUse::new(Target::LightZ, ImageAccess::COMPUTE_READ),
            ImageUse::new(Target::Thickness, ImageAccess::COMPUTE_WRITE),
        ]
        .into_iter()
        .chain(peel)
        .collect()
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let (scene, extent) = (frame.scene, frame.extent);
        let data = &self.data;
        // Instances may have moved: this frame's light view and matrices.
        let now = TranslucentFrame::new(scene, data);
        let cam = &scene.camera;
        let [right, up, forward] = cam.ray_frame(extent.width, extent.height).to_f32();
        self.rect = translucent_pixels(scene, extent);
        self.extent = extent;
        let params = TranslucencyParams {
            right,
            up,
            forward,
            camera: v4(cam.position, 1.0),
            radiance: v4(now.radiance, if now.view.is_some() { 1.0 } else { 0.0 }),
            view: now.view_data,
            // light_id sized its maps from the same frame.
            dims: [extent.width, extent.height, now.map_size, scene.instances.len() as u32],
            lut: [data.lut_image.extent.width, 0, 0, 0],
            rect: self.rect.map_or([0; 4], |r| [r.x0, r.y0, r.x1, r.y1]),
        };
        let mut bindings = vec![
            Binding::Bound(Bound::Uniform(frame.upload(&[params])?)),
            Binding::Image(Target::Ids),
            Binding::Image(Target::Distance),
            Binding::Image(Target::Hdr),
            Binding::Image(Target::LightIds),
            Binding::Image(Target::LightZ),
            Binding::Image(Target::Thickness),
            Binding::Bound(Bound::Sampled(data.lut_image.view, data.sampler.raw)),
            Binding::Bound(Bound::UniformTexel(data.grid.view)),
            Binding::Bound(Bound::UniformTexel(data.records.view)),
            Binding::Bound(frame.texels("translucency instances", &now.instances, Texels::U32x4)?),
            Binding::Bound(Bound::Storage(frame.materials)),
            Binding::Bound(Bound::UniformTexel(data.centres.view)),
            Binding::Image(Target::Normal),
        ];
        if self.peel {
            bindings.extend([Binding::Image(Target::PeelCounts), Binding::Image(Target::PeelLists)]);
        }
        Ok(bindings)
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        // The fill variant's shader uses fewer bindings: a set of its own.
        vec![&self.pipeline, &self.fill]
    }

    fn record(&self, pass: &PassRecording) {
        let extent = self.extent;
        if self.rect != Some(PixelRect::full(extent.width, extent.height)) {
            pass.rec.bind_pipeline(&self.fill, pass.set(1));
            pass.rec.dispatch_2d(extent.width, extent.height, (8, 8));
            if self.rect.is_some() {
                pass.rec.compute_to_compute_barrier();
            }
        }
        if let Some(r) = self.rect {
            pass.rec.bind_pipeline(&self.pipeline, pass.set(0));
            pass.rec.dispatch_2d(r.width(), r.height(), (8, 8));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::thickness_lut::LutLayout;

    #[test]
    fn one_table_packs_as_its_layout_and_too_many_texels_name_the_limit() {
        for n in [0usize, 1, 10, 4000, 12000, 23169] {
            let layout = LutLayout::new(n, 16384).unwrap();
            let e = atlas_extent(layout.pairs, 16384).unwrap();
            assert_eq!((e.width, e.height), (layout.width, layout.height), "{n} surface voxels");
        }
        assert!(atlas_extent(256 * 256, 256).is_ok());
        let message = atlas_extent(256 * 256 + 1, 256).unwrap_err().to_string();
        assert!(
            message.contains("maxImageDimension2D is 256") && message.contains("65537 texels"),
            "{message}"
        );
    }

    #[test]
    fn light_draws_are_the_translucent_instances_split_by_handedness() {
        let text = r#"
            [camera]
            position = [0, 0, 5]
            look_at = [0, 0, 0]
            [[mesh]]
            name = "a"
            kind = "cube"
            [[mesh]]
            name = "b"
            kind = "sphere"
            [[material]]
            name = "plain"
            [[material]]
            name = "jade"
            kind = "translucent"
            sigma = [1, 1, 1]
            voxel_res = 8
            [[instance]]
            mesh = "a"
            material = "jade"
            [[instance]]
            mesh = "b"
            material = "jade"
            [[instance]]
            mesh = "a"
            material = "jade"
            [[instance]]
            mesh = "a"
            material = "plain"
            [[instance]]
            mesh = "a"
            material = "jade"
            transform = [{ scale = [-1, 1, 1] }]
            [[instance]]
            mesh = "a"
            material = "jade"
        "#;
        let scene = crate::scene::parse_scene(text, std::path::Path::new("inline.toml")).unwrap();
        assert!(needed(&scene));
        // Slots: mesh a's instances 0, 2, 3, 4, 5 are slots 0..5; mesh b's instance 1 is slot 5.
        let draw = |mesh, first, count, mirrored| LightDraw { mesh, first, count, mirrored };
        assert_eq!(
            draw_runs(&scene),
            vec![draw(0, 0, 2, false), draw(0, 3, 1, true), draw(0, 4, 1, false), draw(1, 5, 1, false)]
        );
        let mut plain = scene.clone();
        plain.instances.iter_mut().for_each(|i| i.material = 0);
        assert!(!needed(&plain) && draw_runs(&plain).is_empty());
    }
}
