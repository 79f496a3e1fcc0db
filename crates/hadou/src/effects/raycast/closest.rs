//! Distance from a point to a mesh's triangles in f64, through the ray-casting BVH: the unsigned
//! part of the thickness field (`effects::thickness_lut`) and the band of the tests' error bound.
//!
//! The closest point on a triangle is Ericson's region test (Real-Time Collision Detection,
//! §5.1.5): exact up to f64 rounding, degenerate triangles included (they reduce to a segment or
//! a point). Boxes are visited nearest first and pruned by their distance, so a query bounded by
//! `max` only opens the leaves within `max` of the point.

use glam::DVec3;

use super::{MeshBvh, Node};

impl MeshBvh {
    /// The distance from `p` to the nearest triangle when it is below `max`, else `None` (also for
    /// a non-finite point or a mesh without triangles).
    pub fn distance_within(&self, p: DVec3, max: f64) -> Option<f64> {
        if !p.is_finite() || self.nodes.is_empty() || max.is_nan() || max <= 0.0 {
            return None;
        }
        let mut best2 = max * max;
        let mut found = false;
        let mut stack: Vec<(f64, u32)> = Vec::with_capacity(64);
        stack.push((box_distance2(&self.nodes[0], p), 0));
        while let Some((d2, i)) = stack.pop() {
            if d2 >= best2 {
                continue;
            }
            let node = &self.nodes[i as usize];
            if node.count > 0 {
                for &tri in &self.order[node.start as usize..(node.start + node.count) as usize] {
                    let q = closest_on_triangle(p, self.corners(tri as usize));
                    let e2 = (q - p).length_squared();
                    if e2 < best2 {
                        best2 = e2;
                        found = true;
                    }
                }
                continue;
            }
            let (l, r) = (node.start, node.start + 1);
            let (dl, dr) =
                (box_distance2(&self.nodes[l as usize], p), box_distance2(&self.nodes[r as usize], p));
            // Pop the nearer child first.
            if dl <= dr {
                stack.extend([(dr, r), (dl, l)]);
            } else {
                stack.extend([(dl, l), (dr, r)]);
            }
        }
        found.then(|| best2.sqrt())
    }
}

fn box_distance2(node: &Node, p: DVec3) -> f64 {
    let d = (node.min - p).max(p - node.max).max(DVec3::ZERO);
    d.length_squared()
}

/// The point of triangle [a, b, c] nearest to `p` (Ericson §5.1.5, Voronoi regions).
pub(crate) fn closest_on_triangle(p: DVec3, [a, b, c]: [DVec3; 3]) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom == 0.0 || denom.is_nan() {
        // Degenerate (collinear corners) and p projects inside: the nearest of the three edges.
        return [(a, b), (b, c), (c, a)]
            .map(|(s, e)| closest_on_segment(p, s, e))
            .into_iter()
            .min_by(|x, y| (*x - p).length_squared().total_cmp(&(*y - p).length_squared()))
            .unwrap_or(a);
    }
    let (v, w) = (vb / denom, vc / denom);
    a + ab * v + ac * w
}

fn closest_on_segment(p: DVec3, s: DVec3, e: DVec3) -> DVec3 {
    let d = e - s;
    let len2 = d.length_squared();
    if len2 <= 0.0 || len2.is_nan() {
        return s;
    }
    s + d * ((p - s).dot(d) / len2).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;
    use crate::testing::Rng;

    /// The BVH query agrees with a brute-force scan of every triangle, and a box's distance is
    /// the distance to its faces, edges and corners.
    #[test]
    fn distance_matches_brute_force() {
        let mesh = procedural::torus(1.0, 0.35, 24, 12).unwrap();
        let bvh = MeshBvh::new(&mesh).unwrap();
        let mut rng = Rng(3);
        for _ in 0..300 {
            let p = DVec3::new(rng.next(), rng.next(), rng.next()) * 3.0 - 1.5;
            let brute = (0..bvh.triangle_count())
                .map(|t| (closest_on_triangle(p, bvh.corners(t)) - p).length())
                .fold(f64::INFINITY, f64::min);
            let got = bvh.distance_within(p, 10.0).unwrap();
            assert!((got - brute).abs() < 1e-12, "{p}: {got} vs {brute}");
            assert_eq!(bvh.distance_within(p, brute * 0.999), None);
        }
        let cube = MeshBvh::new(&procedural::cube(2.0).unwrap()).unwrap();
        let d = |p: DVec3| cube.distance_within(p, 10.0).unwrap();
        assert!((d(DVec3::new(0.2, 0.3, 0.4)) - 0.6).abs() < 1e-15);
        assert!((d(DVec3::new(2.0, 0.0, 0.0)) - 1.0).abs() < 1e-15);
        assert!((d(DVec3::new(2.0, 2.0, 0.0)) - 2f64.sqrt()).abs() < 1e-15);
        assert!((d(DVec3::new(2.0, 2.0, 2.0)) - 3f64.sqrt()).abs() < 1e-15);
        assert_eq!(cube.distance_within(DVec3::NAN, 1.0), None);
        // A degenerate (collinear) triangle is a segment.
        let q = closest_on_triangle(DVec3::new(0.5, 1.0, 0.0), [DVec3::ZERO, DVec3::X, DVec3::X * 2.0]);
        assert!((q - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-15);
    }
}
