//! `hadou view` under a virtual X server (Xvfb): the window opens, frames are presented through
//! the swapchain, passes are toggled (rebuilt), the window is resized (swapchain recreated), a
//! screenshot is taken and the viewer exits cleanly — validation on, zero errors and warnings.
//! Hot reload is seen through notify and read within 100 ms of a save. The reload logic, the
//! debounce and the minimized-window path are unit tests (src/cli/view/reload.rs,
//! src/present/swapchain.rs): they need no window.

mod common;

use common::cli::{scratch, text};

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::xvfb::Xvfb;

/// Runs `hadou ARGS` with validation on; kills it (and fails) if it runs past `limit`.
fn hadou(args: &[&str], envs: &[(&str, &str)], limit: Duration) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hadou"));
    cmd.args(args)
        .current_dir(common::root())
        .env("HADOU_VALIDATION", "1")
        .env_remove("HADOU_VIEW_SCRIPT")
        .env_remove("HADOU_SHADER_DIR")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for (k, v) in envs {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().expect("run hadou");
    let start = Instant::now();
    while child.try_wait().expect("wait for hadou").is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!("hadou {args:?} ran past {limit:?}:\n{}", text(&out));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}

/// The viewer presents, toggles every pass off and on and both switches there and back, resizes
/// to 320×200, takes a screenshot, then resizes with the swapchain not told (only the driver's
/// suboptimal / out-of-date reports can bring it to 240×160, which the script waits for) and
/// quits; validation sees nothing. Time is paused at 0.5 s and
/// the camera untouched, so the screenshot must be exactly what `hadou render` gives for the same
/// scene, size and time: the same runtime and inputs on the same device are deterministic, so the
/// tolerance is zero.
#[test]
fn view_presents_resizes_screenshots_and_quits_cleanly() {
    let x = Xvfb::start();
    let dir = scratch("run");
    let shot = dir.join("shot.png");
    let script = format!(
        "frames=2;key=1;key=2;key=3;frames=1;key=1;key=2;key=3;key=r;key=t;frames=1;key=r;key=t;\
         frames=1;key=t;frames=1;resize=320x200;frames=2;screenshot={};resize_events=off;resize=240x160;frames=1;\
         quit",
        shot.display()
    );
    let out = hadou(
        &["view", "assets/scenes/showcase.toml", "--time", "0.5", "--paused", "--script", &script],
        &[("DISPLAY", &x.display)],
        Duration::from_secs(300),
    );
    drop(x);
    assert!(out.status.success(), "{}", text(&out));
    assert!(!text(&out).contains("validation"), "{}", text(&out));
    let img = image::open(&shot).unwrap_or_else(|e| panic!("{}: {e}", shot.display())).to_rgba8();
    assert_eq!(img.dimensions(), (320, 200));
    let first = img.get_pixel(0, 0);
    assert!(img.pixels().any(|p| p != first), "the screenshot is blank");

    let reference = dir.join("reference.png");
    let out = hadou(
        &[
            "render",
            "assets/scenes/showcase.toml",
            "-o",
            reference.to_str().unwrap(),
            "--size",
            "320x200",
            "--time",
            "0.5",
        ],
        &[],
        Duration::from_secs(300),
    );
    assert!(out.status.success(), "{}", text(&out));
    let reference = image::open(&reference).unwrap().to_rgba8();
    let differing = img.pixels().zip(reference.pixels()).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "pixels differing from `hadou render`");
    std::fs::remove_dir_all(&dir).ok();
}

/// Saves `text` to `path` as many editors do: a new file renamed over the old one.
fn replace_file(path: &Path, text: &str) {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).unwrap();
    std::fs::rename(&tmp, path).unwrap();
}

