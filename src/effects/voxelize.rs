//! Solid voxelization of a closed mesh and its numbered surface voxels (seed 003, §3.1–3.2): the
//! discretization the thickness LUT is indexed by.
//!
//! **Grid.** At resolution N the voxel edge is h = (longest extent of the mesh's bounding box) / N.
//! Along each axis the grid has `dims[a] = ceil(extent[a] / h) + 2` voxels (one voxel of padding on
//! each side, at least), centred on the bounding box and nudged by a thousandth of a voxel
//! (`GRID_NUDGE`): `origin = centre − dims·h/2 + GRID_NUDGE·h`; voxel (x, y, z) covers
//! `origin + [x, x+1)·h` (likewise y, z) with its centre at `origin + (x+½)·h`. Faces of the
//! bounding box therefore fall near voxel boundaries, never on voxel centres, and the nudge keeps
//! centres off the diagonal planes simple meshes have.
//!
//! **Solid.** A voxel is solid when its centre is inside the solid (winding number > 0). For each
//! (y, z) row one line through the row's centres is cast along +x with `MeshBvh::crossings`
//! (watertight, so the parity along the line is exact); the winding is accumulated from the
//! crossings' `entering` flags. Inner cavities are outside by construction.
//!
//! **Surface voxels.** The exterior is the set of empty voxels reachable from the grid's boundary by
//! a 6-connected flood fill through empty voxels (the padding guarantees the boundary is empty).
//! A surface voxel is a solid voxel with at least one of its 6 neighbours in the exterior: the
//! walls of a sealed cavity are not surface (light never enters there), the inside of an open
//! bottle is (its air is reached through the neck). Surface voxels are numbered in increasing
//! linear index `x + dims[0]·(y + dims[1]·z)` (x fastest, then y, then z).
//!
//! **Lookups.** `id_grid[v]` is the surface id of voxel v (`u32::MAX` if v is not a surface voxel);
//! `nearest_grid[v]` is, for every voxel v, the surface voxel whose centre is nearest to v's centre
//! (computed by a 26-neighbour Dijkstra propagation of nearest seeds, ties to the lower id; exact
//! except in rare configurations where a voxel's true nearest seed reaches none of its neighbours,
//! then it is the nearest of its neighbours' seeds). `vertex_voxel[k]` is the surface voxel whose
//! centre is nearest to mesh vertex k (exact search, ties to the lower id).

use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

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
    #[error("no voxel centre of the {dims:?} grid at resolution {res} lies inside the mesh (raise the resolution)")]
    NoSolidVoxel { res: u32, dims: [u32; 3] },
}

/// The voxelized solid and its surface voxels; see the module documentation for the conventions.
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelGrid {
    /// The requested resolution N (voxels along the longest extent of the bounding box).
    pub res: u32,
    /// Voxels along x, y, z (padding included).
    pub dims: [u32; 3],
    /// Minimum corner of voxel (0, 0, 0), object space.
    pub origin: DVec3,
    /// Voxel edge h, object units.
    pub voxel_size: f64,
    /// Solid flag per voxel, linear index `x + dims[0]·(y + dims[1]·z)`.
    pub solid: Vec<bool>,
    /// Surface voxels' grid coordinates, in id order.
    pub surface_voxels: Vec<[u32; 3]>,
    /// Surface id per voxel, `u32::MAX` for every other voxel.
    pub id_grid: Vec<u32>,
    /// Nearest surface voxel (by centre distance) per voxel.
    pub nearest_grid: Vec<u32>,
    /// Nearest surface voxel per mesh vertex.
    pub vertex_voxel: Vec<u32>,
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
    // Relative to the box: a closed mesh folded flat has volume at rounding level.
    if volume.is_nan() || volume <= 1e-12 * (hi - lo).max_element().powi(3) {
        return Err(VoxelizeError::NoVolume { volume });
    }
    Ok(())
}

impl VoxelGrid {
    pub fn voxel_count(&self) -> usize {
        self.solid.len()
    }

    /// Linear index of voxel (x, y, z).
    pub fn linear(&self, [x, y, z]: [u32; 3]) -> usize {
        linear(self.dims, [x, y, z])
    }

