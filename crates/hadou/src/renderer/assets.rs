//! Run-time assets: meshes and materials a game adds to (and takes out of) the live world, by
//! typed handle, with no reload — every other id stays valid.
//!
//! A spawned mesh gets its vertex and index buffers at once (host-visible, written on the spot:
//! nothing is waited for); a spawned material goes into the material table the next frame
//! uploads. Instances of them are spawned with `spawn_instance_of`; a translucent material's
//! table bakes in the background like any run-time bake (crates/hadou/src/renderer/bakes.rs). A mesh or
//! material is despawned only when nothing draws it; its slot in the scene stays (indices of the
//! others do not move), its id goes stale, its buffers are retired with the frames that may still
//! read them, and its name is free again.
//!
//! A whole glTF file goes in with `spawn_gltf`: its meshes, materials (textures included: copied
//! by the next frame), instances and lights, placed by one transform; the ids of everything it
//! added come back, so the game can take it out again piece by piece.

use std::path::Path;

use glam::Vec3;

use super::game_math::{GameMatrix, GameVector};
use super::ids::{MaterialId, MeshId};
use super::instances::{InstanceId, LightId};
use super::Renderer;
use crate::scene::mesh::{Mesh, MeshSpec};
use crate::scene::model::{Material, MaterialKind, SceneMesh, Surface, MAX_VOXEL_RES, MIN_VOXEL_RES};
use crate::scene::procedural::MAX_LENGTH;
use crate::Error;

/// The id a despawned mesh or material keeps in its slot: no handle has it (ids start at 1).
pub(super) const RETIRED: u64 = 0;

fn invalid(what: String, expected: impl Into<String>) -> Error {
    Error::InvalidUpdate { what, expected: expected.into() }
}

/// What `Renderer::spawn_gltf` added to the world, in the file's order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpawnedGltf {
    /// One per primitive (the file's meshes split as hadou loads them).
    pub meshes: Vec<MeshId>,
    /// Its materials (glTF's own, and `"default"` when a primitive has none).
    pub materials: Vec<MaterialId>,
    /// One per node drawing a mesh primitive.
    pub instances: Vec<InstanceId>,
    /// Its `KHR_lights_punctual` lights, placed by the same transform.
    pub lights: Vec<LightId>,
}

/// A name a game gives a run-time asset: not empty, no control characters.
fn check_name(kind: &str, name: &str) -> Result<(), Error> {
    if name.is_empty() || name.chars().any(char::is_control) {
        return Err(invalid(format!("{kind} name {name:?}"), "a non-empty name without control characters"));
    }
    Ok(())
}

impl Renderer {
    /// The scene index of the live mesh named `name`.
    pub(super) fn live_mesh(&self, name: &str) -> Option<usize> {
        let l = self.loaded.as_ref()?;
        (0..l.scene.meshes.len()).find(|&i| l.mesh_ids[i] != RETIRED && l.scene.meshes[i].name == name)
    }

    /// The scene index of the live material named `name`.
    pub(super) fn live_material(&self, name: &str) -> Option<usize> {
        let l = self.loaded.as_ref()?;
        (0..l.scene.materials.len())
            .find(|&i| l.material_ids[i] != RETIRED && l.scene.materials[i].name == name)
    }

    /// Adds a mesh to the world: `positions` (object space, within 1e6 of the origin), one unit
    /// normal per position or `None` to compute them (area-weighted, as `set_mesh_positions`
    /// does), and three `indices` per triangle (counter-clockwise seen from the normal's side).
    /// Its instances come with `spawn_instance_of` (or `spawn_instance` by its `name`, unique
    /// among the live meshes). State is unchanged on error.
    pub fn spawn_mesh(
        &mut self,
        name: &str,
        positions: &[Vec3],
        normals: Option<&[Vec3]>,
        indices: &[u32],
    ) -> Result<MeshId, Error> {
        check_name("mesh", name)?;
        if self.live_mesh(name).is_some() {
            return Err(invalid(format!("mesh name \"{name}\""), "a name no live mesh of the world has"));
        }
        let what = || format!("mesh \"{name}\" ({} positions, {} indices)", positions.len(), indices.len());
        let max = MAX_LENGTH as f32;
        if !positions.iter().all(|p| p.is_finite() && p.abs().max_element() <= max) {
            return Err(invalid(what(), "finite positions within 1e6 of the origin"));
        }
        let positions: Vec<[f32; 3]> = positions.iter().map(|p| p.to_array()).collect();
        let normals: Vec<[f32; 3]> = match normals {
            Some(n) => n.iter().map(|v| v.to_array()).collect(),
            None if indices.iter().all(|&i| (i as usize) < positions.len()) => {
                super::vertex_normals(&positions, indices, &vec![[0.0, 1.0, 0.0]; positions.len()])
            }
            None => Vec::new(),
        };
        let mesh = Mesh { positions, normals, indices: indices.to_vec(), attributes: None };
        mesh.validate_basic().map_err(|e| invalid(what(), format!("a valid triangle mesh: {e}")))?;
        self.add_mesh(name, mesh)
    }

