//! Running the `hadou` binary from tests: the command, its output as text, scratch folders.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// `hadou ARGS` in the source tree with validation on, to completion.
pub fn hadou(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hadou"))
        .args(args)
        .current_dir(super::root())
        .env("HADOU_VALIDATION", "1")
        .output()
        .expect("run hadou")
}

/// stdout then stderr, for assertions and failure messages.
pub fn text(out: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

/// An empty folder of this test process named `name` under the temp folder (emptied first).
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hadou-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A path as an argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}
