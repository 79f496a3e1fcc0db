//! The math of each effect on the CPU in f64: the references GPU passes are checked against.

pub mod raycast;
pub mod tonemap;
