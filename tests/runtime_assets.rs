//! Run-time assets: a mesh and a material spawned into a live world, by handle, draw exactly as
//! the same mesh and material loaded from a scene file (bit for bit: the same buffers and tables
//! reach the same passes); a translucent one bakes in the background like any run-time bake;
//! despawning is refused while something draws the asset, and its id goes stale; bad meshes are
//! errors that name the mesh and what was expected, and leave the world as it was.

mod common;

use common::gltf_writer::{temp_dir, IndexWidth, Writer};
use glam::{DMat4, DVec3, Vec3};
use hadou::scene::{MaterialKind, ThicknessMode};
use hadou::{Aov, Error, FrameRequest};
use serde_json::json;

const LIGHTS_AND_CAMERA: &str = r#"
[camera]
position = [2, 1.5, 4]
look_at = [0, 0, 0]

[[light]]
kind = "directional"
direction = [-1, -2, -1]
color = [1, 1, 1]
intensity = 2
"#;

/// The same world from a file: a cube of `material`, rotated and moved.
fn file_scene(material: &str) -> String {
    format!(
        r#"{LIGHTS_AND_CAMERA}
[[mesh]]
name = "crate"
kind = "cube"
size = 1.2

{material}

[[instance]]
mesh = "crate"
material = "paint"
transform = [{{ rotate = {{ angle_deg = 30, axis = [0, 1, 0] }} }}, {{ translate = [0.2, 0, -0.3] }}]
"#
    )
}

const LAMBERT: &str = r#"[[material]]
name = "paint"
albedo = [0.8, 0.3, 0.2]"#;

const JADE: &str = r#"[[material]]
name = "paint"
kind = "translucent"
albedo = [0.4, 0.9, 0.6]
sigma = [2, 1, 1.5]
voxel_res = 12"#;

fn transform() -> DMat4 {
    DMat4::from_translation(DVec3::new(0.2, 0.0, -0.3)) * DMat4::from_rotation_y(30f64.to_radians())
}

fn render(rt: &mut common::CheckedRuntime) -> (Vec<u8>, Vec<f32>) {
    let mut request = FrameRequest::new(64, 48);
    request.aovs = vec![Aov::Hdr, Aov::Normal];
    let out = rt.render(&request).unwrap();
    let hdr = out.aov(Aov::Hdr).unwrap().data.clone();
    let mut normal = out.aov(Aov::Normal).unwrap().data.clone();
    normal.extend(hdr);
    (out.color.clone().unwrap_or_default(), normal)
}

/// Panics naming how many values differ between two renders and the first few.
fn assert_same(a: &(Vec<u8>, Vec<f32>), b: &(Vec<u8>, Vec<f32>), what: &str) {
    let colour: Vec<usize> = (0..a.0.len().min(b.0.len())).filter(|&i| a.0[i] != b.0[i]).collect();
    let data: Vec<usize> =
        (0..a.1.len().min(b.1.len())).filter(|&i| a.1[i].to_bits() != b.1[i].to_bits()).collect();
    let first: Vec<String> =
        colour.iter().take(4).map(|&i| format!("byte {i}: {} vs {}", a.0[i], b.0[i])).collect();
    let first_data: Vec<String> =
        data.iter().take(4).map(|&i| format!("value {i}: {} vs {}", a.1[i], b.1[i])).collect();
    assert!(
        colour.is_empty() && data.is_empty() && a.0.len() == b.0.len() && a.1.len() == b.1.len(),
        "{what}: {} colour bytes and {} AOV values differ ({first:?} {first_data:?})",
        colour.len(),
        data.len()
    );
}

/// The cube mesh as the file builds it (`kind = "cube"`), handed over as a game would.
fn crate_mesh() -> (Vec<Vec3>, Vec<Vec3>, Vec<u32>) {
    let m = hadou::scene::procedural::cube(1.2).unwrap();
    let v = |a: &Vec<[f32; 3]>| a.iter().map(|p| Vec3::from_array(*p)).collect::<Vec<_>>();
    (v(&m.positions), v(&m.normals), m.indices)
}

