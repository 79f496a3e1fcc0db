//! `hadou compare` and `hadou test` against hard inputs (issue 24): image headers that claim
//! billions of pixels, outputs that name inputs or reference folders, a bless that fails midway,
//! a FIFO sidecar, file names with escape sequences, bytes that are not UTF-8, and scene entries
//! that are not regular files. Every case ends in a clean error (exit 2) or an honest report,
//! never an abort, a hang, a silent overwrite or a silent skip. Runs that could allocate without
//! bound go through `prlimit --as` so that a regression fails here instead of taking the machine.

mod common;

use std::ffi::OsStr;
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

use common::cli::{hadou, output_within, s, scratch, text};

/// Address space a capped run may take: lavapipe with validation runs `hadou test` in under
/// 2 GB of address space here (measured with prlimit); a decoder that believes a header's
/// 100000×100000 asks for 40 GB and fails at once against it.
const CAP_BYTES: u64 = 4 << 30;

/// A capped run's time limit: each takes well under a second; the limit only turns a hang into
/// a failure.
const CAP_LIMIT: Duration = Duration::from_secs(60);

/// `hadou ARGS` under `prlimit --as=CAP_BYTES`, killed past `CAP_LIMIT`.
fn hadou_capped(args: &[&OsStr]) -> Output {
    let mut cmd = Command::new("prlimit");
    cmd.arg(format!("--as={CAP_BYTES}"))
        .arg("--")
        .arg(env!("CARGO_BIN_EXE_hadou"))
        .args(args)
        .current_dir(common::root())
        .env("HADOU_VALIDATION", "1");
    output_within(&mut cmd, CAP_LIMIT)
}

fn os<'a>(args: &[&'a str]) -> Vec<&'a OsStr> {
    args.iter().map(|a| OsStr::new(*a)).collect()
}

fn code(out: &Output) -> i32 {
    out.status.code().unwrap_or_else(|| panic!("killed by a signal: {}", text(out)))
}

/// An OpenEXR attribute: name, type, size, value.
fn attribute(out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]) {
    out.extend(name.as_bytes());
    out.push(0);
    out.extend(kind.as_bytes());
    out.push(0);
    out.extend((value.len() as i32).to_le_bytes());
    out.extend(value);
}

