//! The camera: the first perspective camera of the scene's nodes, or — in a file without one — a
//! camera that frames the objects of interest of what is drawn from `FRAMING_DIRECTION`
//! (`SceneBounds`: ground planes that dwarf the rest left out).

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

/// How much a flat instance must dwarf the rest to be left out of the framing (`SceneBounds`):
/// its longest side more than this many times the longest side of everything smaller, and its
/// thinnest side at most its longest / this.
pub const BACKDROP_RATIO: f64 = 10.0;

/// The world bounds (min, max) of what a scene draws, and of the part a framing camera frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneBounds {
    /// Every drawn instance: the framing camera's `far` reaches all of it.
    pub all: (DVec3, DVec3),
    /// The objects of interest, which the framing camera fits in its view (`of_boxes`).
    pub framed: (DVec3, DVec3),
}

impl SceneBounds {
    /// One box, framed whole.
    pub fn whole(lo: DVec3, hi: DVec3) -> SceneBounds {
        SceneBounds { all: (lo, hi), framed: (lo, hi) }
    }

    /// The bounds of the instances' world boxes (min, max); None when there are none.
    ///
    /// **What is framed.** Framing the bounds of everything makes a ground plane the subject: a
    /// 1000-unit ground under 1-unit objects leaves them a pixel or two of a 512² image (glTF's
    /// TonemappingTest, a level's terrain, a TOML scene's `plane` floor scaled up). So instances are
    /// taken largest first (by their box's longest side), and the largest k are left out when each
    /// of them is **flat** (its box's thinnest side at most 1/`BACKDROP_RATIO` of its longest: a
    /// plane, a slab, a terrain, a water surface, a backdrop wall) and **dwarfs the rest** (its
    /// longest side more than `BACKDROP_RATIO` times that of the box of all the instances smaller
    /// than it); k is the largest for which both hold, so a terrain under a field under the objects
    /// goes with the field. What is left out is still drawn, and `all` (the framing camera's `far`)
    /// reaches it.
    ///
    /// Why this rule and not "the bounding box of the meshes at their median scale": the median
    /// drops any large instance outnumbered by small ones, and a large solid is usually the
    /// subject (a car body among a hundred bolts, a building with a few props by its door), while
    /// a large *flat* instance under small objects is their stage. And why against the box of the
    /// rest, not each object's size: objects spread over the ground span it, so a city on its
    /// ground plane is framed whole with the ground (it does not dwarf the city). Below 10× the
    /// ground stays framed: the objects keep at least about a tenth of the frame (tens of pixels at
    /// 512²) and the ground shows as the ground it is. A scene of one plane, or of flat parts alike
    /// in size, has nothing that dwarfs the rest: everything is framed.
    pub fn of_boxes(boxes: &[(DVec3, DVec3)]) -> Option<SceneBounds> {
        let union = |a: (DVec3, DVec3), b: (DVec3, DVec3)| (a.0.min(b.0), a.1.max(b.1));
        let size = |b: (DVec3, DVec3)| (b.1 - b.0).max_element();
        let flat = |b: (DVec3, DVec3)| (b.1 - b.0).min_element() <= size(b) / BACKDROP_RATIO;
        let mut order: Vec<usize> = (0..boxes.len()).collect();
        order.sort_by(|&i, &j| size(boxes[j]).total_cmp(&size(boxes[i])));
        // rest[k]: the box of the instances from the k-th largest on.
        let empty = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let mut rest = vec![empty; boxes.len() + 1];
        for k in (0..boxes.len()).rev() {
            rest[k] = union(rest[k + 1], boxes[order[k]]);
        }
        let all = *rest.first().filter(|_| !boxes.is_empty())?;
        let mut framed = all;
        for k in 1..boxes.len() {
            let smallest_left_out = boxes[order[k - 1]];
            if !flat(smallest_left_out) {
                break;
            }
            // Ties never split: an instance as large as this one is in `rest[k]`.
            if size(smallest_left_out) > BACKDROP_RATIO * size(rest[k]) {
                framed = rest[k];
            }
        }
        Some(SceneBounds { all, framed })
    }
}

