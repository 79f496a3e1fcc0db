//! The frame's images (depth, HDR colour, G-buffer, sRGB output, and those effects declare),
//! sized to the frame's extent. Each remembers its last use so the pass runner can place the
//! barriers.

use crate::gpu::barriers::ImageAccess;
pub use crate::gpu::memory::ImageHandles;
use crate::gpu::memory::{Image, Memory};
use crate::gpu::{vk, GpuContext, GpuResult};

/// An image an effect makes for its passes (`Target::Custom`), declared once as a `static`:
/// the runner creates it at the frame's size when a pass of the frame uses it, and drops it when
/// none does. Storage and transfer-source usage are always included.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ImageDesc {
    /// Unique among images: debug name, error messages, AOV name.
    pub name: &'static str,
    /// Its texel format (one a storage image can have on the device).
    pub format: vk::Format,
    /// Bytes per texel (read-backs).
    pub texel_bytes: u64,
    /// Usage besides STORAGE | TRANSFER_SRC (e.g. SAMPLED), else empty.
    pub usage: vk::ImageUsageFlags,
    /// What a scene needs for a pass to write it (error messages), e.g. "a \[fog\] table".
    pub needs: &'static str,
}

/// Every image a frame may hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Target {
    /// D32 reverse-Z depth of the raster.
    Depth,
    /// Linear HDR colour, RGBA16F.
    Hdr,
    /// World normal facing the camera (xyz), w = 1 where a surface was hit; RGBA16F.
    Normal,
    /// (instance id + 1, material id); 0 where nothing was hit; RG32UI. Ids above the instances'
    /// are effects' surfaces (a metaball group's: instances + 1 + group); a pass that writes one
    /// writes that pixel's `Motion` too when motion vectors are on (the upscaler's `motion` pass
    /// fills only the pixels with no id).
    Ids,
    /// Distance along the view ray from the camera to the first surface, +inf where none; R32F.
    /// Compute passes that add surfaces update this one (D32 is no storage image on lavapipe).
    Distance,
    /// Tonemapped sRGB colour, RGBA8.
    Ldr,
    /// Σ over waves of the line integral H along each view ray; R32F. Only with waves.
    Energy,
    /// light_id: per texel of the light's view, the instance id + 1 of the first translucent
    /// surface the light reaches, 0 where none; R32UI, `light_map_size`².
    LightIds,
    /// light_id: light-space distance of that surface along the light (TSM's depth); R32F,
    /// `light_map_size`².
    LightZ,
    /// light_id's own D32 depth attachment, `light_map_size`².
    LightDepth,
    /// peel: per light-map texel, how many crossings of peel instances its light ray has (more
    /// than the lists hold means it overflowed); R32UI, the light maps' size.
    PeelCounts,
    /// peel: per light-map texel, up to `passes::peel::PEEL_K` crossings (light-space depth,
    /// instance + 1 with the entering flag in bit 31), unsorted; RG32UI, tiles of
    /// `PEEL_TILE` texels per light-map texel.
    PeelLists,
    /// translucency: world thickness of material the light crossed to reach the pixel's
    /// translucent surface, +inf elsewhere; R32F.
    Thickness,
    /// Motion in pixels to the previous frame (`Aov::Motion`); RG32F. With motion vectors on:
    /// written by each pass that draws a surface for its pixels, by the `motion` pass elsewhere.
    Motion,
    /// The reactive mask (`Aov::Reactive`); R32F. With motion vectors on.
    Reactive,
    /// The transparency-and-composition mask (`Aov::Composition`); R32F. With motion vectors on.
    Composition,
    /// The game's depth image of this frame (embedding), imported for the frame.
    GameDepth,
    /// The game's colour target of this frame (embedding), imported for the frame.
    GameColor,
    /// The game's motion, reactive and composition images of this frame (`View::upscaler`),
    /// imported for the frame.
    GameMotion,
    GameReactive,
    GameComposition,
    /// An image an effect declared.
    Custom(&'static ImageDesc),
    /// `Custom(desc)` as the previous frame left it, read-only: a temporal effect (an
    /// accumulation, a TAA history) reads it and writes this frame's `Custom(desc)`. The runner
    /// keeps two images and swaps them each frame, so no copy is made. It holds zeros when there
    /// is no previous frame to read: the first frame that uses it, after a resize, or after a
    /// frame in which no pass used it.
    Previous(&'static ImageDesc),
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
            Target::PeelCounts => "peel_counts",
            Target::PeelLists => "peel_lists",
            Target::Motion => "motion",
            Target::Reactive => "reactive",
            Target::Composition => "composition",
            Target::GameDepth => "game depth",
            Target::GameColor => "game colour",
            Target::GameMotion => "game motion",
            Target::GameReactive => "game reactive",
            Target::GameComposition => "game composition",
            Target::Custom(d) | Target::Previous(d) => d.name,
        }
    }

    pub fn format(self) -> vk::Format {
        match self {
            Target::Depth | Target::LightDepth => vk::Format::D32_SFLOAT,
            Target::Hdr | Target::Normal => vk::Format::R16G16B16A16_SFLOAT,
            Target::Ids | Target::PeelLists => vk::Format::R32G32_UINT,
            Target::LightIds | Target::PeelCounts => vk::Format::R32_UINT,
            Target::Distance
            | Target::Energy
            | Target::LightZ
            | Target::Thickness
            | Target::Reactive
            | Target::Composition => vk::Format::R32_SFLOAT,
            Target::Motion => vk::Format::R32G32_SFLOAT,
            Target::Ldr => vk::Format::R8G8B8A8_UNORM,
            // The game's images carry their own format (`Targets::import`).
            Target::GameDepth
            | Target::GameColor
            | Target::GameMotion
            | Target::GameReactive
            | Target::GameComposition => vk::Format::UNDEFINED,
            Target::Custom(d) | Target::Previous(d) => d.format,
        }
    }

    /// Bytes per texel, for read-back buffers.
    pub fn texel_bytes(self) -> u64 {
        match self {
            Target::Depth | Target::Distance | Target::Ldr | Target::Energy => 4,
            Target::LightIds
            | Target::LightZ
            | Target::LightDepth
            | Target::Thickness
            | Target::PeelCounts
            | Target::Reactive
            | Target::Composition => 4,
            Target::Hdr | Target::Normal | Target::Ids | Target::PeelLists | Target::Motion => 8,
            Target::GameDepth
            | Target::GameColor
            | Target::GameMotion
            | Target::GameReactive
            | Target::GameComposition => 0,
            Target::Custom(d) | Target::Previous(d) => d.texel_bytes,
        }
    }

    /// What a scene needs for its passes to write this image (for error messages).
    pub fn needs(self) -> &'static str {
        match self {
            Target::Energy => "a [[wave]]",
            Target::Thickness | Target::LightIds | Target::LightZ | Target::LightDepth => {
                "an instance with a translucent material"
            }
            Target::PeelCounts | Target::PeelLists => "an instance with a thickness = \"peel\" material",
            Target::Motion | Target::Reactive | Target::Composition => {
                "motion vectors on (Renderer::set_motion_vectors)"
            }
            Target::GameDepth
            | Target::GameColor
            | Target::GameMotion
            | Target::GameReactive
            | Target::GameComposition => "a game's image handed to record_frame",
            Target::Custom(d) | Target::Previous(d) => d.needs,
            _ => "a frame recorded first",
        }
    }

    /// The image this one is the previous frame of (`Previous(d)` → `Custom(d)`).
    pub fn current(self) -> Option<Target> {
        match self {
            Target::Previous(d) => Some(Target::Custom(d)),
            _ => None,
        }
    }

    /// Whether the image is the game's, imported each frame rather than made by hadou.
    pub fn is_external(self) -> bool {
        matches!(
            self,
            Target::GameDepth
                | Target::GameColor
                | Target::GameMotion
                | Target::GameReactive
                | Target::GameComposition
        )
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
            Target::Ldr | Target::Energy | Target::Thickness | Target::Reactive | Target::Composition => {
                base | vk::ImageUsageFlags::STORAGE
            }
            // TRANSFER_DST: the peel pass clears its counters with vkCmdClearColorImage.
            Target::PeelCounts => base | vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST,
            Target::PeelLists => base | vk::ImageUsageFlags::STORAGE,
            Target::GameDepth
            | Target::GameColor
            | Target::GameMotion
            | Target::GameReactive
            | Target::GameComposition => vk::ImageUsageFlags::empty(),
            Target::Custom(d) => base | vk::ImageUsageFlags::STORAGE | d.usage,
            // The two images of a history swap roles: the same usage, and TRANSFER_DST for the
            // clear of a fresh history.
            Target::Previous(d) => {
                base | vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST | d.usage
            }
            _ => base | vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::STORAGE,
        }
    }
}

