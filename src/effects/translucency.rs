//! translucency (seed 003) on the CPU in f64: the light's view the `light_id` pass renders from,
//! and the colour the `translucency` pass adds. Twin of shaders/light_id.vert/.frag and
//! shaders/translucency.comp (the thickness itself is `effects::thickness` and
//! `ThicknessLut::world_thickness_between`).
//!
//! **Light view.** An orthographic view along the scene's first directional light l, fitted to the
//! bounding sphere (centre C, radius R) of every translucent instance: the sphere around the centre
//! of the world box of all their transformed mesh-box corners, through the farthest corner, padded
//! by `SPHERE_PAD` so f32 rounding never clips a surface. For a world point p:
//! x = (p − C)·right / R, y = (p − C)·up / R (each in [−1, 1] across the map), and the light-space
//! distance z = (p − C)·l + R (0 on the plane where the light enters the sphere, 2R where it
//! leaves). Texel (⌊(x + 1)/2·S⌋, ⌊(y + 1)/2·S⌋) of an S² map holds what the rasterizer sampled at
//! its centre (Vulkan: NDC y = −1 is row 0).
//!
//! **Colour.** colour = surface + w·L·albedo·exp(−σ·d) per RGB channel (seed 003, eq. 2): `surface`
//! is the raster's Lambert + ambient, L the first light's colour × intensity, d the thickness, and
//! w = max(n·l, 0) the exit weight (`exit_weight`). The seed's eq. 2 alone gives I_out = I_in on a
//! face the light reaches directly (d = 0 there), which adds the light a second time on top of the
//! Lambert term that already counts it: a lit jade cube renders white. The weight is 0 on every face
//! turned toward the light and 1 on a face the light leaves through head-on; for a slab it is the
//! cosine of the light at the opposite, entry face (whose normal is −n), i.e. Lambert's law for the
//! light that got in, and it fades to 0 at the light's terminator, where the Lambert term does too.

use glam::{DVec2, DVec3};

use super::thickness::transmittance;
use super::thickness_lut::ThicknessLut;
use crate::scene::transform::Transform;
use crate::scene::{MaterialKind, Scene};

/// Relative padding of the fitted sphere's radius.
pub const SPHERE_PAD: f64 = 1e-3;

/// An orthographic view along a directional light; see the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightView {
    pub centre: DVec3,
    pub radius: f64,
    pub right: DVec3,
    pub up: DVec3,
    /// Unit direction the light travels.
    pub dir: DVec3,
}

impl LightView {
    /// The view along the scene's first light fitted to its translucent instances; `None` without
    /// a light or a translucent instance.
    pub fn fit(scene: &Scene) -> Option<LightView> {
        let light = scene.lights.first()?;
        let mut corners = Vec::new();
        for inst in &scene.instances {
            if !matches!(scene.materials[inst.material].kind, MaterialKind::Translucent { .. }) {
                continue;
            }
            let (lo, hi) = scene.meshes[inst.mesh].mesh.bounds();
            for k in 0..8 {
                let pick = |bit: usize, a: f64, b: f64| if k & bit == 0 { a } else { b };
                let c = DVec3::new(pick(1, lo.x, hi.x), pick(2, lo.y, hi.y), pick(4, lo.z, hi.z));
                corners.push(inst.transform.transform_point(c));
            }
        }
        LightView::around(light.direction, &corners)
    }

