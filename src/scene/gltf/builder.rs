//! The scene parts of one file as they are built: one hadou mesh per drawable primitive (shared
//! by every node that uses it), one hadou material per glTF material and mesh closedness, one
//! instance per (node, primitive), and the lights with their sum kept within the HDR target.

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;

use super::ignored::Ignored;
use super::{accessor, material, primitive, GltfError, ImportOptions};
use crate::scene::file::{MAX_HDR, MAX_LIGHTS};
use crate::scene::mesh::{Mesh, MeshSpec};
use crate::scene::model::{DirectionalLight, Instance, Material, SceneMesh};
use crate::scene::transform::{Transform, TransformOp};

/// The scene parts as they are built, with the caches that make meshes and materials shared.
pub(super) struct Builder<'a> {
    path: &'a Path,
    options: &'a ImportOptions,
    pub meshes: Vec<SceneMesh>,
    pub materials: Vec<Material>,
    pub instances: Vec<Instance>,
    pub lights: Vec<DirectionalLight>,
    pub ignored: Ignored,
    /// (glTF mesh, primitive) → (hadou mesh, closed) or None when skipped.
    built: HashMap<(usize, usize), Option<(usize, bool)>>,
    /// glTF material index → how it looks.
    looks: HashMap<Option<usize>, material::Look>,
    /// (glTF material, closed mesh) → hadou material.
    used: HashMap<(Option<usize>, bool), usize>,
    light_sum: DVec3,
}

impl<'a> Builder<'a> {
    pub fn new(path: &'a Path, options: &'a ImportOptions, ignored: Ignored) -> Self {
        Builder {
            path,
            options,
            meshes: Vec::new(),
            materials: Vec::new(),
            instances: Vec::new(),
            lights: Vec::new(),
            ignored,
            built: HashMap::new(),
            looks: HashMap::new(),
            used: HashMap::new(),
            light_sum: DVec3::ZERO,
        }
    }

    /// One instance per drawable primitive of `mesh`, placed by `ops`.
    pub fn node_mesh(
        &mut self,
        src: &accessor::Source,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        ops: Vec<TransformOp>,
        world: Transform,
    ) -> Result<(), GltfError> {
        let n = node.index();
        if node.skin().is_some() {
            self.ignored.add("skins (drawn in the rest pose)", format!("/nodes/{n}/skin"));
        }
        for p in mesh.primitives() {
            let key = (mesh.index(), p.index());
            if !self.built.contains_key(&key) {
                let entry = self.build(src, mesh, &p)?;
                self.built.insert(key, entry);
            }
            let Some((mesh_index, closed)) = self.built[&key] else { continue };
            let material = self.material(&p.material(), closed, key)?;
            let name = node.name().map_or_else(|| format!("node {n}"), |s| format!("node {n} \"{s}\""));
            self.instances.push(Instance {
                name: Some(format!("{}{name}", self.options.label)),
                mesh: mesh_index,
                material,
                ops: ops.clone(),
                transform: world,
            });
        }
        Ok(())
    }

    fn build(
        &mut self,
        src: &accessor::Source,
        mesh: &gltf::Mesh,
        p: &gltf::Primitive,
    ) -> Result<Option<(usize, bool)>, GltfError> {
        let at = format!("/meshes/{}/primitives/{}", mesh.index(), p.index());
        if p.morph_targets().len() > 0 {
            self.ignored.add("morph targets (drawn in the base shape)", format!("{at}/targets"));
        }
        let built: Mesh = match primitive::build(src, mesh.index(), p)? {
            primitive::Built::Mesh(m) => m,
            primitive::Built::Skipped(why) => {
                self.ignored.add("primitives hadou cannot draw", why);
                return Ok(None);
            }
        };
        let closed = built.check_closed_oriented().is_ok() && built.signed_volume() > 0.0;
        let mut name = format!("{}mesh {} primitive {}", self.options.label, mesh.index(), p.index());
        if let Some(s) = mesh.name() {
            name.push_str(&format!(" \"{s}\""));
        }
        let spec = MeshSpec::Gltf { path: self.path.to_path_buf(), mesh: mesh.index(), primitive: p.index() };
        self.meshes.push(SceneMesh { name, spec, mesh: built, wobble: None });
        Ok(Some((self.meshes.len() - 1, closed)))
    }

    fn material(
        &mut self,
        m: &gltf::Material,
        closed: bool,
        mesh: (usize, usize),
    ) -> Result<usize, GltfError> {
        if !self.looks.contains_key(&m.index()) {
            let look = material::look(self.path, m, &self.options.label, &mut self.ignored)?;
            self.looks.insert(m.index(), look);
        }
        let look = &self.looks[&m.index()];
        if look.volume.is_some() && !closed {
            let at = format!("/meshes/{}/primitives/{}", mesh.0, mesh.1);
            self.ignored.add("KHR_materials_volume on open meshes (opaque, dimmed by thicknessFactor)", at);
        }
        if let Some(&i) = self.used.get(&(m.index(), closed)) {
            return Ok(i);
        }
        self.materials.push(look.material(closed, self.options.voxel_res, self.path));
        let i = self.materials.len() - 1;
        self.used.insert((m.index(), closed), i);
        Ok(i)
    }

    /// Keeps at most `MAX_LIGHTS`, and the lit colour (ambient + Σ colour × intensity) within the
    /// HDR target, as for TOML lights.
    pub fn push_light(&mut self, l: DirectionalLight, index: usize) -> Result<(), GltfError> {
        let at = format!("/extensions/KHR_lights_punctual/lights/{index}");
        if self.lights.len() == MAX_LIGHTS {
            self.ignored.add("directional lights past the 8th", at);
            return Ok(());
        }
        self.light_sum += l.color * l.intensity;
        let sum = self.options.ambient + self.light_sum;
        if sum.max_element() > MAX_HDR {
            let message = format!(
                "ambient + the sum of the lights' colour × intensity reaches {sum} (expected <= 65504 per channel: the HDR target is 16-bit float)"
            );
            return Err(GltfError::at(self.path, format!("{at}/intensity"), message));
        }
        self.lights.push(l);
        Ok(())
    }
}
