//! Putting packed tables in use a slice at a time. A run-time bake's tables (every table in use,
//! packed again with the new ones on the bake thread) are copied into fresh host-visible buffers
//! by the frames that follow the bake, at most `budget` bytes a frame, and the passes switch to
//! them once all are in: the switch-over's copy costs every frame a bounded slice instead of one
//! frame all of it (see docs/PERFORMANCE.md, "The switch-over").

use crate::gpu::memory::{Image, Memory};
use crate::gpu::sampler::Sampler;
use crate::gpu::staged_image::{stage_empty_compute_image, StagedCopy};
use crate::gpu::texel_buffer::{TexelBuffer, Texels};
use crate::gpu::{vk, GpuContext, GpuResult};

use super::{Packed, TranslucentData};

/// Bytes a frame copies of a run-time bake's tables: 512 KiB. Into fresh host-visible memory the
/// copy runs at ~1.7 GB/s on lavapipe here (every page touched for the first time): ≈ 0.3 ms.
pub(crate) const UPLOAD_BYTES_PER_FRAME: usize = 512 << 10;

/// Packed tables with their buffers made and partly written.
pub(crate) struct Uploading {
    packed: Packed,
    fields: TexelBuffer,
    records: TexelBuffer,
    /// The pair tables' image and its staging buffer (being written).
    pairs: Option<(Image, StagedCopy)>,
    /// Bytes written so far, counted through the fields, the records and the pair atlas in turn.
    written: usize,
}

impl Uploading {
    /// Makes the buffers (and the pair tables' image) for `packed`; writes nothing yet.
    pub(crate) fn begin(ctx: &GpuContext, memory: &Memory, packed: Packed) -> GpuResult<Self> {
        let fields =
            TexelBuffer::new(ctx, memory, "translucency fields", byte_len(&packed.fields), Texels::U32)?;
        let records = TexelBuffer::new(
            ctx,
            memory,
            "translucency lut records",
            byte_len(&packed.records),
            Texels::U32x4,
        )?;
        let a = &packed.atlas;
        let pairs = if a.height == 0 {
            None
        } else {
            let extent = vk::Extent2D { width: a.width, height: a.height };
            let name = "translucency pair tables";
            Some(stage_empty_compute_image(ctx, memory, name, extent, vk::Format::R8_UNORM, 1)?)
        };
        Ok(Uploading { packed, fields, records, pairs, written: 0 })
    }

    /// Bytes written so far.
    pub(crate) fn written(&self) -> usize {
        self.written
    }

    /// Bytes in all.
    pub(crate) fn total(&self) -> usize {
        (byte_len(&self.packed.fields) + byte_len(&self.packed.records)) as usize
            + self.packed.atlas.bytes.len()
    }

    /// Writes up to `budget` more bytes; whether everything is written now.
    pub(crate) fn step(&mut self, budget: usize) -> GpuResult<bool> {
        let Uploading { packed, fields, records, pairs, written } = self;
        let sources: [&[u8]; 3] = [
            bytemuck::cast_slice(&packed.fields),
            bytemuck::cast_slice(&packed.records),
            &packed.atlas.bytes,
        ];
        let (mut start, mut left) = (0, budget);
        for (k, src) in sources.into_iter().enumerate() {
            let end = start + src.len();
            if *written < end && left > 0 {
                let from = *written - start;
                let n = (src.len() - from).min(left);
                let slice = &src[from..from + n];
                match k {
                    0 => fields.buffer.write(from, slice)?,
                    1 => records.buffer.write(from, slice)?,
                    _ => pairs.as_mut().map_or(Ok(()), |(_, copy)| copy.write(from, slice))?,
                }
                *written += n;
                left -= n;
            }
            start = end;
        }
        Ok(*written == start)
    }

    /// The tables, ready for the passes (call once `step` said all is written). The pair tables'
    /// copy into their image is recorded by the first frame that reads it (no wait).
    pub(crate) fn finish(self, ctx: &GpuContext) -> GpuResult<TranslucentData> {
        let Uploading { packed, fields, records, pairs, .. } = self;
        let field_bytes: u64 = packed.tables.iter().map(|s| s.field_bytes).sum();
        log::info!(
            "translucency: {} thickness fields, {field_bytes} bytes ({} words of R8_SNORM quads and τ)",
            packed.tables.len(),
            packed.fields.len()
        );
        let (pairs, pairs_copy) = match pairs {
            None => (None, None),
            Some((image, copy)) => {
                let a = &packed.atlas;
                log::info!(
                    "translucency: pair tables in a {}x{} R8_UNORM image ({} bytes)",
                    a.width,
                    a.height,
                    a.bytes.len()
                );
                (Some((image, Sampler::nearest(ctx, "translucency pair tables")?)), Some(copy))
            }
        };
        Ok(TranslucentData {
            tables: packed.tables,
            keys: packed.keys,
            fields,
            records,
            pairs,
            pairs_copy: std::sync::Mutex::new(pairs_copy),
        })
    }
}

fn byte_len<T>(v: &[T]) -> u64 {
    std::mem::size_of_val(v) as u64
}
