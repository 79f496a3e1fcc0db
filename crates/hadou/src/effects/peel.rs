//! peel on the CPU in f64: twin of the `peel` pass (shaders/peel.vert/.frag) and of
//! `peel_thickness` in shaders/common/translucency_peel.glsl.
//!
//! The GPU rasterizes the peel instances from the light and keeps, per light-map texel, the
//! crossings of the light ray through the texel's centre. Here the same ray is cast exactly
//! (`MeshBvh::crossings`, watertight, in each instance's object space: an affine map keeps inside
//! and outside, so `entering` holds for mirrored instances too) and the same rule applied: P's
//! texel is the one its light-space (x, y) falls in, P's own instance's crossings before z(P)
//! are walked in depth order, and the material is where the winding number is > 0. A texel whose
//! ray crosses more than `PEEL_K` peel surfaces (all peel instances together) overflows.
//!
//! What the twin leaves to the light map (the method's error against P's own light ray, the
//! exact thickness): the texel centre's ray runs up to half a texel diagonal, (√2/2)·(2R/S), beside
//! P's, so each crossing's depth differs by that offset times the surface's slope seen from the
//! light (tan of the angle between its normal and the light); where that ray misses a part P's ray
//! crosses (light silhouettes, cavity rims) a whole interval differs.

use glam::{DVec2, DVec3};

use super::raycast::MeshBvh;
use super::translucency::LightView;
use crate::passes::peel::{is_peel, PEEL_K};
use crate::scene::mesh::MeshError;
use crate::scene::transform::Transform;
use crate::scene::Scene;

/// One crossing of a texel's light ray with a peel instance's surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PeelCrossing {
    /// Light-space depth (world distance from the plane where the light enters the view).
    pub z: f64,
    pub instance: usize,
    /// The light goes into the solid here.
    pub entering: bool,
}

/// The peel thickness of a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PeelThickness {
    /// Material of P's instance between the light and P.
    Inside(f64),
    /// The texel's ray crosses more than `PEEL_K` peel surfaces: the pass falls back to TSM.
    Overflow,
}

/// The peel instances of a scene with the light view and map size the passes use.
pub struct PeelTwin {
    pub view: LightView,
    pub size: u32,
    instances: Vec<(usize, Transform, usize)>,
    bvhs: Vec<Option<MeshBvh>>,
}

impl PeelTwin {
    /// `None` without a light or a translucent instance (the passes add nothing then).
    pub fn new(scene: &Scene) -> Result<Option<PeelTwin>, MeshError> {
        let Some(view) = LightView::fit(scene) else { return Ok(None) };
        let size = super::translucency::light_map_size(scene);
        let instances: Vec<(usize, Transform, usize)> = (0..scene.instances.len())
            .filter(|&i| is_peel(scene, i))
            .map(|i| (i, scene.instances[i].transform, scene.instances[i].mesh))
            .collect();
        let mut bvhs: Vec<Option<MeshBvh>> = scene.meshes.iter().map(|_| None).collect();
        for &(_, _, mesh) in &instances {
            if bvhs[mesh].is_none() {
                bvhs[mesh] = Some(MeshBvh::new(&scene.meshes[mesh].mesh)?);
            }
        }
        Ok(Some(PeelTwin { view, size, instances, bvhs }))
    }

    /// The texel whose list P reads: where its light-space (x, y) falls, clamped to the map (as
    /// shaders/translucency.comp), and P's light-space depth.
    pub fn texel_of(&self, p: DVec3) -> ((u32, u32), f64) {
        let (xy, z) = self.view.project(p);
        let s = self.size as f64;
        let t = |c: f64| ((c * 0.5 + 0.5) * s).floor().clamp(0.0, s - 1.0) as u32;
        ((t(xy.x), t(xy.y)), z)
    }

    /// Every crossing of texel `texel`'s centre ray with a peel instance, sorted by depth.
    pub fn crossings(&self, texel: (u32, u32)) -> Vec<PeelCrossing> {
        let v = &self.view;
        let s = self.size as f64;
        let ndc = DVec2::new(texel.0 as f64 + 0.5, texel.1 as f64 + 0.5) / s * 2.0 - 1.0;
        // On the plane z = 0, where the light enters the view's sphere.
        let origin = v.centre + (v.right * ndc.x + v.up * ndc.y) * v.radius - v.dir * v.radius;
        let mut out = Vec::new();
        for &(instance, transform, mesh) in &self.instances {
            let Some(bvh) = &self.bvhs[mesh] else { continue };
            // In object space the ray's parameter stays the world distance along the unit dir.
            let o = transform.inverse.transform_point3(origin);
            let d = transform.inverse.transform_vector3(v.dir);
            out.extend(bvh.crossings(o, d).into_iter().map(|c| PeelCrossing {
                z: c.t,
                instance,
                entering: c.entering,
            }));
        }
        out.sort_by(|a, b| a.z.total_cmp(&b.z));
        out
    }

