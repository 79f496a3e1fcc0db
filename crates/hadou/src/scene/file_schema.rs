//! The scene file as TOML spells it: serde types that mirror the documented schema
//! (docs/scene-format.md) one to one. Shape and type errors (unknown keys, wrong types,
//! non-finite numbers, wrong array lengths) are raised here, where toml still knows the span;
//! ranges and cross-field rules are checked when converting to `Scene` (file.rs, file_mesh.rs),
//! from the `Spanned` positions kept here.

use std::fmt;
use std::marker::PhantomData;

use glam::DVec3;
use serde::de::{self, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;
use toml::Spanned;

/// Unknown top-level tables are refused before (`file::check_tables`): an effect's own tables
/// (`crate::effect`) are read by the effect.
#[derive(Debug, Deserialize)]
#[serde(expecting = "a scene: TOML tables such as [camera] and [[mesh]]")]
pub(crate) struct SceneDef {
    pub render: Option<Spanned<RenderDef>>,
    pub camera: Option<Spanned<CameraDef>>,
    #[serde(default)]
    pub light: Tables<LightDef>,
    #[serde(default)]
    pub mesh: Tables<MeshDef>,
    #[serde(default)]
    pub material: Tables<MaterialDef>,
    #[serde(default)]
    pub instance: Tables<InstanceDef>,
    #[serde(default)]
    pub gltf: Tables<GltfDef>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [render] table")]
pub(crate) struct RenderDef {
    pub size: Option<Array<Spanned<Int>, 2>>,
    pub exposure: Option<Spanned<NumOrWord>>,
    pub exposure_ev100: Option<Spanned<Num>>,
    pub background: Option<Spanned<Array<Num, 3>>>,
    pub ambient: Option<Spanned<Array<Num, 3>>>,
    pub budget_ms: Option<Spanned<Num>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [camera] table")]
pub(crate) struct CameraDef {
    pub position: Option<Spanned<Array<Num, 3>>>,
    pub look_at: Option<Spanned<Array<Num, 3>>>,
    pub up: Option<Spanned<Array<Num, 3>>>,
    pub fov_y_deg: Option<Spanned<Num>>,
    pub near: Option<Spanned<Num>>,
    pub far: Option<Spanned<Num>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [[light]] table")]
pub(crate) struct LightDef {
    pub kind: Option<Spanned<String>>,
    pub direction: Option<Spanned<Array<Num, 3>>>,
    pub position: Option<Spanned<Array<Num, 3>>>,
    pub color: Option<Spanned<Array<Num, 3>>>,
    pub intensity: Option<Spanned<Num>>,
    pub range: Option<Spanned<Num>>,
    pub inner_cone_deg: Option<Spanned<Num>>,
    pub outer_cone_deg: Option<Spanned<Num>>,
}

/// Every field of every mesh kind. Which ones a kind accepts is checked in file_mesh.rs, so the
/// error can say "`radius` is not a field of mesh kind `cube`"; keys no kind has are kept in
/// `unknown` (not refused here) so their error can list the fields of the table's own kind.
#[derive(Debug, Default)]
pub(crate) struct MeshDef {
    pub name: Option<Spanned<String>>,
    pub kind: Option<Spanned<String>>,
    pub size: Option<Spanned<Num>>,
    pub radius: Option<Spanned<Num>>,
    pub segments: Option<Spanned<Int>>,
    pub rings: Option<Spanned<Int>>,
    pub major_radius: Option<Spanned<Num>>,
    pub minor_radius: Option<Spanned<Num>>,
    pub sides: Option<Spanned<Int>>,
    pub cavity_radius: Option<Spanned<Num>>,
    pub height: Option<Spanned<Num>>,
    pub wall: Option<Spanned<Num>>,
    pub fill: Option<Spanned<Num>>,
    pub path: Option<Spanned<String>>,
    // Any kind:
    pub wobble: Option<Spanned<Num>>,
    pub wobble_hz: Option<Spanned<Num>>,
    /// Keys that are no mesh field, with their spans.
    pub unknown: Vec<Spanned<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [[material]] table")]
pub(crate) struct MaterialDef {
    pub name: Option<Spanned<String>>,
    pub kind: Option<Spanned<String>>,
    pub albedo: Option<Spanned<Array<Num, 3>>>,
    // kind = "translucent" only (checked in file_material.rs):
    pub sigma: Option<Spanned<Array<Num, 3>>>,
    pub attenuation_color: Option<Spanned<Array<Num, 3>>>,
    pub attenuation_distance: Option<Spanned<Num>>,
    pub voxel_res: Option<Spanned<Int>>,
    pub thickness: Option<Spanned<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "an [[instance]] table")]
pub(crate) struct InstanceDef {
    pub name: Option<Spanned<String>>,
    pub mesh: Option<Spanned<String>>,
    pub material: Option<Spanned<String>>,
    pub transform: Option<Spanned<Tables<OpDef>>>,
}

/// A glTF file placed in the scene (file_gltf.rs).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [[gltf]] table")]
pub(crate) struct GltfDef {
    pub name: Option<Spanned<String>>,
    pub path: Option<Spanned<String>>,
    pub transform: Option<Spanned<Tables<OpDef>>>,
    pub voxel_res: Option<Spanned<Int>>,
}

/// An energy wave; ranges, the method's fields and the keyframe rules are checked in
/// effects/energy_wave/file.rs (the energy wave effect reads `[[wave]]`).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [[wave]] table")]
pub(crate) struct WaveDef {
    pub name: Option<Spanned<String>>,
    pub origin: Option<Spanned<Array<Num, 3>>>,
    pub velocity: Option<Spanned<Array<Num, 3>>>,
    pub direction: Option<Spanned<Array<Num, 3>>>,
    pub a: Option<Spanned<Num>>,
    pub b: Option<Spanned<Num>>,
    pub core: Option<Spanned<Num>>,
    pub length: Option<Spanned<Num>>,
    pub color: Option<Spanned<Array<Num, 3>>>,
    pub intensity: Option<Spanned<Num>>,
    pub cutoff: Option<Spanned<Num>>,
    pub tolerance: Option<Spanned<Num>>,
    pub method: Option<Spanned<String>>,
    pub steps: Option<Spanned<Int>>,
    pub jitter: Option<Spanned<bool>>,
    #[serde(default)]
    pub keyframe: Tables<KeyframeDef>,
}

/// One `[[wave.keyframe]]`: a time and any subset of the animatable fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [[wave.keyframe]] table")]
pub(crate) struct KeyframeDef {
    pub time: Option<Spanned<Num>>,
    pub origin: Option<Spanned<Array<Num, 3>>>,
    pub direction: Option<Spanned<Array<Num, 3>>>,
    pub a: Option<Spanned<Num>>,
    pub b: Option<Spanned<Num>>,
    pub core: Option<Spanned<Num>>,
    pub length: Option<Spanned<Num>>,
    pub intensity: Option<Spanned<Num>>,
}

/// One transform step: an inline table with exactly one key (checked in file.rs, so the error
/// can name the keys found).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a transform step such as { translate = [0, 1, 0] }")]
pub(crate) struct OpDef {
    pub translate: Option<Array<Num, 3>>,
    pub rotate: Option<RotateDef>,
    pub scale: Option<Array<Num, 3>>,
    pub matrix: Option<Array<Array<Num, 4>, 4>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table { angle_deg = number, axis = [x, y, z] }")]
pub(crate) struct RotateDef {
    pub angle_deg: Num,
    pub axis: Array<Num, 3>,
}

/// A finite number that f32 holds; TOML integers are accepted too. nan, ±inf and |x| > f32::MAX
/// are refused here so every number hadou reads is finite, in f64 and on the GPU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Num(pub f64);

/// A finite number (as `Num`) or a string (`exposure = "auto"`); which strings are allowed is
/// checked where the value is read.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum NumOrWord {
    Num(Num),
    Word(String),
}

/// A TOML integer (a float such as `32.0` is refused: counts and sizes are whole).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Int(pub i64);

/// Exactly `N` elements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Array<T, const N: usize>(pub [T; N]);

/// An array of tables (`[[mesh]]` sections or `[{ … }, { … }]`), each with its span.
#[derive(Debug)]
pub(crate) struct Tables<T>(pub Vec<Spanned<T>>);

/// How an element type is named in "expected an array of 3 numbers".
pub(crate) trait Plural {
    fn plural() -> String;
}

/// What a list of these tables looks like, for the error on `[mesh]` instead of `[[mesh]]`.
pub(crate) trait TableList {
    const LIST: &'static str;
}

impl TableList for LightDef {
    const LIST: &'static str = "an array of tables, each written [[light]]";
}
impl TableList for MeshDef {
    const LIST: &'static str = "an array of tables, each written [[mesh]]";
}
impl TableList for MaterialDef {
    const LIST: &'static str = "an array of tables, each written [[material]]";
}
impl TableList for OpDef {
    const LIST: &'static str = "an array of transform steps such as [{ translate = [0, 1, 0] }]";
}
impl TableList for InstanceDef {
    const LIST: &'static str = "an array of tables, each written [[instance]]";
}
impl TableList for GltfDef {
    const LIST: &'static str = "an array of tables, each written [[gltf]]";
}
impl TableList for WaveDef {
    const LIST: &'static str = "an array of tables, each written [[wave]]";
}
impl TableList for KeyframeDef {
    const LIST: &'static str = "an array of tables, each written [[wave.keyframe]]";
}

impl Plural for Num {
    fn plural() -> String {
        "numbers".into()
    }
}
impl Plural for Int {
    fn plural() -> String {
        "integers".into()
    }
}
impl<T: Plural> Plural for Spanned<T> {
    fn plural() -> String {
        T::plural()
    }
}
impl<T: Plural, const N: usize> Plural for Array<T, N> {
    fn plural() -> String {
        format!("arrays of {N} {}", T::plural())
    }
}

impl<const N: usize> Array<Num, N> {
    pub fn values(&self) -> [f64; N] {
        self.0.map(|n| n.0)
    }
}

impl Array<Num, 3> {
    pub fn vec3(&self) -> DVec3 {
        DVec3::from_array(self.values())
    }
}

impl<T> Default for Tables<T> {
    fn default() -> Self {
        Tables(Vec::new())
    }
}

/// How a non-finite float is spelled in TOML, for the error message.
fn toml_spelling(v: f64) -> &'static str {
    if v.is_nan() {
        "nan"
    } else if v > 0.0 {
        "inf"
    } else {
        "-inf"
    }
}

struct NumVisitor;

impl Visitor<'_> for NumVisitor {
    type Value = Num;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a finite number")
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Num, E> {
        Ok(Num(v as f64))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Num, E> {
        Ok(Num(v as f64))
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Num, E> {
        if !v.is_finite() {
            return Err(E::custom(format!("expected a finite number, found {}", toml_spelling(v))));
        }
        // Every number reaches the GPU as f32 (directly or through a product of such numbers):
        // past f32::MAX it would become inf there.
        if v.abs() > f32::MAX as f64 {
            return Err(E::custom(format!(
                "expected a number that f32 holds (|x| <= 3.4028235e38, the GPU's float), found {v:e}"
            )));
        }
        Ok(Num(v))
    }
}

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Num, D::Error> {
        d.deserialize_any(NumVisitor)
    }
}

struct NumOrWordVisitor;

impl Visitor<'_> for NumOrWordVisitor {
    type Value = NumOrWord;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a finite number or a string")
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<NumOrWord, E> {
        NumVisitor.visit_i64(v).map(NumOrWord::Num)
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<NumOrWord, E> {
        NumVisitor.visit_u64(v).map(NumOrWord::Num)
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<NumOrWord, E> {
        NumVisitor.visit_f64(v).map(NumOrWord::Num)
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<NumOrWord, E> {
        Ok(NumOrWord::Word(v.to_owned()))
    }
}

impl<'de> Deserialize<'de> for NumOrWord {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<NumOrWord, D::Error> {
        d.deserialize_any(NumOrWordVisitor)
    }
}

struct IntVisitor;

impl Visitor<'_> for IntVisitor {
    type Value = Int;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("an integer")
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Int, E> {
        Ok(Int(v))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Int, E> {
        i64::try_from(v).map(Int).map_err(|_| E::invalid_value(de::Unexpected::Unsigned(v), &self))
    }
}

impl<'de> Deserialize<'de> for Int {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Int, D::Error> {
        d.deserialize_any(IntVisitor)
    }
}

struct ArrayVisitor<T, const N: usize>(PhantomData<T>);

impl<'de, T: Deserialize<'de> + Plural, const N: usize> Visitor<'de> for ArrayVisitor<T, N> {
    type Value = Array<T, N>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "an array of {N} {}", T::plural())
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Array<T, N>, A::Error> {
        let mut items = Vec::with_capacity(N);
        while let Some(item) = seq.next_element::<T>()? {
            items.push(item);
            if items.len() == N {
                break;
            }
        }
        // Count any surplus so the message says how many there were.
        let mut len = items.len();
        while seq.next_element::<IgnoredAny>()?.is_some() {
            len += 1;
        }
        match <[T; N]>::try_from(items) {
            Ok(array) if len == N => Ok(Array(array)),
            _ => Err(de::Error::invalid_length(len, &self)),
        }
    }
}

impl<'de, T: Deserialize<'de> + Plural, const N: usize> Deserialize<'de> for Array<T, N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(ArrayVisitor::<T, N>(PhantomData))
    }
}

struct TablesVisitor<T>(PhantomData<T>);

impl<'de, T: Deserialize<'de> + TableList> Visitor<'de> for TablesVisitor<T> {
    type Value = Tables<T>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(T::LIST)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Tables<T>, A::Error> {
        let mut items = Vec::new();
        while let Some(item) = seq.next_element::<Spanned<T>>()? {
            items.push(item);
        }
        Ok(Tables(items))
    }
}

