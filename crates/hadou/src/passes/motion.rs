//! motion: a temporal upscaler's inputs, completed after every pass that draws a surface and
//! before the energy wave (shaders/motion.comp). The raster writes its instances' motion itself
//! (from their vertices' previous positions, `raster`); this pass gives the metaballs' pixels
//! theirs (the group's transforms and the field-weighted motion of its balls), every other pixel
//! the motion of a still point (the sky: of the direction), the composition mask (translucent
//! surfaces) and clears the reactive mask, which the energy wave then writes.

use glam::{DMat4, DVec3};

use super::gpu_structs::mat4_f32;
use super::{Binding, FrameContext, Pass, PassRecording};
use crate::effects::metaballs::device::{DeviceBalls, DEVICE_BALL_BYTES};
use crate::gpu::barriers::{cmd_barriers, memory_barrier};
use crate::gpu::pipeline::BufferRange;
use crate::gpu::pipeline::{create_compute_pipeline, Bound, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::targets::Target;

/// Keep in sync with `MotionUniforms` in shaders/common/motion.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MotionUniforms {
    /// This frame's view-projection and the previous frame's, both without the jitter.
    pub view_proj: [[f32; 4]; 4],
    pub prev_view_proj: [[f32; 4]; 4],
    /// x: the scene's instances (the first metaball group's id is x + 1), y: groups, z, w: 0.
    pub counts: [u32; 4],
}

crate::gpu::layout::gpu_layout!(MotionUniforms as "MotionUniforms" { view_proj, prev_view_proj, counts });

impl MotionUniforms {
    /// The frame's (identity matrices without motion inputs: a frame recorded on its own).
    pub fn of(frame: &FrameContext) -> MotionUniforms {
        let (now, before) =
            frame.motion.map_or((DMat4::IDENTITY, DMat4::IDENTITY), |m| (m.view_proj, m.prev_view_proj));
        let groups = frame.scene.metaballs().len() as u32;
        MotionUniforms {
            view_proj: mat4_f32(now),
            prev_view_proj: mat4_f32(before),
            counts: [frame.scene.instances.len() as u32, groups, 0, 0],
        }
    }
}

/// Keep in sync with `MotionGroup` in shaders/motion.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MotionGroup {
    pub to_object: [[f32; 4]; 4],
    pub prev_to_world: [[f32; 4]; 4],
    /// x: first ball, y: balls (0: none known on the host, the game's), z: kernel, w: 0.
    pub info: [u32; 4],
}

crate::gpu::layout::gpu_layout!(MotionGroup as "MotionGroup" { to_object, prev_to_world, info });

/// Keep in sync with `MotionBall` in shaders/motion.comp: a `DeviceBall`'s layout, so the game's
/// records are copied in as they are.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MotionBall {
    /// This frame's object-space centre and R.
    pub centre_radius: [f32; 4],
    /// x: q, yzw: the previous frame's centre.
    pub q_prev: [f32; 4],
}

crate::gpu::layout::gpu_layout!(MotionBall as "MotionBall" { centre_radius, q_prev });

const _: () = assert!(std::mem::size_of::<MotionBall>() as u64 == DEVICE_BALL_BYTES);

/// A metaball group as a frame left it: object → world, and its balls' centres.
type GroupState = (DMat4, Vec<DVec3>);

pub struct MotionPass {
    pipeline: Pipeline,
    extent: vk::Extent2D,
    /// Per view (`FrameContext::view`), its groups in its previous frame.
    previous: Vec<Vec<GroupState>>,
    /// This frame's copies of a game's balls that carry their previous centres (`DeviceBalls`):
    /// the source, and the first ball of theirs in `balls`.
    copies: Vec<(DeviceBalls, u32)>,
    balls: BufferRange,
}

impl MotionPass {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let spirv = compiler.compile("motion.comp", &[])?;
        Ok(MotionPass {
            pipeline: create_compute_pipeline(ctx, "motion", &spirv, 0)?,
            extent: vk::Extent2D::default(),
            previous: Vec::new(),
            copies: Vec::new(),
            balls: BufferRange::whole(vk::Buffer::null()),
        })
    }
}

