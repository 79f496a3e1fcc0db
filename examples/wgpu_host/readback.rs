//! Copies of wgpu textures into mappable buffers, read once their frame finished (headless mode
//! and the test).
#![allow(dead_code)]

/// A texture's copy in flight: the buffer (rows padded to wgpu's 256-byte alignment) and its shape.
pub struct Readback {
    buffer: wgpu::Buffer,
    width: u32,
    height: u32,
    bytes_per_pixel: u32,
    padded_row: u32,
}

impl Readback {
    /// Records a copy of the whole `texture` (of `aspect`: `DepthOnly` for a depth texture) into a
    /// new buffer.
    pub fn record(
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        texture: &wgpu::Texture,
        aspect: wgpu::TextureAspect,
    ) -> Readback {
        let (width, height) = (texture.width(), texture.height());
        let bytes_per_pixel = texture.format().block_copy_size(Some(aspect)).expect("a copyable format");
        let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let padded_row = (width * bytes_per_pixel).div_ceil(align) * align;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read-back"),
            size: u64::from(padded_row) * u64::from(height),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo { texture, mip_level: 0, origin: wgpu::Origin3d::ZERO, aspect },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_row),
                    rows_per_image: Some(height),
                },
            },
            texture.size(),
        );
        Readback { buffer, width, height, bytes_per_pixel, padded_row }
    }

    /// The texels, rows unpadded. A copy of a frame already waited for is mapped by a non-blocking
    /// poll (later frames stay in flight); otherwise this waits for the device.
    pub fn read(self, device: &wgpu::Device) -> Result<Vec<u8>, String> {
        let slice = self.buffer.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        device.poll(wgpu::PollType::Poll).map_err(|e| e.to_string())?;
        let mapped = match rx.try_recv() {
            Ok(r) => r,
            Err(_) => {
                device.poll(wgpu::PollType::Wait).map_err(|e| e.to_string())?;
                rx.recv().map_err(|e| e.to_string())?
            }
        };
        mapped.map_err(|e| e.to_string())?;
        let row = (self.width * self.bytes_per_pixel) as usize;
        let data = slice.get_mapped_range();
        let bytes = data.chunks(self.padded_row as usize).take(self.height as usize).flat_map(|r| &r[..row]);
        let out = bytes.copied().collect();
        drop(data);
        self.buffer.unmap();
        Ok(out)
    }
}
