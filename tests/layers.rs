//! The layers are crates, and the build keeps them: only crates/hadou-gpu depends on ash (and the
//! other Vulkan crates) and holds `unsafe` Vulkan calls; the library and the command line above it
//! have neither (`#![deny(unsafe_code)]`, the signal handler of `output::interrupt` the one
//! allowed exception). These checks fail when a manifest or a crate root loses that.

use std::path::{Path, PathBuf};

const VULKAN_CRATES: &[&str] = &["ash", "ash-window", "gpu-allocator", "shaderc", "shaderc-sys"];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn manifest(path: &Path) -> toml::Table {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.parse().unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn dependencies(table: &toml::Table, section: &str) -> Vec<String> {
    table.get(section).and_then(|d| d.as_table()).map_or(Vec::new(), |d| d.keys().cloned().collect())
}

#[test]
fn only_the_gpu_crate_depends_on_vulkan() {
    let top = manifest(&root().join("Cargo.toml"));
    let members: Vec<String> = top["workspace"]["members"]
        .as_array()
        .expect("a [workspace] with members")
        .iter()
        .map(|m| m.as_str().unwrap().to_string())
        .collect();
    assert!(members.contains(&"crates/hadou-gpu".to_string()), "{members:?}");
    for member in &members {
        let table = manifest(&root().join(member).join("Cargo.toml"));
        let deps =
            [dependencies(&table, "dependencies"), dependencies(&table, "build-dependencies")].concat();
        let vulkan: Vec<&String> = deps.iter().filter(|d| VULKAN_CRATES.contains(&d.as_str())).collect();
        if member == "crates/hadou-gpu" {
            assert!(deps.contains(&"ash".to_string()), "hadou-gpu is the layer that calls ash: {deps:?}");
        } else {
            assert!(vulkan.is_empty(), "{member} depends on {vulkan:?}: only crates/hadou-gpu may");
        }
    }
}

/// Every `.rs` file under `dir`.
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut dirs = vec![dir.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for entry in std::fs::read_dir(&d).unwrap().flatten() {
            let path = entry.path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn above_the_gpu_crate_there_is_no_unsafe_code() {
    let src = root().join("src");
    for crate_root in ["lib.rs", "main.rs"] {
        let text = std::fs::read_to_string(src.join(crate_root)).unwrap();
        assert!(text.contains("#![deny(unsafe_code)]"), "src/{crate_root} lost #![deny(unsafe_code)]");
    }
    // The one exception, and nothing else names `unsafe`.
    let (allowed, allowing) = (src.join("output/interrupt.rs"), src.join("output.rs"));
    let mut found = Vec::new();
    for path in sources(&src) {
        let text = std::fs::read_to_string(&path).unwrap();
        for (i, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or_default();
            let names_unsafe =
                code.contains("unsafe {") || code.contains("unsafe fn") || code.contains("unsafe impl");
            let allows = code.contains("allow(unsafe_code)");
            if (names_unsafe && path != allowed) || (allows && path != allowing) {
                found.push(format!("{}:{}: {}", path.display(), i + 1, line.trim()));
            }
        }
    }
    let text = std::fs::read_to_string(src.join("output.rs")).unwrap();
    assert!(text.contains("#[allow(unsafe_code)]\npub mod interrupt;"), "the one exception moved");
    assert_eq!(text.matches("allow(unsafe_code)").count(), 1, "src/output.rs allows unsafe code once");
    assert!(found.is_empty(), "unsafe code above the GPU crate:\n{}", found.join("\n"));
}
