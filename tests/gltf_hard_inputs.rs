//! Issue 24, glTF part: hard inputs that used to cost gigabytes, read files from anywhere or pass
//! unchecked now end in a clear error naming the file and the JSON pointer. The memory bombs run
//! the `hadou` binary under an address-space cap (`prlimit --as`) and a time limit, so a
//! regression fails the test instead of taking the machine down; the rest load through
//! `hadou::scene::load_scene`.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use common::cli::{output_within, s, scratch, text};
use common::gltf_writer::{hierarchy, Writer};
use hadou::scene::load_scene;
use serde_json::json;

/// The address space a refused bomb may use: the binary, its libraries and a parsed file of a
/// few kilobytes need far less; the old importer used 4–6 GB on these files.
const MEMORY_CAP: u64 = 1 << 30;

/// How long a refusal may take (process start included): the budget check reads no data. The old
/// importer took 10–40 s on these files.
const TIME_LIMIT: Duration = Duration::from_secs(5);

/// `hadou ARGS` under `MEMORY_CAP` and `TIME_LIMIT` (killed past it, which fails the test), with
/// `env` set; the time it took.
fn capped(args: &[&str], env: &[(&str, &str)]) -> (Output, Duration) {
    let mut cmd = Command::new("prlimit");
    cmd.arg(format!("--as={MEMORY_CAP}")).arg("--").arg(env!("CARGO_BIN_EXE_hadou")).args(args);
    cmd.current_dir(common::root()).env("HADOU_VALIDATION", "1").env_remove("HADOU_GLTF_BUDGET");
    for (k, v) in env {
        cmd.env(k, v);
    }
    let start = Instant::now();
    let out = output_within(&mut cmd, TIME_LIMIT);
    (out, start.elapsed())
}

/// Asserts `hadou render FILE` was refused with exit 1, `error:` and every one of `says`, quickly,
/// and wrote nothing.
fn assert_refused(file: &Path, env: &[(&str, &str)], says: &[&str]) {
    let png = file.with_extension("png");
    let (out, took) = capped(&["render", s(file), "-o", s(&png), "--size", "32x32"], env);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(1), "{}: {t}", file.display());
    assert!(t.contains("error:") && t.contains(s(file)), "{t}");
    for say in says {
        assert!(t.contains(say), "expected `{say}` in: {t}");
    }
    assert!(took < TIME_LIMIT, "took {took:?}");
    assert!(!png.exists(), "an output was written");
}

fn err(path: &Path) -> String {
    match load_scene(path) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e) => e.to_string(),
    }
}

/// The bomb: `meshes` meshes, each one primitive (TRIANGLE_STRIP, no indices, no normals)
/// whose POSITION is a sparse accessor without a bufferView declaring 2²⁴ vertices, one
/// substitution; a node per mesh. Under a kilobyte.
fn sparse_bomb(meshes: usize) -> Writer {
    let mut w = Writer::default();
    let idx = w.view(&[0, 0, 0, 0], 34963);
    let val = w.view(&[0; 12], 34962);
    w.accessors.push(json!({
        "componentType": 5126, "count": 1 << 24, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1],
        "sparse": { "count": 1, "indices": { "bufferView": idx, "componentType": 5125 }, "values": { "bufferView": val } }
    }));
    for m in 0..meshes {
        w.meshes.push(json!({ "primitives": [{ "attributes": { "POSITION": 0 }, "mode": 5 }] }));
        w.node(json!({ "mesh": m }));
        w.scene_roots.push(m);
    }
    w
}

#[test]
fn sparse_vertex_bombs_are_refused_before_decoding() {
    let dir = scratch("gltf-hard-bomb");
    for meshes in [1, 4] {
        let glb = sparse_bomb(meshes).write_glb(&dir, &format!("bomb{meshes}"));
        let size = std::fs::metadata(&glb).unwrap().len();
        assert!(size < 1200, "{size} bytes");
        // One use alone is past the vertex budget: 2²⁴ positions, then 3 flat vertices per strip
        // triangle (2²⁴ − 2 of them).
        assert_refused(&glb, &[], &["/nodes/0/mesh", "67108858 vertices", "HADOU_GLTF_BUDGET"]);
    }
}

