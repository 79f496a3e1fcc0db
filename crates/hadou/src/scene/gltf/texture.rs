//! glTF textures → `scene::texture::TextureRef`: the image's bytes (a buffer view, a base64
//! `data:` URI, or a file inside the glTF file's folder: `buffers::inside_folder`), decoded once
//! per image (PNG or JPEG) after its header's size has been checked against the `texels` budget
//! and the largest side hadou makes (`MAX_SIDE`); the sampler's filters and wrap modes, the
//! texture coordinate set and `KHR_texture_transform`. Every refusal names the file and the JSON
//! pointer at fault.

use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;
use std::sync::Arc;

use base64::Engine;
use gltf::texture::{MagFilter, MinFilter, WrappingMode};

use super::accessor::Source;
use super::error::GltfError;
use super::primitive::{Budget, BUDGET_VAR};
use crate::scene::texture::{uv_transform, Filter, SamplerDesc, TextureImage, TextureRef, Wrap};

/// The longest side of an image hadou reads: 16384, the largest 2D image lavapipe (and most
/// GPUs) can make.
pub const MAX_SIDE: u32 = 16384;

/// The images of one file decoded so far (each once, however many textures use it) and the
/// texels they hold, against the budget.
#[derive(Default)]
pub(super) struct Images {
    decoded: HashMap<usize, Arc<TextureImage>>,
    texels: u64,
    /// The image files read (outputs may not replace them; the viewer watches them).
    pub files: Vec<std::path::PathBuf>,
}

/// The texture `info` names (at JSON pointer `at`, e.g. `/materials/0/emissiveTexture`).
pub(super) fn texture_ref(
    src: &Source,
    info: &gltf::texture::Info,
    at: &str,
    images: &mut Images,
) -> Result<TextureRef, GltfError> {
    let texture = info.texture();
    let image = image(src, &texture.source(), images)?;
    let mut texcoord = info.tex_coord();
    let mut transform = crate::scene::texture::IDENTITY_UV;
    if let Some(t) = info.texture_transform() {
        let ext = format!("{at}/extensions/KHR_texture_transform");
        let [o, s] = [t.offset(), t.scale()].map(|v| v.map(|x| x as f64));
        let r = t.rotation() as f64;
        if !(o.iter().chain(&s).all(|x| x.is_finite()) && r.is_finite()) {
            let message = format!("offset {o:?}, rotation {r}, scale {s:?} (expected finite numbers)");
            return Err(GltfError::at(src.path, ext, message));
        }
        transform = uv_transform(o, r, s);
        texcoord = t.tex_coord().unwrap_or(texcoord);
    }
    if texcoord > 1 {
        let message = format!("TEXCOORD_{texcoord} (hadou reads TEXCOORD_0 and TEXCOORD_1)");
        return Err(GltfError::at(src.path, format!("{at}/texCoord"), message));
    }
    Ok(TextureRef { image, sampler: sampler(&texture.sampler()), texcoord, transform })
}

/// The sampler's filters and wraps; what the file leaves out is `SamplerDesc::default()`'s.
fn sampler(s: &gltf::texture::Sampler) -> SamplerDesc {
    let d = SamplerDesc::default();
    let wrap = |w: WrappingMode| match w {
        WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        WrappingMode::Repeat => Wrap::Repeat,
    };
    let mag = match s.mag_filter() {
        Some(MagFilter::Nearest) => Filter::Nearest,
        Some(MagFilter::Linear) => Filter::Linear,
        None => d.mag,
    };
    let (min, mipmap) = match s.min_filter() {
        Some(MinFilter::Nearest) => (Filter::Nearest, None),
        Some(MinFilter::Linear) => (Filter::Linear, None),
        Some(MinFilter::NearestMipmapNearest) => (Filter::Nearest, Some(Filter::Nearest)),
        Some(MinFilter::LinearMipmapNearest) => (Filter::Linear, Some(Filter::Nearest)),
        Some(MinFilter::NearestMipmapLinear) => (Filter::Nearest, Some(Filter::Linear)),
        Some(MinFilter::LinearMipmapLinear) => (Filter::Linear, Some(Filter::Linear)),
        None => (d.min, d.mipmap),
    };
    SamplerDesc { mag, min, mipmap, wrap_s: wrap(s.wrap_s()), wrap_t: wrap(s.wrap_t()) }
}

