//! glTF materials → hadou materials: `baseColorFactor` is the albedo; `KHR_materials_transmission`
//! with `KHR_materials_volume` makes a translucent material (seed 003) with σ = −ln(c)/d per
//! channel from `attenuationColor` c and `attenuationDistance` d. `emissiveFactor` ×
//! `KHR_materials_emissive_strength` is added to the shaded colour, `alphaMode: MASK` discards
//! fragments whose alpha is below `alphaCutoff` (`model::Surface`); `BLEND` is drawn opaque.
//! `baseColorTexture` multiplies the base colour and `emissiveTexture` the emission
//! (`gltf::texture`); the other textures are noted as not drawn.

use std::path::Path;

use glam::DVec3;
use gltf::material::AlphaMode;

use super::accessor::Source;
use super::error::GltfError;
use super::ignored::Ignored;
use super::texture::{texture_ref, Images};
use crate::scene::model::{Material, MaterialKind, Surface, ThicknessMode};
use crate::scene::texture::MaterialTextures;

/// σ of a channel that glTF does not attenuate (c = 1 or no distance): hadou's translucent
/// materials need σ > 0, and over the largest mesh (1e6 units) this keeps e^(−σd) ≥ 0.999999.
pub const MIN_SIGMA: f64 = 1e-12;
/// The smallest attenuation colour used in σ = −ln(c)/d: c = 0 (all absorbed) would make σ
/// infinite; e^(−σd) at d is then 1e-12, black in any image.
pub const MIN_ATTENUATION_COLOR: f64 = 1e-12;

/// What a mesh is to a volume material: a solid with a thickness table, a closed mesh too thin for
/// one (`builder::MIN_TABLE_VOXELS`), or an open mesh (no thickness of hadou's own).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Shape {
    Solid,
    Thin,
    Open,
}

/// How one glTF material is drawn, before it is tied to a mesh.
#[derive(Clone, Debug)]
pub(super) struct Look {
    pub name: String,
    pub albedo: DVec3,
    /// σ per channel and `thicknessFactor`, for transmission + volume materials.
    pub volume: Option<(DVec3, f64)>,
    /// Emission, alpha and mask.
    pub surface: Surface,
    pub at: String,
}

/// Reads material `m` (None: glTF's default material, white).
pub(super) fn look(
    src: &Source,
    m: &gltf::Material,
    label: &str,
    ignored: &mut Ignored,
    images: &mut Images,
) -> Result<Look, GltfError> {
    let path = src.path;
    let Some(i) = m.index() else {
        let name = format!("{label}default material");
        let surface = Surface::default();
        return Ok(Look { name, albedo: DVec3::ONE, volume: None, surface, at: String::new() });
    };
    let at = format!("/materials/{i}");
    let pbr = m.pbr_metallic_roughness();
    let base = pbr.base_color_factor();
    if !base.iter().all(|c| (0.0..=1.0).contains(c)) {
        let message = format!("{base:?} (expected 4 numbers in [0, 1])");
        return Err(GltfError::at(path, format!("{at}/pbrMetallicRoughness/baseColorFactor"), message));
    }
    note_ignored(m, &at, ignored);
    let transmission = m.transmission().map_or(0.0, |t| t.transmission_factor());
    let volume = match (m.volume(), transmission > 0.0) {
        (Some(v), true) => Some(volume(path, &v, &format!("{at}/extensions/KHR_materials_volume"))?),
        (None, true) => {
            ignored.add("thin-walled transmission without KHR_materials_volume (drawn opaque)", at.clone());
            None
        }
        _ => None,
    };
    let name = match m.name() {
        Some(n) => format!("{label}material {i} \"{n}\""),
        None => format!("{label}material {i}"),
    };
    let mut surface = surface(path, m, &at, base[3] as f64, ignored)?;
    surface.textures = textures(src, m, &at, images)?;
    Ok(Look { name, albedo: DVec3::new(base[0] as f64, base[1] as f64, base[2] as f64), volume, surface, at })
}

