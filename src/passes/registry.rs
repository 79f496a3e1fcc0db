//! The scene passes hadou knows, in frame order: each says when a scene needs it and how it is
//! built. A new effect is one line here (plus its pass file and shader).
//!
//! Order: the raster first (it clears the G-buffer every later pass reads); metaballs right
//! after it, whose images they bind (on lavapipe a dispatch waits only for the render passes
//! that wrote what it binds, so after light_id it would overlap light_id's rasterizing and its
//! timestamps would straddle the wrong work); light_id (the light's view of translucent
//! instances), peel (the peel instances' crossing lists), translucency (reads what raster and metaballs wrote), the energy wave last, adding
//! on top. The output pass (tonemap, or composite into a game's colour) is chosen per frame by the
//! renderer.

use std::any::Any;
use std::sync::Arc;

use super::energy_wave::EnergyWavePass;
use super::light_id::LightIdPass;
use super::metaballs::MetaballsPass;
use super::peel::PeelPass;
use super::raster::RasterPass;
use super::translucency::{self, TranslucencyPass, TranslucentData};
use super::Pass;
use crate::gpu::memory::Memory;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{GpuContext, GpuResult};
use crate::scene::Scene;

/// Data passes of one scene share (built once, e.g. the baked thickness tables).
pub type Shared = Vec<Arc<dyn Any + Send + Sync>>;

/// What building a pass has at hand, and data passes of one scene share (built once).
pub struct Builder<'a> {
    pub ctx: &'a GpuContext,
    pub memory: &'a Memory,
    pub compiler: &'a mut ShaderCompiler,
    pub scene: &'a Scene,
    shared: &'a mut Shared,
}

impl Builder<'_> {
    /// The scene's shared `T`, made by `make` for the first pass that asks.
    pub fn shared<T: Any + Send + Sync>(
        &mut self,
        make: impl FnOnce(&GpuContext, &Memory, &Scene) -> GpuResult<T>,
    ) -> GpuResult<Arc<T>> {
        if let Some(found) = self.shared.iter().find_map(|s| s.clone().downcast::<T>().ok()) {
            return Ok(found);
        }
        let made = Arc::new(make(self.ctx, self.memory, self.scene)?);
        self.shared.push(made.clone());
        Ok(made)
    }
}

/// A scene pass: its name (the pass's `name()`), when a scene needs it, what in the scene its
/// build depends on (a pass built for another variant is built again), how it is built.
pub struct Entry {
    pub name: &'static str,
    pub needed: fn(&Scene) -> bool,
    pub variant: fn(&Scene) -> String,
    pub build: fn(&mut Builder) -> GpuResult<Box<dyn Pass>>,
}

fn no_variant(_: &Scene) -> String {
    String::new()
}

fn boxed(pass: impl Pass + 'static) -> Box<dyn Pass> {
    Box::new(pass)
}

fn translucent_data(b: &mut Builder) -> GpuResult<Arc<TranslucentData>> {
    b.shared(TranslucentData::new)
}

/// Every scene pass, in frame order.
pub const PASSES: &[Entry] = &[
    Entry {
        name: "raster",
        needed: |_| true,
        variant: no_variant,
        build: |b| Ok(boxed(RasterPass::new(b.ctx, b.compiler)?)),
    },
    Entry {
        name: "metaballs",
        needed: |s| !s.metaballs.is_empty(),
        variant: super::metaballs::variant,
        build: |b| Ok(boxed(MetaballsPass::new(b.ctx, b.compiler, b.scene)?)),
    },
    Entry {
        name: "light_id",
        needed: translucency::needed,
        variant: no_variant,
        build: |b| {
            let data = translucent_data(b)?;
            Ok(boxed(LightIdPass::new(b.ctx, b.compiler, data, b.scene)?))
        },
    },
    Entry {
        name: "peel",
        needed: super::peel::needed,
        variant: no_variant,
        build: |b| Ok(boxed(PeelPass::new(b.ctx, b.compiler, b.scene)?)),
    },
    Entry {
        name: "translucency",
        needed: translucency::needed,
        // With or without the field's march and the peel lists.
        variant: translucency::variant,
        build: |b| {
            let data = translucent_data(b)?;
            let (lut, peel) = (translucency::reads_lut(b.scene), super::peel::needed(b.scene));
            Ok(boxed(TranslucencyPass::new(b.ctx, b.compiler, data, lut, peel)?))
        },
    },
    Entry {
        name: "energy_wave",
        needed: |s| !s.waves.is_empty(),
        variant: no_variant,
        build: |b| Ok(boxed(EnergyWavePass::new(b.ctx, b.compiler)?)),
    },
];

/// The names of the scene passes `scene` needs, in frame order.
pub fn plan(scene: &Scene) -> Vec<&'static str> {
    PASSES.iter().filter(|e| (e.needed)(scene)).map(|e| e.name).collect()
}

/// A built scene pass, with the registry name and variant it was built for.
pub struct Active {
    pub name: &'static str,
    pub variant: String,
    pub pass: Box<dyn Pass>,
}

/// Builds the scene passes `scene` needs. A failure part-way drops what was built (freed with
/// the frames that may use it).
pub fn build(
    ctx: &GpuContext,
    memory: &Memory,
    compiler: &mut ShaderCompiler,
    scene: &Scene,
    shared: &mut Shared,
) -> GpuResult<Vec<Active>> {
    let mut builder = Builder { ctx, memory, compiler, scene, shared };
    PASSES
        .iter()
        .filter(|e| (e.needed)(scene))
        .map(|e| Ok(Active { name: e.name, variant: (e.variant)(scene), pass: (e.build)(&mut builder)? }))
        .collect()
}

/// Builds the scene pass registered as `name` (it must be one of `PASSES`).
pub fn build_one(
    ctx: &GpuContext,
    memory: &Memory,
    compiler: &mut ShaderCompiler,
    scene: &Scene,
    name: &str,
    shared: &mut Shared,
) -> GpuResult<Box<dyn Pass>> {
    let entry = PASSES.iter().find(|e| e.name == name).ok_or_else(|| crate::gpu::GpuError::Internal {
        what: format!("pass {name}"),
        message: "no such pass in the registry".into(),
    })?;
    (entry.build)(&mut Builder { ctx, memory, compiler, scene, shared })
}
