//! The seed's own thickness LUT (seed 003, §3.2, figures 7–9), `thickness = "pairs"`: the surface
//! voxels of the mesh numbered, and for every pair of them the thickness of the segment between
//! their centroids with the cavities subtracted, in an N×N grayscale texture. Kept beside the
//! signed-distance field (`thickness_lut`, `thickness = "lut"`) so the report shows where the
//! seed's method stands; its memory grows as N² in surface voxels (figure 13).
//!
//! # What is stored
//!
//! - **Grid**: `voxelize::grid_layout` (the same grid as the field). A voxel is *solid* when the
//!   winding number at its centre is > 0 (`voxelize::row_windings` along rows of centres), so a
//!   sealed cavity or a bottle's air is not solid. A solid voxel with a face neighbour that is not
//!   solid is a *surface voxel*; they are numbered 0..N in x-fastest order (`surface`).
//! - **Pair table**: for i ≠ j, d(i, j) = the length of the segment c_i → c_j (the voxels'
//!   centroids) inside the solid, exact in f64 from the mesh (`MeshBvh::inside_fraction`: the
//!   watertight crossings, cavities subtracted by the winding number). Stored as R8_UNORM
//!   q = round(d / D · 255), D (`max_thickness`, the stated maximum) the diagonal of the box of the
//!   surface centroids, which no segment between two of them, and so no thickness, exceeds. Row i,
//!   column j; symmetric; the diagonal is 0. |q/255·D − d| ≤ ½·D/255 (`QUANTIZATION_BOUND`·D).
//!   R8 and the square table are the seed's: its figure 13 (968 KB at 30³ … 17.5 MB at 56³) is N²
//!   bytes for N ≈ 1000 … 4300 surface voxels.
//! - **Voxel → surface voxel** (`lookup`, the seed's "which surface voxel each vertex belongs to",
//!   for any point of the grid rather than the mesh's vertices, since the pass shades pixels): per
//!   grid voxel, the surface voxel whose centroid is nearest to its centre within `SEARCH_RADIUS`
//!   voxels (Chebyshev; ties to the lower number), else `NO_SURFACE`. A point on the mesh lies in
//!   a voxel a surface voxel is at most a voxel or two from.
//!
//! # How it is read (the shader and `PairTable::inside_fraction` do the same)
//!
//! For the light's entry a and the shaded point b (object space): i = lookup(voxel of a),
//! j = lookup(voxel of b); the inside fraction is min(q(i, j)/255·D / |c_j − c_i|, 1), 1 for i = j
//! (both ends in one surface voxel) or when either end has no surface voxel (the TSM path); the
//! world thickness is that fraction times |M(b − a)|, exact scaling under any affine M. Applying
//! the pair's fraction to the actual path rather than using d(i, j) itself keeps the length right
//! where the centroids are up to ~√3 voxels from the ends; the cavities come from the pair.
//!
//! # Limits
//!
//! The table is one 2D image side N: N ≤ maxImageDimension2D, and N² bytes ≤ the memory budget
//! (`DEFAULT_MEMORY_BUDGET`), checked once the surface voxels are counted, before the N²/2 pair
//! casts; a larger table is refused (`PairsError::TooLarge`) with the numbers, never cut.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use glam::DVec3;

use super::raycast::MeshBvh;
use super::voxelize::{check_solid_mesh, grid_layout, row_windings, VoxelizeError};
use crate::scene::mesh::{Mesh, MeshError};

/// Quantization levels of a stored thickness (8-bit UNORM, the seed's grayscale).
pub const PAIR_LEVELS: f64 = 255.0;
/// |stored − exact| ≤ this times `max_thickness`.
pub const QUANTIZATION_BOUND: f64 = 0.5 / PAIR_LEVELS;
/// Vulkan format of the table image.
pub const PAIR_FORMAT: &str = "R8_UNORM";
/// The memory a pair table may take unless told otherwise: 64 MiB, N ≤ 8192 surface voxels (the
/// seed's bottle at 56³ took 17.5 MB).
pub const DEFAULT_MEMORY_BUDGET: u64 = 64 << 20;
/// The image side assumed when the device's is not given (lavapipe's maxImageDimension2D).
pub const DEFAULT_MAX_IMAGE_DIM: u32 = 16384;
/// `lookup` of a voxel with no surface voxel within `SEARCH_RADIUS`.
pub const NO_SURFACE: u32 = u32::MAX;
/// How far (voxels, per axis) `lookup` looks for a surface voxel.
pub const SEARCH_RADIUS: i64 = 2;

