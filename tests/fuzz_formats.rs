//! A fuzzing harness for the inputs added after tests/fuzz_scenes.rs (issue 24, item 6): glTF
//! JSON and GLB files (JSON chunk and BIN chunk), PNG and OpenEXR headers fed to `hadou compare`,
//! `hadou profile --json` files fed to `hadou profile-diff`, and `hadou test` sidecars
//! (`NAME.test.toml`) fed to `hadou test`. Every case runs the real binary
//! in its own process under a memory cap and a time limit (see `MEMORY_CAP`, `CASE_LIMIT`), so a
//! decoder that believes a header's 10¹⁰ pixels fails the case instead of taking the machine down.
//!
//! Properties of every case: the process ends by itself within the limit, with exit code 0, 1 or
//! 2 (no panic: 101; no abort or signal: allocation failures under the cap are aborts); an
//! `error:` line naming the mutated file whenever the command reports an error; no "panicked".
//! Per surface: a glTF the loader accepts keeps the scene's numeric limits (docs/scene-format.md,
//! "Numeric limits") and a few of them are rendered (16x16, validation on); `profile-diff` never
//! says `gate: pass` for a candidate without samples in a gated row of the baseline, with fewer
//! than two in one, or with a negative sample (issue 24, item 4).
//!
//! Before the random cases, each property runs inputs that are no regular file (a FIFO nobody
//! writes, a folder, an empty file, `/dev/zero`; for glTF also a buffer that is a FIFO), which
//! must be refused, and the corpus of tests/data/fuzz (inputs that once failed).
//!
//! Cases are deterministic (`hadou::testing::Rng`, seeded from the case number). Failing inputs
//! are written to `$HADOU_FUZZ_FINDINGS` (default: a folder under the temp folder, named in the
//! failure) with the command and its output, so each can be replayed by hand.
//!
//! `HADOU_FUZZ_CASES=N cargo test --test fuzz_formats` runs N cases per property (default 24, a
//! few seconds); `HADOU_FUZZ_CASES=5000 cargo test --release --test fuzz_formats` for a long run.
//! `HADOU_FUZZ_SEED` moves every property to other cases; `HADOU_FUZZ_VERBOSE=1` prints each
//! case's exit code, time and error; `HADOU_FUZZ_BIN` fuzzes another build
//! of `hadou` (e.g. an older commit's, to see that the harness finds what was fixed since).

mod common;

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::gltf_writer::{self, IndexWidth, Writer};
use common::mutate::{self, below};
use hadou::scene::file::{MAX_EXTENT, MAX_FAR_NEAR_RATIO, MAX_HDR};
use hadou::testing::Rng;
use serde_json::{json, Value};

/// Address space each case's process may map (`prlimit --as`), 2 GiB. The inputs are a few KB;
/// a clean refusal maps well under 100 MB, and an accepted 16x16 render (debug build, lavapipe,
/// validation layers, their threads' stacks) under 1 GiB here (it runs under a 1 GiB cap too), so
/// the cap leaves twice the need. The defects it catches want 4–40 GB (issue 24), and six such
/// processes of parallel test runs fit beside each other on a 16 GB CI machine.
const MEMORY_CAP: u64 = 2 << 30;

/// How long one refused or compared case may run (debug build, a shared 2-core machine). A clean
/// refusal or a comparison of a few-KB image takes well under a second; the bombs of issue 24
/// took 10–40 s in a release build. Not a performance bound: a hang guard with room for a busy
/// machine.
const CASE_LIMIT: Duration = Duration::from_secs(10);

/// How long one 16x16 render of an accepted glTF may run: Vulkan start-up with validation, the
/// upload and a translucency bake take 1–5 s here.
const RENDER_LIMIT: Duration = Duration::from_secs(60);

fn cases() -> usize {
    std::env::var("HADOU_FUZZ_CASES").ok().and_then(|n| n.parse().ok()).unwrap_or(24)
}

/// The generator of case `i` of a property.
fn case_rng(property: u64, i: usize) -> Rng {
    let seed: u64 = std::env::var("HADOU_FUZZ_SEED").ok().and_then(|n| n.parse().ok()).unwrap_or(0);
    let mut rng = Rng((property
        ^ seed.wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (i as u64 + 1).wrapping_mul(0x2545_F491_4F6C_DD1D))
        | 1);
    for _ in 0..4 {
        rng.next();
    }
    rng
}

/// The binary under test: this build's, or `$HADOU_FUZZ_BIN` (another build, e.g. a release or an
/// older commit's, to see which findings it has).
fn binary() -> OsString {
    std::env::var_os("HADOU_FUZZ_BIN").unwrap_or_else(|| env!("CARGO_BIN_EXE_hadou").into())
}

/// What one capped run of the binary did.
struct Run {
    /// The command, for findings.
    command: String,
    code: Option<i32>,
    /// The signal that ended it, if one did.
    signal: Option<i32>,
    stderr: String,
    stdout: String,
    timed_out: bool,
    elapsed: Duration,
}

impl Run {
    fn text(&self) -> String {
        format!("{}{}", self.stdout, self.stderr)
    }
}

/// `hadou ARGS` under `prlimit --as=MEMORY_CAP`, killed past `limit` (stdin empty, stdout and
/// stderr drained by threads).
fn hadou_capped(args: &[OsString], limit: Duration) -> Run {
    let mut cmd = Command::new("prlimit");
    cmd.arg(format!("--as={MEMORY_CAP}"))
        .arg("--")
        .arg(binary())
        .args(args)
        .current_dir(common::root())
        .env("HADOU_VALIDATION", "1")
        .env("XDG_RUNTIME_DIR", std::env::var_os("XDG_RUNTIME_DIR").unwrap_or_else(|| "/tmp".into()))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let command = format!(
        "prlimit --as={MEMORY_CAP} -- hadou {}",
        args.iter().map(|a| a.to_string_lossy()).collect::<Vec<_>>().join(" ")
    );
    let start = Instant::now();
    let mut child = cmd.spawn().expect("run prlimit (util-linux) and hadou");
    let drain = |mut pipe: Box<dyn std::io::Read + Send>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            let _ = pipe.read_to_end(&mut bytes);
            String::from_utf8_lossy(&bytes).into_owned()
        })
    };
    let stdout = drain(Box::new(child.stdout.take().unwrap()));
    let stderr = drain(Box::new(child.stderr.take().unwrap()));
    let mut timed_out = false;
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait for hadou") {
            break s;
        }
        if start.elapsed() > limit {
            timed_out = true;
            let _ = child.kill();
            break child.wait().expect("reap hadou");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    Run {
        command,
        code: status.code(),
        signal: std::os::unix::process::ExitStatusExt::signal(&status),
        stderr: stderr.join().unwrap_or_default(),
        stdout: stdout.join().unwrap_or_default(),
        timed_out,
        elapsed: start.elapsed(),
    }
}

