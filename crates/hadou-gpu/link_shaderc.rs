// Shared by this crate's build.rs and the workspace root's (a dependency's `rustc-link-arg` does
// not reach the binaries of the crates above it, so each package whose targets link shaderc
// emits these itself).

/// Links glslang and SPIRV-Tools statically: Debian's `libshaderc_combined.a` leaves them out,
/// and linking the shared `libshaderc.so` against glslang 12 archives crashes (see DESIGN.md).
fn link_shaderc() {
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