#[test]
fn meshes_sharing_one_accessor_are_counted_per_use() {
    // 400 meshes drawing the same 100,000-vertex accessor (1.2 MB of positions): each is within
    // the budget, together they decode 80 M vertices.
    let dir = scratch("gltf-hard-shared");
    let mut w = Writer::default();
    let positions: Vec<[f32; 3]> =
        (0..100_000).map(|i| [(i % 3) as f32, (i % 5) as f32, (i % 7) as f32]).collect();
    let pos = w.vec3(&positions, true);
    for m in 0..400 {
        w.meshes.push(json!({ "primitives": [{ "attributes": { "POSITION": pos } }] }));
        w.node(json!({ "mesh": m }));
        w.scene_roots.push(m);
    }
    let glb = w.write_glb(&dir, "shared");
    assert_refused(&glb, &[], &["vertices", "counting a mesh once per node", "drawn by /nodes/"]);
    // One mesh drawn by 400 nodes counts the same.
    let mut w = Writer::default();
    let pos = w.vec3(&positions, true);
    w.meshes.push(json!({ "primitives": [{ "attributes": { "POSITION": pos } }] }));
    for n in 0..400 {
        w.node(json!({ "mesh": 0, "translation": [n as f32 * 10.0, 0.0, 0.0] }));
        w.scene_roots.push(n);
    }
    let glb = w.write_glb(&dir, "one_mesh");
    assert_refused(&glb, &[], &["vertices", "/meshes/0/primitives/0 drawn by /nodes/"]);
}

#[test]
fn budgets_are_overridden_through_the_environment() {
    let dir = scratch("gltf-hard-env");
    // Three instances of a 24-vertex cube (with normals), four nodes.
    let glb = hierarchy(true, true, None).write_glb(&dir, "h");
    let var = "HADOU_GLTF_BUDGET";
    assert_refused(&glb, &[(var, "instances=2")], &["/nodes/3/mesh", "3 instances", "at most 2 instances"]);
    assert_refused(&glb, &[(var, "nodes=3")], &["/nodes: 4 nodes", "at most 3 nodes"]);
    assert_refused(&glb, &[(var, "vertices=71")], &["72 vertices", "at most 71"]);
    assert_refused(&glb, &[(var, "indices=100")], &["indices", "at most 100"]);
    assert_refused(
        &glb,
        &[(var, "vertices=many")],
        &["environment variable HADOU_GLTF_BUDGET", "`vertices=many`"],
    );
    // Exactly the file's cost is allowed.
    let png = dir.join("h.png");
    let (out, _) = {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_hadou"));
        cmd.args(["render", s(&glb), "-o", s(&png), "--size", "32x32"]);
        cmd.env("HADOU_VALIDATION", "1").env(var, "instances=3,nodes=4,vertices=72,indices=108");
        (output_within(&mut cmd, common::cli::RUN_LIMIT), ())
    };
    assert!(out.status.success(), "{}", text(&out));
    assert!(png.exists());
}

#[test]
fn deep_hierarchies_are_bounded_by_transform_steps() {
    // A chain of 1024 nodes, each translated and scaled and drawing a mesh: every instance keeps
    // its ancestors' steps, 2·(1 + … + 1024) per copy — past the budget of 2²⁰.
    let dir = scratch("gltf-hard-deep");
    let mut w = Writer::default();
    let tet = hadou::scene::procedural::tetrahedron(1.0).unwrap();
    let p = w.primitive(&tet, common::gltf_writer::IndexWidth::U8, true, None);
    let m = w.mesh(vec![p]);
    for n in 0..1024usize {
        let mut node = json!({ "mesh": m, "translation": [0.001, 0.0, 0.0], "scale": [1.0, 1.0, 1.0001] });
        if n + 1 < 1024 {
            node["children"] = json!([n + 1]);
        }
        w.node(node);
    }
    w.scene_roots = vec![0];
    let e = err(&w.write_glb(&dir, "deep"));
    assert!(e.contains("transform steps") && e.contains("at most 1048576"), "{e}");
}

