//! The thickness LUT (seed 003, §3.2: the object's 3D shape stored in a table): a 3D field of the
//! solid, baked once per (mesh, voxel_res) in f64, decoded along the actual light path by the
//! `translucency` pass (and by its f64 twin, `march`).
//!
//! # What is stored
//!
//! The mesh's signed distance φ at the corners of its voxel grid (`effects::voxelize`: edge h,
//! `dims + 1` corners per axis): negative inside the solid (winding number > 0, the row casts of
//! `voxelize::row_windings`), positive outside — sealed cavities and the air in a bottle are
//! outside. |φ| is the exact distance to the triangles in f64 (`MeshBvh::distance_within`),
//! clamped to ±`CLAMP_VOXELS`·h: only the sign matters farther away. Quantized as 8-bit SNORM:
//! q = round(φ / (C·h) · 127), so a stored value is within `QUANTIZATION_BOUND_VOXELS`·h =
//! ½·C·h/127 ≈ 0.016·h of φ. Why 8 bits and not 16, by measurement (20 000 random chords per row,
//! `report::lut_paths`, the same bake quantized both ways; p95 / p99 of |Δd| in voxels):
//!
//! | mesh, res | R16 | R8 |
//! |---|---|---|
//! | bottle 32 | 2.490 / 5.011 | 2.500 / 5.019 |
//! | bottle 56 | 0.233 / 1.515 | 0.231 / 1.534 |
//! | hollow ball 32 | 0.183 / 0.448 | 0.180 / 0.444 |
//! | hollow ball 56 | 0.099 / 0.236 | 0.101 / 0.244 |
//! | cavity cube 32 | 0.075 / 0.164 | 0.076 / 0.173 |
//! | cavity cube 56 | 0.042 / 0.098 | 0.045 / 0.104 |
//!
//! The reconstruction error (up to √3/2·h, `march`) dwarfs 0.016·h, and 8 bits halve the bytes:
//! the three seed objects at 56³ take 0.5 MB together (the bottle 70 KB: 25·59·25 corners plus a
//! τ byte per cell), against 185 MB for the pair table they replaced.
//!
//! # How it is read (the shader and `march` do the same)
//!
//! φ̃(p) is the trilinear interpolation of the 8 corners around p (grid coordinates clamped to the
//! grid). On the segment a → b (object space; a the light's entry, b the shaded point) the inside
//! fraction is 1 − (the fraction of the segment in *gaps*): a gap is a run of φ̃ > 0 between two
//! sign changes (or an end of the segment), unless its largest sample is ≤ τ (`tau`, per cell) and
//! it is joined to an end of the segment by samples with |φ̃| ≤ τ (end noise; see `march`).
//! The world thickness is that fraction times |M(b − a)|: an affine map scales every part of a
//! segment by the same factor, so this is exact for any instance transform. See `march` for the
//! sampling, the error bound and why τ.
//!
//! τ is measured by the bake, per cell: twice the largest |φ̃| on the mesh surface (where φ = 0;
//! sampled on a lattice of at most h/4 over every triangle, corners included) in the cell and its
//! 26 neighbours, plus `GAP_MARGIN_VOXELS`·h; stored as a byte in steps of h/64 (`TAU_STEPS`),
//! rounded up, at most 63/64·h (`TAU_MAX_STEPS`; where the reconstruction is worse than half a
//! voxel, a convex end can then show a sliver of gap). The path's ends are surface points whose
//! φ̃ is anything in ±(that error): without τ, a sliver of "gap" at an end, long for a grazing
//! path, would be cut out of a convex solid; the factor 2 is the convexity argument of `march`.
//! Why per cell: one global τ is set by the mesh's worst place — the bottle's 0.03-voxel gap
//! between liquid and glass, which no grid resolves, makes it a whole voxel — and a low run in a
//! τ zone is dropped, so a global τ of a voxel drops the bottle's air wherever the air is thinner
//! than a voxel deep along the path (measured: the bottle's p95 on the GPU, 3.85 → 0.30 voxels).
//!
//! # Speed
//!
//! z-slices of corners are handed to `std::thread::scope` workers one at a time: each casts its
//! rows for the winding and asks the BVH for the distance of every corner within C·h of the
//! surface (pruned by box distance, so far corners cost a box test). Progress is reported per
//! slice.

