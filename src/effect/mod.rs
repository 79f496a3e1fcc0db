//! Effects as plug-ins (placeholder while being written).

mod error;

pub use error::EffectError;
