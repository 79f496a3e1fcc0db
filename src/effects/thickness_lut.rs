//! The thickness LUT bake (seed 003, §3.2; DESIGN.md "Thickness LUT"): for every unordered pair of
//! surface voxels (see `voxelize`), the fraction of the segment between their centres that lies
//! inside the solid, computed on the original mesh in f64 and stored once per mesh.
//!
//! # What is stored
//!
//! f(i, j) = (length of the segment c_i → c_j inside the solid) / |c_j − c_i|, cavities excluded
//! (winding number > 0 along the segment). The world thickness for an instance with affine
//! transform M is f(i, j)·|M·c_j − M·c_i|: an affine map scales every part of a segment by the same
//! factor, so this is exact for any M (non-uniform scale and shear included). f(i, i) = 1 (the
//! centre of a solid voxel; its segment has length 0, so it never adds thickness).
//!
//! # Quantization
//!
//! Each fraction is stored as 8-bit UNORM: `round(f·255)`. The stored fraction is within
//! q = 0.5/255 ≈ 0.00196 of the computed one (`QUANTIZATION_BOUND`), so the world thickness is
//! within 0.2 % of the segment length of the baked one. Why not u16: at the seed's 56³ the bottle
//! of assets/scenes/translucency.toml has 3808 surface voxels, so u16 would take N(N+1) bytes =
//! 14.5 MB, above half the seed's 17.5 MB; u8 takes N(N+1)/2 = 7.25 MB (the seed's table, stored
//! square, would be about twice that at the same N). And the u8 step is far below the
//! voxelization error: the ends of a light path move to voxel centres up to ~2.6 voxels away, and
//! on the bottle's light paths the thickness is off by ~2 voxels at the 95th percentile
//! (`cargo run --release --example bake_measure`), against 0.2 % of the length for u8.
//!
//! # GPU layout (mirrored in GLSL; keep in sync)
//!
//! With N surface voxels there are P = N(N+1)/2 pairs i ≤ j. Pair (i, j), i ≤ j, is texel
//! `k = i·N − i(i−1)/2 + (j − i)` (row i of the upper triangle starts at i·N − i(i−1)/2); for
//! i > j swap them first. The table is a 2D `R8_UNORM` image of `width × height` texels:
//! `width = min(P, 4096)` (or the device limit if that is smaller), `height = ceil(P / width)`;
//! when that height exceeds the limit, `width` becomes the limit. Texel k lives at
//! `(k mod width, k / width)`. Bytes = width·height (the tail of the last row is 0). With
//! N ≤ 46340 every intermediate of the index formula fits in a u32 (i·N < 2³¹), so the shader can
//! compute it in `uint`. A table with more than limit² texels is refused (`BakeError::TooLarge`).
//!
//! # Picking i and j (what the shader mirrors)
//!
//! For an object-space point p (the shaded point, or the point where the light enters, both found
//! through the instance's inverse transform): v = clamp(floor((p − origin) / voxel_size), 0,
//! dims − 1), i = `nearest_grid[v.x + dims.x·(v.y + dims.y·v.z)]`, the surface voxel whose centre is
//! nearest to v's centre (defined for every voxel of the grid, so a point on the mesh surface
//! whose voxel centre is outside the solid still gets the adjacent surface voxel). Upload it as a
//! 3D `R32_UINT` image of `dims`. `id_grid` (surface voxels only, `u32::MAX` elsewhere) is kept for
//! tools and tests. The centres c_i = origin + (surface_voxels[i] + ½)·voxel_size are available as
//! `surface_centres_f32` for a storage buffer.
//!
//! # Speed
//!
//! Rows i are handed to `std::thread::scope` workers one at a time (row i has N − i pairs). Each pair
//! first tries the grid-accelerated path of `trace` (triangles listed per voxel, a DDA through the
//! voxels between the two centres, wide safety margins); any case near rounding goes to
//! `MeshBvh::inside_fraction` (full-line, watertight), so every stored value is the exact one up
//! to f64 rounding. The fast path costs ~0.5 µs a pair against ~3 µs for `inside_fraction` on the
//! bottle (profiled: the full-line BVH walk dominates there); it answers > 99 % of the pairs.

