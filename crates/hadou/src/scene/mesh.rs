//! Triangle meshes as hadou stores them: f32 positions and normals (the GPU's copy and the f64
//! reference read the same numbers), u32 indices, counter-clockwise front faces seen from outside.

use std::collections::HashMap;
use std::path::PathBuf;

use glam::DVec3;

use super::{obj, procedural};

/// An indexed triangle mesh in object space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions in object space.
    pub positions: Vec<[f32; 3]>,
    /// Unit vertex normals, one per position.
    pub normals: Vec<[f32; 3]>,
    /// Three indices per triangle, counter-clockwise seen from the side the normal points to.
    pub indices: Vec<u32>,
    /// Per-vertex attributes a glTF primitive brings (`COLOR_0`, `TEXCOORD_0/1`); None for every
    /// other mesh, which the raster draws exactly as before (colour 1, no coordinates).
    pub attributes: Option<Box<VertexAttributes>>,
}

/// Optional per-vertex data of a glTF primitive, each list empty or one entry per position.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VertexAttributes {
    /// `COLOR_0` as linear RGBA in [0, 1] (alpha 1 for a VEC3 accessor), multiplied into the
    /// material's base colour; empty: white.
    pub colors: Vec<[f32; 4]>,
    /// `TEXCOORD_0` and `TEXCOORD_1` (glTF's uv: origin at the image's top left); empty: (0, 0).
    pub texcoords: [Vec<[f32; 2]>; 2],
}

/// What a scene asks for; `MeshSpec::build` turns it into a `Mesh`.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshSpec {
    /// Square in the xz-plane centred at the origin, normal +y.
    Plane {
        /// Edge length.
        size: f64,
    },
    /// Axis-aligned cube centred at the origin with edge `size`.
    Cube {
        /// Edge length.
        size: f64,
    },
    /// UV sphere centred at the origin.
    Sphere {
        /// Sphere radius.
        radius: f64,
        /// Vertices per latitude ring (around y), ≥ 3.
        segments: u32,
        /// Latitude bands from pole to pole, ≥ 2.
        rings: u32,
    },
    /// Torus around the y axis.
    Torus {
        /// Radius of the tube's centre circle in the xz-plane.
        major_radius: f64,
        /// Tube radius, in [major_radius/1000, major_radius).
        minor_radius: f64,
        /// Divisions around the y axis, ≥ 3.
        segments: u32,
        /// Divisions around the tube, ≥ 3.
        sides: u32,
    },
    /// Regular tetrahedron centred at the origin with circumradius `size`.
    Tetrahedron {
        /// Circumradius.
        size: f64,
    },
    /// Cube of edge `size` with an inner spherical cavity (inner shell faces inward).
    CavityCube {
        /// Edge length of the cube.
        size: f64,
        /// Radius of the cavity, in [size/1000, size/2).
        cavity_radius: f64,
        /// The cavity's vertices per latitude ring, ≥ 3.
        segments: u32,
        /// The cavity's latitude bands, ≥ 2.
        rings: u32,
    },
    /// Ball of `radius` with two spherical cavities of `cavity_radius` at (0, ±radius/2, 0).
    HollowBall {
        /// Radius of the ball.
        radius: f64,
        /// Radius of each cavity, in [radius/1000, radius/4).
        cavity_radius: f64,
        /// Vertices per latitude ring of each sphere, ≥ 3.
        segments: u32,
        /// Latitude bands of each sphere, ≥ 2.
        rings: u32,
    },
    /// Hollow bottle (closed outer and inner walls) whose lower part holds a closed liquid volume.
    Bottle {
        /// Outer radius of the body.
        radius: f64,
        /// Total height; the bottle stands on y = −height/2.
        height: f64,
        /// Glass thickness: < radius/2, < height/4, ≥ max(radius, height)/1000.
        wall: f64,
        /// Fraction of the inside's height the liquid fills, in [0, 1]; 0: no liquid.
        fill: f64,
        /// Divisions around the y axis, ≥ 3.
        segments: u32,
    },
    /// Wavefront OBJ file.
    Obj {
        /// The file, opened as given.
        path: PathBuf,
    },
    /// A mesh a game handed at run time (`Renderer::spawn_mesh`): no source to build it from.
    Given,
    /// One primitive of a glTF file (`scene::gltf`).
    Gltf {
        /// The .gltf or .glb file, opened as given.
        path: PathBuf,
        /// Index of the glTF mesh.
        mesh: usize,
        /// Index of the primitive in that mesh.
        primitive: usize,
    },
}

