//! Instance transforms (seed 002): homogeneous 4×4 matrices composed from a list of operations,
//! the inverse composed alongside, normals by M⁻ᵀ, and world rays taken to object space.

use glam::{DMat3, DMat4, DQuat, DVec3, DVec4};

/// One step of a transform list, applied to the object in the order listed.
#[derive(Clone, Debug, PartialEq)]
pub enum TransformOp {
    /// Translation by the vector.
    Translate(DVec3),
    /// Rotation by `angle_deg` about `axis` (any non-zero length; normalized here).
    Rotate {
        /// Degrees, right-handed (counter-clockwise looking down the axis toward the origin).
        angle_deg: f64,
        /// Axis through the origin, any non-zero length.
        axis: DVec3,
    },
    /// Per-axis scale factors, none zero (negative mirrors).
    Scale(DVec3),
    /// An affine matrix given column-major (bottom row must be 0 0 0 1).
    Matrix(DMat4),
}

/// Why a transform was refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TransformError {
    /// A rotation axis of zero length.
    #[error("rotation axis has zero length (expected a non-zero vector)")]
    ZeroAxis,
    /// A scale with a zero factor.
    #[error("scale component {axis} is zero (expected non-zero scale factors)")]
    ZeroScale {
        /// `'x'`, `'y'` or `'z'`.
        axis: char,
    },
    /// A matrix whose bottom row is not 0 0 0 1.
    #[error("matrix bottom row is {row:?} (expected an affine matrix with bottom row [0, 0, 0, 1])")]
    NotAffine {
        /// The bottom row found.
        row: [f64; 4],
    },
    /// A linear part (of a step or the whole) with a condition number above `MAX_CONDITION`.
    #[error("matrix is singular or nearly so (condition number {condition:.3e} > {limit:.0e}; f32 cannot invert it)")]
    Singular {
        /// The Frobenius condition number found (∞ when singular).
        condition: f64,
        /// `MAX_CONDITION`.
        limit: f64,
    },
    /// A NaN or infinite number in a step.
    #[error("value is not finite (expected finite numbers)")]
    NotFinite,
}

/// Largest Frobenius condition number accepted for the linear part. f32 keeps 2⁻²⁴ ≈ 6e-8
/// relative; κ·2⁻²⁴ must stay well below 1 for M⁻¹ and M⁻ᵀ evaluated in f32 on the GPU to keep
/// any digits, so κ ≤ 1e6 leaves at least one digit after the worst f32 cancellation.
pub const MAX_CONDITION: f64 = 1.0e6;

/// A composed affine transform with its inverse kept alongside (M⁻¹ = X₁⁻¹⋯Xₙ⁻¹).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// M: object → world (column vectors, p_world = M · p_object).
    pub matrix: DMat4,
    /// M⁻¹: world → object.
    pub inverse: DMat4,
}

/// A world ray taken to object space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectRay {
    /// The ray's origin in object space.
    pub origin: DVec3,
    /// Unit direction in object space.
    pub dir: DVec3,
    /// ‖M⁻¹d‖: a hit at object-space distance t′ is at world distance t = t′ / t_scale.
    pub t_scale: f64,
}

impl Default for Transform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl TransformOp {
    /// The operation's matrix and its exact inverse.
    fn matrix_and_inverse(&self) -> Result<(DMat4, DMat4), TransformError> {
        match *self {
            TransformOp::Translate(t) => {
                check_finite(&t.to_array())?;
                Ok((DMat4::from_translation(t), DMat4::from_translation(-t)))
            }
            TransformOp::Rotate { angle_deg, axis } => {
                check_finite(&[angle_deg, axis.x, axis.y, axis.z])?;
                let len = axis.length();
                if len.is_nan() || len <= 0.0 || !len.is_finite() {
                    return Err(TransformError::ZeroAxis);
                }
                let q = DQuat::from_axis_angle(axis / len, angle_deg.to_radians());
                let r = DMat4::from_quat(q);
                // A rotation's inverse is its transpose: exact, no division.
                Ok((r, r.transpose()))
            }
            TransformOp::Scale(s) => {
                check_finite(&s.to_array())?;
                for (v, axis) in [(s.x, 'x'), (s.y, 'y'), (s.z, 'z')] {
                    if v == 0.0 {
                        return Err(TransformError::ZeroScale { axis });
                    }
                }
                Ok((DMat4::from_scale(s), DMat4::from_scale(DVec3::ONE / s)))
            }
            TransformOp::Matrix(m) => {
                check_finite(&m.to_cols_array())?;
                let row = m.row(3);
                if row != DVec4::new(0.0, 0.0, 0.0, 1.0) {
                    return Err(TransformError::NotAffine { row: row.to_array() });
                }
                check_condition(DMat3::from_mat4(m))?;
                Ok((m, m.inverse()))
            }
        }
    }
}

impl Transform {
    /// The identity, with itself as inverse.
    pub const IDENTITY: Transform = Transform { matrix: DMat4::IDENTITY, inverse: DMat4::IDENTITY };

