//! `Renderer::record_frame`: one frame recorded into the caller's command buffer — the game's
//! depth imported, the scene's passes, the result composited into the game's colour.

use super::composite::Composite;
use super::depth_import::DepthImport;
use super::inputs::{ExternalColor, ExternalDepth, FrameInputs, RecordedFrame};
use super::Renderer;
use crate::effects::translucency::LIGHT_MAP_MIN;
use crate::frame::{record_passes, record_scope, PassRecording, Scope, Timestamps};
use crate::gpu::barriers::{cmd_barriers, image_barrier, memory_barrier, ImageAccess};
use crate::gpu::recorder::Recorder;
use crate::gpu::{vk, GpuResult};
use crate::targets::{Target, Targets};
use crate::Error;

/// How the game's images are found and left: any earlier command may have written them, and any
/// later command may use them (the game needs no barriers of its own around hadou's commands).
fn game_access(layout: vk::ImageLayout) -> ImageAccess {
    ImageAccess {
        stage: vk::PipelineStageFlags2::ALL_COMMANDS,
        access: vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE,
        layout,
    }
}

/// hadou's HDR image read by the composite's fragment shader.
const FRAGMENT_STORAGE_READ: ImageAccess = ImageAccess {
    stage: vk::PipelineStageFlags2::FRAGMENT_SHADER,
    access: vk::AccessFlags2::SHADER_STORAGE_READ,
    layout: vk::ImageLayout::GENERAL,
};

