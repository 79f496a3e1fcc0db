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
//! falls in texel t of the light_id maps, which hold the instance of the first translucent
//! surface the light reaches there, and that surface's light-space distance
//! z(entry). The texel used is t itself when it holds P's instance, else the nearest of its 8
//! neighbours that does (P at the silhouette seen from the light). With
//! tsm = max(z(P) − z(entry), 0):
//! - `thickness = "tsm"`: d = tsm (translucent shadow maps: cavities and gaps count as material).
//! - `thickness = "peel"` (built with WITH_PEEL when the scene has it; the LUT's march likewise only
//!   with WITH_LUT, when an instance reads a LUT): d = the inside intervals of
//!   P's instance on the crossing list of P's texel t (the `peel` pass), up to z(P); an overflowed
//!   list takes the TSM path below (crates/hadou/src/passes/peel.rs).
//! - `thickness = "lut"`: the light's entry point a = P − l·tsm lies on P's own light ray; with
//!   b = P, both taken to object space by M⁻¹, d = |M(b − a)| times the inside fraction the
//!   instance's thickness field decodes along a → b (`lut_inside_fraction` in
//!   shaders/common/translucency.glsl; its f64 twin `ThicknessLut::inside_fraction`, and
//!   `effects::translucency::lut_thickness`): the path less the cavities and gaps it crosses.
//!
//! **Fallbacks** (no texel of P's instance in the 3×3 block): when texel t holds another instance,
//! the light crossed that one first: d = max(z(P) − z(t), 0), TSM's distance from its surface (the
//! gap and the other instance count as material); when t holds none, P lies at a silhouette seen
//! from the light: d = 0. Without a directional light, d = +inf and nothing is added. Metaball
//! groups (instance ids past the scene's instances) are not translucent here. Opaque instances do
//! not shadow the light (the raster has no shadows either).
//!
//! # GPU data (built once at scene load)
//!
//! Every (mesh, voxel_res) drawn by an instance whose material is translucent with
//! `thickness = "lut"` is baked through `BakeCache` (`effects::bake_cache`) and packed into:
//! - **fields**, a uniform texel buffer of R32_UINT: every table's field (`ThicknessLut::words`:
//!   four 8-bit SNORM corners a word, the lowest byte first), one after the other, each
//!   starting on a word. Corner k of table m is byte (k & 3) of word `first_m + k/4`, decoded in
//!   the shader by integer sign extension (exact) times `scale.x`. Why not a 3D image with a
//!   linear sampler: there is no descriptor indexing on lavapipe (one image for all meshes would be
//!   an atlas with borders), and a sampler's filtering weights are only required to have 8
//!   fractional bits (a 1/256-voxel step in where a crossing lands, of the order of R8's
//!   quantization) — 8 texel fetches and the interpolation in f32 are exact to f32 rounding.
//!   Then its τ per cell, four bytes a word (`TAU_STEPS`). A total above
//!   maxTexelBufferElements words is refused, naming the limit.
//! - **`LutRecord`** per table (48 bytes): origin + voxel edge, dims + first word, the field's and
//!   τ's units.
//! - **`TranslucentInstance`** per scene instance, scene order (144 bytes): M and M⁻¹ (from the f64
//!   transform), the table index (`NO_LUT` for TSM or opaque instances), a translucent flag.
//!
//! For assets/scenes/translucency.toml: 1 byte a corner and 1 a cell, 0.6 MB for the three fields (ring
//! 60³, hollow cube 25³, bottle 56³; `hadou report`), plus the light_id maps (12 bytes a texel,
//! `light_map_size`).

use std::sync::Arc;

use glam::DVec3;

use super::pipeline_memo::PipelineMemo;
use super::{Binding, FrameContext, Pass, PassRecording};
use crate::effects::bake_cache::BakeCache;
use crate::effects::thickness_lut::{bake, BakeOptions, ThicknessLut, TAU_STEPS};
use crate::effects::thickness_pairs::{self, PairOptions, PairTable};
use crate::effects::translucency::{light_map_size_in, LightView};
use crate::gpu::memory::{Image, Memory};
use crate::gpu::pipeline::{create_compute_pipeline, Bound, Pipeline};
use crate::gpu::sampler::Sampler;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::texel_buffer::{TexelBuffer, Texels};
use crate::gpu::{vk, GpuContext, GpuError, GpuResult};
use crate::passes::gpu_structs::{instance_records, mat4_f32};
use crate::scene::camera::PixelRect;
use crate::scene::{MaterialKind, Scene, ThicknessMode};
use crate::targets::Target;

