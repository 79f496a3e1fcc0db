//! Decoding the thickness field along a light path: the f64 twin of `lut_inside_fraction` in
//! shaders/common/translucency.glsl (same steps, same order).
//!
//! # The march
//!
//! On the object-space segment p(t) = a + t·(b − a), t ∈ [0, 1], of length ℓ voxel edges, φ̃ is
//! sampled at t₀ = 0 and then at t_{k+1} = min(t_k + max(½/ℓ, |φ̃(t_k)| / (L·h·ℓ)), 1): steps of
//! `MAX_STEP_VOXELS` = ½ voxel, longer only where the Lipschitz bound L (`FIELD_LIPSCHITZ`) proves
//! φ̃ keeps its sign over the step (far from the surface: up to C/L = 2 voxels a sample). Each sign
//! change between samples is located by linear interpolation, then once more inside the part of
//! the bracket where the interpolated point's own sample leaves the sign change (one regula-falsi
//! step). Runs of φ̃ > 0 are gaps — except *low* runs (largest sample ≤ τ) joined to an end of
//! the path by samples with |φ̃| ≤ τ: the ends are surface points, where φ̃ is φ = 0 up to the
//! reconstruction error, and such runs are that error (the "end zones"). The result is
//! 1 − (the gaps' total length in t). At most `MAX_MARCH_STEPS` samples (a path across a 258-voxel
//! grid needs ≤ 895).
//!
//! Why end zones and not a threshold on every run: a path that crosses a cavity near its rim
//! crosses a chord of length c whose depth is only c²/(8R) (R the cavity's radius); dropping every
//! run below τ would miss chords up to √(8Rτ) long, which grows with the resolution in voxels.
//! Why the zone works for a convex solid: between two surface points φ is convex along the path
//! (the distance of a convex set is convex), ≤ 0, so from each end it falls monotonically to its
//! minimum; with the error ε of φ̃ near the surface and τ > 2ε, once a sample has φ̃ < −τ
//! (φ < −τ + ε < −ε), φ̃ stays < 0 until the other end's zone, so every positive run is in a
//! zone and the convex solid gives exactly |M(b − a)|.
//!
//! Why not an exact DDA over cells: along a line φ̃ is a cubic in each cell, its roots need a
//! solver per cell and 8 fetches per cell boundary; the ½-voxel step costs about the same fetches
//! and the bound below covers it.
//!
//! # Error bound (asserted by tests/translucency_bake.rs)
//!
//! - Reconstruction: the corners hold φ within q (`QUANTIZATION_BOUND_VOXELS`·h) and φ is
//!   1-Lipschitz, so |φ̃(x) − φ(x)| ≤ Σ wᵢ|x − cᵢ| + q ≤ E_R = (√3/2)·h + q (the weighted distance
//!   to the cell's corners is largest, √3/2·h, at the cell's centre).
//! - Each partial derivative of φ̃ is a blend of the 4 edge differences along its axis, each
//!   ≤ h + 2q in magnitude, so along any unit direction |dφ̃/ds| ≤ L₀ = √3·(1 + 2q/h) <
//!   `FIELD_LIPSCHITZ` = 2.
//! - Misclassified points lie in the band |φ| ≤ δ = E_R + max(τ + L₀·s/2, L₀·s), s = ½·h:
//!   a point with φ < −(E_R + L₀s) has φ̃ < −L₀s, so it is neither in a run nor in a bracket (a
//!   bracket's points are within s of a zero of φ̃: |φ̃| ≤ L₀s); a point with φ > δ has
//!   φ̃ > max(τ + L₀s/2, L₀s): not in a bracket, and its nearer sample (≤ s/2 away after a ½-voxel
//!   step) has φ̃ > τ with φ̃ > 0 in between, or the step that passed over it was a Lipschitz step,
//!   taken only from a sample with φ̃ ≥ L·s = h > τ in the same run: its run is not low, so it is
//!   counted. (Which low runs count does not enter the bound: their points all have
//!   φ ≤ τ + L₀s/2 + E_R ≤ δ.)
//!
//! So per path, with the exact ends a, b: |d − d*| ≤ |M(b − a)| · |{t : dist(p(t), ∂S) ≤ δ}| — the
//! length of the path within δ of the surface (`ThicknessLut::error_band` is δ). For a path crossing
//! the surface at angles θ_k to the normals that is about Σ_k 2δ/|cos θ_k| (δ/|cos θ| at an end):
//! ≈ 3.5 voxels per internal crossing head-on, unbounded for grazing ones (where the exact
//! thickness itself jumps), 0 away from the surface. The light map adds its own term when a comes
//! from it (`effects::translucency::lut_thickness`).

