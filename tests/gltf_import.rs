//! glTF 2.0 import on the CPU: files written by tests/common/gltf_writer.rs and one written by an
//! independent writer (pygltflib, assets/gltf/make_volume_demo.py) become the scene parts the TOML
//! path builds — transforms composed as seed 002 says, meshes shared, normals right, materials,
//! lights and camera mapped as docs/scene-format.md's table says — and every malformed file is an
//! error naming the file and the JSON pointer.

mod common;

use std::path::Path;

use common::gltf_writer::{temp_dir, IndexWidth, Writer};
use glam::{DMat4, DQuat, DVec3};
use hadou::scene::gltf::{import, ImportOptions};
use hadou::scene::mesh::MeshSpec;
use hadou::scene::procedural;
use hadou::scene::{load_scene, MaterialKind, Scene};
use serde_json::json;

/// tests/common/gltf_writer.rs's hierarchy with its quaternion-turned node.
fn hierarchy(normals: bool) -> Writer {
    common::gltf_writer::hierarchy(normals, true, None)
}

fn load(path: &Path) -> Scene {
    load_scene(path).unwrap_or_else(|e| panic!("{e}"))
}

fn err(path: &Path) -> String {
    match load_scene(path) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn hierarchy_composes_as_seed_002_and_shares_the_mesh() {
    let dir = temp_dir("hierarchy");
    let s = load(&hierarchy(true).write_glb(&dir, "h"));
    assert_eq!(s.meshes.len(), 1, "one glTF mesh, one hadou mesh");
    assert_eq!(s.instances.len(), 3);
    assert!(s.instances.iter().all(|i| i.mesh == 0));
    assert_eq!(s.meshes[0].mesh, procedural::cube(1.0).unwrap(), "positions, normals, indices as written");
    // Independently: M = M_parent · M_child with glam's TRS.
    let parent = DMat4::from_scale_rotation_translation(
        DVec3::new(2.0, 0.5, 1.0),
        DQuat::IDENTITY,
        DVec3::new(0.0, 1.0, -2.0),
    );
    let child =
        DMat4::from_translation(DVec3::new(3.0, 0.0, 0.0)) * DMat4::from_rotation_z(90f64.to_radians());
    let mirrored =
        DMat4::from_translation(DVec3::new(-3.0, 0.0, 0.0)) * DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
    let q = DQuat::from_xyzw(0.0, 0.5, 0.0, 0.8660254f32 as f64).normalize();
    let turned = DMat4::from_rotation_translation(q, DVec3::new(0.0, 0.0, 2.0));
    for (inst, want) in s.instances.iter().zip([parent * child, parent * mirrored, turned]) {
        let got = inst.transform.matrix;
        assert!(got.abs_diff_eq(want, 1e-12), "{:?}: {got} vs {want}", inst.name);
        assert!((inst.transform.inverse * got).abs_diff_eq(DMat4::IDENTITY, 1e-12));
    }
    assert!(
        s.instances[1].transform.matrix.determinant() < 0.0,
        "the mirrored node keeps its negative determinant"
    );
}

/// Same steps written in TOML give bit-identical transforms: the importer's steps are the TOML's
/// (node steps, then the parent's), composed by the same `Transform::from_ops`.
#[test]
fn hierarchy_matches_the_toml_scene_bit_for_bit() {
    let dir = temp_dir("hierarchy_toml");
    let g = load(&common::gltf_writer::hierarchy(true, false, None).write_glb(&dir, "h"));
    let text = format!(
        "[camera]\nposition = [0, 0, 9]\nlook_at = [0, 0, 0]\n{}",
        common::gltf_writer::hierarchy_twin_instances("default")
    );
    let t = common::parse(&text);
    assert_eq!(g.instances.len(), t.instances.len());
    for (a, b) in g.instances.iter().zip(&t.instances) {
        assert_eq!(a.ops, b.ops);
        assert_eq!(
            a.transform.matrix.to_cols_array().map(f64::to_bits),
            b.transform.matrix.to_cols_array().map(f64::to_bits)
        );
        assert_eq!(
            a.transform.inverse.to_cols_array().map(f64::to_bits),
            b.transform.inverse.to_cols_array().map(f64::to_bits)
        );
    }
    assert_eq!(g.meshes[0].mesh, t.meshes[0].mesh);
}

/// Without NORMAL, each triangle gets its face normal: on the cube every generated normal points
/// away from the centre, and through the mirrored instance's M⁻ᵀ it still points out of the
/// world-space cube (the winding flips with the determinant; the normal matrix follows).
#[test]
fn generated_normals_are_flat_and_outward_under_mirroring() {
    let dir = temp_dir("normals");
    let s = load(&hierarchy(false).write_embedded(&dir, "h"));
    let mesh = &s.meshes[0].mesh;
    assert_eq!(mesh.positions.len(), 36, "three own vertices per triangle");
    for t in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(t);
        let centroid = (mesh.position(a) + mesh.position(b) + mesh.position(c)) / 3.0;
        let n = DVec3::from_array(mesh.normals[a].map(f64::from));
        assert!(n.dot(centroid) > 0.0, "triangle {t}");
        assert!(
            (mesh.position(b) - mesh.position(a)).cross(mesh.position(c) - mesh.position(a)).dot(n) > 0.0
        );
        for inst in &s.instances {
            let world_n = inst.transform.transform_normal(n);
            let centre = inst.transform.transform_point(DVec3::ZERO);
            assert!(
                world_n.dot(inst.transform.transform_point(centroid) - centre) > 0.0,
                "{:?} triangle {t}",
                inst.name
            );
        }
    }
    assert!(mesh.check_closed_oriented().is_ok() && mesh.signed_volume() > 0.0);
}

