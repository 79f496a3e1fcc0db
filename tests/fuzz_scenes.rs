//! A fuzzing harness for the scene and OBJ loaders (issue 14): the valid scenes of assets/scenes
//! and the OBJ files of assets/meshes, mutated structurally (lines deleted, duplicated, swapped;
//! tokens swapped) and numerically (numbers replaced by 1e39, -0, nan, inf, 1e-46, huge counts).
//! Properties: loading never panics; every error has a line:col inside the text; every accepted
//! scene holds only numbers the GPU path can represent (docs/scene-format.md, "Numeric limits").
//! CPU only: parse and check, no rendering.
//!
//! `HADOU_FUZZ_CASES=N cargo test --test fuzz_scenes` runs N cases per property (default 48).

use std::path::{Path, PathBuf};

use hadou::scene::file::{MAX_EXTENT, MAX_FAR_NEAR_RATIO, MAX_HDR};
use hadou::scene::mesh::MeshError;
use hadou::scene::{parse_scene, Scene, SceneError};
use proptest::prelude::*;
use proptest::sample::Index;

/// Replacement numbers: past f32's range, signed zero, non-finite, below f32's subnormals, huge
/// or negative counts, and ordinary values.
const EXTREMES: &[&str] = &[
    "1e39",
    "-1e39",
    "-0",
    "-0.0",
    "nan",
    "inf",
    "-inf",
    "1e-46",
    "1e-40",
    "3.4e38",
    "4294967296",
    "18446744073709551615",
    "65536",
    "2048",
    "-1",
    "0",
    "1",
    "0.5",
    "1e20",
    "70000",
    "1e15",
];

fn files(dir: &str, ext: &str) -> Vec<(PathBuf, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut out: Vec<(PathBuf, String)> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == ext))
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            (p, text)
        })
        .collect();
    out.sort();
    out
}

#[derive(Clone, Debug)]
enum Mutation {
    Delete(Index),
    Duplicate(Index),
    SwapLines(Index, Index),
    SwapTokens(Index, Index),
    Number(Index, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        1 => any::<Index>().prop_map(Mutation::Delete),
        1 => any::<Index>().prop_map(Mutation::Duplicate),
        1 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
        1 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Mutation::SwapTokens(a, b)),
        // Numbers weigh most: the checks under test are numeric.
        4 => (any::<Index>(), 0..EXTREMES.len()).prop_map(|(a, v)| Mutation::Number(a, v)),
    ]
}

/// Byte ranges of the number-like tokens of `text` (a sign, digits, `.`, `e`, `_`).
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let starts = bytes[i].is_ascii_digit()
            && (i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_'));
        if !starts {
            i += 1;
            continue;
        }
        let start = if i > 0 && bytes[i - 1] == b'-' { i - 1 } else { i };
        let mut end = i;
        while end < bytes.len() && (bytes[end].is_ascii_alphanumeric() || matches!(bytes[end], b'.' | b'_'))
            || (end > 0 && end < bytes.len() && matches!(bytes[end], b'-' | b'+') && bytes[end - 1] == b'e')
        {
            end += 1;
        }
        out.push((start, end));
        i = end;
    }
    out
}

fn apply(text: &str, m: &Mutation) -> String {
    let mut lines: Vec<String> = text.split('\n').map(str::to_owned).collect();
    match m {
        Mutation::Delete(i) => {
            lines.remove(i.index(lines.len()));
        }
        Mutation::Duplicate(i) => {
            let i = i.index(lines.len());
            lines.insert(i, lines[i].clone());
        }
        Mutation::SwapLines(a, b) => {
            let (a, b) = (a.index(lines.len()), b.index(lines.len()));
            lines.swap(a, b);
        }
        Mutation::SwapTokens(a, b) => {
            let at = a.index(lines.len());
            let line = &mut lines[at];
            let mut tokens: Vec<&str> = line.split(' ').collect();
            let (x, y) = (b.index(tokens.len()), (b.index(tokens.len()) + 1) % tokens.len());
            tokens.swap(x, y);
            *line = tokens.join(" ");
        }
        Mutation::Number(a, v) => {
            let spans = numbers(text);
            if spans.is_empty() {
                return text.to_owned();
            }
            let (start, end) = spans[a.index(spans.len())];
            return format!("{}{}{}", &text[..start], EXTREMES[*v], &text[end..]);
        }
    }
    lines.join("\n")
}

/// line:col inside `text`: line in 1..=lines, column in 1..=(characters in that line + 1).
fn inside(text: &str, line: usize, column: usize) -> bool {
    let Some(l) = text.split('\n').nth(line.wrapping_sub(1)) else { return false };
    line >= 1 && column >= 1 && column <= l.chars().count() + 1
}

fn check_error(text: &str, e: &SceneError) -> Result<(), TestCaseError> {
    prop_assert!(inside(text, e.line, e.column), "error outside the text: {e}");
    Ok(())
}