use glam::DVec3;

use super::{ThicknessLut, CLAMP_VOXELS, QUANTIZATION_BOUND_VOXELS};
use crate::effects::voxelize::corner_linear;

/// The Lipschitz bound of φ̃ along a unit direction used for long steps (≥ √3·(1 + 2q/h)).
pub const FIELD_LIPSCHITZ: f64 = 2.0;
/// The step near the surface, voxel edges.
pub const MAX_STEP_VOXELS: f64 = 0.5;
/// Samples per path at most (the shader's loop bound).
pub const MAX_MARCH_STEPS: u32 = 1024;
/// E_R of the module documentation, voxel edges.
pub const RECONSTRUCTION_BOUND_VOXELS: f64 = 0.866_025_403_784_438_6 + QUANTIZATION_BOUND_VOXELS;

// Long steps need a clamp range above the step's reach, and τ < L·s (see the bound).
const _: () = assert!(CLAMP_VOXELS > 2.0 * FIELD_LIPSCHITZ * MAX_STEP_VOXELS);

impl ThicknessLut {
    /// φ̃ at object point `p`, object units: trilinear over the 8 corners of the cell holding p
    /// (grid coordinates clamped to the grid, NaN to 0), as the shader computes it.
    pub fn field_at(&self, p: DVec3) -> f64 {
        let g = (p - self.origin) / self.voxel_size;
        let mut cell = [0u32; 3];
        let mut f = [0.0; 3];
        for a in 0..3 {
            let hi = self.dims[a] as f64;
            let v = if g[a].is_nan() { 0.0 } else { g[a].clamp(0.0, hi) };
            let i = v.floor().min(hi - 1.0);
            cell[a] = i as u32;
            f[a] = v - i;
        }
        let q = |dx: u32, dy: u32, dz: u32| {
            self.field[corner_linear(self.dims, [cell[0] + dx, cell[1] + dy, cell[2] + dz])] as f64
        };
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let y0 = lerp(lerp(q(0, 0, 0), q(1, 0, 0), f[0]), lerp(q(0, 1, 0), q(1, 1, 0), f[0]), f[1]);
        let y1 = lerp(lerp(q(0, 0, 1), q(1, 0, 1), f[0]), lerp(q(0, 1, 1), q(1, 1, 1), f[0]), f[1]);
        lerp(y0, y1, f[2]) * self.scale()
    }

    /// The fraction of the object-space segment a → b inside the solid, decoded as the module
    /// documentation says; 1 for a = b (no length to cut), 0 for a non-finite segment.
    pub fn inside_fraction(&self, a: DVec3, b: DVec3) -> f64 {
        if !(a.is_finite() && b.is_finite()) {
            return 0.0;
        }
        let h = self.voxel_size;
        let voxels = (b - a).length() / h;
        if voxels.is_nan() || voxels <= 0.0 {
            return 1.0;
        }
        let at = |t: f64| self.field_at(a + (b - a) * t);
        let dt_min = MAX_STEP_VOXELS / voxels;
        let lipschitz = FIELD_LIPSCHITZ * h * voxels;
        let tau = |t: f64| self.tau_at(a + (b - a) * t);
        let (mut t0, mut f0) = (0.0, at(0.0));
        // A run is low when its largest sample is ≤ the largest τ of its samples' cells.
        let (mut run_start, mut run_max, mut run_tau) = (0.0, f0, tau(0.0));
        // Low runs (largest sample ≤ τ) are end noise while they connect to an end through
        // samples with |φ̃| ≤ τ: those of a's zone are dropped, the others wait in `pending`
        // until a sample with |φ̃| > τ separates them from b's zone.
        let (mut gaps, mut pending, mut zone_a) = (0.0, 0.0, f0.abs() <= run_tau);
        let mut steps = 1;
        while t0 < 1.0 && steps < MAX_MARCH_STEPS {
            let t1 = (t0 + dt_min.max(f0.abs() / lipschitz)).min(1.0);
            let (f1, tau1) = (at(t1), tau(t1));
            steps += 1;
            if f0 <= 0.0 && f1 > 0.0 {
                run_start = crossing(&at, t0, f0, t1, f1);
                (run_max, run_tau) = (f1, tau1);
            } else if f0 > 0.0 && f1 > 0.0 {
                (run_max, run_tau) = (run_max.max(f1), run_tau.max(tau1));
            } else if f0 > 0.0 && f1 <= 0.0 {
                let length = crossing(&at, t0, f0, t1, f1) - run_start;
                if run_max > run_tau {
                    gaps += length;
                } else if !zone_a {
                    pending += length;
                }
            }
            if f1.abs() > tau1 {
                zone_a = false;
                gaps += pending;
                pending = 0.0;
            }
            (t0, f0) = (t1, f1);
        }
        if f0 > 0.0 && run_max > run_tau {
            gaps += t0 - run_start;
        }
        (1.0 - gaps).clamp(0.0, 1.0)
    }