#[test]
fn index_widths_modes_and_several_primitives() {
    let dir = temp_dir("indices");
    let tet = procedural::tetrahedron(1.0).unwrap();
    let mut meshes = Vec::new();
    for width in [IndexWidth::U8, IndexWidth::U16, IndexWidth::U32] {
        let mut w = Writer::default();
        let red = w.material(json!({ "pbrMetallicRoughness": { "baseColorFactor": [1.0, 0.0, 0.0, 1.0] } }));
        let blue = w.material(json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.0, 0.0, 1.0, 0.5] } }));
        let a = w.primitive(&tet, width, true, Some(red));
        let b = w.primitive(&procedural::cube(0.5).unwrap(), width, true, Some(blue));
        let m = w.mesh(vec![a, b]);
        w.node(json!({ "mesh": m }));
        w.scene_roots = vec![0];
        let s = load(&w.write_external(&dir, &format!("{width:?}")));
        assert_eq!((s.meshes.len(), s.materials.len(), s.instances.len()), (2, 2, 2));
        assert_eq!(s.materials[0].albedo, DVec3::X);
        assert_eq!(s.materials[1].albedo, DVec3::Z, "alpha is not colour");
        assert!(matches!(&s.meshes[1].spec, MeshSpec::Gltf { mesh: 0, primitive: 1, .. }));
        assert_eq!(s.meshes[1].spec.build().unwrap(), s.meshes[1].mesh, "the spec rebuilds the same mesh");
        meshes.push(s.meshes[0].mesh.clone());
    }
    assert_eq!(meshes[0], tet);
    assert!(meshes.iter().all(|m| *m == tet));
}

