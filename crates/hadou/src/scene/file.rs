//! Reading a scene file: TOML (schema in file_schema.rs, documented in docs/scene-format.md) →
//! validated `Scene`. Every refusal is a `SceneError` at the line:col of the offending value.

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat4, DVec3};
use toml::Spanned;

use super::camera::Camera;
use super::error::SceneError;
use super::file_check::{
    show, show_vec, show_vec_approx, Ctx, Owner, Rule, UniqueNames, ANY, F32_NORMAL, FOV, HDR, NON_NEGATIVE,
    POSITIVE, UNIT,
};
use super::file_gltf::gltf_files;
use super::file_mesh::meshes;
use super::file_schema::{
    CameraDef, InstanceDef, LightDef, MaterialDef, NumOrWord, OpDef, RenderDef, SceneDef, Tables,
};
use super::model::{
    ExposureMode, Instance, Light, LightKind, Material, MaterialKind, MetaballGroup, RenderSettings, Scene,
    SceneMesh,
};
use super::transform::{Transform, TransformOp};
use crate::effect::{EffectStates, Effects, SceneFile};
use crate::effects::tonemap::ev100_exposure;

/// The most lights (directional, point and spot together) a scene may have (the frame uniform's
/// array).
pub const MAX_LIGHTS: usize = 8;
/// The largest image side, lavapipe's and most GPUs' 2D image limit.
pub const MAX_IMAGE_SIZE: u32 = 16384;
/// Name and albedo of the material instances get when they name none.
pub const DEFAULT_MATERIAL: &str = "default";
/// The largest colour the HDR target (RGBA16F) holds; more would be stored as +inf. The
/// background and the ambient are kept at or below it; the lights are not limited: the frame is
/// pre-exposed so that a lit surface stays well below it (`effects::tonemap::pre_exposure`).
pub const MAX_HDR: f64 = 65504.0;
/// The largest far / near ratio. A surface at view depth z gets the reverse-Z depth
/// near·(far − z)/(z·(far − near)), about near/far for z = far/2: it must stay a normal f32
/// (≥ 2⁻¹²⁶) in the D32 buffer, since a GPU may flush a subnormal to 0, the cleared depth that
/// no surface passes. f32's relative precision is the same at every normal magnitude, so a larger
/// ratio costs no depth precision below this.
pub const MAX_FAR_NEAR_RATIO: f64 = 8.507059173023462e37; // 2^126
/// The largest camera coordinate and `far` (2⁴⁸ ≈ 2.8e14): every visible point's clip-space w
/// (its view depth) stays below it. Measured on lavapipe, triangles at w ≳ 2⁵³ (a scene scaled by
/// 2e15) are dropped and the image is empty; 2⁴⁸ leaves a factor 32.
pub const MAX_EXTENT: f64 = 281474976710656.0;
/// Albedo (each channel) of the built-in default material and of a `[[material]]` that gives none.
pub const DEFAULT_ALBEDO: f64 = 0.7;

/// The top-level tables of hadou's own scene format (docs/scene-format.md); an effect's tables
/// (`Effect::tables`) come after them.
pub const SCENE_TABLES: &[&str] = &["render", "camera", "light", "mesh", "material", "instance", "gltf"];

/// Reads and validates the scene file at `path` with hadou's own effects.
/// A .gltf or .glb file is read as a glTF scene (`scene::gltf::load_gltf`).
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    load_scene_with(path, &Effects::builtin())
}

/// Reads and validates the scene file at `path`; the tables of `effects` are read by them.
pub fn load_scene_with(path: &Path, effects: &Effects) -> Result<Scene, SceneError> {
    if super::gltf::is_gltf(path) {
        return super::gltf::load_gltf(path);
    }
    let unreadable =
        |e| SceneError::whole_file(path, format!("cannot read scene file: {e} (expected a readable file)"));
    // The type is checked before opening: a FIFO would block, a device might never end.
    let meta = std::fs::metadata(path).map_err(unreadable)?;
    if !meta.is_file() {
        return Err(unreadable(std::io::Error::other("not a regular file")));
    }
    let bytes = std::fs::read(path).map_err(unreadable)?;
    let text = String::from_utf8(bytes).map_err(|e| not_utf8(path, &e))?;
    parse_scene_with(&text, path, effects)
}

