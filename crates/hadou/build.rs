//! Links glslang and SPIRV-Tools statically for this package's test binaries (the shared function
//! in crates/hadou-gpu/link_shaderc.rs, see DESIGN.md), and lists every file under the workspace's
//! `shaders/` for `passes::SHADERS`, so a new shader needs no registration of its own.
include!("../hadou-gpu/link_shaderc.rs");

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=../hadou-gpu/link_shaderc.rs");
    embed_shaders();
    link_shaderc();
}

/// Writes `$OUT_DIR/shaders.rs`: `(path under shaders/, include_str!(..))` for every shader file.
fn embed_shaders() {
    // At run time, not `env!` at the script's compile time: a target folder shared by worktrees
    // (or copied from another checkout) reuses the compiled script, which then embedded the
    // other checkout's shaders.
    let manifest = std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let root = std::path::Path::new(&manifest).join("../../shaders");
    println!("cargo:rerun-if-changed={}", root.display());
    let mut files = Vec::new();
    let mut dirs = vec![root.clone()];
    while let Some(dir) = dirs.pop() {
        println!("cargo:rerun-if-changed={}", dir.display());
        let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                dirs.push(path);
            } else if matches!(
                path.extension().and_then(|e| e.to_str()),
                Some("comp" | "vert" | "frag" | "glsl")
            ) {
                files.push(path);
            }
        }
    }
    files.sort();
    let mut out = String::from("&[\n");
    for path in files {
        let rel = path.strip_prefix(&root).expect("under shaders/").to_string_lossy().replace('\\', "/");
        out += &format!("    ({rel:?}, include_str!({:?})),\n", path.display().to_string());
    }
    out += "]\n";
    let dest =
        std::path::Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("shaders.rs");
    std::fs::write(dest, out).expect("write shaders.rs");
}
