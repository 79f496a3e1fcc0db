//! The validated scene: what `load_scene` returns and every pass reads. All values are finite,
//! all references resolved, all transforms invertible.

use std::path::PathBuf;

use glam::DVec3;

use super::camera::Camera;
use super::mesh::{Mesh, MeshSpec};
use super::transform::{Transform, TransformOp};

/// A validated scene: what `load_scene` and `parse_scene` return and `Runtime::load_scene` takes.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The file this scene was read from (or a label for in-memory scenes).
    pub source: PathBuf,
    /// `[render]`: default image size, exposure, background and ambient.
    pub render: RenderSettings,
    /// `[camera]`.
    pub camera: Camera,
    /// `[[light]]`s in file order, at most `MAX_LIGHTS`; translucent materials are lit through
    /// the first directional one.
    pub lights: Vec<Light>,
    /// `[[mesh]]`es in file order, each built once.
    pub meshes: Vec<SceneMesh>,
    /// `[[material]]`s in file order, then the built-in `"default"` if something needed it.
    pub materials: Vec<Material>,
    /// `[[instance]]`s in file order: the drawn copies of the meshes.
    pub instances: Vec<Instance>,
    /// The world data of the registered effects the scene uses (`crate::effect`), by effect name:
    /// what their scene-file tables said, changed at run time by `Renderer::update_effect`.
    pub effects: crate::effect::EffectStates,
    /// The level the frame budget chose for each effect that offers levels (`crate::budget`);
    /// empty without a budget: every effect uses its own settings.
    pub quality: crate::budget::QualityChoice,
}

impl Scene {
    /// The light translucent materials are lit through (the light-space map, the thickness along
    /// its parallel rays): the first directional one. Point and spot lights light a translucent
    /// surface like an opaque one (the raster's Lambert), without light through the material.
    pub fn first_directional_light(&self) -> Option<&Light> {
        self.lights.iter().find(|l| !l.is_local())
    }
}

/// `[render]`: defaults for rendering the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Default image width in pixels (1..=16384); the CLI's --size overrides it.
    pub width: u32,
    /// Default image height in pixels (1..=16384); the CLI's --size overrides it.
    pub height: u32,
    /// The linear factor the scene-linear HDR colour is multiplied by before the tonemap curve:
    /// `exposure` as written, or 1 / (1.2 · 2^EV100) for `exposure_ev100`. Unused (1) when
    /// `exposure_mode` is `Auto`, whose factor is measured from each frame.
    pub exposure: f64,
    /// How the file gave the exposure: what `exposure` means.
    pub exposure_mode: ExposureMode,
    /// Linear HDR colour where no surface is hit.
    pub background: DVec3,
    /// Linear ambient light added to every lit surface (times its albedo).
    pub ambient: DVec3,
    /// Write a temporal upscaler's inputs (`Aov::UPSCALER`: motion, reactive and composition
    /// masks); `Renderer::set_motion_vectors`.
    pub motion_vectors: bool,
    /// `budget_ms`: the GPU time per frame the frame budget fits the effects' levels into
    /// (`crate::budget`); `Renderer::set_frame_budget` and `RendererOptions::frame_budget_ms`
    /// override it. None: no budget.
    pub budget_ms: Option<f64>,
}

/// How `[render]` gives the exposure (docs/scene-format.md, "Exposure and light units").
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum ExposureMode {
    /// `exposure = <number>` or none: `RenderSettings::exposure` as written (default 1).
    #[default]
    Linear,
    /// `exposure_ev100 = <number>`: `RenderSettings::exposure` = 1 / (1.2 · 2^EV100).
    Ev100(f64),
    /// `exposure = "auto"`: from each frame's luminance (`effects::tonemap::auto_exposure`),
    /// smoothed over time when frames follow each other.
    Auto,
}