/// Validates scene `text` with hadou's own effects; `path` names it in errors and anchors
/// relative OBJ paths.
pub fn parse_scene(text: &str, path: &Path) -> Result<Scene, SceneError> {
    parse_scene_with(text, path, &Effects::builtin())
}

/// Validates scene `text`; the tables of `effects` are read by them (`Effect::load`), any other
/// table that is not hadou's own is refused at its line:col.
pub fn parse_scene_with(text: &str, path: &Path, effects: &Effects) -> Result<Scene, SceneError> {
    let ctx = Ctx { text, path };
    let tables = crate::effect::top_level_keys(text).map_err(|e| ctx.toml(&e))?;
    check_tables(ctx, &tables, effects)?;
    let def: SceneDef = toml::from_str(text).map_err(|e| ctx.toml(&e))?;
    let render = render(ctx, def.render.as_ref())?;
    // With a [[gltf]] the camera may come from the glTF file (or frame the scene).
    let toml_camera = match (&def.camera, def.gltf.0.is_empty()) {
        (None, false) => None,
        (c, _) => Some(camera(ctx, c.as_ref())?),
    };
    let mut lights = lights(ctx, &def.light)?;
    let mut meshes = meshes(ctx, &def.mesh)?;
    let mut materials = Materials::new(materials(ctx, &def.material)?);
    let mut instances = instances(ctx, &def.instance, &meshes, &mut materials)?;
    // Effects read their tables here: after the materials they may name, before the glTF files
    // append theirs (so a "default" material an effect adds keeps its place).
    let cell = std::cell::RefCell::new(materials);
    let effects = effect_states(SceneFile::with_materials(text, path, &cell), &tables, effects)?;
    let mut materials = cell.into_inner();
    let placed = gltf_files(ctx, &def.gltf, &mut meshes, &mut materials, &mut instances)?;
    let camera = match (toml_camera, placed.camera) {
        (Some(c), _) => c,
        (None, Some(g)) => g.camera,
        (None, None) => {
            check_framable(ctx, &def.instance, &meshes, &instances)?;
            super::gltf::framing(super::gltf::scene_bounds(&meshes, &instances))
        }
    };
    if !def.gltf.0.is_empty() && lights.is_empty() {
        lights = placed.lights;
        if lights.is_empty() {
            let direction = super::gltf::DEFAULT_LIGHT_DIRECTION.normalize();
            lights.push(Light::directional(direction, DVec3::ONE, 1.0));
        }
    }
    let materials = materials.list;
    let metaballs = effects.get::<crate::effects::metaballs::MetaballGroups>().map_or(&[][..], |g| &g.0);
    warn_unused(path, &meshes, &materials, &instances, metaballs);
    let translucent = materials.iter().any(|m| matches!(m.kind, MaterialKind::Translucent { .. }));
    if translucent && lights.iter().any(Light::is_local) {
        log::warn!(
            "{}: point and spot lights light the surfaces of translucent materials, not through them (the light \
             through them is the first directional light's; docs/scene-format.md)",
            path.display()
        );
    }
    let quality = Default::default();
    Ok(Scene {
        source: path.to_path_buf(),
        render,
        camera,
        lights,
        meshes,
        materials,
        instances,
        effects,
        quality,
    })
}

