//! Reads the two sides of a comparison: PNG as 8-bit channels, OpenEXR as f32 per channel.
//!
//! Every image is checked against a pixel budget from its header, before anything is decoded or
//! allocated for its pixels: a 5 KB file whose header claims 100000×100000 is an error naming the
//! file and the size, not a 40 GB allocation.

use std::io::Read;
use std::path::Path;

use super::CompareError;

/// The most pixels (width × height of each layer) `compare` and `test` decode by default:
/// 2²⁴ = 16,777,216, i.e. 4096×4096. It holds 4K UHD (3840×2160) and DCI 4K (4096×2160) frames
/// with room to spare; golden images are far smaller (this project's are at most 64×36). Memory
/// at the budget: an RGBA f32 OpenEXR pair decodes to 2 × 16 B a pixel (0.5 GiB, its file bytes
/// as much again), and a PNG pair through FLIP peaks at about 100 B a pixel (measured: 107 MB
/// for 1024×1024, 201 MB for 2048×1024), 1.6 GiB: what a CI runner has, while the 2²⁸ pixels of
/// the largest render (16384×16384) would need 16 times that. `--max-pixels` raises it on a
/// machine with the memory.
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 24;

/// How large an image may be decoded (see [`DEFAULT_MAX_PIXELS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelBudget {
    /// Width × height of one image (of each layer of an OpenEXR).
    pub max_pixels: u64,
}

impl Default for PixelBudget {
    fn default() -> PixelBudget {
        PixelBudget { max_pixels: DEFAULT_MAX_PIXELS }
    }
}

impl PixelBudget {
    /// The values (pixels × channels, over every layer) an OpenEXR may decode to: an RGBA image
    /// at the pixel budget, so many channels cannot multiply the memory a size check allowed.
    pub fn max_values(&self) -> u64 {
        self.max_pixels.saturating_mul(4)
    }

    /// The bytes a file may have before it is read: 20 a pixel + 1 MiB. An RGBA f32 image at the
    /// budget stored uncompressed is 16 B a pixel; a quarter more covers offset tables and
    /// compression that grows incompressible data; 1 MiB covers headers and metadata. A larger
    /// file (a sparse 100 GB file named .png) cannot hold an image within the budget.
    pub fn max_file_bytes(&self) -> u64 {
        self.max_pixels.saturating_mul(20).saturating_add(1 << 20)
    }

    /// Checks a size from an image's header.
    pub fn check(&self, width: u64, height: u64) -> Result<(), String> {
        let pixels = width.saturating_mul(height);
        if pixels > self.max_pixels {
            return Err(format!(
                "{width}x{height} is {pixels} pixels, more than the pixel budget of {} \
                 (nothing was decoded; --max-pixels N raises the budget)",
                self.max_pixels
            ));
        }
        Ok(())
    }
}

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

/// Reads a PNG or OpenEXR file, told apart by its first bytes (not its name), within the
/// default pixel budget.
pub fn load(path: &Path) -> Result<Loaded, CompareError> {
    load_with(path, &PixelBudget::default())
}

/// Reads a PNG or OpenEXR file within `budget`: a file too large for it is not read, an image
/// whose header claims more pixels is not decoded.
pub fn load_with(path: &Path, budget: &PixelBudget) -> Result<Loaded, CompareError> {
    let err = |message: String| CompareError::File { path: path.into(), message };
    // The type is checked before opening: a FIFO would block, a device might never end.
    let meta = std::fs::metadata(path).map_err(|e| err(format!("cannot read: {e}")))?;
    if !meta.is_file() {
        return Err(err("is not a regular file (expected a PNG or OpenEXR image)".into()));
    }
    let limit = budget.max_file_bytes();
    let too_large = |bytes: u64| {
        err(format!(
            "is {bytes} bytes, more than a PNG or OpenEXR image within the pixel budget of {} can \
             take ({limit} bytes; --max-pixels N raises the budget)",
            budget.max_pixels
        ))
    };
    if meta.len() > limit {
        return Err(too_large(meta.len()));
    }
    let file = std::fs::File::open(path).map_err(|e| err(format!("cannot read: {e}")))?;
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(meta.len() as usize).map_err(|_| err("out of host memory to read it".into()))?;
    // The file may have grown since: never more than the limit is read.
    file.take(limit + 1).read_to_end(&mut bytes).map_err(|e| err(format!("cannot read: {e}")))?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64));
    }
    decode_with(path, &bytes, budget)
}

/// Decodes PNG or OpenEXR bytes within the default pixel budget; `path` names them in errors.
pub fn decode(path: &Path, bytes: &[u8]) -> Result<Loaded, CompareError> {
    decode_with(path, bytes, &PixelBudget::default())
}

/// Decodes PNG or OpenEXR bytes within `budget`; `path` names them in errors.
pub fn decode_with(path: &Path, bytes: &[u8], budget: &PixelBudget) -> Result<Loaded, CompareError> {
    let err = |message: String| CompareError::File { path: path.into(), message };
    if bytes.starts_with(PNG_MAGIC) {
        load_png(bytes, budget).map(Loaded::Ldr).map_err(err)
    } else if bytes.starts_with(EXR_MAGIC) {
        load_exr(bytes, budget).map(Loaded::Hdr).map_err(err)
    } else {
        Err(err("is neither a PNG nor an OpenEXR file (expected one of them, by its first bytes)".into()))
    }
}

