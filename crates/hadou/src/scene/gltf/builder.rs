//! The scene parts of one file as they are built: one hadou mesh per drawable primitive (shared
//! by every node that uses it), one hadou material per glTF material and mesh closedness, one
//! instance per (node, primitive), and the lights.

use std::collections::HashMap;
use std::path::Path;

use super::ignored::Ignored;
use super::material::Shape;
use super::{accessor, material, primitive, GltfError, ImportOptions};
use crate::scene::file::MAX_LIGHTS;
use crate::scene::mesh::{Mesh, MeshSpec};
use crate::scene::model::{Instance, Light, Material, SceneMesh};
use crate::scene::transform::{Transform, TransformOp};

/// The scene parts as they are built, with the caches that make meshes and materials shared.
pub(super) struct Builder<'a> {
    path: &'a Path,
    options: &'a ImportOptions,
    pub meshes: Vec<SceneMesh>,
    pub materials: Vec<Material>,
    pub instances: Vec<Instance>,
    pub lights: Vec<Light>,
    pub ignored: Ignored,
    /// (glTF mesh, primitive) → (hadou mesh, its shape) or None when skipped.
    built: HashMap<(usize, usize), Option<(usize, Shape)>>,
    /// glTF material index → how it looks.
    looks: HashMap<Option<usize>, material::Look>,
    /// (glTF material, mesh shape) → hadou material.
    used: HashMap<(Option<usize>, Shape), usize>,
    /// The images the textures read, each decoded once.
    pub images: super::texture::Images,
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
            images: Default::default(),
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
            let Some((mesh_index, shape)) = self.built[&key] else { continue };
            let material = self.material(src, &p.material(), shape, key)?;
            self.note_texcoords(mesh_index, material, key);
            let colours =
                self.meshes[mesh_index].mesh.attributes.as_ref().is_some_and(|a| !a.colors.is_empty());
            if colours
                && matches!(self.materials[material].kind, crate::scene::MaterialKind::Translucent { .. })
            {
                let kind = "vertex colours on translucent materials (the light through them has the material's colour)";
                self.ignored.add(kind, format!("/meshes/{}/primitives/{}/attributes/COLOR_0", key.0, key.1));
            }
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
    ) -> Result<Option<(usize, Shape)>, GltfError> {
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
        if let Some(a) = p.get(&gltf::mesh::Semantic::Positions) {
            super::limits::check_mesh(self.path, a.index(), &built)?;
        }
        let closed = built.check_closed_oriented().is_ok() && built.signed_volume() > 0.0;
        let shape = match closed {
            false => Shape::Open,
            true if thickness_voxels(&built, self.options.voxel_res) < MIN_TABLE_VOXELS => Shape::Thin,
            true => Shape::Solid,
        };
        let mut name = format!("{}mesh {} primitive {}", self.options.label, mesh.index(), p.index());
        if let Some(s) = mesh.name() {
            name.push_str(&format!(" \"{s}\""));
        }
        let spec = MeshSpec::Gltf { path: self.path.to_path_buf(), mesh: mesh.index(), primitive: p.index() };
        self.meshes.push(SceneMesh { name, spec, mesh: built, wobble: None });
        Ok(Some((self.meshes.len() - 1, shape)))
    }

    /// Textures read through a texture coordinate set the mesh lacks are drawn at (0, 0) of that
    /// set (a file glTF calls invalid): noted. A translucent material's light has its albedo
    /// colour, not its base-colour texture's: noted.
    fn note_texcoords(&mut self, mesh: usize, material: usize, key: (usize, usize)) {
        let textures = &self.materials[material].surface.textures;
        let attributes = self.meshes[mesh].mesh.attributes.as_deref();
        let at = format!("/meshes/{}/primitives/{}/attributes", key.0, key.1);
        for t in [&textures.base, &textures.emissive].into_iter().flatten() {
            let k = t.texcoord as usize;
            if attributes.is_none_or(|a| a.texcoords[k].is_empty()) {
                self.ignored.add(
                    "textures on primitives without their TEXCOORD_n (sampled at (0, 0))",
                    format!("{at}/TEXCOORD_{k}"),
                );
            }
        }
        if textures.base.is_some()
            && matches!(self.materials[material].kind, crate::scene::MaterialKind::Translucent { .. })
        {
            let kind = "base-colour textures on translucent materials (the light through them has the baseColorFactor colour)";
            self.ignored.add(kind, format!("/meshes/{}/primitives/{}/material", key.0, key.1));
        }
    }

    fn material(
        &mut self,
        src: &accessor::Source,
        m: &gltf::Material,
        shape: Shape,
        mesh: (usize, usize),
    ) -> Result<usize, GltfError> {
        if !self.looks.contains_key(&m.index()) {
            let look = material::look(src, m, &self.options.label, &mut self.ignored, &mut self.images)?;
            self.looks.insert(m.index(), look);
        }
        let look = &self.looks[&m.index()];
        let at = format!("/meshes/{}/primitives/{}", mesh.0, mesh.1);
        let shape = match (look.volume.is_some(), shape) {
            (true, Shape::Open) => {
                let kind = "KHR_materials_volume on open meshes (opaque, dimmed by thicknessFactor)";
                self.ignored.add(kind, at);
                shape
            }
            (true, Shape::Thin) => {
                let kind = "KHR_materials_volume on closed meshes too thin for a thickness table \
                            (under 2 voxels thick: opaque, dimmed by thicknessFactor)";
                self.ignored.add(kind, format!("{at} (voxel_res {})", self.options.voxel_res));
                shape
            }
            // Without a volume the shape changes nothing: one material for every closed mesh.
            (false, Shape::Thin) => Shape::Solid,
            (_, shape) => shape,
        };
        if let Some(&i) = self.used.get(&(m.index(), shape)) {
            return Ok(i);
        }
        self.materials.push(look.material(shape, self.options.voxel_res, self.path));
        let i = self.materials.len() - 1;
        self.used.insert((m.index(), shape), i);
        Ok(i)
    }

    /// Keeps at most `MAX_LIGHTS` (of any kind; the others are named in the warning). Their intensity is not limited: the frame is pre-exposed
    /// (`effects::tonemap::pre_exposure`), so no light overflows the HDR target.
    pub fn push_light(&mut self, l: Light, index: usize) -> Result<(), GltfError> {
        let at = format!("/extensions/KHR_lights_punctual/lights/{index}");
        if self.lights.len() == MAX_LIGHTS {
            self.ignored.add("lights past the 8th (the frame uniform holds 8)", at);
            return Ok(());
        }
        self.lights.push(l);
        Ok(())
    }
}