/// A frame image and how it was last used; `image` is None for the game's images (their raw
/// handles are in `external`).
struct Tracked {
    image: Option<Image>,
    /// The last write (or layout transition) to it, which later readers wait for.
    writer: ImageAccess,
    /// Sized by a pass (the light maps) rather than to the frame.
    fixed: bool,
    external: Option<External>,
    last: ImageAccess,
    /// Made since the frame's history images were last swapped: its contents are undefined
    /// (a `Previous` image is cleared to zeros before it is read).
    fresh: bool,
}

/// A game image imported for one frame.
#[derive(Clone, Copy, Debug)]
struct External {
    raw: vk::Image,
    view: vk::ImageView,
    format: vk::Format,
}

/// The frame's images, made on first use by a pass at the sizes the passes ask for; shared by
/// every frame slot (frames are ordered on the GPU by the barriers the runner places).
pub struct Targets {
    /// The frame's size; a target a pass sizes itself has its own (`ImageHandles::extent`).
    pub extent: vk::Extent2D,
    images: Vec<(Target, Tracked)>,
}

impl Targets {
    pub fn new(extent: vk::Extent2D) -> Self {
        Targets { extent, images: Vec::new() }
    }

    /// Makes `target` (at the frame's size, or `fixed` when given) unless it exists at that size.
    /// A pass that gives no size takes a fixed-size target as another pass made it. A target made
    /// anew at another size retires the old image with the frame.
    pub fn ensure(
        &mut self,
        ctx: &GpuContext,
        memory: &Memory,
        target: Target,
        fixed: Option<vk::Extent2D>,
    ) -> GpuResult<()> {
        if target.is_external() {
            return Ok(());
        }
        let size = fixed.unwrap_or(self.extent);
        let found = self.images.iter().position(|(t, _)| *t == target);
        if let Some(i) = found {
            let t = &self.images[i].1;
            let keep = fixed.is_none() && t.fixed;
            if keep || t.image.as_ref().is_some_and(|im| im.extent == size) {
                return Ok(());
            }
            self.images.remove(i);
        }
        let image = memory.create_image(ctx, target.name(), size, target.format(), target.usage())?;
        let fixed = fixed.is_some();
        let tracked = Tracked {
            image: Some(image),
            writer: ImageAccess::UNDEFINED,
            fixed,
            external: None,
            last: ImageAccess::UNDEFINED,
            fresh: true,
        };
        self.images.push((target, tracked));
        Ok(())
    }

