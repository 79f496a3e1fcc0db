//! The pipeline cache on disk: written when the renderer is dropped, read back by the next one,
//! and a file that is not this device's cache (garbage, another device's header) is ignored and
//! replaced, never an error. Lavapipe, validation on.

mod common;

use hadou::{FrameInputs, Renderer, RendererOptions};

/// A renderer on a fresh context with its cache in `dir`, and the guard that checks that context's
/// validation log once the renderer (and with it the device) is gone: drop the renderer first.
fn renderer(dir: &std::path::Path) -> (common::LogCheck, Renderer) {
    let (leaks, ctx) = common::context();
    let options =
        RendererOptions { pipeline_cache_dir: Some(dir.to_path_buf()), ..RendererOptions::default() };
    let mut r = Renderer::with_options(ctx, &options).unwrap();
    r.load_scene(common::load("assets/scenes/showcase.toml")).unwrap();
    r.prepare(&FrameInputs::headless(32, 32, 0.0)).unwrap();
    (leaks, r)
}

/// Runs a renderer on `dir`'s cache and shuts it down (saving the cache); its log, leaks included,
/// must be clean after the device was destroyed.
fn run_once(dir: &std::path::Path) {
    let (leaks, r) = renderer(dir);
    drop(r);
    drop(leaks);
}

fn cache_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("pipelines-")))
        .collect();
    files.sort();
    files
}

#[test]
fn the_cache_is_saved_reused_and_a_foreign_file_is_replaced() {
    let dir = std::env::temp_dir().join(format!("hadou-pipeline-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // Each of the three contexts (a fresh cache, a reused one, garbage) is checked after its
    // device was destroyed: no error, no warning, nothing leaked.
    run_once(&dir);
    let files = cache_files(&dir);
    assert_eq!(files.len(), 1, "one cache file per device: {files:?}");
    let saved = std::fs::read(&files[0]).unwrap();
    // Vulkan's header: length, version 1, vendor, device, UUID (32 bytes), then the driver's data
    // (lavapipe keeps none: Mesa's own disk cache holds its compiled shaders).
    assert!(saved.len() >= 32 && u32::from_le_bytes(saved[4..8].try_into().unwrap()) == 1, "{saved:?}");

    // The second renderer starts from it and saves it again (the same pipelines: no growth).
    run_once(&dir);
    let again = std::fs::read(&files[0]).unwrap();
    assert!(
        again.len() >= saved.len() / 2 && again.len() <= saved.len() * 2,
        "{} vs {}",
        again.len(),
        saved.len()
    );

    // Garbage where the cache was: ignored, then replaced by a valid cache.
    std::fs::write(&files[0], b"not a pipeline cache").unwrap();
    run_once(&dir);
    let replaced = std::fs::read(&files[0]).unwrap();
    assert!(replaced.len() >= 32 && replaced[..32] == saved[..32], "a valid cache again");

    // A link where the cache file goes is not a file of ours: neither it nor what it points at is
    // replaced, and no temporary is left beside it.
    let target = dir.join("elsewhere.txt");
    std::fs::write(&target, b"someone else's").unwrap();
    std::fs::remove_file(&files[0]).unwrap();
    std::os::unix::fs::symlink(&target, &files[0]).unwrap();
    run_once(&dir);
    assert!(std::fs::symlink_metadata(&files[0]).unwrap().file_type().is_symlink(), "the link was replaced");
    assert_eq!(std::fs::read(&target).unwrap(), b"someone else's");
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().flatten().map(|e| e.file_name()).collect();
    assert_eq!(left.len(), 2, "only the link and its target: {left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