mod march;

pub use march::{FIELD_LIPSCHITZ, MAX_MARCH_STEPS, MAX_STEP_VOXELS, RECONSTRUCTION_BOUND_VOXELS};

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use glam::DVec3;

use super::raycast::MeshBvh;
use super::voxelize::{check_solid_mesh, corner_linear, grid_layout, row_windings, VoxelizeError};
use crate::scene::mesh::{Mesh, MeshError};

/// |φ| is clamped to this many voxel edges (C). It must exceed the error band of `march` (about
/// 1.8 voxels) so every corner that can change a decoded crossing holds its true distance, and
/// the larger it is, the longer the steps `march` can take far from the surface.
pub const CLAMP_VOXELS: f64 = 4.0;
/// Quantization levels of a stored value (8-bit SNORM).
pub const FIELD_LEVELS: f64 = 127.0;
/// |stored − exact| ≤ this many voxel edges.
pub const QUANTIZATION_BOUND_VOXELS: f64 = 0.5 * CLAMP_VOXELS / FIELD_LEVELS;
/// Added to the measured surface error for τ: the error between the lattice points.
pub const GAP_MARGIN_VOXELS: f64 = 0.05;
/// τ is stored in steps of h / `TAU_STEPS`, at most `TAU_MAX_STEPS` of them: τ < h = L·(½ h),
/// so `march`'s long steps start only from samples above τ (its error bound needs that).
pub const TAU_STEPS: f64 = 64.0;
pub const TAU_MAX_STEPS: u8 = 63;
/// Lattice spacing of the surface samples τ is measured on, in voxel edges.
pub const SURFACE_SAMPLE_VOXELS: f64 = 0.25;
/// Format name of the stored field, for logs and docs.
pub const FIELD_FORMAT: &str = "R8_SNORM (four per 32-bit texel of a uniform texel buffer)";

/// What the bake can fail with. Each message names the limit involved.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BakeError {
    #[error(transparent)]
    Voxelize(#[from] VoxelizeError),
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

/// How to bake.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BakeOptions {
    /// Worker threads; 0 = `std::thread::available_parallelism`.
    pub threads: usize,
}

/// What a bake did (not stored, not compared).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BakeStats {
    /// Grid corners, and those within the clamp range of the surface (a distance was computed).
    pub corners: u64,
    pub near_corners: u64,
    pub threads: usize,
    /// Windings and distances, then the surface measure of τ.
    pub field_seconds: f64,
    pub threshold_seconds: f64,
}

/// A baked field with what the GPU and the CPU twin need to read it.
#[derive(Clone, Debug, PartialEq)]
pub struct ThicknessLut {
    /// Voxel resolution N (voxels along the longest side of the mesh's box).
    pub res: u32,
    /// Grid voxels along x, y, z (one voxel of padding, at least, on each side); corners are
    /// `dims + 1` per axis.
    pub dims: [u32; 3],
    /// Object-space position of corner (0, 0, 0).
    pub origin: DVec3,
    /// Voxel edge h, object units.
    pub voxel_size: f64,
    /// q per corner, x fastest (`voxelize::corner_linear`): φ ≈ q / 127 · C·h.
    pub field: Vec<i8>,
    /// τ per cell in steps of h/64, x fastest (see the module documentation).
    pub tau: Vec<u8>,
}

impl ThicknessLut {
    /// Corners per axis.
    pub fn corner_dims(&self) -> [u32; 3] {
        self.dims.map(|d| d + 1)
    }

    /// Bytes of the stored field and τ (1 a corner, 1 a cell).
    pub fn bytes(&self) -> usize {
        self.field.len() + self.tau.len()
    }

