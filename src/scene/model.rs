//! The validated scene: what `load_scene` returns and every pass reads. All values are finite,
//! all references resolved, all transforms invertible.

use std::path::PathBuf;

use glam::DVec3;

use super::camera::Camera;
use super::mesh::{Mesh, MeshSpec};
use super::transform::{Transform, TransformOp};

#[derive(Clone, Debug)]
pub struct Scene {
    /// The file this scene was read from (or a label for in-memory scenes).
    pub source: PathBuf,
    pub render: RenderSettings,
    pub camera: Camera,
    pub lights: Vec<DirectionalLight>,
    pub meshes: Vec<SceneMesh>,
    pub materials: Vec<Material>,
    pub instances: Vec<Instance>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Default image size; the CLI's --size overrides it.
    pub width: u32,
    pub height: u32,
    /// Linear multiplier applied before tonemapping.
    pub exposure: f64,
    /// Linear HDR colour where no surface is hit.
    pub background: DVec3,
    /// Linear ambient light added to every lit surface (times its albedo).
    pub ambient: DVec3,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionalLight {
    /// Unit direction the light travels (from the light toward the scene).
    pub direction: DVec3,
    pub color: DVec3,
    pub intensity: f64,
}

#[derive(Clone, Debug)]
pub struct SceneMesh {
    pub name: String,
    pub spec: MeshSpec,
    pub mesh: Mesh,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub kind: MaterialKind,
    pub albedo: DVec3,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaterialKind {
    Lambert,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    pub name: Option<String>,
    /// Index into `Scene::meshes`.
    pub mesh: usize,
    /// Index into `Scene::materials`.
    pub material: usize,
    pub ops: Vec<TransformOp>,
    pub transform: Transform,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 512,
            height: 512,
            exposure: 1.0,
            background: DVec3::new(0.02, 0.02, 0.03),
            ambient: DVec3::splat(0.08),
        }
    }
}