    /// The game's image `target` for this frame, found in `layout` after any earlier command.
    pub fn import(
        &mut self,
        target: Target,
        raw: vk::Image,
        view: vk::ImageView,
        format: vk::Format,
        last: ImageAccess,
    ) {
        self.images.retain(|(t, _)| *t != target);
        let external = Some(External { raw, view, format });
        let tracked = Tracked { image: None, writer: last, fixed: false, external, last, fresh: false };
        self.images.push((target, tracked));
    }

    /// Drops the images no pass of the frame uses any more (retired with the frame).
    pub fn retain_only(&mut self, wanted: &[Target]) {
        self.images.retain(|(t, _)| wanted.contains(t));
    }

    /// Forgets the game's images at the end of a frame (a game may hand other ones next frame).
    pub fn drop_imports(&mut self) {
        self.images.retain(|(t, _)| !t.is_external());
    }

    pub fn contains(&self, target: Target) -> bool {
        self.images.iter().any(|(t, _)| *t == target)
    }

    /// The handles of a target a pass declared (so it exists); None otherwise.
    pub fn get(&self, target: Target) -> Option<ImageHandles> {
        let (_, t) = self.images.iter().find(|(t, _)| *t == target)?;
        Some(match (&t.image, &t.external) {
            (Some(i), _) => ImageHandles { raw: i.raw, view: i.view, format: i.format, extent: i.extent },
            (None, Some(e)) => {
                ImageHandles { raw: e.raw, view: e.view, format: e.format, extent: self.extent }
            }
            (None, None) => return None,
        })
    }

    /// The handles of a target a pass declared in `images()` (the runner made it); a pass that
    /// asks for one it did not declare gets null handles (an error of that pass, which the
    /// validation layers name) and an error in the log, never a panic in the frame path.
    pub fn image(&self, target: Target) -> ImageHandles {
        self.get(target).unwrap_or_else(|| {
            log::error!("image {} was not created: no pass of this frame declares it", target.name());
            ImageHandles {
                raw: vk::Image::null(),
                view: vk::ImageView::null(),
                format: target.format(),
                extent: self.extent,
            }
        })
    }

