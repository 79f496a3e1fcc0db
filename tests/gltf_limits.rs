//! glTF scenes get the TOML scenes' numeric limits (issue 24): object-space positions within
//! ±1e6 and a mesh at least 1e-6 across (the `[[mesh]]` lengths), every drawn instance within
//! ±2⁴⁴ and at least 1e-6 across in the world (so its view depths stay within 2⁴⁸, the TOML
//! camera's extent), world matrices within f32; each refused with the JSON pointer of the value
//! at fault. A camera-less file is framed wherever its content is; light errors name
//! `KHR_lights_punctual` as the file spells it; a long thin box with a volume material is drawn.

mod common;

use std::path::{Path, PathBuf};

use common::cli::{hadou, s, scratch, text};
use common::gltf_writer::{IndexWidth, Writer};
use hadou::scene::mesh::Mesh;
use serde_json::{json, Value};

/// A unit cube (procedural, closed, outward) with every position scaled by `scale`.
fn cube(scale: [f32; 3]) -> Mesh {
    let mut m = hadou::scene::procedural::cube(1.0).unwrap();
    for p in &mut m.positions {
        for k in 0..3 {
            p[k] *= scale[k];
        }
    }
    m
}

/// One node (`node`, given the mesh) drawing `mesh` with `material` (a glTF material JSON).
fn one_node(mesh: &Mesh, node: Value, material: Option<Value>) -> Writer {
    let mut w = Writer::default();
    let mat = material.map(|m| {
        w.uses("KHR_materials_transmission");
        w.uses("KHR_materials_volume");
        w.material(m)
    });
    let p = w.primitive(mesh, IndexWidth::U16, true, mat);
    let m = w.mesh(vec![p]);
    let mut node = node;
    node["mesh"] = json!(m);
    w.node(node);
    w.scene_roots = vec![0];
    w
}

/// The scene error of loading `path` (a panic when it loads).
fn load_error(path: &Path) -> String {
    match hadou::scene::load_scene(path) {
        Ok(_) => panic!("{} loaded; expected an error", path.display()),
        Err(e) => e.to_string(),
    }
}

/// `hadou render` must refuse `glb`: exit 1, `error: FILE: POINTER: …` containing `words`, and
/// no image written.
fn render_refused(glb: &Path, pointer: &str, words: &[&str]) {
    let png = glb.with_extension("png");
    let out = hadou(&["render", s(glb), "-o", s(&png), "--size", "16x16"]);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(1), "{all}");
    let head = format!("error: {}: {pointer}: ", glb.display());
    assert!(all.contains(&head), "expected `{head}` in:\n{all}");
    for w in words {
        assert!(all.contains(w), "expected `{w}` in:\n{all}");
    }
    assert!(!png.exists(), "nothing is written");
}

#[test]
fn positions_beyond_1e6_are_refused_at_the_accessor() {
    let dir = scratch("gltf_limits_huge_positions");
    let glb = one_node(&cube([2e16, 1.0, 1.0]), json!({}), None).write_glb(&dir, "huge");
    render_refused(&glb, "/accessors/0/max", &["1e16", "1e6"]);
    let mut mesh = cube([1.0; 3]);
    for p in &mut mesh.positions {
        p[0] -= 2e7;
    }
    let glb = one_node(&mesh, json!({}), None).write_glb(&dir, "far_negative");
    render_refused(&glb, "/accessors/0/min", &["-20000000", "1e6"]);
}

#[test]
fn a_mesh_smaller_than_1e_6_is_refused_at_the_accessor() {
    let dir = scratch("gltf_limits_tiny_mesh");
    let glb = one_node(&cube([2e-8; 3]), json!({}), None).write_glb(&dir, "tiny");
    render_refused(&glb, "/accessors/0", &["1e-6", "2e-8"]);
}

