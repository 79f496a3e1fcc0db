//! The `hadou` command end to end: render with AOVs, profile with JSON and trace, bad scenes,
//! and no Vulkan driver. Every run asks for validation; `render` fails on any validation error.

mod common;

use common::cli::{scratch, text};
use hadou::testing::Comparison;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn hadou(args: &[&str], envs: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hadou"));
    cmd.args(args).current_dir(common::root()).env("HADOU_VALIDATION", "1");
    for (k, v) in envs {
        cmd.env(k, v);
    }
    cmd.output().expect("run hadou")
}

#[test]
fn render_writes_png_and_depth_exr() {
    let dir = scratch("render");
    let png = dir.join("s.png");
    let exr = dir.join("d.exr");
    let out = hadou(
        &["render", "assets/scenes/showcase.toml", "-o", png.to_str().unwrap(), "--size", "96x64", "--aov"],
        &[],
    );
    // `--aov` without a value is a usage error, not a crash.
    assert!(!out.status.success());
    let aov = format!("depth={}", exr.display());
    let out = hadou(
        &[
            "render",
            "assets/scenes/showcase.toml",
            "-o",
            png.to_str().unwrap(),
            "--size",
            "96x64",
            "--aov",
            &aov,
        ],
        &[],
    );
    assert!(out.status.success(), "{}", text(&out));
    let img = image::open(&png).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (96, 64));
    let (w, h, depth) = hadou::output::read_exr_channel(&exr).unwrap();
    assert_eq!((w, h), (96, 64));
    assert!(depth.iter().any(|d| d.is_finite()) && depth.iter().all(|d| !d.is_nan()));
    assert!(depth.contains(&f32::INFINITY), "the showcase has sky pixels");
}

/// Runs with HADOU_VALIDATION=1: `profile` exits non-zero on any validation error or warning
/// (leaks at device destroy included), so its success is a clean validation log.
#[test]
fn profile_writes_json_and_trace() {
    let dir = scratch("profile");
    let json = dir.join("p.json");
    let trace = dir.join("t.json");
    let out = hadou(
        &[
            "profile",
            "assets/scenes/showcase.toml",
            "--size",
            "64x64",
            "--frames",
            "4",
            "--warmup",
            "1",
            "--json",
            json.to_str().unwrap(),
            "--trace",
            trace.to_str().unwrap(),
        ],
        &[],
    );
    assert!(out.status.success(), "{}", text(&out));
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    for key in
        ["device", "width", "height", "build_profile", "passes", "cpu_record", "cpu_frame", "gpu_frame"]
    {
        assert!(report.get(key).is_some(), "JSON lacks {key}");
    }
    for key in ["name", "driver", "api_version"] {
        assert!(report["device"].get(key).is_some(), "JSON device lacks {key}");
    }
    for pass in ["raster", "tonemap"] {
        let p = &report["passes"][pass];
        assert!(p["p50"].as_f64().is_some_and(|v| v >= 0.0), "pass {pass}: {p}");
    }
    assert_eq!(report["frames"], 4);
    let trace: serde_json::Value = serde_json::from_slice(&std::fs::read(&trace).unwrap()).unwrap();
    let events = trace["traceEvents"].as_array().unwrap();
    assert!(events.iter().filter(|e| e["name"] == "raster").count() == 4);
    assert!(text(&out).contains("gpu raster"));
}