/// How thick, in voxels of its thickness table at `voxel_res` (the box's longest side / `voxel_res`),
/// a closed mesh is at most: the thinnest side of its box, or 6·V/A (V its volume, A its area),
/// which is the side of a cube, the diameter of a ball and 3× the thickness of a thin sheet, so it
/// also sees thin meshes turned diagonally in their box.
fn thickness_voxels(mesh: &Mesh, voxel_res: u32) -> f64 {
    let (lo, hi) = mesh.bounds();
    let voxel = (hi - lo).max_element() / voxel_res as f64;
    let area: f64 = (0..mesh.triangle_count())
        .map(|t| {
            let [a, b, c] = mesh.triangle(t).map(|i| mesh.position(i));
            (b - a).cross(c - a).length() / 2.0
        })
        .sum();
    let thickness = (hi - lo).min_element().min(6.0 * mesh.signed_volume() / area);
    thickness / voxel
}

/// A closed mesh with a volume material gets a thickness table only when it is at least this many
/// voxels thick (`thickness_voxels`). The table is sampled at voxel corners: a solid under √3
/// voxels may hold no corner at all (the bake then fails), and its thickness is read reliably only
/// beyond the ~1.8-voxel error band of the surface (`effects::thickness_lut`), so a solid under 2
/// voxels thick is all error band. Such a mesh (a glass pane, a rod) is drawn as glTF states its
/// thickness instead, like an open mesh: opaque, dimmed by e^(−σ·thicknessFactor).
pub const MIN_TABLE_VOXELS: f64 = 2.0;