/// What the bake can fail with. Each message names the numbers involved.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PairsError {
    #[error(transparent)]
    Voxelize(#[from] VoxelizeError),
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error(
        "the pair table at voxel resolution {res} has {surface_voxels} surface voxels: a \
         {surface_voxels}×{surface_voxels} {PAIR_FORMAT} image of {bytes} bytes, above {limit} \
         (maxImageDimension2D {max_dim}, memory budget {budget} bytes); the table grows as the \
         square of the surface voxels: lower voxel_res, or use thickness = \"lut\""
    )]
    TooLarge { res: u32, surface_voxels: u64, bytes: u64, max_dim: u32, budget: u64, limit: String },
}

/// How to bake.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PairOptions {
    /// Worker threads; 0 = `std::thread::available_parallelism`.
    pub threads: usize,
    /// The device's maxImageDimension2D: the table's side N may not exceed it.
    pub max_image_dim: u32,
    /// The table's N² bytes may not exceed this.
    pub memory_budget: u64,
}

impl Default for PairOptions {
    fn default() -> Self {
        PairOptions { threads: 0, max_image_dim: DEFAULT_MAX_IMAGE_DIM, memory_budget: DEFAULT_MEMORY_BUDGET }
    }
}

/// What a bake did (not stored).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairStats {
    pub pairs: u64,
    pub threads: usize,
    /// Voxelizing and numbering, then the pair casts.
    pub voxelize_seconds: f64,
    pub pair_seconds: f64,
}

/// The surface voxels of a mesh's grid (the first half of the bake; `surface_voxels`).
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceVoxels {
    pub res: u32,
    pub dims: [u32; 3],
    pub origin: DVec3,
    pub voxel_size: f64,
    /// Grid coordinates of surface voxel k, numbered x fastest.
    pub surface: Vec<[u32; 3]>,
    /// Per grid voxel (x fastest): its nearest surface voxel, or `NO_SURFACE`.
    pub lookup: Vec<u32>,
}

/// A baked pair table with what the GPU and the CPU twin need to read it.
#[derive(Clone, Debug, PartialEq)]
pub struct PairTable {
    pub voxels: SurfaceVoxels,
    /// D: a stored 255 means D object units.
    pub max_thickness: f64,
    /// N×N, row i, column j: q(i, j).
    pub table: Vec<u8>,
}

/// Bytes of the table of `n` surface voxels (square, one byte a texel).
pub fn table_bytes(n: u64) -> u64 {
    n * n
}

fn voxel_linear(dims: [u32; 3], [x, y, z]: [u32; 3]) -> usize {
    x as usize + dims[0] as usize * (y as usize + dims[1] as usize * z as usize)
}

impl SurfaceVoxels {
    pub fn count(&self) -> usize {
        self.surface.len()
    }

    /// The centroid of surface voxel `k`, object space.
    pub fn centroid(&self, k: u32) -> DVec3 {
        let [x, y, z] = self.surface[k as usize];
        self.origin + (DVec3::new(x as f64, y as f64, z as f64) + 0.5) * self.voxel_size
    }

    /// The voxel holding `p` (floor, clamped to the grid); `None` for a non-finite point.
    pub fn voxel_of(&self, p: DVec3) -> Option<[u32; 3]> {
        if !p.is_finite() {
            return None;
        }
        let g = (p - self.origin) / self.voxel_size;
        Some([0, 1, 2].map(|a| (g[a].floor().max(0.0) as u32).min(self.dims[a] - 1)))
    }

    /// The surface voxel standing for `p`, if any.
    pub fn surface_of(&self, p: DVec3) -> Option<u32> {
        let v = self.voxel_of(p)?;
        Some(self.lookup[voxel_linear(self.dims, v)]).filter(|&k| k != NO_SURFACE)
    }

    /// The surface voxels the pair of `a` and `b` reads, when both have one.
    pub fn pair_of(&self, a: DVec3, b: DVec3) -> Option<(u32, u32)> {
        Some((self.surface_of(a)?, self.surface_of(b)?))
    }