mod upload;
pub(crate) use upload::{Uploading, UPLOAD_BYTES_PER_FRAME};

/// `TranslucentInstance::info.x` of an instance without a table.
pub const NO_LUT: u32 = u32::MAX;

/// Set in a table key's resolution for a pair table (`thickness = "pairs"`): the keys of the
/// fields and of the pair tables share one list, so run-time bakes handle both
/// (crates/hadou/src/renderer/bakes.rs). voxel_res ≤ 128 leaves the bit free.
pub const PAIRS_KEY: u32 = 1 << 31;

/// The table key (mesh, voxel_res, with `PAIRS_KEY` for a pair table) of an instance of `mesh`
/// drawn with a translucent material of this resolution and mode; `None` for a mode without a
/// table (tsm, peel).
pub fn table_key(mesh: usize, voxel_res: u32, mode: ThicknessMode) -> Option<(usize, u32)> {
    match mode {
        ThicknessMode::Lut => Some((mesh, voxel_res)),
        ThicknessMode::Pairs => Some((mesh, voxel_res | PAIRS_KEY)),
        ThicknessMode::Tsm | ThicknessMode::Peel => None,
    }
}

/// One baked field. Keep in sync with `LutRecord` in shaders/common/translucency.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LutRecord {
    /// xyz: object-space position of corner (0, 0, 0); w: voxel edge h.
    pub origin: [f32; 4],
    /// xyz: grid voxels (corners: + 1); w: its first word in the fields buffer.
    pub dims: [u32; 4],
    /// x: object units per unit of a stored value (C·h/127); y: object units per τ step (h/64).
    pub scale: [f32; 4],
}

/// Per scene instance. Keep in sync with `TranslucentInstance` in shaders/common/translucency.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TranslucentInstance {
    pub model: [[f32; 4]; 4],
    pub inverse_model: [[f32; 4]; 4],
    /// x: `LutRecord` index or `NO_LUT`; y: 1 when the material is translucent; z: 1 when the
    /// record is a pair table.
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

crate::gpu::layout::gpu_layout!(LightViewData as "LightViewData" { centre, right, up, dir });

/// The translucency pass's uniforms (size checked against shaders/translucency.comp when bound).
/// The camera's ray frame and position and the frame's size are the frame's uniforms
/// (`FrameUniforms`: `ray_right`, `ray_up`, `ray_forward`, `camera_pos`, `counts`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TranslucencyParams {
    /// rgb: the first directional light's colour × intensity; w: 1 when the scene has one.
    pub radiance: [f32; 4],
    pub view: LightViewData,
    /// Light map size, scene instances, 0, 0.
    pub dims: [u32; 4],
    /// Unused (kept for the layout).
    pub lut: [u32; 4],
    /// The pixels [x, z) × [y, w) the main dispatch covers (`translucent_pixels`).
    pub rect: [u32; 4],
}

crate::gpu::layout::gpu_layout!(TranslucencyParams as "TranslucencyParams" { radiance, view, dims, lut, rect });

