//! Effects as plug-ins: what a game (or hadou itself) writes to add an effect, and nothing else.
//!
//! An effect is one type implementing [`Effect`]. It owns
//! - its **scene-file tables** (`tables()`; `load()` reads them through [`SceneFile`] into its own
//!   world data, with errors at `file:line:col` like hadou's own);
//! - its **world data**: any `Clone + Debug` type, kept in [`Scene::effects`](crate::scene::Scene)
//!   under the effect's name, changed at run time with `Renderer::update_effect` (the passes follow:
//!   a pass the world no longer needs is parked, built, not run);
//! - its **passes** (`passes()`): each an [`EffectPass`] — a name, when the scene needs it, the
//!   variant it is built for, how it is built — implementing [`Pass`]: the images it touches
//!   ([`ImageUse`], hadou's frame images or its own [`ImageDesc`]), its bindings, its commands.
//!
//! Radiance a pass adds to hadou's `hdr` image is **pre-exposed**: multiplied by
//! `FrameContext::pre_exposure` (1 for every scene whose lighting fits RGBA16F as it is, a power
//! of two otherwise; [`pre_exposure`]`(scene)` for an f64 twin), as hadou's own lights,
//! background, emission and waves are.
//!
//! A game registers its effects with `Effects::builtin().with(MyEffect)?` in
//! `RendererOptions::effects` / `RuntimeOptions::effects`, and reads scene files with
//! [`crate::scene::load_scene_with`]. hadou's own energy wave, metaballs and translucency are
//! registered the same way (`effect::builtin`); the raster, the depth import/out and the output
//! pass are the core frame around them. `examples/custom_effect/` is a whole one: a height fog.

mod builtin;
mod error;
mod frame_check;
mod registry;
mod scene_file;
mod state;

pub use crate::effects::energy_wave::{EnergyWave, Waves};
pub use crate::effects::metaballs::{MetaballGroups, Metaballs};
pub use crate::effects::upscaler::UpscalerInputs;
pub use crate::passes::metaballs::Binning;
pub use builtin::Translucency;
pub use error::EffectError;
pub(crate) use frame_check::{check_reads, declared_images};
pub use registry::Effects;
pub(crate) use registry::{ScenePasses, SharedData};
pub(crate) use scene_file::top_level_keys;
pub use scene_file::SceneFile;
pub use state::{EffectState, EffectStates};

pub use crate::budget::QualityLevel;
pub use crate::effects::tonemap::pre_exposure;
pub use crate::gpu::barriers::ImageAccess;
pub use crate::gpu::pipeline::{create_compute_pipeline, Blend, Bound, BufferRange, Pipeline};
pub use crate::gpu::recorder::Recorder;
pub use crate::gpu::{vk, GpuContext, GpuError, GpuResult};
pub use crate::passes::{Binding, FrameContext, ImageUse, Pass, PassRecording, Reader};
pub use crate::targets::{ImageDesc, Target};

use std::any::{Any, TypeId};
use std::sync::Arc;

use crate::gpu::memory::Memory;
use crate::gpu::shader::ShaderCompiler;
use crate::scene::{Scene, SceneError};

