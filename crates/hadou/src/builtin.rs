//! The scenes of `assets/scenes`, embedded in the library, so an installed `hadou` (`cargo install
//! --path .`) renders, profiles, bakes, views and reports them from any directory: a scene path
//! `builtin:NAME` (e.g. `builtin:showcase`) names one. None of them reads another file (no OBJ
//! mesh; the unit test below parses each one), so nothing has to be found beside them.

use std::path::Path;

use crate::scene::{Scene, SceneError};

/// The prefix that marks a built-in scene in a scene path.
pub const PREFIX: &str = "builtin:";

/// (name, TOML text) of every built-in scene: each file of `assets/scenes`.
pub const SCENES: [(&str, &str); 12] = [
    ("budget", include_str!("../../../assets/scenes/budget.toml")),
    ("empty", include_str!("../../../assets/scenes/empty.toml")),
    ("energy_wave", include_str!("../../../assets/scenes/energy_wave.toml")),
    ("energy_wave_open", include_str!("../../../assets/scenes/energy_wave_open.toml")),
    ("instances", include_str!("../../../assets/scenes/instances.toml")),
    ("metaballs", include_str!("../../../assets/scenes/metaballs.toml")),
    ("metaballs_4096", include_str!("../../../assets/scenes/metaballs_4096.toml")),
    ("metaballs_dense", include_str!("../../../assets/scenes/metaballs_dense.toml")),
    ("showcase", include_str!("../../../assets/scenes/showcase.toml")),
    ("single_cube", include_str!("../../../assets/scenes/single_cube.toml")),
    ("translucency", include_str!("../../../assets/scenes/translucency.toml")),
    ("translucency_peel", include_str!("../../../assets/scenes/translucency_peel.toml")),
];

/// The TOML text of built-in scene `name` (`showcase` or `showcase.toml`).
pub fn text(name: &str) -> Option<&'static str> {
    let name = name.strip_suffix(".toml").unwrap_or(name);
    SCENES.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// The built-in name in `path` when it is `builtin:NAME`.
pub fn name_of(path: &Path) -> Option<&str> {
    path.to_str()?.strip_prefix(PREFIX)
}

/// Parses built-in scene `name`; errors name it as `builtin:NAME`.
pub fn scene(name: &str) -> Result<Scene, SceneError> {
    let path = format!("{PREFIX}{name}");
    let text = text(name).ok_or_else(|| {
        let names: Vec<&str> = SCENES.iter().map(|(n, _)| *n).collect();
        SceneError::whole_file(
            path.as_ref(),
            format!("no such built-in scene (expected one of: {})", names.join(", ")),
        )
    })?;
    crate::scene::parse_scene(text, path.as_ref())
}

/// Loads the scene at `path`: a built-in one for `builtin:NAME`, else the file.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    match name_of(path) {
        Some(name) => scene(name),
        None => crate::scene::load_scene(path),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every file of assets/scenes is built in, and each parses without reading another file.
    #[test]
    fn every_scene_file_is_built_in_and_parses() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/scenes");
        let mut files: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".toml"))
            .collect();
        files.sort();
        let names: Vec<String> = SCENES.iter().map(|(n, _)| format!("{n}.toml")).collect();
        assert_eq!(files, names);
        for (name, _) in SCENES {
            let scene = scene(name).unwrap_or_else(|e| panic!("{e}"));
            let reads_files =
                scene.meshes.iter().any(|m| matches!(m.spec, crate::scene::mesh::MeshSpec::Obj { .. }));
            assert!(!reads_files, "{name} reads an OBJ file: an installed binary would not find it");
        }
    }

    #[test]
    fn names_resolve_and_unknown_ones_list_the_choices() {
        assert!(load(Path::new("builtin:showcase.toml")).is_ok());
        let err = load(Path::new("builtin:nope")).unwrap_err().to_string();
        assert!(err.starts_with("builtin:nope: no such built-in scene") && err.contains("showcase"), "{err}");
        assert_eq!(name_of(Path::new("assets/builtin:x")), None, "only a leading prefix counts");
    }
}
