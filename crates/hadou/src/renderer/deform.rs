//! Meshes deformed at run time: a game changes a mesh's vertex positions for the next frame
//! (a slime, a cloth-wrapped lamp). No host wait: the new vertices go into a vertex buffer of the
//! frame slot that records the next frame (`SceneGpu::begin_slot`), so a frame in flight keeps
//! the vertices it was recorded with.
//!
//! Every instance of the mesh follows: the raster, the light_id maps (so `thickness = "tsm"`
//! follows), and the peel lists (`thickness = "peel"` follows exactly: it has no bake). A mesh
//! drawn by a `thickness = "lut"` material is refused: its table was baked from the shape at load
//! and would describe another solid.

use glam::Vec3;

use super::Renderer;
use crate::scene::procedural::MAX_LENGTH;
use crate::scene::MaterialKind;
use crate::Error;

fn invalid(what: String, expected: impl Into<String>) -> Error {
    Error::InvalidUpdate { what, expected: expected.into() }
}

/// Area-weighted vertex normals of `positions` under `indices` (the sum of the cross products of
/// the triangles using each vertex, normalized); a vertex with no area around it keeps `old`.
pub fn vertex_normals(positions: &[[f32; 3]], indices: &[u32], old: &[[f32; 3]]) -> Vec<[f32; 3]> {
    let mut sums = vec![glam::DVec3::ZERO; positions.len()];
    let p = |i: u32| glam::DVec3::from(positions[i as usize].map(f64::from));
    for t in indices.chunks_exact(3) {
        let n = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
        for &i in t {
            sums[i as usize] += n;
        }
    }
    sums.iter().zip(old).map(|(s, o)| s.try_normalize().map_or(*o, |n| n.as_vec3().to_array())).collect()
}

/// The vertices of a mesh as loaded: positions and normals.
type Vertices = (Vec<[f32; 3]>, Vec<[f32; 3]>);

/// The wobbling meshes of a loaded scene (`scene::wobble`): each one's loaded vertices, and the
/// scene time their current shape is of.
#[derive(Default)]
pub(super) struct WobbleState {
    base: Vec<Option<Vertices>>,
    time: Option<f64>,
}

impl WobbleState {
    pub fn new(scene: &crate::scene::Scene) -> Self {
        let base = scene
            .meshes
            .iter()
            .map(|m| m.wobble.map(|_| (m.mesh.positions.clone(), m.mesh.normals.clone())))
            .collect();
        WobbleState { base, time: None }
    }
}

impl Renderer {
    /// Deforms the wobbling meshes to scene time `time` (nothing when none wobbles or the time is
    /// the one applied last).
    pub(super) fn apply_wobble(&mut self, time: f64) {
        let Some(loaded) = &mut self.loaded else { return };
        if loaded.wobble.time == Some(time) || loaded.wobble.base.iter().all(Option::is_none) {
            return;
        }
        loaded.wobble.time = Some(time);
        for (i, base) in loaded.wobble.base.iter().enumerate() {
            let (Some((positions, normals)), Some(w)) = (base, loaded.scene.meshes[i].wobble) else {
                continue;
            };
            let m = &mut loaded.scene.meshes[i].mesh;
            m.positions = w.positions(positions, time);
            // At rest (t = 0, each half period) the mesh is as loaded, its own normals included.
            m.normals = if m.positions == *positions {
                normals.clone()
            } else {
                vertex_normals(&m.positions, &m.indices, normals)
            };
            loaded.gpu.meshes[i].bounds = m.bounds();
            loaded.gpu.mesh_deformed(i);
        }
    }

    /// Moves the vertices of mesh `mesh` (a `[[mesh]]` name of the loaded scene) to `positions`
    /// (object space, one per vertex in the mesh's order, finite, within 1e6 of the origin) from
    /// the next recorded frame on, for every instance of it; the normals are recomputed
    /// (area-weighted over the triangles using each vertex: vertices the mesh splits, at hard
    /// edges or seams, stay split). The triangles are kept. No host wait. A mesh with a `wobble`
    /// in the scene file stops wobbling: the game's positions replace it. The mesh should stay
    /// closed and not cut through itself for translucent instances (their thickness counts
    /// the winding number of the surface). State is unchanged on error.
    pub fn set_mesh_positions(&mut self, mesh: &str, positions: &[Vec3]) -> Result<(), Error> {
        self.set_mesh_vertices(mesh, positions, None)
    }

    /// `set_mesh_positions` with the game's own unit normals (one per vertex), e.g. from its
    /// skinning, instead of recomputed ones.
    pub fn set_mesh_vertices(
        &mut self,
        mesh: &str,
        positions: &[Vec3],
        normals: Option<&[Vec3]>,
    ) -> Result<(), Error> {
        let index = self
            .live_mesh(mesh)
            .ok_or_else(|| invalid(format!("mesh \"{mesh}\""), "the name of a mesh of the world"))?;
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        let scene = &loaded.scene;
        let count = scene.meshes[index].mesh.positions.len();
        let what = || format!("vertices of mesh \"{mesh}\" ({} given)", positions.len());
        if positions.len() != count || normals.is_some_and(|n| n.len() != count) {
            return Err(invalid(what(), format!("{count} positions (and normals), one per vertex")));
        }
        let max = MAX_LENGTH as f32;
        if !positions.iter().all(|p| p.is_finite() && p.abs().max_element() <= max) {
            return Err(invalid(what(), "finite positions within 1e6 of the origin"));
        }
        if normals.is_some_and(|n| !n.iter().all(|v| v.is_finite() && (v.length() - 1.0).abs() < 1e-3)) {
            return Err(invalid(what(), "unit normals"));
        }
        let lut = scene.instances.iter().find(|i| {
            i.mesh == index
                && matches!(
                    scene.materials[i.material].kind,
                    MaterialKind::Translucent { thickness, .. } if thickness.is_baked()
                )
        });
        if let Some(i) = lut {
            let material = &scene.materials[i.material].name;
            return Err(invalid(
                what(),
                format!(
                    "a mesh no instance draws with a thickness = \"lut\" or \"pairs\" material (material \"{material}\" \
                     reads a table baked from the loaded shape; use \"peel\" or \"tsm\")"
                ),
            ));
        }
        loaded.scene.meshes[index].wobble = None;
        if let Some(base) = loaded.wobble.base.get_mut(index) {
            *base = None;
        }
        let m = &mut loaded.scene.meshes[index].mesh;
        m.positions = positions.iter().map(|p| p.to_array()).collect();
        m.normals = match normals {
            Some(n) => n.iter().map(|v| v.normalize().to_array()).collect(),
            None => vertex_normals(&m.positions, &m.indices, &m.normals),
        };
        loaded.gpu.meshes[index].bounds = m.bounds();
        loaded.gpu.mesh_deformed(index);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_of_a_cube_stay_flat_and_a_lone_vertex_keeps_its_own() {
        let cube = crate::scene::procedural::cube(2.0).unwrap();
        let n = vertex_normals(&cube.positions, &cube.indices, &cube.normals);
        for (a, b) in n.iter().zip(&cube.normals) {
            assert!((Vec3::from(*a) - Vec3::from(*b)).length() < 1e-6);
        }
        let kept = vertex_normals(&[[0.0; 3]], &[], &[[0.0, 0.0, 1.0]]);
        assert_eq!(kept, vec![[0.0, 0.0, 1.0]]);
    }
}
