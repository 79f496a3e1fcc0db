//! CPU ray casting in f64: the reference GPU raster depth is checked against, and the exact
//! thickness reference of the translucency bake (DESIGN.md, "Thickness LUT").
//!
//! Each mesh gets a BVH (binned SAH, built once) over f64 copies of its f32 positions. Triangles
//! are tested with the watertight ray/triangle test of Woop, Benthin & Wald (JCGT 2013) in f64.
//! Where the paper falls back to higher precision for an edge function that rounds to zero, this
//! version recomputes any edge function within rounding of zero with an FMA difference of products,
//! so every sign is exact for the (rounded, but per-vertex deterministic) projected corners, and
//! breaks exact zeros by simulation of simplicity: the ray is treated as if shifted by (ε, ε²) in
//! the projected plane. The tie-break depends only on the edge's projected end points, so the two
//! triangles sharing an edge never both claim it, and the whole classification is that of one real,
//! infinitesimally shifted ray: a line through an edge or a vertex of a closed mesh crosses it an
//! even number of times, entering and leaving in turn (see `crossings_in` for equal-t ordering).
//! Without the tie-break the tests below fail (edge and vertex hits count twice).

mod closest;

use glam::DVec3;

use crate::scene::mesh::{Mesh, MeshError};
use crate::scene::transform::Transform;

/// The nearest hit on one mesh, in the mesh's object space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshHit {
    /// Ray parameter: origin + t·dir (a distance when dir is unit).
    pub t: f64,
    pub triangle: usize,
    /// Unit normal of the triangle's counter-clockwise winding, whichever way the ray comes from.
    pub geometric_normal: DVec3,
}

/// One crossing of a line through a mesh surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    pub t: f64,
    /// The ray runs against the triangle's counter-clockwise normal: it goes into the solid.
    pub entering: bool,
    pub triangle: usize,
}

/// A hit in a scene of instances, in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneHit {
    /// World distance along the (normalized) world ray.
    pub t: f64,
    pub instance: usize,
    pub triangle: usize,
    /// World-space unit geometric normal (M⁻ᵀ·n, renormalized), counter-clockwise side.
    pub normal: DVec3,
}

/// Relative t difference below which crossings count as one point for `crossings_in` ordering.
pub const TIE_TOLERANCE: f64 = 1e-12;
/// Triangles per leaf at most, unless they cannot be separated (identical centroids).
const MAX_LEAF: usize = 4;
const SAH_BINS: usize = 16;
/// Relative widening of slab intervals: the slab arithmetic rounds 3 times (≈ 7e-16 relative),
/// so boxes never cull a triangle the (consistent but rounded) triangle test would hit.
const SLAB_PAD: f64 = 1e-12;

#[derive(Clone, Copy, Debug)]
struct Node {
    min: DVec3,
    max: DVec3,
    /// Leaf: first index into `order`; interior: index of the left child (the right follows).
    start: u32,
    /// Triangles in the leaf; 0 for an interior node.
    count: u32,
}

/// A mesh prepared for ray casting: f64 positions and a BVH over its triangles.
#[derive(Clone, Debug)]
pub struct MeshBvh {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    /// Triangle ids in leaf order.
    order: Vec<u32>,
    nodes: Vec<Node>,
}

impl MeshBvh {
    /// Builds the BVH. Refuses meshes whose index count is not a multiple of 3, whose indices are
    /// out of range, or whose positions are not finite; degenerate triangles are fine (never hit).
    pub fn new(mesh: &Mesh) -> Result<MeshBvh, MeshError> {
        check_mesh(mesh)?;
        let positions: Vec<DVec3> = (0..mesh.positions.len()).map(|i| mesh.position(i)).collect();
        let triangles: Vec<[u32; 3]> = mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        let mut bvh = MeshBvh { positions, triangles, order: Vec::new(), nodes: Vec::new() };
        bvh.build();
        Ok(bvh)
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Bounds of all triangles (zero for a mesh without triangles).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.nodes.first().map_or((DVec3::ZERO, DVec3::ZERO), |n| (n.min, n.max))
    }

