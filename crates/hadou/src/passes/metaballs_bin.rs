//! The metaballs pass's tile lists built on the device (shaders/metaballs_bin.comp: bounds, sort,
//! scan, fill) when the pass runs with [`Binning::Device`](super::metaballs::Binning), so
//! the host's per-frame work does not grow with the balls' screen coverage (and balls a game
//! writes on the GPU would need no read-back). Not the default: on lavapipe these dispatches cost
//! the pass more than the host's binning costs the CPU (docs/PERFORMANCE.md, Metaballs).
//!
//! The lists are those of [`bin_balls`](super::metaballs::bin_balls) (the CPU twin), with two
//! differences that change no pixel: a ball's tile rectangle is computed in f32 and padded wider
//! (a ball listed in a tile none of whose rays meet its support fills no slot: the cast's chords
//! are those of the balls a ray enters, in list order), and the headers and runs are two buffers.
//! Within a run the order is the entry key's ([`bin_key`], ties by ball index) on both sides, so
//! every pixel sums its balls in the same order.
//!
//! Capacities: the header, pending and dispatch buffers hold every tile; entries and runs are
//! sized from the totals the device reports (read back when the slot's frame finished, grown
//! there). A frame whose lists would not fit loses nothing: every tile then walks one run per
//! group over all its visible balls, in the same order (exact, slower), and the next frame has
//! room. At most [`BIN_MAX_BALLS`] balls and [`BIN_MAX_GROUPS`] groups a frame (the sort key's
//! bits; a typed [`GpuError::DeviceLimit`] past them).

use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;

use crate::effects::metaballs::{CastMethod, MetaballGroupParams};
use crate::effects::metaballs_f32::{world_bound, GpuMetaBall};
use crate::gpu::memory::Memory;
use crate::gpu::memory::{Buffer, MemoryLocation};
use crate::gpu::pipeline::{create_compute_pipeline, Bound, BufferRange, Pipeline};
use crate::gpu::recorder::Recorder;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::texel_buffer::{TexelBuffer, Texels};
use crate::gpu::{vk, GpuContext, GpuError, GpuResult};
use crate::scene::camera::Camera;

use super::metaballs::{crowded, sphere_tiles, TileLists, RUN_CROWDED, RUN_TRACE, TILE, TILES_PER_ROW};

/// The most balls (all groups together) one frame bins: 17 bits of the sort key (and the fill
/// stays within lavapipe's loop budget of 65,535 iterations per invocation: ~20 per chunk of 64
/// balls, one per group).
pub const BIN_MAX_BALLS: u32 = 1 << 17;

/// Words of the bin state buffer (keep in sync with BIN_* in shaders/metaballs_bin.comp): the
/// pass's dispatch (x, y, z), then whether the lists overflowed, the entries the device needed
/// (runs: 0, they share the entries' offsets), the tiles with headers, the visible balls and the
/// blocks cut by lavapipe's loop budget; per group from word 12 on: whether RUN_LONE_BOUND is
/// lost, and its visible balls.
pub const BIN_OVERFLOW: usize = 3;
pub const BIN_ENTRIES: usize = 4;
pub const BIN_RUNS: usize = 5;
pub const BIN_ACTIVE: usize = 6;
pub const BIN_VISIBLE: usize = 7;
pub const BIN_CUT: usize = 8;
pub const BIN_GROUPS: usize = 12;

/// Per group, what the bounds stage needs beyond the group header. Keep in sync with `BinGroup`
/// in shaders/metaballs_bin.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BinGroup {
    /// xyz: the camera in the group's object space (f64, rounded once); w: the world radius of a
    /// support of radius 1 (the transform's largest singular value, `world_bound`).
    pub origin: [f32; 4],
    /// x: first ball, y: ball count, z: the run flags the host knows ([`RUN_TRACE`],
    /// [`RUN_CROWDED`]), w: 0.
    pub info: [u32; 4],
}

crate::gpu::layout::gpu_layout!(BinGroup as "BinGroup" { origin, info });

