//! Structs shared with GLSL (shaders/common/frame.glsl). Each is bound as a typed buffer range, so
//! its size is checked against the shader's layout whenever it is bound (`gpu::reflect`); its
//! `gpu_layout!` declaration has every member's name, offset and GLSL type checked against every
//! shader that uses it (`passes::shader_structs`).

use bytemuck::{Pod, Zeroable};
use glam::{DMat3, DMat4, DVec3};

use crate::scene::Scene;

pub const MAX_LIGHTS: usize = 8;

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuLight {
    /// xyz: the unit direction a directional light travels, a spot light's axis (0 for a point
    /// light); w: 0.
    pub direction: [f32; 4],
    /// rgb: `Light::radiance()` pre-exposed; w: 1 / range² (0: no range) of a point or spot light.
    pub radiance: [f32; 4],
    /// xyz: a point or spot light's position relative to the camera; w: 1 for them, 0 for a
    /// directional light.
    pub position: [f32; 4],
    /// x, y: the spot cone's scale and offset of cos θ (`Light::cone_scale_offset`; a point or
    /// directional light: 0, 1).
    pub cone: [f32; 4],
}

crate::gpu::layout::gpu_layout!(GpuLight as "Light" { direction, radiance, position, cone });

impl GpuLight {
    /// `light` with its radiance pre-exposed by `p`, a point or spot light's position relative to
    /// `origin` (the camera's position: the shaders light positions relative to the camera,
    /// subtracted here in f64). A directional light's record holds exactly what it did before
    /// point and spot lights existed (direction, colour × intensity × p).
    pub fn new(light: &crate::scene::Light, p: f64, origin: DVec3) -> Self {
        let (scale, offset) = light.cone_scale_offset();
        let cone = [scale as f32, offset as f32, 0.0, 0.0];
        if !light.is_local() {
            return GpuLight {
                direction: vec4_f32(light.direction, 0.0),
                radiance: vec4_f32(light.radiance() * p, 0.0),
                position: [0.0; 4],
                cone,
            };
        }
        // 1/range² within f32 (a range below 2⁻⁶³ would be +inf: the window is 0 anyway).
        let inv_range2 = light.range.map_or(0.0, |r| (1.0 / (r * r)).min(f32::MAX as f64)) as f32;
        GpuLight {
            direction: vec4_f32(light.direction, 0.0),
            radiance: vec4_f32(light.radiance() * p, inv_range2),
            position: vec4_f32(light.position - origin, 1.0),
            cone,
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniforms {
    /// The camera's view-projection composed with T(camera position) in f64: it takes positions
    /// relative to the camera (world − camera), so that no f32 product cancels coordinates far
    /// from the world's origin (shaders/raster.vert).
    pub view_proj: [[f32; 4]; 4],
    /// xyz: the camera's position in f32 (its high part; `camera_low` holds the rest).
    pub camera_pos: [f32; 4],
    pub ambient: [f32; 4],
    pub background: [f32; 4],
    /// x: lights, y: width, z: height, w: instances.
    pub counts: [u32; 4],
    pub lights: [GpuLight; MAX_LIGHTS],
    /// The camera's ray frame (`Camera::ray_frame`, shaders/common/camera.glsl's
    /// `camera_pixel_ray`): xyz right × the lens's x scale, w its ndc offset.
    pub ray_right: [f32; 4],
    /// xyz image up × the lens's y scale, w its ndc offset.
    pub ray_up: [f32; 4],
    /// xyz the unit view direction, w the camera's far distance.
    pub ray_forward: [f32; 4],
    /// xyz: the camera's position − `camera_pos` (what f32 rounded off it), w: 0.
    pub camera_low: [f32; 4],
}

crate::gpu::layout::gpu_layout!(FrameUniforms as "FrameUniforms" {
    view_proj, camera_pos, ambient, background, counts, lights, ray_right, ray_up, ray_forward, camera_low
});

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct InstanceData {
    pub model: [[f32; 4]; 4],
    /// M⁻ᵀ in the upper 3×3; column 3, xyz: the model's translation − `model`'s (what f32
    /// rounded off it: shaders/raster.vert adds it to the vertex's position relative to the
    /// camera), w: 1.
    pub normal_matrix: [[f32; 4]; 4],
    /// x: instance id (scene order), y: material id.
    pub ids: [u32; 4],
}

crate::gpu::layout::gpu_layout!(InstanceData as "InstanceData" { model, normal_matrix, ids });

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct MaterialData {
    /// rgb: the albedo; a: the base colour's alpha (`Surface::alpha`).
    pub albedo: [f32; 4],
    /// x: `MATERIAL_LAMBERT` or `MATERIAL_TRANSLUCENT`; y (translucent): `THICKNESS_LUT`,
    /// `THICKNESS_TSM`, `THICKNESS_PEEL` or `THICKNESS_PAIRS`.
    pub kind: [u32; 4],
    /// rgb (translucent): extinction σ per world unit; 0 for lambert.
    pub sigma: [f32; 4],
    /// rgb: emission added to the shaded colour (0 for TOML materials); a: the alpha cutoff
    /// (`Surface::alpha_cutoff`, 0: nothing discarded).
    pub emission: [f32; 4],
}

crate::gpu::layout::gpu_layout!(MaterialData as "MaterialData" { albedo, kind, sigma, emission });

/// `MaterialData::kind` values. Keep in sync with shaders/common/frame.glsl.
pub const MATERIAL_LAMBERT: u32 = 0;
pub const MATERIAL_TRANSLUCENT: u32 = 1;
pub const THICKNESS_LUT: u32 = 0;
pub const THICKNESS_TSM: u32 = 1;
/// `MaterialData::kind.y` of a translucent material with `thickness = "peel"`.
pub const THICKNESS_PEEL: u32 = 2;
/// `MaterialData::kind.y` of a translucent material with `thickness = "pairs"`.
pub const THICKNESS_PAIRS: u32 = 3;

const _: () = {
    assert!(std::mem::size_of::<GpuLight>() == 64);
    assert!(std::mem::size_of::<FrameUniforms>() == 128 + 64 * MAX_LIGHTS + 64);
    assert!(std::mem::offset_of!(FrameUniforms, camera_pos) == 64);
    assert!(std::mem::offset_of!(FrameUniforms, counts) == 112);
    assert!(std::mem::offset_of!(FrameUniforms, lights) == 128);
    assert!(std::mem::size_of::<InstanceData>() == 144);
    assert!(std::mem::offset_of!(InstanceData, ids) == 128);
    assert!(std::mem::size_of::<MaterialData>() == 64);
    assert!(std::mem::offset_of!(MaterialData, sigma) == 32);
    assert!(std::mem::offset_of!(MaterialData, emission) == 48);
};

pub fn mat4_f32(m: DMat4) -> [[f32; 4]; 4] {
    m.to_cols_array_2d().map(|c| c.map(|v| v as f32))
}

fn vec4_f32(v: DVec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

fn mat3_as_mat4(m: DMat3) -> [[f32; 4]; 4] {
    mat4_f32(DMat4::from_mat3(m))
}

/// What rounding `v` to f32 leaves off it, in f32: `v` = f32(v) + low_part(v) to ~2⁻⁴⁸ of |v|.
fn low_part(v: DVec3, w: f32) -> [f32; 4] {
    let high = v.as_vec3().as_dvec3();
    vec4_f32(v - high, w)
}

impl FrameUniforms {
    /// The radiances (lights, ambient, background) are pre-exposed: multiplied by `p`, the frame's
    /// `effects::tonemap::pre_exposure` (1 for every scene with a linear exposure that fits).
    pub fn new(scene: &Scene, width: u32, height: u32, p: f64) -> Self {
        let mut lights = [GpuLight::default(); MAX_LIGHTS];
        for (slot, light) in lights.iter_mut().zip(&scene.lights) {
            *slot = GpuLight::new(light, p, scene.camera.position);
        }
        let [ray_right, ray_up, mut ray_forward] = scene.camera.ray_frame(width, height).to_f32();
        ray_forward[3] = scene.camera.far as f32;
        FrameUniforms {
            view_proj: mat4_f32(
                scene.camera.view_projection(width, height) * DMat4::from_translation(scene.camera.position),
            ),
            camera_pos: vec4_f32(scene.camera.position, 1.0),
            camera_low: low_part(scene.camera.position, 0.0),
            ambient: vec4_f32(scene.render.ambient * p, 0.0),
            background: vec4_f32(scene.render.background * p, 1.0),
            counts: [scene.lights.len().min(MAX_LIGHTS) as u32, width, height, scene.instances.len() as u32],
            lights,
            ray_right,
            ray_up,
            ray_forward,
        }
    }
}

/// Per-instance records, grouped by mesh so each mesh is one instanced draw. Returns the records
/// and, per mesh, the (first, count) range of its instances. A counting sort by mesh: O(meshes +
/// instances), instances in scene order within each mesh.
pub fn instance_records(scene: &Scene) -> (Vec<InstanceData>, Vec<(u32, u32)>) {
    let mut counts = vec![0u32; scene.meshes.len()];
    for inst in &scene.instances {
        counts[inst.mesh] += 1;
    }
    let mut ranges = Vec::with_capacity(counts.len());
    let mut first = 0u32;
    for &count in &counts {
        ranges.push((first, count));
        first += count;
    }
    let mut next: Vec<u32> = ranges.iter().map(|&(first, _)| first).collect();
    let mut records = vec![InstanceData::zeroed(); scene.instances.len()];
    for (id, inst) in scene.instances.iter().enumerate() {
        let mut normal_matrix = mat3_as_mat4(inst.transform.normal_matrix());
        normal_matrix[3] = low_part(inst.transform.matrix.w_axis.truncate(), 1.0);
        records[next[inst.mesh] as usize] = InstanceData {
            model: mat4_f32(inst.transform.matrix),
            normal_matrix,
            ids: [id as u32, inst.material as u32, 0, 0],
        };
        next[inst.mesh] += 1;
    }
    (records, ranges)
}

/// The material table; emission is a radiance written into the HDR target, pre-exposed by `p` as
/// the lights are.
pub fn material_records(scene: &Scene, p: f64) -> Vec<MaterialData> {
    use crate::scene::{MaterialKind, ThicknessMode};
    let record = |m: &crate::scene::Material| {
        let albedo = vec4_f32(m.albedo, m.surface.alpha as f32);
        let emission = vec4_f32(m.surface.emission * p, m.surface.alpha_cutoff as f32);
        match m.kind {
            MaterialKind::Lambert => {
                MaterialData { albedo, kind: [MATERIAL_LAMBERT, 0, 0, 0], sigma: [0.0; 4], emission }
            }
            MaterialKind::Translucent { sigma, thickness, .. } => {
                // The frame budget's TSM level: the tables are not read (they stay uploaded).
                let tsm = crate::effects::translucency_budget::tsm_instead_of_tables(scene);
                let thickness = if tsm && thickness.is_baked() { ThicknessMode::Tsm } else { thickness };
                let mode = match thickness {
                    ThicknessMode::Lut => THICKNESS_LUT,
                    ThicknessMode::Tsm => THICKNESS_TSM,
                    ThicknessMode::Peel => THICKNESS_PEEL,
                    ThicknessMode::Pairs => THICKNESS_PAIRS,
                };
                let kind = [MATERIAL_TRANSLUCENT, mode, 0, 0];
                MaterialData { albedo, kind, sigma: vec4_f32(sigma, 0.0), emission }
            }
        }
    };
    scene.materials.iter().map(record).collect()
}