    /// Composes M = Xₙ⋯X₁ and M⁻¹ = X₁⁻¹⋯Xₙ⁻¹ from operations listed in application order.
    pub fn from_ops(ops: &[TransformOp]) -> Result<Transform, TransformError> {
        let mut matrix = DMat4::IDENTITY;
        let mut inverse = DMat4::IDENTITY;
        for op in ops {
            let (m, inv) = op.matrix_and_inverse()?;
            matrix = m * matrix;
            inverse *= inv;
        }
        check_condition(DMat3::from_mat4(matrix))?;
        Ok(Transform { matrix, inverse })
    }

    /// An object-space point in world space: M · p.
    pub fn transform_point(&self, p: DVec3) -> DVec3 {
        self.matrix.transform_point3(p)
    }

    /// The matrix that maps object normals to world normals: the inverse transpose of the linear part.
    pub fn normal_matrix(&self) -> DMat3 {
        DMat3::from_mat4(self.inverse).transpose()
    }

    /// An object-space normal in world space: M⁻ᵀn, renormalized.
    pub fn transform_normal(&self, n: DVec3) -> DVec3 {
        (self.normal_matrix() * n).normalize()
    }

    /// Takes a world ray (any non-zero direction) into object space (seed 002, eq. 14 and the t correction).
    pub fn ray_to_object(&self, origin: DVec3, dir: DVec3) -> ObjectRay {
        let d_world = dir.normalize();
        let o = self.inverse.transform_point3(origin);
        let d = self.inverse.transform_vector3(d_world);
        let t_scale = d.length();
        ObjectRay { origin: o, dir: d / t_scale, t_scale }
    }
}

fn check_finite(values: &[f64]) -> Result<(), TransformError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(TransformError::NotFinite)
    }
}

/// The Frobenius norm ‖A‖_F of a 3×3 linear part: a bound of its largest singular value, so of
/// how far it stretches any length.
pub fn frobenius(a: DMat3) -> f64 {
    (a.x_axis.length_squared() + a.y_axis.length_squared() + a.z_axis.length_squared()).sqrt()
}

/// Frobenius condition number ‖A‖·‖A⁻¹‖ of a 3×3 linear part; ∞ when singular.
pub fn condition_number(a: DMat3) -> f64 {
    let det = a.determinant();
    if det == 0.0 || !det.is_finite() {
        return f64::INFINITY;
    }
    frobenius(a) * frobenius(a.inverse())
}

