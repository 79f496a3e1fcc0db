//! The registered effects and the scene passes they make: which a scene needs now, built (or
//! taken back from the parked ones) in frame order — the core raster first, then each effect's
//! passes in registration order.

use std::any::{Any, TypeId};
use std::fmt;
use std::sync::Arc;

use super::{builtin, Effect, EffectError, EffectPass, PassBuilder};
use crate::gpu::memory::Memory;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{GpuContext, GpuResult};

use crate::passes::Pass;
use crate::scene::Scene;

/// The effects a renderer runs and a scene file may use, in frame order.
#[derive(Clone)]
pub struct Effects {
    list: Vec<Arc<dyn Effect>>,
}

impl fmt::Debug for Effects {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.list.iter().map(|e| e.name())).finish()
    }
}

impl Default for Effects {
    fn default() -> Self {
        Effects::builtin()
    }
}

impl Effects {
    /// hadou's own effects: metaballs, translucency, energy wave (in that frame order).
    pub fn builtin() -> Self {
        Effects { list: builtin::effects() }
    }

    /// No effect at all: the core frame only (raster and output).
    pub fn none() -> Self {
        Effects { list: Vec::new() }
    }

    /// These effects and `effect` after them; refused when its name, a table or a pass name is
    /// taken.
    pub fn with(mut self, effect: impl Effect) -> Result<Self, EffectError> {
        self.register(Arc::new(effect))?;
        Ok(self)
    }

    /// Adds `effect` after the others (see `with`).
    pub fn register(&mut self, effect: Arc<dyn Effect>) -> Result<(), EffectError> {
        let name = effect.name();
        if self.get(name).is_some() {
            return Err(EffectError::DuplicateEffect(name.into()));
        }
        for table in effect.tables() {
            let claimed = |owner: String| EffectError::TableClaimed {
                table: table.to_string(),
                effect: name.into(),
                owner,
            };
            if crate::scene::file::SCENE_TABLES.contains(table) {
                return Err(claimed("hadou's scene format".into()));
            }
            if let Some(other) = self.list.iter().find(|e| e.tables().contains(table)) {
                return Err(claimed(format!("effect `{}`", other.name())));
            }
        }
        let taken: Vec<&str> = self.passes().iter().map(|p| p.name).collect();
        for pass in effect.passes() {
            if taken.contains(&pass.name) || CORE_PASS_NAMES.contains(&pass.name) {
                return Err(EffectError::DuplicatePass(pass.name.into()));
            }
        }
        self.list.push(effect);
        Ok(())
    }

    /// The registered effects, in order.
    pub fn iter(&self) -> impl Iterator<Item = &dyn Effect> {
        self.list.iter().map(|e| e.as_ref())
    }

    /// The effect registered as `name`.
    pub fn get(&self, name: &str) -> Option<&dyn Effect> {
        self.iter().find(|e| e.name() == name)
    }

    /// The effect that reads scene-file table `table`.
    pub fn reading(&self, table: &str) -> Option<&dyn Effect> {
        self.iter().find(|e| e.tables().contains(&table))
    }

    /// The names of the scene passes `scene` needs now, in frame order.
    pub fn plan(&self, scene: &Scene) -> Vec<&'static str> {
        plan_passes(self, scene).into_iter().map(|(p, _)| p.name).collect()
    }

    /// Every scene pass in frame order: the core raster, then the effects' passes.
    pub(crate) fn passes(&self) -> Vec<EffectPass> {
        builtin::core_passes().into_iter().chain(self.list.iter().flat_map(|e| e.passes())).collect()
    }

    /// Refuses a scene holding data of an effect not registered here.
    pub(crate) fn check_scene(&self, scene: &Scene) -> Result<(), EffectError> {
        match scene.effects.names().find(|n| self.get(n).is_none()) {
            Some(n) => Err(EffectError::NotRegistered(n.into())),
            None => Ok(()),
        }
    }
}

/// Names the core frame uses for its own passes (no effect may take them).
const CORE_PASS_NAMES: &[&str] =
    &["raster", "depth_import", "depth_out", "tonemap", "composite", "energy_probe"];

