//! The scene file's error contract: every bad file in tests/bad_scenes is refused at the exact
//! line:col with a message that says what was expected; every scene in assets/scenes loads; and
//! no mangled input makes the loader panic.

use std::path::{Path, PathBuf};

use glam::DVec3;
use hadou::scene::{load_scene, parse_scene, Scene, SceneError, WaveMethod};

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
    ("fov_out_of_range.toml", 4, 13, "`fov_y_deg`: expected a number in [0.1, 180), found 180"),
    ("torus_minor_too_large.toml", 9, 16, "mesh \"ring\": torus minor_radius must be < major_radius"),
    ("wobble_too_large.toml", 8, 10, "mesh \"ball\" `wobble`: expected a number in [0, 0.1], found 0.2"),
    (
        "wobble_with_lut.toml",
        17,
        12,
        "`material`: material \"jade\" reads a thickness table baked from the loaded shape, but mesh \"ball\" wobbles",
    ),
    (
        "hollow_ball_cavity_too_large.toml",
        9,
        17,
        "mesh \"ball\": hollow_ball cavity_radius must be < radius/4 (= 0.25), got 0.3",
    ),
    ("bad_obj_path.toml", 8, 8, "no_such_file.obj: No such file or directory"),
    ("malformed_obj.toml", 8, 8, "mesh \"wedge\": "),
    ("obj_index_out_of_range.toml", 8, 8, "mesh \"wedge\": "),
    ("image_size_zero.toml", 2, 9, "`size`: expected integers in 1..=16384, found 0"),
    ("image_size_too_large.toml", 2, 14, "`size`: expected integers in 1..=16384, found 16385"),
    ("too_many_lights.toml", 21, 1, "too many [[light]] tables (expected at most 8 lights of any kind, the frame uniform's array; found 9)"),
    ("not_utf8.toml", 2, 25, "invalid UTF-8 (byte 0xe9); expected a UTF-8 text file"),
    (
        "translucent_open_mesh.toml",
        17,
        12,
        "instance 1 `material`: translucent material \"jade\" needs a closed, consistently oriented mesh, \
         but mesh \"sheet\" is not: edge between vertices 0",
    ),
    (
        "translucent_sigma_zero.toml",
        8,
        9,
        "material \"jade\" `sigma`: expected an array of 3 numbers, each > 0",
    ),
    (
        "translucent_negative_attenuation_distance.toml",
        9,
        24,
        "material \"wax\" `attenuation_distance`: expected a number > 0, found -0.5",
    ),
    ("translucent_both_sigma_and_attenuation.toml", 9, 1, "`attenuation_color` given together with `sigma`"),
    ("translucent_voxel_res_zero.toml", 9, 13, "`voxel_res`: expected an integer in 4..=128, found 0"),
    ("translucent_voxel_res_too_large.toml", 9, 13, "`voxel_res`: expected an integer in 4..=128, found 129"),
    (
        "translucent_unknown_thickness_mode.toml",
        9,
        13,
        "`thickness`: expected one of \"lut\", \"tsm\", \"peel\", \"pairs\", found \"shadowmap\"",
    ),
    ("wave_nan.toml", 13, 14, "expected a finite number, found nan"),
    ("wave_negative_core.toml", 11, 8, "wave \"beam\" `core`: expected a number >= 0, found -0.5"),
    ("wave_zero_direction.toml", 8, 13, "wave 1 `direction`: expected a non-zero vector, found [0, 0, 0]"),
    ("wave_length_zero.toml", 11, 10, "wave \"beam\" `length`: expected a number > 0, found 0"),
    ("wave_keyframes_unsorted.toml", 20, 8, "wave 1 keyframe 3 `time`: expected a time > 2 (the previous"),
    (
        "wave_unknown_method.toml",
        10,
        10,
        "`method`: expected one of \"analytic\", \"raymarch\", found \"raytrace\"",
    ),
    ("wave_steps_zero.toml", 11, 9, "wave 1 `steps`: expected an integer in 1..=65536, found 0"),
    ("wave_steps_with_analytic.toml", 10, 1, "`steps` is a field of method = \"raymarch\" only"),
    ("wave_tolerance_one.toml", 10, 13, "wave 1 `tolerance`: expected a number in [0, 1)"),
    ("wave_tolerance_with_raymarch.toml", 11, 1, "`tolerance` is a field of method = \"analytic\" only"),
    (
        "wave_opposite_directions.toml",
        22,
        13,
        "keyframe 3 `direction`: expected a direction not opposite to keyframe 1's",
    ),
    ("wave_unknown_key.toml", 10, 1, "unknown field `speed`"),
    ("wave_keyframe_unknown_key.toml", 13, 1, "unknown field `color`"),
    ("wave_zero_strength.toml", 9, 5, "wave 1 `a`: expected a + b > 0"),
    ("wave_negative_color.toml", 10, 9, "wave 1 `color`: expected an array of 3 numbers, each >= 0"),
    (
        "metaballs_radius_zero.toml",
        10,
        34,
        "metaballs \"slime\" ball 2 `radius`: expected a number in [1.0842e-19, 9.2234e18] (2^-63 to 2^63: its square must be a normal f32), found 0",
    ),
    ("metaballs_nan_centre.toml", 9, 18, "expected a finite number, found nan"),
    (
        "metaballs_threshold_zero.toml",
        8,
        13,
        "metaballs \"slime\" `threshold`: expected a number >= 1.1754944e-38 (f32's smallest normal number), found 0",
    ),
    (
        "metaballs_unknown_kernel.toml",
        7,
        10,
        "metaballs 1 `kernel`: expected one of \"wyvill6\", \"murakami4\", found \"gauss\"",
    ),
    ("metaballs_no_balls.toml", 9, 9, "metaballs \"empty\" `balls`: expected at least one ball"),
    ("metaballs_unknown_key.toml", 8, 1, "unknown field `radii`"),
    (
        "metaballs_unknown_method.toml",
        7,
        10,
        "metaballs 1 `method`: expected one of \"bezier\", \"sphere_trace\", found \"marching_cubes\"",
    ),
    (
        "metaballs_steps_zero.toml",
        9,
        9,
        "metaballs \"slime\" `steps`: expected an integer in 1..=100000, found 0",
    ),
    (
        "metaballs_tolerance_negative.toml",
        8,
        13,
        "metaballs \"slime\" `tolerance`: expected a number >= 1.1754944e-38 (f32's smallest normal number), found -0.001",
    ),
    ("metaballs_steps_with_bezier.toml", 7, 1, "`steps` is a field of method = \"sphere_trace\" only"),
    (
        "metaballs_tolerance_with_sphere_trace.toml",
        8,
        1,
        "`tolerance` is a field of method = \"bezier\" only",
    ),
    // Numbers the GPU cannot hold (issue 14, finding 4): f32 range, RGBA16F HDR, D32 depth, extent.
    ("light_intensity_f32_overflow.toml", 7, 13, "expected a number that f32 holds (|x| <= 3.4028235e38"),
    ("background_f32_overflow.toml", 2, 15, "expected a number that f32 holds"),
    (
        "background_over_hdr.toml",
        2,
        14,
        "[render] `background`: expected an array of 3 numbers, each in [0, 65504]",
    ),
    ("exposure_subnormal.toml", 2, 12, "[render] `exposure`: expected a number >= 1.1754944e-38"),
    ("near_underflows_f32.toml", 4, 8, "[camera] `near`: expected a number >= 1.1755e-35 (far / 2^126"),
    ("scene_scaled_3e15.toml", 6, 7, "[camera] `far`: expected a number in [-2.8147e14, 2.8147e14]"),
    (
        "metaballs_radius_squares_to_subnormal.toml",
        7,
        41,
        "metaballs \"dust\" ball 1 `radius`: expected a number in [1.0842e-19, 9.2234e18]",
    ),
    ("wave_emission_f32_overflow.toml", 10, 13, "`intensity`: expected colour × intensity <= 3.4028235e38"),
    ("gltf_missing_file.toml", 7, 8, "gltf 1 `path`: "),
    (
        "framing_past_2_44.toml",
        11,
        13,
        "instance \"far\" `transform`: its world box reaches 1.4074e14, past ±1.7592e13 (2^44), the farthest a \
         scene without a camera can frame",
    ),
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