#[test]
fn triangle_strips_and_fans_become_lists() {
    let dir = temp_dir("strips");
    let quad = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    let mut w = Writer::default();
    let pos = w.vec3(&quad, true);
    let strip_idx = w.indices(&[0, 1, 3, 2], IndexWidth::U8);
    let fan_idx = w.indices(&[0, 1, 2, 3], IndexWidth::U8);
    let strip = json!({ "attributes": { "POSITION": pos }, "indices": strip_idx, "mode": 5 });
    let fan = json!({ "attributes": { "POSITION": pos }, "indices": fan_idx, "mode": 6 });
    let m = w.mesh(vec![strip, fan]);
    w.node(json!({ "mesh": m }));
    w.scene_roots = vec![0];
    let s = load(&w.write_glb(&dir, "s"));
    for sm in &s.meshes {
        assert_eq!(sm.mesh.triangle_count(), 2);
        assert!(
            sm.mesh.normals.iter().all(|n| *n == [0.0, 0.0, 1.0]),
            "both triangles counter-clockwise from +z"
        );
    }
}

/// Sparse accessors: base values (or zeros without a bufferView) with substitutions.
#[test]
fn sparse_positions_are_substituted() {
    let dir = temp_dir("sparse");
    let tet = procedural::tetrahedron(1.0).unwrap();
    for with_base in [true, false] {
        let mut w = Writer::default();
        let mut base = tet.positions.clone();
        base[1] = [9.0, 9.0, 9.0];
        base[3] = [9.0, 9.0, 9.0];
        let pos = w.vec3(&base, true);
        if !with_base {
            w.accessors[pos].as_object_mut().unwrap().remove("bufferView");
        }
        let (sub, values): (Vec<u32>, Vec<[f32; 3]>) = if with_base {
            (vec![1, 3], vec![tet.positions[1], tet.positions[3]])
        } else {
            ((0..tet.positions.len() as u32).collect(), tet.positions.clone())
        };
        let idx_view =
            w.view(&sub.iter().flat_map(|i| (*i as u16).to_le_bytes()).collect::<Vec<u8>>(), 34963);
        let val_view =
            w.view(&values.iter().flatten().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>(), 34962);
        w.accessors[pos]["sparse"] = json!({
            "count": sub.len(),
            "indices": { "bufferView": idx_view, "componentType": 5123 },
            "values": { "bufferView": val_view }
        });
        let nrm = w.vec3(&tet.normals, false);
        let ind = w.indices(&tet.indices, IndexWidth::U8);
        let m = w.mesh(vec![json!({ "attributes": { "POSITION": pos, "NORMAL": nrm }, "indices": ind })]);
        w.node(json!({ "mesh": m }));
        w.scene_roots = vec![0];
        let s = load(&w.write_glb(&dir, &format!("s{with_base}")));
        assert_eq!(s.meshes[0].mesh, tet, "with a base view: {with_base}");
        // Indices must increase strictly.
        let bad_view = w.view(&[3u8, 0, 1, 0], 34963);
        w.accessors[pos]["sparse"]["indices"]["bufferView"] = json!(bad_view);
        w.accessors[pos]["sparse"]["count"] = json!(2);
        let e = err(&w.write_glb(&dir, &format!("bad{with_base}")));
        assert!(e.contains("/attributes/POSITION: accessor /accessors/0: sparse index 1 is 1 (expected strictly increasing"), "{e}");
    }
}

/// .gltf + .bin, .gltf with a data: URI and .glb give the same scene.
#[test]
fn three_containers_give_the_same_scene() {
    let dir = temp_dir("containers");
    let w = hierarchy(true);
    let scenes =
        [w.write_external(&dir, "a"), w.write_embedded(&dir, "b"), w.write_glb(&dir, "c")].map(|p| load(&p));
    for s in &scenes[1..] {
        assert_eq!(s.meshes[0].mesh, scenes[0].meshes[0].mesh);
        assert_eq!(s.instances, scenes[0].instances);
        assert_eq!(s.materials, scenes[0].materials);
        assert_eq!(s.camera, scenes[0].camera);
        assert_eq!(s.lights, scenes[0].lights);
    }
}

