//! `[[mesh]]` tables → `SceneMesh`: the kind decides which fields exist, their defaults and
//! ranges; then the mesh is generated or loaded, and its errors placed in the scene file.

use std::ops::Range;
use std::path::{Path, PathBuf};

use toml::Spanned;

use super::error::SceneError;
use super::file_check::{one_of, Ctx, Owner, Rule, UniqueNames, UNIT};
use super::file_schema::{MeshDef, Tables};
use super::mesh::{MeshError, MeshSpec};
use super::model::SceneMesh;
use super::procedural::{MAX_LENGTH, MAX_SEGMENTS, MIN_LENGTH};
use super::wobble::{Wobble, MAX_WOBBLE};

/// Each kind with the fields it accepts (besides `name` and `kind`).
const KINDS: &[(&str, &[&str])] = &[
    ("plane", &["size"]),
    ("cube", &["size"]),
    ("sphere", &["radius", "segments", "rings"]),
    ("torus", &["major_radius", "minor_radius", "segments", "sides"]),
    ("tetrahedron", &["size"]),
    ("cavity_cube", &["size", "cavity_radius", "segments", "rings"]),
    ("hollow_ball", &["radius", "cavity_radius", "segments", "rings"]),
    ("bottle", &["radius", "height", "wall", "fill", "segments"]),
    ("obj", &["path"]),
];

/// Lengths (sizes, radii, height, wall) in the generators' range; see `procedural::MIN_LENGTH`.
const LENGTH: Rule = Rule { ok: |v| (MIN_LENGTH..=MAX_LENGTH).contains(&v), bound: "in [1e-6, 1e6]" };

pub(super) fn meshes(ctx: Ctx, defs: &Tables<MeshDef>) -> Result<Vec<SceneMesh>, SceneError> {
    let mut names = UniqueNames::new("mesh");
    let mut out = Vec::with_capacity(defs.0.len());
    for def in &defs.0 {
        let name = Owner::new(ctx, "[[mesh]]", def.span()).name(def.get_ref().name.as_ref())?;
        names.insert(ctx, name)?;
        let owner = Owner::new(ctx, format!("mesh \"{}\"", name.get_ref()), def.span());
        out.push(mesh(owner, name.get_ref(), def.get_ref())?);
    }
    Ok(out)
}

fn mesh(owner: Owner, name: &str, def: &MeshDef) -> Result<SceneMesh, SceneError> {
    let kinds: Vec<&str> = KINDS.iter().map(|(k, _)| *k).collect();
    let kind = owner.kind(def.kind.as_ref(), &kinds)?;
    let kind =
        kind.ok_or_else(|| owner.fail_here(format!("missing `kind` (expected {})", one_of(&kinds))))?;
    check_fields_belong(&owner, def, kind)?;
    let spec = spec(&owner, def, kind)?;
    let mesh = spec.build().map_err(|e| build_error(&owner, def, kind, e))?;
    let wobble = wobble(&owner, def)?;
    Ok(SceneMesh { name: name.to_owned(), spec, mesh, wobble })
}

/// `wobble` (fraction of the mesh's longest box side, ≤ `MAX_WOBBLE`) and `wobble_hz`, for any kind.
fn wobble(o: &Owner, d: &MeshDef) -> Result<Option<Wobble>, SceneError> {
    const AMPLITUDE: Rule = Rule { ok: |v| (0.0..=MAX_WOBBLE).contains(&v), bound: "in [0, 0.1]" };
    const HZ: Rule = Rule { ok: |v| (0.0..=1000.0).contains(&v), bound: "in [0, 1000]" };
    let amplitude = o.num("wobble", d.wobble.as_ref(), 0.0, AMPLITUDE)?;
    let hz = o.num("wobble_hz", d.wobble_hz.as_ref(), 0.5, HZ)?;
    Ok((amplitude > 0.0).then_some(Wobble { amplitude, hz }))
}

/// Refuses a key that is not a field of this kind (another kind's field or no field at all),
/// pointing at the key and listing the kind's fields.
fn check_fields_belong(owner: &Owner, def: &MeshDef, kind: &str) -> Result<(), SceneError> {
    let allowed = KINDS.iter().find(|(k, _)| *k == kind).map_or(&[][..], |(_, f)| f);
    let fields = ["name", "kind"].iter().chain(allowed).chain(&["wobble", "wobble_hz"]);
    let expected: Vec<String> = fields.map(|f| format!("`{f}`")).collect();
    let expected = expected.join(", ");
    if let Some(key) = def.unknown.first() {
        let message =
            format!("{}: unknown field `{}` (expected one of {expected})", owner.label, key.get_ref());
        return Err(owner.ctx.err(key.span(), message));
    }
    for (field, span) in given_fields(def) {
        if !allowed.contains(&field) {
            let message = format!(
                "{}: `{field}` is not a field of mesh kind `{kind}` (expected one of {expected})",
                owner.label
            );
            return Err(owner.ctx.err(owner.ctx.key_start(&span)..span.end, message));
        }
    }
    Ok(())
}

fn given_fields(def: &MeshDef) -> Vec<(&'static str, Range<usize>)> {
    fn span<T>(v: &Option<Spanned<T>>) -> Option<Range<usize>> {
        v.as_ref().map(Spanned::span)
    }
    let all = [
        ("size", span(&def.size)),
        ("radius", span(&def.radius)),
        ("segments", span(&def.segments)),
        ("rings", span(&def.rings)),
        ("major_radius", span(&def.major_radius)),
        ("minor_radius", span(&def.minor_radius)),
        ("sides", span(&def.sides)),
        ("cavity_radius", span(&def.cavity_radius)),
        ("height", span(&def.height)),
        ("wall", span(&def.wall)),
        ("fill", span(&def.fill)),
        ("path", span(&def.path)),
    ];
    all.into_iter().filter_map(|(f, s)| s.map(|s| (f, s))).collect()
}

