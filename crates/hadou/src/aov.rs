//! AOVs: images a frame can hand back besides its colour, as f32.

use crate::gpu::vk;
use crate::targets::{ImageDesc, Target};

/// An arbitrary output variable, read back as f32.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Aov {
    /// Distance along the pixel's view ray from the camera position to the first surface, in
    /// world units; +inf where nothing is hit. One channel.
    Depth,
    /// Linear HDR colour before tonemapping (RGBA).
    Hdr,
    /// World normal of the first surface, turned toward the camera (xyz), w = 1 on a hit, 0 elsewhere.
    Normal,
    /// Σ over the scene's waves of the raw line integral H along the view ray, clipped by the
    /// depth (no colour, no intensity). One channel. Only for scenes with waves.
    Energy,
    /// World thickness of material the first directional light crossed to reach the pixel's
    /// translucent surface (seed 003: LUT or TSM, per material); +inf where the surface is not
    /// translucent (or the scene has no light). One channel. Only for scenes with a translucent
    /// instance.
    Thickness,
    /// Screen-space motion in pixels from the pixel to where its surface was in the previous
    /// frame (x right, y down; current → previous, the jitter of both frames removed: the
    /// convention FSR 2 and DLSS document). Two channels. Only with motion vectors on
    /// (`Renderer::set_motion_vectors`).
    Motion,
    /// The reactive mask of a temporal upscaler: the share of the pixel's HDR luminance that the
    /// energy wave's glow added, in [0, 1] (0 where no wave shows). One channel. Only with motion
    /// vectors on.
    Reactive,
    /// The transparency-and-composition mask: 1 where a translucent surface of hadou's is the
    /// pixel's first surface (its colour is light through the object, not its texture), else 0.
    /// One channel. Only with motion vectors on.
    Composition,
    /// An image an effect publishes (`crate::effect`): R32_SFLOAT, R32G32_SFLOAT,
    /// R32G32B32A32_SFLOAT or R16G16B16A16_SFLOAT, read back as f32 (other formats: their
    /// texels' bits as f32, one value per 4 bytes).
    Effect(&'static ImageDesc),
}

impl Aov {
    /// hadou's own AOVs, in declaration order, but for the upscaler's inputs.
    pub const ALL: [Aov; 5] = [Aov::Depth, Aov::Hdr, Aov::Normal, Aov::Energy, Aov::Thickness];
    /// A temporal upscaler's inputs (with motion vectors on, `Renderer::set_motion_vectors`).
    pub const UPSCALER: [Aov; 3] = [Aov::Motion, Aov::Reactive, Aov::Composition];

    /// The CLI's name for it: "depth", "hdr", "normal", "energy" or "thickness".
    pub fn name(self) -> &'static str {
        match self {
            Aov::Depth => "depth",
            Aov::Hdr => "hdr",
            Aov::Normal => "normal",
            Aov::Energy => "energy",
            Aov::Thickness => "thickness",
            Aov::Motion => "motion",
            Aov::Reactive => "reactive",
            Aov::Composition => "composition",
            Aov::Effect(d) => d.name,
        }
    }

    /// hadou's AOV called `name` (see `name`); None for any other string.
    pub fn from_name(name: &str) -> Option<Aov> {
        Aov::ALL.into_iter().chain(Aov::UPSCALER).find(|a| a.name() == name)
    }

    /// The internal image it is read from.
    pub fn target(self) -> Target {
        match self {
            Aov::Depth => Target::Distance,
            Aov::Hdr => Target::Hdr,
            Aov::Normal => Target::Normal,
            Aov::Energy => Target::Energy,
            Aov::Thickness => Target::Thickness,
            Aov::Motion => Target::Motion,
            Aov::Reactive => Target::Reactive,
            Aov::Composition => Target::Composition,
            Aov::Effect(d) => Target::Custom(d),
        }
    }

    /// f32 values per pixel: 1 for depth, energy and thickness, 4 for hdr and normal.
    pub fn channels(self) -> u32 {
        match self {
            Aov::Depth | Aov::Energy | Aov::Thickness | Aov::Reactive | Aov::Composition => 1,
            Aov::Motion => 2,
            Aov::Hdr | Aov::Normal => 4,
            Aov::Effect(d) => match d.format {
                vk::Format::R16G16B16A16_SFLOAT => 4,
                _ => (d.texel_bytes / 4).max(1) as u32,
            },
        }
    }
}

/// A read-back AOV: `channels` interleaved f32 per pixel, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct AovImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Values per pixel (`Aov::channels`).
    pub channels: u32,
    /// width × height × channels values, row-major.
    pub data: Vec<f32>,
}

impl AovImage {
    /// Converts the target's texels (R32F or RGBA16F) to f32.
    pub fn decode(aov: Aov, width: u32, height: u32, bytes: &[u8]) -> AovImage {
        let mut data = Vec::new();
        Self::decode_into(aov, bytes, &mut data);
        AovImage { width, height, channels: aov.channels(), data }
    }

    /// As `decode`, but a host allocation that cannot be had (a 16384² HDR AOV is 4 GiB of f32)
    /// is an error naming the AOV, not an abort.
    pub fn try_decode(aov: Aov, width: u32, height: u32, bytes: &[u8]) -> Result<AovImage, crate::GpuError> {
        let values = match aov.target().format() {
            crate::gpu::vk::Format::R16G16B16A16_SFLOAT => bytes.len() / 2,
            _ => bytes.len() / 4,
        };
        let mut data = Vec::new();
        data.try_reserve_exact(values).map_err(|_| crate::GpuError::OutOfHostMemory {
            what: format!("the {} AOV ({values} values)", aov.name()),
        })?;
        Self::decode_into(aov, bytes, &mut data);
        Ok(AovImage { width, height, channels: aov.channels(), data })
    }

    fn decode_into(aov: Aov, bytes: &[u8], data: &mut Vec<f32>) {
        match aov.target().format() {
            crate::gpu::vk::Format::R16G16B16A16_SFLOAT => data.extend(
                bytes
                    .chunks_exact(2)
                    .map(|b| half::f16::from_bits(u16::from_le_bytes([b[0], b[1]])).to_f32()),
            ),
            _ => data.extend(bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))),
        }
    }

    /// The value of channel `c` at pixel (x, y).
    pub fn at(&self, x: u32, y: u32, c: u32) -> f32 {
        self.data[((y * self.width + x) * self.channels + c) as usize]
    }
}
