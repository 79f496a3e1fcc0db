//! The bake's fast path: the inside fraction of a segment between two voxel centres from the
//! triangles listed in the voxels the segment passes through, instead of a full-line BVH query.
//!
//! - Every triangle is listed in each voxel its (slightly padded) box overlaps (separating-axis
//!   test, Akenine-Möller), so every crossing of a segment lies in a listed voxel it visits.
//! - The segment's voxels come from a 3D DDA (Amanatides & Woo) specialized to voxel-centre ends:
//!   axis a's k-th boundary is at t = (½ + k)/|Δa|, each axis steps exactly |Δa| times.
//! - Per row (all segments from one centre p) the plane distances (p − a)·n of every triangle are
//!   computed once.
//! - Each listed triangle is tested once per segment: both ends clearly on one side of its plane
//!   → no crossing; otherwise the crossing point's in-triangle test must be clear too.
//! - The winding starts at the row-cast winding of the first centre and must end at that of the
//!   second.
//!
//! Anything not clear by a wide margin (an end within 1e-10 of the mesh size from a triangle's
//! plane, a crossing within 1e-9 of an edge, a segment nearly in a triangle's plane, a degenerate
//! triangle, a winding that does not end where the voxel grid says) returns `None`, and the caller
//! uses `MeshBvh::inside_fraction` (watertight, exact). When this path answers, its crossings are
//! those of the watertight test: every sign it decided is far from rounding.

use glam::DVec3;

use crate::scene::mesh::{is_degenerate, Mesh};

/// Ends closer than this fraction of the mesh diagonal to a triangle's plane are left to the
/// exact path.
const PLANE_TOLERANCE: f64 = 1e-10;
/// Crossings closer than this fraction of the mesh diagonal to a triangle's edge line likewise.
const EDGE_TOLERANCE: f64 = 1e-9;
/// Relative padding of the cell boxes triangles are listed in.
const BOX_PAD: f64 = 1e-6;

#[derive(Clone, Copy, Debug)]
struct Tri {
    /// First corner; everything else is relative to it.
    a: DVec3,
    /// Unnormalized counter-clockwise normal (b − a) × (c − a).
    n: DVec3,
    /// In-plane inward edge normals n × (v − u) for the edges a→b, b→c, c→a: a point x of the
    /// plane is inside when every (x − a)·m[k] − o[k] > 0.
    m: [DVec3; 3],
    /// (u − a)·m[k] for each edge's start u (o[0] = 0).
    o: [f64; 3],
    /// |n|·diagonal·PLANE_TOLERANCE: the plane-distance margin in units of n.
    plane_tol: f64,
    /// |m[k]|·diagonal·EDGE_TOLERANCE: the edge-function margins.
    edge_tol: [f64; 3],
    degenerate: bool,
}

impl Tri {
    fn new(a: DVec3, b: DVec3, c: DVec3, diagonal: f64) -> Tri {
        let n = (b - a).cross(c - a);
        let m = [n.cross(b - a), n.cross(c - b), n.cross(a - c)];
        Tri {
            a,
            n,
            m,
            o: [0.0, (b - a).dot(m[1]), (c - a).dot(m[2])],
            plane_tol: n.length() * diagonal * PLANE_TOLERANCE,
            edge_tol: m.map(|m| m.length() * diagonal * EDGE_TOLERANCE),
            degenerate: is_degenerate(a, b, c),
        }
    }
}

/// Triangles per voxel (compressed rows) and the triangles' precomputed data.
pub(super) struct SegmentTracer {
    dims: [u32; 3],
    origin: DVec3,
    h: f64,
    tris: Vec<Tri>,
    cell_start: Vec<u32>,
    cell_tris: Vec<u32>,
}

/// Per-thread scratch: which triangles this segment has tested, its crossings, and per triangle
/// the start point relative to the triangle for the current row (all segments of a row start at
/// the same voxel centre).
pub(super) struct Scratch {
    stamp: Vec<u32>,
    current: u32,
    hits: Vec<(f64, i32)>,
    row: Option<[u32; 3]>,
    /// p − a and (p − a)·n per triangle.
    start: Vec<(DVec3, f64)>,
}