#[test]
fn a_spawned_mesh_and_material_draw_as_loaded_ones() {
    let mut rt = common::runtime();
    rt.load_scene(common::parse(&file_scene(LAMBERT))).unwrap();
    let loaded = render(&mut rt);

    rt.load_scene(common::parse(LIGHTS_AND_CAMERA)).unwrap();
    let (p, n, i) = crate_mesh();
    let mesh = rt.renderer().spawn_mesh("crate", &p, Some(&n), &i).unwrap();
    let paint =
        rt.renderer().spawn_material("paint", Vec3::new(0.8, 0.3, 0.2), MaterialKind::Lambert).unwrap();
    let instance = rt.renderer().spawn_instance_of(mesh, paint, transform()).unwrap();
    assert_same(&render(&mut rt), &loaded, "spawned assets draw as the file's");
    assert_eq!(rt.renderer().mesh_named("crate"), Some(mesh));
    assert_eq!(rt.renderer().material_named("paint"), Some(paint));

    // Despawning: refused while drawn, then allowed; the ids go stale, the names are free again.
    let busy = rt.renderer().despawn_mesh(mesh).unwrap_err().to_string();
    assert!(busy.contains("mesh \"crate\"") && busy.contains("1 instance"), "{busy}");
    let busy = rt.renderer().despawn_material(paint).unwrap_err().to_string();
    assert!(busy.contains("material \"paint\""), "{busy}");
    rt.renderer().despawn_instance(instance).unwrap();
    rt.renderer().despawn_mesh(mesh).unwrap();
    rt.renderer().despawn_material(paint).unwrap();
    assert!(matches!(rt.renderer().despawn_mesh(mesh), Err(Error::StaleId(_))));
    assert!(matches!(rt.renderer().spawn_instance_of(mesh, paint, DMat4::IDENTITY), Err(Error::StaleId(_))));
    assert_eq!(rt.renderer().mesh_named("crate"), None);
    assert!(rt.renderer().mesh_ids().is_empty() && rt.renderer().material_ids().is_empty());
    let empty = render(&mut rt);
    // Spawned again under the same names (into the slots after the retired ones): the picture
    // comes back.
    let mesh = rt.renderer().spawn_mesh("crate", &p, None, &i).unwrap();
    let paint = rt.renderer().spawn_material("paint", [0.8f32, 0.3, 0.2], MaterialKind::Lambert).unwrap();
    rt.renderer().spawn_instance_of(mesh, paint, transform().as_mat4()).unwrap();
    let again = render(&mut rt);
    assert_ne!(again.0, empty.0, "the respawned crate is drawn");
    common::assert_clean(&rt);
}

/// The crate of jade at `voxel_res` loaded from a file and rendered; then the same world built at
/// run time (a bare scene, the mesh, the material and the instance spawned). The runtime and the
/// file's render.
fn jade_crate_spawned(voxel_res: u32) -> (common::CheckedRuntime, (Vec<u8>, Vec<f32>)) {
    let mut rt = common::runtime();
    let jade = JADE.replace("voxel_res = 12", &format!("voxel_res = {voxel_res}"));
    rt.load_scene(common::parse(&file_scene(&jade))).unwrap();
    let loaded = render(&mut rt);

    rt.load_scene(common::parse(LIGHTS_AND_CAMERA)).unwrap();
    let (p, n, i) = crate_mesh();
    let mesh = rt.renderer().spawn_mesh("crate", &p, Some(&n), &i).unwrap();
    let kind = MaterialKind::Translucent {
        sigma: DVec3::new(2.0, 1.0, 1.5),
        voxel_res,
        thickness: ThicknessMode::Lut,
    };
    let jade = rt.renderer().spawn_material("paint", DVec3::new(0.4, 0.9, 0.6), kind).unwrap();
    rt.renderer().spawn_instance_of(mesh, jade, transform()).unwrap();
    (rt, loaded)
}