    /// The material of `instance` on texel `texel`'s ray before depth `zp` (see the module docs).
    pub fn thickness_in_texel(&self, texel: (u32, u32), instance: usize, zp: f64) -> PeelThickness {
        let all = self.crossings(texel);
        if all.len() > PEEL_K as usize {
            return PeelThickness::Overflow;
        }
        PeelThickness::Inside(inside_before(all.iter().filter(|c| c.instance == instance), zp))
    }

    /// The peel thickness the pass gives point `p` (world) of `instance`.
    pub fn thickness(&self, instance: usize, p: DVec3) -> PeelThickness {
        let (texel, zp) = self.texel_of(p);
        self.thickness_in_texel(texel, instance, zp)
    }
}

/// Σ of the intervals before `zp` where the winding number of `crossings` (sorted by depth:
/// entering +1, leaving −1, from 0) is > 0; the interval open at `zp` counts up to it.
pub fn inside_before<'a>(crossings: impl IntoIterator<Item = &'a PeelCrossing>, zp: f64) -> f64 {
    let (mut winding, mut from, mut d) = (0i64, 0.0, 0.0);
    for c in crossings {
        if c.z >= zp {
            break;
        }
        if winding > 0 {
            d += c.z - from;
        }
        winding += if c.entering { 1 } else { -1 };
        from = c.z;
    }
    if winding > 0 {
        d += zp - from;
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    fn crossing(z: f64, entering: bool) -> PeelCrossing {
        PeelCrossing { z, instance: 0, entering }
    }

    /// A hollow solid: in at 1, out into a cavity at 2, back in at 3, out at 5.
    #[test]
    fn intervals_leave_cavities_out_and_stop_at_the_point() {
        let c = [crossing(1.0, true), crossing(2.0, false), crossing(3.0, true), crossing(5.0, false)];
        assert_eq!(inside_before(&c, 6.0), 3.0);
        assert_eq!(inside_before(&c, 5.0), 3.0);
        assert_eq!(inside_before(&c, 4.0), 2.0);
        assert_eq!(inside_before(&c, 2.5), 1.0);
        assert_eq!(inside_before(&c, 0.5), 0.0);
        // Two overlapping shells count once.
        let o = [crossing(1.0, true), crossing(2.0, true), crossing(3.0, false), crossing(4.0, false)];
        assert_eq!(inside_before(&o, 10.0), 3.0);
    }

    #[test]
    fn hollow_ball_along_its_axis_crosses_six_times() {
        let text = r#"
            [camera]
            position = [0, 0, 5]
            look_at = [0, 0, 0]
            [[light]]
            kind = "directional"
            direction = [0, -1, 0]
            [[mesh]]
            name = "ball"
            kind = "hollow_ball"
            radius = 1
            cavity_radius = 0.2
            [[material]]
            name = "wax"
            kind = "translucent"
            sigma = [1, 1, 1]
            thickness = "peel"
            [[instance]]
            mesh = "ball"
            material = "wax"
        "#;
        let scene = crate::scene::parse_scene(text, std::path::Path::new("inline.toml")).unwrap();
        let twin = PeelTwin::new(&scene).unwrap().unwrap();
        // The bottom of the ball, straight below the centre: the light crossed 2 − 4·0.2 of wax
        // (the tessellation's chords are a little shorter than the spheres' diameters).
        let p = DVec3::new(1e-4, -0.999_999, 1e-4);
        let (texel, _) = twin.texel_of(p);
        assert_eq!(twin.crossings(texel).len(), 6);
        let PeelThickness::Inside(d) = twin.thickness(0, p) else { panic!("overflow") };
        // The texel's ray runs ρ ≤ |p_xz| + (√2/2)·texel from the axis, through the three spheres'
        // polar fans (24 rings): each of its 6 crossings moves by ≤ ρ·tan(π/24) (the fan's slope)
        // plus ρ²/r (the sphere's own drop, r = 1 or 0.2).
        let rho = DVec2::new(p.x, p.z).length() + 0.5f64.sqrt() * 2.0 * twin.view.radius / twin.size as f64;
        let tolerance = 6.0 * rho * (std::f64::consts::PI / 24.0).tan() + rho * rho * (2.0 / 1.0 + 4.0 / 0.2);
        assert!((d - 1.2).abs() <= tolerance, "{d}, tolerance {tolerance}");
    }
}
