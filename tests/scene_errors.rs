//! The scene file's error contract: every bad file in tests/bad_scenes is refused at the exact
//! line:col with a message that says what was expected; every scene in assets/scenes loads; and
//! no mangled input makes the loader panic.

use std::path::{Path, PathBuf};

use glam::DVec3;
use hadou::scene::{load_scene, parse_scene, Scene, SceneError};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// (file in tests/bad_scenes, line, column, a distinctive part of the message).
const BAD: &[(&str, usize, usize, &str)] = &[
    ("syntax_error.toml", 8, 6, "expected `.`, `=`"),
    ("unknown_key.toml", 9, 1, "unknown field `radiuss` (expected one of `name`, `kind`, `radius`"),
    ("field_of_other_kind.toml", 8, 1, "`radius` is not a field of mesh kind `cube`"),
    ("unknown_mesh_kind.toml", 7, 8, "expected one of \"plane\", \"cube\""),
    ("wrong_type.toml", 3, 12, "invalid type: integer `5`, expected an array of 3 numbers"),
    ("wrong_length.toml", 7, 10, "invalid length 2, expected an array of 3 numbers"),
    ("nan.toml", 3, 16, "expected a finite number, found nan"),
    ("inf.toml", 7, 13, "expected a finite number, found inf"),
    ("zero_axis.toml", 13, 3, "transform[1] (rotate): rotation axis has zero length"),
    ("zero_scale.toml", 11, 14, "transform[0] (scale): scale component y is zero"),
    ("singular_matrix.toml", 13, 3, "transform[0] (matrix): matrix is singular"),
    ("non_affine_matrix.toml", 13, 3, "expected an affine matrix with bottom row [0, 0, 0, 1]"),
    ("composed_singular.toml", 12, 1, "`transform`: the composed transform is refused: matrix is singular"),
    (
        "two_ops_in_one_step.toml",
        11,
        14,
        "exactly one of `translate`, `rotate`, `scale`, `matrix`, found `translate` and `scale`",
    ),
    ("missing_mesh_ref.toml", 14, 8, "no mesh named \"cube\" (declared: \"box\", \"ball\")"),
    ("missing_material_ref.toml", 15, 12, "no material named \"blue\" (declared: \"red\")"),
    (
        "duplicate_mesh.toml",
        10,
        8,
        "duplicate mesh name \"box\" (expected unique names; first declared on line 6)",
    ),
    ("duplicate_material.toml", 10, 8, "duplicate material name \"red\""),
    ("missing_camera.toml", 1, 1, "missing required table [camera]"),
    ("look_at_eq_position.toml", 3, 11, "`look_at`: expected a point different from `position`"),
    (
        "up_parallel.toml",
        4,
        11,
        "`up`: expected a non-zero vector not parallel to the view direction [0, -1, 0]",
    ),
    ("negative_size.toml", 8, 8, "mesh \"box\" `size`: expected a number in [1e-6, 1e6], found -1"),
    ("negative_near.toml", 4, 8, "`near`: expected a number > 0, found -0.1"),
    ("far_le_near.toml", 5, 7, "`far`: expected a number > near (10), found 10"),
    ("fov_out_of_range.toml", 4, 13, "`fov_y_deg`: expected a number in (0, 180), found 180"),
    ("torus_minor_too_large.toml", 9, 16, "mesh \"ring\": torus minor_radius must be < major_radius"),
    ("bad_obj_path.toml", 8, 8, "no_such_file.obj: No such file or directory"),
    ("malformed_obj.toml", 8, 8, "mesh \"wedge\": "),
    ("obj_index_out_of_range.toml", 8, 8, "mesh \"wedge\": "),
    ("image_size_zero.toml", 2, 9, "`size`: expected integers in 1..=16384, found 0"),
    ("image_size_too_large.toml", 2, 14, "`size`: expected integers in 1..=16384, found 16385"),
    ("too_many_lights.toml", 21, 1, "too many [[light]] tables (expected at most 8, found 9)"),
    ("not_utf8.toml", 2, 25, "invalid UTF-8 (byte 0xe9); expected a UTF-8 text file"),
];