    /// Centre of voxel (x, y, z), object space.
    pub fn centre(&self, v: [u32; 3]) -> DVec3 {
        voxel_centre(self.origin, self.voxel_size, v)
    }

    /// Centre of surface voxel `id`.
    pub fn surface_centre(&self, id: u32) -> DVec3 {
        self.centre(self.surface_voxels[id as usize])
    }

    /// The voxel containing object point `p`, clamped to the grid (`floor((p − origin)/h)`).
    pub fn voxel_of(&self, p: DVec3) -> [u32; 3] {
        voxel_of(self.dims, self.origin, self.voxel_size, p)
    }

    /// The GPU's lookup: `nearest_grid` at the (clamped) voxel containing `p`.
    pub fn surface_voxel_at(&self, p: DVec3) -> Option<u32> {
        if !p.is_finite() {
            return None;
        }
        let id = self.nearest_grid[self.linear(self.voxel_of(p))];
        (id != u32::MAX).then_some(id)
    }

    /// The surface voxel whose centre is nearest to `p` (exact; ties to the lower id).
    pub fn nearest_surface_voxel(&self, p: DVec3) -> Option<u32> {
        Lookup {
            dims: self.dims,
            origin: self.origin,
            h: self.voxel_size,
            surface_voxels: &self.surface_voxels,
            id_grid: &self.id_grid,
            nearest_grid: &self.nearest_grid,
        }
        .nearest_exact(p)
    }
}

/// Voxelizes `mesh` at resolution `res`: solid voxels, surface voxels and the lookups.
pub fn voxelize(mesh: &Mesh, bvh: &MeshBvh, res: u32) -> Result<VoxelGrid, VoxelizeError> {
    voxelize_with_winding(mesh, bvh, res).map(|(grid, _)| grid)
}

/// `voxelize` plus the winding number at every voxel centre (linear index), from the row casts.
pub fn voxelize_with_winding(
    mesh: &Mesh,
    bvh: &MeshBvh,
    res: u32,
) -> Result<(VoxelGrid, Vec<i32>), VoxelizeError> {
    check_solid_mesh(mesh)?;
    let (dims, origin, h) = grid_layout(mesh, res)?;
    let winding = windings(bvh, dims, origin, h);
    let solid: Vec<bool> = winding.iter().map(|&w| w > 0).collect();
    if !solid.iter().any(|&s| s) {
        return Err(VoxelizeError::NoSolidVoxel { res, dims });
    }
    let exterior = exterior(&solid, dims);
    let (surface_voxels, id_grid) = surface(&solid, &exterior, dims);
    if surface_voxels.is_empty() {
        // Unreachable with a padded grid (a solid voxel's neighbours lead to the empty boundary),
        // but a wrong table is worse than an error.
        return Err(VoxelizeError::NoSolidVoxel { res, dims });
    }
    let nearest_grid = nearest_seeds(&surface_voxels, dims);
    let mut grid = VoxelGrid {
        res,
        dims,
        origin,
        voxel_size: h,
        solid,
        surface_voxels,
        id_grid,
        nearest_grid,
        vertex_voxel: Vec::new(),
    };
    grid.vertex_voxel = (0..mesh.positions.len())
        .map(|i| grid.nearest_surface_voxel(mesh.position(i)).unwrap_or(u32::MAX))
        .collect();
    Ok((grid, winding))
}

pub(crate) fn linear(dims: [u32; 3], [x, y, z]: [u32; 3]) -> usize {
    x as usize + dims[0] as usize * (y as usize + dims[1] as usize * z as usize)
}

pub(crate) fn voxel_centre(origin: DVec3, h: f64, [x, y, z]: [u32; 3]) -> DVec3 {
    origin + (DVec3::new(x as f64, y as f64, z as f64) + 0.5) * h
}

pub(crate) fn voxel_of(dims: [u32; 3], origin: DVec3, h: f64, p: DVec3) -> [u32; 3] {
    let g = (p - origin) / h;
    [0, 1, 2].map(|a| {
        let v = g[a].floor();
        // NaN and negatives go to 0 (`as` saturates), the far side to the last voxel.
        (v.max(0.0) as u32).min(dims[a] - 1)
    })
}