/// What a `[[light]]` is: a directional light at infinite distance, or a point or spot light at
/// a position (glTF's `KHR_lights_punctual` kinds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Shines down `direction` everywhere; `intensity` is the luminance (cd/m²) of a white
    /// Lambertian surface facing it: illuminance (lux) / π.
    Directional,
    /// Shines every way from `position`; `intensity` in candela (cd, luminous intensity).
    Point,
    /// Shines from `position` down `direction` in a cone; `intensity` in candela on its axis.
    /// Half-angles from the axis in radians: full inside `inner_cone`, none outside `outer_cone`,
    /// between them glTF's smooth attenuation (`Light::cone_attenuation`). `inner_cone` ≥
    /// `outer_cone` gives glTF's guard: a ramp 0.001 wide in cos θ just inside `outer_cone`.
    Spot {
        /// Half-angle (radians) within which the light is full.
        inner_cone: f64,
        /// Half-angle (radians) outside which there is no light.
        outer_cone: f64,
    },
}

/// A `[[light]]` (or a glTF light, or one spawned at run time).
///
/// What a surface point p with unit normal n receives (docs/scene-format.md, "Exposure and light
/// units"; twin of shaders/common/frame.glsl's `light_arriving`):
/// - directional: color · intensity · max(0, −n·direction);
/// - point and spot: color · intensity / π · max(0, n·l) · window · cone² / d², with d = |position −
///   p| (d² floored at `LOCAL_LIGHT_D2_MIN`), l = (position − p) / d, window = clamp(1 −
///   (d/range)⁴, 0, 1) (1 without a range) and cone = 1 for a point light. The illuminance of a
///   point light of I candela on a surface facing it at distance d is I/d² lux, so the luminance
///   of a white Lambertian surface is I/(π·d²): the directional rule E/π.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Directional, point or spot.
    pub kind: LightKind,
    /// Unit direction the light travels: a directional light's, a spot light's axis (from the
    /// light outward). Unused by a point light (−z).
    pub direction: DVec3,
    /// Where a point or spot light is (world space); unused by a directional light (0).
    pub position: DVec3,
    /// Linear RGB, each ≥ 0.
    pub color: DVec3,
    /// ≥ 0: a directional light's luminance of a white surface facing it (lux / π, cd/m²); a
    /// point or spot light's candela (`LightKind`).
    pub intensity: f64,
    /// Point and spot lights: the distance where glTF's smooth window reaches 0 (> 0); None:
    /// infinite, the pure inverse square.
    pub range: Option<f64>,
}

/// d² below this (in world units²) is taken as this in a point or spot light's 1/d²: a surface
/// point at the light gets a finite light (and none at all where l = 0), never NaN or ∞.
pub const LOCAL_LIGHT_D2_MIN: f64 = 1e-30;
/// The largest radiance a point or spot light adds to a surface before its albedo (pre-exposed
/// HDR units), so that neither a sum of 8 nor a product with an albedo of 0 overflows f32 (∞, or
/// 0 · ∞ = NaN). The shaded colour is then clamped to the HDR target's largest value.
pub const LOCAL_LIGHT_MAX: f64 = 1e30;

impl Light {
    /// A directional light travelling along `direction` (normalized here; non-zero).
    pub fn directional(direction: DVec3, color: DVec3, intensity: f64) -> Self {
        Light {
            kind: LightKind::Directional,
            direction: direction.normalize(),
            position: DVec3::ZERO,
            color,
            intensity,
            range: None,
        }
    }

    /// A point light at `position` of `candela`, infinite range.
    pub fn point(position: DVec3, color: DVec3, candela: f64) -> Self {
        Light {
            kind: LightKind::Point,
            direction: DVec3::NEG_Z,
            position,
            color,
            intensity: candela,
            range: None,
        }
    }

    /// A spot light at `position` shining down `direction` (normalized here; non-zero), cone
    /// half-angles in radians, infinite range.
    pub fn spot(
        position: DVec3,
        direction: DVec3,
        color: DVec3,
        candela: f64,
        inner_cone: f64,
        outer_cone: f64,
    ) -> Self {
        Light {
            kind: LightKind::Spot { inner_cone, outer_cone },
            direction: direction.normalize(),
            position,
            color,
            intensity: candela,
            range: None,
        }
    }

    /// The same light with glTF's `range` (> 0).
    pub fn with_range(self, range: f64) -> Self {
        Light { range: Some(range), ..self }
    }

    /// A point or spot light (at a position).
    pub fn is_local(&self) -> bool {
        !matches!(self.kind, LightKind::Directional)
    }

