//! glTF spec conformance and framing (issue 26 item 3): a file whose `extensionsRequired` lists an
//! extension hadou cannot honour is refused, naming the extension and the file (glTF 2.0 §3.12),
//! while required extensions hadou honours load; a camera-less scene frames its objects of
//! interest — a ground plane that dwarfs them is left out of the framing (not of the drawing), a
//! scene of one plane is still framed — for a glTF file alone and a TOML scene placing one.

mod common;

use std::path::{Path, PathBuf};

use common::cli::{hadou, s, scratch, text};
use common::gltf_writer::{IndexWidth, Writer};
use glam::DVec3;
use hadou::scene::camera::Camera;
use hadou::scene::mesh::Mesh;
use serde_json::json;

/// A cube of edge 1 at `at` and one at `at + (2, 0, 0)` over (with `ground`) a square plane of
/// edge `ground` at y = -0.5, all drawn by nodes of one file.
fn ground_and_cubes(ground: Option<f64>, at: [f64; 3]) -> Writer {
    let mut w = Writer::default();
    let cube = hadou::scene::procedural::cube(1.0).unwrap();
    let p = w.primitive(&cube, IndexWidth::U16, true, None);
    let cube_mesh = w.mesh(vec![p]);
    w.node(json!({ "name": "cube a", "mesh": cube_mesh, "translation": at }));
    w.node(json!({ "name": "cube b", "mesh": cube_mesh, "translation": [at[0] + 2.0, at[1], at[2]] }));
    w.scene_roots = vec![0, 1];
    if let Some(size) = ground {
        let plane = hadou::scene::procedural::plane(1.0).unwrap();
        let p = w.primitive(&plane, IndexWidth::U16, true, None);
        let plane_mesh = w.mesh(vec![p]);
        w.node(json!({ "name": "ground", "mesh": plane_mesh, "translation": [0.0, -0.5, 0.0], "scale": [size, 1.0, size] }));
        w.scene_roots.push(2);
    }
    w
}

/// The pixel rectangle (width, height) at 64×64 of the unit cube at `centre`, as `camera` sees it.
fn cube_pixels(camera: &Camera, centre: DVec3) -> (u32, u32) {
    let corners: Vec<DVec3> = (0..8)
        .map(|k| {
            let d = DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64) - 0.5;
            centre + d
        })
        .collect();
    let r = camera.pixel_bounds(&corners, 64, 64).expect("the cube is in view");
    (r.x1 - r.x0, r.y1 - r.y0)
}

