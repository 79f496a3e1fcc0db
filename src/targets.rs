//! The frame's images (depth, HDR colour, G-buffer, sRGB output), sized to the frame's extent.
//! Each remembers its last use so the pass runner can place the barriers.

use crate::gpu::barriers::ImageAccess;
use crate::gpu::memory::{Image, Memory};
use crate::gpu::{vk, GpuContext, GpuResult};

/// Every image a frame may hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Target {
    /// D32 reverse-Z depth of the raster.
    Depth,
    /// Linear HDR colour, RGBA16F.
    Hdr,
    /// World normal facing the camera (xyz), w = 1 where a surface was hit; RGBA16F.
    Normal,
    /// (instance id + 1, material id); 0 where nothing was hit; RG32UI.
    Ids,
    /// Distance along the view ray from the camera to the first surface, +inf where none; R32F.
    /// Compute passes that add surfaces update this one (D32 is no storage image on lavapipe).
    Distance,
    /// Tonemapped sRGB colour, RGBA8.
    Ldr,
    /// Σ over waves of the line integral H along each view ray; R32F. Only with waves.
    Energy,
    /// light_id: per texel of the light's view, (instance id + 1, surface-voxel id) of the first
    /// translucent surface the light reaches, (0, 0) where none; RG32UI, `LIGHT_MAP_SIZE`².
    LightIds,
    /// light_id: light-space distance of that surface along the light (TSM's depth); R32F,
    /// `LIGHT_MAP_SIZE`².
    LightZ,
    /// light_id's own D32 depth attachment, `LIGHT_MAP_SIZE`².
    LightDepth,
    /// translucency: world thickness of material the light crossed to reach the pixel's
    /// translucent surface, +inf elsewhere; R32F.
    Thickness,
}

impl Target {
    pub fn name(self) -> &'static str {
        match self {
            Target::Depth => "depth",
            Target::Hdr => "hdr",
            Target::Normal => "normal",
            Target::Ids => "ids",
            Target::Distance => "distance",
            Target::Ldr => "ldr",
            Target::Energy => "energy",
            Target::LightIds => "light_ids",
            Target::LightZ => "light_z",
            Target::LightDepth => "light_depth",
            Target::Thickness => "thickness",
        }
    }

    pub fn format(self) -> vk::Format {
        match self {
            Target::Depth | Target::LightDepth => vk::Format::D32_SFLOAT,
            Target::Hdr | Target::Normal => vk::Format::R16G16B16A16_SFLOAT,
            Target::Ids | Target::LightIds => vk::Format::R32G32_UINT,
            Target::Distance | Target::Energy | Target::LightZ | Target::Thickness => vk::Format::R32_SFLOAT,
            Target::Ldr => vk::Format::R8G8B8A8_UNORM,
        }
    }

    /// Bytes per texel, for read-back buffers.
    pub fn texel_bytes(self) -> u64 {
        match self {
            Target::Depth | Target::Distance | Target::Ldr | Target::Energy => 4,
            Target::LightZ | Target::LightDepth | Target::Thickness => 4,
            Target::Hdr | Target::Normal | Target::Ids | Target::LightIds => 8,
        }
    }

    /// The size of a target that does not follow the frame's (the light maps, `light_map`² texels:
    /// `effects::translucency::light_map_size`); `None` for the rest.
    pub fn fixed_extent(self, light_map: u32) -> Option<vk::Extent2D> {
        match self {
            Target::LightIds | Target::LightZ | Target::LightDepth => {
                Some(vk::Extent2D { width: light_map, height: light_map })
            }
            _ => None,
        }
    }

    fn usage(self) -> vk::ImageUsageFlags {
        let base = vk::ImageUsageFlags::TRANSFER_SRC;
        match self {
            // TRANSFER_DST: an embedded frame copies the game's imported depth into it.
            Target::Depth => {
                base | vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
                    | vk::ImageUsageFlags::SAMPLED
                    | vk::ImageUsageFlags::TRANSFER_DST
            }
            Target::LightDepth => {
                base | vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED
            }
            Target::Ldr | Target::Energy | Target::Thickness => base | vk::ImageUsageFlags::STORAGE,
            _ => base | vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::STORAGE,
        }
    }
}

struct Tracked {
    image: Image,
    last: ImageAccess,
}

pub struct Targets {
    /// The frame's size; a target with a `fixed_extent` has its own (`Image::extent`).
    pub extent: vk::Extent2D,
    images: Vec<(Target, Tracked)>,
}

impl Targets {
    /// Creates the images in `wanted` (those the frame's passes use); the light maps are
    /// `light_map`² texels.
    pub fn new(
        ctx: &GpuContext,
        memory: &Memory,
        extent: vk::Extent2D,
        wanted: &[Target],
        light_map: u32,
    ) -> GpuResult<Self> {
        let mut targets = Targets { extent, images: Vec::new() };
        for &target in wanted {
            let size = target.fixed_extent(light_map).unwrap_or(extent);
            match memory.create_image(ctx, target.name(), size, target.format(), target.usage()) {
                Ok(image) => targets.images.push((target, Tracked { image, last: ImageAccess::UNDEFINED })),
                Err(e) => {
                    targets.destroy(ctx, memory);
                    return Err(e);
                }
            }
        }
        Ok(targets)
    }

    pub fn contains(&self, target: Target) -> bool {
        self.images.iter().any(|(t, _)| *t == target)
    }

    /// The image of a target a pass declared in `uses()` (so it was created).
    pub fn image(&self, target: Target) -> &Image {
        let found = self.images.iter().find(|(t, _)| *t == target);
        &found
            .unwrap_or_else(|| panic!("target {} was not created: a pass did not declare it", target.name()))
            .1
            .image
    }

    /// The barrier taking `target` to `next`, recording `next` as its last use.
    pub fn transition(
        &mut self,
        target: Target,
        next: ImageAccess,
    ) -> Option<vk::ImageMemoryBarrier2<'static>> {
        let tracked = &mut self.images.iter_mut().find(|(t, _)| *t == target)?.1;
        let barrier =
            crate::gpu::barriers::image_barrier(tracked.image.raw, tracked.image.format, tracked.last, next);
        tracked.last = next;
        barrier
    }

    /// Forgets the contents (every frame clears or overwrites them): the next transition starts
    /// from UNDEFINED but still waits for the last use, so a new frame never races the previous one.
    pub fn discard_all(&mut self) {
        for (_, t) in &mut self.images {
            t.last.layout = vk::ImageLayout::UNDEFINED;
        }
    }

    pub fn destroy(self, ctx: &GpuContext, memory: &Memory) {
        for (_, t) in self.images {
            memory.destroy_image(ctx, t.image);
        }
    }
}