/// A 4,900-byte scanline OpenEXR whose header claims `width`×`height` f32 pixels of one channel
/// `Y` (uncompressed), followed by zeros where the offset table and pixels would be.
fn exr_claiming(width: i32, height: i32) -> Vec<u8> {
    let mut b = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    let mut channels = b"Y\0".to_vec();
    channels.extend(2i32.to_le_bytes()); // FLOAT
    channels.extend([0, 0, 0, 0]); // pLinear, reserved
    channels.extend(1i32.to_le_bytes());
    channels.extend(1i32.to_le_bytes());
    channels.push(0);
    attribute(&mut b, "channels", "chlist", &channels);
    attribute(&mut b, "compression", "compression", &[0]);
    let window: Vec<u8> = [0, 0, width - 1, height - 1].iter().flat_map(|v: &i32| v.to_le_bytes()).collect();
    attribute(&mut b, "dataWindow", "box2i", &window);
    attribute(&mut b, "displayWindow", "box2i", &window);
    attribute(&mut b, "lineOrder", "lineOrder", &[0]);
    attribute(&mut b, "pixelAspectRatio", "float", &1f32.to_le_bytes());
    attribute(&mut b, "screenWindowCenter", "v2f", &[0; 8]);
    attribute(&mut b, "screenWindowWidth", "float", &1f32.to_le_bytes());
    b.push(0);
    b.resize(4900, 0);
    b
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &byte in bytes {
        crc ^= byte as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xedb8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

/// A PNG of a few dozen bytes whose (valid, CRC-checked) IHDR claims `width`×`height` RGBA8.
fn png_claiming(width: u32, height: u32) -> Vec<u8> {
    let chunk = |out: &mut Vec<u8>, kind: &[u8], data: &[u8]| {
        out.extend((data.len() as u32).to_be_bytes());
        let body: Vec<u8> = kind.iter().chain(data).copied().collect();
        out.extend(&body);
        out.extend(crc32(&body).to_be_bytes());
    };
    let mut b = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = width.to_be_bytes().to_vec();
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([8, 6, 0, 0, 0]);
    chunk(&mut b, b"IHDR", &ihdr);
    chunk(&mut b, b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
    chunk(&mut b, b"IEND", &[]);
    b
}

/// The cube scene (fast: one mesh, one light).
fn cube() -> String {
    std::fs::read_to_string(common::asset("assets/scenes/single_cube.toml")).unwrap()
}

/// `scenes/` with the cube under each name and `refs/` with an 8×8 sidecar for each (plus
/// `extra` sidecar lines), in a scratch folder.
fn suite(name: &str, scenes: &[&str], extra: &str) -> (PathBuf, PathBuf, PathBuf) {
    let dir = scratch(name);
    let (sc, refs) = (dir.join("scenes"), dir.join("refs"));
    std::fs::create_dir_all(&sc).unwrap();
    std::fs::create_dir_all(&refs).unwrap();
    for n in scenes {
        std::fs::write(sc.join(format!("{n}.toml")), cube()).unwrap();
        std::fs::write(refs.join(format!("{n}.test.toml")), format!("size = \"8x8\"\n{extra}")).unwrap();
    }
    (dir, sc, refs)
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn image_headers_claiming_billions_of_pixels_are_refused_before_decoding() {
    let dir = scratch("claims");
    let exr = dir.join("huge.exr");
    std::fs::write(&exr, exr_claiming(100_000, 100_000)).unwrap();
    let png = dir.join("huge.png");
    std::fs::write(&png, png_claiming(100_000, 100_000)).unwrap();
    for file in [&exr, &png] {
        let out = hadou_capped(&os(&["compare", s(file), s(file)]));
        assert_eq!(code(&out), 2, "{}", text(&out));
        let says =
            format!("error: {}: 100000x100000 is 10000000000 pixels, more than the pixel budget", s(file));
        assert!(text(&out).contains(&says), "{}", text(&out));
    }
    // The budget is the default's, and --max-pixels moves it: 3x3 of a 4x3 file is too little.
    let small = dir.join("small.exr");
    std::fs::write(&small, exr_claiming(4, 3)).unwrap();
    let out = hadou_capped(&os(&["compare", s(&small), s(&small), "--max-pixels", "9"]));
    assert_eq!(code(&out), 2, "{}", text(&out));
    assert!(text(&out).contains("4x3 is 12 pixels, more than the pixel budget of 9"), "{}", text(&out));
    let out = hadou_capped(&os(&["compare", s(&small), s(&small), "--max-pixels", "0"]));
    assert_eq!(code(&out), 2, "{}", text(&out));
    assert!(text(&out).contains("--max-pixels"), "{}", text(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_huge_exr_reference_is_one_error_row_and_the_junit_report_is_written() {
    let (dir, scenes, refs) = suite("huge-ref", &["a", "b"], "aovs = [\"depth\"]\n");
    assert_eq!(code(&hadou(&["test", s(&scenes), "--refs", s(&refs), "--bless"])), 0);
    std::fs::write(refs.join("a.depth.exr"), exr_claiming(100_000, 100_000)).unwrap();
    let junit = dir.join("junit.xml");
    let out = hadou_capped(&os(&["test", s(&scenes), "--refs", s(&refs), "--junit", s(&junit)]));
    assert_eq!(code(&out), 2, "{}", text(&out));
    let row = text(&out).lines().find(|l| l.starts_with("a ")).unwrap_or_default().to_string();
    assert!(row.contains("ERROR") && row.contains("a.depth.exr: 100000x100000"), "{}", text(&out));
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(xml.contains("tests=\"2\" failures=\"0\" errors=\"1\""), "{xml}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn junit_and_out_never_replace_a_scene_a_sidecar_or_a_reference() {
    let (dir, scenes, refs) = suite("outputs", &["a", "b"], "");
    assert_eq!(code(&hadou(&["test", s(&scenes), "--refs", s(&refs), "--bless"])), 0);
    let before: Vec<(PathBuf, Vec<u8>)> =
        [scenes.join("a.toml"), refs.join("a.test.toml"), refs.join("b.png")]
            .into_iter()
            .map(|p| {
                let bytes = std::fs::read(&p).unwrap();
                (p, bytes)
            })
            .collect();
    for (input, _) in &before {
        let out = hadou(&["test", s(&scenes), "--refs", s(&refs), "--junit", s(input)]);
        assert_eq!(code(&out), 2, "{}", text(&out));
        assert!(text(&out).contains("is the input"), "{}", text(&out));
    }
    let out = hadou(&["test", s(&scenes), "--refs", s(&refs), "--junit", "/dev/null"]);
    assert_eq!(code(&out), 2, "{}", text(&out));
    assert!(text(&out).contains("character device"), "{}", text(&out));
    // Blessing: the references are outputs, and the report may not be one of them.
    let out = hadou(&["test", s(&scenes), "--refs", s(&refs), "--bless", "--junit", s(&refs.join("a.png"))]);
    assert_eq!(code(&out), 2, "{}", text(&out));
    for (path, bytes) in &before {
        assert_eq!(&std::fs::read(path).unwrap(), bytes, "{} changed", path.display());
    }

    // b changes; `--out` at the references folder would replace b.png with the new render (a
    // silent bless): refused, and the next run still fails.
    std::fs::write(scenes.join("b.toml"), cube().replace("[-1, -2, -1]", "[1, -2, -1]")).unwrap();
    let out = hadou(&["test", s(&scenes), "--refs", s(&refs), "--out", s(&refs)]);
    assert_eq!(code(&out), 2, "{}", text(&out));
    assert!(text(&out).contains("refs/a.png: is the input"), "{}", text(&out));
    let out = hadou(&["test", s(&scenes), "--refs", s(&refs)]);
    assert_eq!(code(&out), 1, "{}", text(&out));
    // Elsewhere, `--out` keeps the render and heat map.
    let artifacts = dir.join("artifacts");
    let out = hadou(&["test", s(&scenes), "--refs", s(&refs), "--out", s(&artifacts)]);
    assert_eq!(code(&out), 1, "{}", text(&out));
    assert_eq!(names(&artifacts), ["b.heat.png", "b.png"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_bless_that_fails_midway_replaces_nothing() {
    let (dir, scenes, refs) = suite("bless", &["a", "b", "c", "d"], "");
    for n in ["a", "b", "c", "d"] {
        std::fs::write(refs.join(format!("{n}.png")), format!("old {n}")).unwrap();
    }
    // d.png cannot be replaced: immutable (root with CAP_LINUX_IMMUTABLE, as the suite runs).
    let d = refs.join("d.png");
    let immutable = Command::new("chattr").arg("+i").arg(&d).status().is_ok_and(|s| s.success());
    if !immutable {
        eprintln!("skipped: `chattr +i` is not available here (needs root on a file system that has it)");
        std::fs::remove_dir_all(&dir).unwrap();
        return;
    }
    let out = hadou(&["test", s(&scenes), "--refs", s(&refs), "--bless"]);
    let _ = Command::new("chattr").arg("-i").arg(&d).status();
    assert_eq!(code(&out), 2, "{}", text(&out));
    assert!(text(&out).contains("nothing was blessed") && text(&out).contains("d.png"), "{}", text(&out));
    for n in ["a", "b", "c", "d"] {
        let got = std::fs::read_to_string(refs.join(format!("{n}.png"))).unwrap_or_default();
        assert_eq!(got, format!("old {n}"), "{n}.png was replaced: {}", text(&out));
    }
    // No temporary or kept copy is left.
    let mut want: Vec<String> =
        ["a", "b", "c", "d"].iter().flat_map(|n| [format!("{n}.png"), format!("{n}.test.toml")]).collect();
    want.sort();
    assert_eq!(names(&refs), want);
    // Writable again, it blesses all four.
    assert_eq!(code(&hadou(&["test", s(&scenes), "--refs", s(&refs), "--bless"])), 0);
    assert!(std::fs::read(&d).unwrap().starts_with(b"\x89PNG"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_fifo_sidecar_is_refused_not_waited_on() {
    let (dir, scenes, refs) = suite("fifo", &["a"], "");
    let sidecar = refs.join("a.test.toml");
    std::fs::remove_file(&sidecar).unwrap();
    assert!(Command::new("mkfifo").arg(&sidecar).status().unwrap().success());
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hadou"));
    cmd.args(["test", s(&scenes), "--refs", s(&refs)]).env("HADOU_VALIDATION", "1");
    // Refused at once; a reader waiting for a writer would be killed here.
    let out = output_within(&mut cmd, Duration::from_secs(30));
    assert_eq!(code(&out), 2, "{}", text(&out));
    assert!(text(&out).contains("a.test.toml: is a FIFO, not a regular file"), "{}", text(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn file_names_reach_the_terminal_escaped_and_no_scene_is_skipped_in_silence() {
    let (dir, scenes, refs) = suite("names", &["plain"], "");
    // A name that would recolour the terminal and set its title, and one that is not UTF-8.
    let loud = OsStr::from_bytes(b"loud\x1b[31m\x1b]0;pwned\x07");
    let odd = OsStr::from_bytes(b"odd\xff");
    for stem in [loud, odd] {
        let mut file = stem.to_os_string();
        file.push(".toml");
        std::fs::write(scenes.join(&file), cube()).unwrap();
        let mut sidecar = stem.to_os_string();
        sidecar.push(".test.toml");
        std::fs::write(refs.join(&sidecar), "size = \"8x8\"\n").unwrap();
    }
    // Entries named like scenes that are not regular files, and look-alikes.
    std::fs::create_dir(scenes.join("folder.toml")).unwrap();
    assert!(Command::new("mkfifo").arg(scenes.join("pipe.toml")).status().unwrap().success());
    std::fs::write(scenes.join("upper.TOML"), cube()).unwrap();

    let run = |extra: &[&str]| {
        let mut args = os(&["test", s(&scenes), "--refs", s(&refs)]);
        args.extend(extra.iter().map(OsStr::new));
        hadou_capped(&args)
    };
    let out = run(&[]);
    let all = [out.stdout.as_slice(), out.stderr.as_slice()].concat();
    assert!(!all.contains(&0x1b) && !all.contains(&0x07), "raw control bytes: {}", text(&out));
    let t = text(&out);
    assert_eq!(code(&out), 2, "{t}");
    assert!(t.contains("loud\\u{1b}[31m\\u{1b}]0;pwned\\u{7}"), "{t}");
    assert!(t.contains("odd\\xff"), "{t}");
    assert!(t.contains("folder.toml: is a directory, not a regular file"), "{t}");
    assert!(t.contains("pipe.toml: is a FIFO, not a regular file"), "{t}");
    assert!(t.contains("upper.TOML: not tested"), "{t}");
    assert!(t.contains("hadou test: 5 scenes: 0 passed, 3 failed, 2 errors"), "{t}");

    // The odd names are tested like any other: blessed under their own bytes, then passing.
    std::fs::remove_dir(scenes.join("folder.toml")).unwrap();
    std::fs::remove_file(scenes.join("pipe.toml")).unwrap();
    let out = run(&["--bless"]);
    assert_eq!(code(&out), 0, "{}", text(&out));
    let mut reference = odd.to_os_string();
    reference.push(".png");
    assert!(refs.join(reference).is_file(), "{:?}", names(&refs));
    let out = run(&[]);
    assert_eq!(code(&out), 0, "{}", text(&out));
    assert!(text(&out).contains("hadou test: 3 scenes: 3 passed"), "{}", text(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}