#[test]
fn a_node_placed_past_the_extent_is_refused_at_its_translation() {
    let dir = scratch("gltf_limits_far_node");
    let glb =
        one_node(&cube([1.0; 3]), json!({ "translation": [1e16, 0.0, 0.0] }), None).write_glb(&dir, "far");
    render_refused(&glb, "/nodes/0/translation", &["1.7592e13"]);
    // Two levels, each within the extent alone, too far together: the parent's translation is
    // the step that takes the instance out.
    let mut w = one_node(&cube([1.0; 3]), json!({ "translation": [1e13, 0.0, 0.0] }), None);
    w.node(json!({ "translation": [1e13, 0.0, 0.0], "children": [0] }));
    w.scene_roots = vec![1];
    let glb = w.write_glb(&dir, "far_sum");
    render_refused(&glb, "/nodes/1/translation", &["node 0"]);
}

#[test]
fn a_node_scaled_below_1e_6_is_refused_at_its_scale() {
    let dir = scratch("gltf_limits_tiny_node");
    let glb = one_node(&cube([1.0; 3]), json!({ "scale": [1e-8, 1e-8, 1e-8] }), None).write_glb(&dir, "tiny");
    render_refused(&glb, "/nodes/0/scale", &["1e-6"]);
    // A scale that blows the instance past the extent is named the same way (as a matrix here).
    let m = [1e12, 0.0, 0.0, 0.0, 0.0, 1e12, 0.0, 0.0, 0.0, 0.0, 1e12, 0.0, 0.0, 0.0, 0.0, 1.0];
    let glb = one_node(&cube([1e6; 3]), json!({ "matrix": m }), None).write_glb(&dir, "huge");
    render_refused(&glb, "/nodes/0/matrix", &["1.7592e13"]);
}

#[test]
fn a_placed_gltf_keeps_the_limits_in_a_toml_scene() {
    let dir = scratch("gltf_limits_placed");
    one_node(&cube([1.0; 3]), json!({}), None).write_glb(&dir, "unit");
    let toml = dir.join("scene.toml");
    std::fs::write(&toml, "[[gltf]]\npath = \"unit.glb\"\ntransform = [{ translate = [1e16, 0, 0] }]\n")
        .unwrap();
    let e = load_error(&toml);
    // At the TOML's `transform`, the step that took the instance out.
    assert!(e.contains("scene.toml:3:1: gltf 1 `transform`: ") && e.contains("reaches 1e16"), "{e}");
}

/// Covered pixels (finite depth) of `glb` rendered by the CLI at 64×64 with its framing camera.
fn covered(glb: &Path) -> usize {
    let exr = glb.with_extension("exr");
    let png = glb.with_extension("png");
    let aov = format!("depth={}", exr.display());
    let out = hadou(&["render", s(glb), "-o", s(&png), "--size", "64x64", "--aov", &aov]);
    assert!(out.status.success(), "{}", text(&out));
    let (_, _, depth) = hadou::output::read_exr_channel(&exr).unwrap();
    depth.iter().filter(|d| d.is_finite()).count()
}

#[test]
fn framing_frames_the_content_wherever_it_is() {
    let dir = scratch("gltf_limits_framing");
    let at = |x: f64| -> PathBuf {
        one_node(&cube([1.0; 3]), json!({ "translation": [x, 0.0, 0.0] }), None)
            .write_glb(&dir, &format!("at_{x:e}"))
    };
    let home = covered(&at(0.0));
    assert!(home > 64 * 64 / 8, "the cube fills a good part of the frame at the origin: {home}");
    for x in [1e5, 1e6] {
        let far = covered(&at(x));
        let ratio = far as f64 / home as f64;
        println!("x = {x:e}: {far} covered pixels, {home} at the origin");
        // f32 places a vertex at 1e6 to within 0.06 (a unit cube's edges move by up to that).
        assert!((0.8..1.25).contains(&ratio), "at x = {x:e}: {far} pixels against {home} at the origin");
    }
}