    /// The barrier taking `target` to `next`, recording `next` as its last use. Reads in one
    /// layout accumulate: a reader in a stage the last write was not yet made visible to gets a
    /// barrier from that write, and the next write or layout change waits for every reader.
    pub fn transition(
        &mut self,
        target: Target,
        next: ImageAccess,
    ) -> Option<vk::ImageMemoryBarrier2<'static>> {
        use crate::gpu::barriers::image_barrier;
        let handles = self.get(target)?;
        let tracked = &mut self.images.iter_mut().find(|(t, _)| *t == target)?.1;
        let (last, writer) = (tracked.last, tracked.writer);
        let read_on = |a: ImageAccess| !a.writes() && a.layout == next.layout && !next.writes();
        if read_on(last) && last.layout != vk::ImageLayout::UNDEFINED {
            tracked.last.stage |= next.stage;
            tracked.last.access |= next.access;
            if last.stage.contains(next.stage) {
                return None;
            }
            // The last write, made visible to this reader's stage too (no layout change).
            let from = ImageAccess { layout: next.layout, ..writer };
            return image_barrier(handles.raw, handles.format, from, next).or_else(|| {
                image_barrier(
                    handles.raw,
                    handles.format,
                    ImageAccess { access: vk::AccessFlags2::MEMORY_WRITE, ..from },
                    next,
                )
            });
        }
        let barrier = image_barrier(handles.raw, handles.format, last, next);
        tracked.last = next;
        tracked.writer = if next.writes() || next.layout != last.layout { next } else { writer };
        barrier
    }

    /// Forgets the contents (every frame clears or overwrites them): the next transition starts
    /// from UNDEFINED but still waits for the last use, so a new frame never races the previous one.
    /// History images (`Previous`) keep theirs.
    pub fn discard_all(&mut self) {
        for (target, t) in &mut self.images {
            if !matches!(target, Target::Previous(_)) {
                t.last.layout = vk::ImageLayout::UNDEFINED;
            }
        }
    }

    /// Starts a frame's history: each `Custom(d)` the last frame wrote becomes this frame's
    /// `Previous(d)` and the old previous image is overwritten as this frame's `Custom(d)` (the
    /// two swap, no copy). A `Previous(d)` whose `Custom(d)` was made anew since (a resize) stays
    /// fresh: cleared before it is read. Called before `discard_all`.
    pub fn advance_history(&mut self) {
        let histories: Vec<usize> =
            (0..self.images.len()).filter(|&i| matches!(self.images[i].0, Target::Previous(_))).collect();
        for i in histories {
            let Some(current) = self.images[i].0.current() else { continue };
            let Some(j) = self.images.iter().position(|(t, _)| *t == current) else { continue };
            let (a, b) = (&self.images[i].1, &self.images[j].1);
            let same_size = a.image.as_ref().map(|im| im.extent) == b.image.as_ref().map(|im| im.extent);
            if !same_size {
                continue;
            }
            // Swap the images with what is known of them; the new previous image holds what
            // the last frame wrote (not fresh), the new current one is overwritten this frame.
            let (lo, hi) = (i.min(j), i.max(j));
            let (left, right) = self.images.split_at_mut(hi);
            std::mem::swap(&mut left[lo].1, &mut right[0].1);
            self.images[i].1.fresh = false;
        }
    }

    /// The fresh history images of `uses` (nothing to read yet) cleared to zeros, recording the
    /// clear as their last write; the pass's own transition then waits for it.
    pub fn clear_fresh_history(&mut self, rec: &crate::gpu::recorder::Recorder, uses: &[Target]) {
        for &target in uses {
            if !matches!(target, Target::Previous(_)) {
                continue;
            }
            let fresh = self.images.iter().any(|(t, tr)| *t == target && tr.fresh);
            if !fresh {
                continue;
            }
            let barrier = self.transition(target, ImageAccess::CLEAR_GENERAL);
            crate::gpu::barriers::cmd_barriers(&rec.ctx.device, rec.cmd, barrier.as_slice(), &[]);
            let zero = vk::ClearColorValue { uint32: [0; 4] };
            rec.clear_general_image(&self.image(target), zero);
            if let Some((_, t)) = self.images.iter_mut().find(|(t, _)| *t == target) {
                t.fresh = false;
            }
        }
    }
}