/// Hot reload through the real window: the scene file is edited into a bad one (the last good
/// scene stays on screen, the error is reported), then into a good one with another field of view
/// (the view changes to it), then a shader is broken (the last good shaders stay) and repaired.
/// Each screenshot must equal `hadou render` of the scene it should show (tolerance zero, as
/// above). The test edits the files when the viewer's script says it waits for a reload.
#[test]
fn view_hot_reload_keeps_the_last_good_state() {
    let x = Xvfb::start();
    let dir = scratch("reload");
    let scene = dir.join("scene.toml");
    let shaders = dir.join("shaders");
    copy_dir(&common::asset("shaders"), &shaders);
    let good = std::fs::read_to_string(common::asset("assets/scenes/showcase.toml")).unwrap();
    assert!(good.contains("fov_y_deg = 45"), "the showcase's field of view changed: update this test");
    std::fs::write(&scene, &good).unwrap();
    let shot = |n: u32| dir.join(format!("shot{n}.png"));
    let script = format!(
        "frames=1;screenshot={};await_reload;frames=1;screenshot={};await_reload;frames=1;screenshot={};\
         await_reload;frames=1;screenshot={};await_reload;frames=1;screenshot={};quit",
        shot(0).display(),
        shot(1).display(),
        shot(2).display(),
        shot(3).display(),
        shot(4).display()
    );
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hadou"));
    cmd.args([
        "view",
        scene.to_str().unwrap(),
        "--size",
        "96x64",
        "--time",
        "0.5",
        "--paused",
        "--script",
        &script,
    ])
    .current_dir(common::root())
    .env("HADOU_VALIDATION", "1")
    .env("HADOU_SHADER_DIR", &shaders)
    .env("DISPLAY", &x.display)
    .env_remove("HADOU_VIEW_SCRIPT")
    .stdout(Stdio::null())
    .stderr(Stdio::piped());
    let mut child = cmd.spawn().expect("run hadou view");
    let (send, lines) = std::sync::mpsc::channel();
    let stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = send.send(line);
        }
    });
    let tonemap = shaders.join("tonemap.comp");
    let tonemap_good = std::fs::read_to_string(&tonemap).unwrap();
    let wider = good.replace("fov_y_deg = 45", "fov_y_deg = 60");
    let edits: [(&Path, String); 4] = [
        (&scene, good.replace("fov_y_deg = 45", "fov_y_deg = -45")),
        (&scene, wider.clone()),
        (&tonemap, format!("{tonemap_good}\nthis does not compile(\n")),
        (&tonemap, tonemap_good.clone()),
    ];
    let mut log = Vec::new();
    let mut next = 0;
    let start = Instant::now();
    loop {
        match lines.recv_timeout(Duration::from_millis(100)) {
            Ok(line) => {
                if line.contains("script: waiting for a reload") {
                    let (path, text) = &edits[next];
                    replace_file(path, text);
                    next += 1;
                }
                log.push(line);
            }
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break,
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
        }
        if start.elapsed() > Duration::from_secs(300) {
            let _ = child.kill();
            panic!("hadou view ran past 300 s:\n{}", log.join("\n"));
        }
    }
    reader.join().unwrap();
    let status = child.wait().unwrap();
    drop(x);
    let log = log.join("\n");
    assert!(status.success(), "{log}");
    assert_eq!(next, 4, "every edit was asked for:\n{log}");
    assert!(!log.contains("validation"), "{log}");
    assert!(log.contains("reload kept the last good state") && log.contains("scene.toml:"), "{log}");
    assert!(log.contains("fov_y_deg"), "the scene error names the field:\n{log}");
    // The good edit was read within 100 ms of its save (the viewer measures from the file's
    // modification time): 25 ms of debounce (src/cli/view/reload.rs) plus the frame in flight, a
    // 96×64 frame here.
    let latency: u64 = log
        .lines()
        .find_map(|l| l.split_once(", read ")?.1.strip_suffix(" ms after its save")?.parse().ok())
        .unwrap_or_else(|| panic!("no reload latency reported:\n{log}"));
    println!("hot reload read the scene {latency} ms after its save");
    assert!(latency < 100, "reloaded {latency} ms after the save:\n{log}");
    assert!(
        log.contains("shader reload kept the last good shaders") && log.contains("tonemap.comp"),
        "{log}"
    );

    let reference = |toml: &str, name: &str| {
        let file = dir.join(format!("{name}.toml"));
        std::fs::write(&file, toml).unwrap();
        let png = dir.join(format!("{name}.png"));
        let out = hadou(
            &[
                "render",
                file.to_str().unwrap(),
                "-o",
                png.to_str().unwrap(),
                "--size",
                "96x64",
                "--time",
                "0.5",
            ],
            &[("HADOU_SHADER_DIR", shaders.to_str().unwrap())],
            Duration::from_secs(300),
        );
        assert!(out.status.success(), "{}", text(&out));
        image::open(&png).unwrap().to_rgba8()
    };
    let original = reference(&good, "original");
    let widened = reference(&wider, "wider");
    assert_ne!(original, widened, "the edit must change the picture for this test to mean anything");
    let expected = [&original, &original, &widened, &widened, &widened];
    for (n, want) in expected.iter().enumerate() {
        let got = image::open(shot(n as u32)).unwrap().to_rgba8();
        assert!(got == **want, "screenshot {n} is not the scene it should show");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Hot reload follows the files a scene reads, not only the scene file: an OBJ mesh saved with
/// other vertices is drawn anew (the screenshot equals `hadou render` of the edited files, tolerance
/// zero as above, and differs from the first).
#[test]
fn view_hot_reload_follows_the_obj_a_scene_reads() {
    let x = Xvfb::start();
    let dir = scratch("reload-obj");
    let scene = dir.join("scene.toml");
    let obj = dir.join("shape.obj");
    let wedge = std::fs::read_to_string(common::asset("assets/meshes/wedge.obj")).unwrap();
    std::fs::write(&obj, &wedge).unwrap();
    std::fs::write(
        &scene,
        "[camera]\nposition = [2, 1.5, 4]\nlook_at = [0, 0, 0]\nfov_y_deg = 45\n\
         [[light]]\ndirection = [-1, -2, -1]\n\
         [[mesh]]\nname = \"shape\"\nkind = \"obj\"\npath = \"shape.obj\"\n\
         [[instance]]\nmesh = \"shape\"\n",
    )
    .unwrap();
    // Every vertex scaled by 1.5: the same faces, a bigger wedge.
    let bigger: String = wedge
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(rest) => {
                let v: Vec<String> =
                    rest.split_whitespace().map(|c| format!("{}", c.parse::<f64>().unwrap() * 1.5)).collect();
                format!("v {}\n", v.join(" "))
            }
            None => format!("{l}\n"),
        })
        .collect();
    let shot = |n: u32| dir.join(format!("shot{n}.png"));
    let script = format!(
        "frames=1;screenshot={};await_reload;frames=1;screenshot={};quit",
        shot(0).display(),
        shot(1).display()
    );
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hadou"));
    cmd.args(["view", scene.to_str().unwrap(), "--size", "96x64", "--paused", "--script", &script])
        .current_dir(common::root())
        .env("HADOU_VALIDATION", "1")
        .env("DISPLAY", &x.display)
        .env_remove("HADOU_VIEW_SCRIPT")
        .env_remove("HADOU_SHADER_DIR")
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    let mut child = cmd.spawn().expect("run hadou view");
    let stderr = child.stderr.take().unwrap();
    let mut log = Vec::new();
    for line in BufReader::new(stderr).lines().map_while(Result::ok) {
        if line.contains("script: waiting for a reload") {
            replace_file(&obj, &bigger);
        }
        log.push(line);
    }
    let status = child.wait().unwrap();
    drop(x);
    let log = log.join("\n");
    assert!(status.success() && !log.contains("validation"), "{log}");
    assert!(log.contains("reloaded"), "the OBJ's save reloaded the scene:\n{log}");
    let render = |name: &str| {
        let png = dir.join(format!("{name}.png"));
        let out = hadou(
            &["render", scene.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "96x64"],
            &[],
            Duration::from_secs(300),
        );
        assert!(out.status.success(), "{}", text(&out));
        image::open(&png).unwrap().to_rgba8()
    };
    let edited = render("edited");
    std::fs::write(&obj, &wedge).unwrap();
    let original = render("original");
    assert_ne!(original, edited, "the edit must change the picture for this test to mean anything");
    assert!(image::open(shot(0)).unwrap().to_rgba8() == original, "screenshot 0 is not the first wedge");
    assert!(image::open(shot(1)).unwrap().to_rgba8() == edited, "screenshot 1 is not the edited wedge");
    std::fs::remove_dir_all(&dir).ok();
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.path().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

