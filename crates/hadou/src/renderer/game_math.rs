//! glam's f32 or f64 types, whichever a game has: game math is f32 (`Mat4`, `Affine3A`, `Vec3`),
//! hadou's world is f64 (its f64 twins and its far-from-the-origin scenes need it). The setters
//! take `impl GameMatrix` / `impl GameVector`; an f32 value is widened exactly, so a game's f32
//! matrix means what it meant in f32.

use glam::{Affine3A, DAffine3, DMat4, DVec3, Mat4, Vec3, Vec3A};

/// A 4×4 matrix a setter takes: `Mat4`, `DMat4`, `Affine3A` or `DAffine3`.
pub trait GameMatrix: Copy {
    /// The matrix in f64 (exact for f32 values).
    fn to_dmat4(self) -> DMat4;
}

impl GameMatrix for DMat4 {
    fn to_dmat4(self) -> DMat4 {
        self
    }
}

impl GameMatrix for Mat4 {
    fn to_dmat4(self) -> DMat4 {
        self.as_dmat4()
    }
}

impl GameMatrix for DAffine3 {
    fn to_dmat4(self) -> DMat4 {
        DMat4::from(self)
    }
}

impl GameMatrix for Affine3A {
    fn to_dmat4(self) -> DMat4 {
        Mat4::from(self).as_dmat4()
    }
}

/// A 3-vector a setter takes: `Vec3`, `Vec3A`, `DVec3`, `[f32; 3]` or `[f64; 3]`.
pub trait GameVector: Copy {
    /// The vector in f64 (exact for f32 values).
    fn to_dvec3(self) -> DVec3;
}

impl GameVector for DVec3 {
    fn to_dvec3(self) -> DVec3 {
        self
    }
}

impl GameVector for Vec3 {
    fn to_dvec3(self) -> DVec3 {
        self.as_dvec3()
    }
}

impl GameVector for Vec3A {
    fn to_dvec3(self) -> DVec3 {
        Vec3::from(self).as_dvec3()
    }
}

impl GameVector for [f64; 3] {
    fn to_dvec3(self) -> DVec3 {
        DVec3::from_array(self)
    }
}

impl GameVector for [f32; 3] {
    fn to_dvec3(self) -> DVec3 {
        Vec3::from_array(self).as_dvec3()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f32 values widen exactly, and every form of one transform gives the same f64 matrix.
    #[test]
    fn every_form_is_the_same_matrix() {
        let f = Mat4::from_scale_rotation_translation(
            Vec3::new(1.5, 0.25, 3.0),
            glam::Quat::from_rotation_y(0.7),
            Vec3::new(1e6, -3.1, 0.1),
        );
        let d = f.as_dmat4();
        assert_eq!(f.to_dmat4(), d);
        assert_eq!(d.to_dmat4(), d);
        assert_eq!(Affine3A::from_mat4(f).to_dmat4(), d);
        assert_eq!(DAffine3::from_mat4(d).to_dmat4(), d);
        // 0.1f32 is not 0.1: the game's value, not a re-rounded one.
        assert_eq!(Vec3::new(0.1, 0.2, 0.3).to_dvec3().x, f64::from(0.1f32));
        assert_eq!([0.1f32, 0.2, 0.3].to_dvec3(), Vec3::new(0.1, 0.2, 0.3).to_dvec3());
        assert_eq!(Vec3A::new(0.1, 0.2, 0.3).to_dvec3(), Vec3::new(0.1, 0.2, 0.3).to_dvec3());
        assert_eq!([0.1f64, 0.2, 0.3].to_dvec3(), DVec3::new(0.1, 0.2, 0.3));
    }
}