fn os(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<OsString> {
    args.iter().map(|a| a.as_ref().to_owned()).collect()
}

/// The checks every run gets: it ended by itself, with an allowed exit code, without a panic,
/// and with an `error:` line naming one of `names` when it exited with `error_code`.
fn check_run(run: &Run, allowed: &[i32], error_code: i32, names: &[&str]) -> Result<(), String> {
    if run.timed_out {
        return Err(format!("ran past its limit ({:.1} s) and was killed", run.elapsed.as_secs_f64()));
    }
    let Some(code) = run.code else {
        return Err(format!(
            "killed by signal {:?} (6 is an abort: e.g. an allocation failed under the memory cap)",
            run.signal
        ));
    };
    if run.text().contains("panicked") {
        return Err(format!("panicked (exit {code})"));
    }
    if !allowed.contains(&code) {
        return Err(format!("exit code {code}, expected one of {allowed:?}"));
    }
    if code == error_code {
        let Some(line) = run.stderr.lines().find(|l| l.starts_with("error:")) else {
            return Err(format!("exit {code} without an `error:` line"));
        };
        if !names.iter().any(|n| line.contains(n)) {
            return Err(format!("the error names none of {names:?}: {line}"));
        }
    }
    Ok(())
}

/// Failing cases of one property, their inputs kept for replay.
struct Findings {
    property: &'static str,
    dir: PathBuf,
    failures: Vec<String>,
    /// How many runs ended with each exit code (None: a signal), for the summary.
    codes: std::collections::BTreeMap<Option<i32>, usize>,
}

impl Findings {
    fn new(property: &'static str) -> Findings {
        let base = std::env::var_os("HADOU_FUZZ_FINDINGS").map(PathBuf::from).unwrap_or_else(|| {
            std::env::temp_dir().join(format!("hadou-fuzz-findings-{}", std::process::id()))
        });
        Findings { property, dir: base.join(property), failures: Vec::new(), codes: Default::default() }
    }

    /// Keeps the case's files (copies of `inputs`) and its run, with `why`.
    fn record(&mut self, case: &str, inputs: &[&Path], run: Option<&Run>, why: &str) {
        let dir = self.dir.join(case);
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for input in inputs {
            if let Some(name) = input.file_name() {
                let _ = std::fs::copy(input, dir.join(name));
            }
        }
        let mut note = format!("{}: {case}: {why}\n", self.property);
        if let Some(run) = run {
            note += &format!(
                "{}\n(exit {:?}, {:.2} s)\n{}",
                run.command,
                run.code,
                run.elapsed.as_secs_f64(),
                run.text()
            );
        }
        std::fs::write(dir.join("finding.txt"), &note).unwrap();
        self.failures.push(format!("{case}: {why} (kept in {})", dir.display()));
    }

    fn count(&mut self, run: &Run) {
        *self.codes.entry(run.code).or_default() += 1;
        if std::env::var_os("HADOU_FUZZ_VERBOSE").is_some() {
            let last = run.stderr.lines().rev().find(|l| l.starts_with("error:")).unwrap_or("");
            eprintln!("{}: exit {:?} {:.2} s {last}", self.property, run.code, run.elapsed.as_secs_f64());
        }
    }

    fn assert_none(&self, cases: usize) {
        eprintln!("{}: {cases} cases, exit codes {:?}", self.property, self.codes);
        assert!(
            self.failures.is_empty(),
            "{}: {} of {cases} cases failed:\n{}",
            self.property,
            self.failures.len(),
            self.failures.join("\n")
        );
    }
}

// ------------------------------------------------------------------------------- glTF / GLB

/// The glTF seeds: the hierarchy scene (volume material, matrix and TRS nodes), a scene with a
/// camera, a directional light and a triangle strip, one with a sparse accessor (the issue's
/// bomb declares its vertices there) drawn without indices, and one with an accessor of zeros
/// (no bufferView); each as a Writer.
fn gltf_seeds() -> Vec<Writer> {
    let volume = json!({
        "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.5, 0.3, 1.0] },
        "extensions": { "KHR_materials_volume": { "thicknessFactor": 1.0, "attenuationDistance": 0.5,
            "attenuationColor": [0.9, 0.6, 0.4] } }
    });
    let mut hierarchy = gltf_writer::hierarchy(true, true, Some(volume));
    hierarchy.uses("KHR_materials_volume");

    let mut lit = Writer::default();
    let strip = lit.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.5]], true);
    let m = lit.mesh(vec![json!({ "attributes": { "POSITION": strip }, "mode": 5 })]);
    lit.node(json!({ "mesh": m, "translation": [0.0, 0.0, -3.0] }));
    lit.cameras
        .push(json!({ "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1, "zfar": 100.0 } }));
    lit.node(json!({ "camera": 0, "translation": [0.0, 0.5, 2.0] }));
    lit.lights.push(json!({ "type": "directional", "color": [1.0, 0.9, 0.8], "intensity": 2.0 }));
    lit.node(json!({ "extensions": { "KHR_lights_punctual": { "light": 0 } }, "rotation": [-0.38, 0.0, 0.0, 0.92] }));
    lit.uses("KHR_lights_punctual");
    lit.scene_roots = vec![0, 1, 2];

    let mut sparse = Writer::default();
    let base = sparse.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]], true);
    let idx = sparse.view(&[1u16, 3].iter().flat_map(|i: &u16| i.to_le_bytes()).collect::<Vec<_>>(), 0);
    let values = sparse
        .view(&[0.5f32, 0.5, 1.0, 1.5, 1.5, 0.5].iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>(), 0);
    sparse.views[idx].as_object_mut().unwrap().remove("target");
    sparse.views[values].as_object_mut().unwrap().remove("target");
    // A sparse accessor without a bufferView: zeros, then two vertices replaced.
    sparse.accessors.push(json!({
        "componentType": 5126, "count": 4, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [1.5, 1.5, 1.0],
        "sparse": { "count": 2, "indices": { "bufferView": idx, "componentType": 5123 },
                    "values": { "bufferView": values } }
    }));
    let _ = base;
    let m = sparse.mesh(vec![json!({ "attributes": { "POSITION": 1 }, "mode": 5 })]);
    sparse.node(json!({ "mesh": m }));
    sparse.node(json!({ "mesh": m, "translation": [2.0, 0.0, 0.0] }));
    sparse.scene_roots = vec![0, 1];

    // Positions without a bufferView (all zeros, as glTF allows) and indices that make one
    // triangle of them non-degenerate through a second, ordinary accessor: a count here costs
    // no bytes in the file.
    let mut zeros = Writer::default();
    let real = zeros.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], true);
    zeros.accessors.push(json!({ "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [0.0, 0.0, 0.0] }));
    let idx = zeros.indices(&[0, 1, 2], IndexWidth::U16);
    // The same zeros made sparse (one vertex replaced), drawn by the same indices.
    let at = zeros.view(&2u32.to_le_bytes(), 0);
    let value = zeros.view(&[0.0f32, 0.0, 1.0].iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>(), 0);
    for v in [at, value] {
        zeros.views[v].as_object_mut().unwrap().remove("target");
    }
    zeros.accessors.push(json!({
        "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [0.0, 0.0, 1.0],
        "sparse": { "count": 1, "indices": { "bufferView": at, "componentType": 5125 }, "values": { "bufferView": value } }
    }));
    let m = zeros.mesh(vec![
        json!({ "attributes": { "POSITION": real }, "indices": idx, "mode": 4 }),
        json!({ "attributes": { "POSITION": 1 }, "mode": 4 }),
        json!({ "attributes": { "POSITION": 3 }, "indices": idx, "mode": 4 }),
    ]);
    zeros.node(json!({ "mesh": m }));
    zeros.scene_roots = vec![0];
    vec![hierarchy, lit, sparse, zeros]
}

/// A structural glTF mutation aimed at the decoders' budgets (issue 24, item 1): an accessor's
/// count made huge (the 560-byte bomb declared 2²⁴ sparse vertices), a mesh node repeated 400
/// times (400 meshes sharing one accessor), the scene's roots listed over and over, a mesh's
/// primitives repeated.
fn inflate(root: &mut Value, rng: &mut Rng) {
    match below(rng, 6) {
        0 | 4 | 5 => {
            if let Some(accessors) = root.get_mut("accessors").and_then(Value::as_array_mut) {
                // Mostly an accessor whose count costs no bytes in the file (sparse, or zeros
                // without a bufferView): the bombs' kind.
                let free: Vec<usize> = (0..accessors.len())
                    .filter(|&k| {
                        accessors[k].get("sparse").is_some() || accessors[k].get("bufferView").is_none()
                    })
                    .collect();
                let k = if !free.is_empty() && below(rng, 4) != 0 {
                    free[below(rng, free.len())]
                } else {
                    below(rng, accessors.len())
                };
                let count =
                    [1u64 << 24, 1 << 24, 1 << 23, 1 << 22, 0x7FFF_FFFF, 0xFFFF_FFFF, 0][below(rng, 7)];
                accessors[k]["count"] = json!(count);
            }
        }
        1 => {
            let Some(nodes) = root.get_mut("nodes").and_then(Value::as_array_mut) else { return };
            let Some(k) = nodes.iter().position(|n| n.get("mesh").is_some()) else { return };
            let first = nodes.len();
            let copy = nodes[k].clone();
            nodes.extend(std::iter::repeat_n(copy, 400));
            if let Some(roots) = root.pointer_mut("/scenes/0/nodes").and_then(Value::as_array_mut) {
                roots.extend((first..first + 400).map(|i| json!(i)));
            }
        }
        2 => {
            if let Some(roots) = root.pointer_mut("/scenes/0/nodes").and_then(Value::as_array_mut) {
                let copy = roots.clone();
                for _ in 0..100 {
                    roots.extend(copy.iter().cloned());
                }
            }
        }
        _ => {
            if let Some(prims) = root.pointer_mut("/meshes/0/primitives").and_then(Value::as_array_mut) {
                let copy = prims.clone();
                for _ in 0..400 {
                    prims.extend(copy.iter().cloned());
                }
            }
        }
    }
}

/// The JSON of `w` with `uri` for its buffer: inflated (half of the cases), then mutated.
fn gltf_json(w: &Writer, uri: Option<String>, rng: &mut Rng) -> String {
    let mut root = w.json(uri);
    let inflated = below(rng, 2) == 0;
    if inflated {
        inflate(&mut root, rng);
    }
    let text = serde_json::to_string(&root).unwrap();
    if inflated && below(rng, 3) != 0 {
        text
    } else {
        mutate::mutate_json(&text, rng)
    }
}

/// Writes case `i`'s mutated glTF into `dir`: one of the seeds as a GLB (its JSON mutated, or its
/// container), a .gltf with an embedded buffer, or a .gltf with an external .bin (cut short or
/// flipped in a third of the cases). Returns the scene file and every file written.
fn gltf_case(dir: &Path, seeds: &[Writer], rng: &mut Rng) -> (PathBuf, Vec<PathBuf>) {
    let w = &seeds[below(rng, seeds.len())];
    match below(rng, 4) {
        0 | 1 => {
            let path = dir.join("case.glb");
            let bytes = if below(rng, 2) == 0 {
                mutate::glb(gltf_json(w, None, rng).as_bytes(), &w.bin)
            } else {
                mutate::mutate_glb(&w.glb(), rng)
            };
            std::fs::write(&path, bytes).unwrap();
            (path.clone(), vec![path])
        }
        2 => {
            let path = w.write_embedded(dir, "case");
            let text = std::fs::read_to_string(&path).unwrap();
            let root: Value = serde_json::from_str(&text).unwrap();
            let data_uri = root.pointer("/buffers/0/uri").and_then(Value::as_str).map(str::to_owned);
            std::fs::write(&path, gltf_json(w, data_uri, rng)).unwrap();
            (path.clone(), vec![path])
        }
        _ => {
            let path = w.write_external(dir, "case");
            std::fs::write(&path, gltf_json(w, Some("case.bin".into()), rng)).unwrap();
            let bin = dir.join("case.bin");
            if below(rng, 3) == 0 {
                let mut b = std::fs::read(&bin).unwrap();
                if below(rng, 2) == 0 {
                    b.truncate(below(rng, b.len().max(1)));
                } else if !b.is_empty() {
                    let at = below(rng, b.len());
                    b[at] ^= 0x80;
                }
                std::fs::write(&bin, b).unwrap();
            }
            (path.clone(), vec![path, bin])
        }
    }
}

/// What the glTF 2.0 specification requires of a file the loader accepts: a GLB's header length
/// is the file's length, and `asset.version` is a 2.x version.
fn check_container(scene: &Path) -> Result<(), String> {
    let bytes = std::fs::read(scene).unwrap();
    let json = if bytes.starts_with(b"glTF") {
        let declared = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
        if declared != bytes.len() {
            return Err(format!("a GLB whose header says {declared} bytes is {} bytes long", bytes.len()));
        }
        mutate::glb_parts(&bytes).map(|(j, _)| j).unwrap_or_default()
    } else {
        bytes
    };
    let version = serde_json::from_slice::<Value>(&json)
        .ok()
        .and_then(|v| v.pointer("/asset/version").and_then(Value::as_str).map(str::to_owned));
    match version {
        Some(v) if v.split('.').next() == Some("2") => Ok(()),
        v => Err(format!("asset.version {v:?} (glTF 2.x expected)")),
    }
}

/// What docs/scene-format.md promises of an accepted scene (its "Numeric limits"), for a glTF.
fn check_scene_limits(s: &hadou::scene::Scene) -> Result<(), String> {
    let finite = |v: f64| (v as f32).is_finite();
    let c = &s.camera;
    if !(c.near >= f32::MIN_POSITIVE as f64 && c.far / c.near <= MAX_FAR_NEAR_RATIO) {
        return Err(format!("camera near {} far {}", c.near, c.far));
    }
    if !(c.far <= MAX_EXTENT && c.position.abs().max_element() <= MAX_EXTENT) {
        return Err(format!("camera far {} position {}", c.far, c.position));
    }
    let vp = c.view_projection(16, 16).to_cols_array();
    if !vp.iter().all(|&v| finite(v)) {
        return Err(format!("view-projection {vp:?}"));
    }
    // Lights are not limited (issue 26): the frame is pre-exposed so a lit surface fits RGBA16F.
    let (lit, p) = (hadou::effects::tonemap::lit_max(s), hadou::effects::tonemap::pre_exposure(s));
    if !(lit.is_finite() && lit * p <= MAX_HDR) {
        return Err(format!("ambient + lights {lit} × pre-exposure {p}"));
    }
    for m in &s.meshes {
        if !m.mesh.positions.iter().flatten().all(|v| v.is_finite()) {
            return Err(format!("mesh \"{}\": a non-finite position", m.name));
        }
    }
    for inst in &s.instances {
        let m = inst.transform.matrix.to_cols_array();
        let n = inst.transform.normal_matrix().to_cols_array();
        if !m.iter().chain(&n).all(|&v| finite(v)) {
            return Err(format!("instance world matrix {m:?}"));
        }
    }
    if let Some(hadou::scene::gltf::SceneBounds { all: (lo, hi), .. }) =
        hadou::scene::gltf::scene_bounds(&s.meshes, &s.instances)
    {
        let extent = lo.abs().max(hi.abs()).max_element();
        if extent.is_nan() || extent > MAX_EXTENT {
            return Err(format!("content extent {extent:e} (limit 2^48 = {MAX_EXTENT:e})"));
        }
        let size = (hi - lo).max_element();
        if size.is_nan() || size < 1e-6 {
            return Err(format!("content size {size:e} (below 1e-6)"));
        }
    }
    Ok(())
}

/// Counts of the glTF property, and what is left of its render budget.
#[derive(Default)]
struct GltfStats {
    accepted: usize,
    render_budget: usize,
    render_codes: std::collections::BTreeMap<Option<i32>, usize>,
}

/// Runs one glTF case (`scene` in `dir`, written as `case.*`): refused with an `error:` naming
/// it, or accepted within the numeric limits and, while the budget lasts, rendered cleanly.
fn gltf_check(
    label: &str,
    dir: &Path,
    scene: &Path,
    files: &[PathBuf],
    findings: &mut Findings,
    stats: &mut GltfStats,
) {
    let inputs: Vec<&Path> = files.iter().map(PathBuf::as_path).collect();
    // The output's folder is a file: an accepted scene is refused after the whole load, before
    // any GPU work; a refused scene never gets that far.
    std::fs::write(dir.join("not-a-folder"), b"").unwrap();
    let blocked = dir.join("not-a-folder").join("out.png");
    let run = hadou_capped(&os(&[&"render", &scene, &"-o", &blocked, &"--size", &"16x16"]), CASE_LIMIT);
    findings.count(&run);
    let names = ["case.glb", "case.gltf", "case.bin"];
    if let Err(why) = check_run(&run, &[1], 1, &["case.glb", "case.gltf", "case.bin", "not-a-folder"]) {
        return findings.record(label, &inputs, Some(&run), &why);
    }
    if !run.stderr.contains("not-a-folder") {
        let _ = std::fs::remove_dir_all(dir);
        return;
    }
    stats.accepted += 1;
    if let Err(why) = check_container(scene) {
        return findings.record(label, &inputs, Some(&run), &format!("accepted: {why}"));
    }
    // Accepted by the loader within the cap: safe to load here and check the limits.
    match hadou::scene::load_scene(scene) {
        Ok(s) => {
            if let Err(why) = check_scene_limits(&s) {
                return findings.record(
                    label,
                    &inputs,
                    None,
                    &format!("accepted beyond the numeric limits: {why}"),
                );
            }
        }
        Err(e) => {
            return findings.record(
                label,
                &inputs,
                Some(&run),
                &format!("the CLI accepted it, load_scene says: {e}"),
            );
        }
    }
    if stats.render_budget > 0 {
        stats.render_budget -= 1;
        let out = dir.join("out.png");
        let run = hadou_capped(&os(&[&"render", &scene, &"-o", &out, &"--size", &"16x16"]), RENDER_LIMIT);
        *stats.render_codes.entry(run.code).or_default() += 1;
        if let Err(why) = check_run(&run, &[0, 1], 1, &names) {
            return findings.record(label, &inputs, Some(&run), &format!("render: {why}"));
        }
        if run.code == Some(0) && !out.is_file() {
            return findings.record(label, &inputs, Some(&run), "render: exit 0 without the PNG");
        }
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// Inputs that are no regular file, each named `file_name` in its own folder under `root`: a
/// FIFO nobody writes (a reader that opens it waits forever), a folder, an empty file; and
/// `/dev/zero` (endless) when `dev_zero`. Labels and paths.
fn special_inputs(root: &Path, file_name: &str, dev_zero: bool) -> Vec<(String, PathBuf)> {
    let mut out = Vec::new();
    for kind in ["fifo", "folder", "empty"] {
        let dir = root.join(format!("special-{kind}"));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(file_name);
        match kind {
            "fifo" => {
                let made = Command::new("mkfifo").arg(&path).status().expect("run mkfifo (coreutils)");
                assert!(made.success(), "mkfifo {}", path.display());
            }
            "folder" => std::fs::create_dir(&path).unwrap(),
            _ => std::fs::write(&path, b"").unwrap(),
        }
        out.push((format!("special-{kind}"), path));
    }
    if dev_zero {
        out.push(("special-dev-zero".into(), PathBuf::from("/dev/zero")));
    }
    out
}

/// The files of tests/data/fuzz/`kind` (inputs that once failed, replayed first every run).
fn corpus(kind: &str) -> Vec<PathBuf> {
    let dir = common::root().join("tests/data/fuzz").join(kind);
    let mut out: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e != "md"))
        .collect();
    out.sort();
    out
}

/// Mutated glTF and GLB files (after the corpus of tests/data/fuzz/gltf): the loader refuses
/// each with an `error:` naming the file, within the time limit and the memory cap, or accepts a
/// scene within the numeric limits; a few accepted ones are rendered (16x16, validation on) to
/// exit 0 with a PNG or 1 with an error.
#[test]
fn mutated_gltf_files_are_refused_cleanly_or_keep_the_limits() {
    let n = cases();
    let seeds = gltf_seeds();
    let mut findings = Findings::new("gltf");
    // Rendering costs a second or more per case: a few per run, more in a long run.
    let mut stats = GltfStats { render_budget: (n / 8).max(2), ..GltfStats::default() };
    // Scenes and a buffer that are no regular file (the glTF's own .bin a FIFO).
    let special_root = common::cli::scratch("fuzz-gltf-special");
    let mut specials = special_inputs(&special_root, "case.glb", false);
    let fifo_bin = special_inputs(&special_root.join("bin"), "case.bin", false).remove(0).1;
    let with_fifo = fifo_bin.with_file_name("case.gltf");
    let text = serde_json::to_string(&seeds[0].json(Some("case.bin".into()))).unwrap();
    std::fs::write(&with_fifo, text).unwrap();
    specials.push(("special-fifo-buffer".into(), with_fifo));
    for (label, scene) in &specials {
        let dir = scene.parent().unwrap().to_path_buf();
        gltf_check(label, &dir, scene, std::slice::from_ref(scene), &mut findings, &mut stats);
    }
    let corpus = corpus("gltf");
    for file in &corpus {
        let name = file.file_name().unwrap().to_string_lossy().into_owned();
        let dir = common::cli::scratch(&format!("fuzz-gltf-{name}"));
        let scene = dir.join(format!("case.{}", file.extension().unwrap().to_string_lossy()));
        std::fs::copy(file, &scene).unwrap();
        gltf_check(&name, &dir, &scene, std::slice::from_ref(&scene), &mut findings, &mut stats);
    }
    for i in 0..n {
        let mut rng = case_rng(0x617c_f001, i);
        let dir = common::cli::scratch(&format!("fuzz-gltf-{i}"));
        let (scene, files) = gltf_case(&dir, &seeds, &mut rng);
        gltf_check(&format!("case-{i}"), &dir, &scene, &files, &mut findings, &mut stats);
    }
    eprintln!(
        "gltf: {} special inputs, {} corpus files and {n} cases, {} accepted by the loader; renders' exit codes {:?}",
        specials.len(),
        corpus.len(),
        stats.accepted,
        stats.render_codes
    );
    findings.assert_none(specials.len() + corpus.len() + n);
}

// ------------------------------------------------------------------------------- compare

/// The image seeds: an RGBA PNG, an RGBA (hdr) and a one-channel (depth) tiled OpenEXR as hadou
/// writes them, and one- and three-channel scanline OpenEXRs; small, with varied values (an
/// infinite depth included, as `render --aov depth` writes for the sky).
fn image_seeds(dir: &Path) -> Vec<PathBuf> {
    let (w, h) = (5u32, 4u32);
    let rgba: Vec<u8> = (0..w * h * 4).map(|i| (i * 37 % 251) as u8).collect();
    let png = dir.join("seed.png");
    std::fs::write(&png, hadou::output::encode_png(&png, w, h, &rgba).unwrap()).unwrap();
    let hdr = hadou::AovImage {
        width: w,
        height: h,
        channels: 4,
        data: (0..w * h * 4).map(|i| i as f32 * 0.25).collect(),
    };
    let exr4 = dir.join("seed4.exr");
    std::fs::write(&exr4, hadou::output::encode_exr(&exr4, "hdr", &hdr).unwrap()).unwrap();
    let depth = hadou::AovImage {
        width: w,
        height: h,
        channels: 1,
        data: (0..w * h).map(|i| if i == 3 { f32::INFINITY } else { 1.0 + i as f32 }).collect(),
    };
    let exr1 = dir.join("seed1.exr");
    std::fs::write(&exr1, hadou::output::encode_exr(&exr1, "depth", &depth).unwrap()).unwrap();
    // Scanline files as other tools write them (hadou writes tiles), without chunkCount.
    let scan1 = dir.join("scan1.exr");
    std::fs::write(&scan1, mutate::scanline_exr(w as i32, h as i32, &["Y"], &depth.data)).unwrap();
    let scan3 = dir.join("scan3.exr");
    let rgb: Vec<f32> = (0..w * h * 3).map(|i| (i % 7) as f32 * 0.5).collect();
    std::fs::write(&scan3, mutate::scanline_exr(w as i32, h as i32, &["B", "G", "R"], &rgb)).unwrap();
    vec![png, exr4, exr1, scan1, scan3]
}

/// PNG and OpenEXR files with mutated headers (dimensions, channel lists, sizes) and bodies,
/// compared with their seed by `hadou compare` (either side), after the corpus of
/// tests/data/fuzz/compare (each compared with itself): exit 0 or 1 with a whole heat map, or 2
/// with an `error:` naming the file and no heat map, within the time limit and the memory cap.
#[test]
fn mutated_images_are_compared_or_refused_cleanly() {
    let n = cases();
    let seed_dir = common::cli::scratch("fuzz-image-seeds");
    let seeds = image_seeds(&seed_dir);
    let mut findings = Findings::new("compare");
    // Either side no regular file: refused (exit 2), naming it.
    let specials = special_inputs(&common::cli::scratch("fuzz-image-special"), "case.png", true);
    for (label, special) in &specials {
        let name = if special.starts_with("/dev") { "/dev/zero" } else { "case.png" };
        for (a, b) in [(special, &seeds[0]), (&seeds[0], special)] {
            let run = hadou_capped(&os(&[&"compare", a, b]), CASE_LIMIT);
            findings.count(&run);
            if let Err(why) = check_run(&run, &[2], 2, &[name]) {
                findings.record(label, &[], Some(&run), &why);
            }
        }
    }
    let corpus = corpus("compare");
    for file in &corpus {
        // Each against itself: a file that decodes is the same (exit 0).
        let name = file.file_name().unwrap().to_string_lossy().into_owned();
        let dir = common::cli::scratch(&format!("fuzz-image-{name}"));
        let case = dir.join(format!("case.{}", file.extension().unwrap().to_string_lossy()));
        std::fs::copy(file, &case).unwrap();
        let run = hadou_capped(&os(&[&"compare", &case, &case]), CASE_LIMIT);
        findings.count(&run);
        match check_run(&run, &[0, 2], 2, &["case."]) {
            Err(why) => findings.record(&name, &[&case], Some(&run), &why),
            Ok(()) => drop(std::fs::remove_dir_all(&dir)),
        }
    }
    for i in 0..n {
        let mut rng = case_rng(0x1a46_e002, i);
        // Three cases in four start from a sidecar that matches, so mutations reach the render
        // and the comparison, not only the refusals.
        let seed = match below(&mut rng, 4) {
            0 => &seeds[below(&mut rng, seeds.len())],
            _ => &seeds[below(&mut rng, MATCHING_SIDECAR_SEEDS)],
        };
        let bytes = std::fs::read(seed).unwrap();
        let mut mutated = if seed.extension().is_some_and(|e| e == "png") {
            mutate::mutate_png(&bytes, &mut rng)
        } else {
            mutate::mutate_exr(&bytes, &mut rng)
        };
        if below(&mut rng, 4) == 0 {
            mutated = if seed.extension().is_some_and(|e| e == "png") {
                mutate::mutate_png(&mutated, &mut rng)
            } else {
                mutate::mutate_exr(&mutated, &mut rng)
            };
        }
        let dir = common::cli::scratch(&format!("fuzz-image-{i}"));
        let name = format!("case.{}", seed.extension().unwrap().to_string_lossy());
        let case = dir.join(&name);
        std::fs::write(&case, &mutated).unwrap();
        let heat = dir.join("heat.png");
        let (a, b) = if below(&mut rng, 2) == 0 {
            (seed.as_path(), case.as_path())
        } else {
            (case.as_path(), seed.as_path())
        };
        let run = hadou_capped(&os(&[&"compare", &a, &b, &"--heatmap", &heat]), CASE_LIMIT);
        findings.count(&run);
        if let Err(why) = check_run(&run, &[0, 1, 2], 2, &[&name]) {
            findings.record(&format!("case-{i}"), &[&case], Some(&run), &why);
            continue;
        }
        // The heat map is written whole when the images were compared, and not at all on an error.
        let heat_ok = match run.code {
            Some(2) => !heat.exists(),
            _ => image::open(&heat).is_ok_and(|h| h.width() > 0 && h.height() > 0),
        };
        if !heat_ok {
            findings.record(
                &format!("case-{i}"),
                &[&case],
                Some(&run),
                "--heatmap missing, unreadable or left on an error",
            );
            continue;
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    findings.assert_none(2 * specials.len() + corpus.len() + n);
}

// ------------------------------------------------------------------------------- profile-diff

/// A `profile --json` file measured here (builtin:energy_wave, 16x16, 8 frames: more than the 6
/// a 95% interval needs, and a second or two on lavapipe), the baseline of every case.
fn measured_profile(dir: &Path) -> PathBuf {
    let path = dir.join("measured.json");
    let out = common::cli::hadou(&[
        "profile",
        "builtin:energy_wave",
        "--size",
        "16x16",
        "--frames",
        "8",
        "--warmup",
        "0",
        "--json",
        common::cli::s(&path),
    ]);
    assert!(out.status.success(), "{}", common::cli::text(&out));
    path
}

/// A synthetic profile file with `runs` runs of `frames` frames per row (what `profile --ab`
/// pools), so mutations meet the cluster bootstrap too.
fn synthetic_profile(measured: &Value, runs: usize, frames: usize, rng: &mut Rng) -> Value {
    let mut v = measured.clone();
    let samples = v["samples"].as_object_mut().unwrap();
    for (_, row) in samples.iter_mut() {
        let base = 0.5 + rng.next() * 2.0;
        let r: Vec<Vec<f64>> =
            (0..runs).map(|_| (0..frames).map(|_| base * (1.0 + 0.05 * rng.next())).collect()).collect();
        row["runs"] = json!(r);
    }
    v
}

/// Mutations particular to the samples: a row's runs emptied, a run emptied, one sample left,
/// a sample negative, null or huge, a row removed or renamed, no rows at all, a row slower or
/// faster as a whole (returned: the row and the factor).
fn mutate_samples(v: &mut Value, rng: &mut Rng) -> Option<(String, f64)> {
    let samples = v.get_mut("samples").and_then(Value::as_object_mut)?;
    let names: Vec<String> = samples.keys().cloned().collect();
    if names.is_empty() {
        return None;
    }
    let name = names[below(rng, names.len())].clone();
    match below(rng, 11) {
        9 | 10 => {
            // A real change: the row's every sample slower (or faster) by a factor, so the gate
            // has regressions to find.
            let factor = [1.5, 2.0, 0.5, 1e6][below(rng, 4)];
            if let Some(runs) = samples[&name]["runs"].as_array_mut() {
                for x in runs.iter_mut().filter_map(Value::as_array_mut).flatten() {
                    if let Some(f) = x.as_f64() {
                        *x = json!(f * factor);
                    }
                }
            }
            return Some((name, factor));
        }
        0 => samples[&name]["runs"] = json!([]),
        1 => samples[&name]["runs"] = json!([[]]),
        2 => samples[&name]["runs"] = json!([[1.0]]),
        3 | 4 => {
            if let Some(run) = samples[&name]["runs"].get_mut(0).and_then(Value::as_array_mut) {
                if !run.is_empty() {
                    let at = below(rng, run.len());
                    run[at] = [json!(-1.0), json!(null), json!(1e308), json!(0.0), json!(-0.0)]
                        [below(rng, 5)]
                    .clone();
                }
            }
        }
        5 => {
            samples.remove(&name);
        }
        6 => {
            let row = samples.remove(&name).unwrap();
            samples.insert(format!("{name} renamed"), row);
        }
        7 => samples.clear(),
        _ => {
            for (_, row) in samples.iter_mut() {
                row["runs"] = json!([]);
            }
        }
    }
    None
}

/// Why the candidate `new` is broken for the gate, if it is (issue 24, item 4): a gated row of
/// the baseline (`gpu …`) missing or with fewer than two timed samples, or a negative sample.
fn broken_candidate(base: &Value, new_text: &str) -> Option<String> {
    let new: Value = serde_json::from_str(new_text).ok()?;
    let base_rows = base.get("samples")?.as_object()?;
    let new_rows = new.get("samples")?.as_object()?;
    for (name, row) in new_rows {
        let runs = row.get("runs").and_then(Value::as_array);
        let negative = runs
            .into_iter()
            .flatten()
            .filter_map(Value::as_array)
            .flatten()
            .any(|s| s.as_f64().is_some_and(|x| x < 0.0));
        if negative {
            return Some(format!("a negative sample in \"{name}\""));
        }
    }
    for name in base_rows.keys().filter(|n| n.starts_with("gpu ")) {
        let Some(row) = new_rows.get(name) else { return Some(format!("no row \"{name}\"")) };
        let timed = row
            .get("runs")
            .and_then(Value::as_array)
            .map(|runs| runs.iter().filter_map(Value::as_array).flatten().filter(|s| s.is_number()).count())
            .unwrap_or(0);
        if timed < 2 {
            return Some(format!("{timed} timed sample(s) in \"{name}\""));
        }
    }
    None
}

/// Mutated `profile --json` files as the candidate (or the baseline) of `hadou profile-diff`,
/// after the corpus of tests/data/fuzz/profile-diff: exit 0 or 1 with a `gate:` line, or 2 with an `error:` naming the file, within the limits; a
/// broken candidate never passes the gate.
#[test]
fn mutated_profiles_are_gated_or_refused_cleanly() {
    let n = cases();
    let seed_dir = common::cli::scratch("fuzz-profile-seeds");
    let measured_path = measured_profile(&seed_dir);
    let measured: Value = serde_json::from_str(&std::fs::read_to_string(&measured_path).unwrap()).unwrap();
    let mut findings = Findings::new("profile-diff");
    // Either side no regular file: refused (exit 2), naming it.
    let specials = special_inputs(&common::cli::scratch("fuzz-profile-special"), "case.json", true);
    for (label, special) in &specials {
        let name = if special.starts_with("/dev") { "/dev/zero" } else { "case.json" };
        for (a, b) in [(special, &measured_path), (&measured_path, special)] {
            let run = hadou_capped(&os(&[&"profile-diff", a, b, &"--resamples", &"200"]), CASE_LIMIT);
            findings.count(&run);
            if let Err(why) = check_run(&run, &[2], 2, &[name]) {
                findings.record(label, &[], Some(&run), &why);
            }
        }
    }
    // The corpus: NAME.base.json and NAME.new.json pairs, the candidate broken.
    let corpus: Vec<PathBuf> =
        corpus("profile-diff").into_iter().filter(|p| p.to_string_lossy().ends_with(".new.json")).collect();
    for new in &corpus {
        let name = new.file_name().unwrap().to_string_lossy().replace(".new.json", "");
        let base_file = new.with_file_name(format!("{name}.base.json"));
        let base: Value = serde_json::from_str(&std::fs::read_to_string(&base_file).unwrap()).unwrap();
        let text = std::fs::read_to_string(new).unwrap();
        let dir = common::cli::scratch(&format!("fuzz-profile-{name}"));
        profile_check(&name, &dir, &base, &text, true, None, &mut findings);
    }
    for i in 0..n {
        let mut rng = case_rng(0x9f0f_1003, i);
        let which = below(&mut rng, 3);
        let base = match which {
            0 => measured.clone(),
            1 => synthetic_profile(&measured, 1, 40, &mut rng),
            _ => synthetic_profile(&measured, 3, 12, &mut rng),
        };
        let mut new = base.clone();
        let mut slowed = None;
        let text = if below(&mut rng, 2) == 0 {
            slowed = mutate_samples(&mut new, &mut rng);
            let t = serde_json::to_string_pretty(&new).unwrap();
            if below(&mut rng, 3) == 0 {
                slowed = None;
                mutate::mutate_json(&t, &mut rng)
            } else {
                t
            }
        } else {
            mutate::mutate_json(&serde_json::to_string_pretty(&new).unwrap(), &mut rng)
        };
        let dir = common::cli::scratch(&format!("fuzz-profile-{i}"));
        // Mostly the candidate (the gate's point); sometimes the baseline is the broken one.
        let as_candidate = below(&mut rng, 4) != 0;
        // A gated row of a synthetic baseline (5% noise) made 1.5x or more slower in every sample,
        // nothing else changed: the ratio's interval lies within [1.5/1.05, 1.5·1.05], past the 5%
        // threshold, so the gate must fail (exit 1).
        let must_fail = slowed
            .filter(|(row, factor)| as_candidate && which != 0 && row.starts_with("gpu ") && *factor >= 1.5)
            .map(|(row, factor)| format!("\"{row}\" {factor}x slower in every sample"));
        profile_check(&format!("case-{i}"), &dir, &base, &text, as_candidate, must_fail, &mut findings);
    }
    findings.assert_none(2 * specials.len() + corpus.len() + n);
}

/// Runs `profile-diff` on `base` and the mutated `text` (as the candidate, or as the baseline)
/// in `dir`: exit 0 with `gate: pass`, 1 with `gate: FAIL`, or 2 with an `error:` naming the file;
/// never a pass for a broken candidate.
fn profile_check(
    label: &str,
    dir: &Path,
    base: &Value,
    text: &str,
    as_candidate: bool,
    must_fail: Option<String>,
    findings: &mut Findings,
) {
    let (base_path, case) = (dir.join("base.json"), dir.join("case.json"));
    std::fs::write(&base_path, serde_json::to_string_pretty(base).unwrap()).unwrap();
    std::fs::write(&case, text).unwrap();
    let (a, b) = if as_candidate { (&base_path, &case) } else { (&case, &base_path) };
    let run = hadou_capped(&os(&[&"profile-diff", a, b, &"--resamples", &"200"]), CASE_LIMIT);
    findings.count(&run);
    let inputs: [&Path; 2] = [&base_path, &case];
    if let Err(why) = check_run(&run, &[0, 1, 2], 2, &["case.json"]) {
        return findings.record(label, &inputs, Some(&run), &why);
    }
    let verdict = match run.code {
        Some(0) => "gate: pass",
        Some(1) => "gate: FAIL",
        _ => "",
    };
    if !run.stdout.contains(verdict) {
        return findings.record(
            label,
            &inputs,
            Some(&run),
            &format!("exit {:?} without `{verdict}`", run.code),
        );
    }
    if let Some(slower) = must_fail.filter(|_| run.code != Some(1)) {
        return findings.record(label, &inputs, Some(&run), &format!("{slower}, and the gate did not fail"));
    }
    if as_candidate && run.code == Some(0) {
        if let Some(why) = broken_candidate(base, text) {
            return findings.record(
                label,
                &inputs,
                Some(&run),
                &format!("gate: pass for a broken candidate: {why}"),
            );
        }
    }
    let _ = std::fs::remove_dir_all(dir);
}

// ------------------------------------------------------------------------------- test sidecars

/// The sidecar seeds: first those that match the case's scene and references (16x16, the depth
/// AOV; one with every key, one skipped), then every sidecar of tests/golden (other sizes and
/// AOVs: errors and failures to start from).
fn sidecar_seeds() -> Vec<Vec<u8>> {
    let mut seeds: Vec<Vec<u8>> = vec![
        b"# every key\nsize = \"16x16\"\ntime = 0.5\naovs = [\"depth\"]\n\n[tolerance]\nflip = 0.01\n\
          abs = 0.001\nrel = 0.001\npixels = 0.5\n"
            .to_vec(),
        b"size = \"16x16\"\naovs = [\"depth\"]\n".to_vec(),
        b"size = \"16x16\"\ntime = 2.0\n\n[tolerance]\npixels = 1.0\n".to_vec(),
        b"size = \"16x16\"\nskip = \"not today\"\n".to_vec(),
    ];
    let dir = common::root().join("tests/golden");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".test.toml"))
        .collect();
    paths.sort();
    seeds.extend(paths.iter().map(|p| std::fs::read(p).unwrap()));
    seeds
}

/// How many of `sidecar_seeds` match the case's scene and references.
const MATCHING_SIDECAR_SEEDS: usize = 4;

/// A scene folder for `hadou test`: `case.toml` (assets/scenes/single_cube.toml) and, in
/// `refs`, its references `case.png` and `case.depth.exr` at 16x16 (blessed once, in `template`).
fn sidecar_folder(template: &Path, dir: &Path, refs: &Path) {
    std::fs::create_dir_all(refs).unwrap();
    std::fs::copy(template.join("case.toml"), dir.join("case.toml")).unwrap();
    for name in ["case.png", "case.depth.exr"] {
        std::fs::copy(template.join("refs").join(name), refs.join(name)).unwrap();
    }
}

/// Runs `hadou test` on `dir` with the sidecar `refs/case.test.toml` (the case's input): exit 0
/// (passed or skipped), 1 (differs, or a reference it asks for is missing) or 2 with an error
/// naming the sidecar (or the scene's `[render] size`, which a sidecar without `size` keeps), on
/// stderr (`error:`) or in the scene's ERROR row, within the limits. The pixel budget is the
/// scene's 512x512: a larger sidecar `size` is refused before it is rendered.
fn sidecar_check(case: &str, dir: &Path, refs: &Path, findings: &mut Findings) {
    let sidecar = refs.join("case.test.toml");
    let args = os(&[&"test", &dir, &"--refs", &refs, &"--max-pixels", &"262144"]);
    let run = hadou_capped(&args, RENDER_LIMIT);
    findings.count(&run);
    // Errors are checked below: on stderr or in the table.
    let mut verdict = check_run(&run, &[0, 1, 2], -1, &[]);
    if verdict.is_ok() && run.code == Some(2) {
        // The sidecar, or the scene when the error is about its own [render] size (a sidecar
        // without `size` renders at the scene's).
        let named = |l: &&str| l.contains("case.test.toml") || l.contains("case.toml: [render] size");
        let on_stderr = run.stderr.lines().filter(|l| l.starts_with("error:")).find(named);
        let in_row = run.stdout.lines().filter(|l| l.starts_with("case") && l.contains("ERROR")).find(named);
        if on_stderr.is_none() && in_row.is_none() {
            verdict =
                Err("exit 2 without an error naming the sidecar (on stderr or in the ERROR row)".into());
        }
    }
    if let Err(why) = verdict {
        findings.record(case, &[&sidecar], Some(&run), &why);
    }
}

/// Mutated `hadou test` sidecars (`REFS/NAME.test.toml`: size, time, aovs, skip, [tolerance]),
/// after sidecars that are no regular file and the corpus of tests/data/fuzz/sidecar: `hadou test`
/// ends within the limits with exit 0, 1, or 2 and an error naming the sidecar; no panic, no
/// abort. The scene is single_cube, its references blessed once at 16x16.
#[test]
fn mutated_test_sidecars_are_run_or_refused_cleanly() {
    let n = cases();
    let mut findings = Findings::new("sidecar");
    let template = common::cli::scratch("fuzz-sidecar-template");
    std::fs::copy(common::root().join("assets/scenes/single_cube.toml"), template.join("case.toml")).unwrap();
    std::fs::create_dir_all(template.join("refs")).unwrap();
    std::fs::write(template.join("refs/case.test.toml"), "size = \"16x16\"\naovs = [\"depth\"]\n").unwrap();
    let bless = os(&[&"test", &template, &"--refs", &template.join("refs"), &"--bless"]);
    let run = hadou_capped(&bless, RENDER_LIMIT);
    assert_eq!(run.code, Some(0), "blessing the template: {}", run.text());
    // Sidecars that are no regular file (a FIFO nobody writes, a folder, an empty file), and a
    // link to /dev/zero (endless).
    let special_root = common::cli::scratch("fuzz-sidecar-special");
    let mut specials = special_inputs(&special_root, "case.test.toml", false);
    let zero = special_root.join("special-dev-zero");
    std::fs::create_dir_all(&zero).unwrap();
    std::os::unix::fs::symlink("/dev/zero", zero.join("case.test.toml")).unwrap();
    specials.push(("special-dev-zero".into(), zero.join("case.test.toml")));
    for (label, sidecar) in &specials {
        let refs = sidecar.parent().unwrap().to_path_buf();
        let dir = special_root.join(format!("{label}-scene"));
        std::fs::create_dir_all(&dir).unwrap();
        sidecar_folder(&template, &dir, &refs);
        sidecar_check(label, &dir, &refs, &mut findings);
    }
    let corpus = corpus("sidecar");
    for file in &corpus {
        let name = file.file_name().unwrap().to_string_lossy().into_owned();
        let dir = common::cli::scratch(&format!("fuzz-sidecar-{name}"));
        let refs = dir.join("refs");
        sidecar_folder(&template, &dir, &refs);
        std::fs::copy(file, refs.join("case.test.toml")).unwrap();
        sidecar_check(&name, &dir, &refs, &mut findings);
    }
    let seeds = sidecar_seeds();
    for i in 0..n {
        let mut rng = case_rng(0x51de_ca25, i);
        let dir = common::cli::scratch(&format!("fuzz-sidecar-{i}"));
        let refs = dir.join("refs");
        sidecar_folder(&template, &dir, &refs);
        // Three cases in four start from a sidecar that matches, so mutations reach the render
        // and the comparison, not only the refusals.
        let seed = match below(&mut rng, 4) {
            0 => &seeds[below(&mut rng, seeds.len())],
            _ => &seeds[below(&mut rng, MATCHING_SIDECAR_SEEDS)],
        };
        std::fs::write(refs.join("case.test.toml"), mutate::mutate_sidecar(seed, &mut rng)).unwrap();
        sidecar_check(&format!("case-{i}"), &dir, &refs, &mut findings);
    }
    findings.assert_none(specials.len() + corpus.len() + n);
}

// ------------------------------------------------------------------------------- the mutators

#[test]
fn mutators_change_what_they_are_meant_to() {
    // Number tokens outside strings only.
    let t = r#"{"a": [1, -2.5e-3], "b": "x1", "c": 1e5}"#;
    let found: Vec<&str> = mutate::json_numbers(t).iter().map(|&(s, e)| &t[s..e]).collect();
    assert_eq!(found, vec!["1", "-2.5e-3", "1e5"]);
    // A GLB reassembled from its parts is the writer's GLB (lengths right).
    let w = gltf_writer::hierarchy(true, false, None);
    let (json, bin) = mutate::glb_parts(&w.glb()).unwrap();
    assert_eq!(mutate::glb(&json, &bin), w.glb());
    // PNG CRC: the IHDR of a real PNG checks.
    let dir = common::cli::scratch("fuzz-mutators");
    let seeds = image_seeds(&dir);
    let png = std::fs::read(&seeds[0]).unwrap();
    assert_eq!(mutate::crc32(&png[12..29]), u32::from_be_bytes(png[29..33].try_into().unwrap()));
    // The OpenEXR header's attributes are found, with a 16-byte dataWindow.
    let exr = std::fs::read(&seeds[1]).unwrap();
    let attrs = mutate::exr_attributes(&exr);
    let window = attrs.iter().find(|a| a.name == "dataWindow").expect("a dataWindow");
    assert_eq!((window.kind.as_str(), window.value.len()), ("box2i", 16));
    assert!(attrs.iter().any(|a| a.name == "channels"));
    // Every seed decodes (compared with itself: the same), so mutations start from valid files.
    for seed in &seeds {
        let out = common::cli::hadou(&["compare", common::cli::s(seed), common::cli::s(seed)]);
        assert_eq!(out.status.code(), Some(0), "{}", common::cli::text(&out));
    }
    // Every mutator changes its input for most draws.
    let mut rng = Rng(7);
    let changed = (0..50).filter(|_| mutate::mutate_exr(&exr, &mut rng) != exr).count();
    assert!(changed >= 40, "{changed} of 50 EXR mutations changed the file");
    let changed = (0..50).filter(|_| mutate::mutate_png(&png, &mut rng) != png).count();
    assert!(changed >= 40, "{changed} of 50 PNG mutations changed the file");
    let glb = w.glb();
    let changed = (0..50).filter(|_| mutate::mutate_glb(&glb, &mut rng) != glb).count();
    assert!(changed >= 40, "{changed} of 50 GLB mutations changed the file");
    for seed in sidecar_seeds() {
        let changed = (0..50).filter(|_| mutate::mutate_sidecar(&seed, &mut rng) != seed).count();
        assert!(
            changed >= 40,
            "{changed} of 50 sidecar mutations changed {:?}",
            String::from_utf8_lossy(&seed)
        );
    }
    // Mutators take their own output (cut short, lengths wrong, grown) without panicking or
    // growing without bound: 20 chains of 20.
    let text = serde_json::to_string(&w.json(None)).unwrap();
    for _ in 0..20 {
        let (mut e, mut p, mut g, mut t) = (exr.clone(), png.clone(), w.glb(), text.clone());
        let mut sc = sidecar_seeds().remove(0);
        for _ in 0..20 {
            e = mutate::mutate_exr(&e, &mut rng);
            p = mutate::mutate_png(&p, &mut rng);
            g = mutate::mutate_glb(&g, &mut rng);
            t = mutate::mutate_json(&t, &mut rng);
            sc = mutate::mutate_sidecar(&sc, &mut rng);
        }
    }
}