#[test]
fn light_errors_name_the_extension_as_the_file_spells_it() {
    let dir = scratch("gltf_limits_lights");
    let mut w = one_node(&cube([1.0; 3]), json!({}), None);
    w.uses("KHR_lights_punctual");
    w.lights.push(json!({ "type": "spot" }));
    w.node(json!({ "extensions": { "KHR_lights_punctual": { "light": 0 } } }));
    w.scene_roots.push(1);
    let e = load_error(&w.write_glb(&dir, "spot"));
    assert!(e.contains(": /extensions/KHR_lights_punctual/lights/0/spot: required value missing"), "{e}");
    w.lights[0] = json!({ "type": "directional" });
    w.nodes[1]["extensions"]["KHR_lights_punctual"]["light"] = json!(3);
    let e = load_error(&w.write_glb(&dir, "index"));
    assert!(e.contains(": /nodes/1/extensions/KHR_lights_punctual/light: index out of range"), "{e}");
    w.nodes[1]["extensions"]["KHR_lights_punctual"]["light"] = json!(0);
    w.lights[0] = json!({ "type": "directional", "intensity": -1.0 });
    let e = load_error(&w.write_glb(&dir, "intensity"));
    assert!(e.contains(": /extensions/KHR_lights_punctual/lights/0/intensity: -1"), "{e}");
}

fn volume_material() -> Value {
    json!({
        "pbrMetallicRoughness": { "metallicFactor": 0.0 },
        "extensions": {
            "KHR_materials_transmission": { "transmissionFactor": 1.0 },
            "KHR_materials_volume": {
                "thicknessFactor": 0.01, "attenuationDistance": 1.0, "attenuationColor": [0.5, 0.5, 0.5]
            }
        }
    })
}

#[test]
fn a_long_thin_box_with_a_volume_material_is_drawn() {
    let dir = scratch("gltf_limits_thin");
    // 20000 × 0.02 × 0.02: a closed box of volume 8, thinner than a voxel of its thickness table
    // (20000 / 48 ≈ 417) by 4 orders; and an ordinary beam of 100 × 0.5 × 0.5 (voxel 2.1).
    for (name, size) in [("needle", [20000.0, 0.02, 0.02]), ("beam", [100.0, 0.5, 0.5])] {
        let glb = one_node(&cube(size), json!({}), Some(volume_material())).write_glb(&dir, name);
        let png = dir.join(format!("{name}.png"));
        let out = hadou(&["render", s(&glb), "-o", s(&png), "--size", "16x16"]);
        let all = text(&out);
        assert!(out.status.success(), "{name}: {all}");
        assert!(!all.contains("encloses no volume"), "{all}");
        assert!(
            all.contains("too thin for a thickness table") && all.contains("/meshes/0/primitives/0"),
            "{all}"
        );
    }
    // A cube of the same material still gets a baked table (not listed).
    let glb = one_node(&cube([1.0; 3]), json!({}), Some(volume_material())).write_glb(&dir, "cube");
    let scene = hadou::scene::load_scene(&glb).unwrap();
    let kind = &scene.materials[scene.instances[0].material].kind;
    assert!(matches!(kind, hadou::scene::model::MaterialKind::Translucent { .. }), "{kind:?}");
}

#[test]
fn a_flat_solid_is_refused_by_the_bake_without_contradicting_itself() {
    // The bake's own check (TOML scenes reach it with `thickness = "lut"`): volume 8 of a box
    // 20000 long is as flat as rounding for the voxelizer, not "no volume".
    let e = hadou::effects::voxelize::check_solid_mesh(&cube([20000.0, 0.02, 0.02])).unwrap_err().to_string();
    assert!(!e.contains("encloses no volume"), "{e}");
    assert!(e.contains("too thin") && e.contains("2e4"), "{e}");
    let mut flipped = cube([1.0; 3]);
    for t in flipped.indices.chunks_exact_mut(3) {
        t.swap(1, 2);
    }
    let e = hadou::effects::voxelize::check_solid_mesh(&flipped).unwrap_err().to_string();
    assert!(e.contains("encloses no volume") && e.contains("-1e0"), "{e}");
}