    /// colour × the factor a white surface facing the light at unit distance gets: colour ×
    /// intensity for a directional light, colour × candela / π for a point or spot light.
    pub fn radiance(&self) -> DVec3 {
        match self.kind {
            LightKind::Directional => self.color * self.intensity,
            _ => self.color * (self.intensity / std::f64::consts::PI),
        }
    }

    /// glTF's spot cone as the scale and offset of cos θ (θ from the axis): attenuation =
    /// clamp(cos θ · scale + offset, 0, 1)², scale = 1 / max(0.001, cos inner − cos outer), offset
    /// = −cos outer · scale (the spec's recommended implementation). A point light: (0, 1), 1
    /// everywhere.
    pub fn cone_scale_offset(&self) -> (f64, f64) {
        match self.kind {
            LightKind::Spot { inner_cone, outer_cone } => {
                let scale = 1.0 / (inner_cone.cos() - outer_cone.cos()).max(0.001);
                (scale, -outer_cone.cos() * scale)
            }
            _ => (0.0, 1.0),
        }
    }

    /// The spot cone's attenuation for a direction of travel `toward` (unit, from the light to the
    /// surface): clamp(cos θ · scale + offset, 0, 1)²; 1 for a point light.
    pub fn cone_attenuation(&self, toward: DVec3) -> f64 {
        let (scale, offset) = self.cone_scale_offset();
        let c = (self.direction.dot(toward) * scale + offset).clamp(0.0, 1.0);
        c * c
    }

    /// glTF's range window at distance² `d2`: clamp(1 − (d/range)⁴, 0, 1); 1 without a range.
    pub fn window(&self, d2: f64) -> f64 {
        match self.range {
            Some(r) => {
                let t = d2 / (r * r);
                (1.0 - t * t).clamp(0.0, 1.0)
            }
            None => 1.0,
        }
    }
}

/// A `[[mesh]]`: what the file asked for and the mesh built from it.
#[derive(Clone, Debug)]
pub struct SceneMesh {
    /// Unique among the scene's meshes; instances refer to it.
    pub name: String,
    /// The shape and parameters given (an OBJ path already resolved against the scene's folder).
    pub spec: MeshSpec,
    /// `spec` built.
    pub mesh: Mesh,
    /// `wobble`/`wobble_hz`: the mesh deforms with scene time (`scene::wobble`); None when still.
    pub wobble: Option<super::wobble::Wobble>,
}

/// A `[[material]]` (or the built-in `"default"`).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Unique among the scene's materials; instances and metaball groups refer to it.
    pub name: String,
    /// Lambert or translucent.
    pub kind: MaterialKind,
    /// Linear RGB diffuse reflectance, each in [0, 1].
    pub albedo: DVec3,
    /// Where the material's `voxel_res` was given ("file:line:column"; its table when the file
    /// gives none), for errors found after loading: a thickness table too large for the device.
    pub voxel_res_at: String,
    /// What a glTF material adds to the albedo: emission, alpha mask, base-colour texture
    /// (`Surface::default()`, none of them, for TOML materials).
    pub surface: Surface,
}

/// The parts of a glTF material the raster draws beyond the albedo. The default changes
/// nothing: emission exactly 0 is added, no fragment is discarded.
#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    /// Linear RGB radiance added to the shaded colour: `emissiveFactor` ×
    /// `KHR_materials_emissive_strength` (each ≥ 0, finite).
    pub emission: DVec3,
    /// The base colour's alpha (`baseColorFactor[3]`), in [0, 1].
    pub alpha: f64,
    /// `alphaMode: MASK`: a fragment whose alpha (base × vertex colour × texture alpha) is below
    /// this is not drawn; 0 (opaque) discards nothing.
    pub alpha_cutoff: f64,
    /// The base-colour and emissive textures (none: drawn exactly as before textures existed).
    pub textures: super::texture::MaterialTextures,
}

impl Default for Surface {
    fn default() -> Self {
        Surface { emission: DVec3::ZERO, alpha: 1.0, alpha_cutoff: 0.0, textures: Default::default() }
    }
}