/// A scene framed by a camera hadou places (no `[camera]`, no glTF camera): its `[[instance]]`s
/// (the first of `instances`, in file order) must lie within ±`MAX_WORLD` = 2⁴⁴, as glTF instances
/// must (`gltf::limits`), so the framing camera stands and sees within 2⁴⁸ (`MAX_EXTENT`). One past
/// it is refused at its `transform`: hadou would otherwise place a camera the raster cannot resolve.
fn check_framable(
    ctx: Ctx,
    defs: &Tables<InstanceDef>,
    meshes: &[SceneMesh],
    instances: &[Instance],
) -> Result<(), SceneError> {
    let limit = super::gltf::MAX_WORLD;
    for (i, (def, instance)) in defs.0.iter().zip(instances).enumerate() {
        let Some(bounds) = super::gltf::scene_bounds(meshes, std::slice::from_ref(instance)) else {
            continue;
        };
        let far = bounds.all.0.abs().max(bounds.all.1.abs()).max_element();
        if far.is_nan() || far > limit {
            let d = def.get_ref();
            let label = match &d.name {
                Some(name) => format!("instance \"{}\"", name.get_ref()),
                None => format!("instance {}", i + 1),
            };
            let span = d.transform.as_ref().map_or(def.span(), Spanned::span);
            let message = format!(
                "{label} `transform`: its world box reaches {}, past ±{} (2^44), the farthest a scene \
                 without a camera can frame (the framing camera stands and sees within 2^48, \
                 docs/scene-format.md \"Numeric limits\"): give the scene a [camera], or move the \
                 instance nearer the origin",
                super::gltf::show_computed(far),
                super::gltf::show_computed(limit)
            );
            return Err(ctx.err(span, message));
        }
    }
    Ok(())
}

/// Refuses a top-level table that neither hadou's format nor a registered effect reads.
fn check_tables(ctx: Ctx, tables: &[Spanned<String>], effects: &Effects) -> Result<(), SceneError> {
    let known = |t: &str| SCENE_TABLES.contains(&t) || effects.reading(t).is_some();
    let Some(unknown) = tables.iter().find(|t| !known(t.get_ref())) else { return Ok(()) };
    let names: Vec<String> = SCENE_TABLES
        .iter()
        .copied()
        .chain(effects.iter().flat_map(|e| e.tables().iter().copied()))
        .map(|t| format!("`{t}`"))
        .collect();
    let message = format!("unknown field `{}`, expected one of {}", unknown.get_ref(), names.join(", "));
    Err(ctx.err(unknown.span(), message))
}

/// The world data of each effect whose tables the file has.
fn effect_states(
    file: SceneFile,
    tables: &[Spanned<String>],
    effects: &Effects,
) -> Result<EffectStates, SceneError> {
    let mut states = EffectStates::default();
    for effect in effects.iter() {
        if !tables.iter().any(|t| effect.tables().contains(&t.get_ref().as_str())) {
            continue;
        }
        if let Some(state) = effect.load(&file)? {
            states.insert_boxed(effect.name(), state);
        }
    }
    Ok(states)
}

fn not_utf8(path: &Path, e: &std::string::FromUtf8Error) -> SceneError {
    let bytes = e.as_bytes();
    let valid = e.utf8_error().valid_up_to();
    // The prefix before the bad byte is valid UTF-8 by definition; it gives the line:col.
    let prefix = std::str::from_utf8(&bytes[..valid]).unwrap_or_default();
    let byte = bytes.get(valid).copied().unwrap_or_default();
    let message = format!("invalid UTF-8 (byte 0x{byte:02x}); expected a UTF-8 text file");
    SceneError::at_offset(path, prefix, valid, message)
}

fn render(ctx: Ctx, def: Option<&Spanned<RenderDef>>) -> Result<RenderSettings, SceneError> {
    let mut r = RenderSettings::default();
    let Some(def) = def else { return Ok(r) };
    let o = Owner::new(ctx, "[render]", def.span());
    let d = def.get_ref();
    if let Some(size) = &d.size {
        for (dim, side) in size.0.iter().zip([&mut r.width, &mut r.height]) {
            let n = dim.get_ref().0;
            *side = match u32::try_from(n) {
                Ok(n) if (1..=MAX_IMAGE_SIZE).contains(&n) => n,
                _ => return Err(o.fail(dim.span(), "size", &format!("integers in 1..={MAX_IMAGE_SIZE}"), n)),
            };
        }
    }
    (r.exposure, r.exposure_mode) = exposure(&o, d)?;
    r.background = o.vec3("background", d.background.as_ref(), r.background, HDR)?;
    r.ambient = o.vec3("ambient", d.ambient.as_ref(), r.ambient, HDR)?;
    r.budget_ms = d.budget_ms.as_ref().map(|b| o.check_num("budget_ms", b, BUDGET_MS)).transpose()?;
    Ok(r)
}

