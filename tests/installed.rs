//! An installed `hadou` (what `cargo install --path .` puts on PATH): the built binary copied into
//! a fresh temporary folder and run there, with no source tree beside it, for every command.
//! The scenes are the built-in ones (`builtin:NAME`); `report` runs the same way in
//! tests/report.rs (it takes a minute, so once). Progress bars: none into a pipe, drawn on a
//! terminal (a pseudo-terminal made by util-linux `script`).

mod common;

use common::cli::text;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use common::xvfb::Xvfb;

/// Held for writing while a test copies the binary and for reading while one runs a process: a
/// process forked while another thread still has the copy open for writing holds that file
/// descriptor until it execs, and exec of the copy then fails with ETXTBSY ("Text file busy").
static SPAWN: std::sync::RwLock<()> = std::sync::RwLock::new(());

/// Runs `cmd` to completion, never while a copy of the binary is being written.
fn output_of(cmd: &mut Command) -> std::io::Result<Output> {
    let _running = SPAWN.read().unwrap_or_else(|e| e.into_inner());
    cmd.output()
}

/// A folder with `bin/hadou` in it, removed when dropped.
struct Installed {
    dir: PathBuf,
    exe: PathBuf,
}

impl Installed {
    fn new(name: &str) -> Installed {
        let dir = std::env::temp_dir().join(format!("hadou-installed-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("bin")).unwrap();
        let exe = dir.join("bin/hadou");
        {
            let _copying = SPAWN.write().unwrap_or_else(|e| e.into_inner());
            std::fs::copy(env!("CARGO_BIN_EXE_hadou"), &exe).unwrap();
        }
        Installed { dir, exe }
    }

    /// With HADOU_VALIDATION=1: `render`, `profile` and `report` exit non-zero on any validation
    /// error or warning (objects leaked at device destroy included), so a success is a clean log.
    fn command(&self, args: &[&str]) -> Command {
        let mut cmd = Command::new(&self.exe);
        cmd.args(args)
            .current_dir(&self.dir)
            .env("HADOU_VALIDATION", "1")
            .env("HADOU_CACHE_DIR", self.dir.join("cache"))
            .env_remove("HADOU_SHADER_DIR")
            .env_remove("HADOU_VIEW_SCRIPT")
            .stdin(Stdio::null());
        cmd
    }

    fn run(&self, args: &[&str]) -> Output {
        let out = output_of(&mut self.command(args)).expect("run the installed hadou");
        assert!(out.status.success(), "hadou {args:?}:\n{}", text(&out));
        out
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }
}

impl Drop for Installed {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

fn png_size(path: &Path) -> (u32, u32) {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgba8().dimensions()
}

/// The commands `hadou --help` lists; each one must be run below (or in tests/report.rs).
const COVERED: [&str; 9] =
    ["render", "profile", "devices", "bake", "report", "view", "compare", "test", "profile-diff"];

#[test]
fn every_command_runs_outside_the_source_tree() {
    let hadou = Installed::new("all");
    let help = String::from_utf8_lossy(&hadou.run(&["--help"]).stdout).to_string();
    let commands: Vec<&str> = help
        .split("Commands:")
        .nth(1)
        .and_then(|rest| rest.split("Options:").next())
        .unwrap_or_else(|| panic!("no command list in:\n{help}"))
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .collect();
    for c in &commands {
        assert!(COVERED.contains(c), "`hadou {c}` is not run outside the source tree by this test");
    }
    assert_eq!(commands.len(), COVERED.len(), "{commands:?}");

    hadou.run(&["devices"]);
    let out =
        hadou.run(&["render", "builtin:showcase", "-o", "s.png", "--size", "64x48", "--aov", "depth=d.exr"]);
    assert!(out.stderr.is_empty(), "render into a pipe prints no progress:\n{}", text(&out));
    assert_eq!(png_size(&hadou.path("s.png")), (64, 48));
    assert!(hadou.path("d.exr").is_file());
    hadou.run(&[
        "profile",
        "builtin:energy_wave",
        "--size",
        "32x32",
        "--frames",
        // profile-diff below needs 6 timed frames a row (its minimum at 95 % confidence).
        "6",
        "--warmup",
        "1",
        "--json",
        "p.json",
    ]);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(hadou.path("p.json")).unwrap()).unwrap();
    assert!(json.is_object());
    // The CI commands: compare two images, golden-test a folder, gate two profiles.
    let out = output_of(&mut hadou.command(&["compare", "s.png", "s.png"])).unwrap();
    assert!(out.status.success(), "compare: {}", text(&out));
    std::fs::create_dir_all(hadou.path("scenes")).unwrap();
    let cube = "[camera]\nposition = [0, 1, 4]\nlook_at = [0, 0, 0]\n[render]\nsize = [32, 24]\n\
                [[mesh]]\nname = \"box\"\nkind = \"cube\"\n[[instance]]\nmesh = \"box\"\n";
    std::fs::write(hadou.path("scenes/cube.toml"), cube).unwrap();
    for args in [&["test", "scenes", "--refs", "refs", "--bless"][..], &["test", "scenes", "--refs", "refs"]]
    {
        let out = output_of(&mut hadou.command(args)).unwrap();
        assert!(out.status.success(), "{args:?}: {}", text(&out));
    }
    let out = output_of(&mut hadou.command(&["profile-diff", "p.json", "p.json"])).unwrap();
    assert!(out.status.success(), "profile-diff: {}", text(&out));
    let out = hadou.run(&["bake", "builtin:translucency", "--res", "8"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("res 8"), "{}", text(&out));
    assert!(!text(&out).contains('%'), "bake into a pipe prints no progress:\n{}", text(&out));
    // An unknown built-in is an error that lists the names.
    let out = output_of(&mut hadou.command(&["render", "builtin:nope", "-o", "n.png"])).unwrap();
    assert!(!out.status.success() && text(&out).contains("builtin:nope: no such built-in scene"));
    assert!(text(&out).contains("showcase"), "{}", text(&out));

    let x = Xvfb::start();
    let mut view = hadou.command(&[
        "view",
        "builtin:single_cube",
        "--size",
        "48x32",
        "--script",
        "frames=2;screenshot=v.png;quit",
    ]);
    let out = output_of(view.env("DISPLAY", &x.display)).unwrap();
    drop(x);
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(png_size(&hadou.path("v.png")), (48, 32));
}

/// On a terminal the bake draws its bar (so the silence into a pipe above is the choice of
/// indicatif's terminal check, not a bar that never draws).
#[test]
fn progress_is_drawn_on_a_terminal() {
    let hadou = Installed::new("tty");
    let line = format!("{} bake builtin:translucency --res 9 --force", hadou.exe.display());
    // `script` runs the command on a new pseudo-terminal and copies what it wrote to stdout.
    let mut script = Command::new("script");
    script
        .args(["-qec", &line, "/dev/null"])
        .current_dir(&hadou.dir)
        .env("HADOU_CACHE_DIR", hadou.dir.join("cache"))
        .stdin(Stdio::null());
    let out = output_of(&mut script).expect("util-linux `script`");
    let tty = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{tty}");
    assert!(tty.contains("baking mesh") && tty.contains("100%"), "no progress bar on a terminal:\n{tty}");
}