    /// The nearest hit with t_min < t ≤ t_max (ties go to the lowest triangle index). `dir` need
    /// not be unit (t is in multiples of it) but must be finite and non-zero; otherwise `None`.
    pub fn intersect(&self, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> Option<MeshHit> {
        let ray = Ray::new(origin, dir)?;
        let mut best: Option<(f64, usize)> = None;
        self.traverse(&ray, t_min, t_max, |tri, t, _| {
            let closer = best.is_none_or(|(bt, bi)| t < bt || (t == bt && tri < bi));
            if t > t_min && t <= t_max && closer {
                best = Some((t, tri));
            }
            best.map_or(t_max, |(bt, _)| bt)
        });
        best.map(|(t, triangle)| MeshHit { t, triangle, geometric_normal: self.triangle_normal(triangle) })
    }

    /// Every crossing of the whole line origin + t·dir, t ∈ (−∞, ∞), sorted as `crossings_in`.
    /// The line starts and ends outside every closed mesh, so inside intervals follow by parity
    /// (or by the `entering` flags for overlapping solids).
    pub fn crossings(&self, origin: DVec3, dir: DVec3) -> Vec<Crossing> {
        self.crossings_in(origin, dir, f64::NEG_INFINITY, f64::INFINITY)
    }

    /// The crossings with t_min ≤ t ≤ t_max, sorted by t. Crossings of one point computed from
    /// different triangles can differ in t by rounding (a line touching the surface at a vertex
    /// may come out "leave at 3 − 4e-16, enter at 3"): within a run whose t agree to `TIE_TOLERANCE`
    /// (relative to |t| + the mesh size in t units) the flags and triangles are reordered so
    /// entering and leaving alternate, starting from outside at t_min, while the t values stay
    /// sorted.
    pub fn crossings_in(&self, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> Vec<Crossing> {
        let Some(ray) = Ray::new(origin, dir) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        self.traverse(&ray, t_min, t_max, |triangle, t, entering| {
            if (t_min..=t_max).contains(&t) {
                out.push(Crossing { t, entering, triangle });
            }
            t_max
        });
        out.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
        let (lo, hi) = self.bounds();
        order_ties(&mut out, (hi - lo).length() / ray.dir.length());
        out
    }

    /// The fraction of the segment p → q inside the solid (winding number > 0 along the whole
    /// line, so cavities and overlapping closed parts come out right): the quantity the thickness
    /// LUT stores. 0 for p = q or a non-finite segment.
    pub fn inside_fraction(&self, p: DVec3, q: DVec3) -> f64 {
        // With dir = q − p the segment is t ∈ [0, 1].
        let mut winding = 0i64;
        let mut from = f64::NEG_INFINITY;
        let mut inside = 0.0;
        for x in self.crossings(p, q - p) {
            if winding > 0 {
                inside += (x.t.min(1.0) - from.max(0.0)).max(0.0);
            }
            winding += if x.entering { 1 } else { -1 };
            from = x.t;
        }
        inside.clamp(0.0, 1.0)
    }

    /// Unit normal of triangle `t`'s counter-clockwise winding (zero for a degenerate one).
    pub fn triangle_normal(&self, t: usize) -> DVec3 {
        let [a, b, c] = self.corners(t);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// The corners of triangle `t` (f64 copies of the mesh's positions).
    pub fn triangle_corners(&self, t: usize) -> [DVec3; 3] {
        self.corners(t)
    }

    fn corners(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    /// Visits every triangle hit in leaves whose boxes overlap [t_min, t_hi], nearest box first;
    /// `visit(triangle, t, entering)` returns the new t_hi (a nearest-hit search shrinks it).
    fn traverse(&self, ray: &Ray, t_min: f64, t_max: f64, mut visit: impl FnMut(usize, f64, bool) -> f64) {
        let mut t_hi = t_max;
        let ordered = t_min <= t_hi; // false for NaN bounds too
        if self.nodes.is_empty() || !ordered {
            return;
        }
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if ray.slab(node, t_min, t_hi).is_none() {
                continue;
            }
            if node.count > 0 {
                let leaf = &self.order[node.start as usize..(node.start + node.count) as usize];
                for &tri in leaf {
                    if let Some((t, entering)) = ray.triangle(self.corners(tri as usize)) {
                        t_hi = visit(tri as usize, t, entering);
                    }
                }
                continue;
            }
            let (l, r) = (node.start, node.start + 1);
            let tl = ray.slab(&self.nodes[l as usize], t_min, t_hi);
            let tr = ray.slab(&self.nodes[r as usize], t_min, t_hi);
            // Push the far child first so the near one is popped (and can shrink t_hi) first.
            match (tl, tr) {
                (Some(a), Some(b)) if a <= b => stack.extend([r, l]),
                (Some(_), Some(_)) => stack.extend([l, r]),
                (Some(_), None) => stack.push(l),
                (None, Some(_)) => stack.push(r),
                (None, None) => {}
            }
        }
    }
}

/// Reorders runs of (nearly) equal t so the flags alternate; see `MeshBvh::crossings_in`.
fn order_ties(c: &mut [Crossing], scale: f64) {
    let mut winding = 0i64;
    let mut i = 0;
    while i < c.len() {
        let mut j = i + 1;
        while j < c.len() && c[j].t - c[j - 1].t <= TIE_TOLERANCE * (c[j].t.abs() + scale) {
            j += 1;
        }
        let group = &mut c[i..j];
        let times: Vec<f64> = group.iter().map(|x| x.t).collect();
        let (mut enters, mut leaves): (Vec<Crossing>, Vec<Crossing>) = group.iter().partition(|x| x.entering);
        enters.reverse();
        leaves.reverse();
        for (slot, t) in group.iter_mut().zip(times) {
            // Enter while outside (or when only entries are left), leave while inside.
            let take_enter = (winding <= 0 && !enters.is_empty()) || leaves.is_empty();
            let next = if take_enter { enters.pop() } else { leaves.pop() };
            if let Some(x) = next {
                winding += if x.entering { 1 } else { -1 };
                *slot = Crossing { t, ..x };
            }
        }
        i = j;
    }
}

fn check_mesh(mesh: &Mesh) -> Result<(), MeshError> {
    if mesh.indices.len() % 3 != 0 {
        let n = mesh.indices.len();
        return Err(MeshError::Invalid(format!("ray casting: index count {n} is not a multiple of 3")));
    }
    let count = mesh.positions.len();
    if let Some(&i) = mesh.indices.iter().find(|&&i| i as usize >= count) {
        return Err(MeshError::Invalid(format!("ray casting: index {i} out of range for {count} positions")));
    }
    if let Some(i) = mesh.positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(MeshError::Invalid(format!("ray casting: position {i} is not finite")));
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// BVH construction (binned SAH)

/// A triangle's box and centroid, for building.
#[derive(Clone, Copy)]
struct Prim {
    min: DVec3,
    max: DVec3,
    centroid: DVec3,
}

impl MeshBvh {
    fn build(&mut self) {
        let n = self.triangles.len();
        if n == 0 {
            return;
        }
        let prims: Vec<Prim> = (0..n)
            .map(|t| {
                let [a, b, c] = self.corners(t);
                let (min, max) = (a.min(b).min(c), a.max(b).max(c));
                Prim { min, max, centroid: (min + max) * 0.5 }
            })
            .collect();
        self.order = (0..n as u32).collect();
        self.nodes = Vec::with_capacity(2 * n / MAX_LEAF + 1);
        self.nodes.push(leaf(&prims, &self.order, 0, n));
        let mut todo = vec![0usize];
        while let Some(i) = todo.pop() {
            let (start, count) = (self.nodes[i].start as usize, self.nodes[i].count as usize);
            let Some(mid) = split(&prims, &mut self.order[start..start + count]) else {
                continue;
            };
            let left = self.nodes.len();
            self.nodes.push(leaf(&prims, &self.order, start, mid));
            self.nodes.push(leaf(&prims, &self.order, start + mid, count - mid));
            self.nodes[i].start = left as u32;
            self.nodes[i].count = 0;
            todo.extend([left, left + 1]);
        }
    }
}

/// A leaf over order[start..start+count] with its (slightly widened) bounds.
fn leaf(prims: &[Prim], order: &[u32], start: usize, count: usize) -> Node {
    let mut min = DVec3::splat(f64::INFINITY);
    let mut max = DVec3::splat(f64::NEG_INFINITY);
    for &t in &order[start..start + count] {
        min = min.min(prims[t as usize].min);
        max = max.max(prims[t as usize].max);
    }
    // Widen by a hair of the box's own scale so rays grazing a face are never culled by rounding.
    let pad = (max - min).max_element().max(min.abs().max(max.abs()).max_element()) * SLAB_PAD;
    Node { min: min - pad, max: max + pad, start: start as u32, count: count as u32 }
}

/// Partitions `order` for a split; returns the size of the left part, or `None` to keep a leaf.
fn split(prims: &[Prim], order: &mut [u32]) -> Option<usize> {
    if order.len() <= MAX_LEAF {
        return None;
    }
    let (cmin, cmax) =
        order.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), &t| {
            (lo.min(prims[t as usize].centroid), hi.max(prims[t as usize].centroid))
        });
    let extent = cmax - cmin;
    if extent.max_element() <= 0.0 {
        // All centroids coincide: no plane separates them.
        return None;
    }
    let (axis, bin) =
        best_sah_split(prims, order, cmin, extent).unwrap_or_else(|| (extent.max_position(), SAH_BINS / 2));
    let mid = partition(order, |t| bin_of(prims[t as usize].centroid[axis], cmin[axis], extent[axis]) < bin);
    if mid == 0 || mid == order.len() {
        // Binning could not separate them: fall back to a median split on the widest axis.
        let axis = extent.max_position();
        let half = order.len() / 2;
        order.select_nth_unstable_by(half, |&a, &b| {
            prims[a as usize].centroid[axis].total_cmp(&prims[b as usize].centroid[axis])
        });
        return Some(half);
    }
    Some(mid)
}

fn bin_of(c: f64, min: f64, extent: f64) -> usize {
    if extent <= 0.0 {
        return 0;
    }
    (((c - min) / extent * SAH_BINS as f64) as usize).min(SAH_BINS - 1)
}

/// The (axis, first right bin) of least surface-area cost over all axes and bin boundaries.
fn best_sah_split(prims: &[Prim], order: &[u32], cmin: DVec3, extent: DVec3) -> Option<(usize, usize)> {
    let mut best: Option<(f64, usize, usize)> = None;
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let mut bins = [(0usize, Bounds::EMPTY); SAH_BINS];
        for &t in order {
            let p = &prims[t as usize];
            let b = &mut bins[bin_of(p.centroid[axis], cmin[axis], extent[axis])];
            b.0 += 1;
            b.1 = b.1.grow(p.min, p.max);
        }
        // Sweep from the right to get the right-side cost of each boundary, then from the left.
        let mut right_cost = [0.0; SAH_BINS];
        let (mut n, mut bounds) = (0usize, Bounds::EMPTY);
        for k in (1..SAH_BINS).rev() {
            n += bins[k].0;
            bounds = bounds.merge(bins[k].1);
            right_cost[k] = n as f64 * bounds.area();
        }
        let (mut n, mut bounds) = (0usize, Bounds::EMPTY);
        for k in 1..SAH_BINS {
            n += bins[k - 1].0;
            bounds = bounds.merge(bins[k - 1].1);
            let cost = n as f64 * bounds.area() + right_cost[k];
            if n > 0 && n < order.len() && best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, k));
            }
        }
    }
    best.map(|(_, axis, bin)| (axis, bin))
}

