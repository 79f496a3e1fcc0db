//! gpu::texel_buffer: a buffer the device cannot address as texels is a clear error before
//! anything is allocated; one it can is sized in whole texels, written within its size only, and
//! freed without a validation message.

mod common;

use hadou::gpu::memory::Memory;
use hadou::gpu::texel_buffer::{TexelBuffer, Texels};

#[test]
fn texel_buffers_respect_the_device_limit() {
    let rt = common::runtime();
    let ctx = rt.context();
    let memory = Memory::new(ctx).unwrap();
    let limit = u64::from(ctx.limits.max_texel_buffer_elements);
    assert_eq!(TexelBuffer::max_bytes(ctx, Texels::U32), 4 * limit);

    let past = TexelBuffer::new(ctx, &memory, "metaballs entries", 4 * (limit + 1), Texels::U32);
    let err = past.err().expect("one texel past maxTexelBufferElements");
    let message = err.to_string();
    // A variant a caller can act on: which limit, how much was needed, the device's maximum.
    match err {
        hadou::GpuError::DeviceLimit { limit: name, needed, max, .. } => {
            assert_eq!((name, needed, max), ("maxTexelBufferElements", limit + 1, limit));
        }
        other => panic!("expected GpuError::DeviceLimit, got {other:?}"),
    }
    for part in ["metaballs entries", "maxTexelBufferElements", &limit.to_string(), &(limit + 1).to_string()]
    {
        assert!(message.contains(part), "{message:?} does not name {part:?}");
    }

    let mut texels = TexelBuffer::new(ctx, &memory, "texels", 1000, Texels::U32x4).unwrap();
    assert_eq!(texels.buffer.size, 1008, "rounded up to whole 16-byte texels");
    texels.write(&[7u8; 1008]).unwrap();
    texels.write(&[]).unwrap();
    assert!(texels.write(&[0u8; 1009]).is_err(), "a write past the end is refused");
    drop(texels);

    let words = TexelBuffer::from_bytes(ctx, &memory, "words", &[1, 0, 0, 0, 2, 0, 0, 0], Texels::U32);
    let words = words.unwrap();
    assert_eq!(&words.buffer.mapped().unwrap()[..8], &[1, 0, 0, 0, 2, 0, 0, 0]);
    drop(words);
    let empty = TexelBuffer::from_bytes(ctx, &memory, "empty", &[], Texels::U32).unwrap();
    assert_eq!(empty.buffer.size, 4, "an empty buffer still holds one texel to bind");
    drop(empty);
    drop(memory);
    // Errors and warnings, leaks included: checked once the device is destroyed.
    rt.finish();
}