    /// τ of the cell holding object point `p` (clamped to the grid, NaN to 0), object units.
    pub fn tau_at(&self, p: DVec3) -> f64 {
        let g = (p - self.origin) / self.voxel_size;
        let c =
            [0, 1, 2].map(|a| if g[a].is_nan() { 0 } else { (g[a].max(0.0) as u32).min(self.dims[a] - 1) });
        let k =
            c[0] as usize + self.dims[0] as usize * (c[1] as usize + self.dims[1] as usize * c[2] as usize);
        self.tau[k] as f64 * self.voxel_size / TAU_STEPS
    }

    /// The largest τ over the grid, object units (the error bound's).
    pub fn gap_threshold(&self) -> f64 {
        self.tau.iter().copied().max().unwrap_or(0) as f64 * self.voxel_size / TAU_STEPS
    }

    /// The field's value per unit of q, object units: C·h / 127.
    pub fn scale(&self) -> f64 {
        CLAMP_VOXELS * self.voxel_size / FIELD_LEVELS
    }

    /// The stored field at a corner, object units.
    pub fn corner(&self, [x, y, z]: [u32; 3]) -> f64 {
        self.field[corner_linear(self.dims, [x, y, z])] as f64 * self.scale()
    }

    /// The field and τ as the GPU reads them: four corners a 32-bit word (corner k in byte k mod 4,
    /// the lowest first), then four cells' τ a word likewise.
    pub fn words(&self) -> Vec<u32> {
        let word = |c: &[u8]| c.iter().enumerate().fold(0u32, |w, (k, &b)| w | (b as u32) << (8 * k));
        let field: Vec<u8> = self.field.iter().map(|&q| q as u8).collect();
        field.chunks(4).map(word).chain(self.tau.chunks(4).map(word)).collect()
    }
}

fn quantize(phi: f64, clamp: f64) -> i8 {
    ((phi / clamp).clamp(-1.0, 1.0) * FIELD_LEVELS).round() as i8
}