/// How a material shades.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MaterialKind {
    /// Diffuse only: albedo × (ambient + the lights' Lambert terms).
    Lambert,
    /// Seed 003: light crossing the object is attenuated by exp(−σ·d) per RGB channel, d the
    /// material thickness along the light's path (cavities excluded with `ThicknessMode::Lut`).
    Translucent {
        /// Extinction σ per world unit, each channel > 0.
        sigma: DVec3,
        /// Voxel resolution of the mesh's thickness LUT bake (4..=128).
        voxel_res: u32,
        /// Where the thickness d comes from.
        thickness: ThicknessMode,
    },
}

/// `voxel_res` of a translucent material when the file gives none: 48³ keeps the LUT of a typical
/// object at a few MB (see effects::thickness_lut) and its bake at seconds.
pub const DEFAULT_VOXEL_RES: u32 = 48;
/// `voxel_res` range: below 4 little but a box survives voxelization; above 128 the table of even a
/// simple shape outgrows a 16384² texture.
pub const MIN_VOXEL_RES: u32 = 4;
/// Largest `voxel_res` (see `MIN_VOXEL_RES`).
pub const MAX_VOXEL_RES: u32 = 128;

/// Where a translucent material's thickness comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ThicknessMode {
    /// The baked thickness LUT (effects::thickness_lut): cavities excluded.
    Lut,
    /// Translucent shadow maps: distance from the light's entry point, cavities counted.
    Tsm,
    /// No bake: each frame the instance's surfaces are rasterized from the light into per-texel
    /// depth lists (the `peel` pass) and the inside intervals of the instance between the light
    /// and the pixel are summed; cavities excluded, follows meshes deformed at run time.
    Peel,
    /// The seed's own LUT (effects::thickness_pairs): the thickness between the centroids of every
    /// pair of surface voxels, cavities excluded, in an N×N R8 image (memory ∝ N²).
    Pairs,
}

impl ThicknessMode {
    /// The mode reads a table baked from the loaded shape (`lut`, `pairs`): a mesh that deforms
    /// cannot use it.
    pub fn is_baked(self) -> bool {
        matches!(self, ThicknessMode::Lut | ThicknessMode::Pairs)
    }
}

/// An `[[instance]]`: one drawn copy of a mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// A label for logs and tools; None when the file gives none.
    pub name: Option<String>,
    /// Index into `Scene::meshes`.
    pub mesh: usize,
    /// Index into `Scene::materials`.
    pub material: usize,
    /// The `transform` steps as given, in the order they apply to the object.
    pub ops: Vec<TransformOp>,
    /// `ops` composed: object → world, with its inverse.
    pub transform: Transform,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 512,
            height: 512,
            exposure: 1.0,
            exposure_mode: ExposureMode::Linear,
            background: DVec3::new(0.02, 0.02, 0.03),
            ambient: DVec3::splat(0.08),
            motion_vectors: false,
            budget_ms: None,
        }
    }
}

/// How the energy-wave pass integrates a wave along each view ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WaveMethod {
    /// The closed-form line integral (asinh/log1p), exact up to f32 rounding.
    Analytic,
    /// The baseline: `steps` samples of the density along [0, L] (midpoint rule; with `jitter`,
    /// one per-pixel random offset shared by all samples of the ray).
    Raymarch {
        /// Samples per ray, 1..=65536.
        steps: u32,
        /// Place a pixel's samples at one random offset within their steps (the same for all of
        /// them) instead of at the midpoints: noise instead of banding.
        jitter: bool,
    },
}

