//! The metaballs' part of a temporal upscaler's motion (with motion vectors on,
//! `Renderer::set_motion_vectors`): the casts (shaders/metaballs.comp built with MB_MOTION,
//! shaders/common/metaballs_motion.glsl) give each pixel whose nearest surface is a metaball the
//! motion of its point where its hit is final, walking only its tile's run of that group (the
//! balls that can reach the pixel). In the casts' own dispatches: on lavapipe a dispatch of its
//! own over the active tiles cost ~1.3 ms at 256² before doing anything (docs/PERFORMANCE.md).
//! This keeps what the motion needs of the previous frame: per view, each group's transform and
//! its balls' centres. A game's balls (`DeviceBalls`) carry their previous
//! centres in their records (`previous_centres`): shaders/metaballs_device.comp copies them into
//! the table of previous centres as it completes the balls; without them the group moves by its
//! transforms only. The upscaler's own `motion` pass leaves these pixels as they are.

use glam::{DMat4, DVec3};

use super::gpu_structs::mat4_f32;
use super::motion::MotionUniforms;
use super::{Binding, FrameContext};
use crate::effects::metaballs::MetaballGroupParams;
use crate::effects::metaballs_f32::table_anchor;
use crate::gpu::pipeline::Bound;
use crate::gpu::ring::RingPart;
use crate::gpu::texel_buffer::Texels;
use crate::gpu::GpuResult;
use crate::targets::Target;

/// Keep in sync with `motion_group_texels` in shaders/common/metaballs_motion.glsl (5 texels of 4 u32).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MotionGroup {
    /// The previous frame's object → world, from the ball table's space (centres relative to the
    /// group's anchor, `metaballs_f32::anchor`) to world coordinates relative to this frame's
    /// camera: T(−camera)·M·T(anchor) in f64.
    pub prev_to_world: [[f32; 4]; 4],
    /// x: 1 when the balls' previous centres are known; y, z, w: 0.
    pub info: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<MotionGroup>() == 80);

/// The first binding of the motion's own (the bindings before it are the casts').
pub const FIRST_BINDING: usize = 25;

/// A group as a frame left it: object → world, and its balls' centres.
type GroupState = (DMat4, Vec<DVec3>);

#[derive(Default)]
pub struct MetaballsMotion {
    /// Per view (`FrameContext::view`), its groups in its previous frame.
    previous: Vec<Vec<GroupState>>,
}

impl MetaballsMotion {
    /// This frame's bindings from [`FIRST_BINDING`] on: the `motion` image, the frame's motion
    /// uniforms, each ball's previous centre (in the ball table's order: a group drawn from the
    /// game's buffer takes its records' count, written on the device when they carry them) and
    /// each group's previous transform. `groups` are the world's groups at this frame's time.
    pub fn prepare(
        &mut self,
        frame: &mut FrameContext,
        groups: &[MetaballGroupParams],
    ) -> GpuResult<Vec<Binding>> {
        if self.previous.len() <= frame.view {
            self.previous.resize(frame.view + 1, Vec::new());
        }
        let before = &self.previous[frame.view];
        // Positions relative to the camera, as the motion's matrices take them (MotionFrame).
        let shift = DMat4::from_translation(-frame.motion.map_or(frame.scene.camera.position, |m| m.origin));
        // The host's balls' previous centres, and per group where its part of the table is:
        // written from `centres`, or the room a game's group leaves for the device to fill.
        let mut centres: Vec<[f32; 4]> = Vec::new();
        let mut pieces: Vec<Result<std::ops::Range<usize>, usize>> = Vec::with_capacity(groups.len());
        let mut motion_groups = Vec::with_capacity(groups.len());
        for (i, (params, group)) in groups.iter().zip(frame.scene.metaballs()).enumerate() {
            // The previous frame's state of this group, when it had as many balls.
            let prev = before.get(i).filter(|(_, c)| c.len() == params.balls.len());
            let known = match group.device {
                // Written by shaders/metaballs_device.comp when the records carry them.
                // Without them nothing reads the room (the group moves by its transforms only).
                Some(source) => {
                    pieces.push(Err(source.count as usize));
                    source.previous_centres
                }
                None => {
                    // Relative to the group's anchor, as the ball table's centres (gpu_balls_cached).
                    let from = table_anchor(params, false);
                    let start = centres.len();
                    centres.extend(params.balls.iter().enumerate().map(|(k, b)| {
                        let was = prev.map_or(b.centre, |(_, c)| c[k]) - from;
                        [was.x as f32, was.y as f32, was.z as f32, 0.0]
                    }));
                    pieces.push(Ok(start..centres.len()));
                    true
                }
            };
            let placed_from = table_anchor(params, group.device.is_some());
            let prev_transform = prev.map_or(params.transform.matrix, |(m, _)| *m);
            motion_groups.push(MotionGroup {
                prev_to_world: mat4_f32(shift * prev_transform * DMat4::from_translation(placed_from)),
                info: [u32::from(known), 0, 0, 0],
            });
        }
        // A game's group keeps its own balls' centres too: they tell the same group apart next
        // frame (its previous transform applies), though its drawn balls are the game's.
        self.previous[frame.view] =
            groups.iter().map(|p| (p.transform.matrix, p.balls.iter().map(|b| b.centre).collect())).collect();
        // The table in the ball table's order; the ring reserves at least one element.
        const CENTRE: usize = std::mem::size_of::<[f32; 4]>();
        let bytes: &[u8] = bytemuck::cast_slice(&centres);
        let parts: Vec<RingPart> = (pieces.iter())
            .map(|piece| match piece {
                Ok(host) => RingPart::Bytes(&bytes[host.start * CENTRE..host.end * CENTRE]),
                Err(count) => RingPart::Room(count * CENTRE),
            })
            .collect();
        let previous = frame.upload_parts::<[f32; 4]>(&parts)?;
        if motion_groups.is_empty() {
            motion_groups.push(MotionGroup::default());
        }
        let uniforms = MotionUniforms::of(frame);
        Ok(vec![
            Binding::read_write(Target::Motion),
            Binding::Bound(Bound::Uniform(frame.upload(&[uniforms])?)),
            Binding::Bound(Bound::Storage(previous)),
            Binding::Bound(frame.texels("metaballs motion groups", &motion_groups, Texels::U32x4)?),
        ])
    }
}