    /// The refusal for a table of this many surface voxels, if it is one.
    pub fn check_limits(&self, options: &PairOptions) -> Result<(), PairsError> {
        let n = self.count() as u64;
        let bytes = table_bytes(n);
        let over_dim = n > options.max_image_dim as u64;
        if !over_dim && bytes <= options.memory_budget {
            return Ok(());
        }
        let limit = if over_dim {
            format!("the device's {}-texel image side", options.max_image_dim)
        } else {
            format!("the {}-byte memory budget", options.memory_budget)
        };
        Err(PairsError::TooLarge {
            res: self.res,
            surface_voxels: n,
            bytes,
            max_dim: options.max_image_dim,
            budget: options.memory_budget,
            limit,
        })
    }
}

fn thread_count(requested: usize) -> usize {
    if requested > 0 {
        return requested;
    }
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Voxelizes `mesh` at `res` and numbers its surface voxels (no pair work: cheap, ~res³ winding
/// lookups along res² rows). Used by the bake and by the memory measurements.
pub fn surface_voxels(mesh: &Mesh, res: u32) -> Result<SurfaceVoxels, PairsError> {
    check_solid_mesh(mesh)?;
    let (dims, origin, h) = grid_layout(mesh, res)?;
    let bvh = MeshBvh::new(mesh)?;
    Ok(number_surface(&bvh, res, dims, origin, h))
}

fn number_surface(bvh: &MeshBvh, res: u32, dims: [u32; 3], origin: DVec3, h: f64) -> SurfaceVoxels {
    let [nx, ny, nz] = dims.map(|d| d as usize);
    let mut solid = vec![false; nx * ny * nz];
    let mut winding = vec![0i32; nx];
    // Rows of voxel centres: row_windings' corners of a grid moved by half a voxel.
    let centres = origin + DVec3::splat(0.5 * h);
    for (row, out) in solid.chunks_exact_mut(nx).enumerate() {
        row_windings(bvh, centres, h, [(row % ny) as u32, (row / ny) as u32], &mut winding);
        out.iter_mut().zip(&winding).for_each(|(s, &w)| *s = w > 0);
    }
    let at = |x: i64, y: i64, z: i64| {
        let inside =
            (0..nx as i64).contains(&x) && (0..ny as i64).contains(&y) && (0..nz as i64).contains(&z);
        inside && solid[x as usize + nx * (y as usize + ny * z as usize)]
    };
    let mut id = vec![NO_SURFACE; solid.len()];
    let mut surface = Vec::new();
    for (k, slot) in id.iter_mut().enumerate() {
        let (x, y, z) = ((k % nx) as i64, ((k / nx) % ny) as i64, (k / (nx * ny)) as i64);
        let faces = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)];
        if at(x, y, z) && faces.iter().any(|&(dx, dy, dz)| !at(x + dx, y + dy, z + dz)) {
            *slot = surface.len() as u32;
            surface.push([x as u32, y as u32, z as u32]);
        }
    }
    let mut lookup = vec![NO_SURFACE; solid.len()];
    let r = SEARCH_RADIUS;
    for (k, slot) in lookup.iter_mut().enumerate() {
        let (x, y, z) = ((k % nx) as i64, ((k / nx) % ny) as i64, (k / (nx * ny)) as i64);
        let mut best = (i64::MAX, NO_SURFACE);
        for dz in -r..=r {
            for dy in -r..=r {
                for dx in -r..=r {
                    let (i, j, l) = (x + dx, y + dy, z + dz);
                    if !((0..nx as i64).contains(&i)
                        && (0..ny as i64).contains(&j)
                        && (0..nz as i64).contains(&l))
                    {
                        continue;
                    }
                    let s = id[i as usize + nx * (j as usize + ny * l as usize)];
                    // Squared distance between centres in voxels, then the lower number.
                    let d2 = dx * dx + dy * dy + dz * dz;
                    if s != NO_SURFACE && (d2, s) < best {
                        best = (d2, s);
                    }
                }
            }
        }
        *slot = best.1;
    }
    SurfaceVoxels { res, dims, origin, voxel_size: h, surface, lookup }
}

/// The exact thickness between the centroids of surface voxels `i` and `j` (f64, cavities
/// subtracted): what the table stores before quantization.
pub fn exact_pair(voxels: &SurfaceVoxels, bvh: &MeshBvh, i: u32, j: u32) -> f64 {
    if i == j {
        return 0.0;
    }
    let (a, b) = (voxels.centroid(i), voxels.centroid(j));
    bvh.inside_fraction(a, b) * (b - a).length()
}