impl BinGroup {
    /// The group `group` (its balls from `first` on, their centres relative to `anchor`:
    /// `metaballs_f32::gpu_group`) seen from `camera`.
    pub fn new(group: &MetaballGroupParams, first: u32, camera: &Camera, anchor: DVec3) -> BinGroup {
        let o = group.transform.inverse.transform_point3(camera.position) - anchor;
        let scale = match group.balls.first() {
            Some(b) => world_bound(group, 0).1 / b.radius,
            None => 0.0,
        };
        let trace = if matches!(group.method, CastMethod::SphereTrace { .. }) { RUN_TRACE } else { 0 };
        let crowd = if crowded(group) { RUN_CROWDED } else { 0 };
        BinGroup {
            origin: [o.x as f32, o.y as f32, o.z as f32, scale as f32],
            info: [first, group.balls.len() as u32, trace | crowd, 0],
        }
    }
}

/// The entry key ‖c − o‖ − R of a ball seen from `origin` (object space), in f32 with the
/// shader's operations in its order (no fused multiply-add): the runs' sort key on both sides.
pub fn bin_key(ball: &GpuMetaBall, origin: [f32; 4]) -> f32 {
    let c = ball.centre_radius;
    let w = [c[0] - origin[0], c[1] - origin[1], c[2] - origin[2]];
    (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt() - c[3]
}

/// Push constants of shaders/metaballs_bin.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BinParams {
    /// x: balls, y: groups, z: sort length (a power of two ≥ balls), w: tiles.
    pub sizes: [u32; 4],
    /// x: entry capacity, y: run capacity, z: tiles per row, w: tile rows.
    pub caps: [u32; 4],
    /// x: the camera's near distance, y: the distance within which a support reaches the near
    /// plane inside the view (RUN_LONE_BOUND, as `GroupBins::new`), z, w: 0.
    pub camera: [f32; 4],
    /// The sort's step: x: the merge width k (0: each block's whole sort), y: the step j.
    pub sort: [u32; 4],
}

crate::gpu::layout::gpu_layout!(BinParams as "BinParams" { sizes, caps, camera, sort });

/// The binning's sizes of one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BinSizes {
    pub balls: u32,
    pub groups: u32,
    pub tiles_x: u32,
    pub tiles_y: u32,
}

impl BinSizes {
    pub fn new(balls: u32, groups: u32, extent: vk::Extent2D) -> BinSizes {
        BinSizes {
            balls,
            groups,
            tiles_x: extent.width.div_ceil(TILE),
            tiles_y: extent.height.div_ceil(TILE),
        }
    }

    pub fn tiles(&self) -> u32 {
        self.tiles_x * self.tiles_y
    }

    fn sort_len(&self) -> u32 {
        self.balls.max(1).next_power_of_two()
    }

    /// Entries to allocate before the device has said how many it needs: 32 per ball.
    fn first_capacity(&self) -> u64 {
        (u64::from(self.balls) * 32).max(1024)
    }
}

/// The stages' pipelines (shaders/metaballs_bin.comp, `MB_BIN_STAGE`).
pub struct BinPipelines {
    bounds: Pipeline,
    sort: Pipeline,
    scan: Pipeline,
    fill: Pipeline,
    merge: Pipeline,
}

impl BinPipelines {
    pub fn new(ctx: &GpuContext, compiler: &mut ShaderCompiler) -> GpuResult<Self> {
        let push = std::mem::size_of::<BinParams>() as u32;
        let mut stage = |name: &str, stage: &str| -> GpuResult<Pipeline> {
            let spirv = compiler.compile("metaballs_bin.comp", &[("MB_BIN_STAGE", stage)])?;
            create_compute_pipeline(ctx, name, &spirv, push)
        };
        Ok(BinPipelines {
            bounds: stage("metaballs bounds", "0")?,
            sort: stage("metaballs sort", "1")?,
            scan: stage("metaballs scan", "3")?,
            fill: stage("metaballs fill", "4")?,
            merge: stage("metaballs merge", "5")?,
        })
    }

    /// In the order of the sets [`record`] takes.
    pub fn all(&self) -> Vec<&Pipeline> {
        vec![&self.bounds, &self.sort, &self.scan, &self.fill, &self.merge]
    }
}

/// One frame slot's buffers: written by the device only, but for the state the host zeroes and
/// reads back.
pub struct BinBuffers {
    sizes: BinSizes,
    elements: Buffer,
    rects: Buffer,
    counts: Buffer,
    offsets: Buffer,
    /// The counts' difference grid, zeroed by the host each frame.
    diff: Buffer,
    pub headers: TexelBuffer,
    pub runs: TexelBuffer,
    pub entries: TexelBuffer,
    /// Host-readable: the dispatch, the totals and the per-group words.
    pub state: Buffer,
    capacity: u64,
}

const STORAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::STORAGE_BUFFER;

impl BinBuffers {
    /// Buffers for `sizes` with room for `capacity` entries and runs (at least the balls and the
    /// groups: the shared lists of an overflowing frame fit), device-local.
    pub fn new(ctx: &GpuContext, memory: &Memory, sizes: BinSizes, capacity: u64) -> GpuResult<BinBuffers> {
        BinBuffers::at(ctx, memory, sizes, capacity, MemoryLocation::GpuOnly)
    }

    /// As [`BinBuffers::new`], in `gpu` (`GpuToCpu`: a test reads the lists back).
    pub fn at(
        ctx: &GpuContext,
        memory: &Memory,
        sizes: BinSizes,
        capacity: u64,
        gpu: MemoryLocation,
    ) -> GpuResult<BinBuffers> {
        let capacity = capacity.max(u64::from(sizes.balls)).max(u64::from(sizes.groups)).max(1);
        let tiles = u64::from(sizes.tiles()).max(1);
        let sort = u64::from(sizes.sort_len());
        let grid = u64::from(sizes.tiles_x + 1) * u64::from(sizes.tiles_y + 1);
        let buffer = |name: &str, bytes: u64| memory.create_buffer(ctx, name, bytes, STORAGE, gpu);
        let state_words = (BIN_GROUPS + 2 * sizes.groups as usize) as u64;
        let usage = STORAGE | vk::BufferUsageFlags::INDIRECT_BUFFER;
        let back = MemoryLocation::GpuToCpu;
        Ok(BinBuffers {
            sizes,
            elements: buffer("metaballs sort keys", 8 * sort)?,
            rects: buffer("metaballs rects", 8 * u64::from(sizes.balls).max(1))?,
            counts: buffer("metaballs tile counts", 8 * tiles)?,
            offsets: buffer("metaballs tile offsets", 16 * tiles)?,
            diff: memory.create_buffer(
                ctx,
                "metaballs count grid",
                4 * grid,
                STORAGE,
                MemoryLocation::CpuToGpu,
            )?,
            headers: TexelBuffer::device(ctx, memory, "metaballs headers", 16 * tiles, Texels::U32x4, gpu)?,
            runs: TexelBuffer::device(ctx, memory, "metaballs runs", 16 * capacity, Texels::U32x4, gpu)?,
            entries: TexelBuffer::device(ctx, memory, "metaballs entries", 4 * capacity, Texels::U32, gpu)?,
            state: memory.create_buffer(ctx, "metaballs bin state", 4 * state_words, usage, back)?,
            capacity,
        })
    }

    /// Whether these buffers serve `sizes` with `capacity` entries.
    pub fn fits(&self, sizes: BinSizes, capacity: u64) -> bool {
        self.sizes == sizes && self.capacity >= capacity
    }

    pub fn capacity(&self) -> u64 {
        self.capacity
    }

    /// Zeroes the state and the count grid (the slot's previous frame has finished).
    pub fn reset(&mut self) -> GpuResult<()> {
        for buffer in [&mut self.state, &mut self.diff] {
            let name = buffer.name.clone();
            let bytes = buffer
                .mapped_mut()
                .ok_or_else(|| GpuError::BufferWrite { buffer: name, message: "not host-visible".into() })?;
            bytes.fill(0);
        }
        Ok(())
    }

    /// The host built the lists: the pass's dispatch over `active` tiles.
    pub fn set_active(&mut self, active: u32) -> GpuResult<()> {
        let rows = active.div_ceil(TILES_PER_ROW);
        self.state.write(0, bytemuck::cast_slice(&[active.min(TILES_PER_ROW), rows, 1]))?;
        self.state.write(4 * BIN_ACTIVE, bytemuck::bytes_of(&active))
    }

    /// A word of the state of the slot's last finished frame.
    pub fn state_word(&self, i: usize) -> u32 {
        word(&self.state, i)
    }

