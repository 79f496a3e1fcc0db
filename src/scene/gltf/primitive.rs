//! A mesh primitive → a hadou `Mesh`: positions, indices (any of the three triangle modes, made a
//! list), normals read or, when absent, flat normals as glTF asks (each triangle gets its own
//! three vertices and its face normal).

use glam::DVec3;
use gltf::mesh::{Mode, Semantic};

use super::accessor::{ReadError, Source};
use super::error::GltfError;
use crate::scene::mesh::Mesh;

/// A primitive built, or why it was skipped (valid glTF hadou does not draw).
pub(super) enum Built {
    Mesh(Mesh),
    Skipped(String),
}

/// Builds primitive `p` of mesh `m`.
pub(super) fn build(src: &Source, m: usize, p: &gltf::Primitive) -> Result<Built, GltfError> {
    let at = format!("/meshes/{m}/primitives/{}", p.index());
    let mode = p.mode();
    if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        return Ok(Built::Skipped(format!("{at}: mode {}", mode_name(mode))));
    }
    let Some(pos_accessor) = p.get(&Semantic::Positions) else {
        return Ok(Built::Skipped(format!("{at}: no POSITION attribute")));
    };
    let pos_at = format!("{at}/attributes/POSITION");
    let positions = match src.vec3(&pos_accessor, &pos_at) {
        Ok(v) => v,
        Err(ReadError::Bad(e)) => return Err(e),
        Err(ReadError::Unsupported(why)) => return Ok(Built::Skipped(why)),
    };
    if let Some((k, v)) = positions.iter().enumerate().find(|(_, v)| !v.iter().all(|c| c.is_finite())) {
        let message = format!("position {k} is {v:?} (expected finite numbers)");
        return Err(GltfError::at(src.path, pos_at, message));
    }
    let n = positions.len();
    let order = match p.indices() {
        Some(a) => {
            let idx_at = format!("{at}/indices");
            let order = match src.indices(&a, &idx_at) {
                Ok(v) => v,
                Err(ReadError::Bad(e)) => return Err(e),
                Err(ReadError::Unsupported(why)) => return Ok(Built::Skipped(why)),
            };
            if let Some((k, i)) = order.iter().enumerate().find(|(_, &i)| i as usize >= n) {
                let message = format!("index {k} is {i}, out of range for {n} vertices (POSITION count)");
                return Err(GltfError::at(src.path, idx_at, message));
            }
            order
        }
        None => (0..n as u32).collect(),
    };
    let indices = triangle_list(mode, &order).map_err(|why| GltfError::at(src.path, at.clone(), why))?;
    let mesh = match p.get(&Semantic::Normals) {
        Some(a) => {
            let nrm_at = format!("{at}/attributes/NORMAL");
            let normals = match src.vec3(&a, &nrm_at) {
                Ok(v) => v,
                Err(ReadError::Bad(e)) => return Err(e),
                Err(ReadError::Unsupported(why)) => return Ok(Built::Skipped(why)),
            };
            if normals.len() != n {
                let message =
                    format!("{} normals for {n} positions (expected one per position)", normals.len());
                return Err(GltfError::at(src.path, nrm_at, message));
            }
            let normals = unit_normals(&normals).map_err(|why| GltfError::at(src.path, nrm_at, why))?;
            Mesh { positions, normals, indices }
        }
        None => flat(&positions, &indices),
    };
    // The checks above cover these; this keeps any gap from reaching the GPU.
    mesh.validate_basic().map_err(|why| GltfError::at(src.path, at, why))?;
    Ok(Built::Mesh(mesh))
}

/// Triangle list from any triangle mode (glTF 2.0 §3.7.2.1 gives the strip and fan orders, which
/// keep every triangle's winding).
fn triangle_list(mode: Mode, v: &[u32]) -> Result<Vec<u32>, String> {
    let n = v.len();
    let list: Vec<u32> = match mode {
        Mode::Triangles => {
            if n % 3 != 0 {
                return Err(format!("TRIANGLES with {n} indices (expected a multiple of 3)"));
            }
            v.to_vec()
        }
        Mode::TriangleStrip => {
            (0..n.saturating_sub(2)).flat_map(|i| [v[i], v[i + 1 + i % 2], v[i + 2 - i % 2]]).collect()
        }
        _ => (1..n.saturating_sub(1)).flat_map(|i| [v[i], v[i + 1], v[0]]).collect(),
    };
    if list.is_empty() {
        return Err(format!("{} with {n} vertices draws no triangle (expected at least 3)", mode_name(mode)));
    }
    Ok(list)
}

/// Normals as given, renormalized (writers round them); zero or non-finite ones are errors.
fn unit_normals(normals: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, String> {
    normals
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let d = DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
            match d.try_normalize() {
                Some(u) => Ok([u.x as f32, u.y as f32, u.z as f32]),
                None => Err(format!("normal {k} is {v:?} (expected a non-zero, finite vector)")),
            }
        })
        .collect()
}

/// Flat shading: three fresh vertices per triangle, each with the face normal (b − a) × (c − a),
/// the outward side of a counter-clockwise triangle. A triangle without area gets +y: it covers
/// no pixel, so the normal is never seen.
fn flat(positions: &[[f32; 3]], indices: &[u32]) -> Mesh {
    let mut mesh = Mesh::default();
    for tri in indices.chunks_exact(3) {
        let p = [tri[0], tri[1], tri[2]].map(|i| positions[i as usize]);
        let [a, b, c] = p.map(|q| DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64));
        let n = (b - a).cross(c - a).try_normalize().unwrap_or(DVec3::Y);
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(p);
        mesh.normals.extend([[n.x as f32, n.y as f32, n.z as f32]; 3]);
        mesh.indices.extend([base, base + 1, base + 2]);
    }
    mesh
}

pub(super) fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Points => "POINTS",
        Mode::Lines => "LINES",
        Mode::LineLoop => "LINE_LOOP",
        Mode::LineStrip => "LINE_STRIP",
        Mode::Triangles => "TRIANGLES",
        Mode::TriangleStrip => "TRIANGLE_STRIP",
        Mode::TriangleFan => "TRIANGLE_FAN",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_the_winding() {
        // A quad 0 1 2 3 counter-clockwise: every triangle of both forms is counter-clockwise too.
        assert_eq!(triangle_list(Mode::TriangleStrip, &[0, 1, 3, 2]).unwrap(), vec![0, 1, 3, 1, 2, 3]);
        assert_eq!(triangle_list(Mode::TriangleFan, &[0, 1, 2, 3]).unwrap(), vec![1, 2, 0, 2, 3, 0]);
        assert!(triangle_list(Mode::Triangles, &[0, 1]).is_err());
        assert!(triangle_list(Mode::TriangleStrip, &[0, 1]).is_err());
    }

    #[test]
    fn flat_normals_point_to_the_counter_clockwise_side() {
        let m = flat(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], &[0, 1, 2]);
        assert_eq!(m.normals, vec![[0.0, 0.0, 1.0]; 3]);
        assert!(unit_normals(&[[0.0, 0.0, 0.0]]).is_err());
        assert_eq!(unit_normals(&[[0.0, 2.0, 0.0]]).unwrap(), vec![[0.0, 1.0, 0.0]]);
    }
}