/// Loads on a thread, so a loader that blocks fails the test instead of hanging it.
fn load_within_seconds(path: &Path) -> Result<Scene, SceneError> {
    let (send, receive) = std::sync::mpsc::channel();
    let path = path.to_path_buf();
    std::thread::spawn(move || {
        let _ = send.send(load_scene(&path));
    });
    receive.recv_timeout(std::time::Duration::from_secs(20)).expect("loading blocked")
}

#[test]
fn fifo_scene_and_obj_paths_are_refused_without_blocking() {
    let dir = std::env::temp_dir().join(format!("hadou-scene-fifo-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for fifo in ["pipe.obj", "pipe.toml"] {
        assert!(std::process::Command::new("mkfifo").arg(dir.join(fifo)).status().unwrap().success());
    }
    let scene = dir.join("s.toml");
    let text = "[[mesh]]\nname = \"m\"\nkind = \"obj\"\npath = \"pipe.obj\"\n\n[[instance]]\nmesh = \"m\"\n\n[camera]\nposition = [0, 2, 8]\nlook_at = [0, 0, 0]\n";
    std::fs::write(&scene, text).unwrap();
    let obj = load_within_seconds(&scene);
    let whole = load_within_seconds(&dir.join("pipe.toml"));
    std::fs::remove_dir_all(&dir).unwrap();
    let err = obj.unwrap_err();
    assert_eq!((err.line, err.column), (4, 8), "{err}");
    assert!(err.message.contains("pipe.obj") && err.message.contains("not a regular file"), "{err}");
    let err = whole.unwrap_err();
    assert!(err.to_string().contains("pipe.toml") && err.message.contains("not a regular file"), "{err}");
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
    let names = ["showcase.toml", "single_cube.toml", "instances.toml", "empty.toml", "energy_wave.toml"];
    for name in names.into_iter().chain(["energy_wave_open.toml"]) {
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
    assert!(showcase.instances.len() >= 6 && showcase.lights.len() == 2);
    assert_eq!(load("single_cube.toml").instances.len(), 1);
    let grid = load("instances.toml");
    assert_eq!((grid.meshes.len(), grid.instances.len()), (1, 50));
    let empty = load("empty.toml");
    assert!(empty.instances.is_empty() && empty.meshes.is_empty());
    assert!(!showcase.waves().is_empty());
}

/// energy_wave.toml is seed 004's set-up: `--time 0/1/2/3` gives m_z of figures 15-18.
#[test]
fn energy_wave_scenes_follow_the_seed() {
    let hidden = load("energy_wave.toml");
    let open = load("energy_wave_open.toml");
    assert_eq!((hidden.instances.len(), open.instances.len()), (2, 0));
    let centres: Vec<DVec3> =
        hidden.instances.iter().map(|i| i.transform.transform_point(DVec3::ZERO)).collect();
    assert_eq!(centres, [DVec3::ZERO, DVec3::new(10.0, 0.0, 250.0)]);
    assert_eq!(hidden.waves(), open.waves());
    assert_eq!((hidden.camera, hidden.render), (open.camera, open.render));
    let wave = &hidden.waves()[0];
    assert_eq!((wave.direction, wave.a, wave.b), (DVec3::X, 60.0, 30.0));
    for (time, m_z) in [(0.0, 280.0), (1.0, 70.0), (2.0, 10.0), (3.0, -140.0)] {
        assert_eq!(wave.at(time).origin, DVec3::new(0.0, 0.0, m_z), "time {time}");
    }
    let c = hidden.camera;
    assert!(c.far >= 1500.0 && c.near == 0.5 && c.position.z > 280.0 && c.look_at.z < c.position.z);
    assert_eq!((hidden.render.width, hidden.render.height), (512, 512));
}

const WAVE: &str = "[[wave]]\norigin = [1, 2, 3]\ndirection = [0, 0, -2]\n";

#[test]
fn wave_defaults_follow_the_documentation() {
    let s = parse(&format!("{WAVE}a = 5\n")).unwrap();
    let w = &s.waves()[0];
    assert_eq!(
        (w.name.as_deref(), w.origin, w.velocity, w.direction),
        (None, DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO, DVec3::NEG_Z)
    );
    assert_eq!(
        (w.a, w.b, w.core, w.length, w.color, w.intensity),
        (5.0, 0.0, 0.0, f64::INFINITY, DVec3::ONE, 1.0)
    );
    assert_eq!((w.method, w.keyframes.len()), (WaveMethod::Analytic, 0));
    let s = parse(&format!("{WAVE}b = 1\nmethod = \"raymarch\"\n")).unwrap();
    assert_eq!(s.waves()[0].method, WaveMethod::Raymarch { steps: 64, jitter: false });
    let s = parse(&format!("{WAVE}b = 1\nmethod = \"raymarch\"\nsteps = 65536\njitter = true\n")).unwrap();
    assert_eq!(s.waves()[0].method, WaveMethod::Raymarch { steps: 65536, jitter: true });
}

#[test]
fn wave_keyframes_are_read_in_order_with_unit_directions() {
    let keys = "[[wave.keyframe]]\ntime = -1\ndirection = [0, 3, 0]\nlength = 2\n\
                [[wave.keyframe]]\ntime = 0.5\norigin = [0, 0, 9]\na = 0\nb = 2\ncore = 0.1\nintensity = 3\n";
    let s = parse(&format!("{WAVE}a = 1\nvelocity = [0, 1, 0]\n{keys}")).unwrap();
    let w = &s.waves()[0];
    assert_eq!(w.keyframes.len(), 2);
    assert_eq!(
        (w.keyframes[0].time, w.keyframes[0].direction, w.keyframes[0].length),
        (-1.0, Some(DVec3::Y), Some(2.0))
    );
    let k = &w.keyframes[1];
    assert_eq!(
        (k.origin, k.a, k.b, k.core, k.intensity),
        (Some(DVec3::new(0.0, 0.0, 9.0)), Some(0.0), Some(2.0), Some(0.1), Some(3.0))
    );
    let at = w.at(2.0);
    assert_eq!((at.origin, at.direction, at.length, at.b), (DVec3::new(0.0, 2.0, 9.0), DVec3::Y, 2.0, 2.0));
}

/// a + b > 0 is asked of the values in effect: keyframes can give the strength the table lacks,
/// and a wave whose every `a` and `b` is 0 is refused where the first of them is written.
#[test]
fn wave_strength_counts_keyframes() {
    assert!(parse(&format!("{WAVE}[[wave.keyframe]]\ntime = 1\nb = 0.5\n")).is_ok());
    let err = parse(&format!("{WAVE}[[wave.keyframe]]\ntime = 1\na = 0\n")).unwrap_err();
    assert_eq!((err.line, err.column), (9, 5), "{err}");
    assert!(err.message.contains("found a = 0 and b = 0 at every keyframe"), "{err}");
    let err = parse(WAVE).unwrap_err();
    assert_eq!((err.line, err.column), (4, 1), "{err}");
    assert!(err.message.contains("wave 1: missing `a` and `b`"), "{err}");
}

#[test]
fn wave_fields_in_the_wrong_place_are_refused() {
    // `jitter` with the default method, at the key.
    let err = parse(&format!("{WAVE}a = 1\njitter = true\n")).unwrap_err();
    assert_eq!((err.line, err.column), (8, 1), "{err}");
    assert!(err.message.contains("`jitter` is a field of method = \"raymarch\" only"), "{err}");
    // A keyframe without a time, at its header.
    let err = parse(&format!("{WAVE}a = 1\n[[wave.keyframe]]\na = 2\n")).unwrap_err();
    assert_eq!((err.line, err.column), (8, 1), "{err}");
    assert!(err.message.contains("wave 1 keyframe 1: missing `time`"), "{err}");
    // A zero keyframe direction and a non-positive keyframe length, at the value.
    let err =
        parse(&format!("{WAVE}a = 1\n[[wave.keyframe]]\ntime = 0\ndirection = [0, 0, 0]\n")).unwrap_err();
    assert_eq!(
        (err.line, err.column, err.message.contains("`direction`: expected a non-zero vector")),
        (10, 13, true),
        "{err}"
    );
    let err = parse(&format!("{WAVE}a = 1\n[[wave.keyframe]]\ntime = 0\nlength = -1\n")).unwrap_err();
    assert_eq!(
        (err.line, err.column, err.message.contains("`length`: expected a number > 0")),
        (10, 10, true),
        "{err}"
    );
    // steps above the limit.
    let err = parse(&format!("{WAVE}a = 1\nmethod = \"raymarch\"\nsteps = 65537\n")).unwrap_err();
    assert_eq!((err.line, err.column), (9, 9), "{err}");
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

/// The `[[wave]]` examples of docs/scene-format.md parse, and the keyframe example gives the
/// values the text after it states.
#[test]
fn documented_wave_examples_parse() {
    let doc = std::fs::read_to_string(root().join("docs/scene-format.md")).unwrap();
    let blocks: Vec<&str> = doc
        .split("```toml\n")
        .skip(1)
        .filter_map(|b| b.split("```").next())
        .filter(|b| b.starts_with("[[wave]]"))
        .collect();
    assert!(blocks.len() >= 3, "found {} [[wave]] examples", blocks.len());
    for block in &blocks {
        parse(block).unwrap_or_else(|e| panic!("{e}\n{block}"));
    }
    let figures = blocks.iter().find(|b| b.contains("time = 3")).expect("the keyframe example");
    let scene = parse(figures).unwrap();
    let wave = &scene.waves()[0];
    let half = wave.at(0.5);
    assert_eq!((half.origin, half.b, half.a), (DVec3::new(0.0, 0.0, 175.0), 35.0, 60.0));
    let late = wave.at(3.5);
    assert_eq!((late.origin, late.b), (DVec3::new(0.0, 0.0, -140.0), 50.0));
}

/// Scene loading is linear (issue 14, finding 7): n instances each with its own material. Every
/// look-up once scanned every name, and every material's location was found by scanning the
/// text from its start (20,000: 10 s in a debug build, 0.125 s → 2.4 s from 2,000 to 8,000).
/// Not a timing bound but a ratio: 8× the tables take ~8× as long when linear and ~64× when
/// quadratic; the bound 24 lies between with a factor 3 for noise either way (a loaded 2-core
/// machine measured 8.2 where 4 was due, for 4× the tables). Noise is cut three ways: each size
/// is the best of 5 loads, the loads of the two sizes alternate (a burst of load elsewhere slows
/// both alike), and a ratio over the bound is measured again, up to 3 attempts in all: linear
/// code fails only if all three are disturbed, quadratic code (~64 every time) never passes.
#[test]
fn loading_is_linear_in_the_number_of_tables() {
    use std::fmt::Write;
    let text = |n: usize| {
        let mut text = String::from("[[mesh]]\nname = \"box\"\nkind = \"cube\"\n");
        for i in 0..n {
            let _ = write!(
                text,
                "[[material]]\nname = \"m{i}\"\n[[instance]]\nmesh = \"box\"\nmaterial = \"m{i}\"\n"
            );
        }
        (n, text)
    };
    let load = |(n, text): &(usize, String)| {
        let start = std::time::Instant::now();
        let scene = parse(text).unwrap();
        let seconds = start.elapsed().as_secs_f64();
        assert_eq!((scene.instances.len(), scene.materials.len()), (*n, *n));
        assert!(scene.instances.iter().enumerate().all(|(i, inst)| inst.material == i));
        seconds
    };
    let (small, large) = (text(2_500), text(20_000));
    let mut ratios = Vec::new();
    for _attempt in 0..3 {
        let (mut best_small, mut best_large) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..5 {
            best_small = best_small.min(load(&small));
            best_large = best_large.min(load(&large));
        }
        let ratio = best_large / best_small;
        println!("2,500 tables: {best_small:.3} s, 20,000: {best_large:.3} s (ratio {ratio:.1})");
        ratios.push(ratio);
        if ratio < 24.0 {
            return;
        }
    }
    panic!("8× the tables took {ratios:.1?}× as long in 3 attempts (linear: ~8, quadratic: ~64)");
}

/// `instance_records` groups instances by mesh (one draw each), in scene order within a mesh.
#[test]
fn instance_records_group_by_mesh_in_scene_order() {
    let meshes = "[[mesh]]\nname = \"a\"\nkind = \"cube\"\n[[mesh]]\nname = \"b\"\nkind = \"plane\"\n\
                  [[mesh]]\nname = \"unused\"\nkind = \"cube\"\n";
    let order = ["b", "a", "b", "b", "a"];
    let instances: String = order.iter().map(|m| format!("[[instance]]\nmesh = \"{m}\"\n")).collect();
    let scene = parse(&format!("{meshes}{instances}")).unwrap();
    let (records, ranges) = hadou::passes::gpu_structs::instance_records(&scene);
    assert_eq!(ranges, vec![(0, 2), (2, 3), (5, 0)]);
    let ids: Vec<u32> = records.iter().map(|r| r.ids[0]).collect();
    assert_eq!(ids, vec![1, 4, 0, 2, 3]);
}

/// Framing near the limit: cubes within ±2⁴⁴ (one at the origin, one at 2⁴⁴ − 1 on each axis, and
/// one at −2⁴⁴ + 1) get a framing camera whose position, look-at and `far` are within 2⁴⁸ and whose
/// `far` reaches every corner; the same scene with a [camera] keeps its far cube (the check is
/// the framing's, not the instances').
#[test]
fn framing_near_the_limit_stays_within_2_48() {
    let path = root().join("tests/bad_scenes/framing_near_the_limit.toml");
    let edge = 2f64.powi(44) - 1.0;
    let cubes =
        |t: [f64; 3]| format!("[[instance]]\nmesh = \"box\"\ntransform = [{{ translate = {t:?} }}]\n");
    let text = format!(
        "[[mesh]]\nname = \"box\"\nkind = \"cube\"\n{}{}{}[[gltf]]\npath = \"one_triangle.gltf\"\n",
        cubes([0.0; 3]),
        cubes([edge - 1.0; 3]),
        cubes([-edge + 1.0, 0.0, 0.0]),
    );
    let scene = parse_scene(&text, &path).unwrap();
    let c = scene.camera;
    let limit = 2f64.powi(48);
    assert!(c.position.abs().max_element() <= limit, "{c:?}");
    assert!(c.look_at.abs().max_element() <= limit, "{c:?}");
    assert!(c.far <= limit && c.near > 0.0 && c.near < c.far, "{c:?}");
    for corner in [DVec3::splat(edge), DVec3::new(-edge, -0.5, -0.5)] {
        assert!((corner - c.position).length() < c.far, "{corner} beyond far from {c:?}");
    }
    // One past 2^44 is refused; with a camera the same cube is a plain (invisible) instance.
    let past = format!("[[mesh]]\nname = \"box\"\nkind = \"cube\"\n{}", cubes([2f64.powi(44), 0.0, 0.0]));
    let err = parse_scene(&format!("{past}[[gltf]]\npath = \"one_triangle.gltf\"\n"), &path).unwrap_err();
    assert_eq!((err.line, err.column), (6, 13), "{err}");
    assert!(err.message.contains("past ±1.7592e13 (2^44)"), "{err}");
    let camera = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";
    parse_scene(&format!("{camera}{past}[[gltf]]\npath = \"one_triangle.gltf\"\n"), &path).unwrap();
}