fn thread_count(requested: usize) -> usize {
    if requested > 0 {
        return requested;
    }
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Bakes the field of `mesh` at `res`. `progress(done, total)` is called (from any worker thread)
/// after each z-slice of corners and once more at the end with done = total.
pub fn bake(
    mesh: &Mesh,
    res: u32,
    options: &BakeOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(ThicknessLut, BakeStats), BakeError> {
    let start = Instant::now();
    check_solid_mesh(mesh)?;
    let (dims, origin, h) = grid_layout(mesh, res)?;
    let bvh = MeshBvh::new(mesh)?;
    let [nx, ny, nz] = dims.map(|d| d as usize + 1);
    let slice = nx * ny;
    let mut field = vec![0i8; slice * nz];
    let clamp = CLAMP_VOXELS * h;
    let threads = thread_count(options.threads).min(nz);
    let near = AtomicUsize::new(0);
    let inside = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let total = nz + 1;
    {
        let queue = Mutex::new(field.chunks_mut(slice).enumerate());
        let (queue, near, inside, done, bvh) = (&queue, &near, &inside, &done, &bvh);
        std::thread::scope(|scope| {
            for _ in 0..threads {
                scope.spawn(move || {
                    let mut winding = vec![0i32; nx];
                    loop {
                        let next = queue.lock().map(|mut q| q.next()).unwrap_or(None);
                        let Some((z, out)) = next else { break };
                        let (mut local_near, mut local_inside) = (0, 0);
                        for (y, row) in out.chunks_mut(nx).enumerate() {
                            row_windings(bvh, origin, h, [y as u32, z as u32], &mut winding);
                            for (x, slot) in row.iter_mut().enumerate() {
                                let p = origin + DVec3::new(x as f64, y as f64, z as f64) * h;
                                let sign = if winding[x] > 0 { -1.0 } else { 1.0 };
                                local_inside += usize::from(winding[x] > 0);
                                let distance = bvh.distance_within(p, clamp).inspect(|_| local_near += 1);
                                *slot = quantize(sign * distance.unwrap_or(clamp), clamp);
                            }
                        }
                        near.fetch_add(local_near, Ordering::Relaxed);
                        inside.fetch_add(local_inside, Ordering::Relaxed);
                        progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
                    }
                });
            }
        });
    }
    if inside.load(Ordering::Relaxed) == 0 {
        return Err(VoxelizeError::NoSolidVoxel { res, dims }.into());
    }
    let field_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let mut lut = ThicknessLut { res, dims, origin, voxel_size: h, field, tau: Vec::new() };
    lut.tau = tau_cells(&lut, &surface_error(&lut, &bvh, threads));
    progress(total, total);
    let stats = BakeStats {
        corners: lut.field.len() as u64,
        near_corners: near.into_inner() as u64,
        threads,
        field_seconds,
        threshold_seconds: start.elapsed().as_secs_f64(),
    };
    Ok((lut, stats))
}

/// The largest |φ̃| on the mesh surface per cell (0 where no surface passes): at the points of a
/// lattice of spacing at most `SURFACE_SAMPLE_VOXELS`·h over every triangle (its corners
/// included), each counted in the cell holding it.
fn surface_error(lut: &ThicknessLut, bvh: &MeshBvh, threads: usize) -> Vec<f64> {
    let spacing = SURFACE_SAMPLE_VOXELS * lut.voxel_size;
    let cells: usize = lut.dims.iter().map(|&d| d as usize).product();
    let triangles = bvh.triangle_count();
    let next = AtomicUsize::new(0);
    let worst = Mutex::new(vec![0.0f64; cells]);
    let cell_of = |p: DVec3| {
        let g = (p - lut.origin) / lut.voxel_size;
        let c = [0, 1, 2].map(|a| (g[a].max(0.0) as usize).min(lut.dims[a] as usize - 1));
        c[0] + lut.dims[0] as usize * (c[1] + lut.dims[1] as usize * c[2])
    };
    std::thread::scope(|scope| {
        for _ in 0..threads.max(1) {
            scope.spawn(|| {
                let mut local = vec![0.0f64; cells];
                loop {
                    let first = next.fetch_add(256, Ordering::Relaxed);
                    if first >= triangles {
                        break;
                    }
                    for t in first..(first + 256).min(triangles) {
                        let [a, b, c] = bvh.triangle_corners(t);
                        let longest = (b - a).length().max((c - a).length()).max((c - b).length());
                        let n = ((longest / spacing).ceil() as usize).clamp(1, 1 << 14);
                        for i in 0..=n {
                            for j in 0..=n - i {
                                let p = a + (b - a) * (i as f64 / n as f64) + (c - a) * (j as f64 / n as f64);
                                let k = cell_of(p);
                                local[k] = local[k].max(lut.field_at(p).abs());
                            }
                        }
                    }
                }
                if let Ok(mut w) = worst.lock() {
                    w.iter_mut().zip(&local).for_each(|(w, l)| *w = w.max(*l));
                }
            });
        }
    });
    worst.into_inner().unwrap_or_default()
}

/// τ per cell as stored: 2·(the largest surface error over the cell and its 26 neighbours) +
/// the margin, in steps of h/64 rounded up (at most `TAU_MAX_STEPS`).
fn tau_cells(lut: &ThicknessLut, error: &[f64]) -> Vec<u8> {
    let [nx, ny, nz] = lut.dims.map(|d| d as i64);
    let h = lut.voxel_size;
    let mut tau = vec![0u8; error.len()];
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let mut e: f64 = 0.0;
                for (dx, dy, dz) in
                    (-1..=1).flat_map(|a| (-1..=1).flat_map(move |b| (-1..=1).map(move |c| (a, b, c))))
                {
                    let (i, j, k) = (x + dx, y + dy, z + dz);
                    if (0..nx).contains(&i) && (0..ny).contains(&j) && (0..nz).contains(&k) {
                        e = e.max(error[(i + nx * (j + ny * k)) as usize]);
                    }
                }
                let steps = ((2.0 * e + GAP_MARGIN_VOXELS * h) / h * TAU_STEPS).ceil();
                tau[(x + nx * (y + ny * z)) as usize] = steps.clamp(0.0, TAU_MAX_STEPS as f64) as u8;
            }
        }
    }
    tau
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;

    /// The stored corners are the clamped signed distance: a cube's centre corner, a corner just
    /// outside a face, one beyond the clamp; the cavity's centre is outside.
    #[test]
    fn corners_hold_the_clamped_signed_distance() {
        let (lut, stats) =
            bake(&procedural::cube(2.0).unwrap(), 10, &BakeOptions::default(), &|_, _| {}).unwrap();
        assert_eq!(lut.dims, [12, 12, 12]);
        assert_eq!(stats.corners, 13 * 13 * 13);
        let h = lut.voxel_size;
        let q = QUANTIZATION_BOUND_VOXELS * h;
        for k in [1u32, 3, 6, 11, 12] {
            let p = lut.origin + DVec3::new(k as f64, 6.0, 6.0) * h;
            let exact = (p.x.abs() - 1.0).max(p.y.abs() - 1.0).max(p.z.abs() - 1.0);
            let want = exact.clamp(-CLAMP_VOXELS * h, CLAMP_VOXELS * h);
            assert!(
                (lut.corner([k, 6, 6]) - want).abs() <= q + 1e-12,
                "corner {k}: {} vs {want}",
                lut.corner([k, 6, 6])
            );
        }
        // A plane is reconstructed exactly, so τ is the margin alone (up to quantization), except
        // at the cube's edges and corners: there the error is at most the corner's (½ voxel).
        assert!(lut.gap_threshold() <= (1.0 + GAP_MARGIN_VOXELS) * h + 2.0 * q + h / TAU_STEPS);
        // Away from the surface only the margin.
        let margin = (GAP_MARGIN_VOXELS * TAU_STEPS).ceil() * h / TAU_STEPS;
        assert_eq!(lut.tau_at(DVec3::ZERO), margin);
        assert!(lut.tau_at(DVec3::new(0.3, 0.3, 1.0)) <= margin + 2.0 * q + h / TAU_STEPS);
        let (hollow, _) = bake(
            &procedural::cavity_cube(2.0, 0.6, 32, 16).unwrap(),
            20,
            &BakeOptions::default(),
            &|_, _| {},
        )
        .unwrap();
        assert!(hollow.field_at(DVec3::ZERO) > 0.5 * hollow.voxel_size);
        assert!(hollow.field_at(DVec3::new(0.8, 0.0, 0.0)) < 0.0);
        // Four corners a word, corner 0 lowest; then τ, four a word.
        let words = lut.words();
        assert_eq!(words.len(), lut.field.len().div_ceil(4) + lut.tau.len().div_ceil(4));
        assert_eq!(lut.tau.len(), 12 * 12 * 12);
        assert_eq!(words[lut.field.len().div_ceil(4)] & 0xff, lut.tau[0] as u32);
        assert_eq!(words[0] & 0xff, lut.field[0] as u8 as u32);
        assert_eq!(words[0] >> 24, lut.field[3] as u8 as u32);
    }

    #[test]
    fn threads_give_the_same_field_and_progress_reaches_the_total() {
        let mesh = procedural::bottle(0.5, 1.6, 0.05, 0.5, 12).unwrap();
        let calls = Mutex::new(Vec::new());
        let progress = |done: usize, total: usize| calls.lock().unwrap().push((done, total));
        let (a, _) = bake(&mesh, 12, &BakeOptions { threads: 1 }, &|_, _| {}).unwrap();
        let (b, _) = bake(&mesh, 12, &BakeOptions { threads: 3 }, &progress).unwrap();
        assert_eq!(a, b);
        let calls = calls.into_inner().unwrap();
        let total = a.dims[2] as usize + 2;
        assert_eq!(calls.len(), total);
        assert!(calls.iter().all(|&(d, t)| t == total && d <= total));
        assert_eq!(*calls.last().unwrap(), (total, total));
    }
}