/// The OBJ rows also carry the OBJ file's own position, checked here so the table stays short.
const OBJ_DETAIL: &[(&str, &str)] = &[
    ("malformed_obj.toml", "malformed.obj:3:5: expected a number"),
    ("obj_index_out_of_range.toml", "index_out_of_range.obj:5:7: vertex index 4 out of range"),
];

#[test]
fn bad_scenes_fail_at_the_right_place() {
    let dir = root().join("tests/bad_scenes");
    let mut failures = Vec::new();
    for &(file, line, column, needle) in BAD {
        let path = dir.join(file);
        let err = match load_scene(&path) {
            Ok(_) => {
                failures.push(format!("{file}: loaded, expected an error"));
                continue;
            }
            Err(e) => e,
        };
        let detail = OBJ_DETAIL.iter().find(|(f, _)| *f == file).map(|(_, d)| *d);
        let ok = err.path == path
            && (err.line, err.column) == (line, column)
            && err.message.contains(needle)
            && detail.is_none_or(|d| err.message.contains(d))
            && err.to_string() == format!("{}:{line}:{column}: {}", path.display(), err.message);
        if !ok {
            failures.push(format!("{file}: expected {line}:{column} containing {needle:?}, got\n    {err}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every file in the folder is in the table (a new bad scene without a row would test nothing).
#[test]
fn every_bad_scene_has_a_row() {
    let dir = root().join("tests/bad_scenes");
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        if name.ends_with(".toml") {
            assert!(BAD.iter().any(|(f, ..)| *f == name), "{name} has no row in BAD");
        }
    }
    assert!(BAD.len() >= 18);
}

#[test]
fn unreadable_scene_path_has_no_position() {
    let path = root().join("tests/bad_scenes/does_not_exist.toml");
    let err = load_scene(&path).unwrap_err();
    assert_eq!((err.line, err.column), (0, 0));
    assert!(err.message.contains("cannot read scene file"), "{err}");
    assert_eq!(err.to_string(), format!("{}: {}", path.display(), err.message));
}

fn scene_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(root().join("assets/scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files
}

fn load(name: &str) -> Scene {
    let path = root().join("assets/scenes").join(name);
    load_scene(&path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn every_asset_scene_loads() {
    let files = scene_files();
    for name in ["showcase.toml", "single_cube.toml", "instances.toml", "empty.toml"] {
        assert!(files.iter().any(|f| f.ends_with(name)), "assets/scenes/{name} is missing");
    }
    for path in files {
        if let Err(e) = load_scene(&path) {
            panic!("{e}");
        }
    }
}

#[test]
fn asset_scenes_have_the_promised_content() {
    let showcase = load("showcase.toml");
    let triangles: usize =
        showcase.instances.iter().map(|i| showcase.meshes[i.mesh].mesh.indices.len() / 3).sum();
    assert!(triangles < 30_000, "showcase has {triangles} triangles");
    assert!(showcase.instances.len() >= 6 && showcase.lights.len() == 1);
    assert_eq!(load("single_cube.toml").instances.len(), 1);
    let grid = load("instances.toml");
    assert_eq!((grid.meshes.len(), grid.instances.len()), (1, 50));
    let empty = load("empty.toml");
    assert!(empty.instances.is_empty() && empty.meshes.is_empty());
}

const CAMERA: &str = "[camera]\nposition = [0, 2, 8]\nlook_at = [0, 0, 0]\n";

fn parse(extra: &str) -> Result<Scene, SceneError> {
    parse_scene(&format!("{CAMERA}{extra}"), Path::new("inline.toml"))
}

#[test]
fn defaults_follow_the_documentation() {
    let s = parse("[[light]]\ndirection = [0, -2, 0]\n").unwrap();
    assert_eq!((s.render.width, s.render.height, s.render.exposure), (512, 512, 1.0));
    assert_eq!(s.render.background, DVec3::new(0.02, 0.02, 0.03));
    assert_eq!(s.render.ambient, DVec3::splat(0.08));
    let c = s.camera;
    assert_eq!((c.up, c.fov_y_deg, c.near, c.far), (DVec3::Y, 45.0, 0.1, 1000.0));
    let l = s.lights[0];
    assert_eq!((l.direction, l.color, l.intensity), (DVec3::NEG_Y, DVec3::ONE, 1.0));
}

fn instance_transform(steps: &str) -> hadou::scene::transform::Transform {
    let mesh = "[[mesh]]\nname = \"m\"\nkind = \"tetrahedron\"\n";
    let s = parse(&format!("{mesh}[[instance]]\nmesh = \"m\"\ntransform = {steps}\n")).unwrap();
    s.instances[0].transform
}

/// Steps apply in the order listed (M = Xn⋯X1): the worked example of docs/scene-format.md.
#[test]
fn transform_steps_apply_in_order() {
    let (s, r, t) = (
        "{ scale = [2, 1, 1] }",
        "{ rotate = { angle_deg = 90, axis = [0, 0, 1] } }",
        "{ translate = [0, 5, 0] }",
    );
    let srt = format!("[{s}, {r}, {t}]");
    let trs = format!("[{t}, {r}, {s}]");
    let matrix = "[{ matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [2, 0, 0, 1]] }]";
    for (steps, expect) in [(srt, DVec3::new(0.0, 7.0, 0.0)), (trs, DVec3::new(-10.0, 1.0, 0.0))] {
        let t = instance_transform(&steps);
        assert!((t.transform_point(DVec3::X) - expect).length() < 1e-12, "{steps}");
        assert!((t.inverse * t.matrix).abs_diff_eq(glam::DMat4::IDENTITY, 1e-12));
    }
    let t = instance_transform(matrix);
    assert!((t.transform_point(DVec3::ZERO) - DVec3::new(2.0, 0.0, 0.0)).length() < 1e-12);
}

#[test]
fn default_material_is_added_once_or_taken_from_the_file() {
    let mesh = "[[mesh]]\nname = \"m\"\nkind = \"cube\"\n";
    let two = "[[instance]]\nmesh = \"m\"\n[[instance]]\nmesh = \"m\"\nmaterial = \"default\"\n";
    let s = parse(&format!("{mesh}{two}")).unwrap();
    assert_eq!(s.materials.len(), 1);
    assert_eq!((s.instances[0].material, s.instances[1].material), (0, 0));
    assert_eq!(s.materials[0].albedo, DVec3::splat(0.7));
    let own = "[[material]]\nname = \"default\"\nalbedo = [0.1, 0.2, 0.3]\n";
    let s = parse(&format!("{mesh}{own}{two}")).unwrap();
    assert_eq!(s.materials.len(), 1);
    assert_eq!(s.materials[0].albedo, DVec3::new(0.1, 0.2, 0.3));
}

/// Truncations and single-character substitutions of the showcase: errors are fine, panics
/// are not, and every error points inside the text.
#[test]
fn mangled_showcase_never_panics() {
    let path = root().join("assets/scenes/showcase.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let check = |t: &str| {
        if let Err(e) = parse_scene(t, &path) {
            let lines = t.split('\n').count();
            assert!(e.line >= 1 && e.line <= lines && e.column >= 1, "{e} (text has {lines} lines)");
        }
    };
    for cut in (0..text.len()).step_by(37) {
        if let Some(prefix) = text.get(..cut) {
            check(prefix);
        }
    }
    let chars: Vec<char> = text.chars().collect();
    for i in (0..chars.len()).step_by(11) {
        for c in ['[', ']', '"', '=', '\n', 'x', '0', '-', '.', '{', 'é'] {
            let mut mangled = chars.clone();
            mangled[i] = c;
            check(&mangled.iter().collect::<String>());
        }
    }
}