const _: () = {
    assert!(std::mem::size_of::<LutRecord>() == 48);
    assert!(std::mem::size_of::<TranslucentInstance>() == 144);
    assert!(std::mem::offset_of!(TranslucentInstance, info) == 128);
    assert!(std::mem::size_of::<LightViewData>() == 64);
    assert!(std::mem::size_of::<TranslucencyParams>() == 128);
    assert!(std::mem::offset_of!(TranslucencyParams, view) == 16);
    assert!(std::mem::offset_of!(TranslucencyParams, dims) == 80);
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

/// What was baked for one table, for logs and reports.
#[derive(Clone, Debug)]
pub struct LutSummary {
    pub mesh: String,
    pub res: u32,
    /// Bytes of its field and τ (1 a corner, 1 a cell); of a pair table, its N² table bytes.
    pub field_bytes: u64,
    /// A pair table (`thickness = "pairs"`) and its surface voxels; `None` for a field.
    pub surface_voxels: Option<u64>,
}

/// The scene's baked translucency data on the GPU, read by `translucency`: what does not change
/// when instances move (the fields are in object space, exact under any affine transform). What
/// does — the light's view, the instance matrices, the light draws — is a `TranslucentFrame`,
/// made each frame.
pub struct TranslucentData {
    pub tables: Vec<LutSummary>,
    /// The (mesh, voxel_res) of each table, in table order.
    pub keys: Vec<(usize, u32)>,
    // Read as texel buffers (see gpu::texel_buffer for why): the fields (two corners a uint
    // texel) and the LutRecords (3 four-uint texels each).
    pub fields: TexelBuffer,
    pub records: TexelBuffer,
    /// The pair tables, one above the other (R8_UNORM, `PairAtlas`), and the sampler the pass
    /// reads it with; `None` when no table is a pair table.
    pub pairs: Option<(Image, Sampler)>,
    /// The pair tables' copy into their image, until the first frame that reads them records it
    /// (the translucency pass, before its dispatch): putting tables in use waits for nothing.
    pairs_copy: std::sync::Mutex<Option<crate::gpu::staged_image::StagedCopy>>,
}

impl TranslucentData {
    /// Records the pair tables' copy into the frame if no frame has yet (once per set of tables).
    pub fn record_pending_copy(&self, rec: &crate::gpu::recorder::Recorder) {
        let pending = self.pairs_copy.lock().unwrap_or_else(|e| e.into_inner()).take();
        if let Some(copy) = pending {
            copy.record(rec);
        }
    }
}

/// What the translucent instances look like this frame, from the scene's current transforms and
/// lights.
pub struct TranslucentFrame {
    /// The first directional light's view fitted to the translucent instances; `None` without one.
    pub view: Option<LightView>,
    pub view_data: LightViewData,
    /// The first directional light's colour × intensity (point and spot lights add no light through).
    pub radiance: glam::DVec3,
    /// Runs of translucent instances in the scene's instance table, for the light_id pass.
    pub draws: Vec<LightDraw>,
    /// Per scene instance (`instance_table`).
    pub instances: Vec<TranslucentInstance>,
    /// The light maps' side (`light_map_size`).
    pub map_size: u32,
}

impl TranslucentFrame {
    /// `pre_exposure`: the frame's (`FrameContext::pre_exposure`), what the light's radiance is
    /// multiplied by.
    /// `mesh_bounds`: each mesh's object-space bounds in scene order (`SceneGpu::mesh_bounds`).
    pub fn new(
        scene: &Scene,
        mesh_bounds: &[(glam::DVec3, glam::DVec3)],
        data: &TranslucentData,
        pre_exposure: f64,
    ) -> Self {
        let view = LightView::fit_with(scene, mesh_bounds);
        let view_data = view.as_ref().map(LightViewData::new).unwrap_or(LightViewData {
            centre: [0.0, 0.0, 0.0, 1.0],
            right: [1.0, 0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0, 0.0],
            dir: [0.0, 0.0, 1.0, 0.0],
        });
        TranslucentFrame {
            view_data,
            // Pre-exposed as the frame's other radiances (`effects::tonemap::pre_exposure`).
            radiance: scene
                .first_directional_light()
                .map_or(glam::DVec3::ZERO, |l| l.color * l.intensity * pre_exposure),
            draws: draw_runs(scene),
            instances: instance_table(scene, &data.keys),
            map_size: light_map_size_in(scene, mesh_bounds, view.as_ref()),
            view,
        }
    }
}

/// Host-side contents of `TranslucentData`'s buffers and image.
pub(crate) struct Packed {
    tables: Vec<LutSummary>,
    keys: Vec<(usize, u32)>,
    fields: Vec<u32>,
    records: Vec<LutRecord>,
    atlas: PairAtlas,
}

/// The pair tables stacked in one image (no descriptor indexing on lavapipe): table m's row i is
/// image row `first_row_m + i`, its column j image column j; width the largest N, height ΣN.
#[derive(Default)]
struct PairAtlas {
    width: u32,
    height: u32,
    /// width × height bytes, row 0 first.
    bytes: Vec<u8>,
}

impl PairAtlas {
    /// Appends `t`'s rows; returns its first row.
    fn push(&mut self, t: &PairTable) -> u32 {
        let n = t.surface_voxels() as u32;
        let first = self.height;
        if n > self.width {
            // Widen the rows already there (zero columns past each table's N are never read).
            let old = std::mem::take(&mut self.bytes);
            self.bytes = old
                .chunks(self.width.max(1) as usize)
                .flat_map(|row| row.iter().copied().chain(std::iter::repeat_n(0, (n - self.width) as usize)))
                .collect();
            self.width = n;
        }
        for row in t.table.chunks(n as usize) {
            self.bytes.extend_from_slice(row);
            self.bytes.extend(std::iter::repeat_n(0, (self.width - n) as usize));
        }
        self.height += n;
        first
    }
}

/// The device limits a packing must respect.
#[derive(Clone, Copy, Debug)]
pub struct PackLimits {
    /// maxTexelBufferElements: the fields' words (and the pair lookups').
    pub texels: u32,
    /// maxImageDimension2D: the pair atlas's sides.
    pub image_dim: u32,
}

impl PackLimits {
    pub fn of(ctx: &GpuContext) -> Self {
        PackLimits {
            texels: ctx.limits.max_texel_buffer_elements,
            image_dim: ctx.limits.max_image_dimension2_d,
        }
    }
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
    progress: &(dyn Fn(usize, usize) + Sync),
) -> GpuResult<ThicknessLut> {
    let m = &scene.meshes[mesh];
    let options = BakeOptions::default();
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
    baked.map_err(|e| GpuError::Bake {
        what: format!("{}thickness LUT of mesh \"{}\" at {res}³", asked_at(scene, mesh, res, false), m.name),
        message: e.to_string(),
    })
}

/// Where the resolution of the table of `mesh` at `res` was asked for: the voxel_res of a
/// material this mesh is drawn with ("" when none is found).
fn asked_at(scene: &Scene, mesh: usize, res: u32, pairs: bool) -> String {
    scene
        .instances
        .iter()
        .filter(|i| i.mesh == mesh)
        .map(|i| &scene.materials[i.material])
        .find(|mat| match mat.kind {
            MaterialKind::Translucent { voxel_res, thickness, .. } => {
                voxel_res == res && (thickness == ThicknessMode::Pairs) == pairs
            }
            MaterialKind::Lambert => false,
        })
        .map_or(String::new(), |mat| {
            format!("{}: voxel_res of material \"{}\": ", mat.voxel_res_at, mat.name)
        })
}

/// The pair table of `mesh` at `res` (through the bake cache when there is one), refused above
/// the device's image side or the memory budget with the material named.
fn bake_pair_table(
    scene: &Scene,
    mesh: usize,
    res: u32,
    image_dim: u32,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> GpuResult<PairTable> {
    let m = &scene.meshes[mesh];
    let options = PairOptions { max_image_dim: image_dim, ..PairOptions::default() };
    let baked = match BakeCache::from_env() {
        Some(cache) => cache.get_or_bake_pairs(&m.mesh, res, &options, progress).map(|c| {
            log::info!(
                "thickness pair table of mesh \"{}\" at {res}³: {:?} in {:.2} s",
                m.name,
                c.outcome,
                c.seconds
            );
            c.table
        }),
        None => thickness_pairs::bake(&m.mesh, res, &options, progress).map(|(t, _)| t),
    };
    baked.map_err(|e| GpuError::Bake {
        what: format!(
            "{}thickness pair table of mesh \"{}\" at {res}³",
            asked_at(scene, mesh, res, true),
            m.name
        ),
        message: e.to_string(),
    })
}

/// The (mesh, voxel_res) of every table the scene's LUT instances need, in first-use order.
fn table_keys(scene: &Scene) -> Vec<(usize, u32)> {
    let mut keys: Vec<(usize, u32)> = Vec::new();
    for (id, inst) in scene.instances.iter().enumerate() {
        if let Some(key) = translucent_mode(scene, id).and_then(|(res, mode)| table_key(inst.mesh, res, mode))
        {
            if !keys.contains(&key) {
                keys.push(key);
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
            let key = mode.and_then(|(res, mode)| table_key(inst.mesh, res, mode));
            let lut = key.and_then(|key| keys.iter().position(|k| *k == key)).map_or(NO_LUT, |k| k as u32);
            let pairs = key.is_some_and(|(_, r)| r & PAIRS_KEY != 0) && lut != NO_LUT;
            TranslucentInstance {
                model: mat4_f32(inst.transform.matrix),
                inverse_model: mat4_f32(inst.transform.inverse),
                info: [lut, u32::from(mode.is_some()), u32::from(pairs), 0],
            }
        })
        .collect();
    if instances.is_empty() {
        let zero = [[0.0; 4]; 4];
        instances.push(TranslucentInstance { model: zero, inverse_model: zero, info: [NO_LUT, 0, 0, 0] });
    }
    instances
}

fn pack(scene: &Scene, limits: PackLimits) -> GpuResult<Packed> {
    pack_keys(scene, table_keys(scene), limits, &|_, _| {})
}

/// The tables of `keys` (mesh, voxel_res; `table_key`), baked through the cache, packed as the
/// pass reads them (under the device's `limits`); `progress(done, total)` of each bake in turn.
/// Runs on any thread (run-time bakes).
pub(crate) fn pack_keys(
    scene: &Scene,
    keys: Vec<(usize, u32)>,
    limits: PackLimits,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> GpuResult<Packed> {
    let limit = limits.texels;
    let (mut tables, mut fields, mut records) = (Vec::new(), Vec::new(), Vec::new());
    let mut atlas = PairAtlas::default();
    for &(mesh, key_res) in &keys {
        if key_res & PAIRS_KEY != 0 {
            let res = key_res & !PAIRS_KEY;
            let t = bake_pair_table(scene, mesh, res, limits.image_dim, progress)?;
            records.push(pack_pairs(&t, &mut fields, &mut atlas, limits)?);
            tables.push(LutSummary {
                mesh: scene.meshes[mesh].name.clone(),
                res,
                field_bytes: t.bytes(),
                surface_voxels: Some(t.surface_voxels() as u64),
            });
            continue;
        }
        let res = key_res;
        let lut = bake_table(scene, mesh, res, progress)?;
        let words = lut.words();
        if fields.len() as u64 + words.len() as u64 > limit as u64 {
            return Err(GpuError::DeviceLimit {
                what: "translucency thickness fields".into(),
                limit: "maxTexelBufferElements",
                needed: fields.len() as u64 + words.len() as u64,
                max: u64::from(limit),
                message: format!(
                    "the scene's fields need {} words, more than the device's maxTexelBufferElements \
                     {limit}; lower the materials' voxel_res",
                    fields.len() + words.len()
                ),
            });
        }
        records.push(LutRecord {
            origin: v4(lut.origin, lut.voxel_size as f32),
            dims: [lut.dims[0], lut.dims[1], lut.dims[2], fields.len() as u32],
            scale: [lut.scale() as f32, (lut.voxel_size / TAU_STEPS) as f32, 0.0, 0.0],
        });
        fields.extend_from_slice(&words);
        tables.push(LutSummary {
            mesh: scene.meshes[mesh].name.clone(),
            res,
            field_bytes: lut.bytes() as u64,
            surface_voxels: None,
        });
    }
    if records.is_empty() {
        records.push(LutRecord::default());
    }
    if fields.is_empty() {
        fields.push(0);
    }
    Ok(Packed { tables, keys, fields, records, atlas })
}

/// A pair table's record: its lookup and surface coordinates appended to the fields' words, its
/// rows to the atlas. Record layout for a pair table: origin.xyz + h; dims.xyz + the first lookup
/// word; scale.x = D (object units of a stored 1.0), scale.y/z = the bits of its first atlas row
/// and of its first coordinate word.
fn pack_pairs(
    t: &PairTable,
    fields: &mut Vec<u32>,
    atlas: &mut PairAtlas,
    limits: PackLimits,
) -> GpuResult<LutRecord> {
    let v = &t.voxels;
    let words = (v.lookup.len() + v.count()) as u64;
    if fields.len() as u64 + words > limits.texels as u64 {
        return Err(GpuError::DeviceLimit {
            what: "translucency pair lookups".into(),
            limit: "maxTexelBufferElements",
            needed: fields.len() as u64 + words,
            max: u64::from(limits.texels),
            message: format!(
                "the scene's tables need {} words, more than the device's maxTexelBufferElements {}; lower \
                 the materials' voxel_res",
                fields.len() as u64 + words,
                limits.texels
            ),
        });
    }
    let height = atlas.height as u64 + v.count() as u64;
    let width = (atlas.width as u64).max(v.count() as u64);
    let budget = thickness_pairs::DEFAULT_MEMORY_BUDGET;
    if height > limits.image_dim as u64 || width * height > budget {
        return Err(GpuError::DeviceLimit {
            what: "translucency pair tables".into(),
            limit: "maxImageDimension2D",
            needed: height,
            max: u64::from(limits.image_dim),
            message: format!(
                "the scene's pair tables stack to a {width}×{height} image ({} bytes), above the device's \
                 maxImageDimension2D {} or the {budget}-byte budget; lower the voxel_res of the \
                 thickness = \"pairs\" materials",
                width * height,
                limits.image_dim
            ),
        });
    }
    let first_lookup = fields.len() as u32;
    fields.extend_from_slice(&v.lookup);
    let first_coordinate = fields.len() as u32;
    fields.extend(t.coordinate_words());
    let first_row = atlas.push(t);
    Ok(LutRecord {
        origin: v4(v.origin, v.voxel_size as f32),
        dims: [v.dims[0], v.dims[1], v.dims[2], first_lookup],
        scale: [t.max_thickness as f32, f32::from_bits(first_row), f32::from_bits(first_coordinate), 0.0],
    })
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
    /// Bakes (through the cache) and uploads everything the translucency pass reads.
    pub fn new(ctx: &GpuContext, memory: &Memory, scene: &Scene) -> GpuResult<Self> {
        Self::upload(ctx, memory, pack(scene, PackLimits::of(ctx))?)
    }

    /// Uploads tables packed already (`pack_keys`): host-visible texel buffers, written at once;
    /// the pair tables' image (if any) staged, its copy recorded by the first frame that reads it
    /// (`record_pending_copy`). Waits for nothing. A run-time bake writes them over several frames
    /// instead (`Uploading`).
    pub(crate) fn upload(ctx: &GpuContext, memory: &Memory, packed: Packed) -> GpuResult<Self> {
        let mut uploading = Uploading::begin(ctx, memory, packed)?;
        uploading.step(usize::MAX)?;
        uploading.finish(ctx)
    }
}

/// Whether the scene needs the light_id and translucency passes: an instance is translucent.
pub fn needed(scene: &Scene) -> bool {
    (0..scene.instances.len()).any(|i| translucent_mode(scene, i).is_some())
}

/// Some instance reads a thickness LUT: the pass is built with the field's march (WITH_LUT).
/// Under the frame budget's TSM level none does.
pub fn reads_lut(scene: &Scene) -> bool {
    !crate::effects::translucency_budget::tsm_instead_of_tables(scene)
        && (0..scene.instances.len())
            .any(|i| matches!(translucent_mode(scene, i), Some((_, ThicknessMode::Lut))))
}

/// The pass's build: with the march (a LUT) and/or the peel lists, as the scene needs.
pub fn variant(scene: &Scene) -> String {
    format!("lut {} {}", reads_lut(scene), super::peel::variant(scene))
}

pub struct TranslucencyPass {
    pipeline: Arc<Pipeline>,
    /// The FILL_ONLY variant: +inf thickness over the frame, for the pixels outside `rect`.
    fill: Arc<Pipeline>,
    /// The pixels that can show a translucent instance this frame; `None`: none can.
    rect: Option<PixelRect>,
    extent: vk::Extent2D,
    data: Arc<TranslucentData>,
    /// Built with WITH_PEEL: reads the peel pass's lists (bindings 13, 14).
    peel: bool,
}

impl TranslucencyPass {
    /// Its pipelines come from `memo` (made there the first time): a pass rebuilt on new tables
    /// compiles nothing.
    pub fn new(
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        memo: &PipelineMemo,
        data: Arc<TranslucentData>,
        lut: bool,
        peel: bool,
    ) -> GpuResult<Self> {
        // The pair tables' march-free read, where the tables in use hold one.
        let (pipeline, fill) = pipelines(ctx, compiler, memo, lut, peel, data.pairs.is_some())?;
        Ok(TranslucencyPass { pipeline, fill, rect: None, extent: vk::Extent2D::default(), data, peel })
    }
}

/// The translucency pass's pipelines for a variant — with the field's march (`lut`), the peel
/// lists, the pair tables' read (WITH_PAIRS: the image at binding 15) — and its fill pipeline,
/// from `memo` (made there the first time). The renderer asks for the pairs variant ahead, when a
/// pair table starts baking, so the frame that puts it in use compiles nothing.
pub(crate) fn pipelines(
    ctx: &GpuContext,
    compiler: &mut ShaderCompiler,
    memo: &PipelineMemo,
    lut: bool,
    peel: bool,
    pairs: bool,
) -> GpuResult<(Arc<Pipeline>, Arc<Pipeline>)> {
    let flags = [(lut, "WITH_LUT"), (peel, "WITH_PEEL"), (pairs, "WITH_PAIRS")];
    let defines: Vec<(&str, &str)> =
        flags.iter().filter(|(on, _)| *on).map(|&(_, name)| (name, "1")).collect();
    let pipeline = memo.get_or_make(&format!("translucency.comp {defines:?}"), || {
        let spirv = compiler.compile("translucency.comp", &defines)?;
        create_compute_pipeline(ctx, "translucency", &spirv, 0)
    })?;
    let fill = memo.get_or_make("translucency.comp FILL_ONLY", || {
        let spirv = compiler.compile("translucency.comp", &[("FILL_ONLY", "1")])?;
        create_compute_pipeline(ctx, "translucency fill", &spirv, 0)
    })?;
    Ok((pipeline, fill))
}

/// The pixels whose rays can meet a translucent instance: the screen bounds of the corners of
/// their transformed mesh boxes (`Camera::pixel_bounds`; the box's hull holds the mesh). Only
/// these run the per-pixel thickness work.
fn translucent_pixels(
    scene: &Scene,
    mesh_bounds: &[(glam::DVec3, glam::DVec3)],
    extent: vk::Extent2D,
) -> Option<PixelRect> {
    let corners: Vec<DVec3> = (0..scene.instances.len())
        .filter(|&k| translucent_mode(scene, k).is_some())
        .flat_map(|k| {
            let inst = &scene.instances[k];
            let (lo, hi) = mesh_bounds[inst.mesh];
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

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let (scene, extent) = (frame.scene, frame.extent);
        let data = &self.data;
        // Instances may have moved: this frame's light view and matrices.
        // Bounds kept with the vertex buffers: no vertex is read here.
        let bounds = frame.scene_gpu.mesh_bounds();
        let now = TranslucentFrame::new(scene, &bounds, data, frame.pre_exposure);
        self.rect = translucent_pixels(scene, &bounds, extent);
        self.extent = extent;
        let params = TranslucencyParams {
            radiance: v4(now.radiance, if now.view.is_some() { 1.0 } else { 0.0 }),
            view: now.view_data,
            // light_id sized its maps from the same frame.
            dims: [now.map_size, scene.instances.len() as u32, 0, 0],
            lut: [0; 4],
            rect: self.rect.map_or([0; 4], |r| [r.x0, r.y0, r.x1, r.y1]),
        };
        let mut bindings = vec![
            Binding::Bound(Bound::Uniform(frame.upload(&[params])?)),
            Binding::read(Target::Ids),
            Binding::read(Target::Distance),
            Binding::read_write(Target::Hdr),
            Binding::read(Target::LightIds),
            Binding::read(Target::LightZ),
            Binding::write(Target::Thickness),
            Binding::Bound(Bound::UniformTexel(data.fields.view)),
            Binding::Bound(Bound::UniformTexel(data.records.view)),
            Binding::Bound(frame.texels("translucency instances", &now.instances, Texels::U32x4)?),
            Binding::Bound(Bound::Storage(frame.materials)),
            Binding::read(Target::Normal),
            Binding::Bound(Bound::Uniform(frame.uniforms)),
        ];
        if self.peel {
            bindings.extend([Binding::read(Target::PeelCounts), Binding::read(Target::PeelLists)]);
        }
        if let Some((image, sampler)) = &data.pairs {
            // Bindings are by position: without the peel lists, 13 and 14 hold nothing (the
            // shader does not declare them).
            bindings.resize(15, Binding::Bound(Bound::Unused));
            bindings.push(Binding::Bound(Bound::Sampled(image.view, sampler.raw)));
        }
        Ok(bindings)
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        // The fill variant's shader uses fewer bindings: a set of its own.
        vec![&*self.pipeline, &*self.fill]
    }

    fn record(&self, pass: &PassRecording) {
        let extent = self.extent;
        // New pair tables: their copy, before anything reads them.
        self.data.record_pending_copy(pass.rec);
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

    /// Two fields pack one after the other, each on a word, and a total above the texel buffer
    /// limit is refused naming it.
    #[test]
    fn fields_pack_on_words_and_too_many_name_the_limit() {
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
            name = "jade"
            kind = "translucent"
            sigma = [1, 1, 1]
            voxel_res = 5
            [[instance]]
            mesh = "a"
            material = "jade"
            [[instance]]
            mesh = "b"
            material = "jade"
        "#;
        let scene = crate::scene::parse_scene(text, std::path::Path::new("inline.toml")).unwrap();
        let packed = pack_keys(
            &scene,
            table_keys(&scene),
            PackLimits { texels: u32::MAX, image_dim: 16384 },
            &|_, _| {},
        )
        .unwrap();
        assert_eq!(packed.records.len(), 2);
        let first_words = packed.records[1].dims[3] as usize;
        // Corners two a word, then cells four a word: each table's words round its bytes up by
        // less than two words.
        let words = |bytes: u64| (bytes.div_ceil(4), bytes / 4 + 2);
        let (lo, hi) = words(packed.tables[0].field_bytes);
        assert!((lo..hi).contains(&(first_words as u64)), "{first_words} words");
        let (lo, hi) = words(packed.tables[1].field_bytes);
        assert!((lo..hi).contains(&(packed.fields.len() as u64 - first_words as u64)));
        let message =
            pack_keys(&scene, table_keys(&scene), PackLimits { texels: 100, image_dim: 16384 }, &|_, _| {})
                .err()
                .unwrap()
                .to_string();
        assert!(message.contains("maxTexelBufferElements 100"), "{message}");
    }

    /// The march is compiled in only where an instance reads a LUT; the variant says so, so a
    /// world that starts or stops reading one rebuilds the pass.
    #[test]
    fn the_field_march_is_built_only_for_lut_scenes() {
        let scene = crate::builtin::load("builtin:translucency".as_ref()).unwrap();
        assert!(reads_lut(&scene));
        let mut tsm = scene.clone();
        for m in &mut tsm.materials {
            if let MaterialKind::Translucent { thickness, .. } = &mut m.kind {
                *thickness = ThicknessMode::Tsm;
            }
        }
        assert!(!reads_lut(&tsm));
        assert_ne!(variant(&scene), variant(&tsm));
        let peel = crate::builtin::load("builtin:translucency_peel".as_ref()).unwrap();
        assert!(!reads_lut(&peel));
        assert_ne!(variant(&peel), variant(&tsm), "the peel lists are a variant too");
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
