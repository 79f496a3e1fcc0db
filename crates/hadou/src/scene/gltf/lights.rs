//! `KHR_lights_punctual` → hadou's lights, placed by the node's world transform.
//!
//! - A directional light shines down its node's −z with `color` as it is and its `intensity` in
//!   lux (the spec's unit): a white Lambertian surface facing it has luminance E/π cd/m², so
//!   hadou's intensity (the luminance it gives such a surface, `Light::intensity`) is lux / π.
//! - A point light sits at the node's origin, a spot light too, shining down the node's −z; their
//!   `intensity` is in candela, kept as it is (`Light::intensity`): the illuminance on a surface
//!   facing one at distance d is I/d² lux, the luminance of a white surface I/(π·d²) — the same
//!   E/π rule, applied when shading (`Light::radiance`). `range` is the spec's recommended smooth
//!   window clamp(1 − (d/range)⁴, 0, 1) on the inverse square; absent: infinite. A `range` of 0
//!   (the schema says > 0) is read as absent and named in the warning. A spot's
//!   `innerConeAngle`/`outerConeAngle` give the spec's smooth attenuation
//!   (`Light::cone_scale_offset`); inner ≥ outer (Blender writes inner = outer for a hard edge) is
//!   the spec's own guard, a ramp 0.001 wide in cos θ.
//!
//! The brightness of the result is the exposure's business (`[render]`, `effects::tonemap`): a
//! glTF file with lights is shown at the automatic exposure, and no intensity is refused, whatever
//! its size (the frame is pre-exposed, `effects::tonemap::pre_exposure`, point and spot lights by
//! their illuminance at the nearest surface).

use std::path::Path;

use glam::DVec3;
use gltf::khr_lights_punctual::Kind;

use super::error::GltfError;
use super::ignored::Ignored;
use crate::scene::model::Light;
use crate::scene::transform::Transform;

/// The light of `node` placed by `world`, or None where the node cannot place it (noted).
pub(super) fn light(
    path: &Path,
    light: &gltf::khr_lights_punctual::Light,
    node: usize,
    world: &Transform,
    ignored: &mut Ignored,
) -> Result<Option<Light>, GltfError> {
    let at = format!("/extensions/KHR_lights_punctual/lights/{}", light.index());
    let color = DVec3::from_array(light.color().map(f64::from));
    if !(color.is_finite() && color.min_element() >= 0.0) {
        return Err(GltfError::at(path, format!("{at}/color"), format!("{color} (expected numbers >= 0)")));
    }
    let intensity = light.intensity() as f64;
    if !(intensity.is_finite() && intensity >= 0.0) {
        return Err(GltfError::at(
            path,
            format!("{at}/intensity"),
            format!("{intensity} (expected a number >= 0)"),
        ));
    }
    let position = world.matrix.transform_point3(DVec3::ZERO);
    if !position.is_finite() {
        ignored.add("lights on nodes with a singular transform", format!("/nodes/{node}"));
        return Ok(None);
    }
    let direction = world.matrix.transform_vector3(-DVec3::Z).try_normalize();
    let mut range = || -> Result<Option<f64>, GltfError> {
        match light.range().map(f64::from) {
            None => Ok(None),
            Some(0.0) => {
                ignored.add("light ranges of 0 (invalid: drawn as infinite)", format!("{at}/range"));
                Ok(None)
            }
            Some(r) if r.is_finite() && r > 0.0 => Ok(Some(r)),
            Some(r) => {
                Err(GltfError::at(path, format!("{at}/range"), format!("{r} (expected a number > 0)")))
            }
        }
    };
    let out = match light.kind() {
        Kind::Directional => {
            let Some(direction) = direction else {
                ignored.add("lights on nodes with a singular transform", format!("/nodes/{node}"));
                return Ok(None);
            };
            Light::directional(direction, color, lux_to_intensity(intensity))
        }
        Kind::Point => {
            let mut l = Light::point(position, color, intensity);
            l.range = range()?;
            l
        }
        Kind::Spot { inner_cone_angle, outer_cone_angle } => {
            let Some(direction) = direction else {
                ignored.add("lights on nodes with a singular transform", format!("/nodes/{node}"));
                return Ok(None);
            };
            let (inner, outer) = (f64::from(inner_cone_angle), f64::from(outer_cone_angle));
            let half_pi = std::f64::consts::FRAC_PI_2;
            if !(outer.is_finite() && outer > 0.0 && outer <= half_pi + 1e-6) {
                return Err(GltfError::at(
                    path,
                    format!("{at}/spot/outerConeAngle"),
                    format!("{outer} (expected a number in (0, pi/2])"),
                ));
            }
            if !(inner.is_finite() && inner >= 0.0 && inner <= half_pi + 1e-6) {
                return Err(GltfError::at(
                    path,
                    format!("{at}/spot/innerConeAngle"),
                    format!("{inner} (expected a number in [0, pi/2])"),
                ));
            }
            let mut l = Light::spot(position, direction, color, intensity, inner, outer);
            l.range = range()?;
            l
        }
    };
    Ok(Some(out))
}

/// hadou's intensity of a directional light of `lux` (illuminance on a surface facing it): the
/// luminance of a white Lambertian surface facing it, E/π cd/m².
pub fn lux_to_intensity(lux: f64) -> f64 {
    lux / std::f64::consts::PI
}