fn f32_finite(v: f64) -> bool {
    (v as f32).is_finite()
}

/// What docs/scene-format.md promises of an accepted scene ("Numeric limits").
fn check_limits(s: &Scene) -> Result<(), TestCaseError> {
    let r = &s.render;
    prop_assert!(r.exposure >= f32::MIN_POSITIVE as f64 && f32_finite(r.exposure), "exposure {}", r.exposure);
    prop_assert!(r.background.min_element() >= 0.0 && r.background.max_element() <= MAX_HDR);
    // Lights are not limited (issue 26): the frame is pre-exposed so a lit surface fits RGBA16F.
    let lit = hadou::effects::tonemap::lit_max(s);
    let p = hadou::effects::tonemap::pre_exposure(s);
    prop_assert!(lit.is_finite() && lit * p <= MAX_HDR, "ambient + lights {lit} × pre-exposure {p}");
    let c = &s.camera;
    prop_assert!(c.near >= f32::MIN_POSITIVE as f64 && c.far / c.near <= MAX_FAR_NEAR_RATIO);
    prop_assert!(c.far <= MAX_EXTENT && c.position.abs().max_element() <= MAX_EXTENT);
    let vp = c.view_projection(64, 64).to_cols_array();
    prop_assert!(vp.iter().all(|&v| f32_finite(v)), "view-projection {vp:?}");
    for inst in &s.instances {
        let m = inst.transform.matrix.to_cols_array();
        let n = inst.transform.normal_matrix().to_cols_array();
        prop_assert!(m.iter().chain(&n).all(|&v| f32_finite(v)), "instance transform {m:?}");
    }
    for w in s.waves() {
        let most = w.keyframes.iter().filter_map(|k| k.intensity).fold(w.intensity, f64::max);
        prop_assert!(f32_finite(w.color.max_element() * most), "wave emission");
    }
    for g in s.metaballs() {
        prop_assert!(g.threshold >= f32::MIN_POSITIVE as f64 && f32_finite(g.threshold));
        for b in &g.balls {
            let r2 = (b.radius * b.radius) as f32;
            prop_assert!(r2.is_normal(), "ball radius {}", b.radius);
        }
    }
    for m in &s.meshes {
        prop_assert!(m.mesh.positions.iter().flatten().all(|v| v.is_finite()), "mesh \"{}\"", m.name);
    }
    Ok(())
}

/// Every OBJ file of the repository as a seed: the valid meshes of assets/meshes and the loader's
/// own malformed and edge cases (tests/data/obj, tests/bad_scenes), each a different start for
/// the mutations.
fn obj_seeds() -> Vec<(PathBuf, String)> {
    let seeds: Vec<_> = ["assets/meshes", "tests/data/obj", "tests/bad_scenes"]
        .iter()
        .flat_map(|d| files(d, "obj"))
        .collect();
    assert!(seeds.len() >= 20, "only {} OBJ seeds", seeds.len());
    seeds
}

fn cases() -> u32 {
    std::env::var("HADOU_FUZZ_CASES").ok().and_then(|n| n.parse().ok()).unwrap_or(48)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_scenes_are_refused_in_place_or_representable(
        which in any::<Index>(),
        mutations in prop::collection::vec(mutation(), 1..4),
    ) {
        let seeds = files("assets/scenes", "toml");
        let (path, text) = &seeds[which.index(seeds.len())];
        let text = mutations.iter().fold(text.clone(), |t, m| apply(&t, m));
        match parse_scene(&text, path) {
            Ok(scene) => check_limits(&scene)?,
            Err(e) => check_error(&text, &e)?,
        }
    }

    #[test]
    fn mutated_obj_files_are_refused_in_place_or_finite(
        which in any::<Index>(),
        mutations in prop::collection::vec(mutation(), 1..4),
    ) {
        let seeds = obj_seeds();
        let (path, text) = &seeds[which.index(seeds.len())];
        let text = mutations.iter().fold(text.clone(), |t, m| apply(&t, m));
        match hadou::scene::obj::parse_obj(&text, path) {
            Ok(mesh) => {
                let finite = mesh.positions.iter().chain(&mesh.normals).flatten().all(|v| v.is_finite());
                prop_assert!(finite, "non-finite vertex data accepted");
            }
            Err(MeshError::Obj { line, column, message, .. }) => {
                prop_assert!(inside(&text, line, column), "{line}:{column}: {message}");
            }
            Err(e) => prop_assert!(matches!(e, MeshError::Invalid(_)), "{e}"),
        }
    }
}

#[test]
fn number_tokens_are_found() {
    let spans = numbers("a = [1, -2.5e-3, x2]\nb = 1_000");
    let found: Vec<&str> = spans.iter().map(|&(s, e)| &"a = [1, -2.5e-3, x2]\nb = 1_000"[s..e]).collect();
    assert_eq!(found, vec!["1", "-2.5e-3", "1_000"]);
}