/// The winding number at every voxel centre: one line per (y, z) row along +x through the
/// centres, accumulating the crossings' `entering` flags.
fn windings(bvh: &MeshBvh, dims: [u32; 3], origin: DVec3, h: f64) -> Vec<i32> {
    let [nx, ny, nz] = dims;
    let mut winding_at = vec![0i32; nx as usize * ny as usize * nz as usize];
    for z in 0..nz {
        for y in 0..ny {
            // The line origin + t·(h, 0, 0): voxel x's centre is at t = x + ½.
            let start = voxel_centre(origin, h, [0, y, z]) - DVec3::new(0.5 * h, 0.0, 0.0);
            let crossings = bvh.crossings(start, DVec3::new(h, 0.0, 0.0));
            let mut winding = 0i32;
            let mut next = 0;
            for x in 0..nx {
                let t = x as f64 + 0.5;
                while next < crossings.len() && crossings[next].t <= t {
                    winding += if crossings[next].entering { 1 } else { -1 };
                    next += 1;
                }
                winding_at[linear(dims, [x, y, z])] = winding;
            }
        }
    }
    winding_at
}

const NEIGHBOURS6: [[i32; 3]; 6] = [[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1]];

fn step(dims: [u32; 3], v: [u32; 3], d: [i32; 3]) -> Option<[u32; 3]> {
    let mut out = [0u32; 3];
    for a in 0..3 {
        let c = v[a] as i64 + d[a] as i64;
        if c < 0 || c >= dims[a] as i64 {
            return None;
        }
        out[a] = c as u32;
    }
    Some(out)
}

/// Empty voxels reachable from the grid boundary through 6-connected empty voxels.
fn exterior(solid: &[bool], dims: [u32; 3]) -> Vec<bool> {
    let mut ext = vec![false; solid.len()];
    let mut queue = VecDeque::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let v = [x, y, z];
                let boundary = (0..3).any(|a| v[a] == 0 || v[a] == dims[a] - 1);
                let i = linear(dims, v);
                if boundary && !solid[i] && !ext[i] {
                    ext[i] = true;
                    queue.push_back(v);
                }
            }
        }
    }
    while let Some(v) = queue.pop_front() {
        for d in NEIGHBOURS6 {
            if let Some(n) = step(dims, v, d) {
                let i = linear(dims, n);
                if !solid[i] && !ext[i] {
                    ext[i] = true;
                    queue.push_back(n);
                }
            }
        }
    }
    ext
}

/// Solid voxels with an exterior 6-neighbour, in linear order, and the id per voxel.
fn surface(solid: &[bool], exterior: &[bool], dims: [u32; 3]) -> (Vec<[u32; 3]>, Vec<u32>) {
    let mut voxels = Vec::new();
    let mut ids = vec![u32::MAX; solid.len()];
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let v = [x, y, z];
                let i = linear(dims, v);
                let touches = |d| step(dims, v, d).is_some_and(|n| exterior[linear(dims, n)]);
                if solid[i] && NEIGHBOURS6.into_iter().any(touches) {
                    ids[i] = voxels.len() as u32;
                    voxels.push(v);
                }
            }
        }
    }
    (voxels, ids)
}

fn dist2(a: [u32; 3], b: [u32; 3]) -> u64 {
    (0..3).map(|k| (a[k] as i64 - b[k] as i64).pow(2) as u64).sum()
}

/// Nearest surface voxel per voxel: Dijkstra from all surface voxels over 26-neighbours, keyed by
/// (squared centre distance to the propagated seed, seed id), so ties go to the lower id.
fn nearest_seeds(seeds: &[[u32; 3]], dims: [u32; 3]) -> Vec<u32> {
    let count = dims.iter().map(|&d| d as usize).product();
    let mut best: Vec<(u64, u32)> = vec![(u64::MAX, u32::MAX); count];
    let mut heap = BinaryHeap::with_capacity(seeds.len() * 4);
    for (id, &v) in seeds.iter().enumerate() {
        best[linear(dims, v)] = (0, id as u32);
        heap.push(Reverse((0u64, id as u32, v)));
    }
    while let Some(Reverse((d, id, v))) = heap.pop() {
        if best[linear(dims, v)] != (d, id) {
            continue;
        }
        let seed = seeds[id as usize];
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let Some(n) = step(dims, v, [dx, dy, dz]) else { continue };
                    let key = (dist2(n, seed), id);
                    let slot = &mut best[linear(dims, n)];
                    if key < *slot {
                        *slot = key;
                        heap.push(Reverse((key.0, id, n)));
                    }
                }
            }
        }
    }
    best.into_iter().map(|(_, id)| id).collect()
}