/// The pygltflib file (independent writer): what hadou reads matches the numbers its script wrote.
#[test]
fn independent_writer_volume_demo() {
    let glb = load(&common::asset("assets/gltf/volume_demo.glb"));
    let gltf = load(&common::asset("assets/gltf/volume_demo.gltf"));
    assert_eq!(glb.instances, gltf.instances);
    let kinds =
        |s: &Scene| s.materials.iter().map(|m| (m.name.clone(), m.kind, m.albedo)).collect::<Vec<_>>();
    assert_eq!(kinds(&glb), kinds(&gltf));
    assert_eq!(
        glb.meshes.iter().map(|m| &m.mesh).collect::<Vec<_>>(),
        gltf.meshes.iter().map(|m| &m.mesh).collect::<Vec<_>>()
    );
    let s = glb;
    assert_eq!((s.meshes.len(), s.instances.len()), (3, 4), "cube, pillar (shared by two nodes), ground");
    let names: Vec<&str> = s.instances.iter().map(|i| i.name.as_deref().unwrap()).collect();
    assert_eq!(
        names,
        [
            "node 0 \"glass cube\"",
            "node 2 \"left pillar\"",
            "node 3 \"right pillar (mirrored)\"",
            "node 4 \"ground\""
        ]
    );
    assert_eq!(s.instances[1].mesh, s.instances[2].mesh);
    assert!(s.instances[2].transform.matrix.determinant() < 0.0);
    let right = s.instances[2].transform.transform_point(DVec3::ZERO);
    assert!(
        right.abs_diff_eq(DVec3::new(2.5, 0.25, -1.5), 1e-12),
        "{right}: parent scale × child translation"
    );
    let glass = &s.materials[s.instances[0].material];
    let MaterialKind::Translucent { sigma, voxel_res, .. } = glass.kind else { panic!("{glass:?}") };
    let c = [0.55f32, 0.85, 0.6].map(f64::from);
    let d = 0.6f32 as f64;
    assert_eq!(sigma, DVec3::new(-c[0].ln() / d, -c[1].ln() / d, -c[2].ln() / d), "σ = −ln(c)/d");
    assert_eq!(voxel_res, hadou::scene::DEFAULT_VOXEL_RES);
    assert_eq!(glass.albedo, DVec3::new(0.75f32 as f64, 0.95f32 as f64, 0.8f32 as f64));
    assert_eq!(s.lights.len(), 2);
    let want = DVec3::new(0.25, -0.45, 1.0).normalize();
    assert!(s.lights[0].direction.abs_diff_eq(want, 1e-6), "{}", s.lights[0].direction);
    // 1.6 lux: a white surface facing the light has luminance 1.6/π cd/m² (issue 26).
    assert_eq!(s.lights[0].intensity, 1.6f32 as f64 / std::f64::consts::PI);
    assert!(s.lights[1].direction.abs_diff_eq(DVec3::new(0.5, -1.0, -0.8).normalize(), 1e-6));
    assert!(s.camera.position.abs_diff_eq(DVec3::new(0.0, 1.6, 6.5), 1e-6));
    let forward = (s.camera.look_at - s.camera.position).normalize();
    assert!(forward.abs_diff_eq((DVec3::new(0.0, 0.1, 0.0) - s.camera.position).normalize(), 1e-6));
    assert!((s.camera.fov_y_deg - 0.7f32.to_degrees() as f64).abs() < 1e-4);
    assert_eq!((s.camera.near, s.camera.far), (0.1f32 as f64, 30.0));
    assert_eq!((s.render.width, s.render.height), (768, 512), "aspectRatio 1.5");
}