impl SegmentTracer {
    pub fn new(mesh: &Mesh, dims: [u32; 3], origin: DVec3, h: f64) -> SegmentTracer {
        let (lo, hi) = mesh.bounds();
        let diagonal = (hi - lo).length().max(f64::MIN_POSITIVE);
        let corners: Vec<[DVec3; 3]> =
            (0..mesh.triangle_count()).map(|t| mesh.triangle(t).map(|i| mesh.position(i))).collect();
        let tris: Vec<Tri> = corners.iter().map(|&[a, b, c]| Tri::new(a, b, c, diagonal)).collect();
        let voxels = dims.iter().map(|&d| d as usize).product::<usize>();
        let mut counts = vec![0u32; voxels + 1];
        for_each_overlap(&corners, dims, origin, h, |_, v| counts[v] += 1);
        let mut cell_start = Vec::with_capacity(voxels + 1);
        let mut sum = 0u32;
        for c in &counts[..voxels] {
            cell_start.push(sum);
            sum += c;
        }
        cell_start.push(sum);
        let mut fill = cell_start.clone();
        let mut cell_tris = vec![0u32; sum as usize];
        for_each_overlap(&corners, dims, origin, h, |t, v| {
            cell_tris[fill[v] as usize] = t as u32;
            fill[v] += 1;
        });
        SegmentTracer { dims, origin, h, tris, cell_start, cell_tris }
    }

    pub fn scratch(&self) -> Scratch {
        Scratch {
            stamp: vec![u32::MAX; self.tris.len()],
            current: 0,
            hits: Vec::with_capacity(64),
            row: None,
            start: vec![(DVec3::ZERO, 0.0); self.tris.len()],
        }
    }

    /// The inside fraction of the segment between the centres of voxels `from` and `to`, whose
    /// row-cast windings are `w_from` and `w_to`; `None` when any decision is near rounding.
    pub fn fraction(
        &self,
        from: [u32; 3],
        to: [u32; 3],
        w_from: i32,
        w_to: i32,
        s: &mut Scratch,
    ) -> Option<f64> {
        let p = self.centre(from);
        let d = self.centre(to) - p;
        if s.row != Some(from) {
            for (slot, tri) in s.start.iter_mut().zip(&self.tris) {
                let pa = p - tri.a;
                *slot = (pa, pa.dot(tri.n));
            }
            s.row = Some(from);
        }
        s.current = s.current.wrapping_add(1);
        if s.current == u32::MAX {
            // Stamps wrapped: forget them all.
            s.stamp.fill(u32::MAX);
            s.current = 0;
        }
        s.hits.clear();
        let mut ok = true;
        self.walk(from, to, |v| {
            let (lo, hi) = (self.cell_start[v], self.cell_start[v + 1]);
            if lo == hi {
                return true;
            }
            ok = self.test_cell(lo as usize, hi as usize, d, s);
            ok
        });
        if !ok {
            return None;
        }
        s.hits.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let mut winding = w_from;
        let mut from_t = 0.0;
        let mut inside = 0.0f64;
        for &(t, step) in &s.hits {
            if winding > 0 {
                inside += t - from_t;
            }
            winding += step;
            from_t = t;
        }
        if winding > 0 {
            inside += 1.0 - from_t;
        }
        (winding == w_to).then_some(inside.clamp(0.0, 1.0))
    }

    /// Tests the not yet tested triangles of one voxel's list; false when one is unclear.
    fn test_cell(&self, lo: usize, hi: usize, d: DVec3, s: &mut Scratch) -> bool {
        for &t in &self.cell_tris[lo..hi] {
            let t = t as usize;
            if s.stamp[t] == s.current {
                continue;
            }
            s.stamp[t] = s.current;
            let (pa, sp) = s.start[t];
            match crossing(&self.tris[t], pa, sp, d) {
                Hit::None => {}
                Hit::At(t, step) => s.hits.push((t, step)),
                Hit::Unclear => return false,
            }
        }
        true
    }

    fn centre(&self, [x, y, z]: [u32; 3]) -> DVec3 {
        self.origin + (DVec3::new(x as f64, y as f64, z as f64) + 0.5) * self.h
    }