/// Data the passes of one scene share, one value per type (e.g. the baked thickness tables).
#[derive(Default)]
pub(crate) struct SharedData {
    items: Vec<(TypeId, Arc<dyn Any + Send + Sync>)>,
}

impl SharedData {
    pub fn get<T: Any + Send + Sync>(&self) -> Option<Arc<T>> {
        let (_, found) = self.items.iter().find(|(t, _)| *t == TypeId::of::<T>())?;
        found.clone().downcast::<T>().ok()
    }

    pub fn get_or_make<T: Any + Send + Sync>(
        &mut self,
        make: impl FnOnce() -> GpuResult<T>,
    ) -> GpuResult<Arc<T>> {
        if let Some(found) = self.get::<T>() {
            return Ok(found);
        }
        let made = Arc::new(make()?);
        self.items.push((TypeId::of::<T>(), made.clone()));
        Ok(made)
    }

    /// Puts `value` in place of the `T` there was; passes built on the old one must be rebuilt
    /// (`Active::uses`).
    pub fn replace<T: Any + Send + Sync>(&mut self, value: T) {
        self.items.retain(|(t, _)| *t != TypeId::of::<T>());
        self.items.push((TypeId::of::<T>(), Arc::new(value)));
    }
}

/// A built scene pass, with the name and variant it was built for and the shared data it holds.
pub(crate) struct Active {
    pub name: &'static str,
    pub variant: String,
    pub pass: Box<dyn Pass>,
    uses: Vec<TypeId>,
}

impl Active {
    /// Whether it was built on the shared `T`.
    pub fn uses<T: Any>(&self) -> bool {
        self.uses.contains(&TypeId::of::<T>())
    }
}

/// The (name, variant) of each scene pass `scene` needs now, in frame order.
pub(crate) fn plan_passes(effects: &Effects, scene: &Scene) -> Vec<(EffectPass, String)> {
    effects
        .passes()
        .into_iter()
        .filter(|p| p.needed(scene))
        .map(|p| {
            let variant = p.variant(scene);
            (p, variant)
        })
        .collect()
}

/// A scene's passes: those the world needs now (in frame order), those built before and not
/// needed now (kept built, not run), and the data they share.
#[derive(Default)]
pub(crate) struct ScenePasses {
    pub running: Vec<Active>,
    pub parked: Vec<Active>,
    pub shared: SharedData,
}

impl ScenePasses {
    /// Brings `running` in line with what `scene` needs: a pass built before for the same variant
    /// is taken back from `running` or `parked`, the others are built; what is not needed is
    /// parked. A failure part-way leaves the passes built so far running and the rest parked.
    pub fn sync(
        &mut self,
        ctx: &GpuContext,
        memory: &Memory,
        compiler: &mut ShaderCompiler,
        effects: &Effects,
        scene: &Scene,
    ) -> Result<(), crate::Error> {
        let wanted = plan_passes(effects, scene);
        let now = self.running.iter().map(|a| (a.name, a.variant.as_str()));
        if now.eq(wanted.iter().map(|(p, v)| (p.name, v.as_str()))) {
            return Ok(());
        }
        self.parked.append(&mut self.running);
        for (entry, variant) in wanted {
            match self.parked.iter().position(|a| a.name == entry.name && a.variant == variant) {
                Some(i) => self.running.push(self.parked.swap_remove(i)),
                None => {
                    let shared = &mut self.shared;
                    let mut builder = PassBuilder { ctx, memory, compiler, scene, shared, used: Vec::new() };
                    let pass = entry.build(&mut builder)?;
                    if pass.name() != entry.name {
                        let named = pass.name();
                        return Err(EffectError::PassName { registered: entry.name, named }.into());
                    }
                    let uses = builder.used;
                    self.running.push(Active { name: entry.name, variant, pass, uses });
                }
            }
        }
        Ok(())
    }

    /// Drops the passes built on the shared `T` (after it was replaced): the next `sync` builds
    /// them again on the new one. The old ones retire with the frames that use them.
    pub fn drop_users_of<T: Any>(&mut self) {
        self.running.retain(|a| !a.uses::<T>());
        self.parked.retain(|a| !a.uses::<T>());
    }
}
