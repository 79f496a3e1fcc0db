//! Reading hadou's images back to the host, in both modes: recorded after `record_frame` into the
//! same command buffer, read after the caller's fence.

use crate::gpu::memory::MemoryLocation;

use super::Renderer;
use crate::aov::{Aov, AovImage};
use crate::frame::{record_scope, Timestamps};
use crate::gpu::barriers::{cmd_barriers, memory_barrier, ImageAccess};
use crate::gpu::memory::Buffer;
use crate::gpu::recorder::Recorder;
use crate::gpu::vk;
use crate::targets::Target;
use crate::Error;

/// Host-visible copies of some of hadou's images. Read them after the frame's fence; dropping the
/// set frees its buffers (with the frames that may still write them).
pub struct AovReadback {
    /// The frame's size in pixels (every image read back has it).
    pub extent: vk::Extent2D,
    buffers: Vec<(Target, Buffer)>,
}

impl AovReadback {
    /// The raw texels of `target` (tightly packed, row 0 at the top).
    pub fn bytes(&self, target: Target) -> Option<&[u8]> {
        self.buffers.iter().find(|(t, _)| *t == target).and_then(|(_, b)| b.mapped())
    }

    /// The tonemapped colour, if it was read back (`Renderer::record_view_color_readback`): RGBA8,
    /// sRGB-encoded, row 0 at the top.
    pub fn color(&self) -> Option<&[u8]> {
        self.bytes(Target::Ldr)
    }

    /// An AOV as f32, if it was read back.
    pub fn aov(&self, aov: Aov) -> Option<AovImage> {
        let bytes = self.bytes(aov.target())?;
        Some(AovImage::decode(aov, self.extent.width, self.extent.height, bytes))
    }

    /// As `aov`, with a host allocation that fails an error rather than an abort.
    pub fn try_aov(&self, aov: Aov) -> Result<Option<AovImage>, Error> {
        let Some(bytes) = self.bytes(aov.target()) else { return Ok(None) };
        Ok(Some(AovImage::try_decode(aov, self.extent.width, self.extent.height, bytes)?))
    }
}

impl Renderer {
    /// Records copies of `aovs` after the frame `record_frame` just recorded into `cmd` (its
    /// first view's, with `record_views`).
    pub fn record_aov_readback(
        &mut self,
        cmd: vk::CommandBuffer,
        aovs: &[Aov],
    ) -> Result<AovReadback, Error> {
        self.record_view_aov_readback(cmd, 0, aovs)
    }

    /// Records copies of view `view`'s `aovs` after the frame `record_views` just recorded into
    /// `cmd`. `Error::NoFrameRecorded` when that frame did not record the view (none so far, or
    /// it was 0 × 0).
    pub fn record_view_aov_readback(
        &mut self,
        cmd: vk::CommandBuffer,
        view: usize,
        aovs: &[Aov],
    ) -> Result<AovReadback, Error> {
        let targets: Vec<Target> = aovs.iter().map(|a| a.target()).collect();
        self.record_view_readback(cmd, view, &targets)
    }

    /// Records a copy of view `view`'s tonemapped colour (a view without an `ExternalColor`), read
    /// with `AovReadback::color`; as `record_view_aov_readback` otherwise.
    pub fn record_view_color_readback(
        &mut self,
        cmd: vk::CommandBuffer,
        view: usize,
    ) -> Result<AovReadback, Error> {
        self.record_view_readback(cmd, view, &[Target::Ldr])
    }

    /// Records copies of `wanted` targets (e.g. `Target::Ldr` for the headless colour).
    pub(crate) fn record_readback(
        &mut self,
        cmd: vk::CommandBuffer,
        wanted: &[Target],
    ) -> Result<AovReadback, Error> {
        self.record_view_readback(cmd, 0, wanted)
    }

    fn record_view_readback(
        &mut self,
        cmd: vk::CommandBuffer,
        view: usize,
        wanted: &[Target],
    ) -> Result<AovReadback, Error> {
        let mut wanted = wanted.to_vec();
        wanted.sort();
        wanted.dedup();
        let passes = self.pass_names().join(", ");
        let recorded = self.current.filter(|_| self.current_views.contains(&view));
        let (Some(targets), Some(slot)) = (self.targets.get_mut(view), recorded) else {
            return Err(Error::NoFrameRecorded);
        };
        if let Some(&missing) = wanted.iter().find(|t| !targets.contains(**t)) {
            return Err(Error::NotProduced { target: missing.name(), passes, needs: missing.needs() });
        }
        // The colour is the output itself: always written.
        let declared =
            |t: &Target| *t == Target::Ldr || self.current_readbacks.as_ref().is_none_or(|r| r.contains(t));
        if let Some(&missing) = wanted.iter().find(|t| !declared(t)) {
            let needs = "declaring it with Renderer::set_readbacks before the frame is recorded";
            return Err(Error::NotProduced { target: missing.name(), passes, needs });
        }
        let extent = targets.extent;
        let mut readback = AovReadback { extent, buffers: Vec::new() };
        for &target in &wanted {
            let size = (extent.width as u64)
                .checked_mul(extent.height as u64)
                .and_then(|n| n.checked_mul(target.texel_bytes()))
                .ok_or(Error::FrameSize { width: extent.width, height: extent.height, max: u32::MAX })?;
            let name = format!("readback {}", target.name());
            let usage = vk::BufferUsageFlags::TRANSFER_DST;
            let buffer =
                self.memory.create_buffer(&self.ctx, &name, size, usage, MemoryLocation::GpuToCpu)?;
            readback.buffers.push((target, buffer));
        }
        let ctx = &self.ctx;
        let barriers: Vec<_> =
            wanted.iter().filter_map(|&t| targets.transition(t, ImageAccess::TRANSFER_SRC)).collect();
        let s = &mut self.slots[slot][view];
        let mut timestamps: Timestamps = Some(&mut s.timestamps);
        let rec = Recorder { ctx, cmd };
        let scope = record_scope(ctx, cmd, &mut timestamps, "readback", &barriers, || {
            for (target, buffer) in &readback.buffers {
                rec.copy_image_to_buffer(&targets.image(*target), buffer);
            }
            let to_host = memory_barrier(
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_WRITE,
                vk::PipelineStageFlags2::HOST,
                vk::AccessFlags2::HOST_READ,
            );
            cmd_barriers(&ctx.device, cmd, &[], &[to_host]);
        });
        s.scopes.push(scope);
        // The read-back's timestamps join the frame's copy.
        s.record_timestamp_copy(ctx, cmd);
        Ok(readback)
    }
}