/// Width, height and bit depth from a PNG's IHDR chunk, which the format puts first.
fn png_header(bytes: &[u8]) -> Result<(u32, u32, u8), String> {
    let ihdr = bytes.get(8..26).filter(|h| &h[4..8] == b"IHDR");
    let h = ihdr.ok_or("corrupt or unsupported PNG: no IHDR chunk after the signature")?;
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    Ok((be(&h[8..12]), be(&h[12..16]), bytes[24]))
}

fn load_png(bytes: &[u8], budget: &PixelBudget) -> Result<LdrImage, String> {
    use image::ImageDecoder;
    let (width, height, depth) = png_header(bytes)?;
    budget.check(width as u64, height as u64)?;
    if depth > 8 {
        return Err(format!("{depth}-bit PNG: only 8-bit PNGs are compared (hadou writes RGBA 8-bit)"));
    }
    // The decoder's own allocations bounded too: the RGBA8 image (4 B a pixel) twice over, plus
    // 64 MiB for its row buffers and text chunks.
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(budget.max_pixels.saturating_mul(8).saturating_add(64 << 20));
    let decoder = image::codecs::png::PngDecoder::with_limits(std::io::Cursor::new(bytes), limits)
        .map_err(|e| format!("corrupt or unsupported PNG: {e}"))?;
    if decoder.dimensions() != (width, height) {
        return Err("corrupt or unsupported PNG: its header read two ways gives two sizes".into());
    }
    let img =
        image::DynamicImage::from_decoder(decoder).map_err(|e| format!("corrupt or unsupported PNG: {e}"))?;
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

/// Checks every layer's size and the values all channels decode to against `budget`, from the
/// headers alone.
fn check_exr_headers(bytes: &[u8], budget: &PixelBudget) -> Result<(), String> {
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
        .map_err(|e| format!("corrupt or unsupported OpenEXR: {e}"))?;
    let mut values = 0u64;
    for header in &meta.headers {
        let (w, h) = (header.layer_size.0 as u64, header.layer_size.1 as u64);
        budget.check(w, h)?;
        for c in &header.channels.list {
            let (sx, sy) = (c.sampling.0.max(1) as u64, c.sampling.1.max(1) as u64);
            values = values.saturating_add(w.div_ceil(sx).saturating_mul(h.div_ceil(sy)));
        }
    }
    if values > budget.max_values() {
        return Err(format!(
            "{} layer(s) of {} channel(s) decode to {values} values, more than {} (4 a pixel of \
             the pixel budget of {}; nothing was decoded; --max-pixels N raises the budget)",
            meta.headers.len(),
            meta.headers.iter().map(|h| h.channels.list.len()).sum::<usize>(),
            budget.max_values(),
            budget.max_pixels
        ));
    }
    Ok(())
}

fn load_exr(bytes: &[u8], budget: &PixelBudget) -> Result<HdrImage, String> {
    use exr::prelude::*;
    check_exr_headers(bytes, budget)?;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// An OpenEXR of `channels` f32 channels at 4×3.
    fn exr_with(channels: usize) -> Vec<u8> {
        use exr::prelude::*;
        let list: Vec<AnyChannel<FlatSamples>> = (0..channels)
            .map(|c| AnyChannel::new(format!("c{c:02}").as_str(), FlatSamples::F32(vec![1.0; 12])))
            .collect();
        let layer = Layer::new(
            (4, 3),
            LayerAttributes::named("x"),
            Encoding::UNCOMPRESSED,
            AnyChannels::sort(list.into()),
        );
        let mut bytes = std::io::Cursor::new(Vec::new());
        Image::from_layer(layer).write().to_buffered(&mut bytes).unwrap();
        bytes.into_inner()
    }

    fn message(r: Result<Loaded, CompareError>) -> String {
        match r {
            Err(e) => e.to_string(),
            Ok(_) => panic!("decoded"),
        }
    }

    #[test]
    fn many_channels_cannot_multiply_the_budget() {
        let budget = PixelBudget { max_pixels: 12 };
        // 4 channels of 12 pixels: 48 values, the most a 12-pixel budget allows.
        assert!(decode_with(Path::new("four.exr"), &exr_with(4), &budget).is_ok());
        let msg = message(decode_with(Path::new("five.exr"), &exr_with(5), &budget));
        assert!(
            msg.starts_with("five.exr: 1 layer(s) of 5 channel(s) decode to 60 values, more than 48"),
            "{msg}"
        );
    }

    #[test]
    fn a_file_larger_than_the_budget_allows_is_not_read() {
        let dir = std::env::temp_dir().join(format!("hadou-compare-size-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("big.png");
        let mut bytes = PNG_MAGIC.to_vec();
        bytes.resize((1 << 20) + 100, 0);
        std::fs::write(&path, &bytes).unwrap();
        let msg = message(load_with(&path, &PixelBudget { max_pixels: 4 }));
        assert!(
            msg.contains(
                "big.png: is 1048676 bytes, more than a PNG or OpenEXR image within the pixel budget of 4"
            ),
            "{msg}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_16_bit_png_is_refused_from_its_header() {
        let img = image::ImageBuffer::<image::Rgba<u16>, _>::from_raw(2, 2, vec![7u16; 16]).unwrap();
        let mut bytes = std::io::Cursor::new(Vec::new());
        img.write_to(&mut bytes, image::ImageFormat::Png).unwrap();
        let msg = message(decode(Path::new("deep.png"), bytes.get_ref()));
        assert!(msg.contains("deep.png: 16-bit PNG: only 8-bit PNGs are compared"), "{msg}");
    }
}
