//! A frame slot's upload ring: one persistently mapped host-visible buffer that a frame's
//! per-frame data (constants, instance tables, wave and metaball tables) is appended to. The slot
//! is written only when its previous frame has finished, so nothing the GPU may still read is
//! written on the host. A frame that needs more grows the ring: the old buffer is retired with
//! the frame (the data already placed in it stays valid until the frame finishes).

use gpu_allocator::MemoryLocation;

use super::error::{GpuError, GpuResult, VkResultExt};
use super::memory::{Buffer, Memory};
use super::pipeline::BufferRange;
use super::resources::{Garbage, Releaser};
use super::texel_buffer::Texels;
use super::{vk, GpuContext};

/// Bytes a ring starts with; it grows to the largest frame it has seen (half as large again).
const FIRST_BYTES: u64 = 64 * 1024;

pub struct UploadRing {
    name: String,
    buffer: Option<Buffer>,
    used: u64,
    /// Every offset handed out is a multiple of this (the device's uniform, storage and texel
    /// buffer offset alignments).
    align: u64,
}

/// One piece of an [`UploadRing::push_parts`] upload.
#[derive(Clone, Copy, Debug)]
pub enum RingPart<'a> {
    /// Bytes written now.
    Bytes(&'a [u8]),
    /// Room left as it is (whatever the ring held there): for data the device writes before
    /// anything reads it, so the host neither builds nor copies it.
    Room(usize),
}

/// Where one push landed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RingSlice {
    pub buffer: vk::Buffer,
    pub offset: u64,
    pub size: u64,
}

impl RingSlice {
    pub fn range(self) -> BufferRange {
        BufferRange { buffer: self.buffer, offset: self.offset, range: self.size, element_bytes: 0 }
    }
}

/// A texel view of a ring slice, made per frame and retired with it.
pub struct TexelView {
    pub raw: vk::BufferView,
    releaser: Releaser,
}

impl Drop for TexelView {
    fn drop(&mut self) {
        self.releaser.retire(Garbage::BufferView(self.raw));
    }
}

impl UploadRing {
    pub fn new(ctx: &GpuContext, name: &str) -> Self {
        let l = &ctx.limits;
        let align = [
            l.min_uniform_buffer_offset_alignment,
            l.min_storage_buffer_offset_alignment,
            l.min_texel_buffer_offset_alignment,
            16,
        ]
        .into_iter()
        .max()
        .unwrap_or(256);
        UploadRing { name: name.into(), buffer: None, used: 0, align }
    }

    /// Starts the slot's next frame: its previous frame has finished, so the whole ring is free.
    pub fn reset(&mut self) {
        self.used = 0;
    }

    /// Bytes the ring holds now (for reports).
    pub fn capacity(&self) -> u64 {
        self.buffer.as_ref().map_or(0, |b| b.size)
    }

    /// Appends `bytes` (at least 16 bytes are reserved, so an empty table still binds).
    pub fn push(&mut self, ctx: &GpuContext, memory: &Memory, bytes: &[u8]) -> GpuResult<RingSlice> {
        self.push_parts(ctx, memory, &[RingPart::Bytes(bytes)])
    }

    /// Appends `parts` one after the other, as one slice: their bytes are written, their room is
    /// not (at least 16 bytes are reserved in all).
    pub fn push_parts(
        &mut self,
        ctx: &GpuContext,
        memory: &Memory,
        parts: &[RingPart],
    ) -> GpuResult<RingSlice> {
        let length: usize = parts
            .iter()
            .map(|p| match p {
                RingPart::Bytes(b) => b.len(),
                RingPart::Room(n) => *n,
            })
            .sum();
        let size = (length as u64).max(16).next_multiple_of(16);
        let offset = self.used.next_multiple_of(self.align);
        let fits = self.buffer.as_ref().is_some_and(|b| offset + size <= b.size);
        let offset = if fits {
            offset
        } else {
            let grown = (self.capacity() + self.capacity() / 2).max(size + size / 2).max(FIRST_BYTES);
            // VERTEX_BUFFER: a deformed mesh's previous vertices (the raster's motion).
            let usage = vk::BufferUsageFlags::UNIFORM_BUFFER
                | vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER
                | vk::BufferUsageFlags::VERTEX_BUFFER
                // TRANSFER_DST: a game's balls copied into their place (the motion pass).
                | vk::BufferUsageFlags::TRANSFER_DST;
            // The old buffer is retired with this frame, which may already use it.
            self.buffer =
                Some(memory.create_buffer(ctx, &self.name, grown, usage, MemoryLocation::CpuToGpu)?);
            0
        };
        let buffer = self.buffer.as_mut().expect("made above");
        let mut at = offset as usize;
        for part in parts {
            match part {
                RingPart::Bytes(b) => {
                    buffer.write(at, b)?;
                    at += b.len();
                }
                RingPart::Room(n) => at += n,
            }
        }
        self.used = offset + size;
        Ok(RingSlice { buffer: buffer.raw, offset, size })
    }

    /// Appends `bytes` and makes a texel view of them as `texels`; an error naming the data when
    /// the device cannot address that many texels (maxTexelBufferElements).
    pub fn push_texels(
        &mut self,
        ctx: &GpuContext,
        memory: &Memory,
        what: &str,
        bytes: &[u8],
        texels: Texels,
    ) -> GpuResult<TexelView> {
        let count = (bytes.len() as u64).div_ceil(texels.bytes()).max(1);
        let limit = u64::from(ctx.limits.max_texel_buffer_elements);
        if count > limit {
            return Err(GpuError::DeviceLimit {
                what: what.into(),
                limit: "maxTexelBufferElements",
                needed: count,
                max: limit,
                message: format!(
                    "{count} texels of {} bytes are needed, but this device reads at most {limit} \
                     (maxTexelBufferElements); make the scene smaller",
                    texels.bytes()
                ),
            });
        }
        let slice = self.push(ctx, memory, bytes)?;
        let info = vk::BufferViewCreateInfo::default()
            .buffer(slice.buffer)
            .format(texels.format())
            .offset(slice.offset)
            .range(count * texels.bytes());
        // SAFETY: the range lies inside the ring buffer; the view is retired with the frame.
        let raw = unsafe { ctx.device.create_buffer_view(&info, None) }.vk("vkCreateBufferView")?;
        Ok(TexelView { raw, releaser: ctx.releaser() })
    }
}
