//! glTF 2.0 import (docs/scene-format.md, "glTF"): a .gltf (external or embedded buffers) or .glb
//! file becomes the same model types a TOML scene does — meshes, materials, instances, lights, a
//! camera — so every pass draws it unchanged. One job per file: `document` (parse, validate),
//! `buffers`, `accessor` (checked reads), `primitive` (a `Mesh`), `nodes` (hierarchy, transforms),
//! `material`, `texture`, `lights`, `view` (camera, framing), `builder` (the parts, shared), `ignored` (the one
//! warning), `scene` (a whole scene from a glTF file).

mod accessor;
mod buffers;
mod builder;
mod document;
mod error;
mod ignored;
mod lights;
mod limits;
mod material;
mod nodes;
mod primitive;
mod scene;
mod texture;
mod view;

use std::path::{Path, PathBuf};

use glam::DVec3;

pub use builder::MIN_TABLE_VOXELS;
pub use error::GltfError;
pub use ignored::Ignored;
pub use lights::lux_to_intensity;
pub(crate) use limits::placed_by_transform;
pub(crate) use limits::show_computed;
pub use limits::MAX_WORLD;
pub use material::{sigma, MIN_ATTENUATION_COLOR, MIN_SIGMA};
pub use nodes::MAX_DEPTH;
pub use primitive::Spent;
pub(crate) use scene::build_primitive;
pub use scene::{is_gltf, load_gltf, DEFAULT_LIGHT_DIRECTION};
pub use texture::MAX_SIDE as MAX_TEXTURE_SIDE;
pub use view::{framing, GltfCamera, SceneBounds, BACKDROP_RATIO, FRAMING_DIRECTION, FRAMING_FOV_DEG};

use super::model::{Instance, Light, Material, SceneMesh, DEFAULT_VOXEL_RES};
use super::transform::{Transform, TransformOp};

/// How a glTF file is placed into a scene.
#[derive(Clone, Debug)]
pub struct ImportOptions {
    /// Steps applied after the file's own node transforms (a TOML `[[gltf]]`'s `transform`).
    pub base: Vec<TransformOp>,
    /// Put before every mesh and material name (`gltf 1: `), so names stay unique in a scene.
    pub label: String,
    /// Voxel resolution of the thickness tables of translucent meshes.
    pub voxel_res: u32,
    /// What earlier glTF files of the same scene drew: they share one budget.
    pub spent: Spent,
}

impl Default for ImportOptions {
    fn default() -> Self {
        ImportOptions {
            base: Vec::new(),
            label: String::new(),
            voxel_res: DEFAULT_VOXEL_RES,
            spent: Spent::default(),
        }
    }
}

/// What a glTF file contributes to a scene. `instances` index into `meshes` and `materials`.
#[derive(Clone, Debug)]
pub struct GltfImport {
    /// One mesh per drawn primitive (glTF mesh m, primitive p), shared by every node using it.
    pub meshes: Vec<SceneMesh>,
    /// One per glTF material used (two when one is on both closed and open meshes).
    pub materials: Vec<Material>,
    /// One per (node, primitive), in depth-first node order.
    pub instances: Vec<Instance>,
    /// Lights (directional, point, spot), in node order (at most `MAX_LIGHTS`).
    pub lights: Vec<Light>,
    /// The first perspective camera of the scene's nodes.
    pub camera: Option<GltfCamera>,
    /// World bounds (min, max) of every drawn instance, and of those a framing camera frames.
    pub bounds: Option<SceneBounds>,
    /// What was not drawn, with where.
    pub ignored: Ignored,
    /// The glTF file and the buffer and image files it read (outputs may not replace them).
    pub files: Vec<PathBuf>,
    /// `ImportOptions::spent` plus what this file draws (for the scene's next file).
    pub spent: Spent,
}

