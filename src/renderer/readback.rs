//! Reading hadou's images back to the host, in both modes: recorded after `record_frame` into the
//! same command buffer, read after the caller's fence.

use gpu_allocator::MemoryLocation;

use super::Renderer;
use crate::aov::{Aov, AovImage};
use crate::frame::record_scope;
use crate::gpu::barriers::{cmd_barriers, memory_barrier, ImageAccess};
use crate::gpu::memory::Buffer;
use crate::gpu::recorder::Recorder;
use crate::gpu::{vk, GpuError};
use crate::targets::Target;
use crate::Error;

/// Host-visible copies of some of hadou's images. Read them after the frame's fence, then hand
/// the set back with `Renderer::release_readback` (its buffers are hadou's).
pub struct AovReadback {
    pub extent: vk::Extent2D,
    buffers: Vec<(Target, Buffer)>,
}

impl AovReadback {
    /// The raw texels of `target` (tightly packed, row 0 at the top).
    pub fn bytes(&self, target: Target) -> Option<&[u8]> {
        self.buffers.iter().find(|(t, _)| *t == target).and_then(|(_, b)| b.mapped())
    }

    /// An AOV as f32, if it was read back.
    pub fn aov(&self, aov: Aov) -> Option<AovImage> {
        let bytes = self.bytes(aov.target())?;
        Some(AovImage::decode(aov, self.extent.width, self.extent.height, bytes))
    }
}

impl Renderer {
    /// Records copies of `aovs` after the frame `record_frame` just recorded into `cmd`.
    pub fn record_aov_readback(
        &mut self,
        cmd: vk::CommandBuffer,
        aovs: &[Aov],
    ) -> Result<AovReadback, Error> {
        let targets: Vec<Target> = aovs.iter().map(|a| a.target()).collect();
        self.record_readback(cmd, &targets)
    }

    /// Records copies of `wanted` targets (e.g. `Target::Ldr` for the headless colour).
    pub fn record_readback(
        &mut self,
        cmd: vk::CommandBuffer,
        wanted: &[Target],
    ) -> Result<AovReadback, Error> {
        let mut wanted = wanted.to_vec();
        wanted.sort();
        wanted.dedup();
        if let Some(missing) = wanted.iter().find(|t| !self.produces(**t)) {
            return Err(Error::InvalidRequest(format!(
                "AOV {} is not produced by this scene's passes ({}): e.g. `energy` needs a [[wave]]",
                missing.name(),
                self.pass_names().join(", ")
            )));
        }
        let Some(targets) = &mut self.targets else {
            return Err(Error::InvalidRequest("no frame recorded yet (or it was 0 × 0)".into()));
        };
        let extent = targets.extent;
        let mut readback = AovReadback { extent, buffers: Vec::new() };
        for &target in &wanted {
            let size = extent.width as u64 * extent.height as u64 * target.texel_bytes();
            let name = format!("readback {}", target.name());
            let usage = vk::BufferUsageFlags::TRANSFER_DST;
            match self.memory.create_buffer(&self.ctx, &name, size, usage, MemoryLocation::GpuToCpu) {
                Ok(buffer) => readback.buffers.push((target, buffer)),
                Err(e) => {
                    readback.buffers.into_iter().for_each(|(_, b)| self.memory.destroy_buffer(&self.ctx, b));
                    return Err(e.into());
                }
            }
        }
        let ctx = &self.ctx;
        let barriers: Vec<_> =
            wanted.iter().filter_map(|&t| targets.transition(t, ImageAccess::TRANSFER_SRC)).collect();
        let mut timestamps = self.timings.pool();
        let rec = Recorder { ctx, cmd };
        let scope = record_scope(ctx, cmd, &mut timestamps, "readback", &barriers, || {
            for (target, buffer) in &readback.buffers {
                rec.copy_image_to_buffer(targets.image(*target), buffer);
            }
            let to_host = memory_barrier(
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_WRITE,
                vk::PipelineStageFlags2::HOST,
                vk::AccessFlags2::HOST_READ,
            );
            cmd_barriers(&ctx.device, cmd, &[], &[to_host]);
        });
        self.timings.push_scopes(&[scope]);
        Ok(readback)
    }

    /// Frees a read-back's buffers (after the frame's fence).
    pub fn release_readback(&self, readback: AovReadback) {
        readback.buffers.into_iter().for_each(|(_, b)| self.memory.destroy_buffer(&self.ctx, b));
    }
}

/// An error for a target that should have been read back but was not.
pub fn not_read_back(target: Target) -> Error {
    Error::Gpu(GpuError::Limit { what: target.name().into(), message: "not read back".into() })
}