mod trace;

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use glam::DVec3;

use super::raycast::MeshBvh;
use super::voxelize::{voxelize, voxelize_with_winding, VoxelizeError};
use crate::scene::mesh::{Mesh, MeshError};

/// Preferred image width (texels): rows of 4 KiB.
pub const LUT_WIDTH: u32 = 4096;
/// The 2D image limit assumed when none is given (lavapipe's and most GPUs' maxImageDimension2D).
pub const DEFAULT_MAX_TEXTURE_DIM: u32 = 16384;
/// Quantization levels of the stored fraction (8-bit UNORM).
pub const LUT_LEVELS: f64 = 255.0;
/// The quantization bound of a stored fraction: |stored − exact| ≤ this.
pub const QUANTIZATION_BOUND: f64 = 0.5 / LUT_LEVELS;
/// Vulkan format name of the table image, for logs and docs.
pub const LUT_FORMAT: &str = "R8_UNORM";

/// What the bake can fail with. Each message names the limit involved.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error(transparent)]
    Voxelize(#[from] VoxelizeError),
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error(
        "thickness LUT at voxel resolution {res} is too large: {surface_voxels} surface voxels make \
         {pairs} pairs, a {width}×{height} texture, above the {limit}×{limit} limit \
         (max_texture_dim {limit}); lower the resolution"
    )]
    TooLarge { res: u32, surface_voxels: usize, pairs: u64, width: u64, height: u64, limit: u32 },
}

/// How to bake.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BakeOptions {
    /// Worker threads; 0 = `std::thread::available_parallelism`.
    pub threads: usize,
    /// The device's largest 2D image side.
    pub max_texture_dim: u32,
    /// Skip the grid-accelerated path: every pair by `MeshBvh::inside_fraction` (for tests).
    pub exact_only: bool,
}

impl Default for BakeOptions {
    fn default() -> Self {
        BakeOptions { threads: 0, max_texture_dim: DEFAULT_MAX_TEXTURE_DIM, exact_only: false }
    }
}

/// What a bake did (not stored, not compared).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BakeStats {
    pub pairs: u64,
    /// Pairs (i < j) computed by `MeshBvh::inside_fraction`: all of them with `exact_only`, else
    /// those the fast path left to it.
    pub exact_pairs: u64,
    pub threads: usize,
    pub voxelize_seconds: f64,
    pub pair_seconds: f64,
}

/// The texture layout of a table of `n` surface voxels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LutLayout {
    pub surface_voxels: u32,
    pub pairs: u64,
    pub width: u32,
    pub height: u32,
}

impl LutLayout {
    /// The layout for `n` surface voxels (see the module documentation); `width, height ≥ 1`. When
    /// it needs more than `max_dim`² texels: `Err((pairs, width, height))`, the size it needed.
    pub fn new(n: usize, max_dim: u32) -> Result<LutLayout, (u64, u64, u64)> {
        let n64 = n as u64;
        let pairs = n64 * (n64 + 1) / 2;
        let max_dim = max_dim.max(1) as u64;
        let mut width = pairs.clamp(1, (LUT_WIDTH as u64).min(max_dim));
        let mut height = pairs.div_ceil(width).max(1);
        if height > max_dim {
            width = max_dim;
            height = pairs.div_ceil(width);
        }
        if height > max_dim || n64 > u32::MAX as u64 {
            return Err((pairs, width, height));
        }
        Ok(LutLayout { surface_voxels: n as u32, pairs, width: width as u32, height: height as u32 })
    }

