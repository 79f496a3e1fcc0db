//! `Renderer::record_frame` and `record_views`: one frame recorded into the caller's command
//! buffer, in the frame's slot — the world's tables once, then per view the game's depth
//! imported, the scene's passes, the output (hadou's tonemapped image, or a composite into the
//! game's colour).

use super::inputs::{DepthConvention, ExternalImage, FrameInputs, RecordedFrame, UpscalerTargets};
use super::motion::jittered;
use super::slots::Slot;
use super::views::{ResolvedCamera, View, ViewCamera, MAX_VIEWS};
use super::{slot_index, view_targets, Renderer};
use crate::frame::{record_passes, SlotFrame, Timestamps};
use crate::gpu::barriers::{cmd_barriers, ImageAccess};
use crate::gpu::pipeline::BufferRange;
use crate::gpu::vk;
use crate::passes::composite::CompositePass;
use crate::passes::depth_import::DepthImportPass;
use crate::passes::depth_out::DepthOutPass;
use crate::passes::gpu_structs::FrameUniforms;
use crate::passes::tonemap::TonemapPass;
use crate::passes::upscaler_out::{mask_qualifier, motion_qualifier, UpscalerOutPass};
use crate::passes::Pass;
use crate::scene::camera::Camera;
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

impl Renderer {
    pub(super) fn check_inputs(&self, inputs: &FrameInputs) -> Result<(), Error> {
        let extent = inputs.extent;
        let max = self.ctx.limits.max_image_dimension2_d;
        if extent.width > max || extent.height > max {
            return Err(Error::FrameSize { width: extent.width, height: extent.height, max });
        }
        if self.loaded.is_none() {
            return Err(Error::NoScene);
        }
        if let Some(depth) = &inputs.depth {
            self.depth_convention(depth, aspect(extent))?;
            if !crate::gpu::memory::is_depth_format(depth.format) {
                return Err(Error::DepthFormat(depth.format));
            }
        }
        Ok(())
    }

    /// Builds the depth import and the output pass the first time a frame needs them.
    pub(super) fn ensure_edges(&mut self, inputs: &FrameInputs) -> Result<(), Error> {
        let convention = self.frame_convention(inputs)?;
        let (ctx, compiler) = (&self.ctx, &mut self.compiler);
        if inputs.depth.is_some() && self.edges.depth_import.is_none() {
            self.edges.depth_import = Some(DepthImportPass::new(ctx, compiler)?);
        }
        if let Some(depth) = inputs.depth.filter(|d| d.write) {
            let out = self.edges.depth_out.get_or_insert_with(DepthOutPass::new);
            out.use_depth(ctx, compiler, depth.format, convention.unwrap_or(depth.convention))?;
        }
        match &inputs.color {
            Some(color) => self.edges.composite.get_or_insert_with(CompositePass::new).use_format(
                ctx,
                compiler,
                color.format,
            )?,
            None if self.edges.tonemap.is_none() => {
                self.edges.tonemap = Some(TonemapPass::new(ctx, compiler)?)
            }
            None => {}
        }
        Ok(())
    }

    /// The frame's depth convention, resolved (`depth_convention`); None without a game depth.
    fn frame_convention(&self, inputs: &FrameInputs) -> Result<Option<DepthConvention>, Error> {
        inputs.depth.as_ref().map(|d| self.depth_convention(d, aspect(inputs.extent))).transpose()
    }

    /// Records one frame into `cmd` (recording, outside a render pass, on the context's queue
    /// family). Never submits or waits. A 0 × 0 extent records nothing and returns
    /// `recorded: false` (a minimized window is not an error). The frame contract (module docs):
    /// every frame up to `frame − frames_in_flight` has finished.
    pub fn record_frame(
        &mut self,
        cmd: vk::CommandBuffer,
        inputs: &FrameInputs,
    ) -> Result<RecordedFrame, Error> {
        let view = View {
            camera: ViewCamera::Renderer,
            extent: inputs.extent,
            depth: inputs.depth,
            color: inputs.color,
            upscaler: None,
        };
        self.record_views(cmd, inputs.time, &[view])
    }

