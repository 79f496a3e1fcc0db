//! `GltfError`: what is wrong with a glTF file, at a JSON pointer (RFC 6901) into its JSON.

use std::fmt;
use std::path::{Path, PathBuf};

use super::super::error::SceneError;

/// Why a glTF file was refused. Displays as `file: /json/pointer: message`; the pointer is empty
/// for problems of the file as a whole (unreadable, not glTF).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GltfError {
    /// The .gltf or .glb file.
    pub file: PathBuf,
    /// JSON pointer to the offending value, e.g. `/meshes/3/primitives/0/attributes/POSITION`.
    pub pointer: String,
    /// What is wrong and what was expected.
    pub message: String,
}

impl GltfError {
    /// An error at `pointer` of `file`.
    pub fn at(file: &Path, pointer: impl Into<String>, message: impl Into<String>) -> GltfError {
        GltfError { file: file.to_path_buf(), pointer: pointer.into(), message: message.into() }
    }
}

impl fmt::Display for GltfError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.pointer.is_empty() {
            write!(f, "{}: {}", self.file.display(), self.message)
        } else {
            write!(f, "{}: {}: {}", self.file.display(), self.pointer, self.message)
        }
    }
}

impl std::error::Error for GltfError {}

impl From<GltfError> for SceneError {
    /// A glTF file loaded as the scene: the glTF file is the scene's path; the pointer leads the
    /// message (a glTF error has no line:col of its own worth more than the pointer).
    fn from(e: GltfError) -> SceneError {
        let message = if e.pointer.is_empty() { e.message } else { format!("{}: {}", e.pointer, e.message) };
        SceneError::whole_file(&e.file, message)
    }
}

/// The gltf crate names an extension member by its Rust field in camelCase
/// (`extensions.khrLightsPunctual`, `extensions.volume`), not as the file spells it: the names the
/// crate can report (gltf-json 1.4, every extension it knows) and their real ones.
const EXTENSION_FIELDS: &[(&str, &str)] = &[
    ("khrLightsPunctual", "KHR_lights_punctual"),
    ("khrMaterialsVariants", "KHR_materials_variants"),
    ("textureTransform", "KHR_texture_transform"),
    ("pbrSpecularGlossiness", "KHR_materials_pbrSpecularGlossiness"),
    ("unlit", "KHR_materials_unlit"),
    ("transmission", "KHR_materials_transmission"),
    ("volume", "KHR_materials_volume"),
    ("specular", "KHR_materials_specular"),
    ("ior", "KHR_materials_ior"),
    ("emissiveStrength", "KHR_materials_emissive_strength"),
];

/// The gltf crate's validation path (`meshes[3].primitives[0].attributes["POSITION"]`, possibly
/// ending in ` = "value"`) as a JSON pointer (`/meshes/3/primitives/0/attributes/POSITION`), with
/// the members of `extensions` under their names in the file (`EXTENSION_FIELDS`).
pub(super) fn pointer_from_crate_path(path: &str) -> String {
    let path = path.split(" = ").next().unwrap_or(path);
    let mut out = String::new();
    let mut token = String::new();
    let mut chars = path.chars().peekable();
    let flush = |out: &mut String, token: &mut String| {
        if !token.is_empty() {
            if out.ends_with("/extensions") {
                if let Some((_, name)) = EXTENSION_FIELDS.iter().find(|(field, _)| *field == token.as_str()) {
                    *token = (*name).to_owned();
                }
            }
            out.push('/');
            // RFC 6901: `~` and `/` inside a token are escaped.
            out.push_str(&token.replace('~', "~0").replace('/', "~1"));
            token.clear();
        }
    };
    while let Some(c) = chars.next() {
        match c {
            '.' => flush(&mut out, &mut token),
            '[' => {
                flush(&mut out, &mut token);
                let quoted = chars.peek() == Some(&'"');
                if quoted {
                    chars.next();
                }
                for c in chars.by_ref() {
                    if (quoted && c == '"') || (!quoted && c == ']') {
                        break;
                    }
                    token.push(c);
                }
                if quoted {
                    chars.next(); // the closing `]`
                }
                flush(&mut out, &mut token);
            }
            c => token.push(c),
        }
    }
    flush(&mut out, &mut token);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crate_paths_become_json_pointers() {
        let p = pointer_from_crate_path("meshes[3].primitives[0].attributes[\"POSITION\"]");
        assert_eq!(p, "/meshes/3/primitives/0/attributes/POSITION");
        let p = pointer_from_crate_path("extensionsRequired[0] = \"KHR_draco_mesh_compression\"");
        assert_eq!(p, "/extensionsRequired/0");
        assert_eq!(pointer_from_crate_path("nodes[1].children[0]"), "/nodes/1/children/0");
        assert_eq!(pointer_from_crate_path(""), "");
    }

    #[test]
    fn extension_members_keep_the_names_of_the_file() {
        let p = pointer_from_crate_path("extensions.khrLightsPunctual.lights[0].spot");
        assert_eq!(p, "/extensions/KHR_lights_punctual/lights/0/spot");
        let p = pointer_from_crate_path("nodes[2].extensions.khrLightsPunctual.light");
        assert_eq!(p, "/nodes/2/extensions/KHR_lights_punctual/light");
        let p = pointer_from_crate_path("materials[1].extensions.volume.thicknessTexture.index");
        assert_eq!(p, "/materials/1/extensions/KHR_materials_volume/thicknessTexture/index");
        // Only members of `extensions` are renamed.
        assert_eq!(pointer_from_crate_path("materials[1].volume"), "/materials/1/volume");
    }

    #[test]
    fn display_and_scene_error() {
        let e = GltfError::at(Path::new("a.glb"), "/nodes/0", "bad");
        assert_eq!(e.to_string(), "a.glb: /nodes/0: bad");
        assert_eq!(SceneError::from(e).to_string(), "a.glb: /nodes/0: bad");
    }
}