/// `profile` fails on validation messages, like `render`: with the layer's best-practices checks
/// switched on from outside (VK_LAYER_ENABLES, read by the Khronos layer), lavapipe's run draws
/// warnings (a timestamp written at ALL_COMMANDS), and the run exits non-zero naming them and
/// writes no JSON. So the success of `profile_writes_json_and_trace` (HADOU_VALIDATION=1, as
/// every run here) means a clean log, not an unchecked one.
#[test]
fn profile_fails_on_validation_warnings() {
    let dir = scratch("profile-warned");
    let json = dir.join("p.json");
    let args =
        ["profile", "assets/scenes/single_cube.toml", "--size", "16x16", "--frames", "1", "--warmup", "0"];
    let mut with_json = args.to_vec();
    with_json.extend(["--json", json.to_str().unwrap()]);
    let best_practices = [("VK_LAYER_ENABLES", "VK_VALIDATION_FEATURE_ENABLE_BEST_PRACTICES_EXT")];
    let out = hadou(&with_json, &best_practices);
    let msg = text(&out);
    assert_eq!(out.status.code(), Some(1), "{msg}");
    assert!(msg.contains("validation reported") && msg.contains("warnings"), "{msg}");
    assert!(!json.exists(), "a run the layer objected to wrote its JSON");
    // The same run without the extra checks passes: the failure above is the warnings'.
    let out = hadou(&with_json, &[]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(json.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every bad scene file: its own message with line and column, non-zero exit, no panic, and no
/// output file written.
#[test]
fn bad_scenes_fail_cleanly_without_output() {
    let dir = scratch("bad");
    let bad = common::root().join("tests/bad_scenes");
    let mut files: Vec<_> =
        std::fs::read_dir(&bad).unwrap().filter_map(|e| e.ok()).map(|e| e.path()).collect();
    files.retain(|p| p.extension().is_some_and(|e| e == "toml"));
    files.sort();
    assert!(files.len() >= 15, "only {} bad scenes", files.len());
    for file in files {
        let png = dir.join("never.png");
        let exr = dir.join("never.exr");
        let aov = format!("depth={}", exr.display());
        let out = hadou(&["render", file.to_str().unwrap(), "-o", png.to_str().unwrap(), "--aov", &aov], &[]);
        let msg = text(&out);
        assert!(!out.status.success(), "{} was accepted", file.display());
        assert!(!msg.contains("panicked"), "{}: {msg}", file.display());
        let name = file.file_name().unwrap().to_string_lossy().to_string();
        assert!(
            msg.contains(&format!("{name}:")),
            "{}: message does not name the file: {msg}",
            file.display()
        );
        assert!(has_line_col(&msg), "{}: no line:col in {msg}", file.display());
        assert!(!png.exists() && !exr.exists(), "{}: an output file was written", file.display());
    }
}

fn has_line_col(msg: &str) -> bool {
    msg.split(':').collect::<Vec<_>>().windows(2).any(|w| {
        w[0].trim().parse::<u32>().is_ok()
            && w[1]
                .trim()
                .split(|c: char| !c.is_ascii_digit())
                .next()
                .is_some_and(|s| s.parse::<u32>().is_ok())
    })
}

#[test]
fn bad_arguments_are_reported() {
    for args in [
        vec!["render", "assets/scenes/showcase.toml", "--size", "0x5"],
        vec!["render", "assets/scenes/showcase.toml", "--size", "banana"],
        vec!["render", "assets/scenes/showcase.toml", "--aov", "colour=x.exr"],
        vec!["render", "does/not/exist.toml"],
        vec!["profile", "assets/scenes/showcase.toml", "--frames", "0"],
    ] {
        let out = hadou(&args, &[]);
        let msg = text(&out);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(msg.contains("error") && !msg.contains("panicked"), "{args:?}: {msg}");
    }
}

/// No driver: a plain message naming the package for software rendering, no panic.
#[test]
fn no_vulkan_driver_is_a_clear_error() {
    let missing = Path::new("/nonexistent/hadou_icd.json");
    for var in ["VK_DRIVER_FILES", "VK_ICD_FILENAMES"] {
        let out = hadou(&["devices"], &[(var, missing.to_str().unwrap())]);
        let msg = text(&out);
        assert!(!out.status.success(), "{var}: {msg}");
        assert!(!msg.contains("panicked"), "{msg}");
        assert!(msg.contains("mesa-vulkan-drivers"), "{var}: {msg}");
    }
    // A device filter that matches nothing lists what exists and why it was refused.
    let out = hadou(&["devices"], &[("HADOU_DEVICE", "no-such-gpu-xyz")]);
    let msg = text(&out);
    assert!(
        !out.status.success() && msg.contains("no-such-gpu-xyz") && msg.contains("does not contain"),
        "{msg}"
    );
}

/// Runs `hadou` and kills it after `seconds`: a regression that blocks fails instead of hanging.
fn hadou_within(seconds: u64, args: &[&str], envs: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hadou"));
    cmd.args(args).current_dir(common::root()).env("HADOU_VALIDATION", "1");
    cmd.envs(envs.iter().copied()).stdout(Stdio::piped()).stderr(Stdio::piped());
    let mut child = cmd.spawn().expect("run hadou");
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(seconds) {
            child.kill().unwrap();
            let out = child.wait_with_output().unwrap();
            panic!("{args:?} still running after {seconds} s: {}", text(&out));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}

/// No Vulkan driver: a command that fails for its arguments fails before any GPU work.
const NO_DRIVER: &[(&str, &str)] = &[("VK_DRIVER_FILES", "/nonexistent/hadou_icd.json")];

fn mkfifo(path: &Path) {
    assert!(Command::new("mkfifo").arg(path).status().unwrap().success(), "mkfifo {}", path.display());
}

/// Fails with exit status 1 and `error:` naming `path` (and not the missing driver: the check
/// ran before rendering).
fn assert_refused(out: &Output, path: &str, says: &str) {
    let msg = text(out);
    assert_eq!(out.status.code(), Some(1), "{msg}");
    assert!(msg.starts_with("error: ") && msg.contains(path) && msg.contains(says), "{msg}");
    assert!(!msg.contains("mesa-vulkan-drivers"), "the output was checked after the GPU start: {msg}");
}

#[test]
fn special_files_are_refused_as_outputs_before_rendering() {
    let dir = scratch("special");
    let fifo = dir.join("fifo.png");
    mkfifo(&fifo);
    let fifo = fifo.to_str().unwrap().to_string();
    let folder = dir.to_str().unwrap().to_string();
    let scene = "assets/scenes/single_cube.toml";
    for (path, says) in [
        ("/dev/null", "character device"),
        ("/dev/full", "character device"),
        (fifo.as_str(), "FIFO"),
        (folder.as_str(), "directory"),
    ] {
        let out = hadou_within(60, &["render", scene, "-o", path], NO_DRIVER);
        assert_refused(&out, path, says);
        let aov = format!("depth={path}");
        let out =
            hadou_within(60, &["render", scene, "-o", &format!("{folder}/a.png"), "--aov", &aov], NO_DRIVER);
        assert_refused(&out, path, says);
        let out = hadou_within(60, &["profile", scene, "--json", path], NO_DRIVER);
        assert_refused(&out, path, says);
    }
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());
    assert!(std::fs::metadata("/dev/full").unwrap().file_type().is_char_device());
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn outputs_may_not_name_the_input_or_each_other() {
    let dir = scratch("same");
    let scene = dir.join("s.toml");
    let text_before = std::fs::read_to_string(common::root().join("assets/scenes/single_cube.toml")).unwrap()
        + "\n[[material]]\nname = \"jade\"\nkind = \"translucent\"\nsigma = [1, 1, 1]\nvoxel_res = 8\n";
    let scene_text = text_before.replace("mesh = \"cube\"\n", "mesh = \"cube\"\nmaterial = \"jade\"\n");
    std::fs::write(&scene, &scene_text).unwrap();
    let s = scene.to_str().unwrap();
    let x = dir.join("x.png");
    let x = x.to_str().unwrap();
    let same_scene = format!("{}/./s.toml", dir.display());
    let hdr = format!("hdr={same_scene}");
    let depth = format!("depth={x}");
    let cache = dir.join("cache");
    let envs = [NO_DRIVER[0], ("HADOU_CACHE_DIR", cache.to_str().unwrap())];
    for (args, path, says) in [
        (vec!["render", s, "-o", s], s, "is the input"),
        (vec!["render", s, "-o", x, "--aov", hdr.as_str()], same_scene.as_str(), "is the input"),
        (vec!["render", s, "-o", x, "--aov", depth.as_str()], x, "is also the output"),
        (vec!["profile", s, "--json", x, "--trace", x], x, "is also the output"),
        (vec!["profile", s, "--trace", s], s, "is the input"),
        (vec!["bake", s, "--out", s], s, "is the input"),
    ] {
        let out = hadou_within(60, &args, &envs);
        assert_refused(&out, path, says);
        assert_eq!(std::fs::read_to_string(&scene).unwrap(), scene_text, "{args:?} changed the scene");
    }
    let entries: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(entries, ["s.toml"], "nothing else written, not even the cache");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unwritable_output_is_found_before_rendering() {
    let dir = scratch("unwritable");
    let file = dir.join("file");
    std::fs::write(&file, "x").unwrap();
    let inside = format!("{}/out.png", file.display());
    let out = hadou_within(60, &["render", "assets/scenes/single_cube.toml", "-o", &inside], NO_DRIVER);
    assert_refused(&out, &inside, "is not a folder");
    let out =
        hadou_within(60, &["render", "assets/scenes/single_cube.toml", "-o", "/proc/hadou.png"], NO_DRIVER);
    assert_refused(&out, "/proc/hadou.png", "cannot create");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn huge_frame_counts_are_errors_not_aborts() {
    let scene = "assets/scenes/single_cube.toml";
    for (args, says) in [
        (vec!["profile", scene, "--frames", "4294967296"], "--frames"),
        (vec!["profile", scene, "--frames", "18446744073709551615"], "--frames"),
        (vec!["profile", scene, "--warmup", "18446744073709551615"], "--warmup"),
        (vec!["report", "--frames", "18446744073709551615"], "--frames"),
    ] {
        let out = hadou_within(60, &args, NO_DRIVER);
        let msg = text(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {msg}");
        assert!(
            msg.starts_with("error: ") && msg.contains(says) && !msg.contains("panicked"),
            "{args:?}: {msg}"
        );
    }
}

#[test]
fn special_input_files_are_refused_without_blocking() {
    let dir = scratch("fifo-in");
    let obj = dir.join("pipe.obj");
    mkfifo(&obj);
    let obj = obj.to_str().unwrap();
    let out = hadou_within(60, &["bake", obj], NO_DRIVER);
    assert_refused(&out, obj, "not a regular file");
    let scene = dir.join("s.toml");
    let camera = "[camera]\nposition = [0, 2, 8]\nlook_at = [0, 0, 0]\n";
    let mesh = "[[mesh]]\nname = \"m\"\nkind = \"obj\"\npath = \"pipe.obj\"\n";
    std::fs::write(&scene, format!("{camera}\n{mesh}\n[[instance]]\nmesh = \"m\"\n")).unwrap();
    let out = hadou_within(60, &["render", scene.to_str().unwrap()], NO_DRIVER);
    assert_refused(&out, "pipe.obj", "not a regular file");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn io_errors_state_the_os_text_once() {
    let out = hadou_within(60, &["bake", "/nonexistent/mesh.obj"], NO_DRIVER);
    let msg = text(&out);
    assert_eq!(out.status.code(), Some(1), "{msg}");
    assert_eq!(msg.matches("No such file or directory").count(), 1, "{msg}");
}

#[test]
fn a_missing_thickness_aov_names_what_produces_it() {
    let dir = scratch("thickness");
    let aov = format!("thickness={}/t.exr", dir.display());
    let png = format!("{}/c.png", dir.display());
    let args = ["render", "assets/scenes/single_cube.toml", "-o", &png, "--size", "16x16", "--aov", &aov];
    let out = hadou_within(300, &args, &[]);
    let msg = text(&out);
    assert_eq!(out.status.code(), Some(1), "{msg}");
    assert!(
        msg.contains("thickness") && msg.contains("translucent material") && !msg.contains("wave"),
        "{msg}"
    );
    let entries: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(entries.is_empty(), "a failed render leaves nothing behind");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every voxel_res the format accepts fits: a translucent cube at 128 (refused before the
/// thickness field, issue 13: 283 M surface-voxel pairs above a 16384² texture) renders, and
/// renders right. A unit cube faces the camera with the light behind it, along the view axis: on
/// the front face the light crossed the whole cube, so the thickness AOV is 1 (the f64 twin: the
/// segment from the face point toward the light, inside the cube). Bound: 1 voxel (1/128), the
/// documented p95 of the thickness LUT, held here by every pixel (an axis-aligned path through
/// whole voxels); pixels within 1.5 pixels' width of the face's border are left out (the raster
/// and the f64 cast may disagree on coverage there), the rest outside show +inf (nothing
/// translucent). The colour shows the cube: its centre differs from the background's corner.
#[test]
fn a_translucent_cube_renders_at_the_largest_voxel_res() {
    let dir = scratch("lut-128");
    let scene = dir.join("big.toml");
    let source = "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\n[[light]]\ndirection = [0, 0, 1]\n\
                [[mesh]]\nname = \"box\"\nkind = \"cube\"\n[[material]]\nname = \"jade\"\nkind = \"translucent\"\n\
                sigma = [1, 1, 1]\nvoxel_res = 128\n[[instance]]\nmesh = \"box\"\nmaterial = \"jade\"\n";
    std::fs::write(&scene, source).unwrap();
    let png = dir.join("out.png");
    let exr = dir.join("t.exr");
    let aov = format!("thickness={}", exr.display());
    let (w, h) = (48u32, 48u32);
    let args =
        ["render", scene.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "48x48", "--aov", &aov];
    let out = hadou_within(300, &args, &[("HADOU_CACHE_DIR", dir.join("cache").to_str().unwrap())]);
    assert!(out.status.success(), "{}", text(&out));
    let img = image::open(&png).unwrap().to_rgba8();
    assert_ne!(img.get_pixel(w / 2, h / 2), img.get_pixel(0, 0), "the cube shows in the colour");
    let (ew, eh, thickness) = hadou::output::read_exr_channel(&exr).unwrap();
    assert_eq!((ew, eh), (w, h));
    let camera = hadou::scene::parse_scene(source, &scene).unwrap().camera;
    let mut c = Comparison::new("thickness at voxel_res 128 vs f64");
    let mut outside = 0;
    for y in 0..h {
        for x in 0..w {
            let (o, u) = camera.pixel_ray(x, y, w, h);
            // The ray meets the face's plane z = 0.5 at p; a pixel spans ≈ |p − o|·2·tan(fov/2)/h.
            let p = o + u * ((0.5 - o.z) / u.z);
            let pixel = (p - o).length() * 2.0 * (camera.fov_y_deg.to_radians() / 2.0).tan() / h as f64;
            let inset = 0.5 - (if p.x.abs() > p.y.abs() { p.x.abs() } else { p.y.abs() });
            let got = thickness[(y * w + x) as usize] as f64;
            if inset > 1.5 * pixel {
                c.abs(format_args!("({x}, {y})"), got, 1.0);
            } else if inset < -1.5 * pixel {
                assert_eq!(got, f64::INFINITY, "({x}, {y}): outside the cube");
                outside += 1;
            } else {
                c.exclude();
            }
        }
    }
    c.assert_within(1.0 / 128.0, 200);
    assert!(outside > 1000, "the background shows: {outside} pixels");
    let _ = std::fs::remove_dir_all(&dir);
}