/// `exposure` (a number or `"auto"`) or `exposure_ev100`, at most one of them.
fn exposure(o: &Owner, d: &RenderDef) -> Result<(f64, ExposureMode), SceneError> {
    let linear = RenderSettings::default().exposure;
    match (&d.exposure, &d.exposure_ev100) {
        (Some(_), Some(ev)) => Err(o.fail(
            ev.span(),
            "exposure_ev100",
            "either `exposure` or `exposure_ev100`, not both",
            "both",
        )),
        (None, None) => Ok((linear, ExposureMode::Linear)),
        (None, Some(ev)) => {
            let ev100 = o.check_num("exposure_ev100", ev, EV100)?;
            Ok((ev100_exposure(ev100), ExposureMode::Ev100(ev100)))
        }
        (Some(e), None) => match e.get_ref() {
            NumOrWord::Word(w) if w == "auto" => Ok((linear, ExposureMode::Auto)),
            NumOrWord::Word(w) => Err(o.fail(e.span(), "exposure", "a number or \"auto\"", format!("{w:?}"))),
            NumOrWord::Num(n) => {
                let v = Spanned::new(e.span(), *n);
                Ok((o.check_num("exposure", &v, F32_NORMAL)?, ExposureMode::Linear))
            }
        },
    }
}

/// `exposure_ev100`: 1 / (1.2 · 2^EV100) must be a normal f32 and so must its inverse (the
/// pre-exposure, effects::tonemap::pre_exposure): |EV100| ≤ 120 keeps both within 2^±121.
/// `budget_ms`: a GPU frame time (`crate::budget::BUDGET_RANGE_MS`).
const BUDGET_MS: Rule = Rule {
    ok: |v| crate::budget::BUDGET_RANGE_MS.contains(&v),
    bound: "in [0.001, 1000000] (ms of GPU time per frame)",
};
const EV100: Rule = Rule { ok: |v| (-120.0..=120.0).contains(&v), bound: "in [-120, 120]" };

fn camera(ctx: Ctx, def: Option<&Spanned<CameraDef>>) -> Result<Camera, SceneError> {
    let def = def.ok_or_else(|| {
        ctx.err(0..0, "missing required table [camera] (expected at least `position` and `look_at`)")
    })?;
    let o = Owner::new(ctx, "[camera]", def.span());
    let c = def.get_ref();
    let vec3 = "an array of 3 numbers";
    let position_def = o.required("position", c.position.as_ref(), vec3)?;
    let position = o.check_vec3("position", position_def, ANY)?;
    let look_at_def = o.required("look_at", c.look_at.as_ref(), vec3)?;
    let look_at = o.check_vec3("look_at", look_at_def, ANY)?;
    let up = o.vec3("up", c.up.as_ref(), DVec3::Y, ANY)?;
    let fov_y_deg = o.num("fov_y_deg", c.fov_y_deg.as_ref(), 45.0, FOV)?;
    let near = o.num("near", c.near.as_ref(), 0.1, POSITIVE)?;
    let far = o.num("far", c.far.as_ref(), Camera::DEFAULT_FAR, EXTENT)?;
    for (field, v) in [("position", position_def), ("look_at", look_at_def)] {
        o.check_vec3(field, v, EXTENT)?;
    }
    if far <= near {
        let span = c.far.as_ref().or(c.near.as_ref()).map_or(o.span.clone(), Spanned::span);
        let default = if c.far.is_none() { " (the default)" } else { "" };
        return Err(o.fail(
            span,
            "far",
            &format!("a number > near ({})", show(near)),
            format!("{}{default}", show(far)),
        ));
    }
    check_near_far_ratio(&o, c, near, far)?;
    // try_normalize also refuses a difference that overflows to infinity.
    let Some(forward) = (look_at - position).try_normalize() else {
        let expected = "a point different from `position`";
        return Err(o.fail(look_at_def.span(), "look_at", expected, show_vec(look_at)));
    };
    check_up(&o, c, up, forward)?;
    Ok(Camera { position, look_at, up, fov_y_deg, near, far, lens: Default::default() })
}

