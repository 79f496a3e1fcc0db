//! Links shaderc's missing static archives for this crate's own test binaries.
include!("link_shaderc.rs");

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=link_shaderc.rs");
    link_shaderc();
}