impl Pass for MotionPass {
    fn name(&self) -> &'static str {
        "motion"
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let scene = frame.scene;
        if self.previous.len() <= frame.view {
            self.previous.resize(frame.view + 1, Vec::new());
        }
        let now: Vec<_> = scene.metaballs().iter().map(|g| g.at(frame.time)).collect();
        let before = &self.previous[frame.view];
        let (mut groups, mut balls) = (Vec::new(), Vec::new());
        self.copies.clear();
        for (i, (group, params)) in scene.metaballs().iter().zip(&now).enumerate() {
            // The previous frame's state of this group, when it had as many balls.
            let prev = before.get(i).filter(|(_, c)| c.len() == params.balls.len());
            let first = balls.len() as u32;
            // The game's balls (`DeviceBalls`) are copied in on the device when their records
            // carry their previous centres; else their group moves by its transforms only.
            if let Some(source) = group.device.filter(|d| d.previous_centres) {
                self.copies.push((source, first));
                balls.resize(balls.len() + source.count as usize, MotionBall::default());
            } else if group.device.is_none() {
                for (k, b) in params.balls.iter().enumerate() {
                    let was = prev.map_or(b.centre, |(_, c)| c[k]);
                    let f = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
                    let [cx, cy, cz] = f(b.centre);
                    let [px, py, pz] = f(was);
                    balls.push(MotionBall {
                        centre_radius: [cx, cy, cz, b.radius as f32],
                        q_prev: [b.q as f32, px, py, pz],
                    });
                }
            }
            groups.push(MotionGroup {
                to_object: mat4_f32(params.transform.inverse),
                prev_to_world: mat4_f32(prev.map_or(params.transform.matrix, |(m, _)| *m)),
                info: [first, balls.len() as u32 - first, params.kernel.gpu_id(), 0],
            });
        }
        self.previous[frame.view] =
            now.iter().map(|p| (p.transform.matrix, p.balls.iter().map(|b| b.centre).collect())).collect();
        // A storage buffer holds at least one element.
        if groups.is_empty() {
            groups.push(MotionGroup::default());
        }
        if balls.is_empty() {
            balls.push(MotionBall::default());
        }
        self.extent = frame.extent;
        self.balls = frame.upload(&balls)?;
        let uniforms = MotionUniforms::of(frame);
        Ok(vec![
            Binding::Bound(Bound::Uniform(frame.uniforms)),
            Binding::Bound(Bound::Storage(frame.materials)),
            Binding::read(Target::Distance),
            Binding::read(Target::Ids),
            Binding::read_write(Target::Motion),
            Binding::write(Target::Reactive),
            Binding::write(Target::Composition),
            Binding::Bound(Bound::Uniform(frame.upload(&[uniforms])?)),
            Binding::Bound(Bound::Storage(frame.upload(&groups)?)),
            Binding::Bound(Bound::Storage(self.balls)),
        ])
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        vec![&self.pipeline]
    }

    fn record(&self, pass: &PassRecording) {
        if !self.copies.is_empty() {
            // The game's records into their places (after the game's writes, before the reads),
            // as the metaballs pass copies them (`metaballs_device`).
            let (device, cmd) = (&pass.rec.ctx.device, pass.rec.cmd);
            let all = vk::PipelineStageFlags2::ALL_COMMANDS;
            let copy = vk::PipelineStageFlags2::COPY;
            let written =
                memory_barrier(all, vk::AccessFlags2::MEMORY_WRITE, copy, vk::AccessFlags2::TRANSFER_READ);
            cmd_barriers(device, cmd, &[], &[written]);
            for (source, first) in &self.copies {
                let at = self.balls.offset + u64::from(*first) * DEVICE_BALL_BYTES;
                let size = u64::from(source.count) * DEVICE_BALL_BYTES;
                pass.rec.copy_buffer(source.buffer, source.offset, self.balls.buffer, at, size);
            }
            let copied = memory_barrier(
                copy,
                vk::AccessFlags2::TRANSFER_WRITE,
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_READ,
            );
            let read = memory_barrier(copy, vk::AccessFlags2::NONE, all, vk::AccessFlags2::NONE);
            cmd_barriers(device, cmd, &[], &[copied, read]);
        }
        pass.rec.bind_pipeline(&self.pipeline, pass.set(0));
        pass.rec.dispatch_2d(self.extent.width, self.extent.height, (8, 8));
    }
}