#[test]
fn volume_on_an_open_mesh_is_opaque_and_dimmed_by_thickness_factor() {
    let dir = temp_dir("open_volume");
    let mut w = Writer::default();
    let glass = w.material(json!({
        "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 1.0, 1.0] },
        "extensions": {
            "KHR_materials_transmission": { "transmissionFactor": 1.0 },
            "KHR_materials_volume": { "thicknessFactor": 0.5, "attenuationColor": [0.5, 0.5, 0.25], "attenuationDistance": 1.0 }
        }
    }));
    w.uses("KHR_materials_transmission");
    w.uses("KHR_materials_volume");
    let plane = w.primitive(&procedural::plane(1.0).unwrap(), IndexWidth::U8, true, Some(glass));
    let cube = w.primitive(&procedural::cube(1.0).unwrap(), IndexWidth::U8, true, Some(glass));
    let m = w.mesh(vec![plane, cube]);
    w.node(json!({ "mesh": m }));
    w.scene_roots = vec![0];
    let path = w.write_glb(&dir, "v");
    let imp = import(&path, &ImportOptions::default()).unwrap();
    assert_eq!(
        imp.materials.len(),
        2,
        "the same glTF material, once opaque (open plane), once translucent (cube)"
    );
    assert_eq!(imp.materials[0].kind, MaterialKind::Lambert);
    let dim = |c: f64| c.powf(0.5); // e^(−σ·t) with σ = −ln(c)/1, t = 0.5
    assert!(imp.materials[0].albedo.abs_diff_eq(DVec3::new(dim(0.5), dim(0.5), dim(0.25)), 1e-12));
    assert!(matches!(imp.materials[1].kind, MaterialKind::Translucent { .. }));
    assert!(imp.ignored.summary().contains(
        "KHR_materials_volume on open meshes (opaque, dimmed by thicknessFactor) (/meshes/0/primitives/0)"
    ));
}

