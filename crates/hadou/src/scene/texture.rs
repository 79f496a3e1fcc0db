//! Textures of glTF materials as the scene holds them: decoded images (RGBA8, sRGB-encoded, with
//! their mip chain made here on the CPU), how each is sampled (the file's sampler, texture
//! coordinate set and `KHR_texture_transform`), and the f64 twins of the sampling the raster
//! does (`TextureRef::uv`, `srgb_to_linear`), which tests compare the GPU against.
//!
//! Mips on the CPU rather than by GPU blits: they are made once per image at load, the average is
//! taken in linear light (a blit's filtering of sRGB formats is left to the driver), the result is
//! the same bits on every device, and the tests' reference reads the very same levels.

use std::sync::Arc;

use glam::DVec2;

/// A decoded image: every mip level, level 0 first, each `width(l) × height(l)` RGBA8 texels,
/// row by row, colour sRGB-encoded and alpha linear (glTF's base colour and emissive textures).
#[derive(Clone, PartialEq, Eq)]
pub struct TextureImage {
    /// The file and JSON pointer it came from (`/images/3`), for names and errors.
    pub name: String,
    /// Level 0's size in texels.
    pub width: u32,
    /// Level 0's height in texels.
    pub height: u32,
    /// Every level's texels, level 0 first.
    pub levels: Vec<Vec<u8>>,
}

impl std::fmt::Debug for TextureImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "TextureImage({} {}x{}, {} levels)", self.name, self.width, self.height, self.levels.len())
    }
}

impl TextureImage {
    /// An image from level 0's texels (`width × height` RGBA8), its mip chain made here.
    pub fn new(name: String, width: u32, height: u32, rgba: Vec<u8>) -> Self {
        let levels = mip_chain(width, height, rgba);
        TextureImage { name, width, height, levels }
    }

    /// The size of level `l`: each side halved (rounded down, at least 1) per level.
    pub fn level_size(&self, l: usize) -> (u32, u32) {
        ((self.width >> l).max(1), (self.height >> l).max(1))
    }

    /// Texel (x, y) of level `l` as RGBA8.
    pub fn texel(&self, l: usize, x: u32, y: u32) -> [u8; 4] {
        let (w, _) = self.level_size(l);
        let i = 4 * (y as usize * w as usize + x as usize);
        let t = &self.levels[l][i..i + 4];
        [t[0], t[1], t[2], t[3]]
    }
}

/// A sampler's filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Filter {
    /// The nearest texel (or level).
    Nearest,
    /// Linear interpolation between texels (or levels).
    Linear,
}

/// A sampler's wrap mode along one axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Wrap {
    /// The image repeats.
    Repeat,
    /// The image repeats, every other copy mirrored.
    MirroredRepeat,
    /// The edge texels extend outward.
    ClampToEdge,
}

/// How a texture is filtered and wrapped (glTF's `samplers`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SamplerDesc {
    /// Magnification (`magFilter`).
    pub mag: Filter,
    /// Minification within a level (`minFilter`).
    pub min: Filter,
    /// Between mip levels; None: level 0 only (`minFilter` NEAREST or LINEAR).
    pub mipmap: Option<Filter>,
    /// Along u (`wrapS`).
    pub wrap_s: Wrap,
    /// Along v (`wrapT`).
    pub wrap_t: Wrap,
}

impl Default for SamplerDesc {
    /// What a texture without a sampler (or a sampler without filters) gets: glTF leaves the
    /// filters to the implementation; hadou takes trilinear filtering, and REPEAT (glTF's default
    /// wrap).
    fn default() -> Self {
        SamplerDesc {
            mag: Filter::Linear,
            min: Filter::Linear,
            mipmap: Some(Filter::Linear),
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
        }
    }
}

/// One texture a material reads: the image, its sampler, the texture coordinate set and the
/// affine map `KHR_texture_transform` applies to the coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureRef {
    /// The decoded image (shared by every texture that reads it).
    pub image: Arc<TextureImage>,
    /// How it is filtered and wrapped.
    pub sampler: SamplerDesc,
    /// TEXCOORD_0 or TEXCOORD_1 (the extension's `texCoord` wins over the textureInfo's).
    pub texcoord: u32,
    /// Rows of the 2×3 matrix uv' = M·(u, v, 1): translation · rotation · scale.
    pub transform: [[f64; 3]; 2],
}

/// The identity map of texture coordinates.
pub const IDENTITY_UV: [[f64; 3]; 2] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// `KHR_texture_transform`'s matrix T·R·S as rows of a 2×3 matrix (the extension's GLSL, ratified
/// form: u' = sx·cos·u + sy·sin·v + ox, v' = −sx·sin·u + sy·cos·v + oy; a positive rotation turns
/// the image clockwise as seen with v down).
pub fn uv_transform(offset: [f64; 2], rotation: f64, scale: [f64; 2]) -> [[f64; 3]; 2] {
    let (s, c) = rotation.sin_cos();
    [[c * scale[0], s * scale[1], offset[0]], [-s * scale[0], c * scale[1], offset[1]]]
}