fn load(path: &Path) -> hadou::scene::Scene {
    hadou::scene::load_scene(path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_required_extension_hadou_cannot_honour_is_refused_by_name() {
    let dir = scratch("gltf_required");
    for ext in ["KHR_materials_unlit", "KHR_texture_basisu", "KHR_draco_mesh_compression"] {
        let mut w = ground_and_cubes(None, [0.0; 3]);
        w.uses("KHR_lights_punctual");
        w.uses(ext);
        w.extra.insert("extensionsRequired".into(), json!(["KHR_lights_punctual", ext]));
        let glb = w.write_glb(&dir, ext);
        let e = hadou::scene::load_scene(&glb).unwrap_err().to_string();
        assert!(e.contains(&format!("{}: /extensionsRequired/1: ", glb.display())), "{e}");
        assert!(e.contains(&format!("requires extension {ext}, which hadou")), "{e}");
        assert!(e.contains("expected only required extensions hadou honours: KHR_lights_punctual"), "{e}");

        // The command: exit 1, the file and the extension named, nothing written.
        let png = dir.join("out.png");
        let out = hadou(&["render", s(&glb), "-o", s(&png), "--size", "16x16"]);
        assert_eq!(out.status.code(), Some(1), "{}", text(&out));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(&format!("error: {}: /extensionsRequired/1: ", glb.display())), "{err}");
        assert!(err.contains(ext), "{err}");
        assert!(!png.exists());

        // Placed by a TOML scene: at the `path` value.
        let toml = dir.join("placed.toml");
        std::fs::write(&toml, format!("[[gltf]]\npath = \"{ext}.glb\"\n")).unwrap();
        let e = hadou::scene::load_scene(&toml).unwrap_err().to_string();
        assert!(e.contains("placed.toml:2:8: gltf 1 `path`: ") && e.contains(ext), "{e}");
    }
    // Used but not required: drawn, with the warning's list.
    let mut w = ground_and_cubes(None, [0.0; 3]);
    w.uses("KHR_materials_unlit");
    let s = load(&w.write_glb(&dir, "used"));
    assert_eq!(s.instances.len(), 2);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn required_extensions_hadou_honours_load() {
    let dir = scratch("gltf_honoured");
    let mut w = ground_and_cubes(None, [0.0; 3]);
    let volume = json!({
        "extensions": {
            "KHR_materials_transmission": { "transmissionFactor": 1.0 },
            "KHR_materials_volume": { "thicknessFactor": 1.0, "attenuationColor": [0.5, 0.5, 0.5], "attenuationDistance": 1.0 }
        }
    });
    w.material(volume);
    w.meshes[0]["primitives"][0]["material"] = json!(0);
    w.lights.push(json!({ "type": "directional", "intensity": 2.0 }));
    let light = w.node(json!({ "extensions": { "KHR_lights_punctual": { "light": 0 } } }));
    w.scene_roots.push(light);
    let all = ["KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_volume"];
    for e in all {
        w.uses(e);
    }
    w.extra.insert("extensionsRequired".into(), json!(all));
    let s = load(&w.write_glb(&dir, "honoured"));
    assert_eq!(s.lights.len(), 1);
    // 2 lux: a white surface facing the light has luminance 2/π cd/m² (issue 26).
    assert_eq!(s.lights[0].intensity, 2.0 / std::f64::consts::PI);
    assert!(matches!(
        s.materials[s.instances[0].material].kind,
        hadou::scene::MaterialKind::Translucent { .. }
    ));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A 1000-unit ground under two unit cubes: the framing camera fits the cubes (as it would
/// without the ground), not the ground (where each cube would be about a pixel); its far plane
/// still reaches the ground's far corners. The same with the ground in a TOML scene.
#[test]
fn a_ground_that_dwarfs_the_objects_is_not_what_is_framed() {
    let dir = scratch("gltf_big_ground");
    let at = [30.0, 0.0, -20.0];
    let with = load(&ground_and_cubes(Some(1000.0), at).write_glb(&dir, "ground"));
    let without = load(&ground_and_cubes(None, at).write_glb(&dir, "cubes"));
    assert_eq!(with.instances.len(), 3);
    let c = with.camera;
    assert_eq!((c.position, c.look_at), (without.camera.position, without.camera.look_at));
    let a = DVec3::from_array(at);
    for centre in [a, a + DVec3::new(2.0, 0.0, 0.0)] {
        let (w, h) = cube_pixels(&c, centre);
        assert!(w >= 12 && h >= 12, "a cube covers {w}x{h} of 64x64 pixels");
    }
    for corner in [DVec3::new(-500.0, -0.5, -500.0), DVec3::new(500.0, -0.5, 500.0)] {
        let depth = (corner - c.position).dot((c.look_at - c.position).normalize());
        assert!(depth < c.far, "the ground corner at {corner} (view depth {depth}) is past far {}", c.far);
    }
    // The whole ground framed (the old rule) would leave each cube a pixel or two.
    let whole = hadou::scene::gltf::framing(Some(hadou::scene::gltf::SceneBounds::whole(
        DVec3::new(-500.0, -0.5, -500.0),
        DVec3::new(500.0, 0.5, 500.0),
    )));
    let (w, h) = cube_pixels(&whole, a);
    assert!(w <= 3 && h <= 3, "{w}x{h}");

    // A TOML scene without [camera]: its own plane floor, scaled up, and the file's cubes.
    let toml = dir.join("level.toml");
    std::fs::write(
        &toml,
        "[[mesh]]\nname = \"floor\"\nkind = \"plane\"\n\n[[instance]]\nmesh = \"floor\"\n\
         transform = [{ scale = [2000, 1, 2000] }, { translate = [0, -0.5, 0] }]\n\n\
         [[gltf]]\npath = \"cubes.glb\"\n",
    )
    .unwrap();
    let placed = load(&toml);
    assert_eq!(placed.instances.len(), 3);
    assert!(placed.camera.position.abs_diff_eq(without.camera.position, 1e-9), "{:?}", placed.camera);
    for centre in [a, a + DVec3::new(2.0, 0.0, 0.0)] {
        let (w, h) = cube_pixels(&placed.camera, centre);
        assert!(w >= 12 && h >= 12, "a cube covers {w}x{h} of 64x64 pixels");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A scene that is only a plane is still framed: it fills a good part of the image.
#[test]
fn a_scene_of_one_plane_is_framed() {
    let dir = scratch("gltf_only_plane");
    let mut w = Writer::default();
    let plane: Mesh = hadou::scene::procedural::plane(1.0).unwrap();
    let p = w.primitive(&plane, IndexWidth::U16, true, None);
    let m = w.mesh(vec![p]);
    w.node(json!({ "mesh": m, "scale": [1000.0, 1.0, 1000.0] }));
    w.scene_roots = vec![0];
    let s = load(&w.write_glb(&dir, "plane"));
    let corners: Vec<DVec3> = [(-500.0, -500.0), (500.0, -500.0), (-500.0, 500.0), (500.0, 500.0)]
        .iter()
        .map(|&(x, z)| DVec3::new(x, 0.0, z))
        .collect();
    let r = s.camera.pixel_bounds(&corners, 64, 64).expect("the plane is in view");
    assert!(r.x1 - r.x0 >= 32 && r.y1 - r.y0 >= 16, "{r:?}");
    assert!(s.camera.far > 1000.0);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Depth of `glb` rendered by the CLI at 64×64 with its framing camera.
fn depth(glb: &Path) -> Vec<f32> {
    let exr: PathBuf = glb.with_extension("exr");
    let png = glb.with_extension("png");
    let aov = format!("depth={}", exr.display());
    let out = hadou(&["render", s(glb), "-o", s(&png), "--size", "64x64", "--aov", &aov]);
    assert!(out.status.success(), "{}", text(&out));
    hadou::output::read_exr_channel(&exr).unwrap().2
}

/// On the GPU: the cubes over the big ground cover what they cover without it (the same camera,
/// the cubes in front of the ground), a good part of the frame, and the ground fills the rest
/// of the lower image up to its far edge (not cut off by the far plane near the cubes).
#[test]
fn the_big_ground_scene_renders_its_cubes_large() {
    let dir = scratch("gltf_big_ground_gpu");
    let cubes = depth(&ground_and_cubes(None, [0.0; 3]).write_glb(&dir, "cubes"));
    let ground = depth(&ground_and_cubes(Some(1000.0), [0.0; 3]).write_glb(&dir, "ground"));
    let covered: Vec<usize> = (0..cubes.len()).filter(|&i| cubes[i].is_finite()).collect();
    assert!(covered.len() > 64 * 64 / 8, "the cubes cover {} of 4096 pixels", covered.len());
    for &i in &covered {
        assert!((ground[i] - cubes[i]).abs() <= 1e-4 * cubes[i], "pixel {i}: {} vs {}", ground[i], cubes[i]);
    }
    let ground_only = (0..ground.len()).filter(|&i| ground[i].is_finite() && !cubes[i].is_finite()).count();
    assert!(ground_only > 64 * 64 / 4, "the ground shows around the cubes: {ground_only} pixels");
    let farthest = ground.iter().filter(|d| d.is_finite()).fold(0.0f32, |m, &d| m.max(d));
    // The top row looks 1.6° below the horizon from 2.3 above the ground: it meets the ground ~80
    // away. A far plane fitted to the cubes alone (2·(distance + radius) ≈ 12) would cut it there.
    assert!(farthest > 50.0, "the ground reaches far past the cubes: {farthest}");
    std::fs::remove_dir_all(&dir).unwrap();
}
