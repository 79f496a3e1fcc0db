//! CPU twin of the base shading in f64: the raster surfaces of shaders/raster.frag (Lambert +
//! ambient under the scene's lights, times the vertex colour, plus emission, alpha masked; point
//! and spot lights as shaders/common/frame.glsl's `light_arriving`: `LocalLight`) and the metaball
//! surfaces of
//! shaders/metaballs.comp (`store_hit`: the same diffuse light plus a white Blinn-Phong
//! highlight), then `effects::tonemap` to the 8-bit sRGB code. Written from the model
//! (docs/scene-format.md: "a surface with unit normal n receives colour · intensity ·
//! max(0, −n·direction)", ambient times albedo), not from the shaders' f32 arithmetic; the GPU
//! tests compare it per pixel with a derived bound (tests/gpu_shading.rs).

use glam::DVec3;

use crate::passes::gpu_structs::MAX_LIGHTS;
use crate::scene::{Light, Scene, LOCAL_LIGHT_D2_MIN, LOCAL_LIGHT_MAX};

/// Strength of the white Blinn-Phong highlight on every metaball material. Keep in sync with
/// `SPECULAR` in shaders/metaballs.comp.
pub const METABALL_SPECULAR: f64 = 0.25;
/// Its exponent. Keep in sync with `SHININESS` in shaders/metaballs.comp.
pub const METABALL_SHININESS: f64 = 48.0;
/// The HDR target's largest value (RGBA16F): a metaball's colour is clamped to it.
pub const HALF_MAX: f64 = 65504.0;

/// One directional light as a surface sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceLight {
    /// Unit vector from the surface toward the light (−direction).
    pub to_light: DVec3,
    /// colour × intensity, per channel.
    pub radiance: DVec3,
}

/// One point or spot light as a surface sees it (shaders/common/frame.glsl, `light_arriving`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalLight {
    /// The light (its kind, position, axis, range and cone).
    pub light: Light,
    /// `light.radiance()`: colour × candela / π.
    pub radiance: DVec3,
}

impl LocalLight {
    /// The unit vector from surface point `p` toward the light (0 at the light itself) and the
    /// radiance arriving there before the n·l factor: radiance · window · cone² / max(d²,
    /// `LOCAL_LIGHT_D2_MIN`), capped at `LOCAL_LIGHT_MAX` (`scene::Light` has the model).
    pub fn arriving(&self, p: DVec3) -> (DVec3, DVec3) {
        let v = self.light.position - p;
        let d2 = v.length_squared().max(LOCAL_LIGHT_D2_MIN);
        let l = v / d2.sqrt();
        let f = self.light.window(d2) * self.light.cone_attenuation(-l) / d2;
        (l, (self.radiance * f).min(DVec3::splat(LOCAL_LIGHT_MAX)))
    }
}

/// The scene's ambient light and the lights the passes use (the first `MAX_LIGHTS`):
/// directional ones in `lights`, point and spot ones in `local`.
#[derive(Clone, Debug, PartialEq)]
pub struct Lighting {
    pub ambient: DVec3,
    pub lights: Vec<SurfaceLight>,
    pub local: Vec<LocalLight>,
}

/// A metaball surface's light split as the shader adds it: `albedo × diffuse + specular`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetaballLight {
    /// ambient + Σ over the lights with n·l > 0 of (n·l)·L.
    pub diffuse: DVec3,
    /// Σ over the same lights of SPECULAR·max(n·h, 0)^SHININESS·L, h = normalize(l + v).
    pub specular: DVec3,
}

impl Lighting {
    pub fn new(scene: &Scene) -> Self {
        let used = &scene.lights[..scene.lights.len().min(MAX_LIGHTS)];
        let lights = used
            .iter()
            .filter(|l| !l.is_local())
            .map(|l| SurfaceLight { to_light: -l.direction.normalize(), radiance: l.color * l.intensity })
            .collect();
        let local = used
            .iter()
            .filter(|l| l.is_local())
            .map(|&light| LocalLight { light, radiance: light.radiance() })
            .collect();
        Lighting { ambient: scene.render.ambient, lights, local }
    }

    /// ambient + Σ max(n·l, 0)·L over the directional lights: the light a surface of unit normal
    /// `n` receives wherever it is. Point and spot lights depend on the surface's position and
    /// are not in it (`diffuse_at` has them); for a scene with none, the whole light.
    pub fn diffuse(&self, n: DVec3) -> DVec3 {
        self.lights.iter().fold(self.ambient, |sum, l| sum + l.radiance * n.dot(l.to_light).max(0.0))
    }