    /// Records one frame of several views of the world into `cmd` (split screen, a headset's two
    /// eyes): view by view, in order, each with its own camera, size and images, as
    /// `record_frame` would record it alone — the same pixels — while the world's tables, meshes
    /// and bakes are uploaded once. It is one frame of the frame contract (`frames_in_flight`).
    /// Per view: its own images (`record_view_aov_readback` reads them), its own temporal state
    /// (history images, the adapted exposure). A 0 × 0 view is skipped; with none left nothing is
    /// recorded (`recorded: false`). Every view is checked before anything is recorded; at most
    /// `MAX_VIEWS`.
    pub fn record_views(
        &mut self,
        cmd: vk::CommandBuffer,
        time: f64,
        views: &[View],
    ) -> Result<RecordedFrame, Error> {
        if views.is_empty() || views.len() > MAX_VIEWS {
            return Err(Error::InvalidUpdate {
                what: format!("{} views", views.len()),
                expected: format!("1..={MAX_VIEWS} views a frame"),
            });
        }
        let live: Vec<usize> =
            (0..views.len()).filter(|&v| views[v].extent.width > 0 && views[v].extent.height > 0).collect();
        if live.is_empty() {
            return Ok(RecordedFrame { recorded: false, frame: self.next_frame, timed: false });
        }
        let resolved = views.iter().map(|v| self.resolve_camera(&v.camera)).collect::<Result<Vec<_>, _>>()?;
        // Each view's camera as given (what motion is measured with) and as it records (jittered).
        let own = self.loaded.as_ref().map(|l| (l.scene.camera, l.game_projection)).ok_or(Error::NoScene)?;
        let cameras: Vec<(Camera, ResolvedCamera)> = (resolved.into_iter().zip(views))
            .map(|(c, v)| {
                let (camera, projection) = c.unwrap_or(own);
                let shifted = jittered(camera, self.jitter, v.extent);
                (camera, if shifted == camera { c } else { Some((shifted, projection)) })
            })
            .collect();
        for &v in &live {
            let inputs = views[v].inputs(time);
            self.with_camera(cameras[v].1, |r| {
                r.check_inputs(&inputs)?;
                r.ensure_edges(&inputs)?;
                r.ensure_upscaler_out(&views[v])
            })?;
        }
        // A run-time bake that finished goes in before the frame's passes are prepared.
        self.poll_bakes(false)?;
        // The frame budget's levels for this frame.
        self.apply_budget()?;
        // `[[mesh]] wobble`: the meshes' shapes at this frame's time.
        self.apply_wobble(time);
        let (frame, slot) = self.begin_frame(&live)?;
        let result = self.record_world(cmd, slot, live[0]).and_then(|world| {
            live.iter().try_for_each(|&v| {
                let inputs = views[v].inputs(time);
                self.with_camera(cameras[v].1, |r| {
                    // The view's formats and depth convention (built above: nothing is built here).
                    r.ensure_edges(&inputs)?;
                    r.ensure_upscaler_out(&views[v])?;
                    r.record_view(cmd, (&inputs, views[v].upscaler), &world, (slot, v), cameras[v].0)
                })
            })
        });
        if result.is_err() {
            self.abandon_frame();
        }
        result.map(|()| RecordedFrame { recorded: true, frame, timed: true })
    }

    /// Numbers the next frame and starts its slot, a slot per view in `views`: by the frame
    /// contract the frame the slot held last has finished, so it is reported and what was retired
    /// with it is freed.
    fn begin_frame(&mut self, views: &[usize]) -> Result<(u64, usize), Error> {
        let frame = self.next_frame;
        let in_flight = self.slots.len();
        if let Some(done) = frame.checked_sub(in_flight as u64) {
            self.frame_finished(done)?;
        }
        self.ctx.begin_frame(frame);
        let slot = (frame % in_flight as u64) as usize;
        let most = views.iter().copied().max().unwrap_or(0);
        while self.slots[slot].len() <= most {
            let index = slot_index(slot, self.slots[slot].len(), in_flight);
            self.slots[slot].push(Slot::new(&self.ctx, index)?);
        }
        for &v in views {
            self.slots[slot][v].begin(&self.ctx, frame)?;
        }
        self.next_frame += 1;
        self.current = Some(slot);
        self.current_views = views.to_vec();
        self.current_readbacks.clone_from(&self.readbacks);
        Ok((frame, slot))
    }