#[test]
fn a_spawned_translucent_material_bakes_in_the_background() {
    let (mut rt, loaded) = jade_crate_spawned(12);
    assert!(!rt.renderer().bakes_in_progress().is_empty(), "its table bakes in the background");
    rt.renderer().wait_for_bakes().unwrap();
    assert_same(&render(&mut rt), &loaded, "once baked, as the file's");
    common::assert_clean(&rt);
}

#[test]
fn a_large_table_is_copied_a_slice_per_frame_and_drawn_as_loaded() {
    // The cube at the largest voxel_res: 129³ corners and 128³ τ bytes, a few slices.
    let (mut rt, loaded) = jade_crate_spawned(128);
    // Frames go on while it bakes and while its tables are copied; no frame copies more than the
    // budget, and the copy takes the frames the bytes need.
    let budget = hadou::Renderer::UPLOAD_BYTES_PER_FRAME;
    let (mut copies, mut last, mut bytes) = (Vec::new(), 0, 0);
    let start = std::time::Instant::now();
    loop {
        let progress = rt.renderer().bakes_in_progress();
        let Some(p) = progress.first() else { break };
        if p.bytes > 0 {
            copies.push(p.copied - last);
            (last, bytes) = (p.copied, p.bytes);
        }
        assert!(start.elapsed().as_secs() < 300, "the bake did not finish: {p:?}");
        rt.render(&FrameRequest::new(64, 48)).unwrap();
    }
    assert!(bytes > 2 * budget, "a 128³ table is more than two slices: {bytes} bytes");
    assert!(copies.iter().all(|&c| c <= budget), "a frame copied more than {budget} bytes: {copies:?}");
    // The frame that saw the first slice, the ones in between, and the one that put it in use.
    assert!(copies.len() + 1 >= bytes.div_ceil(budget), "{} frames for {bytes} bytes", copies.len() + 1);
    assert_same(&render(&mut rt), &loaded, "once copied, as the file's");
    common::assert_clean(&rt);
}

#[test]
fn bad_assets_are_refused_by_name() {
    let mut rt = common::runtime();
    rt.load_scene(common::parse(LIGHTS_AND_CAMERA)).unwrap();
    let (p, n, i) = crate_mesh();
    let r = rt.renderer();
    let text = |e: Error| e.to_string();
    let e = text(r.spawn_mesh("bad", &p, Some(&n), &[0, 1, 99]).unwrap_err());
    assert!(e.contains("mesh \"bad\"") && e.contains("out of range"), "{e}");
    let e = text(r.spawn_mesh("bad", &p, Some(&n), &i[..4]).unwrap_err());
    assert!(e.contains("multiple of 3"), "{e}");
    let mut nan = p.clone();
    nan[0].x = f32::NAN;
    let e = text(r.spawn_mesh("bad", &nan, Some(&n), &i).unwrap_err());
    assert!(e.contains("finite positions"), "{e}");
    let far = vec![Vec3::splat(2e6); p.len()];
    assert!(r.spawn_mesh("bad", &far, Some(&n), &i).is_err());
    let e = text(r.spawn_mesh("bad", &p, Some(&n[..3]), &i).unwrap_err());
    assert!(e.contains("normals"), "{e}");
    assert!(r.spawn_mesh("", &p, None, &i).is_err());
    r.spawn_mesh("ok", &p, None, &i).unwrap();
    let e = text(r.spawn_mesh("ok", &p, None, &i).unwrap_err());
    assert!(e.contains("mesh name \"ok\""), "{e}");
    let e = text(r.spawn_material("m", DVec3::new(1.5, 0.0, 0.0), MaterialKind::Lambert).unwrap_err());
    assert!(e.contains("albedo"), "{e}");
    let kind = MaterialKind::Translucent { sigma: DVec3::ZERO, voxel_res: 12, thickness: ThicknessMode::Lut };
    assert!(r.spawn_material("m", DVec3::splat(0.5), kind).is_err());
    // Nothing of the refused calls stayed: one mesh, no material.
    assert_eq!((r.mesh_ids().len(), r.material_ids().len()), (1, 0));
    rt.render(&FrameRequest::new(16, 16)).unwrap();
    common::assert_clean(&rt);
}

