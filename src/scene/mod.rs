//! What the user describes: the scene file (TOML, see docs/scene-format.md) and the validated
//! `Scene` it becomes — camera, lights, meshes, materials and instanced transforms.

pub mod camera;
pub mod error;
pub mod file;
mod file_check;
mod file_mesh;
mod file_schema;
pub mod mesh;
pub mod model;
pub mod obj;
pub mod procedural;
pub mod transform;

pub use error::SceneError;
pub use file::{load_scene, parse_scene};
pub use model::*;
