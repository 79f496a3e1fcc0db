//! The passes that touch the game's images (depth import, composite), made the first time a game
//! hands such an image: the headless path never builds them.

use super::composite::Composite;
use super::depth_import::DepthImport;
use crate::gpu::memory::Memory;
use crate::gpu::GpuContext;

#[derive(Default)]
pub struct External {
    pub depth: Option<DepthImport>,
    pub composite: Option<Composite>,
}

impl External {
    /// Drops what depends on the frame's size or images (no frame pending).
    pub fn drop_sized(&mut self, ctx: &GpuContext, memory: &Memory) {
        if let Some(d) = &mut self.depth {
            d.drop_sized(ctx, memory);
        }
        if let Some(c) = &mut self.composite {
            c.drop_sized(ctx);
        }
    }

    pub fn destroy(&mut self, ctx: &GpuContext, memory: &Memory) {
        if let Some(d) = self.depth.take() {
            d.destroy(ctx, memory);
        }
        if let Some(c) = self.composite.take() {
            c.destroy(ctx);
        }
    }
}
