//! Shared test set-up: every GPU test runs with validation and synchronization validation on,
//! and asserts zero errors and zero warnings. No device is a failure, never a skip.
#![allow(dead_code)]

pub mod host;

use std::path::{Path, PathBuf};

use hadou::scene::Scene;
use hadou::{Runtime, RuntimeOptions};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn asset(rel: &str) -> PathBuf {
    root().join(rel)
}

pub fn load(rel: &str) -> Scene {
    let path = asset(rel);
    hadou::scene::load_scene(&path).unwrap_or_else(|e| panic!("{e}"))
}

pub fn parse(text: &str) -> Scene {
    hadou::scene::parse_scene(text, Path::new("inline.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// A runtime with validation on; panics (fails the test) when no Vulkan device exists.
pub fn runtime() -> Runtime {
    let options = RuntimeOptions { validation: true, device: std::env::var("HADOU_DEVICE").ok() };
    Runtime::new(&options).unwrap_or_else(|e| panic!("GPU tests need a Vulkan device (lavapipe in CI): {e}"))
}

/// Fails the test when validation reported anything.
pub fn assert_clean(runtime: &Runtime) {
    let counts = runtime.validation_counts();
    assert!(
        counts.errors == 0 && counts.warnings == 0,
        "validation: {} errors, {} warnings:\n{}",
        counts.errors,
        counts.warnings,
        runtime.validation_messages().join("\n")
    );
}