impl<'de, T: Deserialize<'de> + TableList> Deserialize<'de> for Tables<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(TablesVisitor::<T>(PhantomData))
    }
}

struct MeshVisitor;

impl<'de> Visitor<'de> for MeshVisitor {
    type Value = MeshDef;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a [[mesh]] table")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<MeshDef, A::Error> {
        let mut m = MeshDef::default();
        while let Some(key) = map.next_key::<Spanned<String>>()? {
            match key.get_ref().as_str() {
                "name" => m.name = Some(map.next_value()?),
                "kind" => m.kind = Some(map.next_value()?),
                "size" => m.size = Some(map.next_value()?),
                "radius" => m.radius = Some(map.next_value()?),
                "segments" => m.segments = Some(map.next_value()?),
                "rings" => m.rings = Some(map.next_value()?),
                "major_radius" => m.major_radius = Some(map.next_value()?),
                "minor_radius" => m.minor_radius = Some(map.next_value()?),
                "sides" => m.sides = Some(map.next_value()?),
                "cavity_radius" => m.cavity_radius = Some(map.next_value()?),
                "height" => m.height = Some(map.next_value()?),
                "wall" => m.wall = Some(map.next_value()?),
                "fill" => m.fill = Some(map.next_value()?),
                "path" => m.path = Some(map.next_value()?),
                "wobble" => m.wobble = Some(map.next_value()?),
                "wobble_hz" => m.wobble_hz = Some(map.next_value()?),
                _ => {
                    map.next_value::<IgnoredAny>()?;
                    m.unknown.push(key);
                }
            }
        }
        Ok(m)
    }
}

impl<'de> Deserialize<'de> for MeshDef {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<MeshDef, D::Error> {
        d.deserialize_map(MeshVisitor)
    }
}
