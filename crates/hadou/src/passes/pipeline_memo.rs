//! Pipelines kept across the rebuilds of the passes that use them. A pass built on shared data
//! that is replaced — a run-time bake's new thickness tables — is built again; compiling its
//! pipelines again would stall the frame that puts the bake in use (18–45 ms on lavapipe, more
//! under validation). Built through the scene's memo, the new pass takes back the pipelines the
//! old one had: the same shader and defines, the same pipeline.

use std::sync::{Arc, Mutex};

use crate::gpu::pipeline::Pipeline;
use crate::gpu::GpuResult;

/// The pipelines made for one scene's passes, by a key naming the shader and its variant; freed
/// with the scene's shared data.
#[derive(Default)]
pub struct PipelineMemo {
    made: Mutex<Vec<(String, Arc<Pipeline>)>>,
}

impl PipelineMemo {
    /// The pipeline made for `key`, or `make`'s, kept for the next pass that asks.
    pub fn get_or_make(
        &self,
        key: &str,
        make: impl FnOnce() -> GpuResult<Pipeline>,
    ) -> GpuResult<Arc<Pipeline>> {
        let mut made = self.made.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, p)) = made.iter().find(|(k, _)| k == key) {
            return Ok(p.clone());
        }
        let p = Arc::new(make()?);
        made.push((key.to_string(), p.clone()));
        Ok(p)
    }
}
