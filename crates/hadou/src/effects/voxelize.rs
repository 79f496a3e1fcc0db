//! The voxel grid of a closed mesh and the solid's winding number at the grid's corners (seed
//! 003, §3.1): the discretization the thickness field (`effects::thickness_lut`) is sampled on.
//!
//! **Grid.** At resolution N the voxel edge is h = (longest extent of the mesh's bounding box) / N.
//! Along each axis the grid has `dims[a] = ceil(extent[a] / h) + 2` voxels (one voxel of padding on
//! each side, at least), centred on the bounding box and nudged by a thousandth of a voxel
//! (`GRID_NUDGE`): `origin = centre − dims·h/2 + GRID_NUDGE·h`; voxel (x, y, z) covers
//! `origin + [x, x+1)·h` (likewise y, z). Its corners are `origin + (x, y, z)·h` for x in
//! 0..=dims\[0\] (likewise y, z): `dims + 1` per axis, linear index `x + (dims[0]+1)·(y + …)`.
//! The nudge keeps corners off the planes (faces of the box, x + y = c) simple meshes have.
//!
//! **Solid.** A point is inside the solid when its winding number is > 0. For each (y, z) row of
//! corners one line is cast along +x with `MeshBvh::crossings` (watertight, so the parity along the
//! line is exact); the winding is accumulated from the crossings' `entering` flags. Inner
//! cavities (winding 0) are outside by construction.

use glam::DVec3;

use super::raycast::MeshBvh;
use crate::scene::mesh::{is_degenerate, Mesh};

/// The grid is moved off the centred position by this many voxels (the fractional parts of √2, √3
/// and √5, times 10⁻³): man-made meshes put faces on planes such as x + y = c that centred voxel
/// centres hit exactly (a 45° face of a unit wedge at 20³ held 1 in 5 of all pairs' ends), which the
/// bake's fast path must leave to the slower exact path. The padding stays ≥ 0.999 voxel.
pub const GRID_NUDGE: DVec3 = DVec3::new(0.000_414_213_562, 0.000_732_050_808, 0.000_236_067_977);

/// Grid resolutions accepted by `voxelize` (a 256³ grid is 17M voxels: ~150 MB of work arrays).
pub const MAX_VOXEL_RES: u32 = 256;

/// Why a mesh could not be voxelized.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum VoxelizeError {
    #[error("voxel resolution {res} is out of range (expected 1..={MAX_VOXEL_RES})")]
    Resolution { res: u32 },
    #[error("mesh is not a closed, consistently oriented surface: {0}")]
    NotClosed(String),
    #[error("mesh is invalid: {0}")]
    Invalid(String),
    #[error("mesh has zero size (bounding box {min:?} to {max:?}); a solid needs a non-zero extent")]
    ZeroSize { min: [f64; 3], max: [f64; 3] },
    #[error("mesh has zero area: every one of its {triangles} triangles is degenerate")]
    ZeroArea { triangles: usize },
    #[error("mesh encloses no volume (signed volume {volume:e}; faces must point outward)")]
    NoVolume { volume: f64 },
    #[error("mesh is too thin to voxelize: its volume {volume:e} is at most 1e-12 of its longest side cubed ({longest:e}³), as flat as rounding; its thickness is far under a voxel (use thickness = \"peel\" or \"tsm\", or a thicker mesh)")]
    TooThin { volume: f64, longest: f64 },
    #[error("no corner of the {dims:?} voxel grid at resolution {res} lies inside the mesh (raise the resolution)")]
    NoSolidVoxel { res: u32, dims: [u32; 3] },
}

/// The grid's placement for a mesh at resolution `res`, without voxelizing: (dims, origin, h).
pub fn grid_layout(mesh: &Mesh, res: u32) -> Result<([u32; 3], DVec3, f64), VoxelizeError> {
    if res == 0 || res > MAX_VOXEL_RES {
        return Err(VoxelizeError::Resolution { res });
    }
    let (lo, hi) = mesh.bounds();
    let extent = hi - lo;
    let longest = extent.max_element();
    let finite = lo.is_finite() && hi.is_finite();
    if !finite || longest.is_nan() || longest <= 0.0 {
        return Err(VoxelizeError::ZeroSize { min: lo.to_array(), max: hi.to_array() });
    }
    let h = longest / res as f64;
    // ceil(extent/h) (at most res, with a guard for rounding just above an integer) + 2 of padding.
    let dims = extent.to_array().map(|e| {
        let cells = (e / h - 1e-9).ceil().max(1.0) as u32;
        cells.min(res) + 2
    });
    let span = DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64) * h;
    let origin = (lo + hi) * 0.5 - span * 0.5 + GRID_NUDGE * h;
    Ok((dims, origin, h))
}