/// The kind's `MeshSpec` with defaults filled in and each field's own range checked here, where
/// its span is known. Rules between fields (minor < major radius, cavity inside the cube, bottle
/// wall proportions) belong to the generators; `build_error` places their errors.
fn spec(o: &Owner, d: &MeshDef, kind: &str) -> Result<MeshSpec, SceneError> {
    let length = |field, v, default| o.num(field, v, default, LENGTH);
    let count = |field, v, default, min| o.count(field, v, default, min, MAX_SEGMENTS);
    let size = |default| length("size", d.size.as_ref(), default);
    let radius = |default| length("radius", d.radius.as_ref(), default);
    let segments = |default| count("segments", d.segments.as_ref(), default, 3);
    let rings = |default| count("rings", d.rings.as_ref(), default, 2);
    Ok(match kind {
        "plane" => MeshSpec::Plane { size: size(1.0)? },
        "cube" => MeshSpec::Cube { size: size(1.0)? },
        "tetrahedron" => MeshSpec::Tetrahedron { size: size(1.0)? },
        "sphere" => MeshSpec::Sphere { radius: radius(1.0)?, segments: segments(32)?, rings: rings(16)? },
        "torus" => MeshSpec::Torus {
            major_radius: length("major_radius", d.major_radius.as_ref(), 1.0)?,
            minor_radius: length("minor_radius", d.minor_radius.as_ref(), 0.35)?,
            segments: segments(48)?,
            sides: count("sides", d.sides.as_ref(), 24, 3)?,
        },
        "cavity_cube" => MeshSpec::CavityCube {
            size: size(2.0)?,
            cavity_radius: length("cavity_radius", d.cavity_radius.as_ref(), 0.6)?,
            segments: segments(32)?,
            rings: rings(16)?,
        },
        "hollow_ball" => MeshSpec::HollowBall {
            radius: radius(1.0)?,
            cavity_radius: length("cavity_radius", d.cavity_radius.as_ref(), 0.2)?,
            segments: segments(48)?,
            rings: rings(24)?,
        },
        "bottle" => MeshSpec::Bottle {
            // The seed's proportions (assets/scenes/translucency.toml): at 56³ its thickness field
            // is 70 KB and bakes in ~0.1 s; a fatter bottle (r = 0.5) has about 2.5× the bytes.
            radius: radius(0.3)?,
            height: length("height", d.height.as_ref(), 1.6)?,
            wall: length("wall", d.wall.as_ref(), 0.04)?,
            fill: o.num("fill", d.fill.as_ref(), 0.5, UNIT)?,
            segments: segments(48)?,
        },
        _ => MeshSpec::Obj { path: obj_path(o, d)? },
    })
}

/// The OBJ path resolved against the scene file's folder, checked readable before loading so the
/// error points at the `path` value.
fn obj_path(o: &Owner, d: &MeshDef) -> Result<PathBuf, SceneError> {
    let path = o.required("path", d.path.as_ref(), "a path to a .obj file, relative to the scene file")?;
    let resolved = resolve(o.ctx.path, path.get_ref());
    // The type is checked before opening: opening a FIFO blocks until a writer comes.
    let readable = std::fs::metadata(&resolved).and_then(|m| {
        if m.is_file() {
            std::fs::File::open(&resolved).map(drop)
        } else {
            Err(std::io::Error::other("not a regular file"))
        }
    });
    match readable {
        Ok(()) => Ok(resolved),
        Err(e) => Err(o.ctx.err(
            path.span(),
            format!(
                "{} `path`: cannot read OBJ file {}: {e} (expected a readable .obj file)",
                o.label,
                resolved.display()
            ),
        )),
    }
}

fn resolve(scene: &Path, relative: &str) -> PathBuf {
    match scene.parent() {
        Some(dir) => dir.join(relative),
        None => PathBuf::from(relative),
    }
}

/// Places a build failure: file problems at the `path` value; a generator's parameter problem
/// ("torus minor_radius must be …") at the field it names when the file wrote that field, else at
/// the table.
fn build_error(o: &Owner, d: &MeshDef, kind: &str, e: MeshError) -> SceneError {
    let span = match (&e, &d.path) {
        (MeshError::Io { .. } | MeshError::Obj { .. }, Some(path)) => Some(path.span()),
        (MeshError::Invalid(message), _) => named_field(message, kind)
            .and_then(|f| given_fields(d).into_iter().find(|(g, _)| *g == f))
            .map(|(_, span)| span),
        _ => None,
    };
    o.ctx.err(span.unwrap_or(o.span.clone()), format!("{}: {e}", o.label))
}

/// The field a generator message names: the word after the kind ("torus minor_radius must …").
fn named_field<'m>(message: &'m str, kind: &str) -> Option<&'m str> {
    message.strip_prefix(kind)?.strip_prefix(' ')?.split(' ').next()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn length_bound_text_matches_the_generators() {
        assert_eq!(LENGTH.bound, format!("in [{MIN_LENGTH:e}, {MAX_LENGTH:e}]"));
    }

    #[test]
    fn named_field_reads_the_generator_message() {
        assert_eq!(named_field("torus minor_radius must be < 1, got 2", "torus"), Some("minor_radius"));
        assert_eq!(named_field("something else", "torus"), None);
    }
}