    /// Puts a checked mesh into the world under `name`.
    fn add_mesh(&mut self, name: &str, mesh: Mesh) -> Result<MeshId, Error> {
        let id = self.next_id();
        let (ctx, memory) = (&self.ctx, &self.memory);
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        let gpu_mesh = crate::scene_gpu::GpuMesh::new(ctx, memory, name, &mesh)?;
        let loaded_mesh = SceneMesh { name: name.into(), spec: MeshSpec::Given, mesh, wobble: None };
        loaded.scene.meshes.push(loaded_mesh);
        loaded.gpu.meshes.push(gpu_mesh);
        loaded.mesh_ids.push(id);
        loaded.tables_dirty = true;
        Ok(MeshId(id))
    }

    /// Takes a mesh out of the world: refused while an instance draws it (despawn those first).
    pub fn despawn_mesh(&mut self, id: MeshId) -> Result<(), Error> {
        let index = self.mesh_index(id)?;
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        let users = loaded.scene.instances.iter().filter(|i| i.mesh == index).count();
        if users > 0 {
            let name = &loaded.scene.meshes[index].name;
            return Err(invalid(
                format!("despawn of mesh \"{name}\", drawn by {users} instance(s)"),
                "a mesh no instance draws (despawn its instances first)",
            ));
        }
        // Its slot stays (the others keep their indices); its buffers retire with the frames.
        loaded.gpu.retire_mesh(&self.ctx, &self.memory, index)?;
        loaded.mesh_ids[index] = RETIRED;
        Ok(())
    }

    /// Adds a material: Lambertian or translucent (`MaterialKind`), its linear `albedo` in
    /// [0, 1]; a translucent one needs σ finite > 0 and `voxel_res` in 4..=128. Its name is
    /// unique among the live materials. Untextured (glTF textures come with their files).
    pub fn spawn_material(
        &mut self,
        name: &str,
        albedo: impl GameVector,
        kind: MaterialKind,
    ) -> Result<MaterialId, Error> {
        check_name("material", name)?;
        if self.live_material(name).is_some() {
            return Err(invalid(
                format!("material name \"{name}\""),
                "a name no live material of the world has",
            ));
        }
        let albedo = albedo.to_dvec3();
        let albedo_ok = albedo.is_finite() && albedo.min_element() >= 0.0 && albedo.max_element() <= 1.0;
        let kind_ok = match kind {
            MaterialKind::Lambert => true,
            MaterialKind::Translucent { sigma, voxel_res, .. } => {
                sigma.is_finite()
                    && sigma.min_element() > 0.0
                    && (MIN_VOXEL_RES..=MAX_VOXEL_RES).contains(&voxel_res)
            }
        };
        if !albedo_ok || !kind_ok {
            return Err(invalid(
                format!("material \"{name}\": albedo {albedo}, {kind:?}"),
                "an albedo in [0, 1]; for a translucent material a finite σ > 0 and voxel_res in 4..=128",
            ));
        }
        let voxel_res_at = format!("spawn_material(\"{name}\")");
        let surface = Surface::default();
        self.loaded.as_ref().ok_or(Error::NoScene)?;
        Ok(self.add_material(Material { name: name.into(), kind, albedo, voxel_res_at, surface }))
    }

    /// Puts a checked material into the world (a scene must be loaded).
    fn add_material(&mut self, material: Material) -> MaterialId {
        let id = self.next_id();
        if let Some(loaded) = self.loaded.as_mut() {
            loaded.scene.materials.push(material);
            loaded.material_ids.push(id);
            loaded.tables_dirty = true;
        }
        MaterialId(id)
    }

    /// Takes a material out of the world: refused while an instance or a metaball group uses it.
    pub fn despawn_material(&mut self, id: MaterialId) -> Result<(), Error> {
        let index = self.material_index(id)?;
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        let scene = &loaded.scene;
        let users = scene.instances.iter().filter(|i| i.material == index).count()
            + scene.metaballs().iter().filter(|g| g.material == index).count();
        if users > 0 {
            let name = &scene.materials[index].name;
            return Err(invalid(
                format!("despawn of material \"{name}\", used by {users} instance(s) or metaball group(s)"),
                "a material nothing uses (despawn its users first)",
            ));
        }
        loaded.material_ids[index] = RETIRED;
        Ok(())
    }

