//! `KHR_lights_punctual` directional lights → hadou's directional lights. A directional light
//! shines down its node's −z with `color` as it is and its `intensity` in lux (the spec's unit):
//! a white Lambertian surface facing it has luminance E/π cd/m², so hadou's intensity (the
//! luminance it gives such a surface, `DirectionalLight::intensity`) is lux / π. Point (candela)
//! and spot lights are not drawn (named in the file's warning). The brightness of the result is
//! the exposure's business (`[render]`, `effects::tonemap`): a glTF file with lights is shown at
//! the automatic exposure, and no intensity is refused, whatever its size (the frame is
//! pre-exposed, `effects::tonemap::pre_exposure`).

use std::path::Path;

use glam::DVec3;
use gltf::khr_lights_punctual::Kind;

use super::error::GltfError;
use super::ignored::Ignored;
use crate::scene::model::DirectionalLight;
use crate::scene::transform::Transform;

/// The light of `node` placed by `world`, or None for a kind hadou does not draw (noted).
pub(super) fn light(
    path: &Path,
    light: &gltf::khr_lights_punctual::Light,
    node: usize,
    world: &Transform,
    ignored: &mut Ignored,
) -> Result<Option<DirectionalLight>, GltfError> {
    let at = format!("/extensions/KHR_lights_punctual/lights/{}", light.index());
    match light.kind() {
        Kind::Directional => {}
        Kind::Point => {
            ignored.add("point lights", at);
            return Ok(None);
        }
        Kind::Spot { .. } => {
            ignored.add("spot lights", at);
            return Ok(None);
        }
    }
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
    let Some(direction) = world.matrix.transform_vector3(-DVec3::Z).try_normalize() else {
        ignored.add("lights on nodes with a singular transform", format!("/nodes/{node}"));
        return Ok(None);
    };
    Ok(Some(DirectionalLight { direction, color, intensity: lux_to_intensity(intensity) }))
}

/// hadou's intensity of a directional light of `lux` (illuminance on a surface facing it): the
/// luminance of a white Lambertian surface facing it, E/π cd/m².
pub fn lux_to_intensity(lux: f64) -> f64 {
    lux / std::f64::consts::PI
}