impl TextureRef {
    /// The transformed coordinates the texture is sampled at, from the mesh's `uv`.
    pub fn uv(&self, uv: DVec2) -> DVec2 {
        let m = &self.transform;
        DVec2::new(m[0][0] * uv.x + m[0][1] * uv.y + m[0][2], m[1][0] * uv.x + m[1][1] * uv.y + m[1][2])
    }
}

/// The textures of a material the raster draws (none for TOML materials).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct MaterialTextures {
    /// `baseColorTexture`: multiplies the base colour (RGB and alpha).
    pub base: Option<TextureRef>,
    /// `emissiveTexture`: multiplies the emission.
    pub emissive: Option<TextureRef>,
}

impl MaterialTextures {
    /// True when the material has neither texture.
    pub fn is_empty(&self) -> bool {
        self.base.is_none() && self.emissive.is_none()
    }
}

/// An sRGB-encoded 8-bit value in linear light (the sRGB transfer function, in f64).
pub fn srgb_to_linear(v: u8) -> f64 {
    let c = v as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light to the nearest sRGB-encoded 8-bit value.
pub fn linear_to_srgb(l: f64) -> u8 {
    let l = l.clamp(0.0, 1.0);
    let c = if l <= 0.0031308 { l * 12.92 } else { 1.055 * l.powf(1.0 / 2.4) - 0.055 };
    (c * 255.0).round() as u8
}

/// Every mip level from level 0 down to 1×1: each texel of level l+1 averages the 2×2 texels of
/// level l it covers (the last row or column repeated where a side is odd), colour in linear light
/// and re-encoded to sRGB, alpha as is.
pub fn mip_chain(width: u32, height: u32, rgba: Vec<u8>) -> Vec<Vec<u8>> {
    let mut levels = vec![rgba];
    let (mut w, mut h) = (width.max(1), height.max(1));
    while w > 1 || h > 1 {
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let src = levels.last().expect("level 0 exists");
        let mut out = vec![0u8; 4 * nw as usize * nh as usize];
        for y in 0..nh {
            for x in 0..nw {
                let mut sum = [0.0f64; 4];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let sx = (2 * x + dx).min(w - 1) as usize;
                    let sy = (2 * y + dy).min(h - 1) as usize;
                    let t = &src[4 * (sy * w as usize + sx)..][..4];
                    for c in 0..3 {
                        sum[c] += srgb_to_linear(t[c]);
                    }
                    sum[3] += t[3] as f64;
                }
                let o = &mut out[4 * (y as usize * nw as usize + x as usize)..][..4];
                for c in 0..3 {
                    o[c] = linear_to_srgb(sum[c] / 4.0);
                }
                o[3] = (sum[3] / 4.0).round() as u8;
            }
        }
        levels.push(out);
        (w, h) = (nw, nh);
    }
    levels
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mips_average_in_linear_light() {
        // A 2×2 of black and white: the 1×1 level is half the light, sRGB 188, not 128.
        let rgba = [0, 0, 0, 255, 255, 255, 255, 255, 255, 255, 255, 0, 0, 0, 0, 0].to_vec();
        let levels = mip_chain(2, 2, rgba);
        assert_eq!(levels.len(), 2);
        assert_eq!(levels[1], vec![188, 188, 188, 128]);
        let odd = mip_chain(5, 3, vec![7; 60]);
        assert_eq!(odd.iter().map(Vec::len).collect::<Vec<_>>(), vec![60, 8, 4]);
    }

    #[test]
    fn transform_matches_the_extension() {
        // The extension's example: offset [0, 1], rotation π/2, scale 0.5 maps the unit square
        // onto the lower-left quadrant (u in [0, 0.5], v in [0.5, 1]).
        let t = TextureRef {
            image: Arc::new(TextureImage::new("t".into(), 1, 1, vec![0; 4])),
            sampler: SamplerDesc::default(),
            texcoord: 0,
            transform: uv_transform([0.0, 1.0], std::f64::consts::FRAC_PI_2, [0.5, 0.5]),
        };
        for (uv, want) in [((0.0, 0.0), (0.0, 1.0)), ((1.0, 1.0), (0.5, 0.5)), ((0.0, 1.0), (0.5, 1.0))] {
            let got = t.uv(DVec2::new(uv.0, uv.1));
            assert!((got - DVec2::new(want.0, want.1)).length() < 1e-12, "{uv:?} → {got}");
        }
    }
}
