//! `[[gltf]]` tables: a glTF file placed in a TOML scene beside its waves, metaballs and meshes.
//! The file's meshes, materials and instances are appended to the scene's; its camera and lights
//! are used only where the TOML gives none (parse_scene decides).

use super::error::SceneError;
use super::file::{transform, Materials, MAX_LIGHTS};
use super::file_check::{Ctx, Owner};
use super::file_schema::{GltfDef, Tables};
use super::gltf::{import, placed_by_transform, GltfCamera, ImportOptions, Spent};
use super::model::{Instance, Light, SceneMesh, DEFAULT_VOXEL_RES, MAX_VOXEL_RES, MIN_VOXEL_RES};

/// What the placed files bring besides geometry.
pub(super) struct Placed {
    /// The first file's camera, if it has one.
    pub camera: Option<GltfCamera>,
    /// Their directional lights, in file order (at most `MAX_LIGHTS`).
    pub lights: Vec<Light>,
}

/// Imports every `[[gltf]]` into `meshes`, `materials` and `instances`.
pub(super) fn gltf_files(
    ctx: Ctx,
    defs: &Tables<GltfDef>,
    meshes: &mut Vec<SceneMesh>,
    materials: &mut Materials,
    instances: &mut Vec<Instance>,
) -> Result<Placed, SceneError> {
    let mut placed = Placed { camera: None, lights: Vec::new() };
    // The scene's files share one decoding budget (docs/scene-format.md, "glTF budgets").
    let mut spent = Spent::default();
    for (i, def) in defs.0.iter().enumerate() {
        let d = def.get_ref();
        let label = match &d.name {
            Some(name) => format!("gltf \"{}\"", name.get_ref()),
            None => format!("gltf {}", i + 1),
        };
        let o = Owner::new(ctx, label.clone(), def.span());
        let path = o.required(
            "path",
            d.path.as_ref(),
            "a path to a .gltf or .glb file, relative to the scene file",
        )?;
        let file = ctx.path.parent().map_or_else(|| path.get_ref().into(), |dir| dir.join(path.get_ref()));
        let (base, _) = transform(&o, d.transform.as_ref())?;
        let voxel_res =
            o.count("voxel_res", d.voxel_res.as_ref(), DEFAULT_VOXEL_RES, MIN_VOXEL_RES, MAX_VOXEL_RES)?;
        let options = ImportOptions { base, label: format!("{label}: "), voxel_res, spent };
        // An instance the `transform` takes out of the numeric limits is placed at the `transform`.
        let imp = import(&file, &options).map_err(|e| match d.transform.as_ref() {
            Some(t) if placed_by_transform(&e) => {
                ctx.err(ctx.key_start(&t.span())..t.span().end, format!("{label} `transform`: {e}"))
            }
            _ => ctx.err(path.span(), format!("{label} `path`: {e}")),
        })?;
        imp.ignored.warn(&file);
        spent = imp.spent;
        let (mesh_offset, material_offset) = (meshes.len(), materials.list.len());
        meshes.extend(imp.meshes);
        materials.list.extend(imp.materials);
        instances.extend(imp.instances.into_iter().map(|mut inst| {
            inst.mesh += mesh_offset;
            inst.material += material_offset;
            inst
        }));
        if placed.camera.is_none() {
            placed.camera = imp.camera;
        }
        for light in imp.lights {
            if placed.lights.len() == MAX_LIGHTS {
                log::warn!("{}: {label}: lights past the {MAX_LIGHTS}th are not used", ctx.path.display());
                break;
            }
            placed.lights.push(light);
        }
    }
    Ok(placed)
}
