//! The camera: the first perspective camera of the scene's nodes, or — in a file without one — a
//! camera that frames the bounds of what is drawn from `FRAMING_DIRECTION`.

use std::path::Path;

use glam::DVec3;

use super::error::GltfError;
use crate::scene::camera::Camera;
use crate::scene::file::{MAX_EXTENT, MAX_FAR_NEAR_RATIO};
use crate::scene::transform::Transform;

/// Where a framing camera stands, seen from the centre of the scene's bounds: in front (+z),
/// above and to the right (≈ 24° up, ≈ 27° to the right of +z), normalized.
pub const FRAMING_DIRECTION: DVec3 = DVec3::new(0.5, 0.5, 1.0);
/// The framing camera's vertical field of view, degrees (the TOML default).
pub const FRAMING_FOV_DEG: f64 = 45.0;

/// A glTF perspective camera placed by its node: hadou's camera and glTF's `aspectRatio`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GltfCamera {
    /// The camera (looking down the node's −z, up its +y).
    pub camera: Camera,
    /// `aspectRatio` when the file gives one (width / height).
    pub aspect: Option<f64>,
}

/// Camera `cam` placed by `world`; `bounds` (world min, max of what is drawn) sets `far` when the
/// file gives no `zfar` (glTF's infinite projection).
pub(super) fn perspective(
    path: &Path,
    cam: &gltf::Camera,
    world: &Transform,
    bounds: Option<(DVec3, DVec3)>,
) -> Result<Option<GltfCamera>, GltfError> {
    let gltf::camera::Projection::Perspective(p) = cam.projection() else { return Ok(None) };
    let at = |f: &str| format!("/cameras/{}/perspective/{f}", cam.index());
    let fail = |f: &str, message: String| Err(GltfError::at(path, at(f), message));
    let fov_y_deg = (p.yfov() as f64).to_degrees();
    if !(0.1..180.0).contains(&fov_y_deg) {
        return fail("yfov", format!("{} rad = {fov_y_deg}° (expected 0.1° to < 180°)", p.yfov()));
    }
    let near = p.znear() as f64;
    if !(near.is_finite() && near >= f32::MIN_POSITIVE as f64) {
        return fail("znear", format!("{near} (expected a number > 0)"));
    }
    let position = world.transform_point(DVec3::ZERO);
    let forward = world.matrix.transform_vector3(-DVec3::Z).try_normalize();
    let up = world.matrix.transform_vector3(DVec3::Y).try_normalize();
    let (Some(forward), Some(up)) = (forward, up) else { return Ok(None) };
    if up.cross(forward).length() < 1e-6 || position.abs().max_element() > MAX_EXTENT {
        return Ok(None);
    }
    let far = match p.zfar() {
        Some(z) => z as f64,
        None => {
            // Far enough for every corner of the bounds, at least the TOML default.
            let reach =
                bounds.map_or(0.0, |(lo, hi)| (position - (lo + hi) / 2.0).length() + (hi - lo).length());
            (2.0 * reach).clamp(Camera::DEFAULT_FAR, MAX_EXTENT)
        }
    };
    if !(far > near && far <= MAX_EXTENT) {
        return fail("zfar", format!("{far} (expected a number > znear ({near}) and <= 2^48)"));
    }
    if near < far / MAX_FAR_NEAR_RATIO {
        return fail(
            "znear",
            format!("{near} (expected >= zfar / 2^126: the reverse-Z depth must stay a normal f32)"),
        );
    }
    let aspect = match p.aspect_ratio() {
        Some(a) if a.is_finite() && a > 0.0 => Some(a as f64),
        Some(a) => return fail("aspectRatio", format!("{a} (expected a number > 0)")),
        None => None,
    };
    let camera =
        Camera { position, look_at: position + forward, up, fov_y_deg, near, far, lens: Default::default() };
    Ok(Some(GltfCamera { camera, aspect }))
}

/// A camera looking at the centre of `bounds` from `FRAMING_DIRECTION`, far enough that the
/// bounding sphere fits the vertical field of view (and the horizontal one when the image is at
/// least as wide as it is high). The sphere is the bounds' own wherever they are: content far from
/// the origin fills the frame as it does at the origin (its vertices are placed to within f32's
/// 2⁻²⁴ of their distance from the origin, docs/scene-format.md "Numeric limits").
pub fn framing(bounds: Option<(DVec3, DVec3)>) -> Camera {
    let (lo, hi) = bounds.unwrap_or((DVec3::splat(-1.0), DVec3::splat(1.0)));
    let centre = (lo + hi) / 2.0;
    // At least the smallest instance size glTF content may have (`limits`); a point (a TOML scene
    // of metaballs or waves alone gives no bounds) still gets a camera that is not at its centre.
    let radius = ((hi - lo).length() / 2.0).max(1e-6);
    let distance = radius / (FRAMING_FOV_DEG.to_radians() / 2.0).sin();
    let position = centre + FRAMING_DIRECTION.normalize() * distance;
    Camera {
        position,
        look_at: centre,
        up: DVec3::Y,
        fov_y_deg: FRAMING_FOV_DEG,
        near: ((distance - radius) * 0.5).max(distance * 1e-4),
        far: (distance + radius) * 2.0,
        lens: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_keeps_the_bounds_inside_the_view() {
        let bounds = (DVec3::new(-1.0, 0.0, -2.0), DVec3::new(3.0, 2.0, 2.0));
        let c = framing(Some(bounds));
        let b = c.basis();
        let tan = (c.fov_y_deg.to_radians() / 2.0).tan();
        for k in 0..8 {
            let p = DVec3::new(
                if k & 1 == 0 { bounds.0.x } else { bounds.1.x },
                if k & 2 == 0 { bounds.0.y } else { bounds.1.y },
                if k & 4 == 0 { bounds.0.z } else { bounds.1.z },
            );
            let v = p - c.position;
            let z = v.dot(b.forward);
            assert!(z > c.near && z < c.far);
            assert!(v.dot(b.up).abs() <= z * tan && v.dot(b.right).abs() <= z * tan);
        }
    }

    #[test]
    fn framing_does_not_zoom_out_with_the_distance_from_the_origin() {
        let near = framing(Some((DVec3::splat(-0.5), DVec3::splat(0.5))));
        let shift = DVec3::new(1e6, 0.0, 0.0);
        let far = framing(Some((DVec3::splat(-0.5) + shift, DVec3::splat(0.5) + shift)));
        assert!(((far.position - shift) - near.position).length() < 1e-9);
        assert_eq!((far.near, far.far), (near.near, near.far));
    }
}