    /// Visits the linear indices of the voxels from `from` to `to` in order, 6-connected: exactly
    /// |Δx| + |Δy| + |Δz| steps, each axis exactly |Δ| times. Both ends are voxel centres, so the
    /// k-th boundary of axis a is at t = (½ + k)/|Δa|. At an edge or corner pass (or rounding near
    /// one) the order of the axes may add a voxel the segment touches only within rounding of a
    /// point, which the padded triangle lists make harmless. Stops when `visit` returns false.
    #[inline(always)]
    fn walk(&self, from: [u32; 3], to: [u32; 3], mut visit: impl FnMut(usize) -> bool) {
        let stride = [1i64, self.dims[0] as i64, self.dims[0] as i64 * self.dims[1] as i64];
        let mut tmax = [f64::INFINITY; 3];
        let mut tdelta = [0.0; 3];
        let mut step = [0i64; 3];
        let mut total = 0;
        let mut index = 0i64;
        for a in 0..3 {
            index += from[a] as i64 * stride[a];
            if to[a] != from[a] {
                let span = to[a].abs_diff(from[a]);
                tmax[a] = 0.5 / span as f64;
                tdelta[a] = 1.0 / span as f64;
                step[a] = if to[a] > from[a] { stride[a] } else { -stride[a] };
                total += span;
            }
        }
        if !visit(index as usize) {
            return;
        }
        // After its last step an axis's next boundary is at (|Δ| + ½)/|Δ| > 1, beyond every other
        // axis's pending one (< 1), so it is never picked again before the walk ends.
        let [mut t0, mut t1, mut t2] = tmax;
        for _ in 0..total {
            if t0 <= t1 && t0 <= t2 {
                index += step[0];
                t0 += tdelta[0];
            } else if t1 <= t2 {
                index += step[1];
                t1 += tdelta[1];
            } else {
                index += step[2];
                t2 += tdelta[2];
            }
            if !visit(index as usize) {
                return;
            }
        }
    }
}

enum Hit {
    None,
    /// Crossing at t with winding step +1 (entering) or −1 (leaving).
    At(f64, i32),
    Unclear,
}

/// The crossing of the segment p → p + d with `tri`, given pa = p − a and sp = pa·n.
fn crossing(tri: &Tri, pa: DVec3, sp: f64, d: DVec3) -> Hit {
    let sq = sp + d.dot(tri.n);
    let tol = tri.plane_tol;
    if (sp > tol && sq > tol) || (sp < -tol && sq < -tol) {
        return Hit::None;
    }
    if tri.degenerate || sp.abs() <= tol || sq.abs() <= tol {
        return Hit::Unclear;
    }
    // Opposite sides, both clearly: the plane is crossed once, at a well-conditioned t.
    let t = sp / (sp - sq);
    let xa = pa + d * t;
    let mut unclear = false;
    for k in 0..3 {
        let e = xa.dot(tri.m[k]) - tri.o[k];
        if e < -tri.edge_tol[k] {
            return Hit::None;
        }
        unclear |= e <= tri.edge_tol[k];
    }
    if unclear {
        return Hit::Unclear;
    }
    // d runs against n (sq < sp): into the solid.
    Hit::At(t, if sp > sq { 1 } else { -1 })
}

/// Calls `f(triangle, voxel)` for every voxel whose padded box overlaps the triangle.
fn for_each_overlap(
    tris: &[[DVec3; 3]],
    dims: [u32; 3],
    origin: DVec3,
    h: f64,
    mut f: impl FnMut(usize, usize),
) {
    let half = DVec3::splat(0.5 * h * (1.0 + BOX_PAD));
    for (t, &[a, b, c]) in tris.iter().enumerate() {
        let lo = a.min(b).min(c);
        let hi = a.max(b).max(c);
        let cell = |p: DVec3, round_down: bool| {
            [0, 1, 2].map(|k| {
                let g = (p[k] - origin[k]) / h;
                let g = if round_down { (g - BOX_PAD).floor() } else { (g + BOX_PAD).floor() };
                (g.max(0.0) as u32).min(dims[k] - 1)
            })
        };
        let (c0, c1) = (cell(lo, true), cell(hi, false));
        for z in c0[2]..=c1[2] {
            for y in c0[1]..=c1[1] {
                for x in c0[0]..=c1[0] {
                    let centre = origin + (DVec3::new(x as f64, y as f64, z as f64) + 0.5) * h;
                    if tri_box_overlap(centre, half, [a, b, c]) {
                        f(t, x as usize + dims[0] as usize * (y as usize + dims[1] as usize * z as usize));
                    }
                }
            }
        }
    }
}

