//! Balls a game writes on the GPU (a particle or fluid simulation): a metaball group drawn from
//! the game's own buffer (`Renderer::set_metaball_buffer`), copied on the device into the frame's
//! ball table and completed there (the lone-ball radius ρ* solved per ball), with no host copy.
//! The passes then bin and cast them as any other group's (device binning).

use crate::gpu::vk;

/// One ball as the game writes it: 32 bytes, std430
/// `struct { vec4 centre_radius; vec4 q; }` — the object-space centre, the support radius
/// R > 0, and the density coefficient q in `q.x`; `q.yzw`: the ball's centre in the previous
/// frame (object space) when `DeviceBalls::previous_centres` says so (a temporal upscaler's motion
/// vectors follow it), else ignored. A ball with a value that is not finite, or R ≤ 0, is drawn as
/// no ball and counted (`metaballs.invalid_balls`). The records are f32 as written and used as
/// they are: a simulation far from the world's origin keeps them near its group's object origin
/// and places the group with its transform (composed in f64), or its centres are rounded to ε of
/// their distance from that origin (10⁻³ of a unit at 10⁴), where the host's own balls are held
/// relative to their group's first ball (`metaballs_f32::anchor`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DeviceBall {
    /// xyz: object-space centre; w: support radius R.
    pub centre_radius: [f32; 4],
    /// x: q; y, z, w: the previous frame's centre (`DeviceBalls::previous_centres`), or ignored.
    pub q: [f32; 4],
}

/// Bytes of a `DeviceBall`.
pub const DEVICE_BALL_BYTES: u64 = std::mem::size_of::<DeviceBall>() as u64;

/// Where a group's balls are: `count` `DeviceBall` records from byte `offset` of `buffer`, a
/// buffer of the game's device made with `TRANSFER_SRC` usage (hadou copies the records on the
/// device). Synchronization as for `ExternalDepth`: hadou's first command on it waits for every
/// earlier command's writes (`ALL_COMMANDS` / `MEMORY_WRITE`) and every later command waits for its
/// read, so a simulation writes the buffer before hadou's frame in the same queue and the game
/// needs no barrier of its own. The game keeps the buffer alive while frames that read it are in
/// flight.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceBalls {
    pub buffer: vk::Buffer,
    /// Byte offset of the first record.
    pub offset: u64,
    /// Records, 1..=`BIN_MAX_BALLS` (all groups of a frame together).
    pub count: u32,
    /// The records' `q.yzw` hold each ball's centre in the previous frame: with motion vectors
    /// on (`Renderer::set_motion_vectors`) the group's surface moves with its balls. Without it
    /// the group moves by its transforms only (hadou keeps no copy of the game's balls).
    pub previous_centres: bool,
}