fn check_condition(a: DMat3) -> Result<(), TransformError> {
    let condition = condition_number(a);
    if condition > MAX_CONDITION {
        Err(TransformError::Singular { condition, limit: MAX_CONDITION })
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
        (a - b).length() <= tol
    }

    /// Seed 002, figure 1: the hypotenuse normal (1,1)/√2 of a right isosceles triangle becomes
    /// (2,1)/√5 when y is scaled by 2 (not (1,2)/√5, which scaling the normal directly would give).
    #[test]
    fn seed_normal_example() {
        let t = Transform::from_ops(&[TransformOp::Scale(DVec3::new(1.0, 2.0, 1.0))]).unwrap();
        let n = t.transform_normal(DVec3::new(1.0, 1.0, 0.0).normalize());
        assert!(close(n, DVec3::new(2.0, 1.0, 0.0) / 5f64.sqrt(), 1e-15), "{n}");
    }

    #[test]
    fn rotation_about_non_unit_axis() {
        let t =
            Transform::from_ops(&[TransformOp::Rotate { angle_deg: 90.0, axis: DVec3::new(0.0, 0.0, 7.5) }])
                .unwrap();
        assert!(close(t.transform_point(DVec3::X), DVec3::Y, 1e-15));
        // 120° about (1,1,1) cycles the axes.
        let t = Transform::from_ops(&[TransformOp::Rotate { angle_deg: 120.0, axis: DVec3::splat(3.0) }])
            .unwrap();
        assert!(close(t.transform_point(DVec3::X), DVec3::Y, 1e-15));
        assert!(close(t.transform_point(DVec3::Y), DVec3::Z, 1e-15));
    }

    fn sample_ops() -> Vec<TransformOp> {
        vec![
            TransformOp::Scale(DVec3::new(2.0, 0.5, 3.0)),
            TransformOp::Rotate { angle_deg: 37.0, axis: DVec3::new(1.0, 2.0, -0.5) },
            TransformOp::Translate(DVec3::new(4.0, -1.0, 2.5)),
            TransformOp::Matrix(DMat4::from_cols_array(&[
                1.0, 0.2, 0.0, 0.0, 0.0, 1.0, 0.3, 0.0, 0.1, 0.0, 1.0, 0.0, 0.5, 0.0, 0.0, 1.0,
            ])),
        ]
    }

    #[test]
    fn composed_inverse_equals_direct_inverse() {
        let t = Transform::from_ops(&sample_ops()).unwrap();
        let direct = t.matrix.inverse();
        for (a, b) in t.inverse.to_cols_array().iter().zip(direct.to_cols_array()) {
            assert!((a - b).abs() < 1e-13, "{a} vs {b}");
        }
        let id = t.matrix * t.inverse;
        assert!(id.abs_diff_eq(DMat4::IDENTITY, 1e-13));
    }

    #[test]
    fn order_is_as_listed() {
        // Scale then translate: the translation is not scaled.
        let t =
            Transform::from_ops(&[TransformOp::Scale(DVec3::splat(2.0)), TransformOp::Translate(DVec3::X)])
                .unwrap();
        assert!(close(t.transform_point(DVec3::ZERO), DVec3::X, 0.0));
        let t =
            Transform::from_ops(&[TransformOp::Translate(DVec3::X), TransformOp::Scale(DVec3::splat(2.0))])
                .unwrap();
        assert!(close(t.transform_point(DVec3::ZERO), DVec3::new(2.0, 0.0, 0.0), 0.0));
    }

    /// A world ray hits a scaled-rotated-translated unit sphere at the analytically known t after
    /// the object-space round trip (seed 002: t = t′ / ‖M⁻¹d‖).
    #[test]
    fn ray_round_trip_hits_transformed_sphere() {
        // Uniform scale keeps a sphere: radius 2.5 about (3, -1, 2).
        let ops = [
            TransformOp::Scale(DVec3::splat(2.5)),
            TransformOp::Rotate { angle_deg: 71.0, axis: DVec3::new(0.3, 1.0, 0.2) },
            TransformOp::Translate(DVec3::new(3.0, -1.0, 2.0)),
        ];
        let t = Transform::from_ops(&ops).unwrap();
        let origin = DVec3::new(-10.0, 0.5, 1.0);
        let dir = (DVec3::new(3.0, -1.0, 2.0) + DVec3::new(0.0, 0.7, 0.3) - origin).normalize();
        // Analytic world hit with the sphere |p − c| = 2.5.
        let oc = origin - DVec3::new(3.0, -1.0, 2.0);
        let b = oc.dot(dir);
        let expected = -b - (b * b - (oc.length_squared() - 6.25)).sqrt();
        // Object space: unit sphere.
        let r = t.ray_to_object(origin, dir);
        let bo = r.origin.dot(r.dir);
        let t_obj = -bo - (bo * bo - (r.origin.length_squared() - 1.0)).sqrt();
        let t_world = t_obj / r.t_scale;
        assert!((t_world - expected).abs() < 1e-12 * expected, "{t_world} vs {expected}");
        // The object-space hit maps back to the world hit.
        let p_world = t.transform_point(r.origin + r.dir * t_obj);
        assert!(close(p_world, origin + dir * expected, 1e-12));
    }

    /// Non-uniform scale: an ellipsoid hit at the known t.
    #[test]
    fn ray_round_trip_non_uniform_scale() {
        let t = Transform::from_ops(&[TransformOp::Scale(DVec3::new(4.0, 1.0, 1.0))]).unwrap();
        let r = t.ray_to_object(DVec3::new(-10.0, 0.0, 0.0), DVec3::X);
        assert!((r.t_scale - 0.25).abs() < 1e-15);
        let t_obj = -r.origin.x - 1.0; // unit sphere along x from x = -2.5
        assert!((t_obj / r.t_scale - 6.0).abs() < 1e-12);
    }

    #[test]
    fn rejects_bad_operations() {
        let zero_axis = TransformOp::Rotate { angle_deg: 10.0, axis: DVec3::ZERO };
        assert_eq!(Transform::from_ops(&[zero_axis]), Err(TransformError::ZeroAxis));
        assert_eq!(
            Transform::from_ops(&[TransformOp::Scale(DVec3::new(1.0, 0.0, 1.0))]),
            Err(TransformError::ZeroScale { axis: 'y' })
        );
        let singular =
            DMat4::from_cols_array(&[1., 0., 0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 0., 0., 0., 1.]);
        assert!(matches!(
            Transform::from_ops(&[TransformOp::Matrix(singular)]),
            Err(TransformError::Singular { .. })
        ));
        let projective =
            DMat4::from_cols_array(&[1., 0., 0., 0.5, 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.]);
        assert!(matches!(
            Transform::from_ops(&[TransformOp::Matrix(projective)]),
            Err(TransformError::NotAffine { .. })
        ));
        // Nearly singular through composition: 1e-4 × 1e4 anisotropy.
        let squash =
            [TransformOp::Scale(DVec3::new(1e4, 1.0, 1.0)), TransformOp::Scale(DVec3::new(1.0, 1e-4, 1.0))];
        assert!(matches!(Transform::from_ops(&squash), Err(TransformError::Singular { .. })));
        assert_eq!(
            Transform::from_ops(&[TransformOp::Translate(DVec3::new(f64::NAN, 0.0, 0.0))]),
            Err(TransformError::NotFinite)
        );
        // A mirror is fine.
        assert!(Transform::from_ops(&[TransformOp::Scale(DVec3::new(-1.0, 1.0, 1.0))]).is_ok());
    }
}
