//! The `hadou` command end to end: render with AOVs, profile with JSON and trace, bad scenes,
//! and no Vulkan driver. Every run asks for validation; `render` fails on any validation error.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn hadou(args: &[&str], envs: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hadou"));
    cmd.args(args).current_dir(common::root()).env("HADOU_VALIDATION", "1");
    for (k, v) in envs {
        cmd.env(k, v);
    }
    cmd.output().expect("run hadou")
}

fn tmp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hadou-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn text(out: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

#[test]
fn render_writes_png_and_depth_exr() {
    let dir = tmp_dir("render");
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

#[test]
fn profile_writes_json_and_trace() {
    let dir = tmp_dir("profile");
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

/// Every bad scene file: its own message with line and column, non-zero exit, no panic, and no
/// output file written.
#[test]
fn bad_scenes_fail_cleanly_without_output() {
    let dir = tmp_dir("bad");
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