    /// δ of the module documentation, object units: points of a path farther than this from the
    /// surface are classified right.
    pub fn error_band(&self) -> f64 {
        let h = self.voxel_size;
        let l0 = 3f64.sqrt() * (1.0 + 2.0 * QUANTIZATION_BOUND_VOXELS);
        let s = MAX_STEP_VOXELS * h;
        RECONSTRUCTION_BOUND_VOXELS * h + (self.gap_threshold() + l0 * s / 2.0).max(l0 * s)
    }
}

/// The zero of φ̃ between t0 and t1 (opposite signs: one ≤ 0 < the other): linear interpolation,
/// then again in the part of the bracket where the sign still changes.
fn crossing(at: &impl Fn(f64) -> f64, t0: f64, f0: f64, t1: f64, f1: f64) -> f64 {
    let tm = t0 + (t1 - t0) * f0 / (f0 - f1);
    let fm = at(tm);
    let (ta, fa, tb, fb) = if (fm > 0.0) == (f0 > 0.0) { (tm, fm, t1, f1) } else { (t0, f0, tm, fm) };
    if fa == fb {
        return tm;
    }
    ta + (tb - ta) * fa / (fa - fb)
}

#[cfg(test)]
mod tests {
    use crate::effects::thickness_lut::{bake, BakeOptions};
    use crate::scene::procedural;
    use glam::DVec3;

    /// A convex solid: every segment between two surface points is all inside, whatever its
    /// angle (grazing included).
    #[test]
    fn a_convex_solid_is_all_inside() {
        let (lut, _) = bake(&procedural::cube(2.0).unwrap(), 8, &BakeOptions::default(), &|_, _| {}).unwrap();
        for (a, b) in [
            (DVec3::new(0.3, -0.2, -1.0), DVec3::new(-0.1, 0.4, 1.0)),
            (DVec3::new(-1.0, 0.9, 0.0), DVec3::new(1.0, -0.95, 0.3)),
            (DVec3::new(0.2, 0.2, 1.0), DVec3::new(0.25, 0.2, 1.0)),
            (DVec3::new(-0.9, 0.2, 1.0), DVec3::new(0.9, 0.3, 1.0)),
        ] {
            assert_eq!(lut.inside_fraction(a, b), 1.0, "{a} → {b}");
        }
        assert_eq!(lut.inside_fraction(DVec3::ZERO, DVec3::ZERO), 1.0);
        assert_eq!(lut.inside_fraction(DVec3::NAN, DVec3::ZERO), 0.0);
        // Outside the grid the field is clamped to the grid's (outside) border.
        assert!(lut.field_at(DVec3::splat(100.0)) > 0.0 && lut.field_at(DVec3::splat(f64::NAN)) > 0.0);
    }

    /// Straight through a cavity of radius 0.6: the path is 2 long, the cavity 1.2 of it.
    #[test]
    fn the_cavity_is_cut_out() {
        let mesh = procedural::cavity_cube(2.0, 0.6, 48, 24).unwrap();
        let (lut, _) = bake(&mesh, 24, &BakeOptions::default(), &|_, _| {}).unwrap();
        let (a, b) = (DVec3::new(0.013, 0.011, -1.0), DVec3::new(0.013, 0.011, 1.0));
        let exact = crate::effects::raycast::MeshBvh::new(&mesh).unwrap().inside_fraction(a, b);
        let f = lut.inside_fraction(a, b);
        assert!(((f - exact) * 2.0).abs() < 0.25 * lut.voxel_size, "{f} vs {exact}");
    }
}
