//! Writes images to disk atomically: into a temporary file beside the target, then renamed, so a
//! failure never leaves a half-written output.

use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};

use crate::aov::AovImage;

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("cannot write {}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    #[error("cannot encode {}: {message}", path.display())]
    Encode { path: PathBuf, message: String },
}

/// Writes `bytes` to `path` via a temporary file in the same directory.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let io = |source| OutputError::Io { path: path.to_path_buf(), source };
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(io)?;
    let file_name =
        path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{file_name}.{}.tmp", std::process::id()));
    let result = std::fs::File::create(&tmp).and_then(|mut f| {
        f.write_all(bytes)?;
        f.sync_all()
    });
    if let Err(e) = result.and_then(|_| std::fs::rename(&tmp, path)) {
        let _ = std::fs::remove_file(&tmp);
        return Err(io(e));
    }
    Ok(())
}

/// Encodes RGBA8 pixels as PNG.
pub fn write_png(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<(), OutputError> {
    let encode = |message: String| OutputError::Encode { path: path.to_path_buf(), message };
    let img = image::RgbaImage::from_raw(width, height, rgba.to_vec())
        .ok_or_else(|| encode(format!("{} bytes is not {width}x{height} RGBA", rgba.len())))?;
    let mut bytes = Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png).map_err(|e| encode(e.to_string()))?;
    write_atomically(path, bytes.get_ref())
}

/// Encodes an AOV as OpenEXR with f32 channels: one channel named `Y`, or R, G, B, A.
pub fn write_exr(path: &Path, name: &str, aov: &AovImage) -> Result<(), OutputError> {
    use exr::prelude::*;
    let encode = |message: String| OutputError::Encode { path: path.to_path_buf(), message };
    let (w, h, n) = (aov.width as usize, aov.height as usize, aov.channels as usize);
    if aov.data.len() != w * h * n {
        return Err(encode(format!("{} values is not {w}x{h}x{n}", aov.data.len())));
    }
    let names: &[&str] = if n == 1 { &["Y"] } else { &["R", "G", "B", "A"] };
    let channels: Vec<AnyChannel<FlatSamples>> = names
        .iter()
        .enumerate()
        .map(|(c, label)| {
            let samples: Vec<f32> = aov.data.iter().skip(c).step_by(n).copied().collect();
            AnyChannel::new(*label, FlatSamples::F32(samples))
        })
        .collect();
    let layer = Layer::new(
        (w, h),
        LayerAttributes::named(name),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels.into()),
    );
    let mut bytes = Cursor::new(Vec::new());
    Image::from_layer(layer).write().to_buffered(&mut bytes).map_err(|e| encode(e.to_string()))?;
    write_atomically(path, bytes.get_ref())
}

/// Reads a single-channel f32 EXR written by `write_exr` (tests and tools).
pub fn read_exr_channel(path: &Path) -> Result<(u32, u32, Vec<f32>), String> {
    use exr::prelude::*;
    let image = read_first_flat_layer_from_file(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let size = image.layer_data.size;
    let channel = image.layer_data.channel_data.list.first().ok_or("no channels")?;
    let values: Vec<f32> = channel.sample_data.values_as_f32().collect();
    Ok((size.0 as u32, size.1 as u32, values))
}
