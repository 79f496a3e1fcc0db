//! One file per pass. A pass declares what it touches — the frame images with how it uses them,
//! and each frame the resources of its descriptor set in binding order — and records its
//! commands; the runner (frame.rs) derives the images to make, the barriers, the descriptor set,
//! the debug label and the timestamps from that declaration. See docs/ARCHITECTURE.md.
//!
//! Which passes a scene runs: `crate::effect` (each effect registers its passes).

pub mod composite;
pub mod depth_import;
pub mod depth_out;
pub mod energy_probe;
pub mod energy_wave;
pub mod energy_wave_tiles;
pub mod gpu_structs;
pub mod light_id;
pub mod metaballs;
pub mod metaballs_bin;
pub mod metaballs_device;
pub mod metaballs_motion;
pub mod motion;
pub mod peel;
pub mod pipeline_memo;
pub mod raster;
pub mod upscaler_out;

pub mod tonemap;
pub mod translucency;

use bytemuck::Pod;

use crate::frame::FrameStats;
use crate::gpu::barriers::ImageAccess;
use crate::gpu::memory::Memory;
use crate::gpu::pipeline::{Bound, BufferRange, Pipeline};
use crate::gpu::recorder::Recorder;
use crate::gpu::ring::{RingPart, TexelView, UploadRing};
use crate::gpu::texel_buffer::Texels;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene::Scene;
use crate::scene_gpu::SceneGpu;
use crate::targets::{Target, Targets};

/// One resource of a pass's descriptor set, in binding order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Binding {
    /// A frame image bound as a storage image (its access in the GENERAL layout). This one
    /// declaration makes the runner create the image, place its barrier and bind it; it is not
    /// repeated in `Pass::images()`. `Binding::read` / `write` / `read_write` for a compute pass.
    Image(ImageUse),
    /// A frame image sampled with `sampler` (`Binding::sampled` for a compute pass).
    SampledImage(ImageUse, vk::Sampler),
    /// Anything else the pass owns or the frame's ring holds (read by the GPU, written by the host).
    Bound(Bound),
    /// A storage buffer the pass writes, and who reads it afterwards: the runner places the
    /// barriers before (after that reader's previous-frame use) and after the pass.
    Written(BufferRange, Reader),
}

impl Binding {
    /// `target` read by a compute shader as a storage image.
    pub fn read(target: Target) -> Binding {
        Binding::Image(ImageUse::new(target, ImageAccess::COMPUTE_READ))
    }

    /// `target` written by a compute shader as a storage image.
    pub fn write(target: Target) -> Binding {
        Binding::Image(ImageUse::new(target, ImageAccess::COMPUTE_WRITE))
    }

    /// `target` read and written by a compute shader as a storage image.
    pub fn read_write(target: Target) -> Binding {
        Binding::Image(ImageUse::new(target, ImageAccess::COMPUTE_READ_WRITE))
    }

    /// `target` sampled by a compute shader with `sampler`.
    pub fn sampled(target: Target, sampler: vk::Sampler) -> Binding {
        Binding::SampledImage(ImageUse::new(target, ImageAccess::COMPUTE_SAMPLED), sampler)
    }

    /// The frame image this binding declares, if it is one.
    pub fn image_use(&self) -> Option<ImageUse> {
        match *self {
            Binding::Image(u) | Binding::SampledImage(u, _) => Some(u),
            _ => None,
        }
    }
}

/// Who reads a buffer a pass wrote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reader {
    /// The host, after the frame has finished (statistics, probe results).
    Host,
    /// A copy command later in the same pass.
    Copy,
    /// A later compute dispatch of the same pass (which places the barrier between them).
    Compute,
    /// A later indirect dispatch of the same pass, as its arguments (the pass places the barrier).
    Indirect,
}