    /// The view along `dir` fitted to the bounding sphere of `points`; `None` for no points, a
    /// zero direction or non-finite values.
    pub fn around(dir: DVec3, points: &[DVec3]) -> Option<LightView> {
        let dir = dir.try_normalize()?;
        let (first, rest) = points.split_first()?;
        let (lo, hi) = rest.iter().fold((*first, *first), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let centre = (lo + hi) * 0.5;
        let far = points.iter().map(|p| p.distance(centre)).fold(0.0, f64::max);
        // A point set of zero size still needs a map of non-zero size.
        let radius = far.max(1e-6 * (1.0 + centre.length())) * (1.0 + SPHERE_PAD);
        let hint = if dir.y.abs() < 0.9 { DVec3::Y } else { DVec3::X };
        let right = dir.cross(hint).normalize();
        let up = right.cross(dir);
        let view = LightView { centre, radius, right, up, dir };
        (centre.is_finite() && radius.is_finite()).then_some(view)
    }

    /// (x, y) in [−1, 1]² across the map, and the light-space distance z in [0, 2R].
    pub fn project(&self, p: DVec3) -> (DVec2, f64) {
        let v = p - self.centre;
        (DVec2::new(v.dot(self.right), v.dot(self.up)) / self.radius, v.dot(self.dir) + self.radius)
    }

    /// The texel of an `size`² map whose centre's light ray passes nearest to `p`; `None` outside.
    pub fn texel(&self, p: DVec3, size: u32) -> Option<(u32, u32)> {
        let (xy, _) = self.project(p);
        let t = (xy + 1.0) * 0.5 * size as f64;
        let inside = |c: f64| (0.0..size as f64).contains(&c.floor());
        (inside(t.x) && inside(t.y)).then(|| (t.x.floor() as u32, t.y.floor() as u32))
    }
}

/// Where the lookups for an end of a light path are made, in voxel edges along the path into the
/// material (each clamped to half the path, so the two ends never swap sides).
pub const END_SHIFTS: [f64; 4] = [0.0, 0.5, 1.0, 1.5];

/// The surface voxel for the end `p` (object space) of a light path of an instance with transform
/// `m`: the nearest-grid lookups (`ThicknessLut::surface_voxel_at`) at p moved `END_SHIFTS` voxels
/// along `inward` (the object-space unit direction into the material, along the path; at most
/// `half` object units), keeping the one whose centre lies nearest, in world space, to the path's
/// line through p along the world unit direction `dir` (the first one on a tie). The plain lookup
/// at p picks the surface voxel nearest p's voxel centre, up to ~1.3 voxels beside the path; the
/// table's segment between two such centres then crosses cavity rims and thin walls the path does
/// not (or the reverse). Looking a little deeper along the path finds centres beside it.
pub fn path_end_voxel(
    lut: &ThicknessLut,
    m: &Transform,
    p: DVec3,
    inward: DVec3,
    half: f64,
    dir: DVec3,
) -> Option<u32> {
    let mut best: Option<(f64, u32)> = None;
    for k in END_SHIFTS {
        let id = lut.surface_voxel_at(p + inward * (k * lut.voxel_size).min(half))?;
        let w = m.matrix.transform_vector3(lut.centre(id) - p);
        let off = w - dir * w.dot(dir);
        let d2 = off.dot(off);
        if best.is_none_or(|(b, _)| d2 < b) {
            best = Some((d2, id));
        }
    }
    best.map(|(_, id)| id)
}

/// The LUT thickness between the light's entry point `a` and the shaded point `b` (object space)
/// of an instance with transform `m`, as the translucency shader computes it: the path's world
/// length minus the gaps the table knows, (1 − f(i, j))·|M(c_j − c_i)|, clamped to [0, |M(b − a)|],
/// with i, j the `path_end_voxel`s of b and a. The ends lie on the surface, so what the centre
/// segment does not cover near them is material: unlike f·|M(b − a)| (`world_thickness_between`),
/// a thin wall keeps its part between the surface and the voxel centre. `None` for a non-finite
/// point; 0 for a = b.
pub fn lut_thickness(lut: &ThicknessLut, m: &Transform, a: DVec3, b: DVec3) -> Option<f64> {
    if !(a.is_finite() && b.is_finite()) {
        return None;
    }
    let path = (m.transform_point(b) - m.transform_point(a)).length();
    let Some(inward) = (a - b).try_normalize().filter(|_| path > 0.0) else { return Some(0.0) };
    let (half, dir) = (0.5 * (a - b).length(), (m.transform_point(a) - m.transform_point(b)) / path);
    let i = path_end_voxel(lut, m, b, inward, half, dir)?;
    let j = path_end_voxel(lut, m, a, -inward, half, dir)?;
    let span = (m.transform_point(lut.centre(j)) - m.transform_point(lut.centre(i))).length();
    Some((path - (1.0 - lut.fraction(i, j)) * span).clamp(0.0, path))
}

/// The smallest and largest side of the light_id maps, in texels.
pub const LIGHT_MAP_MIN: u32 = 256;
pub const LIGHT_MAP_MAX: u32 = 1024;

/// The side of the light_id maps: texels of at most a quarter of the finest world voxel edge among
/// the translucent instances, so the entry point a texel gives lies within a quarter voxel of the
/// light's own ray, well under the LUT's voxel-scale error; a power of two in [`LIGHT_MAP_MIN`,
/// `LIGHT_MAP_MAX`] (the smallest map for a scene without a translucent instance or a light).
/// The quarter-voxel bound holds only while it fits in `LIGHT_MAP_MAX`: fine voxels over a wide
/// light view (res 64, several instances apart) are capped at 1024² with coarser texels (0.26–0.40
/// voxel measured by a review; issue 13 item 5). Instances that move change the view and so the
/// size, frame by frame (`TranslucentFrame`).
/// The map spans the light view's diameter 2R. An instance's finest world voxel edge is its object
/// edge h = (longest side of the mesh box) / voxel_res shrunk by M's smallest stretch σ_min =
/// 1/‖M⁻¹‖₂ ≥ 1/‖M⁻¹‖_F (Frobenius, on the linear part): h/‖M⁻¹‖_F is a lower bound of it
/// (√3 below the true edge for a uniform scale: the map may be one step larger than needed).
pub fn light_map_size(scene: &Scene) -> u32 {
    let Some(view) = LightView::fit(scene) else { return LIGHT_MAP_MIN };
    let mut finest = f64::INFINITY;
    for inst in &scene.instances {
        let MaterialKind::Translucent { voxel_res, .. } = scene.materials[inst.material].kind else {
            continue;
        };
        let (lo, hi) = scene.meshes[inst.mesh].mesh.bounds();
        let inv = inst.transform.inverse;
        let frobenius = (inv.x_axis.truncate().length_squared()
            + inv.y_axis.truncate().length_squared()
            + inv.z_axis.truncate().length_squared())
        .sqrt();
        finest = finest.min((hi - lo).max_element() / voxel_res as f64 / frobenius);
    }
    let texels = 2.0 * view.radius / (0.25 * finest);
    if !(texels.is_finite() && texels > 0.0) {
        return LIGHT_MAP_MAX;
    }
    (texels.ceil().min(LIGHT_MAP_MAX as f64) as u32).next_power_of_two().clamp(LIGHT_MAP_MIN, LIGHT_MAP_MAX)
}

/// The light that crossed d of material: L·albedo·exp(−σ·d) per channel (0 for d = +inf).
pub fn transmitted(radiance: DVec3, albedo: DVec3, sigma: DVec3, d: f64) -> DVec3 {
    if d == f64::INFINITY {
        return DVec3::ZERO;
    }
    radiance * albedo * transmittance(sigma, d)
}

/// The exit weight max(n·l, 0): n the unit normal of the shaded surface (turned toward the camera,
/// as the G-buffer holds it), l the unit direction the light travels. See the module documentation.
pub fn exit_weight(normal: DVec3, light_dir: DVec3) -> f64 {
    normal.dot(light_dir).max(0.0)
}

/// What the translucency pass writes to HDR: the surface term plus the transmitted light weighted by
/// the exit weight `w` (`exit_weight`).
pub fn translucent_colour(
    surface: DVec3,
    radiance: DVec3,
    albedo: DVec3,
    sigma: DVec3,
    d: f64,
    w: f64,
) -> DVec3 {
    surface + w * transmitted(radiance, albedo, sigma, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_covers_its_points_and_orders_them_along_the_light() {
        let pts = [DVec3::new(-2.0, 0.0, 0.0), DVec3::new(3.0, 1.0, -1.0), DVec3::new(0.5, -2.0, 2.0)];
        let dir = DVec3::new(0.0, -0.25, 1.0);
        let v = LightView::around(dir, &pts).unwrap();
        assert!((v.dir.length() - 1.0).abs() < 1e-15 && v.right.dot(v.dir).abs() < 1e-15);
        assert!(v.up.dot(v.dir).abs() < 1e-15 && v.up.dot(v.right).abs() < 1e-15);
        for p in pts {
            let (xy, z) = v.project(p);
            assert!(xy.length() < 1.0 && z > 0.0 && z < 2.0 * v.radius);
            assert!(v.texel(p, 1024).is_some());
        }
        // Moving along the light only changes z, by the distance moved.
        let (xy0, z0) = v.project(pts[0]);
        let (xy1, z1) = v.project(pts[0] + v.dir * 0.7);
        assert!((xy1 - xy0).length() < 1e-12 && (z1 - z0 - 0.7).abs() < 1e-12);
        // A vertical light picks another hint and still gives an orthonormal frame.
        let w = LightView::around(DVec3::NEG_Y, &pts).unwrap();
        assert!(w.right.dot(w.dir).abs() < 1e-15 && (w.up.length() - 1.0).abs() < 1e-15);
        assert!(LightView::around(DVec3::ZERO, &pts).is_none());
        assert!(LightView::around(dir, &[]).is_none());
    }

    /// On a box every segment between two surface points is inside: the LUT thickness is the
    /// path's length (f = 1, whatever voxels the ends pick), under any transform; and it shrinks
    /// by about the cavity chord through the cavity cube.
    #[test]
    fn lut_thickness_is_the_path_on_a_box_and_leaves_the_cavity_out() {
        use crate::effects::thickness_lut::{bake, BakeOptions};
        use crate::scene::procedural;
        use crate::scene::transform::TransformOp;
        let options = BakeOptions { threads: 1, ..BakeOptions::default() };
        let (lut, _) = bake(&procedural::cube(2.0).unwrap(), 8, &options, &|_, _| {}).unwrap();
        let m = Transform::from_ops(&[
            TransformOp::Scale(DVec3::new(1.5, 0.7, 1.0)),
            TransformOp::Rotate { angle_deg: 30.0, axis: DVec3::new(1.0, 2.0, 0.5) },
        ])
        .unwrap();
        for (a, b) in [
            (DVec3::new(0.3, -0.2, -1.0), DVec3::new(-0.1, 0.4, 1.0)),
            (DVec3::new(-1.0, 0.9, 0.0), DVec3::new(1.0, -0.95, 0.3)),
            (DVec3::new(0.2, 0.2, 1.0), DVec3::new(0.25, 0.2, 1.0)),
        ] {
            let path = (m.transform_point(b) - m.transform_point(a)).length();
            assert!((lut_thickness(&lut, &m, a, b).unwrap() - path).abs() < 1e-12);
        }
        assert_eq!(lut_thickness(&lut, &m, DVec3::ZERO, DVec3::ZERO), Some(0.0));
        assert_eq!(lut_thickness(&lut, &m, DVec3::NAN, DVec3::ZERO), None);
        // Straight through the centre of a cube with a cavity of radius 0.6: the path is 2 long,
        // the table's segment crosses the whole (tessellated) cavity.
        let (hollow, _) =
            bake(&procedural::cavity_cube(2.0, 0.6, 32, 16).unwrap(), 25, &options, &|_, _| {}).unwrap();
        let (a, b) = (DVec3::new(0.013, 0.011, -1.0), DVec3::new(0.013, 0.011, 1.0));
        let d = lut_thickness(&hollow, &Transform::IDENTITY, a, b).unwrap();
        assert!((d - (2.0 - 1.2)).abs() < 2.0 * hollow.voxel_size, "{d}");
    }

    #[test]
    fn colour_is_surface_plus_attenuated_light() {
        let (l, a, s) = (DVec3::splat(2.0), DVec3::new(0.5, 1.0, 0.25), DVec3::new(1.0, 2.0, 0.0));
        let c = translucent_colour(DVec3::splat(0.1), l, a, s, 0.5, 1.0);
        assert!((c.x - (0.1 + 1.0 * (-0.5f64).exp())).abs() < 1e-15);
        assert!((c.y - (0.1 + 2.0 * (-1.0f64).exp())).abs() < 1e-15);
        assert!((c.z - 0.6).abs() < 1e-15);
        assert_eq!(transmitted(l, a, s, f64::INFINITY), DVec3::ZERO);
        let half = translucent_colour(DVec3::ZERO, l, a, s, 0.5, 0.5);
        assert!((half.z - 0.25).abs() < 1e-15);
    }

    #[test]
    fn light_map_texels_are_a_quarter_of_the_finest_voxel() {
        let load = |name: &str| crate::scene::load_scene(format!("assets/scenes/{name}").as_ref()).unwrap();
        // The three seed objects side by side need the largest map; the showcase's one cube less.
        let seed = load("translucency.toml");
        assert_eq!(light_map_size(&seed), LIGHT_MAP_MAX);
        let mut showcase = load("showcase.toml");
        let size = light_map_size(&showcase);
        let view = LightView::fit(&showcase).unwrap();
        let jade = showcase.instances.iter().find(|i| i.name.as_deref() == Some("jade cube")).unwrap();
        let MaterialKind::Translucent { voxel_res, .. } = showcase.materials[jade.material].kind else {
            panic!()
        };
        let (lo, hi) = showcase.meshes[jade.mesh].mesh.bounds();
        // A uniform scale s: the world voxel is s·h exactly.
        let world_voxel = 0.55 * (hi - lo).max_element() / voxel_res as f64;
        let texel = 2.0 * view.radius / size as f64;
        assert!(texel <= 0.25 * world_voxel * (1.0 + 1e-12), "texel {texel}, voxel {world_voxel}");
        // The Frobenius bound takes a uniform scale's voxel √3 times smaller: half the size must
        // not meet that bound, or the size is larger than the rule asks.
        let bound = 0.25 * world_voxel / 3f64.sqrt();
        assert!(size == LIGHT_MAP_MIN || 2.0 * texel > bound, "{size} is larger than needed");
        assert!(size < LIGHT_MAP_MAX);
        // No translucent instance or no light: the smallest map.
        assert_eq!(light_map_size(&load("single_cube.toml")), LIGHT_MAP_MIN);
        showcase.lights.clear();
        assert_eq!(light_map_size(&showcase), LIGHT_MAP_MIN);
    }

    #[test]
    fn exit_weight_is_zero_on_lit_faces_and_one_head_on() {
        let l = DVec3::new(0.0, 0.0, 1.0);
        assert_eq!(exit_weight(DVec3::Z, l), 1.0);
        assert_eq!(exit_weight(-DVec3::Z, l), 0.0);
        assert_eq!(exit_weight(DVec3::X, l), 0.0);
        let n = DVec3::new(0.0, 0.6, 0.8);
        assert!((exit_weight(n, l) - 0.8).abs() < 1e-15);
    }
}