/// The fraction the pass applies to the path for pair (i, j) whose thickness is `d` (see the
/// module documentation): d/|c_j − c_i| capped at 1, and 1 for i = j.
pub fn pair_fraction(voxels: &SurfaceVoxels, i: u32, j: u32, d: f64) -> f64 {
    if i == j {
        return 1.0;
    }
    let length = (voxels.centroid(j) - voxels.centroid(i)).length();
    (d / length).clamp(0.0, 1.0)
}

impl PairTable {
    pub fn surface_voxels(&self) -> usize {
        self.voxels.count()
    }

    /// Bytes of the table image (N², the seed's figure-13 quantity).
    pub fn bytes(&self) -> u64 {
        self.table.len() as u64
    }

    /// Bytes of everything the GPU holds: the table, a word per grid voxel (`lookup`) and per
    /// surface voxel (its coordinates).
    pub fn gpu_bytes(&self) -> u64 {
        self.bytes() + 4 * (self.voxels.lookup.len() + self.voxels.count()) as u64
    }

    /// The stored thickness of pair (i, j), object units.
    pub fn stored(&self, i: u32, j: u32) -> f64 {
        let n = self.voxels.count();
        self.table[i as usize * n + j as usize] as f64 / PAIR_LEVELS * self.max_thickness
    }

    /// The inside fraction of the segment a → b (object space) as the pass reads it: 1 where an
    /// end has no surface voxel (the pass keeps TSM's distance there).
    pub fn inside_fraction(&self, a: DVec3, b: DVec3) -> f64 {
        match self.voxels.pair_of(a, b) {
            Some((i, j)) => pair_fraction(&self.voxels, i, j, self.stored(i, j)),
            None => 1.0,
        }
    }

    /// The bound on |stored − exact| of a pair, object units.
    pub fn quantization_bound(&self) -> f64 {
        QUANTIZATION_BOUND * self.max_thickness
    }

    /// The surface voxels' coordinates packed a word each (x | y << 10 | z << 20; dims ≤ 258).
    pub fn coordinate_words(&self) -> Vec<u32> {
        self.voxels.surface.iter().map(|&[x, y, z]| x | y << 10 | z << 20).collect()
    }
}