impl Reader {
    /// The stage and access the reader uses the buffer with (the barriers' destination).
    pub fn stage(self) -> (vk::PipelineStageFlags2, vk::AccessFlags2) {
        match self {
            Reader::Host => (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
            Reader::Copy => (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_READ),
            Reader::Compute => {
                (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_READ)
            }
            Reader::Indirect => {
                (vk::PipelineStageFlags2::DRAW_INDIRECT, vk::AccessFlags2::INDIRECT_COMMAND_READ)
            }
        }
    }
}

/// What a pass sees while preparing a frame: the scene, the frame's parameters and the slot's
/// upload ring. The slot's previous frame has finished.
pub struct FrameContext<'a> {
    /// The device.
    pub ctx: &'a GpuContext,
    /// Its memory allocator.
    pub memory: &'a Memory,
    /// The world as it is this frame (effects' data in `scene.effects`).
    pub scene: &'a Scene,
    /// The scene's GPU data: meshes, draws.
    pub scene_gpu: &'a SceneGpu,
    /// This frame's scene uniforms, instance and material tables (in the slot's ring).
    pub uniforms: BufferRange,
    pub instances: BufferRange,
    pub materials: BufferRange,
    /// Scene time in seconds.
    pub time: f64,
    /// What every radiance written into `hdr` is multiplied by this frame
    /// (`effects::tonemap::pre_exposure` of the scene, computed once per frame).
    pub pre_exposure: f64,
    /// The frame's size in pixels.
    pub extent: vk::Extent2D,
    /// The slot being recorded: per-slot data (a host-written buffer, a device counter read back
    /// once the frame finished) is indexed by it. Each view of a frame has a slot of its own, so
    /// it may exceed `frames_in_flight` (`Renderer::record_views`).
    pub slot: usize,
    /// Which view of the frame this is (0 for `record_frame`): state a pass keeps from frame to
    /// frame about what it saw (an adapted exposure, a path chosen from the last frame's counts)
    /// is kept per view. The view's camera is `scene.camera` while it records.
    pub view: usize,
    /// Embedded in a game's frame: the background is transparent black (hadou's result is
    /// composited over the game's colour).
    pub embedded: bool,
    /// `Depth` and `Distance` hold the game's imported depth: load them, do not clear them.
    pub depth_imported: bool,
    /// With motion vectors on (`Renderer::set_motion_vectors`): what the passes that write them
    /// need of the previous frame.
    pub motion: Option<MotionFrame>,
    pub(crate) ring: &'a mut UploadRing,
    /// Texel views made this frame; dropped (retired with the frame) once the sets are written.
    pub(crate) views: &'a mut Vec<TexelView>,
}

impl FrameContext<'_> {
    /// Copies `data` into the slot's ring for this frame; the range knows its element type (its
    /// size is checked against the shader's when bound).
    pub fn upload<T: Pod>(&mut self, data: &[T]) -> GpuResult<BufferRange> {
        Ok(self.ring.push(self.ctx, self.memory, bytemuck::cast_slice(data))?.range().of::<T>())
    }

    /// Copies `parts` into the slot's ring as one range of `T`s: their bytes written, their room
    /// left for the device to write before anything reads it (`RingPart`).
    pub fn upload_parts<T: Pod>(&mut self, parts: &[RingPart]) -> GpuResult<BufferRange> {
        Ok(self.ring.push_parts(self.ctx, self.memory, parts)?.range().of::<T>())
    }

    /// Copies `data` into the slot's ring and binds it as a uniform texel buffer of `texels`.
    pub fn texels<T: Pod>(&mut self, what: &str, data: &[T], texels: Texels) -> GpuResult<Bound> {
        let view = self.ring.push_texels(self.ctx, self.memory, what, bytemuck::cast_slice(data), texels)?;
        let bound = Bound::UniformTexel(view.raw);
        self.views.push(view);
        Ok(bound)
    }
}

/// What a frame with motion vectors on hands the passes that write them (`Aov::Motion`).
#[derive(Clone, Copy, Debug)]
pub struct MotionFrame {
    /// The view's view-projection this frame and in its previous frame, both without the jitter
    /// (`Renderer::set_jitter`): the motion is measured between unjittered positions.
    pub view_proj: glam::DMat4,
    pub prev_view_proj: glam::DMat4,
    /// Where the motion's positions are measured from: the view's camera position. The motion
    /// passes work with world − origin (`MotionUniforms` takes its matrices relative to it, in
    /// f64), so that no f32 product cancels coordinates far from the world's origin.
    pub origin: glam::DVec3,
    /// Per instance of `FrameContext::instances`, in its order, two f32 `mat4`s relative to
    /// `origin` (T(−origin)·M, composed in f64): its model matrix this frame, then in the previous
    /// frame (its current one when it is new).
    pub models: BufferRange,
}

