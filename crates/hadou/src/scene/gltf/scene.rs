//! A whole scene from a glTF file (`hadou render level.glb`): the file's parts, its first
//! perspective camera or a framing one, its directional lights or one default light, and the
//! TOML defaults for everything glTF does not say (`[render]`), but for the exposure: automatic
//! when the file has lights (their lux need one), the TOML default 1 when it has none.

use std::path::Path;

use glam::DVec3;

use super::{framing, import, GltfError, ImportOptions};
use crate::scene::error::SceneError;
use crate::scene::file::MAX_IMAGE_SIZE;
use crate::scene::mesh::{Mesh, MeshError};
use crate::scene::model::{ExposureMode, Light, RenderSettings, Scene};

/// The light a glTF file without `KHR_lights_punctual` directional lights gets (travelling down
/// and away from the framing camera's side, intensity 1, white), so its surfaces are not lit by
/// the ambient alone.
pub const DEFAULT_LIGHT_DIRECTION: DVec3 = DVec3::new(-1.0, -2.0, -1.0);

/// True for paths ending in .gltf or .glb (any case): the scene loader reads them as glTF.
pub fn is_gltf(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

/// Loads a .gltf or .glb file as a scene; what it cannot draw is reported in one warning.
pub fn load_gltf(path: &Path) -> Result<Scene, SceneError> {
    let imp = import(path, &ImportOptions::default())?;
    imp.ignored.warn(path);
    let mut render = RenderSettings::default();
    if let Some(aspect) = imp.camera.and_then(|c| c.aspect) {
        // The default 512 rows (or columns, for a tall image) and the other side from aspectRatio.
        let side = |x: f64| (x.round() as u32).clamp(1, MAX_IMAGE_SIZE);
        if aspect >= 1.0 {
            render.width = side(render.height as f64 * aspect);
        } else {
            render.height = side(render.width as f64 / aspect);
        }
    }
    let camera = imp.camera.map_or_else(|| framing(imp.bounds), |c| c.camera);
    let mut lights = imp.lights;
    // The file's lights are in lux: shown at the automatic exposure, as a camera would. Without
    // them the default light (intensity 1) keeps the TOML default exposure 1.
    if !lights.is_empty() {
        render.exposure_mode = ExposureMode::Auto;
    }
    if lights.is_empty() {
        let direction = DEFAULT_LIGHT_DIRECTION.normalize();
        lights.push(Light::directional(direction, DVec3::ONE, 1.0));
    }
    Ok(Scene {
        source: path.to_path_buf(),
        render,
        camera,
        lights,
        meshes: imp.meshes,
        materials: imp.materials,
        instances: imp.instances,
        effects: Default::default(),
        quality: Default::default(),
    })
}

/// Primitive `p` of mesh `m` of the file, as `MeshSpec::Gltf` builds it.
pub(crate) fn build_primitive(path: &Path, m: usize, p: usize) -> Result<Mesh, MeshError> {
    let invalid = |e: GltfError| MeshError::Invalid(e.to_string());
    let mut parsed = super::document::read(path).map_err(invalid)?;
    let buffers = super::buffers::load(path, &parsed.doc, &mut parsed.blob).map_err(invalid)?;
    let src = super::accessor::Source { path, buffers: &buffers.data };
    let missing =
        || MeshError::Invalid(format!("{}: /meshes/{m}/primitives/{p}: no such primitive", path.display()));
    let mesh = parsed.doc.meshes().nth(m).ok_or_else(missing)?;
    let prim = mesh.primitives().nth(p).ok_or_else(missing)?;
    match super::primitive::build(&src, m, &prim).map_err(invalid)? {
        super::primitive::Built::Mesh(mesh) => Ok(mesh),
        super::primitive::Built::Skipped(why) => {
            Err(MeshError::Invalid(format!("{}: {why}", path.display())))
        }
    }
}