/// Camera coordinates and `far` within ±`MAX_EXTENT`.
const EXTENT: Rule = Rule {
    ok: |v| v.abs() <= MAX_EXTENT,
    bound:
        "in [-2.8147e14, 2.8147e14] (2^48: the scene's extent seen from the camera, see docs/scene-format.md)",
};

/// near ≥ far / `MAX_FAR_NEAR_RATIO` and near a normal f32, so every depth before far/2 is a
/// normal f32 (near = 1e-46 is 0 in f32: every depth 0, nothing drawn).
fn check_near_far_ratio(o: &Owner, c: &CameraDef, near: f64, far: f64) -> Result<(), SceneError> {
    let least = (far / MAX_FAR_NEAR_RATIO).max(f32::MIN_POSITIVE as f64);
    if near >= least {
        return Ok(());
    }
    let span = c.near.as_ref().or(c.far.as_ref()).map_or(o.span.clone(), Spanned::span);
    let expected = format!(
        "a number >= {least:.4e} (far / 2^126 and f32's smallest normal: the reverse-Z depth \
         near/distance must stay a normal f32)"
    );
    Err(o.fail(span, "near", &expected, show(near)))
}

/// `up` must leave a well-defined right vector: non-zero and not (nearly) along the view.
fn check_up(o: &Owner, c: &CameraDef, up: DVec3, forward: DVec3) -> Result<(), SceneError> {
    let sin_angle = up.try_normalize().map_or(0.0, |u| u.cross(forward).length());
    if sin_angle > 1e-6 {
        return Ok(());
    }
    // With the default `up`, the fix is to write one: point at `look_at`.
    let span = c.up.as_ref().or(c.look_at.as_ref()).map_or(o.span.clone(), Spanned::span);
    let expected =
        format!("a non-zero vector not parallel to the view direction {}", show_vec_approx(forward));
    let default = if c.up.is_none() { " (the default)" } else { "" };
    Err(o.fail(span, "up", &expected, format!("{}{default}", show_vec(up))))
}

fn lights(ctx: Ctx, defs: &Tables<LightDef>) -> Result<Vec<Light>, SceneError> {
    if let Some(extra) = defs.0.get(MAX_LIGHTS) {
        let message = format!(
            "too many [[light]] tables (expected at most {MAX_LIGHTS} lights of any kind, the frame uniform's \
             array; found {})",
            defs.0.len()
        );
        return Err(ctx.err(extra.span(), message));
    }
    let light_at = |(i, def): (usize, &Spanned<LightDef>)| {
        light(Owner::new(ctx, format!("light {}", i + 1), def.span()), def.get_ref())
    };
    defs.0.iter().enumerate().map(light_at).collect()
}

/// A light's range: squared on the GPU (1/range²), so within 2^±63 like a metaball's radius.
const RANGE: Rule = Rule {
    ok: |v| (1.0842021724855044e-19..=9.223372036854776e18).contains(&v),
    bound: "in [1.0842e-19, 9.2234e18] (> 0, its square a normal f32; leave it out for an infinite range)",
};
/// A spot light's cone half-angles in degrees.
const OUTER_CONE: Rule = Rule { ok: |v| v > 0.0 && v <= 90.0, bound: "in (0, 90] (degrees from the axis)" };
const INNER_CONE: Rule =
    Rule { ok: |v| (0.0..=90.0).contains(&v), bound: "in [0, 90] (degrees from the axis)" };