    pub fn bytes(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// Texel index of the pair (i, j) among n surface voxels; symmetric (i > j is swapped).
pub fn pair_index(i: u32, j: u32, n: u32) -> u64 {
    let (i, j) = if i <= j { (i as u64, j as u64) } else { (j as u64, i as u64) };
    let n = n as u64;
    // i·N − i(i−1)/2 written with i(i−1)/2 ≤ i·N so it never underflows.
    i * n - i * i.saturating_sub(1) / 2 + (j - i)
}

/// Texel (x, y) of texel index k in an image `width` texels wide.
pub fn texel_of(k: u64, width: u32) -> (u32, u32) {
    ((k % width as u64) as u32, (k / width as u64) as u32)
}

/// A baked table with everything the GPU and the CPU references need to use it.
#[derive(Clone, Debug, PartialEq)]
pub struct ThicknessLut {
    /// Voxel resolution N (voxels along the longest side of the mesh's box).
    pub res: u32,
    /// Grid voxels along x, y, z (one voxel of padding, at least, on each side).
    pub dims: [u32; 3],
    /// Object-space minimum corner of voxel (0, 0, 0).
    pub origin: DVec3,
    /// Voxel edge, object units.
    pub voxel_size: f64,
    /// Grid coordinates of each surface voxel, in id order.
    pub surface_voxels: Vec<[u32; 3]>,
    /// Nearest surface voxel per mesh vertex.
    pub vertex_voxel: Vec<u32>,
    /// Surface id per grid voxel, `u32::MAX` for non-surface voxels.
    pub id_grid: Vec<u32>,
    /// Nearest surface voxel per grid voxel: the shader's lookup.
    pub nearest_grid: Vec<u32>,
    /// Image size in texels.
    pub width: u32,
    pub height: u32,
    /// `width·height` R8_UNORM texels, row-major.
    pub data: Vec<u8>,
}

impl ThicknessLut {
    pub fn surface_count(&self) -> usize {
        self.surface_voxels.len()
    }

    pub fn layout(&self) -> LutLayout {
        let n = self.surface_voxels.len() as u64;
        LutLayout { surface_voxels: n as u32, pairs: n * (n + 1) / 2, width: self.width, height: self.height }
    }

    /// Bytes of the table image (`width·height`, one byte per texel).
    pub fn bytes(&self) -> usize {
        self.data.len()
    }

    /// The stored (quantized) fraction of the segment between surface voxels i and j.
    pub fn fraction(&self, i: u32, j: u32) -> f64 {
        let k = pair_index(i, j, self.surface_voxels.len() as u32);
        let (x, y) = texel_of(k, self.width);
        self.data[y as usize * self.width as usize + x as usize] as f64 / LUT_LEVELS
    }

    /// Object-space centre of surface voxel i.
    pub fn centre(&self, i: u32) -> DVec3 {
        let [x, y, z] = self.surface_voxels[i as usize];
        self.origin + (DVec3::new(x as f64, y as f64, z as f64) + 0.5) * self.voxel_size
    }

    /// Centres as `[x, y, z, 0]` f32, for a storage buffer.
    pub fn surface_centres_f32(&self) -> Vec<[f32; 4]> {
        (0..self.surface_voxels.len() as u32)
            .map(|i| {
                let c = self.centre(i);
                [c.x as f32, c.y as f32, c.z as f32, 0.0]
            })
            .collect()
    }

    /// The grid voxel containing `p`, clamped to the grid.
    pub fn voxel_of(&self, p: DVec3) -> [u32; 3] {
        super::voxelize::voxel_of(self.dims, self.origin, self.voxel_size, p)
    }

    /// The shader's lookup (see the module documentation): `nearest_grid` at the clamped voxel
    /// containing object point `p`; `None` for a non-finite point.
    pub fn surface_voxel_at(&self, p: DVec3) -> Option<u32> {
        if !p.is_finite() {
            return None;
        }
        let id = self.nearest_grid[super::voxelize::linear(self.dims, self.voxel_of(p))];
        (id != u32::MAX).then_some(id)
    }

    /// The surface voxel whose centre is nearest to object point `p` (exact; ties to the lower id),
    /// by a neighbourhood search. Measured on the bottle's light paths it is no better than
    /// `surface_voxel_at` (the error is the centres' depth below the surface, not the choice
    /// among neighbours), so the shader need not search; kept for tools and tests.
    pub fn nearest_surface_voxel(&self, p: DVec3) -> Option<u32> {
        super::voxelize::Lookup {
            dims: self.dims,
            origin: self.origin,
            h: self.voxel_size,
            surface_voxels: &self.surface_voxels,
            id_grid: &self.id_grid,
            nearest_grid: &self.nearest_grid,
        }
        .nearest_exact(p)
    }

    /// World thickness between object points `a` and `b` of an instance with transform `m`, as the
    /// shader computes it: f(i, j) · |M·c_j − M·c_i| with i, j from `surface_voxel_at`.
    pub fn world_thickness(&self, m: &crate::scene::transform::Transform, a: DVec3, b: DVec3) -> Option<f64> {
        let (i, j) = (self.surface_voxel_at(a)?, self.surface_voxel_at(b)?);
        let length = (m.transform_point(self.centre(j)) - m.transform_point(self.centre(i))).length();
        Some(self.fraction(i, j) * length)
    }

    /// The variant that scales the fraction by the actual segment: f(i, j) · |M·b − M·a|. Exact
    /// for any pair on a convex solid (where `world_thickness` is short by up to the two ends'
    /// offsets), and about 10 % smaller at the 95th percentile on the bottle's light paths
    /// (`cargo run --release --example bake_measure`); the shader knows a and b anyway.
    pub fn world_thickness_between(
        &self,
        m: &crate::scene::transform::Transform,
        a: DVec3,
        b: DVec3,
    ) -> Option<f64> {
        let (i, j) = (self.surface_voxel_at(a)?, self.surface_voxel_at(b)?);
        Some(self.fraction(i, j) * (m.transform_point(b) - m.transform_point(a)).length())
    }
}

fn quantize(f: f64) -> u8 {
    (f.clamp(0.0, 1.0) * LUT_LEVELS).round() as u8
}

fn thread_count(requested: usize) -> usize {
    if requested > 0 {
        return requested;
    }
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Voxelizes `mesh` at `res` and bakes the table. `progress(done, total)` is called (from any
/// worker thread) after each row of pairs, and once more at the end with done = total.
pub fn bake(
    mesh: &Mesh,
    res: u32,
    options: &BakeOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(ThicknessLut, BakeStats), BakeError> {
    let start = Instant::now();
    let bvh = MeshBvh::new(mesh)?;
    let (grid, winding) = voxelize_with_winding(mesh, &bvh, res)?;
    let n = grid.surface_voxels.len();
    let layout = LutLayout::new(n, options.max_texture_dim).map_err(|(pairs, width, height)| {
        BakeError::TooLarge { res, surface_voxels: n, pairs, width, height, limit: options.max_texture_dim }
    })?;
    let voxelize_seconds = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let threads = thread_count(options.threads).min(n.max(1));
    let mut data = vec![0u8; layout.bytes()];
    let fallbacks = AtomicU64::new(0);
    {
        let tracer = (!options.exact_only)
            .then(|| trace::SegmentTracer::new(mesh, grid.dims, grid.origin, grid.voxel_size));
        // Row i of the upper triangle is the slice of N − i texels starting at pair_index(i, i).
        let mut rows: Vec<(usize, &mut [u8])> = Vec::with_capacity(n);
        let mut rest: &mut [u8] = &mut data[..layout.pairs as usize];
        for i in 0..n {
            let (row, tail) = rest.split_at_mut(n - i);
            rows.push((i, row));
            rest = tail;
        }
        let queue = Mutex::new(rows.into_iter());
        let done = AtomicUsize::new(0);
        let total = layout.pairs as usize;
        let (grid, winding, bvh, tracer) = (&grid, &winding, &bvh, tracer.as_ref());
        let (queue, done, fallbacks) = (&queue, &done, &fallbacks);
        std::thread::scope(|scope| {
            for _ in 0..threads {
                scope.spawn(move || {
                    let mut scratch = tracer.map(trace::SegmentTracer::scratch);
                    loop {
                        let next = queue.lock().map(|mut q| q.next()).unwrap_or(None);
                        let Some((i, row)) = next else { break };
                        let mut local_fallbacks = 0;
                        let vi = grid.surface_voxels[i];
                        let pi = grid.centre(vi);
                        let wi = winding[grid.linear(vi)];
                        row[0] = quantize(1.0);
                        for (slot, j) in row.iter_mut().zip(i..n).skip(1) {
                            let vj = grid.surface_voxels[j];
                            let fast = match (tracer, scratch.as_mut()) {
                                (Some(t), Some(s)) => t.fraction(vi, vj, wi, winding[grid.linear(vj)], s),
                                _ => None,
                            };
                            let f = fast.unwrap_or_else(|| {
                                local_fallbacks += 1;
                                bvh.inside_fraction(pi, grid.centre(vj))
                            });
                            *slot = quantize(f);
                        }
                        fallbacks.fetch_add(local_fallbacks, Ordering::Relaxed);
                        let now = done.fetch_add(n - i, Ordering::Relaxed) + (n - i);
                        progress(now, total);
                    }
                });
            }
        });
        progress(total, total);
    }
    let pairs = layout.pairs;
    let stats = BakeStats {
        pairs,
        exact_pairs: fallbacks.into_inner(),
        threads,
        voxelize_seconds,
        pair_seconds: start.elapsed().as_secs_f64(),
    };
    let lut = ThicknessLut {
        res,
        dims: grid.dims,
        origin: grid.origin,
        voxel_size: grid.voxel_size,
        width: layout.width,
        height: layout.height,
        data,
        surface_voxels: grid.surface_voxels,
        vertex_voxel: grid.vertex_voxel,
        id_grid: grid.id_grid,
        nearest_grid: grid.nearest_grid,
    };
    Ok((lut, stats))
}

/// The surface-voxel count and layout `bake` would produce, without baking (cheap: one
/// voxelization).
pub fn plan(mesh: &Mesh, res: u32, max_texture_dim: u32) -> Result<LutLayout, BakeError> {
    let bvh = MeshBvh::new(mesh)?;
    let grid = voxelize(mesh, &bvh, res)?;
    let n = grid.surface_voxels.len();
    LutLayout::new(n, max_texture_dim).map_err(|(pairs, width, height)| BakeError::TooLarge {
        res,
        surface_voxels: n,
        pairs,
        width,
        height,
        limit: max_texture_dim,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;

    #[test]
    fn pair_index_numbers_the_upper_triangle_row_by_row() {
        for n in [1u32, 2, 3, 7, 40] {
            let mut seen = vec![false; (n as usize * (n as usize + 1)) / 2];
            let mut expected = 0u64;
            for i in 0..n {
                for j in i..n {
                    let k = pair_index(i, j, n);
                    assert_eq!(k, expected, "row-major order, n = {n}");
                    assert_eq!(pair_index(j, i, n), k, "symmetric");
                    assert!(!seen[k as usize]);
                    seen[k as usize] = true;
                    expected += 1;
                }
            }
            assert!(seen.iter().all(|&s| s));
        }
        // The last pair of a big table, in u64 without overflow.
        let n = 46340u32;
        assert_eq!(pair_index(n - 1, n - 1, n), n as u64 * (n as u64 + 1) / 2 - 1);
        assert_eq!(texel_of(4096 * 3 + 5, 4096), (5, 3));
    }

    #[test]
    fn layout_widths_and_limits() {
        let l = LutLayout::new(10, DEFAULT_MAX_TEXTURE_DIM).unwrap();
        assert_eq!((l.pairs, l.width, l.height), (55, 55, 1));
        let l = LutLayout::new(4000, DEFAULT_MAX_TEXTURE_DIM).unwrap();
        assert_eq!((l.width, l.height), (4096, 1954));
        assert!(l.bytes() as u64 >= l.pairs && l.bytes() as u64 - l.pairs < 4096);
        // Past 4096 rows of 4096 → wider rows up to the limit.
        let l = LutLayout::new(12000, DEFAULT_MAX_TEXTURE_DIM).unwrap();
        assert_eq!(l.width, DEFAULT_MAX_TEXTURE_DIM);
        assert!(l.height <= DEFAULT_MAX_TEXTURE_DIM);
        // 23169 surface voxels fit a 16384² texture (23169·23170/2 ≤ 16384²); 23170 do not.
        assert!(LutLayout::new(23169, 16384).is_ok());
        assert!(LutLayout::new(23170, 16384).is_err());
        assert_eq!(LutLayout::new(0, 16).unwrap().bytes(), 1);
    }

    /// The grid-accelerated path agrees with `MeshBvh::inside_fraction` on every pair it answers,
    /// and answers almost all of them.
    #[test]
    fn fast_path_matches_the_exact_path() {
        for (mesh, res) in [
            (procedural::cavity_cube(2.0, 0.6, 16, 8).unwrap(), 10),
            (procedural::bottle(0.5, 1.6, 0.05, 0.5, 16).unwrap(), 14),
            (procedural::torus(1.0, 0.35, 16, 8).unwrap(), 14),
            (procedural::tetrahedron(1.0).unwrap(), 9),
        ] {
            let bvh = MeshBvh::new(&mesh).unwrap();
            let (grid, winding) = voxelize_with_winding(&mesh, &bvh, res).unwrap();
            let tracer = trace::SegmentTracer::new(&mesh, grid.dims, grid.origin, grid.voxel_size);
            let mut scratch = tracer.scratch();
            let sv = &grid.surface_voxels;
            let (mut answered, mut total) = (0, 0);
            for i in 0..sv.len() {
                for j in i + 1..sv.len() {
                    total += 1;
                    let (wi, wj) = (winding[grid.linear(sv[i])], winding[grid.linear(sv[j])]);
                    let Some(fast) = tracer.fraction(sv[i], sv[j], wi, wj, &mut scratch) else { continue };
                    answered += 1;
                    let exact = bvh.inside_fraction(grid.centre(sv[i]), grid.centre(sv[j]));
                    assert!((fast - exact).abs() < 1e-12, "{:?}→{:?}: {fast} vs {exact}", sv[i], sv[j]);
                }
            }
            assert!(answered * 100 >= total * 97, "fast path answered only {answered} of {total}");
        }
    }

    #[test]
    fn threads_and_paths_give_the_same_table() {
        let mesh = procedural::bottle(0.5, 1.6, 0.05, 0.5, 12).unwrap();
        let one = BakeOptions { threads: 1, ..BakeOptions::default() };
        let (a, sa) = bake(&mesh, 12, &one, &|_, _| {}).unwrap();
        let (b, _) = bake(&mesh, 12, &BakeOptions { threads: 3, ..one }, &|_, _| {}).unwrap();
        let (c, sc) = bake(&mesh, 12, &BakeOptions { exact_only: true, ..one }, &|_, _| {}).unwrap();
        assert_eq!(a, b);
        assert_eq!(a, c);
        assert!(sa.exact_pairs < sa.pairs / 20);
        assert_eq!(sc.exact_pairs, sc.pairs - a.surface_count() as u64);
    }

    #[test]
    fn progress_reaches_the_total() {
        let mesh = procedural::cube(1.0).unwrap();
        let calls = Mutex::new(Vec::new());
        let progress = |done: usize, total: usize| calls.lock().unwrap().push((done, total));
        let (lut, stats) =
            bake(&mesh, 5, &BakeOptions { threads: 2, ..BakeOptions::default() }, &progress).unwrap();
        let calls = calls.into_inner().unwrap();
        let total = stats.pairs as usize;
        assert_eq!(calls.len(), lut.surface_count() + 1);
        assert!(calls.iter().all(|&(d, t)| t == total && d <= total));
        assert_eq!(*calls.last().unwrap(), (total, total));
    }
}