/// Parts hadou does not draw are listed once, by kind with their pointers; the rest still draws.
#[test]
fn ignored_parts_are_listed_not_dropped() {
    let dir = temp_dir("ignored");
    let mut w = hierarchy(true);
    // A normal texture is not drawn (base-colour and emissive ones are: tests/gltf_textures.rs),
    // so its image (missing) is never read.
    let tex = w.material(
        json!({ "normalTexture": { "index": 0 }, "emissiveFactor": [1.0, 0.0, 0.0], "alphaMode": "BLEND" }),
    );
    let lines_pos = w.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], true);
    let tri = w.primitive(&procedural::tetrahedron(1.0).unwrap(), IndexWidth::U8, true, Some(tex));
    let lines = json!({ "attributes": { "POSITION": lines_pos }, "mode": 1 });
    let m = w.mesh(vec![lines, tri]);
    let n =
        w.node(json!({ "mesh": m, "camera": 0, "extensions": { "KHR_lights_punctual": { "light": 0 } } }));
    let hidden = w.node(json!({ "mesh": 0, "scale": [0.0, 1.0, 1.0] }));
    w.scene_roots.extend([n, hidden]);
    w.cameras.push(json!({ "type": "orthographic", "orthographic": { "xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0 } }));
    w.lights.push(json!({ "type": "point", "intensity": 3.0 }));
    w.uses("KHR_lights_punctual");
    w.uses("KHR_materials_sheen");
    w.extra.insert("images".into(), json!([{ "uri": "nowhere.png" }]));
    w.extra.insert("textures".into(), json!([{ "source": 0 }]));
    w.extra.insert("animations".into(), json!([{ "channels": [], "samplers": [] }]));
    let imp = import(&w.write_glb(&dir, "i"), &ImportOptions::default()).unwrap();
    let summary = imp.ignored.summary();
    for part in [
        "textures hadou does not draw (normal, occlusion, metallic-roughness, transmission, thickness) (/materials/0/normalTexture)",
        "alpha blending (alphaMode BLEND, drawn opaque) (/materials/0/alphaMode)",
        "primitives hadou cannot draw (/meshes/1/primitives/0: mode LINES)",
        "orthographic cameras and cameras on degenerate nodes (/nodes/4/camera)",
        "animations (/animations/0)",
        "extensions (/extensionsUsed/1 (KHR_materials_sheen))",
        "nodes with a singular transform (such as scale 0) (/nodes/5",
    ] {
        assert!(summary.contains(part), "missing {part:?} in {summary}");
    }
    // Emission is drawn (tests/gltf_materials.rs): not listed; nor are point lights (drawn,
    // tests/point_spot_lights.rs): the point light is the import's one light.
    assert!(!summary.contains("emissi"), "{summary}");
    assert!(!summary.contains("point light") && !summary.contains("spot light"), "{summary}");
    assert_eq!(imp.lights.len(), 1);
    assert!(matches!(imp.lights[0].kind, hadou::scene::LightKind::Point));
    assert_eq!(imp.lights[0].intensity, 3.0, "candela kept as they are");
    assert_eq!(imp.instances.len(), 4, "three cubes and the tetrahedron");
    assert!(imp.camera.is_none());
}

#[test]
fn camera_and_default_framing() {
    let dir = temp_dir("camera");
    let mut w = hierarchy(true);
    // A camera at (0, 0, 10) looking down −z (the identity rotation), no zfar.
    let c = w.node(json!({ "camera": 0, "translation": [0.0, 0.0, 10.0] }));
    w.scene_roots.push(c);
    w.cameras.push(json!({ "type": "perspective", "perspective": { "yfov": 0.5, "znear": 0.25 } }));
    let s = load(&w.write_glb(&dir, "cam"));
    assert_eq!(s.camera.position, DVec3::new(0.0, 0.0, 10.0));
    assert_eq!(s.camera.look_at, DVec3::new(0.0, 0.0, 9.0));
    assert_eq!(s.camera.near, 0.25);
    assert!(
        s.camera.far >= hadou::scene::camera::Camera::DEFAULT_FAR,
        "infinite glTF far: at least the TOML default"
    );
    assert_eq!((s.render.width, s.render.height), (512, 512));
    // Without a camera: the bounds framed from FRAMING_DIRECTION, the default light added.
    let s = load(&hierarchy(true).write_glb(&dir, "nocam"));
    let dir_to_camera = (s.camera.position - s.camera.look_at).normalize();
    assert!(dir_to_camera.abs_diff_eq(hadou::scene::gltf::FRAMING_DIRECTION.normalize(), 1e-12));
    assert_eq!(s.lights.len(), 1);
    assert_eq!(s.lights[0].direction, hadou::scene::gltf::DEFAULT_LIGHT_DIRECTION.normalize());
}

/// A TOML scene places a glTF file beside its own effects; its camera and lights win.
#[test]
fn toml_overlay_places_the_file() {
    let s = load(&common::asset("assets/gltf/overlay.toml"));
    let alone = load(&common::asset("assets/gltf/volume_demo.glb"));
    assert_eq!(s.waves().len(), 1);
    assert_eq!(s.instances.len(), alone.instances.len());
    let lift = DMat4::from_translation(DVec3::new(0.0, 0.0, 0.0));
    for (a, b) in s.instances.iter().zip(&alone.instances) {
        assert!(a.transform.matrix.abs_diff_eq(lift * b.transform.matrix, 1e-12));
        assert!(a.name.as_deref().unwrap().starts_with("gltf \"demo\": node "));
    }
    assert_eq!(s.camera, alone.camera, "no [camera] in the TOML: the file's");
    let text = "[camera]\nposition = [0, 0, 9]\nlook_at = [0, 0, 0]\n[[light]]\ndirection = [0, -1, 0]\n\
                [[gltf]]\npath = \"../../assets/gltf/volume_demo.glb\"\ntransform = [{ translate = [1, 0, 0] }]\nvoxel_res = 20\n";
    let s = hadou::scene::parse_scene(text, &common::asset("tests/data/inline.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.camera.position, DVec3::new(0.0, 0.0, 9.0));
    assert_eq!(s.lights.len(), 1);
    assert_eq!(s.lights[0].direction, DVec3::NEG_Y);
    let moved = s.instances[0].transform.matrix * alone.instances[0].transform.inverse;
    assert!(moved.abs_diff_eq(DMat4::from_translation(DVec3::X), 1e-12));
    assert!(matches!(
        s.materials[s.instances[0].material].kind,
        MaterialKind::Translucent { voxel_res: 20, .. }
    ));
    // A broken file is an error at the TOML's `path` value, with the file and the pointer.
    let text = "[[gltf]]\npath = \"missing.glb\"\n";
    let e =
        hadou::scene::parse_scene(text, &common::asset("tests/data/inline.toml")).unwrap_err().to_string();
    assert!(
        e.contains("inline.toml:2:8: gltf 1 `path`: ") && e.contains("missing.glb: cannot read glTF file"),
        "{e}"
    );
}

// ---------------------------------------------------------------------------------------------
// Malformed files: each a clear error with the file and the JSON pointer.

/// (what, how the good hierarchy file is broken, the pointer, a part of the message).
fn malformed() -> Vec<(&'static str, Writer, &'static str, &'static str)> {
    let mut out = Vec::new();
    let mut w = hierarchy(true);
    w.accessors[0]["count"] = json!(1000);
    out.push((
        "bad accessor",
        w,
        "/meshes/0/primitives/0/attributes/POSITION",
        "accessor /accessors/0: accessor reads bytes 0..12000",
    ));
    let mut w = hierarchy(true);
    w.accessors[2]["componentType"] = json!(5126);
    out.push(("float indices", w, "/meshes/0/primitives/0/indices", "expected indices of UNSIGNED_BYTE"));
    let mut w = hierarchy(true);
    let idx_view = w.accessors[2]["bufferView"].as_u64().unwrap() as usize;
    let at = w.views[idx_view]["byteOffset"].as_u64().unwrap() as usize;
    w.bin[at..at + 2].copy_from_slice(&77u16.to_le_bytes());
    out.push((
        "index out of range",
        w,
        "/meshes/0/primitives/0/indices",
        "index 0 is 77, out of range for 24 vertices",
    ));
    let mut w = hierarchy(true);
    w.bin[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
    out.push(("NaN position", w, "/meshes/0/primitives/0/attributes/POSITION", "position 0 is [0.5, NaN"));
    let mut w = hierarchy(true);
    w.nodes[1]["children"] = json!([0]);
    out.push(("cyclic nodes", w, "/nodes/1/children", "the node graph has a cycle: 1 → 0 → 1"));
    let mut w = hierarchy(true);
    w.nodes[3]["children"] = json!([1]);
    out.push(("two parents", w, "/nodes/3/children/0", "already a child of /nodes/0"));
    let mut w = hierarchy(true);
    w.nodes[1]["mesh"] = json!(7);
    out.push(("crate validation", w, "/nodes/1/mesh", "index out of range"));
    let mut w = hierarchy(true);
    w.meshes[0]["primitives"][0]["attributes"]["POSITION"] = json!(99);
    out.push((
        "POSITION index",
        w,
        "/meshes/0/primitives/0/attributes/POSITION",
        "accessor 99 does not exist",
    ));
    let mut w = hierarchy(true);
    w.views[0]["byteOffset"] = json!(u64::MAX - 4);
    out.push((
        "overflowing view",
        w,
        "/meshes/0/primitives/0/attributes/POSITION",
        "past the end of buffer /buffers/0",
    ));
    let mut w = hierarchy(true);
    w.views[0]["byteLength"] = json!(100000);
    out.push((
        "view past the buffer",
        w,
        "/meshes/0/primitives/0/attributes/POSITION",
        "past the end of buffer /buffers/0",
    ));
    let mut w = hierarchy(true);
    w.accessors[0]["count"] = json!(u64::MAX / 2);
    w.views[0]["byteStride"] = json!(252);
    out.push((
        "overflowing count",
        w,
        "/meshes/0/primitives/0/attributes/POSITION",
        "accessor reads bytes 0..",
    ));
    let mut w = hierarchy(true);
    w.accessors[0].as_object_mut().unwrap().remove("bufferView");
    w.accessors[0]["count"] = json!(1u64 << 40);
    w.accessors[0]["sparse"] = json!({ "count": 1, "indices": { "bufferView": 0, "componentType": 5121 }, "values": { "bufferView": 0 } });
    out.push((
        "huge sparse count",
        w,
        "/meshes/0/primitives/0/attributes/POSITION",
        "elements without a bufferView",
    ));
    let mut w = hierarchy(true);
    w.nodes[0]["scale"] = json!([1e39, 1.0, 1.0]);
    out.push(("infinite scale", w, "/nodes/0/scale", "is not finite"));
    out
}

#[test]
fn malformed_files_name_the_file_and_the_pointer() {
    let dir = temp_dir("malformed");
    for (what, w, pointer, says) in malformed() {
        for path in [w.write_glb(&dir, what), w.write_embedded(&dir, what)] {
            let e = err(&path);
            assert!(e.starts_with(&format!("{}: {pointer}", path.display())), "{what}: {e}");
            assert!(e.contains(says), "{what}: {e}");
        }
    }
    // Missing buffers: the .bin gone, and a .glb without its BIN chunk.
    let w = hierarchy(true);
    let path = w.write_external(&dir, "nobin");
    std::fs::remove_file(dir.join("nobin.bin")).unwrap();
    let e = err(&path);
    assert!(e.contains("/buffers/0/uri: missing buffer: cannot read") && e.contains("nobin.bin"), "{e}");
    let mut glb = w.glb();
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    glb.truncate(20 + json_len);
    let total = glb.len() as u32;
    glb[8..12].copy_from_slice(&total.to_le_bytes());
    std::fs::write(dir.join("nochunk.glb"), &glb).unwrap();
    assert!(err(&dir.join("nochunk.glb")).contains("/buffers/0: missing buffer"));
    // Not glTF at all, cut short, nothing to draw.
    std::fs::write(dir.join("junk.gltf"), "{ \"asset\": ").unwrap();
    assert!(err(&dir.join("junk.gltf")).contains("invalid glTF JSON at line 1"));
    std::fs::write(dir.join("short.glb"), &w.glb()[..10]).unwrap();
    assert!(err(&dir.join("short.glb")).contains("binary glTF header cut short"));
    let mut lines = Writer::default();
    let p = lines.vec3(&[[0.0; 3], [1.0, 0.0, 0.0]], true);
    let m = lines.mesh(vec![json!({ "attributes": { "POSITION": p }, "mode": 1 })]);
    lines.node(json!({ "mesh": m }));
    lines.scene_roots = vec![0];
    let e = err(&lines.write_glb(&dir, "lines"));
    assert!(
        e.contains("nothing to draw: primitives hadou cannot draw (/meshes/0/primitives/0: mode LINES)"),
        "{e}"
    );
}

/// Mangled copies never panic the importer (byte flips and truncations of a valid .glb);
/// `HADOU_FUZZ_CASES` sets the count (300 in `make test`).
#[test]
fn mangled_glb_never_panics() {
    let dir = temp_dir("mangled");
    let glb = hierarchy(true).glb();
    let mut state = 0x9e3779b97f4a7c15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let path = dir.join("m.glb");
    let cases: usize = std::env::var("HADOU_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(300);
    for case in 0..cases {
        let mut bytes = glb.clone();
        if case % 3 == 0 {
            bytes.truncate((next() as usize) % bytes.len());
        } else {
            for _ in 0..1 + next() % 4 {
                let i = (next() as usize) % bytes.len();
                bytes[i] = next() as u8;
            }
        }
        std::fs::write(&path, &bytes).unwrap();
        let _ = load_scene(&path);
    }
}