    /// Adds a glTF file (`.gltf` or `.glb`) to the live world, its scene placed by `transform`
    /// (object → world, applied after the file's own node transforms): every mesh primitive, every
    /// material (base-colour and emissive textures copied by the next frame; translucent ones
    /// baked in the background), every instance and the file's own lights (no default light: the
    /// world has its lighting), exactly as a `[[gltf]]` table places a file in a scene. Names the
    /// file's objects by `"{file stem}/{name}"`, with `#2`, `#3`… when the world already has one
    /// of that name. The file is read and checked as `load_scene` reads it (errors name the file
    /// and its JSON path); what cannot be added (more lights than `MAX_LIGHTS` in all) is refused
    /// before anything changes; the camera of the file is not used.
    pub fn spawn_gltf(&mut self, path: &Path, transform: impl GameMatrix) -> Result<SpawnedGltf, Error> {
        use crate::scene::gltf::{import, ImportOptions};
        use crate::scene::transform::TransformOp;
        let place = transform.to_dmat4();
        // Checked (affine, invertible, finite) and applied after the file's node transforms by
        // the importer, as a `[[gltf]]` table's `transform` is.
        crate::scene::transform::Transform::from_ops(&[TransformOp::Matrix(place)])
            .map_err(|e| invalid(format!("transform of {}", path.display()), e.to_string()))?;
        let options = ImportOptions { base: vec![TransformOp::Matrix(place)], ..ImportOptions::default() };
        let file = import(path, &options).map_err(crate::scene::SceneError::from)?;
        file.ignored.warn(path);
        let lights_now = self.loaded.as_ref().ok_or(Error::NoScene)?.scene.lights.len();
        let max = crate::scene::file::MAX_LIGHTS;
        if lights_now + file.lights.len() > max {
            return Err(invalid(
                format!("{} lights of {} beside the world's {lights_now}", file.lights.len(), path.display()),
                format!("at most {max} lights of any kind (the frame uniform's array)"),
            ));
        }
        let stem = path.file_stem().map_or("gltf".into(), |s| s.to_string_lossy().into_owned());
        let mut out = SpawnedGltf::default();
        match self.spawn_parts(file, &stem, &mut out) {
            Ok(()) => Ok(out),
            Err(e) => {
                // All or nothing: what was added before the error goes again (its ids stale).
                self.despawn_parts(&out);
                Err(e)
            }
        }
    }

    /// Adds `file`'s meshes, materials, instances and lights, recording each in `out` as it goes.
    fn spawn_parts(
        &mut self,
        file: crate::scene::gltf::GltfImport,
        stem: &str,
        out: &mut SpawnedGltf,
    ) -> Result<(), Error> {
        let first_material = self.loaded.as_ref().ok_or(Error::NoScene)?.scene.materials.len();
        let textures =
            crate::scene_textures::SceneTextures::of_materials(&self.ctx, &self.memory, &file.materials)?;
        for m in file.meshes {
            let name = self.free_name(&format!("{stem}/{}", m.name), |r, n| r.live_mesh(n).is_some());
            out.meshes.push(self.add_mesh(&name, m.mesh)?);
        }
        for m in file.materials {
            let name = self.free_name(&format!("{stem}/{}", m.name), |r, n| r.live_material(n).is_some());
            let material = crate::scene::model::Material { name, ..m };
            out.materials.push(self.add_material(material));
        }
        self.loaded.as_mut().ok_or(Error::NoScene)?.gpu.textures.append(textures, first_material);
        for i in &file.instances {
            let (mesh, material) = (out.meshes[i.mesh], out.materials[i.material]);
            out.instances.push(self.spawn_instance_of(mesh, material, i.transform.matrix)?);
        }
        for light in file.lights {
            out.lights.push(self.spawn_light_with(light)?);
        }
        Ok(())
    }

    /// Takes out what `spawn_parts` added: instances and lights, then meshes and materials.
    fn despawn_parts(&mut self, parts: &SpawnedGltf) {
        for &id in &parts.instances {
            let _ = self.despawn_instance(id);
        }
        for &id in &parts.lights {
            let _ = self.despawn_light(id);
        }
        for &id in &parts.meshes {
            let _ = self.despawn_mesh(id);
        }
        for &id in &parts.materials {
            let _ = self.despawn_material(id);
        }
    }

    /// `wanted`, or `wanted#2`, `wanted#3`… the first no live asset of the kind has.
    fn free_name(&self, wanted: &str, taken: impl Fn(&Renderer, &str) -> bool) -> String {
        let mut name = wanted.to_string();
        let mut k = 2;
        while taken(self, &name) {
            name = format!("{wanted}#{k}");
            k += 1;
        }
        name
    }

    /// `spawn_instance` by handles: an instance of `mesh` drawn with `material`, placed by
    /// `transform` (object → world, affine and invertible in f32).
    pub fn spawn_instance_of(
        &mut self,
        mesh: MeshId,
        material: MaterialId,
        transform: impl GameMatrix,
    ) -> Result<InstanceId, Error> {
        let (m, k) = (self.mesh_index(mesh)?, self.material_index(material)?);
        let scene = &self.loaded.as_ref().ok_or(Error::NoScene)?.scene;
        let (mesh, material) = (scene.meshes[m].name.clone(), scene.materials[k].name.clone());
        self.spawn_instance(&mesh, &material, transform.to_dmat4())
    }
}