fn light(o: Owner, def: &LightDef) -> Result<Light, SceneError> {
    let kind = o.kind(def.kind.as_ref(), &["directional", "point", "spot"])?.unwrap_or("directional");
    // A field the kind has no use for is refused at its key (a point light's `direction` would
    // otherwise be silently meaningless).
    let fields: [(&str, Option<std::ops::Range<usize>>, bool); 5] = [
        ("direction", def.direction.as_ref().map(Spanned::span), kind != "point"),
        ("position", def.position.as_ref().map(Spanned::span), kind != "directional"),
        ("range", def.range.as_ref().map(Spanned::span), kind != "directional"),
        ("inner_cone_deg", def.inner_cone_deg.as_ref().map(Spanned::span), kind == "spot"),
        ("outer_cone_deg", def.outer_cone_deg.as_ref().map(Spanned::span), kind == "spot"),
    ];
    for (field, span, belongs) in fields.clone() {
        if let (Some(span), false) = (span, belongs) {
            let has: Vec<String> = fields.iter().filter(|f| f.2).map(|f| format!("`{}`", f.0)).collect();
            let message = format!(
                "{}: `{field}` is not a field of a {kind} light (its fields: `kind`, {}, `color`, `intensity`)",
                o.label,
                has.join(", ")
            );
            return Err(o.ctx.err(o.ctx.key_start(&span)..span.end, message));
        }
    }
    let color = o.vec3("color", def.color.as_ref(), DVec3::ONE, NON_NEGATIVE)?;
    let intensity = o.num("intensity", def.intensity.as_ref(), 1.0, NON_NEGATIVE)?;
    let direction = |o: &Owner| -> Result<DVec3, SceneError> {
        let direction_def = o.required("direction", def.direction.as_ref(), "an array of 3 numbers")?;
        let direction = o.check_vec3("direction", direction_def, ANY)?;
        direction.try_normalize().ok_or_else(|| {
            o.fail(direction_def.span(), "direction", "a non-zero vector", show_vec(direction))
        })
    };
    if kind == "directional" {
        return Ok(Light::directional(direction(&o)?, color, intensity));
    }
    let position_def = o.required("position", def.position.as_ref(), "an array of 3 numbers")?;
    let position = o.check_vec3("position", position_def, EXTENT)?;
    let range = match def.range.as_ref() {
        Some(r) => Some(o.check_num("range", r, RANGE)?),
        None => None,
    };
    let mut light = if kind == "point" {
        Light::point(position, color, intensity)
    } else {
        let outer = o.num("outer_cone_deg", def.outer_cone_deg.as_ref(), 45.0, OUTER_CONE)?;
        let inner = o.num("inner_cone_deg", def.inner_cone_deg.as_ref(), 0.0, INNER_CONE)?;
        let mut spot =
            Light::spot(position, DVec3::NEG_Z, color, intensity, inner.to_radians(), outer.to_radians());
        spot.direction = direction(&o)?;
        spot
    };
    light.range = range;
    debug_assert!(matches!(light.kind, LightKind::Point | LightKind::Spot { .. }));
    Ok(light)
}

fn materials(ctx: Ctx, defs: &Tables<MaterialDef>) -> Result<Vec<Material>, SceneError> {
    let mut names = UniqueNames::new("material");
    let mut out = Vec::with_capacity(defs.0.len());
    let lines = super::error::LineIndex::new(ctx.text);
    for def in &defs.0 {
        let name = Owner::new(ctx, "[[material]]", def.span()).name(def.get_ref().name.as_ref())?;
        names.insert(ctx, name)?;
        let o = Owner::new(ctx, format!("material \"{}\"", name.get_ref()), def.span());
        out.push(material(&o, &lines, name.get_ref(), def.get_ref())?);
    }
    Ok(out)
}

fn material(
    o: &Owner,
    lines: &super::error::LineIndex,
    name: &str,
    def: &MaterialDef,
) -> Result<Material, SceneError> {
    let kind = super::file_material::material_kind(o, def)?;
    let albedo = o.vec3("albedo", def.albedo.as_ref(), DVec3::splat(DEFAULT_ALBEDO), UNIT)?;
    let at = def.voxel_res.as_ref().map_or(o.span.start, |v| v.span().start);
    let (line, column) = lines.line_column(at);
    let voxel_res_at = format!("{}:{line}:{column}", o.ctx.path.display());
    Ok(Material { name: name.to_owned(), kind, albedo, voxel_res_at, surface: Default::default() })
}

/// The scene's materials and a name → index map, so resolving n instances costs O(n).
pub(crate) struct Materials {
    /// In scene order; materials of glTF files are appended without names to look up.
    pub list: Vec<Material>,
    index: HashMap<String, usize>,
}