    /// Records `pass` alone as a frame of its own (no images; the loaded scene, or an empty one,
    /// is what it sees): how `energy_probe` runs on the same runner as every pass.
    pub(crate) fn record_one_off(
        &mut self,
        cmd: vk::CommandBuffer,
        pass: &mut dyn Pass,
    ) -> Result<u64, Error> {
        let (frame, slot) = self.begin_frame(&[0])?;
        let empty;
        let (scene, gpu) = match &self.loaded {
            Some(l) => (&l.scene, Some(&l.gpu)),
            None => {
                empty = crate::scene::parse_scene(
                    "[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\n",
                    "probe".as_ref(),
                )?;
                (&empty, None)
            }
        };
        let gpu_owned;
        let gpu = match gpu {
            Some(g) => g,
            None => {
                gpu_owned = crate::scene_gpu::SceneGpu::new(&self.ctx, &self.memory, scene)?;
                &gpu_owned
            }
        };
        let s = &mut self.slots[slot][0];
        let none = BufferRange::whole(vk::Buffer::null());
        let mut targets = Targets::new(vk::Extent2D { width: 1, height: 1 });
        let mut f = SlotFrame {
            ctx: &self.ctx,
            memory: &self.memory,
            cmd,
            slot,
            view: 0,
            pool: &s.pool,
            ring: &mut s.ring,
            targets: &mut targets,
            scene,
            scene_gpu: gpu,
            uniforms: none,
            instances: none,
            materials: none,
            time: 0.0,
            pre_exposure: crate::effects::tonemap::pre_exposure_with(scene, &gpu.mesh_bounds()),
            embedded: false,
            depth_imported: false,
            host_reads: None,
            motion: None,
        };
        let mut timestamps: Timestamps = Some(&mut s.timestamps);
        let recorded = record_passes(&mut f, &mut [pass], &mut timestamps, &mut s.scopes);
        if let Err(e) = recorded {
            self.abandon_frame();
            return Err(e);
        }
        s.record_timestamp_copy(&self.ctx, cmd);
        Ok(frame)
    }

    /// What every view of the frame shares, recorded once into the slot of its first recorded view
    /// (`view`): the deformed meshes' vertices, the materials' texture uploads, the instance and
    /// material tables.
    fn record_world(
        &mut self,
        cmd: vk::CommandBuffer,
        slot: usize,
        view: usize,
    ) -> Result<WorldFrame, Error> {
        let (ctx, memory) = (&self.ctx, &self.memory);
        let Some(loaded) = &mut self.loaded else { return Err(Error::NoScene) };
        let s = &mut self.slots[slot][view];
        // Deformed meshes: this slot's vertex buffers (its previous frame has finished).
        let motion = loaded.scene.render.motion_vectors;
        loaded.gpu.begin_slot(ctx, memory, &loaded.scene, slot, motion)?;
        // The materials' textures, copied by the first frame after the scene was loaded.
        loaded.gpu.textures.record_uploads(&crate::gpu::recorder::Recorder { ctx, cmd });
        // Once per frame: what every radiance written into the HDR target is multiplied by. A
        // light, the ambient, the background or the exposure changed since the material table
        // was built changes it, and the table's emission with it.
        let bounds = loaded.gpu.mesh_bounds();
        let pre_exposure = crate::effects::tonemap::pre_exposure_with(&loaded.scene, &bounds);
        let changed = std::mem::take(&mut loaded.tables_dirty);
        if changed {
            loaded.gpu.refresh_instances(&loaded.scene);
        }
        loaded.gpu.refresh_materials(&loaded.scene, pre_exposure, changed);
        let motion_models = super::motion::model_pairs(loaded);
        let instances: BufferRange = s
            .ring
            .push(ctx, memory, bytemuck::cast_slice(loaded.gpu.instance_table()))?
            .range()
            .of::<crate::passes::gpu_structs::InstanceData>();
        let materials: BufferRange = s
            .ring
            .push(ctx, memory, bytemuck::cast_slice(loaded.gpu.material_table()))?
            .range()
            .of::<crate::passes::gpu_structs::MaterialData>();
        Ok(WorldFrame { pre_exposure, instances, materials, motion_models })
    }

