//! The layers are crates, and the build keeps them: only crates/hadou-gpu depends on ash (and the
//! other Vulkan crates) and holds `unsafe` Vulkan calls; the library (crates/hadou) and the command
//! line above it (this package: src/) have neither (`#![deny(unsafe_code)]`, the signal handler of
//! `output::interrupt` the one allowed exception), and the command line uses the library's public
//! API alone (no module the library hides from its docs). These checks fail when a manifest, a
//! crate root or an import loses that.

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
    for layer in ["crates/hadou-gpu", "crates/hadou", "."] {
        assert!(members.contains(&layer.to_string()), "{layer} is not a member: {members:?}");
    }
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
    let (lib, cli) = (root().join("crates/hadou/src"), root().join("src"));
    for crate_root in [lib.join("lib.rs"), cli.join("lib.rs"), cli.join("main.rs")] {
        let text = std::fs::read_to_string(&crate_root).unwrap();
        assert!(
            text.contains("#![deny(unsafe_code)]"),
            "{} lost #![deny(unsafe_code)]",
            crate_root.display()
        );
    }
    // The one exception, and nothing else names `unsafe`.
    let (allowed, allowing) = (lib.join("output/interrupt.rs"), lib.join("output.rs"));
    let mut found = Vec::new();
    for path in [sources(&lib), sources(&cli)].concat() {
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
    let text = std::fs::read_to_string(lib.join("output.rs")).unwrap();
    assert!(text.contains("#[allow(unsafe_code)]\npub mod interrupt;"), "the one exception moved");
    assert_eq!(text.matches("allow(unsafe_code)").count(), 1, "output.rs allows unsafe code once");
    assert!(found.is_empty(), "unsafe code above the GPU crate:\n{}", found.join("\n"));
}

/// The names `crates/hadou/src/lib.rs` declares or re-exports under `#[doc(hidden)]`.
fn hidden_library_modules() -> Vec<String> {
    let text = std::fs::read_to_string(root().join("crates/hadou/src/lib.rs")).unwrap();
    let lines: Vec<&str> = text.lines().map(str::trim).collect();
    let mut hidden = Vec::new();
    for pair in lines.windows(2) {
        if pair[0] != "#[doc(hidden)]" {
            continue;
        }
        let item = pair[1].trim_end_matches(';');
        let name = if let Some(m) = item.strip_prefix("pub mod ") {
            m.to_string()
        } else if let Some(u) = item.strip_prefix("pub use ") {
            u.rsplit([':', ' ']).next().unwrap().to_string()
        } else {
            panic!("lib.rs hides something this test does not read: {item}");
        };
        hidden.push(name);
    }
    hidden
}

/// `hadou::NAME` paths in `code`, including the first segment of each `use hadou::{..}` group
/// member (`use hadou::{scene, passes::x}` names `scene` and `passes`).
fn library_names(code: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut rest = code;
    while let Some(at) = rest.find("hadou::") {
        let before = rest[..at].chars().next_back();
        rest = &rest[at + "hadou::".len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue; // hadou_cli::, my_hadou::
        }
        if let Some(group) = rest.strip_prefix('{') {
            // Members at the group's top level: nested groups (`scene::{A, B}`) are skipped over.
            let (mut depth, mut member) = (0, String::new());
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        names.push(member.trim().split("::").next().unwrap_or_default().to_string());
                        member.clear();
                        continue;
                    }
                    _ => {}
                }
                member.push(c);
            }
            names.push(member.trim().split("::").next().unwrap_or_default().to_string());
        } else {
            let end = rest.find(|c: char| !(c.is_alphanumeric() || c == '_')).unwrap_or(rest.len());
            names.push(rest[..end].to_string());
        }
    }
    names
}

#[test]
fn the_command_line_uses_the_public_api_alone() {
    let hidden = hidden_library_modules();
    assert!(hidden.contains(&"passes".to_string()), "the reading of lib.rs broke: {hidden:?}");
    let mut found = Vec::new();
    for path in sources(&root().join("src")) {
        // `use` groups span lines: read the file with its comments removed, as one string.
        let text = std::fs::read_to_string(&path).unwrap();
        let code: String =
            text.lines().map(|l| l.split("//").next().unwrap_or_default()).collect::<Vec<_>>().join(" ");
        for name in library_names(&code) {
            if hidden.contains(&name) {
                found.push(format!("{}: hadou::{name}", path.display()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "the command line reaches into the library's hidden modules:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_import_reader_sees_groups_and_paths() {
    let code = "use hadou::{scene::{A, B}, passes::plan}; let x = hadou::effects::y; hadou_cli::report; ";
    assert_eq!(library_names(code), ["scene", "passes", "effects"]);
}
