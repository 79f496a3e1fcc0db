//! Links glslang and SPIRV-Tools statically: Debian's `libshaderc_combined.a` leaves them out,
//! and linking the shared `libshaderc.so` against glslang 12 archives crashes (see DESIGN.md).
//! Also lists every file under `shaders/` for `gpu::shader::EMBEDDED`, so a new shader needs no
//! registration of its own.
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    embed_shaders();
    println!("cargo:rerun-if-env-changed=SHADERC_LIB_DIR");
    let dir = std::env::var("SHADERC_LIB_DIR").unwrap_or_else(|_| "/usr/lib/x86_64-linux-gnu".into());
    println!("cargo:rustc-link-search=native={dir}");
    // Link arguments go after every crate's archives on the command line, so the static
    // archives resolve the symbols shaderc_combined (inside shaderc-sys) leaves undefined.
    for lib in [
        "glslang",
        "MachineIndependent",
        "GenericCodeGen",
        "OSDependent",
        "OGLCompiler",
        "SPIRV",
        "SPIRV-Tools-opt",
        "SPIRV-Tools",
    ] {
        println!("cargo:rustc-link-arg=-l:lib{lib}.a");
    }
    println!("cargo:rustc-link-arg=-lstdc++");
}

/// Writes `$OUT_DIR/shaders.rs`: `(path under shaders/, include_str!(..))` for every shader file.
fn embed_shaders() {
    // Read at run time: `env!` would bake in the tree the build script was compiled for, and a
    // target folder copied from another checkout would then embed that checkout's shaders.
    let manifest = std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let root = std::path::Path::new(&manifest).join("shaders");
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