/// Bakes the pair table of `mesh` at `res`. `progress(done, total)` is called (from any worker
/// thread) after each row of pairs and once more at the end with done = total. Refuses a table
/// above `options`' limits before casting any pair.
pub fn bake(
    mesh: &Mesh,
    res: u32,
    options: &PairOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(PairTable, PairStats), PairsError> {
    let start = Instant::now();
    check_solid_mesh(mesh)?;
    let (dims, origin, h) = grid_layout(mesh, res)?;
    let bvh = MeshBvh::new(mesh)?;
    let voxels = number_surface(&bvh, res, dims, origin, h);
    if voxels.count() == 0 {
        return Err(VoxelizeError::NoSolidVoxel { res, dims }.into());
    }
    voxels.check_limits(options)?;
    let voxelize_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let n = voxels.count();
    let centroids: Vec<DVec3> = (0..n as u32).map(|k| voxels.centroid(k)).collect();
    let (lo, hi) =
        centroids.iter().fold((centroids[0], centroids[0]), |(lo, hi), c| (lo.min(*c), hi.max(*c)));
    // The stated maximum: no segment between two centroids is longer (at least a voxel, for one).
    let max_thickness = (hi - lo).length().max(h);
    let mut table = vec![0u8; n * n];
    let threads = thread_count(options.threads).min(n);
    let done = AtomicUsize::new(0);
    {
        let queue = Mutex::new(table.chunks_mut(n).enumerate());
        let (queue, done, bvh, centroids) = (&queue, &done, &bvh, &centroids);
        std::thread::scope(|scope| {
            for _ in 0..threads {
                scope.spawn(move || loop {
                    let next = queue.lock().map(|mut q| q.next()).unwrap_or(None);
                    let Some((i, row)) = next else { break };
                    for j in i + 1..n {
                        let (a, b) = (centroids[i], centroids[j]);
                        let d = bvh.inside_fraction(a, b) * (b - a).length();
                        row[j] = ((d / max_thickness).clamp(0.0, 1.0) * PAIR_LEVELS).round() as u8;
                    }
                    progress(done.fetch_add(1, Ordering::Relaxed) + 1, n + 1);
                });
            }
        });
    }
    // The lower triangle mirrors the upper one.
    for i in 0..n {
        for j in 0..i {
            table[i * n + j] = table[j * n + i];
        }
    }
    progress(n + 1, n + 1);
    let stats = PairStats {
        pairs: (n as u64 * (n as u64 - 1)) / 2,
        threads,
        voxelize_seconds,
        pair_seconds: start.elapsed().as_secs_f64(),
    };
    Ok((PairTable { voxels, max_thickness, table }, stats))
}

/// The f64 twin of the pass's pair thickness with the *exact* pair thickness (not the stored
/// one): |M(b − a)| times `pair_fraction` of d(i, j) cast on the mesh; the TSM path (the whole
/// |M(b − a)|) where an end has no surface voxel. `None` for a non-finite point.
pub fn exact_pair_thickness(
    voxels: &SurfaceVoxels,
    bvh: &MeshBvh,
    m: &crate::scene::transform::Transform,
    a: DVec3,
    b: DVec3,
) -> Option<f64> {
    if !(a.is_finite() && b.is_finite()) {
        return None;
    }
    let path = (m.transform_point(b) - m.transform_point(a)).length();
    let fraction = match voxels.pair_of(a, b) {
        Some((i, j)) => pair_fraction(voxels, i, j, exact_pair(voxels, bvh, i, j)),
        None => 1.0,
    };
    Some(path * fraction)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;

    /// A cube: every pair is all inside (stored within the quantization bound of its length),
    /// and every voxel of the grid finds a surface voxel within the search radius or is far.
    #[test]
    fn a_convex_solid_stores_the_segment_lengths() {
        let mesh = procedural::cube(2.0).unwrap();
        let (t, stats) = bake(&mesh, 6, &PairOptions::default(), &|_, _| {}).unwrap();
        // 6³ solid voxels less the 4³ inner ones.
        assert_eq!(t.surface_voxels(), 6 * 6 * 6 - 4 * 4 * 4);
        assert_eq!(stats.pairs, 152 * 151 / 2);
        let v = &t.voxels;
        for (i, j) in [(0, 151), (3, 77), (40, 41)] {
            let length = (v.centroid(j) - v.centroid(i)).length();
            assert!((t.stored(i, j) - length).abs() <= t.quantization_bound() + 1e-12);
            assert_eq!(t.stored(i, j), t.stored(j, i));
        }
        assert_eq!(t.stored(5, 5), 0.0);
        assert_eq!(t.inside_fraction(DVec3::new(-0.99, 0.1, 0.2), DVec3::new(-0.99, 0.12, 0.2)), 1.0);
        assert_eq!(v.surface_of(DVec3::NAN), None);
    }

    /// Straight through the cavity of a cavity cube the pair's thickness leaves the cavity's
    /// chord out.
    #[test]
    fn the_cavity_is_subtracted() {
        let mesh = procedural::cavity_cube(2.0, 0.6, 32, 16).unwrap();
        let (t, _) = bake(&mesh, 10, &PairOptions::default(), &|_, _| {}).unwrap();
        let bvh = MeshBvh::new(&mesh).unwrap();
        let (a, b) = (DVec3::new(0.05, 0.05, -0.95), DVec3::new(0.05, 0.05, 0.95));
        let (i, j) = t.voxels.pair_of(a, b).unwrap();
        let exact = exact_pair(&t.voxels, &bvh, i, j);
        let length = (t.voxels.centroid(j) - t.voxels.centroid(i)).length();
        assert!(exact < length - 1.0, "{exact} of {length}");
        assert!((t.stored(i, j) - exact).abs() <= t.quantization_bound() + 1e-12);
    }

    #[test]
    fn too_large_a_table_is_refused_with_its_numbers() {
        let mesh = procedural::cube(2.0).unwrap();
        let small = PairOptions { max_image_dim: 100, ..PairOptions::default() };
        let e = bake(&mesh, 6, &small, &|_, _| {}).unwrap_err().to_string();
        assert!(e.contains("152 surface voxels") && e.contains("100-texel image side"), "{e}");
        let tight = PairOptions { memory_budget: 1000, ..PairOptions::default() };
        let e = bake(&mesh, 6, &tight, &|_, _| {}).unwrap_err().to_string();
        assert!(e.contains("23104 bytes") && e.contains("1000-byte memory budget"), "{e}");
    }
}
