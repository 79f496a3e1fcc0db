//! `hadou test`: the project's own scenes against their committed references (tests/golden),
//! and the bless → test → change cycle in a scratch folder. Validation is on in every run and a
//! validation message fails the scene.

mod common;

use common::cli::{hadou, s, scratch, text};

/// The `<testcase …>` element of scene `name` in a JUnit report, up to its end.
fn testcase<'a>(xml: &'a str, name: &str) -> &'a str {
    let start = xml.find(&format!("name=\"{name}\"")).unwrap_or_else(|| panic!("no testcase {name}:\n{xml}"));
    let rest = &xml[start..];
    let end = rest.find("<testcase").unwrap_or(rest.len());
    &rest[..end]
}

#[test]
fn the_projects_scenes_match_their_references() {
    let dir = scratch("project");
    let junit = dir.join("junit.xml");
    let out =
        hadou(&["test", "assets/scenes", "--refs", "tests/golden", "--junit", s(&junit), "--out", s(&dir)]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let scenes = std::fs::read_dir(common::asset("assets/scenes"))
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "toml"))
        .count();
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(xml.contains(&format!("tests=\"{scenes}\" failures=\"0\" errors=\"0\"")), "{xml}");
    assert!(text(&out).contains(&format!("hadou test: {scenes} scenes: {scenes} passed")), "{}", text(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bless_then_test_passes_and_a_changed_scene_fails_by_name() {
    let dir = scratch("cycle");
    let scenes = dir.join("scenes");
    let refs = dir.join("refs");
    std::fs::create_dir_all(&scenes).unwrap();
    std::fs::create_dir_all(&refs).unwrap();
    let cube = std::fs::read_to_string(common::asset("assets/scenes/single_cube.toml")).unwrap();
    std::fs::write(scenes.join("cube_a.toml"), &cube).unwrap();
    std::fs::write(scenes.join("cube_b.toml"), &cube).unwrap();
    std::fs::write(refs.join("cube_a.test.toml"), "size = \"40x30\"\naovs = [\"depth\"]\n").unwrap();
    std::fs::write(refs.join("cube_b.test.toml"), "size = \"40x30\"\n").unwrap();

    // Nothing blessed yet: each scene fails, saying how to make its reference.
    let out = hadou(&["test", s(&scenes), "--refs", s(&refs)]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(text(&out).contains("(make it with --bless)"), "{}", text(&out));

    let out = hadou(&["test", s(&scenes), "--refs", s(&refs), "--bless"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    for f in ["cube_a.png", "cube_a.depth.exr", "cube_b.png"] {
        assert!(refs.join(f).is_file(), "{f} blessed");
    }
    let out = hadou(&["test", s(&scenes), "--refs", s(&refs)]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));

    // cube_b's light turns: its PNG changes (its depth would not), and only it fails.
    std::fs::write(
        scenes.join("cube_b.toml"),
        cube.replace("direction = [-1, -2, -1]", "direction = [1, -2, -1]"),
    )
    .unwrap();
    let junit = dir.join("report.xml");
    let artifacts = dir.join("artifacts");
    let out = hadou(&["test", s(&scenes), "--refs", s(&refs), "--junit", s(&junit), "--out", s(&artifacts)]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    let table = text(&out);
    let row = |name: &str| table.lines().find(|l| l.starts_with(name)).unwrap_or_default().to_string();
    assert!(row("cube_b ").contains("FAIL") && row("cube_b ").contains("cube_b.png: mean FLIP"), "{table}");
    assert!(row("cube_a ").contains("pass"), "{table}");
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(xml.contains("tests=\"2\" failures=\"1\" errors=\"0\""), "{xml}");
    assert!(testcase(&xml, "cube_b").contains("<failure message=\"cube_b.png: mean FLIP"), "{xml}");
    assert!(!testcase(&xml, "cube_a").contains("<failure"), "{xml}");
    // The render and its heat map are left for the CI's artifacts.
    assert!(artifacts.join("cube_b.png").is_file() && artifacts.join("cube_b.heat.png").is_file());

    // A loose enough tolerance in the sidecar accepts the change; a malformed one is an error
    // naming the file, line and column.
    std::fs::write(refs.join("cube_b.test.toml"), "size = \"40x30\"\n[tolerance]\nflip = 1.0\n").unwrap();
    assert_eq!(hadou(&["test", s(&scenes), "--refs", s(&refs)]).status.code(), Some(0));
    std::fs::write(refs.join("cube_b.test.toml"), "size = \"40x30\"\n[tolerance]\nflop = 1.0\n").unwrap();
    let out = hadou(&["test", s(&scenes), "--refs", s(&refs)]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("cube_b.test.toml:3:1: unknown field `flop`"), "{}", text(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}