/// An effect: its scene-file tables, its world data, its passes. See the module docs.
pub trait Effect: Send + Sync + 'static {
    /// Unique among the registered effects: the key of its data in `Scene::effects`, its passes'
    /// owner in errors.
    fn name(&self) -> &'static str;

    /// The top-level scene-file tables it reads (`"fog"` for `[fog]` or `[[fog]]`). A scene file
    /// with a table no registered effect (and not hadou's format) reads is refused.
    fn tables(&self) -> &'static [&'static str] {
        &[]
    }

    /// Reads its tables of a scene file (called when the file has at least one of them) into its
    /// world data; `Ok(None)` leaves the scene without its data.
    fn load(&self, _file: &SceneFile) -> Result<Option<Box<dyn EffectState>>, SceneError> {
        Ok(None)
    }

    /// Its passes, in frame order (the registration order of effects orders their passes).
    fn passes(&self) -> Vec<EffectPass>;

    /// Checks the scene's data of this effect after a run-time change (`Renderer::update_effect`,
    /// `insert_effect`): `Err(expected)` undoes the change, which returns
    /// `Error::InvalidUpdate` with `expected` (what the values must be).
    fn check(&self, _scene: &Scene) -> Result<(), String> {
        Ok(())
    }

    /// Leaves the effect out of `scene` (the viewer's toggle, a report's baseline): by default
    /// its data is removed, so none of its passes is needed.
    fn switch_off(&self, scene: &mut Scene) {
        scene.effects.remove(self.name());
    }

    /// The settings it offers the frame budget (`crate::budget`), from the most exact to the
    /// cheapest, for the world as it is (empty, the default: none; the budget counts its passes
    /// as a fixed cost). The level the budget picks is `scene.quality.level(self.name())`, read
    /// where the effect reads its settings (its passes' `needed`, variant and `prepare`); `None`
    /// means the effect's own settings.
    fn quality_levels(&self, _scene: &Scene) -> Vec<QualityLevel> {
        Vec::new()
    }
}

/// Whether a scene needs a pass now.
type NeededFn = dyn Fn(&Scene) -> bool + Send + Sync;
/// What of a scene a pass's build depends on.
type VariantFn = dyn Fn(&Scene) -> String + Send + Sync;
/// Builds a pass.
type BuildFn = dyn Fn(&mut PassBuilder) -> GpuResult<Box<dyn Pass>> + Send + Sync;

/// One pass of an effect: when a scene needs it, the variant it is built for and how it is built.
/// Each is a closure, so an effect's own configuration (a quality setting, a shader variant, a
/// handle to the game's data) travels into its passes: `EffectPass::new("fog", move |s| …,
/// move |b| FogPass::new(b, steps))`.
#[derive(Clone)]
pub struct EffectPass {
    /// The pass's `Pass::name()` (checked when it is built): label, timestamp scope, profile row.
    pub name: &'static str,
    needed: Arc<NeededFn>,
    variant: Arc<VariantFn>,
    build: Arc<BuildFn>,
}

impl EffectPass {
    /// A pass needed when `needed` says so (e.g. `|s| s.effects.get::<Fog>().is_some()`), built
    /// by `build`, with one variant.
    pub fn new(
        name: &'static str,
        needed: impl Fn(&Scene) -> bool + Send + Sync + 'static,
        build: impl Fn(&mut PassBuilder) -> GpuResult<Box<dyn Pass>> + Send + Sync + 'static,
    ) -> Self {
        EffectPass {
            name,
            needed: Arc::new(needed),
            variant: Arc::new(|_| String::new()),
            build: Arc::new(build),
        }
    }

    /// The pass built again whenever `variant` of the scene changes (the one built for the old
    /// variant is parked, kept for when the scene comes back to it).
    pub fn with_variant(mut self, variant: impl Fn(&Scene) -> String + Send + Sync + 'static) -> Self {
        self.variant = Arc::new(variant);
        self
    }

    /// Whether `scene` needs the pass now.
    pub fn needed(&self, scene: &Scene) -> bool {
        (self.needed)(scene)
    }

    /// The variant of the pass `scene` needs.
    pub fn variant(&self, scene: &Scene) -> String {
        (self.variant)(scene)
    }

    /// Builds the pass.
    pub(crate) fn build(&self, builder: &mut PassBuilder) -> GpuResult<Box<dyn Pass>> {
        (self.build)(builder)
    }
}

/// What building a pass has at hand: the device, the scene, the shader compiler, and data the
/// passes of one scene share (built by the first pass that asks).
pub struct PassBuilder<'a> {
    /// The device.
    pub ctx: &'a GpuContext,
    pub(crate) memory: &'a Memory,
    pub(crate) compiler: &'a mut ShaderCompiler,
    /// The scene the pass is built for.
    pub scene: &'a Scene,
    pub(crate) shared: &'a mut SharedData,
    /// The shared data this pass was given (a pass built on data that is replaced is rebuilt).
    pub(crate) used: Vec<TypeId>,
}