/// A glTF file with a textured cube (an 4×4 checker PNG in the buffer, NEAREST) and a plain one.
fn gltf_file(dir: &std::path::Path) -> std::path::PathBuf {
    let mut w = Writer::default();
    let cube = hadou::scene::procedural::cube(1.0).unwrap();
    let mut img = image::RgbaImage::new(4, 4);
    for (x, y, p) in img.enumerate_pixels_mut() {
        *p = if (x + y) % 2 == 0 { image::Rgba([230, 40, 30, 255]) } else { image::Rgba([20, 90, 240, 255]) };
    }
    let mut png = Vec::new();
    image::DynamicImage::ImageRgba8(img)
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    // An image's buffer view has no target.
    let view = w.view(&png, 34962);
    w.views[view].as_object_mut().unwrap().remove("target");
    w.extra.insert("images".into(), json!([{ "bufferView": view, "mimeType": "image/png" }]));
    w.extra.insert("samplers".into(), json!([{ "magFilter": 9728, "minFilter": 9728 }]));
    w.extra.insert("textures".into(), json!([{ "source": 0, "sampler": 0 }]));
    let textured = w.material(
        json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 }, "metallicFactor": 0.0 } }),
    );
    let plain = w.material(
        json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.3, 0.8, 0.4, 1.0], "metallicFactor": 0.0 } }),
    );
    // Texture coordinates: each vertex's x, y (a checker across every face).
    let uv: Vec<[f32; 2]> = cube.positions.iter().map(|p| [p[0] + 0.5, p[1] + 0.5]).collect();
    let uv_bytes: Vec<u8> = bytemuck::cast_slice(&uv).to_vec();
    let uv_view = w.view(&uv_bytes, 34962);
    w.accessors
        .push(json!({ "bufferView": uv_view, "componentType": 5126, "count": uv.len(), "type": "VEC2" }));
    let uv_accessor = w.accessors.len() - 1;
    let mut a = w.primitive(&cube, IndexWidth::U16, true, Some(textured));
    a["attributes"]["TEXCOORD_0"] = json!(uv_accessor);
    let b = w.primitive(&cube, IndexWidth::U16, true, Some(plain));
    let (ma, mb) = (w.mesh(vec![a]), w.mesh(vec![b]));
    let na = w.node(json!({ "mesh": ma, "translation": [-0.8, 0.0, 0.0] }));
    let nb = w.node(json!({ "mesh": mb, "translation": [0.8, 0.0, 0.0], "scale": [0.7, 0.7, 0.7] }));
    w.scene_roots.extend([na, nb]);
    w.write_glb(dir, "props")
}

