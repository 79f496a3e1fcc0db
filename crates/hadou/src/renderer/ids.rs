//! Handles of the world's objects and their lookup by name.
//!
//! Every run-time setter takes a typed id (`InstanceId`, `LightId`, `WaveId`, `GroupId`,
//! `MaterialId`), never a scene index: an id keeps naming its object when others are despawned
//! (indices shift), and an id that names nothing here — despawned, from another renderer or from
//! a scene loaded before — is `Error::StaleId`.
//!
//! The objects of a scene file are found by their `name` (`instance_named`, `wave_named`,
//! `metaballs_named`, `material_named`: `None` when no object of that kind has the name) or by
//! position (`instance_ids`, `wave_ids`, `metaballs_ids`, `light_ids`, `material_ids`, in scene
//! order). Material names are unique in a file; instance, wave and metaball-group names need not
//! be, and a lookup gives the first in scene order. Lights have no name.

use super::instances::{InstanceId, LightId};
use super::world::{GroupId, WaveId};
use super::Renderer;
use crate::Error;

/// A material of the world (from the scene file or `spawn_material`); stale once despawned, or
/// from a scene loaded before or another renderer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MaterialId(pub(super) u64);

/// A mesh of the world (from the scene file or `spawn_mesh`); stale once despawned, or from a
/// scene loaded before or another renderer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MeshId(pub(super) u64);

/// The place of `id` in `ids` (the scene order of its kind), or `Error::StaleId`.
fn position(ids: &[u64], id: u64) -> Result<usize, Error> {
    ids.iter().position(|i| *i == id).ok_or(Error::StaleId(id))
}

impl Renderer {
    fn loaded_ref(&self) -> Result<&super::Loaded, Error> {
        self.loaded.as_ref().ok_or(Error::NoScene)
    }

    /// The scene index of an instance now: its place in `Scene::instances` and in the `ids` AOV
    /// (instance index + 1).
    pub(super) fn instance_index(&self, id: InstanceId) -> Result<usize, Error> {
        position(&self.loaded_ref()?.instance_ids, id.0)
    }

    /// The scene index of a light now.
    pub(super) fn light_index(&self, id: LightId) -> Result<usize, Error> {
        position(&self.loaded_ref()?.light_ids, id.0)
    }

    /// The scene index of a wave now.
    pub(super) fn wave_index(&self, id: WaveId) -> Result<usize, Error> {
        position(&self.loaded_ref()?.wave_ids, id.0)
    }

    /// The scene index of a metaball group now.
    pub(super) fn group_index(&self, id: GroupId) -> Result<usize, Error> {
        position(&self.loaded_ref()?.group_ids, id.0)
    }

    /// The scene index of a material.
    pub(super) fn material_index(&self, id: MaterialId) -> Result<usize, Error> {
        position(&self.loaded_ref()?.material_ids, id.0)
    }

    /// The scene index of a mesh.
    pub(super) fn mesh_index(&self, id: MeshId) -> Result<usize, Error> {
        position(&self.loaded_ref()?.mesh_ids, id.0)
    }

    /// The ids of the world's materials, in scene order (that of `Scene::materials`: the file's
    /// `[[material]]`s, the built-in `"default"` when something used it, then spawned ones).
    pub fn material_ids(&self) -> Vec<MaterialId> {
        let live = |id: &&u64| **id != super::assets::RETIRED;
        self.loaded
            .iter()
            .flat_map(|l| l.material_ids.iter().filter(live).map(|&id| MaterialId(id)))
            .collect()
    }

    /// The ids of the world's meshes, in scene order (the file's `[[mesh]]`es and glTF
    /// primitives, then spawned ones).
    pub fn mesh_ids(&self) -> Vec<MeshId> {
        let live = |id: &&u64| **id != super::assets::RETIRED;
        self.loaded.iter().flat_map(|l| l.mesh_ids.iter().filter(live).map(|&id| MeshId(id))).collect()
    }

    /// The live mesh named `name`; `None` when the world has none.
    pub fn mesh_named(&self, name: &str) -> Option<MeshId> {
        let i = self.live_mesh(name)?;
        Some(MeshId(self.loaded.as_ref()?.mesh_ids[i]))
    }

    /// The first instance (scene order) whose scene-file `name` is `name`; `None` when none is
    /// (spawned instances have no name).
    pub fn instance_named(&self, name: &str) -> Option<InstanceId> {
        let l = self.loaded.as_ref()?;
        let i = l.scene.instances.iter().position(|o| o.name.as_deref() == Some(name))?;
        Some(InstanceId(l.instance_ids[i]))
    }

    /// The first wave (scene order) whose scene-file `name` is `name`; `None` when none is.
    pub fn wave_named(&self, name: &str) -> Option<WaveId> {
        let l = self.loaded.as_ref()?;
        let i = l.scene.waves().iter().position(|o| o.name.as_deref() == Some(name))?;
        Some(WaveId(l.wave_ids[i]))
    }

    /// The first metaball group (scene order) whose scene-file `name` is `name`; `None` when none
    /// is.
    pub fn metaballs_named(&self, name: &str) -> Option<GroupId> {
        let l = self.loaded.as_ref()?;
        let i = l.scene.metaballs().iter().position(|o| o.name.as_deref() == Some(name))?;
        Some(GroupId(l.group_ids[i]))
    }

    /// The material named `name` (`[[material]] name`, or `"default"` for the built-in one when
    /// the scene uses it); `None` when the scene has none of that name.
    pub fn material_named(&self, name: &str) -> Option<MaterialId> {
        let i = self.live_material(name)?;
        Some(MaterialId(self.loaded.as_ref()?.material_ids[i]))
    }
}