/// Moves the items where `left` holds to the front; returns how many there are.
fn partition(order: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut mid = 0;
    for i in 0..order.len() {
        if left(order[i]) {
            order.swap(i, mid);
            mid += 1;
        }
    }
    mid
}

#[derive(Clone, Copy)]
struct Bounds {
    min: DVec3,
    max: DVec3,
}

impl Bounds {
    const EMPTY: Bounds = Bounds { min: DVec3::splat(f64::INFINITY), max: DVec3::splat(f64::NEG_INFINITY) };

    fn grow(self, min: DVec3, max: DVec3) -> Bounds {
        Bounds { min: self.min.min(min), max: self.max.max(max) }
    }

    fn merge(self, o: Bounds) -> Bounds {
        self.grow(o.min, o.max)
    }

    fn area(self) -> f64 {
        let d = self.max - self.min;
        if d.min_element() < 0.0 {
            return 0.0;
        }
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

// ---------------------------------------------------------------------------------------------
// The ray and the watertight triangle test

/// A ray with what the slab and triangle tests precompute.
struct Ray {
    origin: DVec3,
    dir: DVec3,
    inv: DVec3,
    /// Woop et al.: kz is the dominant axis; kx, ky keep the winding (swapped when dir[kz] < 0).
    k: [usize; 3],
    shear: DVec3,
}

impl Ray {
    fn new(origin: DVec3, dir: DVec3) -> Option<Ray> {
        if !origin.is_finite() || !dir.is_finite() || dir == DVec3::ZERO {
            return None;
        }
        let kz = dir.abs().max_position();
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let shear = DVec3::new(dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
        Some(Ray { origin, dir, inv: dir.recip(), k: [kx, ky, kz], shear })
    }

    /// The entry t of the ray into the node's box within [t_lo, t_hi], widened by `SLAB_PAD`.
    fn slab(&self, node: &Node, t_lo: f64, t_hi: f64) -> Option<f64> {
        let (mut near, mut far) = (t_lo, t_hi);
        for a in 0..3 {
            if self.dir[a] == 0.0 {
                // Parallel to the slab: inside it or never (avoids 0·∞ = NaN).
                if self.origin[a] < node.min[a] || self.origin[a] > node.max[a] {
                    return None;
                }
                continue;
            }
            let t0 = (node.min[a] - self.origin[a]) * self.inv[a];
            let t1 = (node.max[a] - self.origin[a]) * self.inv[a];
            let (lo, hi) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
            near = near.max(lo - lo.abs() * SLAB_PAD);
            far = far.min(hi + hi.abs() * SLAB_PAD);
        }
        (near <= far).then_some(near)
    }

    /// Watertight ray/triangle test: (t, entering) or `None`. Triangles seen edge-on (zero
    /// projected area) are never hit.
    fn triangle(&self, [a, b, c]: [DVec3; 3]) -> Option<(f64, bool)> {
        let [kx, ky, kz] = self.k;
        let project = |p: DVec3| {
            let q = p - self.origin;
            (q[kx] - self.shear.x * q[kz], q[ky] - self.shear.y * q[kz], q[kz] * self.shear.z)
        };
        let (pa, pb, pc) = (project(a), project(b), project(c));
        let xy = |p: (f64, f64, f64)| (p.0, p.1);
        let u = edge_function(xy(pb), xy(pc));
        let v = edge_function(xy(pc), xy(pa));
        let w = edge_function(xy(pa), xy(pb));
        let signs = [u.1, v.1, w.1];
        if signs.contains(&-1) && signs.contains(&1) {
            return None;
        }
        let det = u.0 + v.0 + w.0;
        if det == 0.0 {
            return None;
        }
        let t = (u.0 * pa.2 + v.0 * pb.2 + w.0 * pc.2) / det;
        // det > 0: the triangle winds counter-clockwise as the ray sees it, i.e. it faces the ray.
        t.is_finite().then_some((t, det > 0.0))
    }
}

/// Rounding bound for a·b − c·d from rounded products: below 4u·(|ab| + |cd|) the sign of the
/// rounded difference is not trustworthy.
const EDGE_ERROR_BOUND: f64 = 4.0 * f64::EPSILON / 2.0;

/// The edge function of the directed edge p → q at the projected ray (the origin): value and sign
/// (−1, 0, 1). The sign is exact; 0 only for an edge that projects to a point.
fn edge_function(p: (f64, f64), q: (f64, f64)) -> (f64, i8) {
    let (x, y) = (q.0 * p.1, q.1 * p.0);
    let f = x - y;
    if f.abs() > EDGE_ERROR_BOUND * (x.abs() + y.abs()) {
        return (f, sign(f));
    }
    let exact = difference_of_products(q.0, p.1, q.1, p.0);
    if exact != 0.0 {
        return (exact, sign(exact));
    }
    // The projected ray lies exactly on the edge's line: decide as if it were shifted by (ε, ε²),
    // f + ε·(q.y − p.y) + ε²·(p.x − q.x). Swapping p and q flips the answer, so the two triangles
    // of a shared edge never both claim it. Differences of floats have exact signs.
    let tie = match sign(q.1 - p.1) {
        0 => sign(p.0 - q.0),
        s => s,
    };
    (0.0, tie)
}

/// a·b − c·d with one rounding error (Kahan's algorithm with FMA): the sign is exact and the
/// result is zero only when a·b = c·d exactly (barring underflow).
fn difference_of_products(a: f64, b: f64, c: f64, d: f64) -> f64 {
    let cd = c * d;
    let err = (-c).mul_add(d, cd);
    a.mul_add(b, -cd) + err
}

fn sign(v: f64) -> i8 {
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

// ---------------------------------------------------------------------------------------------
// Scenes of instances

#[derive(Clone, Debug)]
struct CastInstance {
    mesh: usize,
    transform: Transform,
    /// World bounding sphere of the instance's transformed mesh box.
    centre: DVec3,
    radius: f64,
}

/// Instances of meshes, each with its transform, ready for world-space ray casts.
#[derive(Clone, Debug)]
pub struct SceneCaster {
    meshes: Vec<MeshBvh>,
    instances: Vec<CastInstance>,
}

impl SceneCaster {
    /// One BVH per mesh; `instances` are (index into `meshes`, transform).
    pub fn new(meshes: &[Mesh], instances: &[(usize, Transform)]) -> Result<SceneCaster, MeshError> {
        let meshes = meshes.iter().map(MeshBvh::new).collect::<Result<Vec<_>, _>>()?;
        let instances = instances
            .iter()
            .enumerate()
            .map(|(i, &(mesh, transform))| {
                let bvh = meshes.get(mesh).ok_or_else(|| {
                    MeshError::Invalid(format!(
                        "instance {i} names mesh {mesh}, but there are {} meshes",
                        meshes.len()
                    ))
                })?;
                let (centre, radius) = world_sphere(bvh, &transform);
                Ok(CastInstance { mesh, transform, centre, radius })
            })
            .collect::<Result<Vec<_>, MeshError>>()?;
        Ok(SceneCaster { meshes, instances })
    }

    pub fn mesh(&self, i: usize) -> Option<&MeshBvh> {
        self.meshes.get(i)
    }

    pub fn instance_count(&self) -> usize {
        self.instances.len()
    }

    /// The nearest hit in front of the origin (0 < t); `dir` is any finite non-zero vector and is
    /// normalized, so t is a world distance.
    pub fn cast(&self, origin: DVec3, dir: DVec3) -> Option<SceneHit> {
        self.cast_range(origin, dir, 0.0, f64::INFINITY)
    }

    /// The nearest hit with t_min < t ≤ t_max in world distance (ties to the lowest instance).
    pub fn cast_range(&self, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> Option<SceneHit> {
        let d = dir.normalize_or_zero();
        if !origin.is_finite() || d == DVec3::ZERO || !d.is_finite() {
            return None;
        }
        let mut best: Option<SceneHit> = None;
        let mut t_hi = t_max;
        for (index, inst) in self.instances.iter().enumerate() {
            if misses_sphere(origin, d, inst.centre, inst.radius, t_min, t_hi) {
                continue;
            }
            let ray = inst.transform.ray_to_object(origin, d);
            let s = ray.t_scale;
            // Object-space t′ = t·s for the same point.
            let Some(hit) = self.meshes[inst.mesh].intersect(ray.origin, ray.dir, t_min * s, t_hi * s) else {
                continue;
            };
            let t = hit.t / s;
            if t > t_min && t <= t_hi && best.is_none_or(|b| t < b.t) {
                let normal = inst.transform.transform_normal(hit.geometric_normal);
                best = Some(SceneHit { t, instance: index, triangle: hit.triangle, normal });
                t_hi = t;
            }
        }
        best
    }
}

/// A sphere around the transformed corners of the mesh's box (which contain the transformed
/// mesh), widened a little for rounding.
fn world_sphere(bvh: &MeshBvh, transform: &Transform) -> (DVec3, f64) {
    let (lo, hi) = bvh.bounds();
    let centre = transform.transform_point((lo + hi) * 0.5);
    let radius = (0..8)
        .map(|k| {
            let corner = DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            (transform.transform_point(corner) - centre).length()
        })
        .fold(0.0, f64::max);
    (centre, radius * (1.0 + 1e-9) + centre.abs().max_element() * 1e-12)
}

/// Whether the unit ray's [t_min, t_max] part certainly misses the sphere.
fn misses_sphere(origin: DVec3, d: DVec3, centre: DVec3, radius: f64, t_min: f64, t_max: f64) -> bool {
    let oc = centre - origin;
    let along = oc.dot(d);
    let off_axis2 = (oc - d * along).length_squared();
    off_axis2 > radius * radius || along + radius < t_min || along - radius > t_max
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural::{cavity_cube, cube, tetrahedron, torus, uv_sphere};
    use crate::scene::transform::TransformOp;
    use std::f64::consts::PI;

    /// Deterministic pseudo-random numbers in [0, 1) (splitmix64).
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }

        fn unit(&mut self) -> DVec3 {
            loop {
                let v = DVec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0;
                if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                    return v.normalize();
                }
            }
        }
    }

    /// Distance to a sphere of radius r at the origin along a unit ray from outside, if hit.
    fn sphere_t(o: DVec3, d: DVec3, r: f64) -> Option<f64> {
        let b = o.dot(d);
        let disc = b * b - (o.length_squared() - r * r);
        (disc >= 0.0).then(|| -b - disc.sqrt())
    }

    #[test]
    fn sphere_hits_lie_between_the_sphere_and_its_inscribed_ball() {
        let (seg, rings) = (48, 24);
        let bvh = MeshBvh::new(&uv_sphere(1.0, seg, rings).unwrap()).unwrap();
        let inner = (PI / seg as f64).cos() * (PI / (2.0 * rings as f64)).cos();
        let mut rng = Rng(7);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = rng.unit() * 3.0;
            let d = (rng.unit() * 0.5 - o).normalize();
            let hit = bvh.intersect(o, d, 0.0, f64::INFINITY);
            match (sphere_t(o, d, 1.0), sphere_t(o, d, inner)) {
                (_, Some(t_in)) => {
                    let h = hit.expect("a ray through the inscribed ball hits the mesh");
                    let t_out = sphere_t(o, d, 1.0).unwrap();
                    assert!(h.t >= t_out - 1e-6 && h.t <= t_in + 1e-6, "{} not in [{t_out}, {t_in}]", h.t);
                    // The normal is within a facet's angular size of the radial direction.
                    let radial = (o + d * h.t).normalize();
                    assert!(h.geometric_normal.dot(radial) > (PI / rings as f64).cos());
                    assert!(h.geometric_normal.dot(d) < 0.0);
                    hits += 1;
                }
                (None, None) => assert!(hit.is_none()),
                (Some(_), None) => {} // grazing the band between mesh and sphere: either way
            }
        }
        assert!(hits > 500);
    }

    #[test]
    fn bvh_matches_brute_force() {
        let mesh = torus(1.0, 0.4, 40, 20).unwrap();
        let bvh = MeshBvh::new(&mesh).unwrap();
        let mut rng = Rng(3);
        for _ in 0..500 {
            let o = rng.unit() * 2.5;
            let d = (rng.unit() * 1.2 - o).normalize();
            let brute = (0..bvh.triangle_count())
                .filter_map(|t| Ray::new(o, d).unwrap().triangle(bvh.corners(t)).map(|(h, _)| (h, t)))
                .filter(|&(h, _)| h > 0.0)
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let hit = bvh.intersect(o, d, 0.0, f64::INFINITY).map(|h| (h.t, h.triangle));
            assert_eq!(hit, brute);
            let all = bvh.crossings(o, d);
            assert_eq!(all.len() % 2, 0);
            assert!(all.windows(2).all(|w| w[0].t <= w[1].t));
        }
    }

    /// Points on the cube's vertices, edges, face diagonals and face centres, with integer
    /// directions, so the lines pass exactly through them.
    fn cube_targets() -> Vec<DVec3> {
        let mut out = Vec::new();
        for x in [-1.0, -0.5, 0.0, 0.5, 1.0] {
            for y in [-1.0, -0.5, 0.0, 0.5, 1.0] {
                for z in [-1.0, -0.5, 0.0, 0.5, 1.0] {
                    let p = DVec3::new(x, y, z);
                    if p.abs().max_element() == 1.0 {
                        out.push(p);
                    }
                }
            }
        }
        out
    }

    fn directions() -> Vec<DVec3> {
        let mut out = Vec::new();
        for x in -2i32..=2 {
            for y in -2i32..=2 {
                for z in -2i32..=2 {
                    if (x, y, z) != (0, 0, 0) {
                        out.push(DVec3::new(x as f64, y as f64, z as f64));
                    }
                }
            }
        }
        out
    }

    /// Crossings of a closed mesh alternate entering and leaving, starting with entering.
    fn assert_alternating(c: &[Crossing], what: &str) {
        assert_eq!(c.len() % 2, 0, "{what}: {c:?}");
        for (k, x) in c.iter().enumerate() {
            assert_eq!(x.entering, k % 2 == 0, "{what}: {c:?}");
        }
    }

    #[test]
    fn lines_through_cube_vertices_and_edges_cross_evenly() {
        let bvh = MeshBvh::new(&cube(2.0).unwrap()).unwrap();
        let mut through = 0;
        for p in cube_targets() {
            for d in directions() {
                let c = bvh.crossings(p - d * 4.0, d);
                assert_alternating(&c, &format!("target {p} dir {d}"));
                assert!(c.len() <= 2, "convex: {c:?}");
                // A line into the interior (the point just past the target is strictly inside)
                // must cross exactly twice.
                let inside = p + d * 1e-3;
                if inside.abs().max_element() < 1.0 {
                    assert_eq!(c.len(), 2, "target {p} dir {d}");
                    through += 1;
                }
            }
        }
        assert!(through > 1000);
    }

    #[test]
    fn lines_through_sphere_vertices_and_poles_cross_evenly() {
        let mesh = uv_sphere(1.0, 12, 6).unwrap();
        let bvh = MeshBvh::new(&mesh).unwrap();
        for i in 0..mesh.positions.len() {
            let p = mesh.position(i);
            for d in directions() {
                let c = bvh.crossings(p - d * 4.0, d);
                assert_alternating(&c, &format!("vertex {i} dir {d}"));
                assert!(c.len() <= 2);
            }
        }
        // Along the axis through both pole fans.
        let c = bvh.crossings(DVec3::new(0.0, -5.0, 0.0), DVec3::Y);
        assert_eq!(c.len(), 2);
        assert_alternating(&c, "axis");
        assert!((c[0].t - 4.0).abs() < 1e-12 && (c[1].t - 6.0).abs() < 1e-12);
    }

    /// Lines in arbitrary directions through every vertex and edge midpoint of a torus and a
    /// cavity cube: the crossing count is even and the flags alternate.
    #[test]
    fn lines_through_vertices_and_edges_in_random_directions() {
        let mut rng = Rng(5);
        for mesh in [torus(1.0, 0.35, 24, 12).unwrap(), cavity_cube(2.0, 0.7, 12, 6).unwrap()] {
            let bvh = MeshBvh::new(&mesh).unwrap();
            for t in 0..mesh.triangle_count() {
                let [a, b, c] = mesh.triangle(t).map(|v| mesh.position(v));
                for p in [a, (a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5] {
                    let d = rng.unit();
                    assert_alternating(
                        &bvh.crossings(p - d * 3.0, d),
                        &format!("triangle {t} at {p} dir {d}"),
                    );
                }
            }
        }
    }

    #[test]
    fn tetrahedron_and_cavity_cross_with_correct_nesting() {
        let tet = tetrahedron(1.0).unwrap();
        let bvh = MeshBvh::new(&tet).unwrap();
        for i in 0..tet.positions.len() {
            for d in directions() {
                let p = tet.position(i);
                assert_alternating(&bvh.crossings(p - d * 3.0, d), "tetrahedron");
            }
        }
        let bvh = MeshBvh::new(&cavity_cube(2.0, 0.5, 16, 8).unwrap()).unwrap();
        let c = bvh.crossings(DVec3::new(0.0, 0.0, -3.0), DVec3::Z);
        let entering: Vec<bool> = c.iter().map(|x| x.entering).collect();
        assert_eq!(entering, [true, false, true, false]);
        assert!((c[0].t - 2.0).abs() < 1e-12 && (c[3].t - 4.0).abs() < 1e-12);
        // Solid length along the line: 2 − (cavity chord), the chord at most the diameter 1 and
        // at least the inscribed ball's.
        let solid = (c[1].t - c[0].t) + (c[3].t - c[2].t);
        assert!(solid > 1.0 - 1e-12 && solid < 1.0 + 0.02, "{solid}");
    }

    #[test]
    fn inside_fraction_of_segments() {
        let bvh = MeshBvh::new(&cube(2.0).unwrap()).unwrap();
        let f = |p: [f64; 3], q: [f64; 3]| bvh.inside_fraction(DVec3::from(p), DVec3::from(q));
        assert!((f([-2.0, 0.0, 0.0], [2.0, 0.0, 0.0]) - 0.5).abs() < 1e-15);
        assert!((f([0.0, 0.0, 0.0], [4.0, 0.0, 0.0]) - 0.25).abs() < 1e-15);
        assert_eq!(f([-0.5, 0.2, 0.1], [0.5, 0.3, 0.0]), 1.0);
        assert_eq!(f([2.0, 0.0, 0.0], [3.0, 0.0, 0.0]), 0.0);
        assert_eq!(f([0.0; 3], [0.0; 3]), 0.0);
        // Through the cavity: the cube's 2 minus the cavity's chord (≤ its diameter 1).
        let bvh = MeshBvh::new(&cavity_cube(2.0, 0.5, 32, 16).unwrap()).unwrap();
        let frac = bvh.inside_fraction(DVec3::new(-0.3, -2.0, 0.1), DVec3::new(0.2, 2.0, -0.1));
        let len = DVec3::new(0.5, 4.0, -0.2).length();
        assert!(frac * len > 1.0 - 1e-12 && frac * len < 2.0, "{frac}");
        let solid = bvh.inside_fraction(DVec3::new(-2.0, 0.0, 0.0), DVec3::new(2.0, 0.0, 0.0)) * 4.0;
        assert!((solid - 1.0).abs() < 0.01, "{solid}");
    }

    #[test]
    fn crossings_in_range_and_degenerate_rays() {
        let bvh = MeshBvh::new(&cube(2.0).unwrap()).unwrap();
        let o = DVec3::new(0.1, 0.2, 0.0);
        let c = bvh.crossings_in(o, DVec3::X, 0.0, f64::INFINITY);
        assert_eq!(c.len(), 1);
        assert!(!c[0].entering && (c[0].t - 0.9).abs() < 1e-15);
        assert_eq!(bvh.crossings(o, DVec3::X).len(), 2);
        assert!(bvh.intersect(o, DVec3::ZERO, 0.0, 1.0).is_none());
        assert!(bvh.intersect(o, DVec3::NAN, 0.0, 1.0).is_none());
        assert!(bvh.intersect(DVec3::INFINITY, DVec3::X, 0.0, 1.0).is_none());
        assert!(bvh.crossings(o, DVec3::ZERO).is_empty());
        assert!(bvh.intersect(o, DVec3::X, 0.0, 0.5).is_none());
        let h = bvh.intersect(o, DVec3::X, 0.0, 1.0).unwrap();
        assert_eq!(h.geometric_normal, DVec3::X);
        assert!(MeshBvh::new(&Mesh::default()).unwrap().intersect(o, DVec3::X, 0.0, 1.0).is_none());
    }

    #[test]
    fn bad_meshes_are_refused() {
        let mut m = cube(1.0).unwrap();
        m.indices[5] = 99;
        assert!(MeshBvh::new(&m).is_err());
        let mut m = cube(1.0).unwrap();
        m.positions[0][1] = f32::INFINITY;
        assert!(MeshBvh::new(&m).is_err());
        let mut m = cube(1.0).unwrap();
        m.indices.pop();
        assert!(MeshBvh::new(&m).is_err());
        assert!(SceneCaster::new(&[cube(1.0).unwrap()], &[(1, Transform::IDENTITY)]).is_err());
    }

    #[test]
    fn world_ray_hits_transformed_cube_at_known_distance() {
        let transform = Transform::from_ops(&[
            TransformOp::Scale(DVec3::new(2.0, 1.0, 0.5)),
            TransformOp::Rotate { angle_deg: 30.0, axis: DVec3::new(1.0, 2.0, 0.5) },
            TransformOp::Translate(DVec3::new(1.0, -2.0, 3.0)),
        ])
        .unwrap();
        let scene = SceneCaster::new(&[cube(2.0).unwrap()], &[(0, transform)]).unwrap();
        // A point on the object's +x face, and the face's world normal.
        let target = transform.transform_point(DVec3::new(1.0, 0.3, -0.2));
        let n = transform.transform_normal(DVec3::X);
        let mut rng = Rng(11);
        for _ in 0..50 {
            // Come in from the +x side at any angle up to ~60° from the normal.
            let u = (-n + rng.unit() * 0.9).normalize();
            if u.dot(n) > -0.5 {
                continue;
            }
            let dist = 7.0;
            let hit = scene.cast(target - u * dist, u * 3.0).expect("hit");
            assert!((hit.t - dist).abs() < 1e-9, "{}", hit.t);
            assert_eq!(hit.instance, 0);
            assert!((hit.normal - n).length() < 1e-12);
        }
    }

    #[test]
    fn nearest_instance_wins_and_far_ones_are_skipped() {
        let meshes = [cube(1.0).unwrap(), uv_sphere(0.5, 16, 8).unwrap()];
        let at =
            |x: f64, y: f64| Transform::from_ops(&[TransformOp::Translate(DVec3::new(x, y, 0.0))]).unwrap();
        let instances = [(1, at(10.0, 0.0)), (0, at(5.0, 0.0)), (0, at(5.0, 50.0))];
        let scene = SceneCaster::new(&meshes, &instances).unwrap();
        let hit = scene.cast(DVec3::ZERO, DVec3::X).unwrap();
        assert_eq!(hit.instance, 1);
        assert!((hit.t - 4.5).abs() < 1e-12);
        assert_eq!(hit.normal, -DVec3::X);
        let beyond = scene.cast(DVec3::new(7.0, 0.0, 0.0), DVec3::X).unwrap();
        assert_eq!(beyond.instance, 0);
        assert!((beyond.t - 2.5).abs() < 1e-12);
        assert!(scene.cast(DVec3::ZERO, -DVec3::X).is_none());
        assert!(scene.cast_range(DVec3::ZERO, DVec3::X, 0.0, 4.0).is_none());
        assert!(scene.cast(DVec3::ZERO, DVec3::ZERO).is_none());
    }

    /// 256×256 rays into a scene of ~5k triangles: results agree with casting each instance
    /// alone (the timing is checked by hand, not here).
    #[test]
    fn many_rays_against_a_5k_triangle_scene() {
        let meshes = [uv_sphere(1.0, 40, 20).unwrap(), torus(1.0, 0.3, 48, 16).unwrap(), cube(1.0).unwrap()];
        let tri: usize = meshes.iter().map(Mesh::triangle_count).sum();
        let mut instances = Vec::new();
        for k in 0..9 {
            let (x, y) = ((k % 3) as f64 * 3.0 - 3.0, (k / 3) as f64 * 3.0 - 3.0);
            let ops = [
                TransformOp::Rotate { angle_deg: 20.0 * k as f64, axis: DVec3::new(1.0, 1.0, 0.0) },
                TransformOp::Translate(DVec3::new(x, y, 0.0)),
            ];
            instances.push((k % 3, Transform::from_ops(&ops).unwrap()));
        }
        assert!(tri * 3 > 5000, "{tri}");
        let scene = SceneCaster::new(&meshes, &instances).unwrap();
        let origin = DVec3::new(0.0, 0.0, 12.0);
        let mut hits = 0;
        for y in 0..256 {
            for x in 0..256 {
                let target = DVec3::new(x as f64 / 255.0 * 10.0 - 5.0, y as f64 / 255.0 * 10.0 - 5.0, 0.0);
                if let Some(h) = scene.cast(origin, target - origin) {
                    assert!(h.t > 10.0 && h.t < 15.0, "{}", h.t);
                    hits += 1;
                }
            }
        }
        assert!(hits > 10_000, "{hits}");
    }
}
