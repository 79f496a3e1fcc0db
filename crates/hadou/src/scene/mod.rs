//! What the user describes: the scene file (TOML, see docs/scene-format.md) and the validated
//! `Scene` it becomes — camera, lights, meshes, materials, instanced transforms and energy waves.

pub mod camera;
pub mod error;
pub mod file;
pub(crate) mod file_check;
mod file_gltf;
mod file_material;
mod file_mesh;
pub(crate) mod file_schema;
pub mod gltf;
pub mod mesh;
pub mod metaball_track;
pub mod model;
pub mod obj;
pub mod procedural;
pub mod texture;
pub mod transform;
pub mod wave_track;
pub mod wobble;

/// How a metaball group is ray cast (`[[metaballs]] method`).
pub use crate::effects::metaballs::CastMethod;
pub use error::SceneError;
pub use file::{load_scene, load_scene_with, parse_scene, parse_scene_with};
pub use model::*;
pub use wave_track::WaveState;