/// A buffer file outside the folder the glTF is in, and the glTF files naming it.
fn outside_setup(name: &str) -> (PathBuf, PathBuf, Writer) {
    let root = scratch(name);
    let inner = root.join("level");
    std::fs::create_dir_all(inner.join("sub")).unwrap();
    let w = hierarchy(true, false, None);
    std::fs::write(root.join("outside.bin"), &w.bin).unwrap();
    (root, inner, w)
}

fn with_uri(w: &Writer, dir: &Path, name: &str, uri: &str) -> PathBuf {
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_vec(&w.json(Some(uri.to_owned()))).unwrap()).unwrap();
    path
}

#[test]
fn buffer_uris_stay_inside_the_gltf_folder() {
    let (root, inner, w) = outside_setup("gltf-hard-uri");
    let outside = root.join("outside.bin");
    let absolute = outside.to_str().unwrap().to_owned();
    std::os::unix::fs::symlink(&outside, inner.join("link.bin")).unwrap();
    for (name, uri, says) in [
        ("dotdot", "../outside.bin", "leads out of the glTF file's folder"),
        ("encoded", "%2e%2e/outside.bin", "leads out of the glTF file's folder"),
        ("deeper", "sub/../../outside.bin", "leads out of the glTF file's folder"),
        ("absolute", absolute.as_str(), "is an absolute path"),
        ("encoded_absolute", &absolute.replace('/', "%2F"), "is an absolute path"),
        ("symlink", "link.bin", "through a symbolic link"),
    ] {
        let e = err(&with_uri(&w, &inner, name, uri));
        assert!(e.contains("/buffers/0/uri") && e.contains(says), "{name}: {e}");
    }
    // Inside the folder, by any spelling, and through a link that stays inside: read.
    std::fs::write(inner.join("sub/in.bin"), &w.bin).unwrap();
    std::os::unix::fs::symlink("sub/in.bin", inner.join("inner_link.bin")).unwrap();
    for (name, uri) in [
        ("plain", "sub/in.bin"),
        ("dots", "./sub/../sub/in.bin"),
        ("pct", "sub%2Fin.bin"),
        ("ilink", "inner_link.bin"),
    ] {
        load_scene(&with_uri(&w, &inner, name, uri)).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    // An image URI (never read) may not leave the folder either.
    let mut img = w.clone();
    std::fs::write(inner.join("in.bin"), &w.bin).unwrap();
    img.extra.insert("images".into(), json!([{ "uri": "../../etc/passwd" }]));
    let e = err(&with_uri(&img, &inner, "image", "in.bin"));
    assert!(e.contains("/images/0/uri") && e.contains("leads out"), "{e}");
}

#[test]
fn errors_do_not_echo_the_bytes_of_files_outside() {
    // The old importer read `../secret.txt` as the index buffer and said `index 0 is 83` ('S').
    let (root, inner, w) = outside_setup("gltf-hard-echo");
    std::fs::write(
        root.join("secret.txt"),
        b"S3CRET PASSWORD AND MORE TEXT OF A SECRET FILE, LONG ENOUGH...................".repeat(40),
    )
    .unwrap();
    let mut w = w;
    // The cube's buffer as a data: URI buffer 0; the indices read from buffer 1, the secret.
    let b64 = base64::Engine::encode(&base64::engine::general_purpose::STANDARD, &w.bin);
    let ind_view = w.accessors[2]["bufferView"].as_u64().unwrap() as usize;
    w.views[ind_view]["buffer"] = json!(1);
    w.views[ind_view]["byteOffset"] = json!(0);
    let mut root_json = w.json(Some(format!("data:application/octet-stream;base64,{b64}")));
    root_json["buffers"].as_array_mut().unwrap().push(json!({ "uri": "../secret.txt", "byteLength": 3000 }));
    let path = inner.join("echo.gltf");
    std::fs::write(&path, serde_json::to_vec(&root_json).unwrap()).unwrap();
    let e = err(&path);
    assert!(e.contains("/buffers/1/uri") && e.contains("leads out"), "{e}");
    // The message names the file; its path holds this process's id, which may contain "83".
    let message = e.replace(&path.display().to_string(), "<file>");
    for leaked in ["index 0 is", "S3CRET", "83"] {
        assert!(!message.contains(leaked), "{e}");
    }
}

#[test]
fn glb_total_length_must_be_the_file_length() {
    let dir = scratch("gltf-hard-glb-length");
    let mut glb = hierarchy(true, false, None).glb();
    let real = glb.len() as u32;
    glb[8..12].copy_from_slice(&(real - 4).to_le_bytes());
    let path = dir.join("short.glb");
    std::fs::write(&path, &glb).unwrap();
    let e = err(&path);
    assert!(e.contains(&format!("total length of {} bytes but the file has {real}", real - 4)), "{e}");
}

#[test]
fn only_gltf_2_is_read() {
    let dir = scratch("gltf-hard-version");
    let w = hierarchy(true, false, None);
    let write = |name: &str, asset: serde_json::Value| {
        let mut j = w.json(Some(format!(
            "data:application/octet-stream;base64,{}",
            base64::Engine::encode(&base64::engine::general_purpose::STANDARD, &w.bin)
        )));
        j["asset"] = asset;
        let p = dir.join(format!("{name}.gltf"));
        std::fs::write(&p, serde_json::to_vec(&j).unwrap()).unwrap();
        p
    };
    for v in ["1.0", "3.0", "2", "20"] {
        let e = err(&write(&format!("v{v}"), json!({ "version": v })));
        assert!(e.contains("/asset/version") && e.contains(&format!("\"{v}\"")), "{v}: {e}");
    }
    let e = err(&write("min", json!({ "version": "2.1", "minVersion": "2.1" })));
    assert!(e.contains("/asset/minVersion"), "{e}");
    load_scene(&write("v2.1", json!({ "version": "2.1", "minVersion": "2.0" }))).unwrap();
}

#[test]
fn a_scene_lists_each_root_node_once() {
    let dir = scratch("gltf-hard-roots");
    let mut w = hierarchy(true, true, None);
    w.scene_roots = vec![0, 3, 0];
    let e = err(&w.write_glb(&dir, "twice"));
    assert!(e.contains("/scenes/0/nodes/2: node 0 is listed twice, first at /scenes/0/nodes/0"), "{e}");
}

#[test]
fn a_scenes_gltf_files_share_one_budget() {
    // Two `[[gltf]]` tables place the same file of three instances: each alone is within a budget
    // of five instances, together they are not (else many files, each just within the budget,
    // could add up to any total).
    let dir = scratch("gltf-hard-scene");
    hierarchy(true, true, None).write_glb(&dir, "h");
    let scene = dir.join("two.toml");
    let table = |x: f64| format!("[[gltf]]\npath = \"h.glb\"\ntransform = [{{ translate = [{x}, 0, 0] }}]\n");
    std::fs::write(&scene, format!("{}\n{}", table(0.0), table(10.0))).unwrap();
    let var = "HADOU_GLTF_BUDGET";
    assert_refused(&scene, &[(var, "instances=5")], &["gltf 2", "6 instances", "earlier glTF files"]);
    let png = dir.join("two.png");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hadou"));
    cmd.args(["render", s(&scene), "-o", s(&png), "--size", "32x32"]);
    cmd.env("HADOU_VALIDATION", "1").env(var, "instances=6");
    let out = output_within(&mut cmd, common::cli::RUN_LIMIT);
    assert!(out.status.success(), "{}", text(&out));
}
