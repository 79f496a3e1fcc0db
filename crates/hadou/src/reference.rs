//! The f64 CPU twins of the built-in effects, which the tests and `hadou report` compare the GPU
//! against, and the memory figures the report prints. A game checking its own scenes (or its own
//! effect composed with these) can call them too; each names its GPU counterpart.

pub use crate::effects::energy_wave::{line_integral, WaveParams};
pub use crate::effects::metaballs_compare::{compare_metaballs, MetaballErrorStats, MetaballFrame};
pub use crate::effects::raycast::{MeshBvh, SceneCaster};
pub use crate::effects::thickness::{exact_thickness, tsm_thickness};
pub use crate::effects::translucency::{exit_weight, light_map_size, translucent_colour};
pub use crate::passes::energy_wave::wave_params;
pub use crate::passes::peel::image_bytes as peel_image_bytes;
