//! The `hadou` command's own code: `hadou report`, `hadou profile` and `hadou profile-diff`, written
//! on the library's public API alone (the binary in `main.rs` parses the command line and calls
//! into the library and these modules). Tests reach them here.

// No Vulkan of its own and no unsafe code: tests/layers.rs checks this crate names nothing the
// library hides.
#![deny(unsafe_code)]

pub mod profile;
pub mod profile_diff;
pub mod report;