    /// The lists of the last finished frame, where the buffers are host-visible ([`BinBuffers::at`]
    /// with `GpuToCpu`): headers, runs and entries in [`TileLists`]' layout (runs after the headers).
    pub fn read_back(&self) -> Option<TileLists> {
        let active = self.state_word(BIN_ACTIVE);
        let quads = |b: &Buffer, n: usize| -> Option<Vec<[u32; 4]>> {
            let bytes = b.mapped()?.get(..16 * n)?;
            Some(bytemuck::pod_collect_to_vec(bytes))
        };
        let heads = quads(&self.headers.buffer, active as usize)?;
        let entries_len = self.state_word(BIN_ENTRIES) as usize;
        let entries: Vec<u32> = if self.state_word(BIN_OVERFLOW) != 0 {
            bytemuck::pod_collect_to_vec(
                self.entries.buffer.mapped()?.get(..4 * self.state_word(BIN_VISIBLE) as usize)?,
            )
        } else {
            bytemuck::pod_collect_to_vec(self.entries.buffer.mapped()?.get(..4 * entries_len)?)
        };
        let run_room = (self.runs.buffer.size / 16) as usize;
        let runs = quads(&self.runs.buffer, run_room)?;
        // Renumber: each tile's runs copied after the headers, in header order.
        let mut tiles: Vec<[u32; 4]> = heads.clone();
        for (i, h) in heads.iter().enumerate() {
            tiles[i][0] = tiles.len() as u32;
            tiles.extend_from_slice(runs.get(h[0] as usize..(h[0] + h[1]) as usize)?);
        }
        Some(TileLists { tiles_x: self.sizes.tiles_x, tiles_y: self.sizes.tiles_y, active, tiles, entries })
    }

    /// The storage buffers the stages write, in binding order from binding 15 on (elements,
    /// rects, counts, offsets, headers, runs, entries, state, count grid).
    pub fn written(&self) -> [BufferRange; 9] {
        [
            BufferRange::whole(self.elements.raw),
            BufferRange::whole(self.rects.raw),
            BufferRange::whole(self.counts.raw),
            BufferRange::whole(self.offsets.raw),
            BufferRange::whole(self.headers.buffer.raw),
            BufferRange::whole(self.runs.buffer.raw),
            BufferRange::whole(self.entries.buffer.raw),
            BufferRange::whole(self.state.raw),
            BufferRange::whole(self.diff.raw),
        ]
    }

    /// The texel views the pass reads: headers (binding 8), entries (9), runs (13).
    pub fn views(&self) -> [Bound; 3] {
        [
            Bound::UniformTexel(self.headers.view),
            Bound::UniformTexel(self.entries.view),
            Bound::UniformTexel(self.runs.view),
        ]
    }

    /// The push constants of a frame seen from `camera`.
    pub fn params(&self, camera: &Camera, extent: vk::Extent2D) -> BinParams {
        let s = self.sizes;
        let tan = camera.max_slopes(extent.width, extent.height);
        let near_reach = camera.near * (1.0 + tan.x * tan.x + tan.y * tan.y).sqrt() * (1.0 + 1e-3);
        let cap = self.capacity.min(u64::from(u32::MAX)) as u32;
        BinParams {
            sizes: [s.balls, s.groups, s.sort_len(), s.tiles()],
            caps: [cap, cap, s.tiles_x, s.tiles_y],
            camera: [camera.near as f32, near_reach as f32, 0.0, 0.0],
            sort: [0; 4],
        }
    }
}

fn word(buffer: &Buffer, i: usize) -> u32 {
    let Some(words) = buffer.mapped() else { return 0 };
    words.get(4 * i..4 * i + 4).map_or(0, |w| u32::from_le_bytes(w.try_into().unwrap_or([0; 4])))
}

/// The largest entry or run total any finished frame needed (grows the slots' buffers).
#[derive(Debug, Default)]
pub struct Wanted(AtomicU64);

impl Wanted {
    /// At least `entries`.
    pub fn at_least(&self, entries: u64) {
        self.0.fetch_max(entries, Ordering::Relaxed);
    }

    pub fn note(&self, buffers: &BinBuffers) {
        let need = u64::from(buffers.state_word(BIN_ENTRIES).max(buffers.state_word(BIN_RUNS)));
        self.0.fetch_max(need, Ordering::Relaxed);
    }

    /// The capacity a slot's buffers should have for `sizes`: what frames needed, a quarter more.
    pub fn capacity(&self, sizes: BinSizes) -> u64 {
        let seen = self.0.load(Ordering::Relaxed);
        sizes.first_capacity().max(seen + seen / 4)
    }
}

