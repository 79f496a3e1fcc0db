//! The exact thickness reference (f64) the LUT and the GPU translucency pass are checked against,
//! and the TSM baseline (Dachsbacher & Stamminger's translucent shadow maps, seed 003 §2).
//!
//! Both take a shaded point on an instance's surface and the direction toward the light, in world
//! space. The world ray p + t·l (l unit) is taken to object space as M⁻¹p + t·M⁻¹l without
//! normalizing, so object-space crossings come out with t already in world units (an affine map
//! keeps the ray parameter). Crossings are those of `MeshBvh::crossings` (watertight), sorted, and
//! the winding number along the line follows from their `entering` flags (the line starts outside).
//!
//! - `exact_thickness`: the length of {t ≥ 0 : winding > 0}: all the material the light crosses
//!   from where it enters the instance to the shaded point; cavities and gaps (the hole of a
//!   torus, the air in a bottle) do not count. I_out = I_in·exp(−σ·d) with this d is the seed's
//!   eq. (2).
//! - `tsm_thickness`: the distance from the shaded point to the light's first entry into the
//!   instance (the last crossing along the ray), as a shadow map gives it: everything between
//!   counts as material, cavities included.

use glam::DVec3;

use super::raycast::MeshBvh;
use crate::scene::transform::Transform;

/// The world ray toward the light in object space (unnormalized direction, t in world units), or
/// `None` for a non-finite point or a zero direction.
fn object_ray(
    transform: &Transform,
    point_world: DVec3,
    toward_light_world: DVec3,
) -> Option<(DVec3, DVec3)> {
    let l = toward_light_world.try_normalize()?;
    if !point_world.is_finite() {
        return None;
    }
    let origin = transform.inverse.transform_point3(point_world);
    let dir = transform.inverse.transform_vector3(l);
    (origin.is_finite() && dir.is_finite() && dir != DVec3::ZERO).then_some((origin, dir))
}

/// World length of material along the ray from `point_world` toward the light (t ≥ 0), cavities
/// excluded. 0 for a point the light reaches without crossing the instance.
pub fn exact_thickness(
    bvh: &MeshBvh,
    transform: &Transform,
    point_world: DVec3,
    toward_light_world: DVec3,
) -> f64 {
    let Some((origin, dir)) = object_ray(transform, point_world, toward_light_world) else {
        return 0.0;
    };
    let mut winding = 0i64;
    let mut from = f64::NEG_INFINITY;
    let mut inside = 0.0;
    for x in bvh.crossings(origin, dir) {
        if winding > 0 && x.t > 0.0 {
            inside += x.t - from.max(0.0);
        }
        winding += if x.entering { 1 } else { -1 };
        from = x.t;
    }
    inside
}

/// The TSM thickness: world distance from `point_world` to the last crossing along the ray toward
/// the light (where the light first enters the instance), every gap counted as material. 0 when the
/// ray leaves without crossing.
pub fn tsm_thickness(
    bvh: &MeshBvh,
    transform: &Transform,
    point_world: DVec3,
    toward_light_world: DVec3,
) -> f64 {
    let Some((origin, dir)) = object_ray(transform, point_world, toward_light_world) else {
        return 0.0;
    };
    bvh.crossings(origin, dir).last().map_or(0.0, |x| x.t.max(0.0))
}