/// Emission (`emissiveFactor` in [0, 1] × `KHR_materials_emissive_strength` ≥ 0) and the alpha
/// mode: MASK keeps `alphaCutoff` (≥ 0), BLEND is drawn opaque and noted.
fn surface(
    path: &Path,
    m: &gltf::Material,
    at: &str,
    alpha: f64,
    ignored: &mut Ignored,
) -> Result<Surface, GltfError> {
    let e = m.emissive_factor();
    if !e.iter().all(|c| (0.0..=1.0).contains(c)) {
        let message = format!("{e:?} (expected 3 numbers in [0, 1])");
        return Err(GltfError::at(path, format!("{at}/emissiveFactor"), message));
    }
    let strength = m.emissive_strength().unwrap_or(1.0) as f64;
    if !(strength.is_finite() && strength >= 0.0) {
        let field = format!("{at}/extensions/KHR_materials_emissive_strength/emissiveStrength");
        return Err(GltfError::at(path, field, format!("{strength} (expected a finite number >= 0)")));
    }
    let emission = DVec3::new(e[0] as f64, e[1] as f64, e[2] as f64) * strength;
    let alpha_cutoff = match m.alpha_mode() {
        AlphaMode::Opaque => 0.0,
        AlphaMode::Mask => {
            let c = m.alpha_cutoff().unwrap_or(0.5) as f64;
            if !(c.is_finite() && c >= 0.0) {
                let message = format!("{c} (expected a finite number >= 0)");
                return Err(GltfError::at(path, format!("{at}/alphaCutoff"), message));
            }
            c
        }
        AlphaMode::Blend => {
            ignored.add("alpha blending (alphaMode BLEND, drawn opaque)", format!("{at}/alphaMode"));
            0.0
        }
    };
    Ok(Surface { emission, alpha, alpha_cutoff, textures: MaterialTextures::default() })
}

/// The base-colour and emissive textures, read (and their images decoded) here.
fn textures(
    src: &Source,
    m: &gltf::Material,
    at: &str,
    images: &mut Images,
) -> Result<MaterialTextures, GltfError> {
    let base = match m.pbr_metallic_roughness().base_color_texture() {
        Some(info) => {
            Some(texture_ref(src, &info, &format!("{at}/pbrMetallicRoughness/baseColorTexture"), images)?)
        }
        None => None,
    };
    let emissive = match m.emissive_texture() {
        Some(info) => Some(texture_ref(src, &info, &format!("{at}/emissiveTexture"), images)?),
        None => None,
    };
    Ok(MaterialTextures { base, emissive })
}

/// σ and `thicknessFactor` from a volume, range-checked where glTF sets the ranges.
fn volume(path: &Path, v: &gltf::material::Volume, at: &str) -> Result<(DVec3, f64), GltfError> {
    let c = v.attenuation_color();
    if !c.iter().all(|x| (0.0..=1.0).contains(x)) {
        return Err(GltfError::at(
            path,
            format!("{at}/attenuationColor"),
            format!("{c:?} (expected 3 numbers in [0, 1])"),
        ));
    }
    let d = v.attenuation_distance() as f64;
    // NaN cannot come from JSON; +inf is the default (no attenuation).
    if d.is_nan() || d <= 0.0 {
        return Err(GltfError::at(
            path,
            format!("{at}/attenuationDistance"),
            format!("{d} (expected a number > 0)"),
        ));
    }
    let t = v.thickness_factor() as f64;
    if !(t.is_finite() && t >= 0.0) {
        return Err(GltfError::at(
            path,
            format!("{at}/thicknessFactor"),
            format!("{t} (expected a finite number >= 0)"),
        ));
    }
    Ok((DVec3::from_array(c.map(|x| sigma(x as f64, d))), t))
}