/// An upper bound of the entries the device will list for `groups` (before any frame has said):
/// each visible ball's f64 rectangle ([`sphere_tiles`]) widened by a tile on each side, where the
/// device's f32 one may reach. O(balls) on the host, so only for a world's first frames.
pub fn estimate(groups: &[MetaballGroupParams], camera: &Camera, extent: vk::Extent2D) -> u64 {
    let (tiles_x, tiles_y) = (extent.width.div_ceil(TILE), extent.height.div_ceil(TILE));
    let mut total = 0u64;
    for group in groups {
        let Some(first) = group.balls.first() else { continue };
        let scale = world_bound(group, 0).1 / first.radius;
        for b in &group.balls {
            let centre = group.transform.transform_point(b.centre);
            if let Some(r) = sphere_tiles(camera, extent, centre, b.radius * scale) {
                let w = (r[2] + 1).min(tiles_x - 1) - r[0].saturating_sub(1) + 1;
                let h = (r[3] + 1).min(tiles_y - 1) - r[1].saturating_sub(1) + 1;
                total += u64::from(w) * u64::from(h);
            }
        }
    }
    total
}

/// The most groups one frame bins: the fill walks each group's chunks apart, so with
/// [`BIN_MAX_BALLS`] it stays within lavapipe's loop budget (~20 iterations a chunk, a chunk at
/// least per group). The sort key would hold 2^15.
pub const BIN_MAX_GROUPS: u32 = 1 << 10;

/// The refusal past [`BIN_MAX_BALLS`] balls or [`BIN_MAX_GROUPS`] groups.
pub fn check_ball_count(balls: usize, groups: usize) -> GpuResult<()> {
    if groups as u64 > u64::from(BIN_MAX_GROUPS) {
        return Err(GpuError::DeviceLimit {
            what: "metaball groups in one frame".into(),
            limit: "metaballs binning sort key",
            needed: groups as u64,
            max: u64::from(BIN_MAX_GROUPS),
            message: format!(
                "{groups} metaball groups, but the pass bins at most {BIN_MAX_GROUPS}; merge groups"
            ),
        });
    }
    if balls as u64 > u64::from(BIN_MAX_BALLS) {
        return Err(GpuError::DeviceLimit {
            what: "metaballs balls in one frame".into(),
            limit: "metaballs binning sort",
            needed: balls as u64,
            max: u64::from(BIN_MAX_BALLS),
            message: format!(
                "{balls} balls in one frame, but the metaballs pass bins at most {BIN_MAX_BALLS}; \
                 use fewer balls"
            ),
        });
    }
    Ok(())
}

/// Sort keys per block of the sort within blocks (keep in sync with shaders/metaballs_bin.comp).
const SORT_BLOCK: u32 = 512;

/// Records the stages with `sets` (one per pipeline of [`BinPipelines::all`], in its order)
/// bound, each dispatch followed by a barrier; the pass's dispatch may then read the state's
/// arguments and the lists' views.
pub fn record(rec: &Recorder, pipelines: &BinPipelines, sets: &[vk::DescriptorSet], params: &BinParams) {
    let set = |i: usize| sets.get(i).copied().unwrap_or_default();
    let run = |i: usize, pipeline: &Pipeline, p: &BinParams, (x, y): (u32, u32)| {
        rec.bind_pipeline(pipeline, set(i));
        rec.push_constants(pipeline, bytemuck::bytes_of(p));
        rec.dispatch_groups(x, y);
        rec.compute_to_texel_and_indirect_barrier();
    };
    let n = params.sizes[2];
    let blocks = (params.caps[2].div_ceil(8), params.caps[3].div_ceil(8));
    run(0, &pipelines.bounds, params, (n.div_ceil(256), 1));
    // Bitonic: each block sorted in shared memory, then every merge wider than a block as its
    // steps across blocks (one dispatch each) and the rest within blocks.
    let block_groups = n.div_ceil(SORT_BLOCK);
    run(1, &pipelines.sort, params, (block_groups, 1));
    let mut k = 2 * SORT_BLOCK;
    while k <= n {
        let mut j = k / 2;
        while j >= SORT_BLOCK {
            let step = BinParams { sort: [k, j, 0, 0], ..*params };
            run(4, &pipelines.merge, &step, ((n / 2).div_ceil(256), 1));
            j /= 2;
        }
        run(1, &pipelines.sort, &BinParams { sort: [k, 0, 0, 0], ..*params }, (block_groups, 1));
        k *= 2;
    }
    run(2, &pipelines.scan, params, (1, 1));
    run(3, &pipelines.fill, params, blocks);
}
