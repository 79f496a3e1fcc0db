//! Host-visible buffers read by shaders as uniform texel buffers (`usamplerBuffer` + texelFetch).
//!
//! Why not storage buffers: on lavapipe (Mesa 22.3), inside a branch or a loop, a storage-buffer
//! load is a loop over the SIMD lanes with a branch per lane and component, while a texel fetch is
//! a branch-free gather of whole texels (measured on the metaballs pass: docs/PERFORMANCE.md).
//! Data is viewed as uint texels ([`Texels`]) and floats are read back with
//! `uintBitsToFloat`: an integer format carries every bit pattern unchanged, where a float format
//! could flush denormals.

use gpu_allocator::MemoryLocation;

use super::error::VkResultExt;
use super::memory::{Buffer, Memory};
use super::resources::{Garbage, Releaser};
use super::{vk, GpuContext, GpuError, GpuResult};

pub struct TexelBuffer {
    pub buffer: Buffer,
    pub view: vk::BufferView,
    releaser: Releaser,
}

impl Drop for TexelBuffer {
    fn drop(&mut self) {
        // Queued before the buffer (dropped after this), so the view is destroyed first.
        if self.view != vk::BufferView::null() {
            self.releaser.retire(Garbage::BufferView(self.view));
        }
    }
}

/// How a buffer's bytes are viewed: one uint per texel (`R32_UINT`), or four (`R32G32B32A32_UINT`,
/// a 16-byte struct field or a vec4 per texel).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Texels {
    U32,
    U32x4,
}

impl Texels {
    pub fn format(self) -> vk::Format {
        match self {
            Texels::U32 => vk::Format::R32_UINT,
            Texels::U32x4 => vk::Format::R32G32B32A32_UINT,
        }
    }

    /// Bytes per texel.
    pub fn bytes(self) -> u64 {
        match self {
            Texels::U32 => 4,
            Texels::U32x4 => 16,
        }
    }
}

impl TexelBuffer {
    /// The most bytes a view of `texels` can address on this device.
    pub fn max_bytes(ctx: &GpuContext, texels: Texels) -> u64 {
        u64::from(ctx.limits.max_texel_buffer_elements) * texels.bytes()
    }

    /// A host-visible buffer of at least `bytes` and its view as `texels`; an error naming the
    /// buffer when the device cannot address that many texels (maxTexelBufferElements).
    pub fn new(
        ctx: &GpuContext,
        memory: &Memory,
        name: &str,
        bytes: u64,
        texels: Texels,
    ) -> GpuResult<TexelBuffer> {
        let usage = vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER;
        TexelBuffer::with(ctx, memory, name, bytes, texels, usage, MemoryLocation::CpuToGpu)
    }

    /// A buffer that compute shaders write as a storage buffer and later dispatches read through
    /// its texel view (the metaballs pass's tile lists, built on the device), in `location`
    /// (`GpuOnly`; `GpuToCpu` where a test reads it back).
    pub fn device(
        ctx: &GpuContext,
        memory: &Memory,
        name: &str,
        bytes: u64,
        texels: Texels,
        location: MemoryLocation,
    ) -> GpuResult<TexelBuffer> {
        let usage = vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER;
        TexelBuffer::with(ctx, memory, name, bytes, texels, usage, location)
    }

    /// As `device`, host-visible (the host writes part of it) and a copy's destination too (the
    /// metaballs' ball table: the host's balls written, a game's copied in, completed by a
    /// compute shader, read through the view).
    pub fn device_table(
        ctx: &GpuContext,
        memory: &Memory,
        name: &str,
        bytes: u64,
        texels: Texels,
    ) -> GpuResult<TexelBuffer> {
        let usage = vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER
            | vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST;
        TexelBuffer::with(ctx, memory, name, bytes, texels, usage, MemoryLocation::CpuToGpu)
    }

    fn with(
        ctx: &GpuContext,
        memory: &Memory,
        name: &str,
        bytes: u64,
        texels: Texels,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> GpuResult<TexelBuffer> {
        let texel = texels.bytes();
        let size = bytes.max(texel).div_ceil(texel) * texel;
        let limit = u64::from(ctx.limits.max_texel_buffer_elements);
        if size / texel > limit {
            return Err(GpuError::DeviceLimit {
                what: name.into(),
                limit: "maxTexelBufferElements",
                needed: size / texel,
                max: limit,
                message: format!(
                    "{} texels of {texel} bytes are needed, but this device reads at most {limit} \
                     (maxTexelBufferElements); make the scene smaller",
                    size / texel
                ),
            });
        }
        let buffer = memory.create_buffer(ctx, name, size, usage, location)?;
        let info = vk::BufferViewCreateInfo::default()
            .buffer(buffer.raw)
            .format(texels.format())
            .range(vk::WHOLE_SIZE);
        // SAFETY: valid device and buffer; the view is freed before the buffer (Drop).
        let view = unsafe { ctx.device.create_buffer_view(&info, None) }.vk("vkCreateBufferView")?;
        ctx.name_object(view, name);
        Ok(TexelBuffer { buffer, view, releaser: ctx.releaser() })
    }

    /// A texel buffer holding `bytes` (at least one texel), freed again if the write fails.
    pub fn from_bytes(
        ctx: &GpuContext,
        memory: &Memory,
        name: &str,
        bytes: &[u8],
        texels: Texels,
    ) -> GpuResult<TexelBuffer> {
        let mut buffer = TexelBuffer::new(ctx, memory, name, bytes.len() as u64, texels)?;
        buffer.write(bytes)?;
        Ok(buffer)
    }

    /// Copies `data` to the start of the buffer.
    pub fn write(&mut self, data: &[u8]) -> GpuResult<()> {
        self.write_at(0, data)
    }

    /// Copies `data` to byte `offset` of the buffer.
    pub fn write_at(&mut self, offset: usize, data: &[u8]) -> GpuResult<()> {
        if data.is_empty() {
            return Ok(());
        }
        self.buffer.write(offset, data)
    }
}