    /// Records view `view` of the frame in frame slot `slot`: its camera is the scene's while it
    /// records (jittered); `camera` is the view's camera without the jitter (what motion is from).
    fn record_view(
        &mut self,
        cmd: vk::CommandBuffer,
        (inputs, upscaler): (&FrameInputs, Option<UpscalerTargets>),
        world: &WorldFrame,
        (slot, view): (usize, usize),
        camera: Camera,
    ) -> Result<(), Error> {
        let extent = inputs.extent;
        // With motion vectors on: measured against the view's previous frame (`camera`, unjittered).
        // The instances' model matrices relative to this view's camera, in its slot's ring.
        let models = match &world.motion_models {
            Some(pairs) => {
                let table = super::motion::relative_models(pairs, camera.position);
                let ring = &mut self.slots[slot][view].ring;
                Some(
                    ring.push(&self.ctx, &self.memory, bytemuck::cast_slice(&table))?
                        .range()
                        .of::<[[f32; 4]; 4]>(),
                )
            }
            None => None,
        };
        let motion = models.and_then(|m| self.motion_frame(view, camera, extent, m));
        let convention = self.frame_convention(inputs)?;
        let index = slot_index(slot, view, self.slots.len());
        let (ctx, memory) = (&self.ctx, &self.memory);
        let Some(loaded) = &self.loaded else { return Err(Error::NoScene) };
        let s = &mut self.slots[slot][view];
        let uniforms = FrameUniforms::new(&loaded.scene, extent.width, extent.height, world.pre_exposure);
        let uniforms = s.ring.push(ctx, memory, bytemuck::bytes_of(&uniforms))?.range().of::<FrameUniforms>();

        let targets = view_targets(&mut self.targets, view, extent);
        targets.advance_history();
        targets.discard_all();
        if let Some(depth) = &inputs.depth {
            let last = game_access(depth.layout);
            targets.import(Target::GameDepth, depth.image, depth.view, depth.format, last);
            if let (Some(p), Some(convention)) = (&mut self.edges.depth_import, convention) {
                p.set_convention(convention);
            }
        }
        if let Some(color) = &inputs.color {
            targets.import(
                Target::GameColor,
                color.image,
                color.view,
                color.format,
                game_access(color.layout),
            );
        }
        for (target, image) in upscaler_images(upscaler) {
            targets.import(target, image.image, image.view, image.format, game_access(image.layout));
        }
        // This view's passes: the game's depth in, the scene's, the output.
        let mut passes: Vec<&mut dyn Pass> = Vec::new();
        if let (Some(_), Some(p)) = (&inputs.depth, &mut self.edges.depth_import) {
            passes.push(p);
        }
        let Some(loaded) = &mut self.loaded else { return Err(Error::NoScene) };
        passes.extend(loaded.passes.running.iter_mut().map(|a| a.pass.as_mut() as &mut dyn Pass));
        match (&inputs.color, &mut self.edges.composite, &mut self.edges.tonemap) {
            (Some(_), Some(c), _) => passes.push(c),
            (None, _, Some(t)) => passes.push(t),
            _ => {}
        }
        if let (Some(_), Some(out)) = (inputs.depth.filter(|d| d.write), &mut self.edges.depth_out) {
            passes.push(out);
        }
        if let (Some(_), Some(out)) = (upscaler, &mut self.edges.upscaler_out) {
            passes.push(out);
        }
        let mut f = SlotFrame {
            ctx,
            memory,
            cmd,
            slot: index,
            view,
            pool: &s.pool,
            ring: &mut s.ring,
            targets,
            scene: &loaded.scene,
            scene_gpu: &loaded.gpu,
            uniforms,
            instances: world.instances,
            materials: world.materials,
            time: inputs.time,
            pre_exposure: world.pre_exposure,
            embedded: inputs.depth.is_some() || inputs.color.is_some(),
            depth_imported: inputs.depth.is_some(),
            host_reads: self.readbacks.as_deref(),
            motion,
        };
        // The slot's queries were reset on the host when it began.
        let mut timestamps: Timestamps = Some(&mut s.timestamps);
        record_passes(&mut f, &mut passes, &mut timestamps, &mut s.scopes)?;
        // The game's images go back to the layouts it asked for.
        let mut release = Vec::new();
        if let Some(depth) = &inputs.depth {
            release.extend(targets.transition(Target::GameDepth, game_access(depth.final_layout)));
        }
        if let Some(color) = &inputs.color {
            release.extend(targets.transition(Target::GameColor, game_access(color.final_layout)));
        }
        for (target, image) in upscaler_images(upscaler) {
            release.extend(targets.transition(target, game_access(image.final_layout)));
        }
        cmd_barriers(&ctx.device, cmd, &release, &[]);
        targets.drop_imports();
        s.record_timestamp_copy(ctx, cmd);
        log::trace!("view {view} recorded in slot {index}");
        Ok(())
    }
}

