//! glTF scenes on the GPU (lavapipe, validation and synchronization validation on, zero messages):
//! the hierarchy with a non-uniform scale and a mirrored node renders bit for bit as the same scene
//! written in TOML (translucent, so the mirrored instance's winding reaches the light pass); .glb
//! and .gltf + .bin render identically; the pygltflib file's KHR_materials_volume cube against the
//! CPU f64 twin of the translucency pass.
//!
//! # The colour bound (translucent cube)
//!
//! As tests/gpu_translucency.rs `colour_matches_the_f64_formula` argues: the pass adds
//! T = w·L·a·e^(−σd); isolated as HDR(translucent) − HDR(same scene, lambert). Per pixel and
//! channel the error is at most the thickness term w·L·a·σ·|d − d*|·e^(−σ·min(d, d*)) (mean value
//! theorem; d the GPU's thickness, d* the exact f64 one), plus 2⁻¹⁰·(|H₁| + |H₀|) (two RGBA16F
//! stores), plus 2⁻²³ (f16 subnormals), plus 1e-5·L·a (f32 arithmetic). The 95th percentile of
//! the error beyond rounding is at most L·a·σ·h_w (one world voxel of thickness error).

mod common;

use std::path::Path;

use common::gltf_writer::{hierarchy, hierarchy_twin_instances, temp_dir};
use glam::DVec3;
use hadou::effects::translucency::{exit_weight, transmitted};
use hadou::scene::{MaterialKind, Scene};
use hadou::testing::Comparison;
use hadou::{Aov, FrameRequest};
use hadou_cli::report::translucency::{self as report, abs_stats};
use serde_json::json;

/// Renders colour and the depth, HDR, normal (and thickness when translucent) AOVs.
fn render(scene: &Scene, w: u32, h: u32) -> hadou::FrameOutput {
    let mut rt = common::runtime();
    rt.load_scene(scene.clone()).unwrap();
    let mut request = FrameRequest::new(w, h);
    request.aovs = vec![Aov::Depth, Aov::Hdr, Aov::Normal];
    if rt.pass_names().contains(&"translucency") {
        request.aovs.push(Aov::Thickness);
    }
    let frame = rt.render(&request).unwrap();
    // Errors and warnings, leaks included: checked once the device is destroyed.
    rt.finish();
    frame
}

fn same(a: &hadou::FrameOutput, b: &hadou::FrameOutput) {
    assert_eq!(a.color, b.color, "colour");
    for aov in [Aov::Depth, Aov::Hdr, Aov::Normal, Aov::Thickness] {
        match (a.aov(aov), b.aov(aov)) {
            (Some(x), Some(y)) => assert!(common::same_bits(x, y), "{aov:?} differs"),
            (None, None) => {}
            _ => panic!("{aov:?} in one frame only"),
        }
    }
}

const VIEW: &str = "[camera]\nposition = [0, 3, 12]\nlook_at = [0, 1, -2]\nfov_y_deg = 60\n\
                    [[light]]\ndirection = [0.25, -0.45, 1]\nintensity = 1.5\n";

/// A translucent cube through a parent with a non-uniform scale, once as a matrix child and once
/// mirrored: imported from glTF (KHR_materials_volume) and written in TOML with the same steps, σ
/// and albedo, the two scenes render the same bits. The mirrored instance is drawn by light_id
/// with the opposite culling; a wrong winding or normal would change its thickness and colour.
#[test]
fn hierarchy_with_a_mirrored_node_renders_as_its_toml_twin() {
    let dir = temp_dir("render_hierarchy");
    let (c, d) = ([0.5f32, 0.25, 0.125], 2.0f32);
    let material = json!({
        "pbrMetallicRoughness": { "baseColorFactor": [0.75, 0.875, 0.5, 1.0] },
        "extensions": {
            "KHR_materials_transmission": { "transmissionFactor": 1.0 },
            "KHR_materials_volume": { "attenuationColor": c, "attenuationDistance": d }
        }
    });
    let path = hierarchy(true, false, Some(material)).write_glb(&dir, "h");
    let overlay = format!("{VIEW}[[gltf]]\npath = \"{}\"\nvoxel_res = 12\n", path.display());
    let g = hadou::scene::parse_scene(&overlay, Path::new("/overlay.toml")).unwrap_or_else(|e| panic!("{e}"));
    let sigma = c.map(|x| hadou::scene::gltf::sigma(x as f64, d as f64));
    let twin = format!(
        "{VIEW}[[material]]\nname = \"glass\"\nkind = \"translucent\"\nalbedo = [0.75, 0.875, 0.5]\nsigma = {sigma:?}\nvoxel_res = 12\n{}",
        hierarchy_twin_instances("glass")
    );
    let t = common::parse(&twin);
    assert!(matches!(g.materials[g.instances[1].material].kind, MaterialKind::Translucent { .. }));
    assert!(g.instances[1].transform.matrix.determinant() < 0.0);
    let (a, b) = (render(&g, 400, 300), render(&t, 400, 300));
    same(&a, &b);
    // Not an empty picture: both cubes cover pixels, with light through them.
    let thick = a.aov(Aov::Thickness).unwrap();
    let lit = thick.data.iter().filter(|t| t.is_finite()).count();
    println!("{lit} translucent pixels");
    assert!(lit > 600, "{lit} translucent pixels");
}