impl Renderer {
    /// Records one frame into `cmd` (recording, outside a render pass, on the context's queue
    /// family). Never submits or waits, except when the frame size changed since the last frame:
    /// then the size-dependent images are rebuilt after `vkDeviceWaitIdle`. A 0 × 0 extent records
    /// nothing and returns `recorded: false` (a minimized window is not an error).
    /// Before calling it, the previous frame hadou recorded must have finished (module docs).
    pub fn record_frame(
        &mut self,
        cmd: vk::CommandBuffer,
        inputs: &FrameInputs,
    ) -> Result<RecordedFrame, Error> {
        let extent = inputs.extent;
        if extent.width == 0 || extent.height == 0 {
            return Ok(RecordedFrame { recorded: false, frame: self.frame_index, timed: false });
        }
        let max = self.ctx.limits.max_image_dimension2_d;
        if extent.width > max || extent.height > max {
            return Err(Error::InvalidRequest(format!(
                "frame size {}x{} outside 1..={max} (the device's maxImageDimension2D)",
                extent.width, extent.height
            )));
        }
        if self.loaded.is_none() {
            return Err(Error::InvalidRequest("no scene loaded (call load_scene first)".into()));
        }
        if let Some(depth) = &inputs.depth {
            check_depth(depth)?;
        }
        self.ensure_targets(extent)?;
        let import_set = self.ensure_external(inputs)?;
        let (Some(loaded), Some(targets)) = (&mut self.loaded, &mut self.targets) else {
            return Err(Error::InvalidRequest("no scene loaded".into()));
        };
        // Host writes of this frame's parameters (the previous frame has finished).
        if loaded.instances_dirty {
            loaded.gpu.upload_instances(&loaded.scene)?;
            loaded.instances_dirty = false;
        }
        loaded.gpu.update_uniforms(&loaded.scene, extent.width, extent.height)?;
        for pass in loaded.passes.iter_mut() {
            pass.prepare(&loaded.scene, inputs.time, extent)?;
            pass.prepare_device(&self.ctx, &self.memory)?;
        }
        let frame = self.frame_index;
        self.frame_index += 1;
        let timed = self.timings.begin(&self.ctx, frame)?;
        let ctx = &self.ctx;
        let mut timestamps: Timestamps = self.timings.pool();
        targets.discard_all();
        let mut scopes: Vec<Scope> = Vec::new();
        if let (Some(depth), Some(import), Some(set)) = (&inputs.depth, &self.external.depth, import_set) {
            let rec = Recorder { ctx, cmd };
            let camera = &loaded.scene.camera;
            scopes.push(record_import(&rec, &mut timestamps, targets, import, set, depth, camera));
        }
        // The game's colour is the output: hadou's own tonemapped image is not needed.
        let skip: &[&'static str] = if inputs.color.is_some() { &["tonemap"] } else { &[] };
        let recording = PassRecording {
            ctx,
            cmd,
            passes: &loaded.passes,
            targets,
            scene_gpu: &loaded.gpu,
            scene: &loaded.scene,
            time: inputs.time,
            embedded: inputs.depth.is_some() || inputs.color.is_some(),
            depth_imported: inputs.depth.is_some(),
            skip,
        };
        record_passes(recording, &mut timestamps, &mut scopes);
        if let (Some(color), Some(composite)) = (&inputs.color, &self.external.composite) {
            let rec = Recorder { ctx, cmd };
            let exposure = loaded.scene.render.exposure;
            scopes.push(record_composite(&rec, &mut timestamps, targets, composite, color, exposure));
        }
        self.timings.push_scopes(&scopes);
        Ok(RecordedFrame { recorded: true, frame, timed })
    }

    /// (Re)creates the frame's images when the size changed, and points every pass at them.
    pub(super) fn ensure_targets(&mut self, extent: vk::Extent2D) -> GpuResult<()> {
        if self.targets.as_ref().is_some_and(|t| t.extent == extent) {
            return Ok(());
        }
        self.drop_targets();
        let wanted = self.loaded.as_ref().map(|l| crate::frame::targets_used(&l.passes)).unwrap_or_default();
        let light_map = self
            .loaded
            .as_ref()
            .map_or(LIGHT_MAP_MIN, |l| crate::effects::translucency::light_map_size(&l.scene));
        let targets = Targets::new(&self.ctx, &self.memory, extent, &wanted, light_map)?;
        self.pool.reset(&self.ctx)?;
        if let Some(loaded) = &mut self.loaded {
            for pass in &mut loaded.passes {
                if let Err(e) = pass.bind(&self.ctx, &self.pool, &loaded.gpu, &targets) {
                    targets.destroy(&self.ctx, &self.memory);
                    return Err(e);
                }
            }
        }
        self.targets = Some(targets);
        Ok(())
    }

    /// Builds the depth import and composite the first time a game hands such an image, and their
    /// size- and view-dependent parts; returns the import's descriptor set for this depth view.
    fn ensure_external(&mut self, inputs: &FrameInputs) -> GpuResult<Option<vk::DescriptorSet>> {
        let Some(targets) = &self.targets else { return Ok(None) };
        if let Some(color) = &inputs.color {
            if self.external.composite.is_none() {
                self.external.composite = Some(Composite::new(&self.ctx)?);
            }
            if let Some(c) = &mut self.external.composite {
                c.prepare(&self.ctx, &mut self.compiler, color.format, targets.image(Target::Hdr).view)?;
            }
        }
        let Some(depth) = &inputs.depth else { return Ok(None) };
        if self.external.depth.is_none() {
            self.external.depth = Some(DepthImport::new(&self.ctx, &mut self.compiler)?);
        }
        let Some(import) = &mut self.external.depth else { return Ok(None) };
        import.ensure_size(&self.ctx, &self.memory, inputs.extent)?;
        import.set_for(&self.ctx, depth, targets.image(Target::Distance).view).map(Some)
    }

    /// Forgets the game's depth views hadou has seen: call it after destroying a depth image view
    /// handed to `record_frame` (a new view could get the same handle). Waits for the device.
    pub fn forget_external_views(&mut self) -> GpuResult<()> {
        if let Some(d) = &mut self.external.depth {
            self.ctx.wait_idle()?;
            d.forget_views(&self.ctx)?;
        }
        Ok(())
    }
}

fn check_depth(depth: &ExternalDepth) -> Result<(), Error> {
    if let Err(why) = depth.convention.check() {
        return Err(Error::InvalidRequest(format!("external depth: {why}")));
    }
    if !crate::gpu::memory::is_depth_format(depth.format) {
        return Err(Error::InvalidRequest(format!(
            "external depth: format {:?} is not a depth format hadou samples (D32_SFLOAT, D16_UNORM, \
             D24_UNORM_S8_UINT)",
            depth.format
        )));
    }
    Ok(())
}

/// The game's depth → `Distance` (storage write) and, through a staging buffer, `Depth`.
fn record_import(
    rec: &Recorder,
    timestamps: &mut Timestamps,
    targets: &mut Targets,
    import: &DepthImport,
    set: vk::DescriptorSet,
    depth: &ExternalDepth,
    camera: &crate::scene::camera::Camera,
) -> Scope {
    let (ctx, cmd) = (rec.ctx, rec.cmd);
    let sampled = ImageAccess::COMPUTE_SAMPLED;
    let mut barriers: Vec<_> =
        image_barrier(depth.image, depth.format, game_access(depth.layout), sampled).into_iter().collect();
    barriers.extend(targets.transition(Target::Distance, ImageAccess::COMPUTE_WRITE));
    let depth_barrier = targets.transition(Target::Depth, ImageAccess::TRANSFER_DST);
    let release = image_barrier(depth.image, depth.format, sampled, game_access(depth.final_layout));
    let extent = targets.extent;
    record_scope(ctx, cmd, timestamps, "depth_import", &barriers, || {
        // The previous frame's copy read the staging buffer: write it only after.
        let war = memory_barrier(
            vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::NONE,
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
        );
        cmd_barriers(&ctx.device, cmd, &[], &[war]);
        import.record(rec, set, depth, camera, extent);
        let to_copy = memory_barrier(
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
            vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::TRANSFER_READ,
        );
        let mut images: Vec<_> = depth_barrier.into_iter().collect();
        images.extend(release);
        cmd_barriers(&ctx.device, cmd, &images, &[to_copy]);
        if let Some(staging) = &import.staging {
            rec.copy_buffer_to_depth(staging, targets.image(Target::Depth));
        }
    })
}

/// hadou's HDR over the game's colour target, which is left in its `final_layout`.
fn record_composite(
    rec: &Recorder,
    timestamps: &mut Timestamps,
    targets: &mut Targets,
    composite: &Composite,
    color: &ExternalColor,
    exposure: f64,
) -> Scope {
    let attachment = ImageAccess::COLOR_ATTACHMENT;
    let mut barriers: Vec<_> =
        image_barrier(color.image, color.format, game_access(color.layout), attachment).into_iter().collect();
    barriers.extend(targets.transition(Target::Hdr, FRAGMENT_STORAGE_READ));
    let release = image_barrier(color.image, color.format, attachment, game_access(color.final_layout));
    let extent = targets.extent;
    record_scope(rec.ctx, rec.cmd, timestamps, "composite", &barriers, || {
        composite.record(rec, color, extent, exposure);
        cmd_barriers(&rec.ctx.device, rec.cmd, &release.into_iter().collect::<Vec<_>>(), &[]);
    })
}
