//! Shared test set-up: every GPU test runs with validation and synchronization validation on,
//! and asserts zero errors and zero warnings. No device is a failure, never a skip.
#![allow(dead_code)]

pub mod cli;
pub mod gltf_writer;
pub mod host;
pub mod xvfb;

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

/// A context of hadou's own with validation and synchronization validation on (for tests that
/// drive a `Renderer` themselves); panics when no Vulkan device exists.
pub fn context() -> hadou::gpu::GpuContext {
    let options =
        hadou::gpu::ContextOptions { validation: true, device_filter: std::env::var("HADOU_DEVICE").ok() };
    hadou::gpu::GpuContext::new(&options)
        .unwrap_or_else(|e| panic!("GPU tests need a Vulkan device (lavapipe in CI): {e}"))
}

/// Fails when validation reported anything so far (leaked objects are reported at device destroy,
/// into the same log, which outlives the context).
pub fn assert_log_clean(log: &hadou::gpu::validation::ValidationLog, when: &str) {
    let c = log.counts();
    assert!(c.errors == 0 && c.warnings == 0, "{when}: validation {c:?}:\n{}", log.messages().join("\n"));
}

/// Whether two AOVs hold the same bits.
pub fn same_bits(a: &hadou::AovImage, b: &hadou::AovImage) -> bool {
    a.data.len() == b.data.len() && a.data.iter().zip(&b.data).all(|(x, y)| x.to_bits() == y.to_bits())
}
