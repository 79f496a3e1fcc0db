//! Links glslang and SPIRV-Tools statically for the `hadou` binary, the tests and the examples (the
//! shared function in crates/hadou-gpu/link_shaderc.rs, see DESIGN.md): a dependency's
//! `rustc-link-arg` does not reach this package's binaries.
include!("crates/hadou-gpu/link_shaderc.rs");

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=crates/hadou-gpu/link_shaderc.rs");
    link_shaderc();
}