impl Materials {
    fn new(list: Vec<Material>) -> Self {
        // Names are unique (checked by `materials`), so no entry is overwritten.
        let index = list.iter().enumerate().map(|(i, m)| (m.name.clone(), i)).collect();
        Materials { list, index }
    }

    /// The scene's "default" material, added (grey, albedo 0.7) the first time it is needed when
    /// the file declares none.
    pub(crate) fn default_index(&mut self) -> usize {
        if let Some(&i) = self.index.get(DEFAULT_MATERIAL) {
            return i;
        }
        let albedo = DVec3::splat(DEFAULT_ALBEDO);
        let voxel_res_at = String::new();
        self.list.push(Material {
            name: DEFAULT_MATERIAL.into(),
            kind: MaterialKind::Lambert,
            albedo,
            voxel_res_at,
            surface: Default::default(),
        });
        self.index.insert(DEFAULT_MATERIAL.into(), self.list.len() - 1);
        self.list.len() - 1
    }
}

/// Resolves names to indices. An instance without `material` gets the scene's "default" material,
/// added (grey, albedo 0.7) only when the file does not declare one.
fn instances(
    ctx: Ctx,
    defs: &Tables<InstanceDef>,
    meshes: &[SceneMesh],
    materials: &mut Materials,
) -> Result<Vec<Instance>, SceneError> {
    let mesh_index: HashMap<&str, usize> =
        meshes.iter().enumerate().map(|(i, m)| (m.name.as_str(), i)).collect();
    // Meshes already found closed: the check walks the whole mesh, once per mesh, not per instance.
    let mut closed = vec![false; meshes.len()];
    let mut out = Vec::with_capacity(defs.0.len());
    for (i, def) in defs.0.iter().enumerate() {
        let d = def.get_ref();
        let label = match &d.name {
            Some(name) => format!("instance \"{}\"", name.get_ref()),
            None => format!("instance {}", i + 1),
        };
        let o = Owner::new(ctx, label, def.span());
        let mesh = o.required("mesh", d.mesh.as_ref(), "the name of a [[mesh]]")?;
        let mesh = mesh_index.get(mesh.get_ref().as_str()).copied().ok_or_else(|| {
            let names: Vec<&str> = meshes.iter().map(|m| m.name.as_str()).collect();
            not_found(&o, "mesh", mesh, &names)
        })?;
        let material = match &d.material {
            Some(m) => material_index(&o, m, materials)?,
            None => materials.default_index(),
        };
        let m = &materials.list[material];
        if !closed[mesh] && matches!(m.kind, MaterialKind::Translucent { .. }) {
            let material_span = d.material.as_ref().map_or(o.span.clone(), Spanned::span);
            super::file_material::check_instance_mesh(&o, material_span, m, &meshes[mesh])?;
            closed[mesh] = true;
        }
        let lut = matches!(m.kind, MaterialKind::Translucent { thickness, .. } if thickness.is_baked());
        if lut && meshes[mesh].wobble.is_some() {
            let material_span = d.material.as_ref().map_or(o.span.clone(), Spanned::span);
            let message = format!(
                "{} `material`: material \"{}\" reads a thickness table baked from the loaded shape, but \
                 mesh \"{}\" wobbles: use thickness = \"peel\" (or \"tsm\") for a deforming mesh",
                o.label, m.name, meshes[mesh].name
            );
            return Err(o.ctx.err(material_span, message));
        }
        let (ops, transform) = transform(&o, d.transform.as_ref())?;
        out.push(Instance {
            name: d.name.as_ref().map(|n| n.get_ref().clone()),
            mesh,
            material,
            ops,
            transform,
        });
    }
    Ok(out)
}

pub(crate) fn material_index(
    o: &Owner,
    name: &Spanned<String>,
    materials: &mut Materials,
) -> Result<usize, SceneError> {
    if name.get_ref() == DEFAULT_MATERIAL {
        return Ok(materials.default_index());
    }
    materials.index.get(name.get_ref().as_str()).copied().ok_or_else(|| {
        let names: Vec<&str> = materials.list.iter().map(|m| m.name.as_str()).collect();
        not_found(o, "material", name, &names)
    })
}

