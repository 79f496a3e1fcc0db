//! `[[mesh]] wobble`: a mesh that deforms with scene time, to see deforming translucent meshes in
//! a scene file (a game deforms its own with `Renderer::set_mesh_positions`). Each vertex p of the
//! loaded mesh moves to p + D(p, t) with
//!
//!   D(p, t) = a·L·sin(2π·hz·t) · (sin(2π·p.y/L), sin(2π·p.z/L), sin(2π·p.x/L)),
//!
//! L the longest side of the mesh's box, a = `wobble` ∈ [0, 0.1]. D depends on the position
//! only, so vertices a closed mesh splits (hard edges) move together and it stays closed; its
//! Jacobian differs from the identity by at most 2π·a ≤ 0.63 < 1 in norm, so p ↦ p + D is
//! injective: the surface never cuts through itself (cavities stay inside, shells stay apart by
//! at least 1 − 0.63 of their gap). Normals are recomputed per frame (area-weighted).

/// A mesh's wobble: amplitude as a fraction of its longest box side, and frequency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wobble {
    /// a ∈ (0, 0.1].
    pub amplitude: f64,
    /// Oscillations per second of scene time, ≥ 0.
    pub hz: f64,
}

/// Largest `wobble` (see the module docs: keeps the deformation injective).
pub const MAX_WOBBLE: f64 = 0.1;

impl Wobble {
    /// `base` (the loaded mesh's positions) deformed at scene time `t`.
    pub fn positions(&self, base: &[[f32; 3]], t: f64) -> Vec<[f32; 3]> {
        let (lo, hi) = base.iter().fold((glam::DVec3::MAX, glam::DVec3::MIN), |(lo, hi), p| {
            let p = glam::DVec3::from(p.map(f64::from));
            (lo.min(p), hi.max(p))
        });
        let size = (hi - lo).max_element();
        if size.is_nan() || size <= 0.0 {
            return base.to_vec();
        }
        let tau = std::f64::consts::TAU;
        let s = self.amplitude * size * (tau * self.hz * t).sin();
        let k = tau / size;
        base.iter()
            .map(|p| {
                let [x, y, z] = p.map(f64::from);
                let d = [(k * y).sin(), (k * z).sin(), (k * x).sin()];
                [(x + s * d[0]) as f32, (y + s * d[1]) as f32, (z + s * d[2]) as f32]
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rest_at_time_zero_and_bounded_displacement() {
        let base = crate::scene::procedural::hollow_ball(1.0, 0.2, 16, 8).unwrap().positions;
        let w = Wobble { amplitude: 0.1, hz: 0.5 };
        assert_eq!(w.positions(&base, 0.0), base);
        let moved = w.positions(&base, 0.5);
        let max = base
            .iter()
            .zip(&moved)
            .map(|(a, b)| (glam::Vec3::from(*a) - glam::Vec3::from(*b)).length())
            .fold(0.0f32, f32::max);
        // |D| ≤ a·L·√3 with L = 2.
        assert!(max > 0.05 && max <= 0.1 * 2.0 * 3f32.sqrt() + 1e-5, "{max}");
    }
}