/// An energy wave (seed 004): E(P) = a·k(|P − M|) + b·k(dist(P, segment M → M + ℓD)),
/// k(r) = 1/√(r² + ε²). Values here are those at time 0, before keyframes and velocity.
#[derive(Clone, Debug, PartialEq)]
pub struct Wave {
    /// A label for logs and tools; None when the file gives none.
    pub name: Option<String>,
    /// M at time 0.
    pub origin: DVec3,
    /// M moves by velocity × time (added to the keyframed origin).
    pub velocity: DVec3,
    /// D, unit length.
    pub direction: DVec3,
    /// Sphere strength a ≥ 0.
    pub a: f64,
    /// Line strength b ≥ 0.
    pub b: f64,
    /// Soft core radius ε ≥ 0.
    pub core: f64,
    /// Beam length ℓ > 0; `f64::INFINITY` when not given.
    pub length: f64,
    /// Linear RGB emission colour.
    pub color: DVec3,
    /// Emission added to HDR = color × intensity × H.
    pub intensity: f64,
    /// Energy below which the wave emits nothing: HDR gets colour × intensity × max(H − cutoff,
    /// 0) (0: the seed's integral as it is). The energy AOV holds H itself.
    pub cutoff: f64,
    /// How the pass integrates the wave along each view ray.
    pub method: WaveMethod,
    /// The relative error of H per pixel the pass may trade for speed (0: every pixel exact);
    /// None: the default, `Wave::effective_tolerance`. See `effects::energy_wave::tolerance`.
    pub tolerance: Option<f64>,
    /// Sorted by time, strictly increasing.
    pub keyframes: Vec<WaveKeyframe>,
}

/// Values a wave takes at `time`; each field given here is a piecewise-linear track through the
/// keyframes that set it (held constant before the first and after the last of them).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct WaveKeyframe {
    /// Scene time in seconds.
    pub time: f64,
    /// M (before velocity × time is added).
    pub origin: Option<DVec3>,
    /// Interpolated by normalized lerp (consecutive directions are never opposite).
    pub direction: Option<DVec3>,
    /// Sphere strength a ≥ 0.
    pub a: Option<f64>,
    /// Line strength b ≥ 0.
    pub b: Option<f64>,
    /// Soft core radius ε ≥ 0.
    pub core: Option<f64>,
    /// Beam length ℓ > 0, finite.
    pub length: Option<f64>,
    /// Emission multiplier ≥ 0.
    pub intensity: Option<f64>,
}

/// A metaball group (seed 000; `[[metaballs]]`, docs/scene-format.md): the surface
/// Σ qᵢ f(‖x − cᵢ‖²/Rᵢ²) = T in the group's object space, placed by `transform`. Values here
/// are those at time 0; `MetaballGroup::at(T)` (metaball_track.rs) gives the group at time T.
#[derive(Clone, Debug, PartialEq)]
pub struct MetaballGroup {
    /// A label for logs and tools; None when the file gives none.
    pub name: Option<String>,
    /// T > 0.
    pub threshold: f64,
    /// The falloff f of each ball's density.
    pub kernel: crate::effects::metaballs::Kernel,
    /// Index into `Scene::materials` (shading of the surface).
    pub material: usize,
    /// The `transform` steps as given, in the order they apply to the group.
    pub ops: Vec<TransformOp>,
    /// `ops` composed: object → world, with its inverse.
    pub transform: Transform,
    /// The `balls` listed in the file, then the generated ones; never empty.
    pub balls: Vec<AnimatedBall>,
    /// Sorted by time, strictly increasing.
    pub keyframes: Vec<MetaballKeyframe>,
    /// How the metaballs pass casts rays against the group (`method`, `tolerance`, `steps`).
    pub method: crate::effects::metaballs::CastMethod,
    /// Balls the game writes on the GPU (`Renderer::set_metaball_buffer`): drawn instead of
    /// `balls` (and `keyframes`), which the f64 references keep using.
    pub device: Option<crate::effects::metaballs::device::DeviceBalls>,
}

/// One ball of a group: its values at time 0 and its rates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnimatedBall {
    /// Object-space centre at time 0 (unless keyframes set the centres).
    pub centre: DVec3,
    /// Support radius R > 0.
    pub radius: f64,
    /// Density coefficient q at time 0 (any sign).
    pub q: f64,
    /// The centre moves by velocity × T (added to the keyframed centre).
    pub velocity: DVec3,
    /// q changes by q_rate × T (added to the keyframed q).
    pub q_rate: f64,
}

/// A `[[metaballs.keyframe]]`: at `time`, every ball's centre and/or q (one entry per ball, in
/// the order of `MetaballGroup::balls`).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct MetaballKeyframe {
    /// Scene time in seconds.
    pub time: f64,
    /// Object-space centre of every ball (before velocity × time is added).
    pub centres: Option<Vec<DVec3>>,
    /// Density coefficient of every ball (before q_rate × time is added).
    pub q: Option<Vec<f64>>,
}
