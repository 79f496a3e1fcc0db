//! The wgpu host's frame: wgpu draws the game's boxes into its colour and depth textures, then
//! hadou is recorded into the same command encoder (through `as_hal_mut`) on those textures'
//! raw images, and wgpu goes on (a copy for read-back, or present). Frames in flight: the host
//! waits for the submission that last used a slot before recording it again — hadou's frame
//! contract, met with wgpu's submission indices.
#![allow(dead_code)]

use ash::vk;
use hadou::{DepthConvention, ExternalColor, ExternalDepth, FrameInputs};
use wgpu::hal::api::Vulkan;

use super::boxes::{BoxPainter, DEPTH_FORMAT};
use super::device::WgpuVulkan;
use super::game::{camera, GameState};
use super::world::{wgpu_view_projection, HadouWorld};

/// The layouts wgpu's states put the textures in (wgpu-hal's `derive_image_layout`), which hadou
/// is handed as `layout` and `final_layout`: the host moves them there with
/// `transition_resources` before hadou, and wgpu's tracker still holds that state after it.
pub const COLOR_STATE: (wgpu::TextureUses, vk::ImageLayout) =
    (wgpu::TextureUses::COLOR_TARGET, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
/// A depth texture in RESOURCE (sampled) state: depth-stencil read-only for wgpu.
pub const DEPTH_STATE: (wgpu::TextureUses, vk::ImageLayout) =
    (wgpu::TextureUses::RESOURCE, vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL);

/// The game's depth texture: D32 with TEXTURE_BINDING (hadou samples it) and COPY_SRC (tests
/// read it back).
pub struct DepthTarget {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub size: (u32, u32),
}

/// One submitted frame: hadou's frame number and wgpu's submission.
struct InFlight {
    frame: u64,
    submission: wgpu::SubmissionIndex,
}

pub struct WgpuHost {
    /// hadou's world first: dropped before the device (`destroy`).
    pub world: Option<HadouWorld>,
    pub gpu: WgpuVulkan,
    pub state: GameState,
    boxes: Option<BoxPainter>,
    pub depth: Option<DepthTarget>,
    /// Per slot (hadou's frames in flight): the frame that last used it.
    slots: Vec<Option<InFlight>>,
}

impl WgpuHost {
    pub fn new(gpu: WgpuVulkan, frames: usize) -> Result<Self, String> {
        // SAFETY: wgpu's device was opened with EnabledFeatures::REQUIRED (device.rs); `destroy`
        // drops the world before the device.
        let world = unsafe { HadouWorld::new(gpu.hadou_raw(), frames) }?;
        let slots = (0..world.hadou.frames_in_flight()).map(|_| None).collect();
        Ok(WgpuHost { world: Some(world), gpu, state: GameState::default(), boxes: None, depth: None, slots })
    }

    pub fn world(&mut self) -> &mut HadouWorld {
        self.world.as_mut().expect("a live world")
    }

    /// Steps the game and hands hadou the new state.
    pub fn update(&mut self, input: &super::game::Input, dt: f64) -> Result<(), String> {
        self.state.step(input, dt);
        let state = self.state.clone();
        self.world().apply(&state)
    }

    /// Waits for the frame that last used the next frame's slot (n − frames in flight) and tells
    /// hadou it finished; returns a fresh encoder for the frame.
    pub fn begin_frame(&mut self) -> Result<wgpu::CommandEncoder, String> {
        let next = self.world().hadou.next_frame();
        let slot = next as usize % self.slots.len();
        if let Some(done) = self.slots[slot].take() {
            self.gpu
                .device
                .poll(wgpu::PollType::WaitForSubmissionIndex(done.submission))
                .map_err(|e| e.to_string())?;
            self.world().hadou.frame_finished(done.frame).map_err(|e| e.to_string())?;
        }
        Ok(self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") }))
    }

    /// wgpu's own content: clears and draws the game's boxes into `color` and the host's depth.
    pub fn record_game(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::Texture,
        view: &wgpu::TextureView,
    ) -> Result<(), String> {
        let size = (color.width(), color.height());
        if self.boxes.as_ref().is_none_or(|b| b.color_format != color.format()) {
            self.boxes = Some(BoxPainter::new(&self.gpu.device, color.format()));
        }
        if self.depth.as_ref().is_none_or(|d| d.size != size) {
            // The old texture may still be read by frames in flight: wgpu keeps it alive until
            // they finish, but hadou was handed its raw image, so wait for them first.
            self.wait_all()?;
            let texture = self.gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("game depth"),
                size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: DEPTH_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            });
            let view = texture.create_view(&wgpu::TextureViewDescriptor {
                aspect: wgpu::TextureAspect::DepthOnly,
                ..Default::default()
            });
            self.depth = Some(DepthTarget { texture, view, size });
        }
        let (Some(boxes), Some(depth)) = (&self.boxes, &self.depth) else { return Ok(()) };
        let vp = wgpu_view_projection(size.0, size.1);
        boxes.record(&self.gpu.queue, encoder, view, &depth.view, vp, &self.state.boxes());
        Ok(())
    }

    /// hadou's frame, recorded into `encoder` after wgpu's content: depth imported from the host's
    /// depth texture, composited into `color`. Both are first moved to the states whose layouts
    /// hadou is told (COLOR_STATE, DEPTH_STATE); hadou leaves them in those layouts.
    pub fn record_hadou(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        color: &wgpu::Texture,
        view: &wgpu::TextureView,
    ) -> Result<hadou::RecordedFrame, String> {
        let depth = self.depth.as_ref().ok_or("record_game first")?;
        let transitions = [
            wgpu::TextureTransition { texture: color, selector: None, state: COLOR_STATE.0 },
            wgpu::TextureTransition { texture: &depth.texture, selector: None, state: DEPTH_STATE.0 },
        ];
        encoder.transition_resources(std::iter::empty(), transitions.into_iter());
        let raw = |t: &wgpu::Texture, v: &wgpu::TextureView| {
            // SAFETY: the handles are only read; wgpu keeps the texture and view alive while the host
            // holds them, and the host keeps them until the frame finished (begin_frame, wait_all).
            unsafe {
                let image = t.as_hal::<Vulkan>().map(|t| t.raw_handle());
                let view = v.as_hal::<Vulkan>().map(|v| v.raw_handle());
                image.zip(view).ok_or("not a Vulkan texture")
            }
        };
        let (depth_image, depth_view) = raw(&depth.texture, &depth.view)?;
        let (color_image, color_view) = raw(color, view)?;
        let cam = camera();
        let inputs = FrameInputs {
            extent: vk::Extent2D { width: color.width(), height: color.height() },
            time: self.state.time,
            depth: Some(ExternalDepth {
                image: depth_image,
                view: depth_view,
                format: vk::Format::D32_SFLOAT,
                layout: DEPTH_STATE.1,
                final_layout: DEPTH_STATE.1,
                convention: DepthConvention::Standard { near: cam.near, far: cam.far },
                write: false,
            }),
            color: Some(ExternalColor {
                image: color_image,
                view: color_view,
                format: self.gpu.raw_format(color.format()),
                layout: COLOR_STATE.1,
                final_layout: COLOR_STATE.1,
            }),
        };
        let hadou = &mut self.world.as_mut().ok_or("no world")?.hadou;
        // SAFETY: the raw command buffer is only recorded into (never ended, submitted or freed);
        // every image hadou is handed is in the layout it is told (the transitions above).
        unsafe {
            encoder.as_hal_mut::<Vulkan, _, _>(|e| {
                let e = e.ok_or("not a Vulkan encoder")?;
                hadou.record_frame(e.raw_handle(), &inputs).map_err(|e| e.to_string())
            })
        }
    }

    /// Submits the frame's encoder and remembers it in the slot of the frame just recorded.
    pub fn submit(&mut self, encoder: wgpu::CommandEncoder, recorded: hadou::RecordedFrame) {
        let submission = self.gpu.queue.submit([encoder.finish()]);
        if recorded.recorded {
            let slot = recorded.frame as usize % self.slots.len();
            self.slots[slot] = Some(InFlight { frame: recorded.frame, submission });
        }
    }

    /// Waits for every frame in flight and tells hadou they finished.
    pub fn wait_all(&mut self) -> Result<(), String> {
        self.gpu.device.poll(wgpu::PollType::Wait).map_err(|e| e.to_string())?;
        let mut done: Vec<u64> = self.slots.iter_mut().filter_map(|s| s.take().map(|f| f.frame)).collect();
        done.sort_unstable();
        for frame in done {
            self.world().hadou.frame_finished(frame).map_err(|e| e.to_string())?;
        }
        Ok(())
    }

    /// hadou first (after the frames finished), then wgpu's objects, then the device; returns what
    /// validation reported over the whole run, device destruction included.
    pub fn destroy(mut self) -> std::sync::Arc<super::gpu::Messages> {
        let _ = self.wait_all();
        drop(self.world.take());
        let WgpuHost { gpu, boxes, depth, .. } = self;
        drop((boxes, depth));
        gpu.destroy()
    }
}

/// A colour texture wgpu renders into and hadou composites into, read back by copies.
pub fn color_texture(
    device: &wgpu::Device,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("game colour"),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}