    /// ambient + Σ max(n·l, 0)·L over every light at surface point `p` with unit normal `n`;
    /// exactly `diffuse(n)` for directional lights alone.
    pub fn diffuse_at(&self, p: DVec3, n: DVec3) -> DVec3 {
        let directional =
            self.lights.iter().fold(self.ambient, |sum, l| sum + l.radiance * n.dot(l.to_light).max(0.0));
        self.local.iter().fold(directional, |sum, l| {
            let (to_light, arriving) = l.arriving(p);
            sum + arriving * n.dot(to_light).max(0.0)
        })
    }

    /// ambient + Σ L over the directional lights: what a surface facing them all at once would
    /// receive (the scale of `diffuse`, for error bounds; `diffuse_scale_at` with point and spot
    /// lights).
    pub fn diffuse_scale(&self) -> DVec3 {
        self.lights.iter().fold(self.ambient, |sum, l| sum + l.radiance)
    }

    /// ambient + Σ of each light's radiance arriving at `p` (the scale of `diffuse_at`).
    pub fn diffuse_scale_at(&self, p: DVec3) -> DVec3 {
        let directional = self.lights.iter().fold(self.ambient, |sum, l| sum + l.radiance);
        self.local.iter().fold(directional, |sum, l| sum + l.arriving(p).1)
    }

    /// The HDR colour of a raster surface at world point `p` (shaders/raster.frag): albedo ×
    /// `diffuse_at(p, n)`, `n` the unit normal turned toward the camera. Scene-linear: the shader
    /// writes it pre-exposed and capped, `(v · pre_exposure).min(HALF_MAX)`.
    pub fn raster_at(&self, albedo: DVec3, p: DVec3, n: DVec3) -> DVec3 {
        albedo * self.diffuse_at(p, n)
    }

    /// The light of a metaball surface at `p` (`metaball_light` with point and spot lights).
    pub fn metaball_light_at(&self, p: DVec3, n: DVec3, v: DVec3) -> MetaballLight {
        let mut out = self.metaball_directional(n, v);
        for l in &self.local {
            let (to_light, arriving) = l.arriving(p);
            let nl = n.dot(to_light);
            if nl > 0.0 {
                out.diffuse += arriving * nl;
                out.specular += arriving * Self::highlight(n, to_light, v);
            }
        }
        out
    }

    /// The HDR colour of a metaball surface at `p`: min(albedo × diffuse + specular, HALF_MAX).
    pub fn metaball_at(&self, albedo: DVec3, p: DVec3, n: DVec3, v: DVec3) -> DVec3 {
        let m = self.metaball_light_at(p, n, v);
        (albedo * m.diffuse + m.specular).min(DVec3::splat(HALF_MAX))
    }

    /// The HDR colour of a raster surface (shaders/raster.frag): albedo × `diffuse(n)`, `n` the
    /// unit normal turned toward the camera.
    pub fn raster(&self, albedo: DVec3, n: DVec3) -> DVec3 {
        albedo * self.diffuse(n)
    }

    /// The HDR colour of a raster surface of a glTF material (shaders/raster.frag): base colour
    /// (albedo × vertex colour) × `diffuse(n)` + emission. With a white vertex colour and no
    /// emission this is `raster` exactly (the shader multiplies by 1 and adds 0).
    pub fn raster_surface(&self, albedo: DVec3, vertex_color: DVec3, emission: DVec3, n: DVec3) -> DVec3 {
        albedo * vertex_color * self.diffuse(n) + emission
    }

    /// `raster_surface` at world point `p` under every light (scene-linear, as `raster_at`).
    pub fn raster_surface_at(
        &self,
        albedo: DVec3,
        vertex_color: DVec3,
        emission: DVec3,
        p: DVec3,
        n: DVec3,
    ) -> DVec3 {
        albedo * vertex_color * self.diffuse_at(p, n) + emission
    }

    /// Whether the raster draws a fragment of `alpha` (base × vertex colour alpha) under a
    /// material's alpha cutoff (`alphaMode: MASK`; 0 for opaque materials, which draw all).
    pub fn drawn(alpha: f64, cutoff: f64) -> bool {
        alpha >= cutoff
    }