/// I_out = I_in·exp(−σ·d) per channel (seed 003, eq. 2).
pub fn transmittance(sigma: DVec3, thickness: f64) -> DVec3 {
    DVec3::new((-sigma.x * thickness).exp(), (-sigma.y * thickness).exp(), (-sigma.z * thickness).exp())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::procedural;
    use crate::scene::transform::TransformOp;

    #[test]
    fn cube_back_lit_through_its_width() {
        let bvh = MeshBvh::new(&procedural::cube(2.0).unwrap()).unwrap();
        let id = Transform::IDENTITY;
        // A point on the front face, light behind the cube: 2 units of material.
        let p = DVec3::new(0.3, 0.2, 1.0);
        assert!((exact_thickness(&bvh, &id, p, DVec3::NEG_Z) - 2.0).abs() < 1e-12);
        assert!((tsm_thickness(&bvh, &id, p, DVec3::NEG_Z) - 2.0).abs() < 1e-12);
        // Front-lit: nothing to cross.
        assert_eq!(exact_thickness(&bvh, &id, p, DVec3::Z), 0.0);
        assert_eq!(tsm_thickness(&bvh, &id, p, DVec3::Z), 0.0);
        // Non-unit light direction is normalized; a zero one gives 0.
        assert!((exact_thickness(&bvh, &id, p, DVec3::new(0.0, 0.0, -5.0)) - 2.0).abs() < 1e-12);
        assert_eq!(exact_thickness(&bvh, &id, p, DVec3::ZERO), 0.0);
    }

    #[test]
    fn thickness_follows_non_uniform_scale_and_rotation() {
        let bvh = MeshBvh::new(&procedural::cube(2.0).unwrap()).unwrap();
        let ops = [
            TransformOp::Scale(DVec3::new(1.0, 1.0, 3.0)),
            TransformOp::Rotate { angle_deg: 90.0, axis: DVec3::Y },
            TransformOp::Translate(DVec3::new(5.0, 0.0, 0.0)),
        ];
        let m = Transform::from_ops(&ops).unwrap();
        // The cube's z extent (6 after the scale) now lies along x, centred at x = 5.
        let p = DVec3::new(2.0, 0.1, 0.2);
        assert!((exact_thickness(&bvh, &m, p, DVec3::X) - 6.0).abs() < 1e-9);
        // Along z the world width is 2.
        let q = DVec3::new(5.5, 0.1, -1.0);
        assert!((exact_thickness(&bvh, &m, q, DVec3::Z) - 2.0).abs() < 1e-9);
    }

    #[test]
    fn cavity_is_excluded_by_exact_and_counted_by_tsm() {
        let r = 0.6;
        let bvh = MeshBvh::new(&procedural::cavity_cube(2.0, r, 64, 32).unwrap()).unwrap();
        let id = Transform::IDENTITY;
        // Through the centre, off the poles and seams a little.
        let p = DVec3::new(0.013, 0.011, 1.0);
        let exact = exact_thickness(&bvh, &id, p, DVec3::NEG_Z);
        let tsm = tsm_thickness(&bvh, &id, p, DVec3::NEG_Z);
        assert!((tsm - 2.0).abs() < 1e-12, "{tsm}");
        // The tessellated sphere's chord is a little shorter than the true one: inscribed, each end
        // moves in by at most the sag r·(1 − cos(π/32)) of its quads (64 segments, 32 rings: their
        // diagonal half-angle (π/64)·√2 < π/32), along a ray 0.03 rad off the normal.
        let chord = 2.0 * (r * r - p.x * p.x - p.y * p.y).sqrt();
        let sag = 2.0 * r * (1.0 - (std::f64::consts::PI / 32.0).cos()) / (1.0 - 0.03f64.powi(2)).sqrt();
        assert!(exact > 2.0 - chord - 1e-12 && exact <= 2.0 - chord + sag, "{exact} vs {}", 2.0 - chord);
        // TSM counts the cavity as material: its chord more (both faces of the cube are exact).
        assert!((tsm - exact - chord).abs() <= sag, "difference {}", tsm - exact);
    }

    #[test]
    fn transmittance_is_the_exponential() {
        let t = transmittance(DVec3::new(1.0, 2.0, 0.0), 0.5);
        assert!((t.x - (-0.5f64).exp()).abs() < 1e-15 && (t.y - (-1.0f64).exp()).abs() < 1e-15);
        assert_eq!(t.z, 1.0);
    }
}
