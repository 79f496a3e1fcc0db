//! translucency (seed 003) on the CPU in f64: the light's view the `light_id` pass renders from,
//! and the colour the `translucency` pass adds. Twin of shaders/light_id.vert/.frag and
//! shaders/translucency.comp (the thickness itself is `effects::thickness` and `lut_thickness`).
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
//! is the raster's Lambert + ambient (every light), L the first directional light's colour × intensity, d the thickness, and
//! w = max(n·l, 0) the exit weight (`exit_weight`). The seed's eq. 2 alone gives I_out = I_in on a
//! face the light reaches directly (d = 0 there), which adds the light a second time on top of the
//! Lambert term that already counts it: a lit jade cube renders white. The weight is 0 on every face
//! turned toward the light and 1 on a face the light leaves through head-on; for a slab it is the
//! cosine of the light at the opposite, entry face (whose normal is −n), i.e. Lambert's law for the
//! light that got in, and it fades to 0 at the light's terminator, where the Lambert term does too.

use glam::{DMat3, DVec2, DVec3};

use super::thickness::transmittance;
use super::thickness_lut::ThicknessLut;
use super::tonemap::mesh_bounds;
use crate::scene::transform::{frobenius, Transform};
use crate::scene::{MaterialKind, Scene, ThicknessMode};

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
    /// The view along the scene's first directional light fitted to its translucent instances;
    /// `None` without one or without a translucent instance.
    pub fn fit(scene: &Scene) -> Option<LightView> {
        LightView::fit_with(scene, &mesh_bounds(scene))
    }

    /// `fit` with each mesh's object-space bounds known (`mesh_bounds`, in scene order: the
    /// renderer keeps them with the vertex buffers, so a frame reads no vertex).
    pub fn fit_with(scene: &Scene, mesh_bounds: &[(DVec3, DVec3)]) -> Option<LightView> {
        let light = scene.first_directional_light()?;
        let mut corners = Vec::new();
        for inst in &scene.instances {
            if !matches!(scene.materials[inst.material].kind, MaterialKind::Translucent { .. }) {
                continue;
            }
            let (lo, hi) = mesh_bounds[inst.mesh];
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

/// The LUT thickness between the light's entry point `a` and the shaded point `b` (object space)
/// of an instance with transform `m`, as the translucency shader computes it: |M(b − a)| times the
/// inside fraction the field decodes along the segment (`ThicknessLut::inside_fraction`; exact
/// scaling for an affine M). `None` for a non-finite point; 0 for a = b.
///
/// Error bound per pixel (`effects::thickness_lut` march docs): with a* the light's true entry on
/// P's ray, |d − d*| ≤ |a − a*|_world + |M(b − a)|·|{t : dist(p(t), ∂S) ≤ δ}|. The first term is
/// the light map's: a comes from the depth rasterized at a texel centre up to 1.5 texels (the
/// 3×3 search) beside P's ray, so |a − a*| ≤ 1.5·√2·texel·tan θ on a planar entry face at angle
/// θ to the light (the slope), more across its silhouette; `light_map_size` keeps the texel at a
/// quarter voxel.
pub fn lut_thickness(lut: &ThicknessLut, m: &Transform, a: DVec3, b: DVec3) -> Option<f64> {
    if !(a.is_finite() && b.is_finite()) {
        return None;
    }
    let path = (m.transform_point(b) - m.transform_point(a)).length();
    if path.is_nan() || path <= 0.0 {
        return Some(0.0);
    }
    Some(path * lut.inside_fraction(a, b))
}

/// The smallest and largest side of the light_id maps, in texels. 4096 is the least
/// maxImageDimension2D Vulkan allows a device, so every device takes it; at 12 bytes a texel
/// (light_ids R32UI, light_z R32F, light_depth D32) it is 192 MiB, the memory cap.
pub const LIGHT_MAP_MIN: u32 = 256;
pub const LIGHT_MAP_MAX: u32 = 4096;
/// The cap in scenes that draw a `thickness = "peel"` material: its crossing lists take 68 bytes a
/// texel more (passes::peel::image_bytes), 272 MiB at 2048² (1.1 GiB at 4096²).
pub const LIGHT_MAP_MAX_PEEL: u32 = 2048;
/// Map sides are rounded up to a multiple of this.
pub const LIGHT_MAP_STEP: u32 = 256;

/// The side of the light_id maps: texels of at most a quarter of the finest world voxel edge among
/// the translucent instances, so the entry point a texel gives lies within a quarter voxel (times
/// the slope) of the light's own ray; rounded up to a multiple of `LIGHT_MAP_STEP` in
/// [`LIGHT_MAP_MIN`, `LIGHT_MAP_MAX`] (the smallest map for a scene without a translucent instance
/// or a light). When the cap binds (`light_map_texel_voxels` > ¼: fine voxels over a light view
/// wider than 1024 of them, e.g. res 128 instances spread 8 of their sizes apart), the texel is
/// 2R/4096 (2R/2048 with a peel material: `LIGHT_MAP_MAX_PEEL`, the view wider than 512 voxels)
/// and the light-map term of the bound grows with it. Instances that move change the view
/// and so the size, frame by frame (`TranslucentFrame`).
/// The map spans the light view's diameter 2R. An instance's finest world voxel edge is its object
/// edge h = (longest side of the mesh box) / voxel_res shrunk by M's smallest stretch σ_min =
/// 1/‖M⁻¹‖₂ ≥ 1/‖M⁻¹‖_F (Frobenius, on the linear part): h/‖M⁻¹‖_F is a lower bound of it
/// (√3 below the true edge for a uniform scale: the map may be larger than needed).
pub fn light_map_size(scene: &Scene) -> u32 {
    let bounds = mesh_bounds(scene);
    light_map_size_in(scene, &bounds, LightView::fit_with(scene, &bounds).as_ref())
}

/// `light_map_size` with the meshes' bounds known (see `LightView::fit_with`) and the light view
/// already fitted to them (`None`: no light or no translucent instance).
pub fn light_map_size_in(scene: &Scene, mesh_bounds: &[(DVec3, DVec3)], view: Option<&LightView>) -> u32 {
    light_map_size_at(scene, mesh_bounds, view, super::translucency_budget::texel_voxels(scene))
}

/// `light_map_size_in` for a texel target of `texel_voxels` finest voxel edges.
pub(crate) fn light_map_size_at(
    scene: &Scene,
    mesh_bounds: &[(DVec3, DVec3)],
    view: Option<&LightView>,
    texel_voxels: f64,
) -> u32 {
    let Some((diameter, finest)) = view.map(|v| light_map_extent(scene, mesh_bounds, v)) else {
        return LIGHT_MAP_MIN;
    };
    let peel = scene.instances.iter().any(|i| {
        matches!(
            scene.materials[i.material].kind,
            MaterialKind::Translucent { thickness: ThicknessMode::Peel, .. }
        )
    });
    let max = if peel { LIGHT_MAP_MAX_PEEL } else { LIGHT_MAP_MAX };
    let texels = diameter / (texel_voxels * finest);
    if !(texels.is_finite() && texels > 0.0) {
        return max;
    }
    let steps = (texels.min(max as f64) / LIGHT_MAP_STEP as f64).ceil() as u32;
    (steps * LIGHT_MAP_STEP).clamp(LIGHT_MAP_MIN, max)
}

/// The light map's texel in finest voxel edges (the bound `light_map_size` aims at ≤ ¼);
/// `None` without a light or a translucent instance.
pub fn light_map_texel_voxels(scene: &Scene) -> Option<f64> {
    let bounds = mesh_bounds(scene);
    let view = LightView::fit_with(scene, &bounds)?;
    let (diameter, finest) = light_map_extent(scene, &bounds, &view);
    Some(diameter / light_map_size_in(scene, &bounds, Some(&view)) as f64 / finest)
}

/// The light view's diameter 2R and the finest world voxel edge bound (see `light_map_size`).
fn light_map_extent(scene: &Scene, mesh_bounds: &[(DVec3, DVec3)], view: &LightView) -> (f64, f64) {
    let mut finest = f64::INFINITY;
    for inst in &scene.instances {
        let MaterialKind::Translucent { voxel_res, .. } = scene.materials[inst.material].kind else {
            continue;
        };
        let (lo, hi) = mesh_bounds[inst.mesh];
        let inverse_stretch = frobenius(DMat3::from_mat4(inst.transform.inverse));
        finest = finest.min((hi - lo).max_element() / voxel_res as f64 / inverse_stretch);
    }
    (2.0 * view.radius, finest)
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
    /// path's length under any transform; and it shrinks by about the cavity chord through the
    /// cavity cube.
    #[test]
    fn lut_thickness_is_the_path_on_a_box_and_leaves_the_cavity_out() {
        use crate::effects::thickness_lut::{bake, BakeOptions};
        use crate::scene::procedural;
        use crate::scene::transform::TransformOp;
        let options = BakeOptions { threads: 1 };
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
        let (hollow, _) =
            bake(&procedural::cavity_cube(2.0, 0.6, 32, 16).unwrap(), 25, &options, &|_, _| {}).unwrap();
        let (a, b) = (DVec3::new(0.013, 0.011, -1.0), DVec3::new(0.013, 0.011, 1.0));
        let d = lut_thickness(&hollow, &Transform::IDENTITY, a, b).unwrap();
        assert!((d - (2.0 - 1.2)).abs() < 0.5 * hollow.voxel_size, "{d}");
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
        let load = |name: &str| {
            crate::builtin::load(format!("builtin:{}", name.trim_end_matches(".toml")).as_ref()).unwrap()
        };
        for name in ["translucency.toml", "showcase.toml"] {
            let scene = load(name);
            let size = light_map_size(&scene);
            // The Frobenius bound is a lower bound of the finest voxel: the texel in true voxels is
            // at most the texel in bound voxels.
            let texel = light_map_texel_voxels(&scene).unwrap();
            assert!(texel <= 0.25 + 1e-12, "{name}: {size}² map, texel {texel} voxel");
            // One step smaller would not meet the rule: the size is not larger than it asks.
            assert!(size == LIGHT_MAP_MIN || texel * size as f64 / (size - LIGHT_MAP_STEP) as f64 > 0.25);
            assert!(size % LIGHT_MAP_STEP == 0 && size <= LIGHT_MAP_MAX);
        }
        // The showcase's jade cube (a uniform scale, where the true voxel is known): its texel is
        // at most a quarter of it.
        let showcase = load("showcase.toml");
        let view = LightView::fit(&showcase).unwrap();
        let jade = showcase.instances.iter().find(|i| i.name.as_deref() == Some("jade cube")).unwrap();
        let MaterialKind::Translucent { voxel_res, .. } = showcase.materials[jade.material].kind else {
            panic!()
        };
        let (lo, hi) = showcase.meshes[jade.mesh].mesh.bounds();
        let world_voxel = 0.55 * (hi - lo).max_element() / voxel_res as f64;
        let texel = 2.0 * view.radius / light_map_size(&showcase) as f64;
        assert!(texel <= 0.25 * world_voxel * (1.0 + 1e-12), "texel {texel}, voxel {world_voxel}");
        // Where the cap binds (res 128 cubes far apart), the texel is 2R/4096 and reported > ¼.
        let mut wide = showcase.clone();
        for m in &mut wide.materials {
            if let MaterialKind::Translucent { voxel_res, .. } = &mut m.kind {
                *voxel_res = 128;
            }
        }
        let k = wide.instances.iter().position(|i| i.name.as_deref() == Some("jade cube")).unwrap();
        let mut far = wide.instances[k].clone();
        far.transform = Transform::from_ops(&[crate::scene::transform::TransformOp::Translate(DVec3::new(
            60.0, 0.0, 0.0,
        ))])
        .unwrap();
        wide.instances.push(far);
        assert_eq!(light_map_size(&wide), LIGHT_MAP_MAX);
        assert!(light_map_texel_voxels(&wide).unwrap() > 0.25);
        // With a peel material the lists cap the map at 2048².
        let mut peeled = wide.clone();
        for m in &mut peeled.materials {
            if let MaterialKind::Translucent { thickness, .. } = &mut m.kind {
                *thickness = ThicknessMode::Peel;
            }
        }
        assert_eq!(light_map_size(&peeled), LIGHT_MAP_MAX_PEEL);
        // No translucent instance or no light: the smallest map.
        assert_eq!(light_map_size(&load("single_cube.toml")), LIGHT_MAP_MIN);
        let mut dark = showcase;
        dark.lights.clear();
        assert_eq!(light_map_size(&dark), LIGHT_MAP_MIN);
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
