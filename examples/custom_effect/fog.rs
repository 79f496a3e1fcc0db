//! A height fog written as a game writes an effect: its own `[fog]` scene-file table, its world
//! data (`Fog`, changed per frame through `Renderer::update_effect`), one compute pass with its
//! own shader (fog.comp) and its own image (the transmittance, readable as an AOV), and its f64
//! twin (`Fog::transmittance`). It uses only hadou's public API: no file of the library knows it.
//!
//! The fog: ρ(y) = density · exp(−falloff · (y − base_height)). Along the view ray
//! p(t) = C + t·u, t ∈ [0, L] (L: the first surface, else the camera's far distance) its optical
//! depth is τ = ρ(C_y) · L · (1 − e^(−x)) / x with x = falloff · u_y · L, and the pixel becomes
//! HDR · T + colour · (1 − T), T = e^(−τ).

use glam::DVec3;
use hadou::effect::{
    Binding, Bound, Effect, EffectPass, EffectState, FrameContext, GpuResult, ImageDesc, Pass, PassBuilder,
    PassRecording, Pipeline, SceneFile, Target,
};
use hadou::gpu::vk;
use hadou::scene::{Scene, SceneError};
use serde::Deserialize;
use toml::Spanned;

/// The fog's world data: what `[fog]` says, and what a game changes at run time.
#[derive(Clone, Debug, PartialEq)]
pub struct Fog {
    /// Extinction per world unit at `base_height`, ≥ 0 (0: no fog, the pass does not run).
    pub density: f64,
    /// How fast the density falls with height, per world unit, in 0..=1e6 (0: uniform fog).
    pub falloff: f64,
    /// The height where the density is `density`.
    pub base_height: f64,
    /// Linear RGB in-scattered colour, each channel in 0..=65504 (RGBA16F's largest).
    pub color: DVec3,
}

/// Largest `falloff`: keeps falloff × (any height difference ≤ 2⁴⁹) finite in f32.
pub const MAX_FALLOFF: f64 = 1e6;
/// Largest |base_height| (hadou's largest camera coordinate, 2⁴⁸).
pub const MAX_HEIGHT: f64 = 281474976710656.0;

impl Fog {
    /// Whether the values are in the documented ranges (what the shader is written for).
    pub fn is_valid(&self) -> bool {
        self.density.is_finite()
            && self.density >= 0.0
            && self.density <= f64::from(f32::MAX)
            && (0.0..=MAX_FALLOFF).contains(&self.falloff)
            && self.base_height.abs() <= MAX_HEIGHT
            && self.color.is_finite()
            && self.color.min_element() >= 0.0
            && self.color.max_element() <= 65504.0
    }

    /// The f64 twin of fog.comp: transmittance T = e^(−τ) along the unit ray `u` from `camera`
    /// over length `len` (≥ 0, +inf allowed only where the shader clips it to `far` first).
    pub fn transmittance(&self, camera: DVec3, u: DVec3, len: f64) -> f64 {
        (-self.optical_depth(camera, u, len)).exp()
    }

    /// τ along the ray (see the module docs), in f64.
    pub fn optical_depth(&self, camera: DVec3, u: DVec3, len: f64) -> f64 {
        if len == 0.0 || self.density == 0.0 {
            return 0.0;
        }
        let k = self.falloff;
        let x = k * u.y * len;
        // L · (1 − e^(−x)) / x, exact at x = 0; −expm1 keeps the small-x digits.
        let span = if x == 0.0 { len } else { len * -(-x).exp_m1() / x };
        self.density * (-k * (camera.y - self.base_height)).exp() * span
    }
}

/// The `[fog]` table as TOML spells it.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [fog] table")]
struct FogTable {
    density: Spanned<f64>,
    falloff: Option<Spanned<f64>>,
    base_height: Option<Spanned<f64>>,
    color: Option<Spanned<[f64; 3]>>,
}

/// The effect: registered with `Effects::builtin().with(HeightFog::default())`. Its configuration
/// is the game's, not the scene file's: it travels into the pass through `EffectPass`'s closures.
#[derive(Clone, Copy, Debug, Default)]
pub struct HeightFog {
    /// Fog thinner than this (density per world unit at `base_height`) is not drawn: its pass is
    /// not even run (a game's quality setting). 0, the default, draws any fog of density > 0.
    pub min_density: f64,
}

/// Its image: the transmittance T per pixel (R32F), an AOV as `Aov::Effect(&FOG_TRANSMITTANCE)`.
pub static FOG_TRANSMITTANCE: ImageDesc = ImageDesc {
    name: "fog_transmittance",
    format: vk::Format::R32_SFLOAT,
    texel_bytes: 4,
    usage: vk::ImageUsageFlags::empty(),
    needs: "a [fog] table with density > 0",
};

