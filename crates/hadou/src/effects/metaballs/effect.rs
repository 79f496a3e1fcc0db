//! Metaballs as an effect (`crate::effect`), registered like any other: it reads the
//! `[[metaballs]]` tables (file.rs; a group names a material of the file) into its world data,
//! `MetaballGroups`, kept in `Scene::effects`, and runs the `metaballs` pass while the world has
//! a group. `Scene::metaballs()` / `metaballs_mut()` are shorthands for that data.

use super::file;
use crate::effect::{Effect, EffectPass, EffectState, SceneFile};
use crate::passes::metaballs::{self, Binning, MetaballsPass};
use crate::scene::file_schema::Tables;
use crate::scene::{MetaballGroup, Scene, SceneError};

/// Seed 000: `[[metaballs]]` groups ray-cast with Bézier clipping.
#[derive(Clone, Copy, Debug)]
#[non_exhaustive]
pub struct Metaballs {
    /// Where the tile lists are built: on the host (the default) or on the device.
    pub binning: Binning,
}

impl Default for Metaballs {
    /// Host binning, or the device's with `HADOU_METABALLS_BINNING=device` in the environment
    /// (how the command line picks it, e.g. for `hadou profile`).
    fn default() -> Self {
        Metaballs { binning: Binning::from_env() }
    }
}

impl Metaballs {
    /// The effect with its tile lists built where `binning` says.
    pub fn with_binning(binning: Binning) -> Self {
        Metaballs { binning }
    }
}

/// The metaballs' world data: the groups of the file (in file order), then those spawned.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MetaballGroups(pub Vec<MetaballGroup>);

/// The effect's name: its key in `Scene::effects`.
const NAME: &str = "metaballs";

impl Effect for Metaballs {
    fn name(&self) -> &'static str {
        NAME
    }

    fn tables(&self) -> &'static [&'static str] {
        &["metaballs"]
    }

    fn load(&self, file: &SceneFile) -> Result<Option<Box<dyn EffectState>>, SceneError> {
        let Some(defs) = file.table::<Tables<file::MetaballsDef>>("metaballs")? else { return Ok(None) };
        let Some(mut materials) = file.materials() else {
            let message = "[[metaballs]] needs the file's materials (load it with scene::load_scene_with)";
            return Err(file.error(defs.span(), message));
        };
        let groups = file::metaballs(file.ctx(), defs.get_ref(), &mut materials)?;
        Ok(Some(Box::new(MetaballGroups(groups))))
    }

    fn passes(&self) -> Vec<EffectPass> {
        let binning = self.binning;
        vec![EffectPass::new(
            "metaballs",
            |s| !s.metaballs().is_empty(),
            move |b| Ok(Box::new(MetaballsPass::new(b.ctx, b.compiler, b.scene, binning)?)),
        )
        .with_variant(metaballs::variant)]
    }
}

impl Scene {
    /// The metaball groups (`[[metaballs]]` and spawned), in order; empty when the world has none.
    pub fn metaballs(&self) -> &[MetaballGroup] {
        self.effects.get::<MetaballGroups>().map_or(&[], |g| &g.0)
    }

    /// The groups, to change; the metaballs' data is added to the scene when it had none.
    pub fn metaballs_mut(&mut self) -> &mut Vec<MetaballGroup> {
        &mut self.effects.get_or_insert_with(NAME, MetaballGroups::default).0
    }
}