    /// The light of a metaball surface of unit normal `n` (toward the camera) seen along `-v`
    /// (`v` the unit vector from the surface toward the camera) from the ambient and the
    /// directional lights (`metaball_light_at` adds point and spot lights): only lights with
    /// n·l > 0 add a diffuse and a highlight term.
    pub fn metaball_light(&self, n: DVec3, v: DVec3) -> MetaballLight {
        self.metaball_directional(n, v)
    }

    fn metaball_directional(&self, n: DVec3, v: DVec3) -> MetaballLight {
        let mut out = MetaballLight { diffuse: self.ambient, specular: DVec3::ZERO };
        for l in &self.lights {
            let nl = n.dot(l.to_light);
            if nl > 0.0 {
                out.diffuse += l.radiance * nl;
                out.specular += l.radiance * Self::highlight(n, l.to_light, v);
            }
        }
        out
    }

    /// SPECULAR·max(n·h, 0)^SHININESS with h = normalize(l + v); 0 where l = −v (no half vector).
    pub fn highlight(n: DVec3, l: DVec3, v: DVec3) -> f64 {
        let h = (l + v).normalize_or_zero();
        METABALL_SPECULAR * n.dot(h).max(0.0).powf(METABALL_SHININESS)
    }

    /// The HDR colour of a metaball surface: min(albedo × diffuse + specular, HALF_MAX).
    pub fn metaball(&self, albedo: DVec3, n: DVec3, v: DVec3) -> DVec3 {
        let m = self.metaball_light(n, v);
        (albedo * m.diffuse + m.specular).min(DVec3::splat(HALF_MAX))
    }
}

/// The 8-bit sRGB code (unrounded) of each channel of an HDR colour after exposure, the ACES
/// curve and the sRGB encoding (`tonemap::tonemap_channel`).
pub fn ldr_code(hdr: DVec3, exposure: f64) -> DVec3 {
    DVec3::from_array(hdr.to_array().map(|c| super::tonemap::tonemap_channel(c, exposure)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lighting() -> Lighting {
        Lighting {
            ambient: DVec3::new(0.1, 0.2, 0.3),
            lights: vec![
                SurfaceLight { to_light: DVec3::Y, radiance: DVec3::new(2.0, 1.0, 0.5) },
                SurfaceLight { to_light: DVec3::X, radiance: DVec3::splat(3.0) },
            ],
            local: Vec::new(),
        }
    }

    #[test]
    fn lambert_terms() {
        let l = lighting();
        // Facing the first light only (perpendicular to the second: it adds exactly nothing).
        assert_eq!(l.diffuse(DVec3::Y), DVec3::new(2.1, 1.2, 0.8));
        // Facing away from both: ambient alone.
        assert_eq!(l.diffuse(-DVec3::ONE.normalize()), l.ambient);
        // 60° from the second light: half of it.
        let n = DVec3::new(0.5, 0.0, 0.75f64.sqrt());
        assert!((l.diffuse(n) - (l.ambient + DVec3::splat(1.5))).abs().max_element() < 1e-15);
        assert_eq!(l.raster(DVec3::new(0.5, 1.0, 0.0), DVec3::Y), DVec3::new(1.05, 1.2, 0.0));
    }

    #[test]
    fn metaball_highlight_peaks_at_the_mirror_direction() {
        let l = lighting();
        // n halfway between the first light and the viewer: h = n, the full highlight.
        let v = DVec3::Z;
        let n = (DVec3::Y + v).normalize();
        let m = l.metaball_light(n, v);
        let nl = n.dot(DVec3::Y);
        // The second light is perpendicular to n: no highlight either. (n·h is 1 within a few
        // ulps, raised to the 48th: 48 times that.)
        let expected = DVec3::new(2.0, 1.0, 0.5) * METABALL_SPECULAR;
        assert!((m.specular - expected).abs().max_element() < 1e-13, "{m:?}");
        assert!((m.diffuse - (l.ambient + DVec3::new(2.0, 1.0, 0.5) * nl)).abs().max_element() < 1e-15);
        // A light behind the surface adds neither term, even where its half vector meets n.
        let behind = l.metaball_light(-DVec3::Y, DVec3::NEG_Y);
        assert_eq!(behind.diffuse, l.ambient);
        assert_eq!(behind.specular, DVec3::ZERO);
    }
}
