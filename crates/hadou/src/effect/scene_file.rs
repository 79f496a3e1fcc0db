//! The scene file as an effect reads it: its own top-level tables, deserialized with serde into
//! the effect's types (`toml::Spanned` fields keep their places), and errors at `file:line:col`
//! worded like hadou's own ("expected …, found …").

use std::cell::RefCell;
use std::fmt;
use std::marker::PhantomData;
use std::ops::Range;
use std::path::Path;

use serde::de::{self, DeserializeOwned, DeserializeSeed, IgnoredAny, MapAccess, Visitor};
use toml::Spanned;

use crate::scene::file::Materials;
use crate::scene::SceneError;

/// A scene file being loaded, for `Effect::load`.
#[derive(Clone, Copy)]
pub struct SceneFile<'a> {
    text: &'a str,
    path: &'a Path,
    /// The file's materials, resolved before effects load (none for a file made with `new`).
    materials: Option<&'a RefCell<Materials>>,
}

impl fmt::Debug for SceneFile<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SceneFile").field("path", &self.path).finish_non_exhaustive()
    }
}

impl<'a> SceneFile<'a> {
    /// The scene `text` read from `path` (the path names it in errors and anchors relative paths).
    pub fn new(text: &'a str, path: &'a Path) -> Self {
        SceneFile { text, path, materials: None }
    }

    /// As `new`, with the file's materials (what `load_scene_with` hands effects).
    pub(crate) fn with_materials(text: &'a str, path: &'a Path, materials: &'a RefCell<Materials>) -> Self {
        SceneFile { text, path, materials: Some(materials) }
    }

    /// The index in `Scene::materials` of the file's `[[material]]` named `name`.
    pub fn material(&self, name: &str) -> Option<usize> {
        self.materials?.borrow().list.iter().position(|m| m.name == name)
    }

    /// The file's materials, to resolve (and add the built-in "default" to).
    pub(crate) fn materials(&self) -> Option<std::cell::RefMut<'a, Materials>> {
        self.materials.map(|m| m.borrow_mut())
    }

    /// The file's path.
    pub fn path(&self) -> &'a Path {
        self.path
    }

    /// The top-level table (or array of tables) `name` as `T`, with its span; None when the file
    /// has none. Shape and type errors (unknown keys with `#[serde(deny_unknown_fields)]`, wrong
    /// types) come back at their line:col.
    pub fn table<T: DeserializeOwned>(&self, name: &str) -> Result<Option<Spanned<T>>, SceneError> {
        let seed = OneTable::<T> { name, found: PhantomData };
        seed.deserialize(toml::Deserializer::new(self.text)).map_err(|e| self.toml_error(&e))
    }

    /// An error at the start of `span` (a `Spanned` value's `span()`).
    pub fn error(&self, span: Range<usize>, message: impl Into<String>) -> SceneError {
        SceneError::at_span(self.path, self.text, span, message)
    }

    /// A field value that breaks a rule: "\[table\] `field`: expected …, found …".
    pub fn invalid<V: fmt::Display>(
        &self,
        table: &str,
        field: &str,
        value: &Spanned<V>,
        expected: &str,
    ) -> SceneError {
        self.error(
            value.span(),
            format!("[{table}] `{field}`: expected {expected}, found {}", value.get_ref()),
        )
    }

    /// hadou's own scene-file checks on this text (built-in effects' tables).
    pub(crate) fn ctx(&self) -> crate::scene::file_check::Ctx<'a> {
        crate::scene::file_check::Ctx { text: self.text, path: self.path }
    }

    fn toml_error(&self, e: &toml::de::Error) -> SceneError {
        let message = e.message().trim().replace('\n', "; ");
        self.error(e.span().unwrap_or(0..0), message)
    }
}

/// Deserializes the top-level key `name` of a document, skipping the others.
struct OneTable<'n, T> {
    name: &'n str,
    found: PhantomData<T>,
}

impl<'de, T: DeserializeOwned> DeserializeSeed<'de> for OneTable<'_, T> {
    type Value = Option<Spanned<T>>;

    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de, T: DeserializeOwned> Visitor<'de> for OneTable<'_, T> {
    type Value = Option<Spanned<T>>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "a scene file (TOML tables)")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let mut found = None;
        while let Some(key) = map.next_key::<String>()? {
            if key == self.name {
                found = Some(map.next_value::<Spanned<T>>()?);
            } else {
                map.next_value::<IgnoredAny>()?;
            }
        }
        Ok(found)
    }
}

/// The top-level keys of a scene text with their spans (for the unknown-table check).
pub(crate) fn top_level_keys(text: &str) -> Result<Vec<Spanned<String>>, toml::de::Error> {
    let keys: std::collections::BTreeMap<Spanned<String>, IgnoredAny> = toml::from_str(text)?;
    let mut keys: Vec<_> = keys.into_keys().collect();
    keys.sort_by_key(|k| k.span().start);
    Ok(keys)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Fog {
        density: Spanned<f64>,
    }

    #[test]
    fn reads_one_table_with_places() {
        let text = "[camera]\nposition = [0, 0, 1]\n\n[fog]\ndensity = -2.0\n";
        let file = SceneFile::new(text, Path::new("s.toml"));
        let fog = file.table::<Fog>("fog").unwrap().unwrap();
        let e = file.invalid("fog", "density", &fog.get_ref().density, "a number ≥ 0");
        assert_eq!(e.to_string(), "s.toml:5:11: [fog] `density`: expected a number ≥ 0, found -2");
        assert!(file.table::<Fog>("mist").unwrap().is_none());
        let keys: Vec<String> = top_level_keys(text).unwrap().into_iter().map(|k| k.into_inner()).collect();
        assert_eq!(keys, ["camera", "fog"]);
    }

    #[test]
    fn shape_errors_have_places() {
        let file = SceneFile::new("[fog]\ndensity = 1.0\ncolour = 2\n", Path::new("s.toml"));
        let e = file.table::<Fog>("fog").unwrap_err();
        assert_eq!((e.line, e.column), (3, 1), "{e}");
        assert!(e.message.contains("unknown field `colour`"), "{e}");
    }
}