/// Why a mesh could not be built or loaded. Each variant's message names where the problem is.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// An OBJ file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The OBJ file.
        path: PathBuf,
        /// What the OS reported.
        source: std::io::Error,
    },
    /// An OBJ file's content is malformed at `line`:`column`.
    #[error("{}:{line}:{column}: {message}", path.display())]
    Obj {
        /// The OBJ file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column, in characters.
        column: usize,
        /// What was expected and what was found.
        message: String,
    },
    /// Parameters a generator refuses ("`<kind> <field> must be …, got …`"), or a mesh a consumer
    /// cannot use (e.g. ray casting); the message says which and why.
    #[error("{0}")]
    Invalid(String),
}

impl MeshSpec {
    /// Generates or loads the mesh. Parameters are validated by the generator (see
    /// `procedural`); an OBJ path is opened as given (the scene loader resolves relative paths
    /// against the scene file before it builds the spec).
    pub fn build(&self) -> Result<Mesh, MeshError> {
        match self {
            MeshSpec::Plane { size } => procedural::plane(*size),
            MeshSpec::Cube { size } => procedural::cube(*size),
            MeshSpec::Sphere { radius, segments, rings } => procedural::uv_sphere(*radius, *segments, *rings),
            MeshSpec::Torus { major_radius, minor_radius, segments, sides } => {
                procedural::torus(*major_radius, *minor_radius, *segments, *sides)
            }
            MeshSpec::Tetrahedron { size } => procedural::tetrahedron(*size),
            MeshSpec::CavityCube { size, cavity_radius, segments, rings } => {
                procedural::cavity_cube(*size, *cavity_radius, *segments, *rings)
            }
            MeshSpec::HollowBall { radius, cavity_radius, segments, rings } => {
                procedural::hollow_ball(*radius, *cavity_radius, *segments, *rings)
            }
            MeshSpec::Bottle { radius, height, wall, fill, segments } => {
                procedural::bottle(*radius, *height, *wall, *fill, *segments)
            }
            MeshSpec::Obj { path } => obj::load_obj(path),
            MeshSpec::Gltf { path, mesh, primitive } => super::gltf::build_primitive(path, *mesh, *primitive),
            MeshSpec::Given => {
                Err(MeshError::Invalid("a mesh given at run time has no source to build it from".into()))
            }
        }
    }
}

/// A triangle counts as degenerate when twice its area is at most this fraction of its longest
/// edge squared (scale-free: a sliver and a point-triangle both qualify, a tiny but well-shaped
/// triangle does not).
pub const DEGENERATE_RELATIVE_AREA: f64 = 1e-12;

/// How far a vertex normal's length may stray from 1 in `validate_basic` (f32 rounding of a unit
/// vector is ~1e-7; anything beyond this was never normalized).
pub const NORMAL_LENGTH_TOLERANCE: f64 = 1e-4;

impl Mesh {
    /// Number of triangles: `indices.len() / 3`.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Position `i` in f64.
    pub fn position(&self, i: usize) -> DVec3 {
        let p = self.positions[i];
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    }

    /// The three vertex indices of triangle `t`.
    pub fn triangle(&self, t: usize) -> [usize; 3] {
        let i = &self.indices[3 * t..3 * t + 3];
        [i[0] as usize, i[1] as usize, i[2] as usize]
    }