/// The game's images of `upscaler` and the targets they are imported as.
fn upscaler_images(upscaler: Option<UpscalerTargets>) -> Vec<(Target, ExternalImage)> {
    let Some(u) = upscaler else { return Vec::new() };
    let mut images = vec![(Target::GameMotion, u.motion)];
    images.extend(u.reactive.map(|r| (Target::GameReactive, r)));
    images.extend(u.composition.map(|c| (Target::GameComposition, c)));
    images
}

impl Renderer {
    /// Checks `view`'s upscaler targets and builds the pass that writes them for their formats.
    fn ensure_upscaler_out(&mut self, view: &View) -> Result<(), Error> {
        let Some(u) = view.upscaler else { return Ok(()) };
        let refused = |what: String, expected: &str| Error::InvalidUpdate { what, expected: expected.into() };
        if !self.loaded.as_ref().is_some_and(|l| l.scene.render.motion_vectors) {
            return Err(refused(
                "View.upscaler".into(),
                "motion vectors on (Renderer::set_motion_vectors(true))",
            ));
        }
        if motion_qualifier(u.motion.format).is_none() {
            let what = format!("View.upscaler.motion.format {:?}", u.motion.format);
            return Err(refused(what, "R16G16_SFLOAT or R32G32_SFLOAT (a storage image)"));
        }
        for (field, image) in [("reactive", u.reactive), ("composition", u.composition)] {
            if let Some(f) = image.map(|i| i.format).filter(|f| mask_qualifier(*f).is_none()) {
                let what = format!("View.upscaler.{field}.format {f:?}");
                return Err(refused(what, "R8_UNORM, R16_SFLOAT or R32_SFLOAT (a storage image)"));
            }
        }
        let formats = (u.motion.format, u.reactive.map(|i| i.format), u.composition.map(|i| i.format));
        let (ctx, compiler) = (&self.ctx, &mut self.compiler);
        self.edges
            .upscaler_out
            .get_or_insert_with(UpscalerOutPass::new)
            .use_formats(ctx, compiler, formats)?;
        Ok(())
    }
}

/// What the views of one frame share (`record_world`).
struct WorldFrame {
    /// `effects::tonemap::pre_exposure` of the frame (no view changes it).
    pre_exposure: f64,
    /// The instance and material tables, in the first view's slot ring.
    instances: BufferRange,
    materials: BufferRange,
    /// With motion vectors on: the instances' model matrices, this frame's and the previous
    /// frame's, in f64 (each view uploads them relative to its camera: `MotionFrame::models`).
    motion_models: Option<Vec<(glam::DMat4, glam::DMat4)>>,
}

/// Width over height of a frame (1 for an empty one: nothing is recorded for it).
fn aspect(extent: vk::Extent2D) -> f64 {
    if extent.height == 0 {
        1.0
    } else {
        f64::from(extent.width) / f64::from(extent.height)
    }
}