/// A glTF file spawned into a live world draws as the same file placed by `[[gltf]]` at load:
/// bit for bit (its textured material's image copied by the next frame, the plain one beside it),
/// and its parts come back as ids the game can take out again.
#[test]
fn a_gltf_file_spawned_at_run_time_draws_as_one_loaded_with_the_scene() {
    let dir = temp_dir("spawn_gltf");
    let path = gltf_file(&dir);
    let placed = format!(
        "{LIGHTS_AND_CAMERA}\n[[gltf]]\npath = {:?}\ntransform = [{{ rotate = {{ angle_deg = 30, axis = [0, 1, 0] }} }}, {{ translate = [0.2, 0, -0.3] }}]\n",
        path.display().to_string()
    );
    let mut rt = common::runtime();
    rt.load_scene(hadou::scene::parse_scene(&placed, &dir.join("placed.toml")).unwrap()).unwrap();
    let loaded = render(&mut rt);

    rt.load_scene(common::parse(LIGHTS_AND_CAMERA)).unwrap();
    let spawned = rt.renderer().spawn_gltf(&path, transform()).unwrap();
    assert_eq!((spawned.meshes.len(), spawned.materials.len(), spawned.instances.len()), (2, 2, 2));
    assert_same(&render(&mut rt), &loaded, "the spawned file draws as the loaded one");
    assert_eq!(rt.renderer().mesh_ids(), spawned.meshes);
    assert!(spawned.lights.is_empty(), "the file has no lights, and no default one is added");

    // Spawned twice: the names of the second get #2, both draw.
    let again = rt.renderer().spawn_gltf(&path, DMat4::from_translation(DVec3::new(0.0, -3.0, 0.0))).unwrap();
    assert!(again.meshes.iter().all(|m| !spawned.meshes.contains(m)));
    let twice = render(&mut rt);
    assert_ne!(twice, loaded);
    // Taken out piece by piece: the first file's picture comes back.
    for i in again.instances {
        rt.renderer().despawn_instance(i).unwrap();
    }
    for m in again.meshes {
        rt.renderer().despawn_mesh(m).unwrap();
    }
    for m in again.materials {
        rt.renderer().despawn_material(m).unwrap();
    }
    assert_same(&render(&mut rt), &loaded, "with the second copy taken out");
    // A file that is not there is an error naming it; nothing was added.
    let meshes = rt.renderer().mesh_ids().len();
    let e = rt.renderer().spawn_gltf(&dir.join("missing.glb"), DMat4::IDENTITY).unwrap_err().to_string();
    assert!(e.contains("missing.glb"), "{e}");
    assert_eq!(rt.renderer().mesh_ids().len(), meshes);
    common::assert_clean(&rt);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A file with a part hadou cannot hold (a light of intensity 1e39, past f32) is refused whole,
/// with the field's JSON path named: no mesh, material, instance or light of it stays and the
/// picture is the picture before. (What fails after the first part is in — a device allocation —
/// is undone by `spawn_gltf` itself; no file can make that happen.)
#[test]
fn a_gltf_file_with_a_part_past_f32_adds_nothing() {
    let dir = temp_dir("spawn_gltf_fails");
    let mut w = Writer::default();
    let cube = hadou::scene::procedural::cube(1.0).unwrap();
    let m = w.material(json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.9, 0.5, 0.2, 1.0] } }));
    let p = w.primitive(&cube, IndexWidth::U16, true, Some(m));
    let mesh = w.mesh(vec![p]);
    let node = w.node(json!({ "mesh": mesh }));
    w.lights.push(json!({ "type": "point", "color": [1.0, 1.0, 1.0], "intensity": 1e39 }));
    let lit = w.node(
        json!({ "extensions": { "KHR_lights_punctual": { "light": 0 } }, "translation": [0.0, 2.0, 0.0] }),
    );
    w.uses("KHR_lights_punctual");
    w.scene_roots.extend([node, lit]);
    let path = w.write_glb(&dir, "too_bright");

    let mut rt = common::runtime();
    rt.load_scene(common::parse(LIGHTS_AND_CAMERA)).unwrap();
    let before = render(&mut rt);
    let r = rt.renderer();
    let counts = |r: &hadou::Renderer| {
        (r.mesh_ids().len(), r.material_ids().len(), r.instance_ids().len(), r.light_ids().len())
    };
    let was = counts(r);
    let e = r.spawn_gltf(&path, DMat4::IDENTITY).unwrap_err().to_string();
    assert!(e.contains("/extensions/KHR_lights_punctual/lights/0/intensity"), "{e}");
    assert_eq!(counts(rt.renderer()), was, "nothing of the file stays");
    assert!(rt.renderer().mesh_named("too_bright/mesh0").is_none());
    assert_same(&render(&mut rt), &before, "the world draws as before the failed spawn");
    common::assert_clean(&rt);
    let _ = std::fs::remove_dir_all(&dir);
}