/// What every pass sees while recording.
pub struct PassRecording<'a> {
    /// Records into the frame's command buffer.
    pub rec: &'a Recorder<'a>,
    /// The frame's images (those the pass declared exist).
    pub targets: &'a Targets,
    /// The scene's GPU data.
    pub scene_gpu: &'a SceneGpu,
    /// The world as it is this frame.
    pub scene: &'a Scene,
    /// The pass's descriptor sets of this frame, one per pipeline of `Pass::pipelines`, in order.
    pub sets: Vec<vk::DescriptorSet>,
    /// See `FrameContext::pre_exposure`.
    pub pre_exposure: f64,
    /// See `FrameContext::embedded`.
    pub embedded: bool,
    /// See `FrameContext::depth_imported`.
    pub depth_imported: bool,
    /// The passes recorded after this one this frame and the images each declared.
    pub later: &'a [(&'static str, Vec<Target>)],
    /// The images the host may read back after the frame (`Renderer::set_readbacks`); None: any.
    pub host_reads: Option<&'a [Target]>,
}

impl PassRecording<'_> {
    /// The names of the passes after this one that declared `target` this frame (however they use
    /// it): what an edge pass can leave out of an image depends on who reads it.
    pub fn used_later_by(&self, target: Target) -> impl Iterator<Item = &'static str> + '_ {
        self.later.iter().filter(move |(_, t)| t.contains(&target)).map(|(n, _)| *n)
    }

    /// Whether anything reads `target` after this pass: a later pass of the frame declared it, or
    /// the host may read it back. An image only the host would read (an AOV) need not be written
    /// when it will not.
    pub fn is_read_after(&self, target: Target) -> bool {
        self.used_later_by(target).next().is_some() || self.host_reads.is_none_or(|r| r.contains(&target))
    }

    /// The set of the pass's `i`-th pipeline.
    pub fn set(&self, i: usize) -> vk::DescriptorSet {
        self.sets.get(i).copied().unwrap_or_default()
    }
}

/// A frame image a pass touches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageUse {
    /// The image.
    pub target: Target,
    /// How the pass uses it: stage, access, layout (the runner's barriers).
    pub access: ImageAccess,
    /// Its own size (the light maps), else the frame's.
    pub extent: Option<vk::Extent2D>,
}

impl ImageUse {
    /// `target` used with `access`, at the frame's size.
    pub fn new(target: Target, access: ImageAccess) -> Self {
        ImageUse { target, access, extent: None }
    }
}

/// Every shader file of hadou's passes, by its path under `shaders/` (listed by build.rs): what
/// the renderer's `ShaderCompiler` compiles (`HADOU_SHADER_DIR` points at a tree to use instead).
pub const SHADERS: &[(&str, &str)] = include!(concat!(env!("OUT_DIR"), "/shaders.rs"));

/// The names of the scene passes `scene` needs with hadou's own effects, in frame order.
pub fn plan(scene: &Scene) -> Vec<&'static str> {
    crate::effect::Effects::builtin().plan(scene)
}

/// A pass: what it touches, what it binds, what it records. See docs/ARCHITECTURE.md.
pub trait Pass: Send {
    /// The pass's one name: file, shader, debug label, timestamp scope, test.
    fn name(&self) -> &'static str;
    /// The frame images this pass touches other than through its bindings — render attachments,
    /// copies, clears — and how (called after `prepare`). An image a `Binding` declares is not
    /// repeated here: each image is declared once.
    fn images(&self) -> Vec<ImageUse> {
        Vec::new()
    }
    /// This frame's host work (uploads through the slot's ring) and the resources of descriptor
    /// set 0, in binding order; each pipeline's set holds those its shaders use.
    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>>;
    /// The pipelines the pass records with (a set is written for each, in this order).
    fn pipelines(&self) -> Vec<&Pipeline>;
    /// Records the pass's commands (after the runner's barriers, inside its label and timestamps).
    fn record(&self, pass: &PassRecording);
    /// After the frame recorded in `slot` has finished: adds what the pass counted on the device.
    fn finished(&self, _slot: usize, _stats: &mut FrameStats) {}
}
#[cfg(test)]
mod shader_structs;
