//! Reads the two sides of a comparison: PNG as 8-bit channels, OpenEXR as f32 per channel.

use std::path::Path;

use super::CompareError;

/// An 8-bit image as its file stores it (1 to 4 channels).
#[derive(Clone, Debug)]
pub struct LdrImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The file's colour type, e.g. "RGBA 8-bit" (for mismatch messages).
    pub layout: String,
    /// Whether the file has an alpha channel.
    pub has_alpha: bool,
    /// RGBA8, row-major (grey and missing alpha expanded).
    pub rgba: Vec<u8>,
}

/// One EXR channel as f32.
#[derive(Clone, Debug)]
pub struct Channel {
    /// `layer.channel`, or the channel's name in an unnamed layer.
    pub name: String,
    /// width × height values, row-major.
    pub values: Vec<f32>,
}

/// Every channel of every layer of an OpenEXR file.
#[derive(Clone, Debug)]
pub struct HdrImage {
    /// Width in pixels (every layer must have it).
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The channels, in file order.
    pub channels: Vec<Channel>,
}

/// A decoded file.
#[derive(Clone, Debug)]
pub enum Loaded {
    /// A PNG.
    Ldr(LdrImage),
    /// An OpenEXR.
    Hdr(HdrImage),
}

impl Loaded {
    /// "PNG" or "OpenEXR".
    pub fn kind(&self) -> &'static str {
        match self {
            Loaded::Ldr(_) => "PNG",
            Loaded::Hdr(_) => "OpenEXR",
        }
    }
}

const PNG_MAGIC: &[u8] = b"\x89PNG\r\n\x1a\n";
const EXR_MAGIC: &[u8] = &[0x76, 0x2f, 0x31, 0x01];

/// Reads a PNG or OpenEXR file, told apart by its first bytes (not its name).
pub fn load(path: &Path) -> Result<Loaded, CompareError> {
    let err = |message: String| CompareError::File { path: path.into(), message };
    let meta = std::fs::metadata(path).map_err(|e| err(format!("cannot read: {e}")))?;
    if !meta.is_file() {
        return Err(err("is not a regular file (expected a PNG or OpenEXR image)".into()));
    }
    let bytes = std::fs::read(path).map_err(|e| err(format!("cannot read: {e}")))?;
    decode(path, &bytes)
}

/// Decodes PNG or OpenEXR bytes; `path` names them in errors.
pub fn decode(path: &Path, bytes: &[u8]) -> Result<Loaded, CompareError> {
    let err = |message: String| CompareError::File { path: path.into(), message };
    if bytes.starts_with(PNG_MAGIC) {
        load_png(bytes).map(Loaded::Ldr).map_err(err)
    } else if bytes.starts_with(EXR_MAGIC) {
        load_exr(bytes).map(Loaded::Hdr).map_err(err)
    } else {
        Err(err("is neither a PNG nor an OpenEXR file (expected one of them, by its first bytes)".into()))
    }
}

fn load_png(bytes: &[u8]) -> Result<LdrImage, String> {
    let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Png)
        .map_err(|e| format!("corrupt or unsupported PNG: {e}"))?;
    let color = img.color();
    if color.bytes_per_pixel() / color.channel_count() != 1 {
        return Err(format!("{color:?}: only 8-bit PNGs are compared (hadou writes RGBA 8-bit)"));
    }
    let layout = match color.channel_count() {
        1 => "grey 8-bit",
        2 => "grey+alpha 8-bit",
        3 => "RGB 8-bit",
        _ => "RGBA 8-bit",
    };
    Ok(LdrImage {
        width: img.width(),
        height: img.height(),
        layout: layout.into(),
        has_alpha: color.has_alpha(),
        rgba: img.to_rgba8().into_raw(),
    })
}

fn load_exr(bytes: &[u8]) -> Result<HdrImage, String> {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| format!("corrupt or unsupported OpenEXR: {e}"))?;
    let mut size = None;
    let mut channels = Vec::new();
    for layer in &image.layer_data {
        let (w, h) = (layer.size.0 as u32, layer.size.1 as u32);
        match size {
            None => size = Some((w, h)),
            Some(s) if s != (w, h) => {
                return Err(format!(
                    "layers of different sizes ({}x{} and {w}x{h}) are not compared",
                    s.0, s.1
                ))
            }
            Some(_) => {}
        }
        let layer_name = layer.attributes.layer_name.as_ref().map(|n| n.to_string());
        for c in &layer.channel_data.list {
            let name = match &layer_name {
                Some(l) => format!("{l}.{}", c.name),
                None => c.name.to_string(),
            };
            channels.push(Channel { name, values: c.sample_data.values_as_f32().collect() });
        }
    }
    let (width, height) = size.ok_or("has no layers")?;
    Ok(HdrImage { width, height, channels })
}