impl PassBuilder<'_> {
    /// The scene's shared `T`, made by `make` for the first pass that asks.
    pub fn shared<T: Any + Send + Sync>(
        &mut self,
        make: impl FnOnce(&GpuContext, &Memory, &Scene) -> GpuResult<T>,
    ) -> GpuResult<std::sync::Arc<T>> {
        self.used.push(TypeId::of::<T>());
        self.shared.get_or_make(|| make(self.ctx, self.memory, self.scene))
    }

    /// As `shared`, without making the pass a user of `T` (a pass built on data that is replaced
    /// is rebuilt; data made to outlive such rebuilds, e.g. a pipeline memo, is not a reason to).
    pub(crate) fn shared_untracked<T: Any + Send + Sync>(
        &mut self,
        make: impl FnOnce(&GpuContext, &Memory, &Scene) -> GpuResult<T>,
    ) -> GpuResult<std::sync::Arc<T>> {
        self.shared.get_or_make(|| make(self.ctx, self.memory, self.scene))
    }

    /// A compute pipeline from GLSL `source` (a `.comp` shader; `#include "common/…"` reaches
    /// hadou's shared GLSL, e.g. `common/frame.glsl` for `FrameUniforms` with the camera's ray
    /// frame). Its descriptor set layout and push-constant range come from the shader; a
    /// push-constant block of another size than `push_constant_bytes` is refused.
    pub fn compute_pipeline(
        &mut self,
        name: &str,
        source: &str,
        push_constant_bytes: u32,
    ) -> GpuResult<Pipeline> {
        let spirv = self.compiler.compile_source(&format!("{name}.comp"), source, &[])?;
        create_compute_pipeline(self.ctx, name, &spirv, push_constant_bytes)
    }

    /// A full-screen graphics pipeline: hadou's full-screen-triangle vertex shader and the
    /// fragment shader `fragment_source` (GLSL, `#include "common/…"` as for compute), writing its
    /// location 0 into `target` (one of hadou's colour images, e.g. `Target::Hdr`, or the effect's
    /// own `Target::Custom` with `COLOR_ATTACHMENT` in its usage) with `blend`. Set 0 is
    /// reflected from both stages, so the pass binds it like a compute pass's (`Binding`s in
    /// binding order); a storage image a fragment shader reads is declared with
    /// `ImageAccess::FRAGMENT_READ`, the target with `ImageAccess::COLOR_ATTACHMENT`. Record with
    /// `rec.begin_rendering_views(extent, &[(targets.image(target).view, None)], None)`,
    /// `bind_pipeline`, `push_constants`, `draw_fullscreen`, `end_rendering`.
    pub fn fullscreen_pipeline(
        &mut self,
        name: &str,
        fragment_source: &str,
        push_constant_bytes: u32,
        target: Target,
        blend: Blend,
    ) -> GpuResult<Pipeline> {
        let vertex = self.compiler.compile("fullscreen.vert", &[])?;
        let fragment = self.compiler.compile_source(&format!("{name}.frag"), fragment_source, &[])?;
        let desc = crate::gpu::pipeline::GraphicsDesc {
            name,
            vertex: &vertex,
            fragment: &fragment,
            push_constant_bytes,
            vertex_bindings: &[],
            vertex_attributes: &[],
            color_formats: &[target.format()],
            depth_format: vk::Format::UNDEFINED,
            depth_compare: vk::CompareOp::ALWAYS,
            cull_mode: vk::CullModeFlags::NONE,
            blend,
        };
        crate::gpu::pipeline::create_graphics_pipeline(self.ctx, &desc)
    }

    /// The device memory allocator (for buffers and images a pass owns).
    pub fn memory(&self) -> &Memory {
        self.memory
    }
}