/// The grid data a nearest-voxel search needs (shared by `VoxelGrid` and `ThicknessLut`).
pub(crate) struct Lookup<'a> {
    pub dims: [u32; 3],
    pub origin: DVec3,
    pub h: f64,
    pub surface_voxels: &'a [[u32; 3]],
    pub id_grid: &'a [u32],
    pub nearest_grid: &'a [u32],
}

impl Lookup<'_> {
    /// Exact nearest surface voxel centre to `p` (ties to the lower id): `nearest_grid`'s answer
    /// bounds the search radius, then every surface voxel whose centre can be closer is checked.
    pub fn nearest_exact(&self, p: DVec3) -> Option<u32> {
        if !p.is_finite() || self.surface_voxels.is_empty() {
            return None;
        }
        let centre = |id: u32| voxel_centre(self.origin, self.h, self.surface_voxels[id as usize]);
        let guess = self.nearest_grid[linear(self.dims, voxel_of(self.dims, self.origin, self.h, p))];
        let mut best = (centre(guess).distance_squared(p), guess);
        let r = best.0.sqrt() + self.h;
        let lo = voxel_of(self.dims, self.origin, self.h, p - DVec3::splat(r));
        let hi = voxel_of(self.dims, self.origin, self.h, p + DVec3::splat(r));
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let id = self.id_grid[linear(self.dims, [x, y, z])];
                    if id == u32::MAX {
                        continue;
                    }
                    let d = centre(id).distance_squared(p);
                    if d < best.0 || (d == best.0 && id < best.1) {
                        best = (d, id);
                    }
                }
            }
        }
        Some(best.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;

    fn grid(mesh: &Mesh, res: u32) -> VoxelGrid {
        voxelize(mesh, &MeshBvh::new(mesh).unwrap(), res).unwrap()
    }

    #[test]
    fn cube_is_all_solid_and_its_shell_is_the_surface() {
        let m = procedural::cube(2.0).unwrap();
        let g = grid(&m, 10);
        assert_eq!(g.dims, [12, 12, 12]);
        assert!((g.voxel_size - 0.2).abs() < 1e-15);
        assert!((g.origin - DVec3::splat(-1.2) - GRID_NUDGE * 0.2).length() < 1e-12);
        let solid = g.solid.iter().filter(|&&s| s).count();
        assert_eq!(solid, 1000);
        // The 10³ block minus its 8³ interior.
        assert_eq!(g.surface_voxels.len(), 1000 - 512);
        // Numbered in linear order: first (1,1,1), last (10,10,10).
        assert_eq!(g.surface_voxels[0], [1, 1, 1]);
        assert_eq!(*g.surface_voxels.last().unwrap(), [10, 10, 10]);
        assert!(g.surface_voxels.windows(2).all(|w| g.linear(w[0]) < g.linear(w[1])));
        for (id, &v) in g.surface_voxels.iter().enumerate() {
            assert_eq!(g.id_grid[g.linear(v)], id as u32);
            assert_eq!(g.nearest_grid[g.linear(v)], id as u32);
        }
        // Corner vertices belong to the corner voxels.
        let corner = g.vertex_voxel[m.positions.iter().position(|p| *p == [1.0, 1.0, 1.0]).unwrap()];
        assert_eq!(g.surface_voxels[corner as usize], [10, 10, 10]);
    }

    #[test]
    fn sealed_cavity_walls_are_not_surface() {
        let m = procedural::cavity_cube(2.0, 0.6, 32, 16).unwrap();
        let g = grid(&m, 25);
        let h = g.voxel_size;
        // The centre voxel is empty (in the cavity), but not exterior: no solid voxel next to the
        // cavity is numbered, so every surface voxel lies in the outer shell of the cube.
        let c = g.voxel_of(DVec3::ZERO);
        assert!(!g.solid[g.linear(c)]);
        for &v in &g.surface_voxels {
            let p = g.centre(v);
            assert!(p.abs().max_element() > 1.0 - h, "{v:?} at {p} is not in the outer shell");
        }
        let shell = g.surface_voxels.len();
        let cube = grid(&procedural::cube(2.0).unwrap(), 25);
        assert_eq!(shell, cube.surface_voxels.len());
    }

    #[test]
    fn open_bottle_inside_is_surface() {
        let m = procedural::bottle(0.5, 1.6, 0.05, 0.5, 32).unwrap();
        let g = grid(&m, 40);
        // A voxel on the inner glass wall above the liquid faces the air inside the bottle, which is
        // reached through the neck: it is a surface voxel.
        let inner = g.voxel_of(DVec3::new(0.5 - 0.05 - 0.5 * g.voxel_size, 0.2, 0.0));
        let found = (0..3).any(|dx| {
            let v = [inner[0] - 1 + dx, inner[1], inner[2]];
            g.id_grid[g.linear(v)] != u32::MAX && g.centre(v).x < 0.5 - g.voxel_size
        });
        assert!(found, "no surface voxel on the inner wall near {inner:?}");
    }

    #[test]
    fn nearest_grid_matches_brute_force() {
        let m = procedural::torus(1.0, 0.35, 24, 12).unwrap();
        let g = grid(&m, 16);
        let mut wrong = 0;
        for z in 0..g.dims[2] {
            for y in 0..g.dims[1] {
                for x in 0..g.dims[0] {
                    let v = [x, y, z];
                    let got = g.nearest_grid[g.linear(v)];
                    let want = (0..g.surface_voxels.len() as u32)
                        .min_by_key(|&id| (dist2(v, g.surface_voxels[id as usize]), id))
                        .unwrap();
                    let (dg, dw) =
                        (dist2(v, g.surface_voxels[got as usize]), dist2(v, g.surface_voxels[want as usize]));
                    if dg != dw {
                        wrong += 1;
                        // Never more than a little off.
                        assert!((dg as f64).sqrt() - (dw as f64).sqrt() < 0.5, "{v:?}: {dg} vs {dw}");
                    }
                }
            }
        }
        let total = g.voxel_count();
        assert!(wrong * 1000 <= total, "{wrong} of {total} voxels have a non-nearest seed");
        // Vertex lookups are exact.
        for (k, &id) in g.vertex_voxel.iter().enumerate() {
            let p = m.position(k);
            let want = (0..g.surface_voxels.len() as u32)
                .min_by(|&a, &b| {
                    let (da, db) =
                        (g.surface_centre(a).distance_squared(p), g.surface_centre(b).distance_squared(p));
                    da.total_cmp(&db).then(a.cmp(&b))
                })
                .unwrap();
            assert_eq!(id, want, "vertex {k}");
        }
    }

    #[test]
    fn lookup_clamps_and_refuses_non_finite() {
        let g = grid(&procedural::cube(1.0).unwrap(), 4);
        assert!(g.surface_voxel_at(DVec3::splat(100.0)).is_some());
        assert!(g.surface_voxel_at(DVec3::splat(f64::NAN)).is_none());
        assert_eq!(g.voxel_of(DVec3::splat(-100.0)), [0, 0, 0]);
    }

    #[test]
    fn bad_meshes_are_refused() {
        let cube = procedural::cube(1.0).unwrap();
        let bvh = MeshBvh::new(&cube).unwrap();
        assert_eq!(voxelize(&cube, &bvh, 0).unwrap_err(), VoxelizeError::Resolution { res: 0 });
        assert!(matches!(voxelize(&cube, &bvh, MAX_VOXEL_RES + 1), Err(VoxelizeError::Resolution { .. })));
        let mut open = cube.clone();
        open.indices.truncate(33);
        assert!(matches!(voxelize(&open, &bvh, 8), Err(VoxelizeError::NotClosed(_))));
        let mut flipped = cube.clone();
        for t in flipped.indices.chunks_exact_mut(3) {
            t.swap(1, 2);
        }
        assert!(matches!(voxelize(&flipped, &bvh, 8), Err(VoxelizeError::NoVolume { .. })));
        let mut point = cube.clone();
        point.positions.iter_mut().for_each(|p| *p = [0.0; 3]);
        assert!(matches!(voxelize(&point, &bvh, 8), Err(VoxelizeError::ZeroSize { .. })));
    }
}
