//! The thickness field's error on light paths, on the CPU (seed 003, figure 13): for random lines
//! through a mesh, the segment from the light's first entry to its last exit (the TSM segment),
//! the exact inside fraction (`MeshBvh::inside_fraction`) against the field's decoded fraction
//! (`ThicknessLut::inside_fraction`) along the same segment. `examples/bake_measure.rs` prints
//! these per resolution.

use glam::DVec3;

use hadou::bake::thickness_lut::ThicknessLut;
use hadou::reference::MeshBvh;
use hadou::testing::Rng;

/// |Δf| and |Δd| per path (d in voxel edges), sorted ascending.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PathErrors {
    pub df: Vec<f64>,
    pub dd: Vec<f64>,
}

/// Nearest-rank-style percentile of sorted values: the value at index ⌊(n − 1)·p⌋.
pub fn at(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * p) as usize]
}

/// Measures `paths` random paths (uniform directions, offsets uniform over the bounding sphere's
/// disc) with the deterministic generator seeded by `seed`.
pub fn path_errors(bvh: &MeshBvh, lut: &ThicknessLut, paths: usize, seed: u64) -> PathErrors {
    let (lo, hi) = bvh.bounds();
    let (centre, radius) = ((lo + hi) * 0.5, (hi - lo).length() * 0.5);
    let mut rng = Rng(seed);
    let mut e = PathErrors::default();
    // Give up on meshes the lines never cross twice (a flat mesh): at most 100 tries per path.
    let mut tries = 0usize;
    while e.df.len() < paths && tries < 100 * paths.max(1) {
        tries += 1;
        let z = 2.0 * rng.next() - 1.0;
        let phi = std::f64::consts::TAU * rng.next();
        let u = DVec3::new((1.0 - z * z).sqrt() * phi.cos(), z, (1.0 - z * z).sqrt() * phi.sin());
        let side = u.any_orthonormal_vector();
        let up = u.cross(side);
        let (s, t) = (rng.next().sqrt() * radius, std::f64::consts::TAU * rng.next());
        let origin = centre + (side * t.cos() + up * t.sin()) * s - u * 2.0 * radius;
        let crossings = bvh.crossings(origin, u);
        let (Some(first), Some(last)) = (crossings.first(), crossings.last()) else { continue };
        if last.t - first.t < 1e-9 {
            continue;
        }
        let (a, b) = (origin + u * last.t, origin + u * first.t);
        let exact = bvh.inside_fraction(a, b);
        let f = lut.inside_fraction(a, b);
        e.df.push((f - exact).abs());
        e.dd.push((f - exact).abs() * a.distance(b) / lut.voxel_size);
    }
    for v in [&mut e.df, &mut e.dd] {
        v.sort_by(f64::total_cmp);
    }
    e
}

/// CPU seconds (user + system) this process has used so far, from /proc/self/stat (Linux); 0
/// elsewhere. A loaded machine does not inflate it as it does wall time.
pub fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // Fields after the command name (which is in parentheses and may hold spaces).
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(0.0);
    // utime and stime are fields 14 and 15 of the whole line: 11 and 12 after the name.
    (ticks(11) + ticks(12)) / 100.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use hadou::bake::thickness_lut::{bake, BakeOptions};
    use hadou::scene::procedural;

    /// On a solid box every segment between two surface points is inside: the exact fraction is 1
    /// and so is the field's (the gap threshold keeps the ends' reconstruction error out).
    #[test]
    fn a_box_has_no_fraction_error() {
        let mesh = procedural::cube(2.0).unwrap();
        let options = BakeOptions { threads: 1 };
        let (lut, _) = bake(&mesh, 8, &options, &|_, _| {}).unwrap();
        let e = path_errors(&MeshBvh::new(&mesh).unwrap(), &lut, 200, 7);
        assert_eq!(e.df.len(), 200);
        assert!(at(&e.df, 1.0) <= 1e-12, "{}", at(&e.df, 1.0));
        assert!(e.df.windows(2).all(|w| w[0] <= w[1]));
        assert!(at(&[], 0.5).is_nan());
    }
}