/// Image `image` decoded (once per file).
fn image(src: &Source, image: &gltf::Image, images: &mut Images) -> Result<Arc<TextureImage>, GltfError> {
    let i = image.index();
    if let Some(done) = images.decoded.get(&i) {
        return Ok(done.clone());
    }
    let (bytes, at, shown) = image_bytes(src, image, &mut images.files)?;
    let fail = |message: String| GltfError::at(src.path, at.clone(), format!("{shown}: {message}"));
    let reader = || {
        image::ImageReader::new(Cursor::new(&bytes[..]))
            .with_guessed_format()
            .map_err(|e| fail(format!("cannot read the image: {e}")))
    };
    match reader()?.format() {
        Some(image::ImageFormat::Png | image::ImageFormat::Jpeg) => {}
        _ => return Err(fail("not a PNG or JPEG image (hadou decodes PNG and JPEG)".into())),
    }
    let (w, h) = reader()?
        .into_dimensions()
        .map_err(|e| fail(format!("undecodable image: {e} (expected a valid PNG or JPEG)")))?;
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(fail(format!("the image is {w}x{h} (expected each side in 1..={MAX_SIDE})")));
    }
    let budget = Budget::from_env(src.path)?;
    let total = images.texels + w as u64 * h as u64;
    if total > budget.texels {
        return Err(fail(format!(
            "{total} texels of images to decode with this one ({w}x{h}; hadou reads at most {} texels of images per glTF file, each image once; set {BUDGET_VAR}=\"texels=N\" to allow more)",
            budget.texels
        )));
    }
    let mut reader = reader()?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_SIDE);
    limits.max_image_height = Some(MAX_SIDE);
    // The decoded RGBA8 and the decoder's own buffer of the same size, with room to spare.
    limits.max_alloc = Some(16 * w as u64 * h as u64 + (1 << 20));
    reader.limits(limits);
    let decoded = reader
        .decode()
        .map_err(|e| fail(format!("undecodable image: {e} (expected a valid PNG or JPEG)")))?;
    let rgba = decoded.into_rgba8();
    images.texels = total;
    let name = format!("{} /images/{i}", src.path.display());
    let made = Arc::new(TextureImage::new(name, w, h, rgba.into_raw()));
    images.decoded.insert(i, made.clone());
    Ok(made)
}

/// The encoded bytes of an image, the JSON pointer of where they come from and how a message
/// names them.
fn image_bytes(
    src: &Source,
    image: &gltf::Image,
    files: &mut Vec<std::path::PathBuf>,
) -> Result<(Vec<u8>, String, String), GltfError> {
    let i = image.index();
    match image.source() {
        gltf::image::Source::View { view, .. } => {
            let at = format!("/images/{i}/bufferView");
            let data = src.buffers.get(view.buffer().index()).map(Vec::as_slice).unwrap_or(&[]);
            let range = view.offset().checked_add(view.length()).map(|end| view.offset()..end);
            match range.and_then(|r| data.get(r)) {
                Some(bytes) => Ok((bytes.to_vec(), at, format!("image {i} (bufferView {})", view.index()))),
                None => Err(GltfError::at(
                    src.path,
                    at,
                    format!(
                        "bufferView {} (bytes {}..+{}) lies outside its buffer of {} bytes (expected a view inside the buffer)",
                        view.index(),
                        view.offset(),
                        view.length(),
                        data.len()
                    ),
                )),
            }
        }
        gltf::image::Source::Uri { uri, .. } => {
            let at = format!("/images/{i}/uri");
            if let Some(rest) = uri.strip_prefix("data:") {
                let Some((_, payload)) = rest.split_once(";base64,") else {
                    let message = "a data: URI without `;base64,` (expected base64-encoded data)";
                    return Err(GltfError::at(src.path, at, message));
                };
                let bytes = base64::engine::general_purpose::STANDARD
                    .decode(payload)
                    .map_err(|e| GltfError::at(src.path, &at, format!("invalid base64 in data: URI: {e}")))?;
                return Ok((bytes, at, format!("image {i} (data: URI)")));
            }
            if uri.contains("://") {
                let shown: String = uri.chars().take(200).collect();
                let message = format!("`{shown}`: only data: URIs and relative file paths are read");
                return Err(GltfError::at(src.path, at, message));
            }
            let file = super::buffers::inside_folder(src.path, &at, uri)?;
            let missing = |e: std::io::Error| {
                GltfError::at(src.path, &at, format!("missing image: cannot read {}: {e}", file.display()))
            };
            // The type is checked before opening (a FIFO would block).
            let meta = std::fs::metadata(&file).map_err(missing)?;
            if !meta.is_file() {
                return Err(missing(std::io::Error::other("not a regular file")));
            }
            let bytes = std::fs::read(&file).map_err(missing)?;
            files.push(file.clone());
            Ok((bytes, at.clone(), format!("image {}", file.display())))
        }
    }
}

/// The path of every image file a glTF file's textures could read (for `referenced_files`).
pub(super) fn image_files(path: &Path, doc: &gltf::Document) -> Vec<std::path::PathBuf> {
    doc.images()
        .filter_map(|image| match image.source() {
            gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") && !uri.contains("://") => {
                super::buffers::inside_folder(path, "", uri).ok()
            }
            _ => None,
        })
        .collect()
}