/// Reads `path` (.gltf or .glb) into scene parts.
pub fn import(path: &Path, options: &ImportOptions) -> Result<GltfImport, GltfError> {
    let mut parsed = document::read(path)?;
    let doc = &parsed.doc;
    let mut ignored = Ignored::default();
    note_file_level(doc, &mut ignored);
    let buffers = buffers::load(path, doc, &mut parsed.blob)?;
    let hierarchy = nodes::hierarchy(path, doc)?;
    let (order, other_scenes, spent) = nodes::scene_nodes(path, doc, &hierarchy, options.spent)?;
    for s in other_scenes {
        ignored.add("scenes other than the one shown", s);
    }
    let src = accessor::Source { path, buffers: &buffers.data };
    let mut b = builder::Builder::new(path, options, ignored);
    let all_nodes: Vec<gltf::Node> = doc.nodes().collect();
    let mut cameras = Vec::new();
    let mut local_lights: Vec<String> = Vec::new();
    for &n in &order {
        let node = &all_nodes[n];
        let ops = hierarchy.world_ops(n, &options.base);
        let world = match Transform::from_ops(&ops) {
            Ok(t) => t,
            Err(e) => {
                if node.mesh().is_some() || node.camera().is_some() || node.light().is_some() {
                    b.ignored.add(
                        "nodes with a singular transform (such as scale 0)",
                        format!("/nodes/{n} ({e})"),
                    );
                }
                continue;
            }
        };
        if let Some(mesh) = node.mesh() {
            let first = b.instances.len();
            b.node_mesh(&src, node, &mesh, ops, world)?;
            for inst in &b.instances[first..] {
                let m = &b.meshes[inst.mesh];
                let bounds = m.mesh.bounds();
                limits::check_instance(path, &hierarchy, n, &options.base, bounds, &world, &m.name)?;
            }
        }
        if let Some(cam) = node.camera() {
            cameras.push((n, cam, world));
        }
        if let Some(light) = node.light() {
            if let Some(l) = lights::light(path, &light, n, &world, &mut b.ignored)? {
                if l.is_local() {
                    local_lights.push(format!("/extensions/KHR_lights_punctual/lights/{}", light.index()));
                }
                b.push_light(l, light.index())?;
            }
        }
    }
    // Translucent materials (transmission, volume) are lit through by the first directional light
    // only; a point or spot light lights their surface as it lights an opaque one (`Scene::
    // first_directional_light`): what it does not draw is named.
    let translucent =
        b.materials.iter().any(|m| matches!(m.kind, super::model::MaterialKind::Translucent { .. }));
    if translucent {
        for at in local_lights {
            b.ignored.add(
                "light of point and spot lights through translucent materials (their surfaces are lit; the light through them is the first directional light's)",
                at,
            );
        }
    }
    if b.instances.is_empty() {
        let why = if b.ignored.is_empty() { "the scene has no mesh".to_owned() } else { b.ignored.summary() };
        return Err(GltfError::at(path, "", format!("nothing to draw: {why}")));
    }
    let bounds = scene_bounds(&b.meshes, &b.instances);
    let all = bounds.map(|b| b.all);
    let mut camera = None;
    for (n, cam, world) in cameras {
        let at = format!("/nodes/{n}/camera");
        if camera.is_some() {
            b.ignored.add("cameras after the first perspective one", at);
            continue;
        }
        camera = view::perspective(path, &cam, &world, all)?;
        if camera.is_none() {
            b.ignored.add("orthographic cameras and cameras on degenerate nodes", at);
        }
    }
    let mut files = vec![path.to_path_buf()];
    files.extend(buffers.files);
    files.extend(std::mem::take(&mut b.images.files));
    Ok(GltfImport {
        meshes: b.meshes,
        materials: b.materials,
        instances: b.instances,
        lights: b.lights,
        camera,
        bounds,
        ignored: b.ignored,
        files,
        spent,
    })
}

/// The glTF file and the buffer and image files it names (empty when it cannot be read: the caller has
/// already loaded it, so this only lists what to protect from being overwritten).
pub fn referenced_files(path: &Path) -> Vec<PathBuf> {
    let mut files = vec![path.to_path_buf()];
    if let Ok(mut parsed) = document::read(path) {
        if let Ok(b) = buffers::load(path, &parsed.doc, &mut parsed.blob) {
            files.extend(b.files);
        }
        files.extend(texture::image_files(path, &parsed.doc));
    }
    files
}

/// Extensions used (not required: those were refused) that hadou does not read, and animations
/// (never drawn).
fn note_file_level(doc: &gltf::Document, ignored: &mut Ignored) {
    for (i, ext) in doc.extensions_used().enumerate() {
        if !document::HONOURED.contains(&ext) {
            ignored.add("extensions", format!("/extensionsUsed/{i} ({ext})"));
        }
    }
    for a in doc.animations() {
        ignored.add("animations", format!("/animations/{}", a.index()));
    }
}

/// The bounds of the instances, each mesh's box corners through its instance's matrix: all of
/// them, and those a framing camera frames (`view::framed_boxes`: ground planes that dwarf the
/// rest left out); None without instances.
pub fn scene_bounds(meshes: &[SceneMesh], instances: &[Instance]) -> Option<SceneBounds> {
    let boxes: Vec<(DVec3, DVec3)> = instances
        .iter()
        .map(|inst| limits::world_box(&inst.transform.matrix, meshes[inst.mesh].mesh.bounds()))
        .collect();
    SceneBounds::of_boxes(&boxes)
}