/// σ = −ln(c)/d, kept within what a translucent material holds (`MIN_SIGMA`,
/// `MIN_ATTENUATION_COLOR`; at most f32's largest number).
pub fn sigma(c: f64, d: f64) -> f64 {
    (-c.max(MIN_ATTENUATION_COLOR).ln() / d).clamp(MIN_SIGMA, f32::MAX as f64)
}

impl Look {
    /// The hadou material for a mesh of `shape`: a solid the thickness tables can measure gets a
    /// translucent material. A volume on an open mesh, or on a closed one too thin for a table,
    /// has no thickness of hadou's own: it is drawn opaque with the albedo dimmed by
    /// e^(−σ·thicknessFactor), the light left after crossing the thickness glTF states.
    pub fn material(&self, shape: Shape, voxel_res: u32, file: &Path) -> Material {
        let voxel_res_at =
            format!("{}: {} (KHR_materials_volume; voxel_res {voxel_res})", file.display(), self.at);
        match self.volume {
            Some((sigma, _)) if shape == Shape::Solid => Material {
                name: self.name.clone(),
                kind: MaterialKind::Translucent { sigma, voxel_res, thickness: ThicknessMode::Lut },
                albedo: self.albedo,
                voxel_res_at,
                surface: self.surface.clone(),
            },
            Some((sigma, t)) => Material {
                name: match shape {
                    Shape::Thin => format!("{} (too thin for a thickness table: opaque)", self.name),
                    _ => format!("{} (open mesh: opaque)", self.name),
                },
                kind: MaterialKind::Lambert,
                albedo: self.albedo * DVec3::from_array(sigma.to_array().map(|s| (-s * t).exp())),
                voxel_res_at: String::new(),
                surface: self.surface.clone(),
            },
            None => Material {
                name: self.name.clone(),
                kind: MaterialKind::Lambert,
                albedo: self.albedo,
                voxel_res_at: String::new(),
                surface: self.surface.clone(),
            },
        }
    }
}

/// Textures other than base colour and emissive, and metallic/specular shading, are not drawn by
/// hadou: noted, with where they are.
fn note_ignored(m: &gltf::Material, at: &str, ignored: &mut Ignored) {
    let pbr = m.pbr_metallic_roughness();
    let textures = [
        ("pbrMetallicRoughness/metallicRoughnessTexture", pbr.metallic_roughness_texture().is_some()),
        ("normalTexture", m.normal_texture().is_some()),
        ("occlusionTexture", m.occlusion_texture().is_some()),
        (
            "extensions/KHR_materials_transmission/transmissionTexture",
            m.transmission().is_some_and(|t| t.transmission_texture().is_some()),
        ),
        (
            "extensions/KHR_materials_volume/thicknessTexture",
            m.volume().is_some_and(|v| v.thickness_texture().is_some()),
        ),
    ];
    for (field, present) in textures {
        if present {
            ignored.add("textures hadou does not draw (normal, occlusion, metallic-roughness, transmission, thickness)", format!("{at}/{field}"));
        }
    }
    // Lambert shading is glTF's metallic 0, roughness 1; anything else shades differently.
    if pbr.metallic_factor() > 0.0 {
        ignored.add(
            "metallic and specular shading (hadou shades Lambert)",
            format!("{at}/pbrMetallicRoughness/metallicFactor"),
        );
    }
    if pbr.roughness_factor() < 1.0 {
        ignored.add(
            "metallic and specular shading (hadou shades Lambert)",
            format!("{at}/pbrMetallicRoughness/roughnessFactor"),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigma_from_colour_and_distance() {
        assert!((sigma(0.5, 2.0) - std::f64::consts::LN_2 / 2.0).abs() < 1e-16);
        assert_eq!(sigma(1.0, 1.0), MIN_SIGMA);
        assert_eq!(sigma(0.5, f64::INFINITY), MIN_SIGMA);
        assert!((sigma(0.0, 1.0) - 1e12f64.ln()).abs() < 1e-12);
    }
}