    /// Axis-aligned bounds of all positions, (min, max); both zero for a mesh without positions.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        if self.positions.is_empty() {
            return (DVec3::ZERO, DVec3::ZERO);
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for i in 0..self.positions.len() {
            let p = self.position(i);
            lo = lo.min(p);
            hi = hi.max(p);
        }
        (lo, hi)
    }

    /// Signed volume by the divergence theorem (Σ a·(b×c)/6), in f64 from the f32 positions.
    /// Positive for a closed mesh whose faces point outward. Triangles with an index out of range
    /// are skipped (see `validate_basic`).
    pub fn signed_volume(&self) -> f64 {
        let n = self.positions.len();
        let mut sum = 0.0;
        for tri in self.indices.chunks_exact(3) {
            if tri.iter().any(|&i| i as usize >= n) {
                continue;
            }
            let [a, b, c] = [0, 1, 2].map(|k| self.position(tri[k] as usize));
            sum += a.dot(b.cross(c));
        }
        sum / 6.0
    }

    /// Cheap structural checks every consumer relies on: index count a non-zero multiple of 3,
    /// indices in range, finite positions, one unit normal per position.
    pub fn validate_basic(&self) -> Result<(), String> {
        if self.indices.len() % 3 != 0 {
            return Err(format!("index count {} is not a multiple of 3", self.indices.len()));
        }
        if self.indices.is_empty() {
            return Err("mesh has no triangles".into());
        }
        if self.normals.len() != self.positions.len() {
            return Err(format!(
                "mesh has {} normals for {} positions (expected one per position)",
                self.normals.len(),
                self.positions.len()
            ));
        }
        if let Some((k, &i)) =
            self.indices.iter().enumerate().find(|(_, &i)| i as usize >= self.positions.len())
        {
            return Err(format!(
                "index {k} (triangle {}) is {i}, out of range for {} positions",
                k / 3,
                self.positions.len()
            ));
        }
        if let Some(i) = self.positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(format!("position {i} is not finite: {:?}", self.positions[i]));
        }
        if let Some(a) = &self.attributes {
            let n = self.positions.len();
            for (what, len) in [
                ("colours", a.colors.len()),
                ("TEXCOORD_0", a.texcoords[0].len()),
                ("TEXCOORD_1", a.texcoords[1].len()),
            ] {
                if len != 0 && len != n {
                    return Err(format!(
                        "mesh has {len} {what} for {n} positions (expected one per position)"
                    ));
                }
            }
        }
        for (i, n) in self.normals.iter().enumerate() {
            let len = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64).length();
            // Written so a NaN length fails too.
            let unit = (len - 1.0).abs() <= NORMAL_LENGTH_TOLERANCE;
            if !unit {
                return Err(format!("normal {i} {n:?} has length {len} (expected unit length)"));
            }
        }
        Ok(())
    }

    /// Triangles whose doubled area is at most `DEGENERATE_RELATIVE_AREA` times their longest
    /// edge squared, computed in f64 (non-finite corners count as degenerate). Triangles with an
    /// index out of range are skipped (see `validate_basic`).
    pub fn degenerate_triangles(&self) -> Vec<usize> {
        let n = self.positions.len();
        let mut out = Vec::new();
        for (t, tri) in self.indices.chunks_exact(3).enumerate() {
            if tri.iter().any(|&i| i as usize >= n) {
                continue;
            }
            let [a, b, c] = [0, 1, 2].map(|k| self.position(tri[k] as usize));
            if is_degenerate(a, b, c) {
                out.push(t);
            }
        }
        out
    }

    /// Checks that the mesh is a closed, consistently oriented surface: after welding positions
    /// that are bit-for-bit equal (so flat-shaded meshes with split vertices count), every edge is
    /// used exactly twice, once in each direction. The error names the first offending edge in
    /// triangle order, with vertex indices, positions and how many triangles use it.
    pub fn check_closed_oriented(&self) -> Result<(), String> {
        if self.indices.len() % 3 != 0 {
            return Err(format!("index count {} is not a multiple of 3", self.indices.len()));
        }
        let n = self.positions.len();
        if let Some(&i) = self.indices.iter().find(|&&i| i as usize >= n) {
            return Err(format!("index {i} out of range for {n} positions"));
        }
        let weld = weld_positions(&self.positions);
        let edges = count_edges(&self.indices, &weld);
        for (t, tri) in self.indices.chunks_exact(3).enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let (wa, wb) = (weld[a as usize], weld[b as usize]);
                if wa == wb {
                    return Err(format!(
                        "triangle {t} has a zero-length edge: vertices {a} and {b} are both at {:?}",
                        self.positions[a as usize]
                    ));
                }
                let use_ = edges[&edge_key(wa, wb)];
                if use_.forward != 1 || use_.backward != 1 {
                    return Err(self.edge_message(t, a, b, wa < wb, use_));
                }
            }
        }
        Ok(())
    }

    fn edge_message(&self, t: usize, a: u32, b: u32, a_is_low: bool, use_: EdgeUse) -> String {
        // Express the counts in the direction this triangle walks the edge.
        let (same, opposite) =
            if a_is_low { (use_.forward, use_.backward) } else { (use_.backward, use_.forward) };
        format!(
            "edge between vertices {a} {:?} and {b} {:?} (first seen in triangle {t}) is used by {} \
             triangle(s): {same} walk it {a}→{b}, {opposite} walk it {b}→{a} (a closed, consistently \
             oriented mesh has exactly one of each)",
            self.positions[a as usize],
            self.positions[b as usize],
            same + opposite
        )
    }
}

/// Zero area within a relative `DEGENERATE_RELATIVE_AREA` of the longest edge squared.
pub fn is_degenerate(a: DVec3, b: DVec3, c: DVec3) -> bool {
    let twice_area = (b - a).cross(c - a).length();
    let longest2 = (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared());
    // Written as "not well shaped" so NaN and all-zero triangles count as degenerate.
    let well_shaped = twice_area > DEGENERATE_RELATIVE_AREA * longest2;
    !well_shaped
}

#[derive(Clone, Copy, Debug, Default)]
struct EdgeUse {
    /// Triangles walking the edge from the lower welded id to the higher one.
    forward: u32,
    backward: u32,
}

