//! Instances and lights spawned and despawned at run time by typed ids. An instance is a mesh of
//! the loaded scene drawn
//! with one of its materials, placed by any affine matrix. The instance table and the instanced
//! draws are rebuilt before the next frame; the passes follow (the first translucent instance
//! brings the translucency passes in, the last one takes them out).
//!
//! A translucent instance whose material reads a thickness table (`thickness = "lut"`) and whose
//! (mesh, voxel_res) has no table yet is drawn with the shadow-map thickness until the table,
//! baked in the background, is in (crates/hadou/src/renderer/bakes.rs); `thickness = "tsm"` materials need no
//! table.

use super::game_math::{GameMatrix, GameVector};
use super::Renderer;
use crate::passes::translucency::table_key;
use crate::scene::model::Instance;
use crate::scene::transform::{Transform, TransformOp};
use crate::scene::MaterialKind;
use crate::Error;

/// An instance of the world (from the scene file or spawned); stale once despawned.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct InstanceId(pub(super) u64);

fn invalid(what: String, expected: impl Into<String>) -> Error {
    Error::InvalidUpdate { what, expected: expected.into() }
}

impl Renderer {
    /// Adds an instance of mesh `mesh` (a `[[mesh]]` name of the loaded scene) drawn with material
    /// `material` (a `[[material]]` name), placed by `transform` (object → world, affine and
    /// invertible in f32), from the next frame on. State is unchanged on error.
    pub fn spawn_instance(
        &mut self,
        mesh: &str,
        material: &str,
        transform: impl GameMatrix,
    ) -> Result<InstanceId, Error> {
        let transform = transform.to_dmat4();
        let mesh_index = self
            .live_mesh(mesh)
            .ok_or_else(|| invalid(format!("instance mesh \"{mesh}\""), "the name of a mesh of the world"))?;
        let material_index = self.live_material(material).ok_or_else(|| {
            invalid(format!("instance material \"{material}\""), "the name of a material of the world")
        })?;
        let loaded = self.loaded.as_ref().ok_or(Error::NoScene)?;
        let scene = &loaded.scene;
        let transform = Transform::from_ops(&[TransformOp::Matrix(transform)])
            .map_err(|e| invalid(format!("instance of \"{mesh}\""), e.to_string()))?;
        let table = match scene.materials[material_index].kind {
            MaterialKind::Translucent { voxel_res, thickness, .. } => {
                table_key(mesh_index, voxel_res, thickness)
            }
            _ => None,
        };
        let deforms = scene.meshes[mesh_index].wobble.is_some() || loaded.gpu.is_deformed(mesh_index);
        if table.is_some() && deforms {
            return Err(invalid(
                format!("instance of mesh \"{mesh}\" with material \"{material}\""),
                "a material without a thickness table (thickness = \"peel\" or \"tsm\"): the mesh deforms \
                 (set_mesh_positions or wobble), a table would be of one shape",
            ));
        }
        if let Some(key) = table.filter(|&k| !self.table_known(k)) {
            // Tables for the passes to find (not bake) before the instance is in the scene; its
            // own is baked in the background (crates/hadou/src/renderer/bakes.rs).
            self.ensure_tables()?;
            self.request_bake(key);
        }
        let id = self.next_id();
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        let ops = vec![TransformOp::Matrix(transform.matrix)];
        loaded.scene.instances.push(Instance {
            name: None,
            mesh: mesh_index,
            material: material_index,
            ops,
            transform,
        });
        loaded.instance_ids.push(id);
        loaded.tables_dirty = true;
        self.sync_passes()?;
        if table.is_some_and(|(_, r)| r & crate::passes::translucency::PAIRS_KEY != 0) {
            self.warm_pair_pipelines()?;
        }
        Ok(InstanceId(id))
    }

    /// Removes an instance (spawned or from the scene file) from the next frame on.
    pub fn despawn_instance(&mut self, id: InstanceId) -> Result<(), Error> {
        let index = self.instance_index(id)?;
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        loaded.scene.instances.remove(index);
        loaded.instance_ids.remove(index);
        loaded.tables_dirty = true;
        self.sync_passes()
    }

    /// The ids of the world's instances, in scene order (those of the scene file included): the
    /// instance drawn with `ids` AOV value k is `instance_ids()[k - 1]` (this frame's order).
    pub fn instance_ids(&self) -> Vec<InstanceId> {
        self.loaded.iter().flat_map(|l| l.instance_ids.iter().map(|&id| InstanceId(id))).collect()
    }
}

/// A light of the world (directional, point or spot; from the scene file or spawned); stale once
/// despawned.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LightId(pub(super) u64);

impl Renderer {
    /// Adds a directional light (the direction it travels, any non-zero length; colour and
    /// intensity ≥ 0) from the next frame on. At most `MAX_LIGHTS` (8, the frame uniform's array)
    /// at once, of every kind together; translucent materials are lit through the first
    /// directional one. State is unchanged on error. `spawn_light_with` adds a point or spot light.
    pub fn spawn_light(
        &mut self,
        direction: impl GameVector,
        color: impl GameVector,
        intensity: f64,
    ) -> Result<LightId, Error> {
        let (direction, color) = (direction.to_dvec3(), color.to_dvec3());
        self.spawn_light_with(crate::scene::Light {
            direction,
            color,
            intensity,
            ..crate::scene::Light::directional(glam::DVec3::NEG_Y, glam::DVec3::ZERO, 0.0)
        })
    }

    /// Adds any light — `Light::directional`, `Light::point(position, color, candela)`,
    /// `Light::spot(..)`, `.with_range(r)` — from the next frame on, checked as a `[[light]]`
    /// table is (finite numbers, colour and intensity ≥ 0 within f32, a non-zero direction, a
    /// range > 0, cone half-angles in [0, π/2] with the outer one > 0; docs/scene-format.md). At
    /// most `MAX_LIGHTS` at once, of every kind together. State is unchanged on error.
    pub fn spawn_light_with(&mut self, light: crate::scene::Light) -> Result<LightId, Error> {
        use crate::scene::file::MAX_LIGHTS;
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        let index = loaded.scene.lights.len();
        if index >= MAX_LIGHTS {
            return Err(invalid(
                format!("light {}", index + 1),
                format!("at most {MAX_LIGHTS} lights of any kind (the frame uniform's array)"),
            ));
        }
        let light = super::update::checked_light(index, light)?;
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        loaded.scene.lights.push(light);
        let id = self.next_id();
        self.loaded.as_mut().ok_or(Error::NoScene)?.light_ids.push(id);
        self.sync_passes()?;
        Ok(LightId(id))
    }

    /// Removes a light (spawned or from the scene file) from the next frame on.
    pub fn despawn_light(&mut self, id: LightId) -> Result<(), Error> {
        let index = self.light_index(id)?;
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        loaded.scene.lights.remove(index);
        loaded.light_ids.remove(index);
        self.sync_passes()
    }

    /// The ids of the world's lights, in scene order (those of the scene file included).
    pub fn light_ids(&self) -> Vec<LightId> {
        self.loaded.iter().flat_map(|l| l.light_ids.iter().map(|&id| LightId(id))).collect()
    }
}