/// Checks what the bake needs of a mesh: structurally valid, closed and oriented, non-zero size
/// and area, positive volume.
pub fn check_solid_mesh(mesh: &Mesh) -> Result<(), VoxelizeError> {
    if mesh.indices.is_empty() {
        return Err(VoxelizeError::Invalid("mesh has no triangles".into()));
    }
    if let Some(i) = mesh.positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(VoxelizeError::Invalid(format!("position {i} is not finite: {:?}", mesh.positions[i])));
    }
    let (lo, hi) = mesh.bounds();
    if (hi - lo).max_element() <= 0.0 {
        return Err(VoxelizeError::ZeroSize { min: lo.to_array(), max: hi.to_array() });
    }
    mesh.check_closed_oriented().map_err(VoxelizeError::NotClosed)?;
    let all_degenerate = (0..mesh.triangle_count()).all(|t| {
        let [a, b, c] = mesh.triangle(t).map(|i| mesh.position(i));
        is_degenerate(a, b, c)
    });
    if all_degenerate {
        return Err(VoxelizeError::ZeroArea { triangles: mesh.triangle_count() });
    }
    let volume = mesh.signed_volume();
    let (lo, hi) = mesh.bounds();
    if volume.is_nan() || volume <= 0.0 {
        return Err(VoxelizeError::NoVolume { volume });
    }
    // Relative to the box: a closed mesh folded flat has volume at rounding level.
    let longest = (hi - lo).max_element();
    if volume <= 1e-12 * longest.powi(3) {
        return Err(VoxelizeError::TooThin { volume, longest });
    }
    Ok(())
}

/// The winding number at every corner of the grid (`dims + 1` per axis, linear index
/// `corner_linear`), row by row (`row_windings`).
pub fn corner_windings(bvh: &MeshBvh, dims: [u32; 3], origin: DVec3, h: f64) -> Vec<i32> {
    let [nx, ny, nz] = dims.map(|d| d + 1);
    let mut winding_at = vec![0i32; nx as usize * ny as usize * nz as usize];
    for (row, out) in winding_at.chunks_exact_mut(nx as usize).enumerate() {
        row_windings(bvh, origin, h, [row as u32 % ny, row as u32 / ny], out);
    }
    winding_at
}

/// The winding numbers of the corners (0..out.len(), y, z): one line along +x through them,
/// accumulating the crossings' `entering` flags.
pub fn row_windings(bvh: &MeshBvh, origin: DVec3, h: f64, [y, z]: [u32; 2], out: &mut [i32]) {
    // The line start + t·(h, 0, 0): corner x is at t = x.
    let start = origin + DVec3::new(0.0, y as f64, z as f64) * h;
    let crossings = bvh.crossings(start, DVec3::new(h, 0.0, 0.0));
    let mut winding = 0i32;
    let mut next = 0;
    for (x, slot) in out.iter_mut().enumerate() {
        while next < crossings.len() && crossings[next].t <= x as f64 {
            winding += if crossings[next].entering { 1 } else { -1 };
            next += 1;
        }
        *slot = winding;
    }
}

/// Linear index of corner (x, y, z) of a grid of `dims` voxels (`dims + 1` corners per axis).
pub(crate) fn corner_linear(dims: [u32; 3], [x, y, z]: [u32; 3]) -> usize {
    let (nx, ny) = (dims[0] as usize + 1, dims[1] as usize + 1);
    x as usize + nx * (y as usize + ny * z as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;

    #[test]
    fn cube_grid_and_corner_windings() {
        let m = procedural::cube(2.0).unwrap();
        let (dims, origin, h) = grid_layout(&m, 10).unwrap();
        assert_eq!(dims, [12, 12, 12]);
        assert!((h - 0.2).abs() < 1e-15);
        assert!((origin - DVec3::splat(-1.2) - GRID_NUDGE * 0.2).length() < 1e-12);
        let w = corner_windings(&MeshBvh::new(&m).unwrap(), dims, origin, h);
        assert_eq!(w.len(), 13 * 13 * 13);
        // Corners 1..=11 along each axis lie in [-1, 1] (the nudge is tiny and positive): 11³
        // inside minus those of the upper face at index 11 (x = 1.0 + nudge, outside).
        let inside = w.iter().filter(|&&v| v > 0).count();
        assert_eq!(inside, 10 * 10 * 10);
        assert!(w[corner_linear(dims, [6, 6, 6])] == 1 && w[corner_linear(dims, [0, 6, 6])] == 0);
    }

    #[test]
    fn a_sealed_cavity_has_winding_zero() {
        let m = procedural::cavity_cube(2.0, 0.6, 32, 16).unwrap();
        let (dims, origin, h) = grid_layout(&m, 24).unwrap();
        let w = corner_windings(&MeshBvh::new(&m).unwrap(), dims, origin, h);
        let at = |p: DVec3| {
            let g = ((p - origin) / h).round();
            w[corner_linear(dims, [g.x as u32, g.y as u32, g.z as u32])]
        };
        assert_eq!(at(DVec3::ZERO), 0);
        assert_eq!(at(DVec3::new(0.8, 0.0, 0.0)), 1);
        assert_eq!(at(DVec3::new(1.05, 0.0, 0.0)), 0);
    }

    #[test]
    fn bad_meshes_are_refused() {
        let cube = procedural::cube(1.0).unwrap();
        assert_eq!(grid_layout(&cube, 0).unwrap_err(), VoxelizeError::Resolution { res: 0 });
        assert!(matches!(grid_layout(&cube, MAX_VOXEL_RES + 1), Err(VoxelizeError::Resolution { .. })));
        let mut open = cube.clone();
        open.indices.truncate(33);
        assert!(matches!(check_solid_mesh(&open), Err(VoxelizeError::NotClosed(_))));
        let mut flipped = cube.clone();
        for t in flipped.indices.chunks_exact_mut(3) {
            t.swap(1, 2);
        }
        assert!(matches!(check_solid_mesh(&flipped), Err(VoxelizeError::NoVolume { .. })));
        let mut point = cube.clone();
        point.positions.iter_mut().for_each(|p| *p = [0.0; 3]);
        assert!(matches!(check_solid_mesh(&point), Err(VoxelizeError::ZeroSize { .. })));
    }
}