fn edge_key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// Welded id per vertex: vertices whose positions are bit-for-bit equal (−0 = +0) share an id.
fn weld_positions(positions: &[[f32; 3]]) -> Vec<u32> {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::with_capacity(positions.len());
    positions
        .iter()
        .map(|p| {
            // Adding 0.0 turns −0.0 into +0.0, so the two zeros weld.
            let key = p.map(|c| (c + 0.0).to_bits());
            let next = ids.len() as u32;
            *ids.entry(key).or_insert(next)
        })
        .collect()
}

fn count_edges(indices: &[u32], weld: &[u32]) -> HashMap<(u32, u32), EdgeUse> {
    let mut edges: HashMap<(u32, u32), EdgeUse> = HashMap::with_capacity(indices.len());
    for tri in indices.chunks_exact(3) {
        for k in 0..3 {
            let (a, b) = (weld[tri[k] as usize], weld[tri[(k + 1) % 3] as usize]);
            let e = edges.entry(edge_key(a, b)).or_default();
            if a < b {
                e.forward += 1;
            } else {
                e.backward += 1;
            }
        }
    }
    edges
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> Mesh {
        // Corners of a right tetrahedron, faces CCW from outside.
        let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        Mesh {
            normals: vec![[0.0, 1.0, 0.0]; 4],
            positions,
            indices: vec![0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3],
            attributes: None,
        }
    }

    #[test]
    fn closed_tetrahedron_passes() {
        let m = tetra();
        assert_eq!(m.triangle_count(), 4);
        m.check_closed_oriented().unwrap();
        m.validate_basic().unwrap();
        assert!(m.degenerate_triangles().is_empty());
        assert!((m.signed_volume() - 1.0 / 6.0).abs() < 1e-15);
        assert_eq!(m.bounds(), (DVec3::ZERO, DVec3::ONE));
    }

    #[test]
    fn open_mesh_names_the_edge() {
        let mut m = tetra();
        m.indices.truncate(9);
        let err = m.check_closed_oriented().unwrap_err();
        assert!(
            err.contains("vertices 2 [0.0, 1.0, 0.0] and 1") && err.contains("used by 1 triangle"),
            "{err}"
        );
    }

    #[test]
    fn flipped_triangle_is_reported() {
        let mut m = tetra();
        m.indices.swap(10, 11);
        let err = m.check_closed_oriented().unwrap_err();
        assert!(err.contains("used by 2 triangle(s): 2 walk it"), "{err}");
    }

    #[test]
    fn split_vertices_weld_including_negative_zero() {
        let mut m = tetra();
        // Give the last face its own copies of its corners, one with −0.0.
        m.positions.extend([[1.0, -0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        m.normals.extend([[0.0, 1.0, 0.0]; 3]);
        m.indices.splice(9..12, [4, 5, 6]);
        m.check_closed_oriented().unwrap();
    }

    #[test]
    fn degenerate_and_basic_checks() {
        let mut m = tetra();
        m.positions.push([0.5, 0.5, 0.0]); // on the edge 1–2
        m.normals.push([0.0, 0.0, 1.0]);
        m.indices.extend([1, 4, 2, 0, 0, 1]);
        assert_eq!(m.degenerate_triangles(), vec![4, 5]);
        let mut collapsed = tetra();
        collapsed.indices[1] = 0;
        assert!(collapsed.check_closed_oriented().unwrap_err().contains("zero-length edge"));
        m.indices.push(0);
        assert!(m.validate_basic().unwrap_err().contains("multiple of 3"));
        m.indices.extend([1, 99]);
        assert!(m.validate_basic().unwrap_err().contains("out of range"));
        assert!(m.check_closed_oriented().unwrap_err().contains("out of range"));
        m.indices.truncate(12);
        m.normals[0] = [0.0, 2.0, 0.0];
        assert!(m.validate_basic().unwrap_err().contains("normal 0"));
        m.normals[0] = [0.0, 1.0, 0.0];
        m.positions[1][0] = f32::NAN;
        assert!(m.validate_basic().unwrap_err().contains("not finite"));
        assert!(Mesh::default().validate_basic().is_err());
        assert_eq!(Mesh::default().bounds(), (DVec3::ZERO, DVec3::ZERO));
    }

    #[test]
    fn spec_build_dispatches() {
        let m = MeshSpec::Cube { size: 2.0 }.build().unwrap();
        assert_eq!(m.triangle_count(), 12);
        assert!(MeshSpec::Sphere { radius: -1.0, segments: 8, rings: 4 }.build().is_err());
        let missing = MeshSpec::Obj { path: "/nonexistent/x.obj".into() }.build();
        assert!(matches!(missing, Err(MeshError::Io { .. })));
    }
}