/// The same file as .glb and as .gltf with an external .bin (and with a data: URI), loaded as the
/// scene itself (the path `hadou render x.glb` takes): the same image, bit for bit.
#[test]
fn glb_and_gltf_with_bin_render_identically() {
    let dir = temp_dir("render_containers");
    let mut w = hierarchy(
        false,
        true,
        Some(json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.3, 0.2, 1.0] } })),
    );
    w.cameras
        .push(json!({ "type": "perspective", "perspective": { "yfov": 0.9, "znear": 0.1, "zfar": 60.0 } }));
    let cam = w.node(json!({ "camera": 0, "translation": [0.0, 2.0, 14.0] }));
    w.scene_roots.push(cam);
    let frames: Vec<hadou::FrameOutput> =
        [w.write_glb(&dir, "a"), w.write_external(&dir, "b"), w.write_embedded(&dir, "c")]
            .iter()
            .map(|p| render(&hadou::scene::load_scene(p).unwrap(), 320, 240))
            .collect();
    let depth = frames[0].aov(Aov::Depth).unwrap();
    let hits = depth.data.iter().filter(|d| d.is_finite()).count();
    println!("{hits} pixels hit");
    assert!(hits > 1000, "the cubes are in view: {hits} pixels");
    same(&frames[0], &frames[1]);
    same(&frames[0], &frames[2]);
}

/// The pygltflib file's KHR_materials_volume cube (σ = −ln(c)/d), back-lit by its
/// KHR_lights_punctual light, against the f64 twin of the translucency pass (module docs).
#[test]
fn volume_cube_matches_the_cpu_twin() {
    let (w, h) = (300, 200);
    let overlay = "[[gltf]]\npath = \"volume_demo.glb\"\nvoxel_res = 24\n";
    let scene = hadou::scene::parse_scene(overlay, &common::asset("assets/gltf/overlay.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    let frame = render(&scene, w, h);
    let mut lambert = scene.clone();
    for m in &mut lambert.materials {
        m.kind = MaterialKind::Lambert;
    }
    let surface = render(&lambert, w, h);
    let thickness = &frame.aov(Aov::Thickness).unwrap().data;
    let depth = &frame.aov(Aov::Depth).unwrap().data;
    let (hdr, hdr0) = (&frame.aov(Aov::Hdr).unwrap().data, &surface.aov(Aov::Hdr).unwrap().data);
    let normal = &frame.aov(Aov::Normal).unwrap().data;
    // > 2000 translucent pixels compared, ≤ 1/16 left out as silhouettes (sample_set's cap).
    let set = report::sample_set(&scene, (w, h), thickness, depth).unwrap();
    println!("{}", set.assert_usable(2001));
    let samples = set.samples;
    let light = &scene.lights[0];
    let radiance = light.color * light.intensity;
    let step = 2f64.powi(-10);
    let mut excess = Vec::new();
    let mut lit_through = 0;
    let inst = samples[0].instance;
    let mat = &scene.materials[scene.instances[inst].material];
    let MaterialKind::Translucent { sigma, .. } = mat.kind else { panic!("{mat:?}") };
    for s in &samples {
        assert_eq!(s.instance, inst, "one translucent instance");
        let i = s.pixel * 4;
        let n = DVec3::new(normal[i] as f64, normal[i + 1] as f64, normal[i + 2] as f64);
        let weight = exit_weight(n, light.direction.normalize());
        lit_through += usize::from(weight > 0.5);
        let cpu = weight * transmitted(radiance, mat.albedo, sigma, s.exact);
        let la = radiance * mat.albedo;
        // The pixel's error beyond rounding, over its channels (NaN-aware; 0 when within rounding).
        let mut pixel = Comparison::new(format!("pixel {}: colour error beyond rounding", s.pixel));
        for c in 0..3 {
            let (h1, h0) = (hdr[i + c] as f64, hdr0[i + c] as f64);
            let rounding = step * (h1.abs() + h0.abs()) + 2f64.powi(-23) + 1e-5 * la[c];
            let slope = weight * la[c] * sigma[c] * (-sigma[c] * s.gpu.min(s.exact)).exp();
            let bound = slope * (s.gpu - s.exact).abs() + rounding;
            let err = ((h1 - h0) - cpu[c]).abs();
            assert!(
                err <= bound,
                "pixel {} channel {c}: gpu {} cpu {} bound {bound}",
                s.pixel,
                h1 - h0,
                cpu[c]
            );
            let beyond = err - rounding;
            pixel.error(c, if beyond < 0.0 { 0.0 } else { beyond });
        }
        excess.push(pixel.worst());
    }
    assert!(lit_through * 2 > samples.len(), "back-lit: {lit_through} of {}", samples.len());
    let hw = report::world_voxel(&scene, inst).unwrap();
    let (mean, p95, max) = abs_stats(excess);
    let p95_bound = (radiance * mat.albedo * sigma).max_element() * hw;
    println!("volume cube: colour error beyond rounding mean {mean:.5}, p95 {p95:.5} (bound {p95_bound:.5}), max {max:.5}");
    assert!(p95 <= p95_bound);
}
