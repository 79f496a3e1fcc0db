//! `hadou render` on glTF files directly (validation on): a .glb renders; a malformed one is an
//! `error:` with the file and the JSON pointer, exit 1, and leaves no output or temporary; an
//! output may not replace the glTF's own .bin.

mod common;

use common::cli::{hadou, s, text};

use common::gltf_writer::{hierarchy, temp_dir};
use serde_json::json;

#[test]
fn render_a_glb_directly() {
    let dir = temp_dir("cli_render");
    let glb = hierarchy(true, true, None).write_glb(&dir, "level");
    let png = dir.join("out.png");
    let exr = dir.join("depth.exr");
    let aov = format!("depth={}", exr.display());
    let out = hadou(&["render", s(&glb), "-o", s(&png), "--size", "96x64", "--aov", &aov]);
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(image::open(&png).unwrap().to_rgba8().dimensions(), (96, 64));
    let (_, _, depth) = hadou::output::read_exr_channel(&exr).unwrap();
    assert!(depth.iter().any(|d| d.is_finite()), "the framing camera sees the cubes");
}

#[test]
fn a_malformed_glb_is_an_error_with_the_pointer_and_writes_nothing() {
    let dir = temp_dir("cli_bad");
    let mut w = hierarchy(true, false, None);
    w.nodes[2]["children"] = json!([0]);
    let glb = w.write_glb(&dir, "cyclic");
    let png = dir.join("out.png");
    let out = hadou(&["render", s(&glb), "-o", s(&png)]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(&format!("error: {}: /nodes/", glb.display())) && err.contains("cycle"), "{err}");
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left, vec![std::ffi::OsString::from("cyclic.glb")], "nothing written beside it");
}

#[test]
fn an_output_may_not_replace_the_gltf_buffer() {
    let dir = temp_dir("cli_bin");
    let gltf = hierarchy(true, false, None).write_external(&dir, "level");
    let bin = dir.join("level.bin");
    let before = std::fs::read(&bin).unwrap();
    let out = hadou(&["render", s(&gltf), "-o", s(&bin)]);
    assert!(!out.status.success());
    assert!(text(&out).contains("level.bin"), "{}", text(&out));
    assert_eq!(std::fs::read(&bin).unwrap(), before);
}