/// "no `what` named …", listing the declared names (built only when a look-up fails).
fn not_found(o: &Owner, what: &str, name: &Spanned<String>, names: &[&str]) -> SceneError {
    let declared = if names.is_empty() {
        format!("no [[{what}]] is declared")
    } else {
        let quoted: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
        format!("declared: {}", quoted.join(", "))
    };
    let message = format!("{} `{what}`: no {what} named \"{}\" ({declared})", o.label, name.get_ref());
    o.ctx.err(name.span(), message)
}

type OpList = Spanned<Tables<OpDef>>;

/// Checks each step where it is written, then the composition at the `transform` key.
pub(crate) fn transform(
    o: &Owner,
    list: Option<&OpList>,
) -> Result<(Vec<TransformOp>, Transform), SceneError> {
    let Some(list) = list else {
        return Ok((Vec::new(), Transform::IDENTITY));
    };
    let mut ops = Vec::with_capacity(list.get_ref().0.len());
    for (i, step) in list.get_ref().0.iter().enumerate() {
        let (name, op) = op(o, step)?;
        Transform::from_ops(std::slice::from_ref(&op))
            .map_err(|e| o.ctx.err(step.span(), format!("{} transform[{i}] ({name}): {e}", o.label)))?;
        ops.push(op);
    }
    let transform = Transform::from_ops(&ops).map_err(|e| {
        let key = o.ctx.key_start(&list.span());
        o.ctx.err(
            key..list.span().end,
            format!("{} `transform`: the composed transform is refused: {e}", o.label),
        )
    })?;
    Ok((ops, transform))
}

/// One `{ translate = … }`-style step: exactly one key.
fn op(o: &Owner, step: &Spanned<OpDef>) -> Result<(&'static str, TransformOp), SceneError> {
    let d = step.get_ref();
    let mut found = Vec::new();
    if let Some(t) = &d.translate {
        found.push(("translate", TransformOp::Translate(t.vec3())));
    }
    if let Some(r) = &d.rotate {
        found.push(("rotate", TransformOp::Rotate { angle_deg: r.angle_deg.0, axis: r.axis.vec3() }));
    }
    if let Some(s) = &d.scale {
        found.push(("scale", TransformOp::Scale(s.vec3())));
    }
    if let Some(m) = &d.matrix {
        let columns = m.0.map(|column| column.values());
        found.push(("matrix", TransformOp::Matrix(DMat4::from_cols_array_2d(&columns))));
    }
    if found.len() == 1 {
        return Ok(found.remove(0));
    }
    let keys: Vec<String> = found.iter().map(|(k, _)| format!("`{k}`")).collect();
    let found = if keys.is_empty() { "none".to_owned() } else { keys.join(" and ") };
    let expected = "a table with exactly one of `translate`, `rotate`, `scale`, `matrix`";
    Err(o.ctx.err(step.span(), format!("{} transform step: expected {expected}, found {found}", o.label)))
}

/// Declared but unused meshes and materials are legal (a scene being edited) but worth a note.
fn warn_unused(
    path: &Path,
    meshes: &[SceneMesh],
    materials: &[Material],
    instances: &[Instance],
    metaballs: &[MetaballGroup],
) {
    // One pass marks what is used; scanning every instance per mesh would be O(n²).
    let mut mesh_used = vec![false; meshes.len()];
    let mut material_used = vec![false; materials.len()];
    for inst in instances {
        mesh_used[inst.mesh] = true;
        material_used[inst.material] = true;
    }
    for g in metaballs {
        material_used[g.material] = true;
    }
    for (m, _) in meshes.iter().zip(&mesh_used).filter(|(_, used)| !**used) {
        log::warn!("{}: mesh \"{}\" is declared but no instance uses it", path.display(), m.name);
    }
    for (m, _) in materials.iter().zip(&material_used).filter(|(_, used)| !**used) {
        log::warn!("{}: material \"{}\" is declared but no instance uses it", path.display(), m.name);
    }
}