/// No X server: a plain error and a non-zero exit, not a panic.
#[test]
fn view_without_a_display_fails_with_a_message() {
    let out = hadou(
        &["view", "assets/scenes/showcase.toml", "--script", "frames=1;quit"],
        &[("DISPLAY", ":9999"), ("WAYLAND_DISPLAY", "")],
        Duration::from_secs(60),
    );
    assert!(!out.status.success());
    let t = text(&out);
    assert!(t.contains("error:") && t.contains("cannot open a window"), "{t}");
    assert!(!t.contains("panicked"), "{t}");
}

/// A bad script or scene is refused before any window opens.
#[test]
fn view_refuses_bad_arguments_before_opening_a_window() {
    let out = hadou(
        &["view", "assets/scenes/showcase.toml", "--script", "frames=0;quit"],
        &[],
        Duration::from_secs(60),
    );
    assert!(!out.status.success());
    assert!(text(&out).contains("frames=N with N ≥ 1"), "{}", text(&out));
    let out = hadou(&["view", "tests/bad_scenes/zero_axis.toml"], &[], Duration::from_secs(60));
    assert!(!out.status.success());
    assert!(text(&out).contains("zero_axis.toml:"), "{}", text(&out));
}

/// `--help` lists the keys (the README lists the same).
#[test]
fn view_help_lists_the_keys() {
    let out = hadou(&["view", "--help"], &[], Duration::from_secs(60));
    assert!(out.status.success());
    let t = text(&out);
    for key in ["Space", "F12", "W A S D", "1 / 2 / 3", "T ", "R ", "mouse wheel"] {
        assert!(t.contains(key), "--help lacks {key:?}:\n{t}");
    }
}