/// Separating-axis test of a triangle against an axis-aligned box (Akenine-Möller 2001): the 3
/// box normals, the triangle normal and the 9 edge cross products. True when no axis separates.
fn tri_box_overlap(centre: DVec3, half: DVec3, tri: [DVec3; 3]) -> bool {
    let v = tri.map(|p| p - centre);
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let separated = |axis: DVec3| {
        if axis == DVec3::ZERO {
            return false;
        }
        let p = v.map(|x| x.dot(axis));
        let r = half.x * axis.x.abs() + half.y * axis.y.abs() + half.z * axis.z.abs();
        p.iter().copied().fold(f64::INFINITY, f64::min) > r
            || p.iter().copied().fold(f64::NEG_INFINITY, f64::max) < -r
    };
    for a in [DVec3::X, DVec3::Y, DVec3::Z] {
        if separated(a) {
            return false;
        }
    }
    if separated(edges[0].cross(edges[1])) {
        return false;
    }
    for e in edges {
        for a in [DVec3::X, DVec3::Y, DVec3::Z] {
            if separated(e.cross(a)) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_overlap_basics() {
        let half = DVec3::splat(0.5);
        let inside = [DVec3::new(-0.1, 0.0, 0.0), DVec3::new(0.1, 0.0, 0.0), DVec3::new(0.0, 0.1, 0.0)];
        assert!(tri_box_overlap(DVec3::ZERO, half, inside));
        // Large triangle cutting through the box.
        let big = [DVec3::new(-5.0, -5.0, 0.0), DVec3::new(5.0, -5.0, 0.0), DVec3::new(0.0, 5.0, 0.0)];
        assert!(tri_box_overlap(DVec3::ZERO, half, big));
        // Same triangle's plane moved away.
        let away = big.map(|p| p + DVec3::new(0.0, 0.0, 0.6));
        assert!(!tri_box_overlap(DVec3::ZERO, half, away));
        // Diagonal triangle whose box overlaps but which passes beside the corner.
        // Edge x + y = 1.5 passes beside the box's corner (x + y = 1) though the boxes overlap.
        let beside = [DVec3::new(-1.0, 2.5, 0.0), DVec3::new(2.5, -1.0, 0.0), DVec3::new(2.5, 2.5, 0.0)];
        assert!(!tri_box_overlap(DVec3::ZERO, half, beside));
        let corner = [DVec3::new(-1.0, 1.5, 0.0), DVec3::new(1.5, -1.0, 0.0), DVec3::new(2.5, 2.5, 0.0)];
        assert!(tri_box_overlap(DVec3::ZERO, half, corner));
    }

    #[test]
    fn walk_is_six_connected_and_covers_the_segment() {
        let mesh = crate::scene::procedural::cube(1.0).unwrap();
        let t = SegmentTracer::new(&mesh, [10, 10, 10], DVec3::ZERO, 1.0);
        let ends =
            [([0, 0, 0], [9, 9, 9]), ([9, 2, 3], [1, 7, 0]), ([4, 4, 4], [4, 4, 4]), ([0, 5, 0], [3, 5, 9])];
        for (from, to) in ends {
            let mut path = Vec::new();
            t.walk(from, to, |v| {
                path.push([v % 10, v / 10 % 10, v / 100]);
                true
            });
            assert_eq!(path[0], from.map(|c| c as usize));
            assert_eq!(*path.last().unwrap(), to.map(|c| c as usize));
            for w in path.windows(2) {
                let d: usize = (0..3).map(|a| w[0][a].abs_diff(w[1][a])).sum();
                assert_eq!(d, 1);
            }
            // Every voxel the segment passes through (sampled densely) is on the path.
            let (p, q) = (t.centre(from), t.centre(to));
            for k in 0..=1000 {
                let x = p + (q - p) * (k as f64 / 1000.0);
                let v = [0, 1, 2].map(|a| x[a].floor() as usize);
                assert!(path.contains(&v), "{from:?}→{to:?}: {v:?} at {k} missing");
            }
        }
    }
}