/// A camera looking at the centre of the framed bounds (`SceneBounds::framed`) from
/// `FRAMING_DIRECTION`, far enough that their bounding sphere fits the vertical field of view (and
/// the horizontal one when the image is at least as wide as it is high), its `far` past all of
/// the bounds (`all`, what was left out of the framing included). The sphere is the bounds' own
/// wherever they are: content far from the origin fills the frame as it does at the origin (its
/// vertices are placed to within f32's 2⁻²⁴ of their distance from the origin,
/// docs/scene-format.md "Numeric limits").
pub fn framing(bounds: Option<SceneBounds>) -> Camera {
    let bounds = bounds.unwrap_or(SceneBounds::whole(DVec3::splat(-1.0), DVec3::splat(1.0)));
    let (lo, hi) = bounds.framed;
    let centre = (lo + hi) / 2.0;
    // At least the smallest instance size glTF content may have (`limits`); a point (a TOML scene
    // of metaballs or waves alone gives no bounds) still gets a camera that is not at its centre.
    let radius = ((hi - lo).length() / 2.0).max(1e-6);
    let distance = radius / (FRAMING_FOV_DEG.to_radians() / 2.0).sin();
    let position = centre + FRAMING_DIRECTION.normalize() * distance;
    // The farthest corner of everything drawn, with a margin (≤ 1.25·√3·5.7·L ≈ 12.4·L for corners
    // within ±L, `MAX_WORLD`); when nothing was left out this is within the sphere's own far.
    let (a, b) = bounds.all;
    let reach = (0..8)
        .map(|k| {
            let corner = DVec3::new(
                if k & 1 == 0 { a.x } else { b.x },
                if k & 2 == 0 { a.y } else { b.y },
                if k & 4 == 0 { a.z } else { b.z },
            );
            (corner - position).length()
        })
        .fold(0.0, f64::max);
    Camera {
        position,
        look_at: centre,
        up: DVec3::Y,
        fov_y_deg: FRAMING_FOV_DEG,
        near: ((distance - radius) * 0.5).max(distance * 1e-4),
        far: ((distance + radius) * 2.0).max(reach * 1.25).min(MAX_EXTENT),
        lens: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_keeps_the_bounds_inside_the_view() {
        let bounds = (DVec3::new(-1.0, 0.0, -2.0), DVec3::new(3.0, 2.0, 2.0));
        let c = framing(Some(SceneBounds::whole(bounds.0, bounds.1)));
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
        let near = framing(Some(SceneBounds::whole(DVec3::splat(-0.5), DVec3::splat(0.5))));
        let shift = DVec3::new(1e6, 0.0, 0.0);
        let far = framing(Some(SceneBounds::whole(DVec3::splat(-0.5) + shift, DVec3::splat(0.5) + shift)));
        assert!(((far.position - shift) - near.position).length() < 1e-9);
        assert_eq!((far.near, far.far), (near.near, near.far));
    }

    fn cube(centre: DVec3, half: f64) -> (DVec3, DVec3) {
        (centre - DVec3::splat(half), centre + DVec3::splat(half))
    }

    fn ground(half: f64) -> (DVec3, DVec3) {
        (DVec3::new(-half, -1.0, -half), DVec3::new(half, -1.0, half))
    }

    #[test]
    fn a_ground_that_dwarfs_the_objects_is_left_out_of_the_framing_not_of_far() {
        let objects = [cube(DVec3::ZERO, 0.5), cube(DVec3::new(2.0, 0.0, 0.0), 0.5)];
        let mut boxes = vec![ground(500.0)];
        boxes.extend(objects);
        let b = SceneBounds::of_boxes(&boxes).unwrap();
        assert_eq!(b.framed, (DVec3::splat(-0.5), DVec3::new(2.5, 0.5, 0.5)));
        assert_eq!(b.all, (DVec3::new(-500.0, -1.0, -500.0), DVec3::new(500.0, 0.5, 500.0)));
        let c = framing(Some(b));
        assert!((c.look_at - DVec3::new(1.0, 0.0, 0.0)).length() < 1e-12);
        assert!(c.far > (DVec3::new(-500.0, -1.0, -500.0) - c.position).length(), "{c:?}");
        // A ground the objects span, a ground only 10 times their size, a large solid: kept.
        let spread = [cube(DVec3::new(-90.0, 0.0, -90.0), 0.5), cube(DVec3::new(90.0, 0.0, 90.0), 0.5)];
        for boxes in [
            vec![ground(500.0), spread[0], spread[1]],
            vec![ground(15.0), objects[0], objects[1]],
            vec![cube(DVec3::ZERO, 500.0), objects[0], objects[1]],
        ] {
            let b = SceneBounds::of_boxes(&boxes).unwrap();
            assert_eq!(b.framed, b.all, "{boxes:?}");
        }
    }

    #[test]
    fn nested_grounds_go_together_and_ties_stay() {
        let field = (DVec3::new(-40.0, -0.9, -40.0), DVec3::new(40.0, -0.9, 40.0));
        let b = SceneBounds::of_boxes(&[ground(5000.0), field, cube(DVec3::ZERO, 0.5)]).unwrap();
        assert_eq!(b.framed, cube(DVec3::ZERO, 0.5));
        // Two grounds alike and nothing else, or one plane: everything framed.
        let b = SceneBounds::of_boxes(&[ground(500.0), ground(500.0)]).unwrap();
        assert_eq!(b.framed, ground(500.0));
        let b = SceneBounds::of_boxes(&[ground(500.0)]).unwrap();
        assert_eq!(b.framed, b.all);
        assert_eq!(SceneBounds::of_boxes(&[]), None);
    }
}
