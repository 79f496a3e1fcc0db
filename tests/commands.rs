//! The commands' contracts of issue 26 item 4: `render` names every file it wrote and labels its
//! one-frame timing as a cold first frame, refuses an AOV file that is not `.exr`; `hadou test`
//! takes `.glb`/`.gltf` files as scenes beside `.toml` ones, under the same reference and sidecar
//! rules, and refuses two scenes of one name. (`compare` RGBA against RGB: tests/compare.rs.)
//! Validation is on in every run.

mod common;

use common::cli::{hadou, s, scratch, text};
use common::gltf_writer::hierarchy;

#[test]
fn render_names_every_file_it_wrote_and_says_the_frame_was_cold() {
    let dir = scratch("cmd_wrote");
    let png = dir.join("s.png");
    let depth = dir.join("d.exr");
    let normal = dir.join("n.EXR");
    let (a, b) = (format!("depth={}", depth.display()), format!("normal={}", normal.display()));
    let out = hadou(&[
        "render",
        "assets/scenes/single_cube.toml",
        "-o",
        s(&png),
        "--size",
        "24x16",
        "--aov",
        &a,
        "--aov",
        &b,
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let wrote = stdout.lines().find(|l| l.starts_with("wrote ")).unwrap_or_else(|| panic!("{stdout}"));
    assert_eq!(
        wrote,
        format!(
            "wrote {} (24x16 PNG), {} (depth AOV, OpenEXR), {} (normal AOV, OpenEXR)",
            png.display(),
            depth.display(),
            normal.display()
        )
    );
    for f in [&png, &depth, &normal] {
        assert!(f.is_file(), "{} was named but not written", f.display());
    }
    // The one frame's GPU times are a cold frame's: labelled so, not as what a pass costs.
    let gpu = stdout.lines().find(|l| l.starts_with("gpu")).unwrap_or_else(|| panic!("{stdout}"));
    assert!(gpu.starts_with("gpu, first frame including pipeline compilation"), "{gpu}");
    assert!(gpu.contains("hadou profile") && gpu.contains("raster "), "{gpu}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_aov_file_that_is_not_exr_is_refused_and_nothing_is_written() {
    let dir = scratch("cmd_aov_ext");
    let png = dir.join("s.png");
    let good = format!("hdr={}", dir.join("h.exr").display());
    for name in ["d.png", "d", "d.exr.png", "d.tiff"] {
        let bad = format!("depth={}", dir.join(name).display());
        let out = hadou(&[
            "render",
            "assets/scenes/single_cube.toml",
            "-o",
            s(&png),
            "--size",
            "8x8",
            "--aov",
            &good,
            "--aov",
            &bad,
        ]);
        assert_eq!(out.status.code(), Some(1), "{}", text(&out));
        let err = String::from_utf8_lossy(&out.stderr);
        let shown = dir.join(name);
        assert!(
            err.contains(&format!(
                "error: --aov depth={}: AOVs are written as f32 OpenEXR only",
                shown.display()
            )) && err.contains("expected a file name ending in `.exr`"),
            "{err}"
        );
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert!(left.is_empty(), "{name}: something was written: {left:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_colour_file_that_is_not_png_is_refused_and_nothing_is_written() {
    let dir = scratch("cmd_color_ext");
    for name in ["c.exr", "c", "c.png.exr", "c.jpg"] {
        let path = dir.join(name);
        let out = hadou(&["render", "assets/scenes/single_cube.toml", "-o", s(&path), "--size", "8x8"]);
        assert_eq!(out.status.code(), Some(1), "{}", text(&out));
        let err = String::from_utf8_lossy(&out.stderr);
        let says =
            format!("error: -o {}: the colour image is written as an 8-bit sRGB PNG only", path.display());
        assert!(err.contains(&says) && err.contains("expected a file name ending in `.png`"), "{err}");
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert!(left.is_empty(), "{name}: something was written: {left:?}");
    }
    // Any case of the extension is a PNG name.
    let upper = dir.join("c.PNG");
    let out = hadou(&["render", "assets/scenes/single_cube.toml", "-o", s(&upper), "--size", "8x8"]);
    assert!(out.status.success(), "{}", text(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A scratch folder `name` with empty `scenes/` and `refs/` folders in it, for `hadou test`.
fn scenes_and_refs(name: &str) -> (std::path::PathBuf, std::path::PathBuf, std::path::PathBuf) {
    let dir = scratch(name);
    let (scenes, refs) = (dir.join("scenes"), dir.join("refs"));
    std::fs::create_dir_all(&scenes).unwrap();
    std::fs::create_dir_all(&refs).unwrap();
    (dir, scenes, refs)
}

/// A folder of glTF scenes (.glb, .gltf with its .bin, and a TOML scene beside them): each is a
/// scene, blessed under its stem, compared under its sidecar, failing by name when it changes.
#[test]
fn hadou_test_takes_gltf_files_as_scenes() {
    let (dir, scenes, refs) = scenes_and_refs("cmd_test_gltf");
    hierarchy(true, true, None).write_glb(&scenes, "level");
    hierarchy(true, false, None).write_external(&scenes, "rooms");
    let cube = std::fs::read_to_string(common::asset("assets/scenes/single_cube.toml")).unwrap();
    std::fs::write(scenes.join("cube.toml"), cube).unwrap();
    for n in ["level", "rooms", "cube"] {
        std::fs::write(refs.join(format!("{n}.test.toml")), "size = \"16x12\"\naovs = [\"depth\"]\n")
            .unwrap();
    }
    let run = |extra: &[&str]| {
        let mut args = vec!["test", s(&scenes), "--refs", s(&refs)];
        args.extend(extra);
        hadou(&args)
    };
    let out = run(&[]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(
        text(&out).contains(&format!("no reference {}", refs.join("level.png").display())),
        "{}",
        text(&out)
    );
    assert!(!text(&out).contains("not tested"), "{}", text(&out));

    let out = run(&["--bless"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    for f in ["level.png", "level.depth.exr", "rooms.png", "rooms.depth.exr", "cube.png", "cube.depth.exr"] {
        assert!(refs.join(f).is_file(), "{f} not blessed");
    }
    // The sidecar's size applies to a glTF scene as to a TOML one.
    assert_eq!(image::open(refs.join("level.png")).unwrap().to_rgba8().dimensions(), (16, 12));
    let junit = dir.join("junit.xml");
    let out = run(&["--junit", s(&junit)]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(text(&out).contains("hadou test: 3 scenes: 3 passed"), "{}", text(&out));
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(
        xml.contains(&format!("name=\"level\" file=\"{}\"", scenes.join("level.glb").display())),
        "{xml}"
    );

    // A changed file fails by name.
    hierarchy(true, false, None).write_glb(&scenes, "level");
    let out = run(&[]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    let t = text(&out);
    let row = t.lines().find(|l| l.starts_with("level ")).unwrap_or_else(|| panic!("{t}"));
    assert!(row.contains("FAIL") && row.contains("level.png: mean FLIP"), "{t}");
    // A render whose size no longer matches its reference fails too (exit 1, not 2), saying so.
    std::fs::write(refs.join("cube.test.toml"), "size = \"16x10\"\naovs = [\"depth\"]\n").unwrap();
    let out = run(&[]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    let t = text(&out);
    let row = t.lines().find(|l| l.starts_with("cube ")).unwrap_or_else(|| panic!("{t}"));
    assert!(row.contains("FAIL") && row.contains("cube.png") && row.contains("16x10"), "{t}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `level.toml`, `level.glb` and `level.gltf` would share `level.png` and `level.test.toml`: each
/// is an error row naming the others (exit 2), the other scenes still run.
#[test]
fn hadou_test_refuses_two_scenes_of_one_name() {
    let (dir, scenes, refs) = scenes_and_refs("cmd_test_shared");
    hierarchy(true, false, None).write_glb(&scenes, "level");
    hierarchy(true, false, None).write_embedded(&scenes, "level");
    hierarchy(true, false, None).write_glb(&scenes, "other");
    std::fs::write(refs.join("other.test.toml"), "size = \"8x8\"\n").unwrap();
    let out = hadou(&["test", s(&scenes), "--refs", s(&refs), "--bless"]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    let t = text(&out);
    assert!(
        t.contains(&format!("{}: shares its name with level.gltf", scenes.join("level.glb").display())),
        "{t}"
    );
    assert!(
        t.contains(&format!("{}: shares its name with level.glb", scenes.join("level.gltf").display())),
        "{t}"
    );
    assert!(t.contains(&format!("compared with {}", refs.join("level.png").display())), "{t}");
    assert!(t.contains("hadou test: 3 scenes: 1 blessed, 0 failed, 2 errors"), "{t}");
    assert!(t.contains("nothing was blessed"), "{t}");
    assert!(!refs.join("other.png").exists(), "all or none");
    // A folder with no scene at all says which files are scenes.
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let out = hadou(&["test", s(&empty)]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("no scene files (*.toml, *.gltf, *.glb)"), "{}", text(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}
