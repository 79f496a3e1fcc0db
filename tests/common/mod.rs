//! Shared test set-up: every GPU test runs with validation and synchronization validation on,
//! and asserts zero errors and zero warnings. No device is a failure, never a skip.
#![allow(dead_code)]

pub mod cli;
pub mod gltf_writer;
pub mod host;
pub mod march_bound;
pub mod metaball_bound;
pub mod mutate;
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

/// A runtime with validation on, checked when it is dropped: after the device is destroyed (so
/// leaked objects, reported at vkDestroyDevice, count) the log must hold no error and no warning.
/// Panics (fails the test) when no Vulkan device exists.
pub fn runtime() -> CheckedRuntime {
    CheckedRuntime(Some(runtime_unchecked()))
}

/// A runtime with validation on and no check at drop: for tests that provoke messages on purpose.
pub fn runtime_unchecked() -> Runtime {
    runtime_with_effects_unchecked(hadou::effect::Effects::builtin())
}

/// As `runtime`, running `effects` (a game's own effects registered after hadou's).
pub fn runtime_with_effects(effects: hadou::effect::Effects) -> CheckedRuntime {
    CheckedRuntime(Some(runtime_with_effects_unchecked(effects)))
}

fn runtime_with_effects_unchecked(effects: hadou::effect::Effects) -> Runtime {
    let options = RuntimeOptions { validation: true, device: std::env::var("HADOU_DEVICE").ok(), effects };
    Runtime::new(&options).unwrap_or_else(|e| panic!("GPU tests need a Vulkan device (lavapipe in CI): {e}"))
}

/// A [`Runtime`] that asserts a clean validation log after its device is destroyed.
pub struct CheckedRuntime(Option<Runtime>);

impl CheckedRuntime {
    /// Destroys the runtime now and asserts its log is clean (leaks included).
    pub fn finish(mut self) {
        self.check();
    }

    fn check(&mut self) {
        if let Some(rt) = self.0.take() {
            let log = rt.validation_log();
            drop(rt);
            // A test already failing keeps its own message (a second panic would abort).
            if !std::thread::panicking() {
                assert_log_clean(&log, "after the device was destroyed");
            }
        }
    }
}

impl std::ops::Deref for CheckedRuntime {
    type Target = Runtime;
    fn deref(&self) -> &Runtime {
        self.0.as_ref().expect("a live runtime")
    }
}

impl std::ops::DerefMut for CheckedRuntime {
    fn deref_mut(&mut self) -> &mut Runtime {
        self.0.as_mut().expect("a live runtime")
    }
}

impl Drop for CheckedRuntime {
    fn drop(&mut self) {
        self.check();
    }
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
/// drive a `Renderer` themselves), and the guard that checks its log once everything holding the
/// device is gone. Bind the guard first — `let (_leaks, ctx) = common::context();` — so it is
/// dropped last (bindings drop in reverse order). Panics when no Vulkan device exists.
pub fn context() -> (LogCheck, hadou::gpu::GpuContext) {
    let ctx = context_unchecked();
    (LogCheck(ctx.validation_log()), ctx)
}

/// A context with validation on and no check: for tests that provoke messages on purpose.
pub fn context_unchecked() -> hadou::gpu::GpuContext {
    let options =
        hadou::gpu::ContextOptions { validation: true, device_filter: std::env::var("HADOU_DEVICE").ok() };
    hadou::gpu::GpuContext::new(&options)
        .unwrap_or_else(|e| panic!("GPU tests need a Vulkan device (lavapipe in CI): {e}"))
}

/// Asserts, when dropped, that a validation log holds no error and no warning (the log outlives
/// the device, so what vkDestroyDevice reports about leaks is in it by then).
#[must_use = "bind it (`let (_leaks, ctx) = …`): `_` would check at once, before any work"]
pub struct LogCheck(pub std::sync::Arc<hadou::gpu::validation::ValidationLog>);

impl Drop for LogCheck {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            assert_log_clean(&self.0, "after the device was destroyed");
        }
    }
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
