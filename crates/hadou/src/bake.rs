//! Offline bakes of translucent meshes: the thickness field LUT (`thickness = "lut"`), the seed's
//! pair tables (`thickness = "pairs"`), and the on-disk cache the renderer reads them back from.
//! The renderer bakes by itself in the background when a scene needs a table it has not cached;
//! this is for an asset pipeline that bakes ahead of time (what `hadou bake` runs).

pub use crate::effects::bake_cache;
pub use crate::effects::pair_cache;
pub use crate::effects::thickness_lut;
pub use crate::effects::thickness_pairs;
pub use crate::effects::voxelize::MAX_VOXEL_RES;
