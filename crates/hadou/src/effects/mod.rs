//! The math of each effect on the CPU in f64: the references GPU passes are checked against.

pub mod bake_cache;
pub mod energy_wave;
pub mod energy_wave_f32;
pub mod metaballs;
pub mod metaballs_compare;
pub mod metaballs_f32;
pub mod metaballs_trace;
pub mod pair_cache;
pub mod peel;
pub mod raycast;
pub mod shading;
pub mod thickness;
pub mod thickness_lut;
pub mod thickness_pairs;
pub mod tonemap;
pub mod translucency;
pub mod translucency_budget;
pub mod upscaler;
pub mod voxelize;