impl Effect for HeightFog {
    fn name(&self) -> &'static str {
        "height_fog"
    }

    fn tables(&self) -> &'static [&'static str] {
        &["fog"]
    }

    fn load(&self, file: &SceneFile) -> Result<Option<Box<dyn EffectState>>, SceneError> {
        let Some(table) = file.table::<FogTable>("fog")? else { return Ok(None) };
        let t = table.get_ref();
        let number = |field: &str, v: &Spanned<f64>, ok: bool, expected: &str| {
            if ok {
                Ok(*v.get_ref())
            } else {
                Err(file.invalid("fog", field, v, expected))
            }
        };
        let d = &t.density;
        let density = number(
            "density",
            d,
            d.get_ref().is_finite() && (0.0..=3.4e38).contains(d.get_ref()),
            "a number in 0..=3.4e38",
        )?;
        let falloff = match &t.falloff {
            Some(f) => {
                number("falloff", f, (0.0..=MAX_FALLOFF).contains(f.get_ref()), "a number in 0..=1e6")?
            }
            None => 0.0,
        };
        let base_height = match &t.base_height {
            Some(h) => number("base_height", h, h.get_ref().abs() <= MAX_HEIGHT, "a number within ±2⁴⁸")?,
            None => 0.0,
        };
        let color = match &t.color {
            Some(c) => {
                let v = DVec3::from_array(*c.get_ref());
                if !(v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= 65504.0) {
                    let found = format!("[{}, {}, {}]", v.x, v.y, v.z);
                    let message = format!("[fog] `color`: expected 3 numbers in 0..=65504, found {found}");
                    return Err(file.error(c.span(), message));
                }
                v
            }
            None => DVec3::splat(0.5),
        };
        Ok(Some(Box::new(Fog { density, falloff, base_height, color })))
    }

    fn check(&self, scene: &Scene) -> Result<(), String> {
        match scene.effects.get::<Fog>() {
            Some(fog) if !fog.is_valid() => Err(format!(
                "density in 0..=3.4e38, falloff in 0..=1e6, |base_height| ≤ 2⁴⁸ and a colour in \
                 0..=65504 (found {fog:?})"
            )),
            _ => Ok(()),
        }
    }

    fn passes(&self) -> Vec<EffectPass> {
        let min_density = self.min_density;
        vec![EffectPass::new("fog", move |s| needed(s, min_density), |b| Ok(Box::new(FogPass::new(b)?)))]
    }
}

fn needed(scene: &Scene, min_density: f64) -> bool {
    scene.effects.get::<Fog>().is_some_and(|f| f.density > 0.0 && f.density >= min_density)
}

/// Push constants of fog.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FogParams {
    /// rgb: colour; w: ln(density).
    pub color_log_density: [f32; 4],
    /// x: falloff; y: base height.
    pub shape: [f32; 4],
}

impl FogParams {
    /// What the shader is given for `fog` in a frame pre-exposed by `pre_exposure` (the colour is
    /// radiance added to hadou's HDR image; the twin test evaluates these f32 values in f64).
    pub fn new(fog: &Fog, pre_exposure: f64) -> Self {
        let c = fog.color * pre_exposure;
        FogParams {
            color_log_density: [c.x as f32, c.y as f32, c.z as f32, fog.density.ln() as f32],
            shape: [fog.falloff as f32, fog.base_height as f32, 0.0, 0.0],
        }
    }
}

struct FogPass {
    pipeline: Pipeline,
    params: FogParams,
    extent: vk::Extent2D,
}

impl FogPass {
    fn new(b: &mut PassBuilder) -> GpuResult<Self> {
        let push = std::mem::size_of::<FogParams>() as u32;
        let pipeline = b.compute_pipeline("fog", include_str!("fog.comp"), push)?;
        Ok(FogPass { pipeline, params: FogParams::default(), extent: vk::Extent2D::default() })
    }
}

impl Pass for FogPass {
    fn name(&self) -> &'static str {
        "fog"
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        // `needed` ran this pass only with a fog of density > 0.
        if let Some(fog) = frame.scene.effects.get::<Fog>() {
            self.params = FogParams::new(fog, frame.pre_exposure);
        }
        self.extent = frame.extent;
        Ok(vec![
            Binding::read(Target::Distance),
            Binding::read_write(Target::Hdr),
            Binding::write(Target::Custom(&FOG_TRANSMITTANCE)),
            Binding::Bound(Bound::Uniform(frame.uniforms)),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline]
    }

    fn record(&self, pass: &PassRecording) {
        pass.rec.bind_pipeline(&self.pipeline, pass.set(0));
        pass.rec.push_constants(&self.pipeline, bytemuck::bytes_of(&self.params));
        pass.rec.dispatch_2d(self.extent.width, self.extent.height, (8, 8));
    }
}
