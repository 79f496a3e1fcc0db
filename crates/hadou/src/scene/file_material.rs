//! `[[material]]` kinds and their fields: `lambert` (albedo only) and `translucent` (seed 003:
//! extinction σ, the thickness LUT's voxel resolution, the thickness mode), plus the rule that a
//! translucent instance's mesh is a closed, oriented solid. Every refusal points at the value (or
//! key) at fault.

use std::ops::Range;

use glam::DVec3;
use toml::Spanned;

use super::error::SceneError;
use super::file_check::{one_of, show, show_vec, Owner, Rule, POSITIVE};
use super::file_schema::MaterialDef;
use super::model::{
    Material, MaterialKind, SceneMesh, ThicknessMode, DEFAULT_VOXEL_RES, MAX_VOXEL_RES, MIN_VOXEL_RES,
};

const KINDS: &[&str] = &["lambert", "translucent"];
const THICKNESS_MODES: &[&str] = &["lut", "tsm", "peel", "pairs"];
/// Attenuation colours: the fraction of light left after `attenuation_distance`, strictly between
/// 0 (σ infinite) and 1 (σ zero).
const OPEN_UNIT: Rule = Rule { ok: |v| v > 0.0 && v < 1.0, bound: "in (0, 1)" };

/// The material's kind with its kind-specific fields checked.
pub(super) fn material_kind(o: &Owner, def: &MaterialDef) -> Result<MaterialKind, SceneError> {
    match o.kind(def.kind.as_ref(), KINDS)? {
        Some("translucent") => translucent(o, def),
        _ => {
            if let Some((field, span)) = translucent_fields(def).into_iter().next() {
                let message = format!(
                    "{}: `{field}` is a field of kind = \"translucent\" only (this material is \"lambert\")",
                    o.label
                );
                return Err(o.ctx.err(o.ctx.key_start(&span)..span.end, message));
            }
            Ok(MaterialKind::Lambert)
        }
    }
}

fn translucent_fields(def: &MaterialDef) -> Vec<(&'static str, Range<usize>)> {
    fn span<T>(v: &Option<Spanned<T>>) -> Option<Range<usize>> {
        v.as_ref().map(Spanned::span)
    }
    let all = [
        ("sigma", span(&def.sigma)),
        ("attenuation_color", span(&def.attenuation_color)),
        ("attenuation_distance", span(&def.attenuation_distance)),
        ("voxel_res", span(&def.voxel_res)),
        ("thickness", span(&def.thickness)),
    ];
    all.into_iter().filter_map(|(f, s)| s.map(|s| (f, s))).collect()
}

fn translucent(o: &Owner, def: &MaterialDef) -> Result<MaterialKind, SceneError> {
    let sigma = sigma(o, def)?;
    let voxel_res =
        o.count("voxel_res", def.voxel_res.as_ref(), DEFAULT_VOXEL_RES, MIN_VOXEL_RES, MAX_VOXEL_RES)?;
    let thickness = match &def.thickness {
        None => ThicknessMode::Lut,
        Some(v) => match v.get_ref().as_str() {
            "lut" => ThicknessMode::Lut,
            "tsm" => ThicknessMode::Tsm,
            "peel" => ThicknessMode::Peel,
            "pairs" => ThicknessMode::Pairs,
            other => {
                return Err(o.fail(v.span(), "thickness", &one_of(THICKNESS_MODES), format!("\"{other}\"")))
            }
        },
    };
    Ok(MaterialKind::Translucent { sigma, voxel_res, thickness })
}

/// σ from `sigma`, or from `attenuation_color` c and `attenuation_distance` d as σ = −ln(c)/d
/// (glTF KHR_materials_volume): exactly one of the two forms.
fn sigma(o: &Owner, def: &MaterialDef) -> Result<DVec3, SceneError> {
    let both = "either `sigma` or `attenuation_color` with `attenuation_distance`";
    match (&def.sigma, &def.attenuation_color, &def.attenuation_distance) {
        (Some(_), color, distance) if color.is_some() || distance.is_some() => {
            let (key, other) = match (color, distance) {
                (Some(c), _) => ("attenuation_color", c.span()),
                (None, Some(d)) => ("attenuation_distance", d.span()),
                (None, None) => ("sigma", o.span.clone()),
            };
            let span = o.ctx.key_start(&other)..other.end;
            let message =
                format!("{}: `{key}` given together with `sigma` (expected {both}, not both)", o.label);
            Err(o.ctx.err(span, message))
        }
        (Some(sigma), _, _) => o.check_vec3("sigma", sigma, POSITIVE),
        (None, Some(color), Some(distance)) => {
            let c = o.check_vec3("attenuation_color", color, OPEN_UNIT)?;
            let d = o.check_num("attenuation_distance", distance, POSITIVE)?;
            let sigma = DVec3::new(-c.x.ln(), -c.y.ln(), -c.z.ln()) / d;
            if !(sigma.is_finite() && sigma.min_element() > 0.0) {
                // A colour a hair below 1 over a huge distance, or a hair above 0 over a tiny one.
                let found = format!("σ = {} from it", show_vec(sigma));
                return Err(o.fail(distance.span(), "attenuation_distance", "a finite σ > 0", found));
            }
            Ok(sigma)
        }
        (None, Some(color), None) => {
            let span = o.ctx.key_start(&color.span())..color.span().end;
            Err(o.ctx.err(span, format!("{}: `attenuation_color` needs `attenuation_distance` too", o.label)))
        }
        (None, None, Some(distance)) => {
            let span = o.ctx.key_start(&distance.span())..distance.span().end;
            Err(o.ctx.err(span, format!("{}: `attenuation_distance` needs `attenuation_color` too", o.label)))
        }
        (None, None, None) => Err(o.fail_here(
            "kind \"translucent\" needs an extinction: `sigma = [r, g, b]` (each > 0, per world unit) \
             or `attenuation_color` (each in (0, 1)) with `attenuation_distance` (> 0)",
        )),
    }
}

/// A translucent material needs a closed, consistently oriented mesh enclosing a positive volume:
/// refused at the instance's `material` value (`span`), naming the mesh and the first bad edge.
pub(super) fn check_instance_mesh(
    o: &Owner,
    span: Range<usize>,
    material: &Material,
    mesh: &SceneMesh,
) -> Result<(), SceneError> {
    if !matches!(material.kind, MaterialKind::Translucent { .. }) {
        return Ok(());
    }
    let fail = |why: String| {
        o.ctx.err(
            span.clone(),
            format!(
                "{} `material`: translucent material \"{}\" needs a closed, consistently oriented mesh, \
                 but mesh \"{}\" is not: {why}",
                o.label, material.name, mesh.name
            ),
        )
    };
    mesh.mesh.check_closed_oriented().map_err(fail)?;
    let volume = mesh.mesh.signed_volume();
    if volume.is_nan() || volume <= 0.0 {
        return Err(fail(format!("it encloses a volume of {} (its faces must point outward)", show(volume))));
    }
    Ok(())
}
