//! metaballs: ray-casts the scene's metaball groups per pixel (seed 000, Bézier clipping in
//! shaders/common/metaballs.glsl), depth-tested against the raster, and writes the nearest surface
//! into HDR colour, `distance`, `normal` and `ids` so later passes (energy wave, AOVs) see it.
//!
//! # Binning (every frame, on the host by default: [`bin_balls`]; on the device: [`Binning`])
//! Each ball's world bounding sphere ([`world_bound`]) is projected to a conservative rectangle of
//! 8×8-pixel tiles ([`sphere_tiles`]): exact tangent planes through the camera, padded by a
//! pixel; a sphere crossing the near plane covers the whole screen, one entirely nearer than the
//! near plane (behind the camera included) or beyond the far plane is skipped. The lists are
//! exact and variable-length ([`TileLists`]), so nothing is cut short; they go through the frame
//! slot's upload ring, which grows when a frame needs more. [`Binning::Device`] builds the same
//! lists by compute instead (`passes::metaballs_bin`, the same image bit for bit); either way the
//! headers and the runs reach the shader as two texel buffers, and the pass's dispatch is
//! indirect, its arguments in the bin state buffer.
//!
//! Per pixel the shader casts each group present in its tile over that tile's run of balls: the
//! subgroup gathers the support chords its rays cross into at most 32 shared slots per round
//! (each pixel marking its own), and a pixel whose chords did not all fit searches up to the
//! first one left out, then goes on from there in the next round. Where that cannot move on (more
//! than 32 supports overlap at one point, or the other rays' balls took the slots) the rest of
//! the ray is cast streamed from the tile's run, and so is, from the start, every run of 256 balls
//! or more of a [`crowded`] group (its rounds would end crowded on most rays). `mb_clip_stream`:
//! a walk over the run gathers the ray's next 128 chords into a per-invocation cache, and the
//! clipping's windows walk those; where more than 128 supports overlap at one point the windows
//! walk the run itself, every walk recomputing the chords, so no count of overlapping supports
//! is too many. Those streamed casts
//! run in a second, indirect dispatch over the tiles holding a crowded pixel (the first lists
//! them, with each pixel's crowded runs in a [`PendingRecord`]): lavapipe runs a branch's code for
//! the whole SIMD group even where no lane takes it, so inside the first dispatch the long cast
//! would cost every tile, and each dispatch starts a fresh loop budget (below). Where the clipping
//! does not converge, or a sphere-traced group (`method = "sphere_trace"`) runs out of steps, the
//! pixel is counted in the frame's counter `metaballs.dropped` and a warning is logged.
//!
//! Lavapipe (Mesa's gallivm) ends every loop of a SIMD group, silently, once all of them together
//! have iterated 65,535 times in one invocation. The streamed walks take 8 balls per iteration
//! (the dense fluid of assets/scenes/metaballs_dense.toml stays below it), and each dispatch
//! checks at its end, with a loop the compiler cannot unroll, whether the limit was reached: then
//! every pixel of the SIMD group counts in `metaballs.dropped` (tests/gpu_metaballs.rs: 100,000
//! concentric balls). Other devices have no such limit.
//!
//! # Counters (`FrameStats::counter`)
//! `metaballs.dropped`: pixels whose cast could not finish (a surface may be missing there);
//! `metaballs.hits`: pixels where a metaball is the nearest surface; `metaballs.clip_steps` and
//! `metaballs.clip_steps_max`: the Bézier-clipping steps of those hits (sum, max);
//! `metaballs.streamed`: casts that went on streamed (a ball containing the search's start found
//! no slot: more than 32 supports there, or the subgroup's other rays filled the slots; or a
//! [`crowded`] group's run of 256 balls or more, streamed without slot rounds).
//!
//! # Motion vectors
//! With motion vectors on, the casts also write each metaball pixel's motion where its hit is
//! final, from the balls of its tile's run of that group ([`crate::passes::metaballs_motion`]).
//!
//! # Methods
//! Each group's [`CastMethod`] picks Bézier clipping (with its `tolerance`) or sphere tracing (its
//! `steps`), carried in the group header and the run flags ([`RUN_TRACE`]). The pipeline is
//! compiled with only the casts the scene's groups use (`MB_WITH_CLIP`, `MB_WITH_TRACE`).

use crate::gpu::memory::MemoryLocation;
use glam::DVec3;

use super::{Binding, FrameContext, Pass, PassRecording, Reader};
use crate::effects::metaballs::{CastMethod, MetaballGroupParams};
use crate::effects::metaballs_f32::{
    gpu_balls_cached, gpu_group, table_anchor, world_bound, GpuMetaBall, GpuMetaGroup, IsoCache,
    MB_MAX_RAY_BALLS,
};
use crate::frame::FrameStats;
use crate::gpu::memory::Buffer;
use crate::gpu::pipeline::{create_compute_pipeline, Bound, BufferRange, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::texel_buffer::{TexelBuffer, Texels};
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::passes::metaballs_bin::{
    check_ball_count, estimate, BinBuffers, BinGroup, BinParams, BinPipelines, BinSizes, Wanted,
};
use crate::passes::metaballs_device::{self, DeviceBallParams, DeviceBallPipeline, DeviceCopy};
use crate::passes::metaballs_motion::{self, MetaballsMotion};
use crate::scene::camera::Camera;
use crate::scene::Scene;
use crate::targets::Target;

const STORAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::STORAGE_BUFFER;
const GPU: MemoryLocation = MemoryLocation::GpuOnly;
const HOST: MemoryLocation = MemoryLocation::CpuToGpu;

/// Per pixel of an active tile with a crowded pixel, written by the rounds for the streamed
/// dispatch (keep in sync with `pending_runs` in shaders/metaballs.comp): the crowded runs (bits
/// of runs 0–31 and 32–63, the first crowded run from 64 on or u32::MAX) and the rounds' hit (bit
/// 31) with its clipping steps.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PendingRecord {
    pub runs_lo: u32,
    pub runs_hi: u32,
    pub runs_from: u32,
    pub hit_steps: u32,
}

/// Tile edge in pixels: one 8×8 workgroup per tile (keep in sync with shaders/metaballs.comp). A
/// pixel walks only the balls of its tile: with the 4,096-ball scene at 256², 58 per tile on
/// average (max 164) against 92 (max 264) with 16×16 tiles (measured: 0.93× the pass time).
pub const TILE: u32 = 8;
/// Active tiles per row of the dispatch (one workgroup each: within maxComputeWorkGroupCount\[0\]).
/// Keep in sync with shaders/metaballs.comp and shaders/metaballs_bin.comp.
pub const TILES_PER_ROW: u32 = 8192;

/// Push constants of shaders/metaballs.comp (size checked against the shader at pipeline creation).
/// The camera's ray frame, the far distance and the frame's size are the frame's uniforms
/// (`FrameUniforms`: `ray_right`, `ray_up`, `ray_forward`, `counts`); the near distance is not
/// among them, so it stays here.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MetaballParams {
    /// x: 0 (the active tiles are in the bin state); y: the instance id of group 0 (= the scene's
    /// instance count); z, w: 0.
    pub counts: [u32; 4],
    /// x: the camera's near distance (a view depth); y, z, w: 0.
    pub near: [f32; 4],
}

crate::gpu::layout::gpu_layout!(MetaballParams as "MetaballParams" { counts, near });

const _: () = assert!(std::mem::size_of::<MetaballParams>() == 32);

/// Indices into the stats buffer. Keep in sync with STAT_* in shaders/metaballs.comp.
const STAT_DROPPED: usize = 0;
const STAT_HITS: usize = 1;
const STAT_ITERATIONS: usize = 2;
const STAT_MAX_ITERATIONS: usize = 3;
const STAT_STREAMED: usize = 4;
/// Written by shaders/metaballs_device.comp.
const STAT_INVALID: usize = 5;
const STAT_COUNT: usize = 6;

impl MetaballParams {
    /// The parameters of a frame of `scene`.
    pub fn new(scene: &Scene) -> Self {
        MetaballParams {
            counts: [0, scene.instances.len() as u32, 0, 0],
            near: [scene.camera.near as f32, 0.0, 0.0, 0.0],
        }
    }
}

/// The tiles (inclusive ranges x0..=x1, y0..=y1) a world sphere may cover, or `None` when no
/// pixel ray can reach it between the near and far planes.
pub fn sphere_tiles(camera: &Camera, extent: vk::Extent2D, centre: DVec3, radius: f64) -> Option<[u32; 4]> {
    let (w, h) = (extent.width, extent.height);
    let (tiles_x, tiles_y) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let full = Some([0, 0, tiles_x - 1, tiles_y - 1]);
    let b = camera.basis();
    let v = centre - camera.position;
    // Pad for the f32 arithmetic of the shader (positions, transforms, pixel rays).
    let r = radius * (1.0 + 1e-5) + 1e-6 * (v.length() + radius);
    let z = v.dot(b.forward);
    if !z.is_finite() || z + r < camera.near * (1.0 - 1e-6) || z - r > camera.far * (1.0 + 1e-6) {
        return None; // wholly nearer than the near plane (or behind the camera), or beyond far
    }
    if z - r <= camera.near {
        return full; // crosses the near plane
    }
    // Planes through the camera containing the other image axis and tangent to the sphere:
    // x = k·z with (x − k z)² = r²(1 + k²); valid as the sphere lies in z > r.
    let slopes = |x: f64| {
        let disc = (x * x + z * z - r * r).max(0.0).sqrt();
        let den = z * z - r * r;
        ((x * z - r * disc) / den, (x * z + r * disc) / den)
    };
    let (kx0, kx1) = slopes(v.dot(b.right));
    let (ky0, ky1) = slopes(v.dot(b.up));
    // NDC → pixel coordinates (x right, y down), then the pixels whose centres may fall inside,
    // widened by one pixel.
    // (The lens maps slopes to ndc increasingly in each axis, so the extreme slopes bound it.)
    let lo = camera.ndc_of_slopes(glam::DVec2::new(kx0, ky0), w, h);
    let hi = camera.ndc_of_slopes(glam::DVec2::new(kx1, ky1), w, h);
    let px = |ndc: f64| (ndc + 1.0) * 0.5 * w as f64;
    let py = |ndc: f64| (1.0 - ndc) * 0.5 * h as f64;
    let (x0, x1) = (px(lo.x) - 1.5, px(hi.x) + 0.5);
    let (y0, y1) = (py(hi.y) - 1.5, py(lo.y) + 0.5);
    if !(x1 >= 0.0 && y1 >= 0.0 && x0 < w as f64 && y0 < h as f64) {
        return None; // off screen (also rejects NaN)
    }
    let tile = |p: f64, n: u32| ((p.max(0.0).min((n - 1) as f64) as u32) / TILE).min(n.div_ceil(TILE) - 1);
    Some([tile(x0.floor(), w), tile(y0.floor(), h), tile(x1.ceil(), w), tile(y1.ceil(), h)])
}

/// `run.w` flag: every q of the group is ≥ 0 and no support sphere reaches the near plane, so
/// a ray passing well inside a ball's lone isosurface sphere (the sphere q·f = T) at t_c has its
/// first hit before t_c (there F ≥ q·f > T while F(t_min) = 0 < T): the shader stops there.
pub const RUN_LONE_BOUND: u32 = 1;
/// `run.w` flag: the group is sphere-traced (`CastMethod::SphereTrace`), else Bézier-clipped.
pub const RUN_TRACE: u32 = 2;
/// `run.w` flag: the group's supports overlap on average deeper than the 32 slots hold
/// ([`crowded`]), so its runs skip the slot rounds and go to the streamed cast at once.
pub const RUN_CROWDED: u32 = 4;

/// Whether a group crowds its supports: their volumes summed, over the volume of their bounding
/// box (a ratio no linear transform changes), is at least [`MB_MAX_RAY_BALLS`] = 32 — the mean
/// number of supports on a point of the box. The slot rounds of such a group end crowded on most
/// rays, so its long runs skip them (measured: the dense fluid, ~58 deep by this count, 0.8× the
/// pass time; the 10,000-ball swarm, ~2 deep, keeps its rounds, which streaming would double).
/// Exact either way: it only picks the faster path. A group whose balls live on the device (a
/// game's buffer) is never flagged.
pub fn crowded(group: &MetaballGroupParams) -> bool {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut volume = 0.0;
    for b in &group.balls {
        lo = lo.min(b.centre - DVec3::splat(b.radius));
        hi = hi.max(b.centre + DVec3::splat(b.radius));
        volume += 4.0 / 3.0 * std::f64::consts::PI * b.radius.powi(3);
    }
    let size = hi - lo;
    let bounds = size.x * size.y * size.z;
    bounds > 0.0 && volume >= MB_MAX_RAY_BALLS as f64 * bounds
}

/// Per-tile ball lists, grouped by metaball group. Keep in sync with `Tiles`/`Entries` in
/// shaders/metaballs.comp:
/// - `tiles[0 .. active]`: one header per tile that holds any ball (row-major order), x: index in
///   `tiles` of the tile's first run, y: its run count, z, w: the tile's column and row. The pass
///   dispatches one 8×8 workgroup per header, so empty tiles cost nothing;
/// - `tiles[active ..]`: the runs, x: group index, y: first entry, z: entry count, w: flags
///   ([`RUN_LONE_BOUND`]); a tile's runs are contiguous, one per group present in the tile, in
///   group order;
/// - `entries`: global ball indices (into the ball buffer, all groups concatenated); within a run
///   sorted by the ball's key ‖c − o‖ − R in the group's object space (o the camera), a lower
///   bound of the distance t′ at which any ray from the camera enters its support, so the shader
///   can stop once every ray of a subgroup has a bound nearer than the next ball's key.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TileLists {
    pub tiles_x: u32,
    pub tiles_y: u32,
    /// Tiles with at least one run.
    pub active: u32,
    pub tiles: Vec<[u32; 4]>,
    pub entries: Vec<u32>,
}

impl TileLists {
    /// The (group, global ball indices) runs of tile (tx, ty).
    pub fn runs(&self, tx: u32, ty: u32) -> Vec<(u32, &[u32])> {
        let heads = &self.tiles[..self.active as usize];
        let Some(head) = heads.iter().find(|h| h[2] == tx && h[3] == ty) else { return Vec::new() };
        (0..head[1])
            .map(|r| {
                let run = self.tiles[(head[0] + r) as usize];
                (run[0], &self.entries[run[1] as usize..(run[1] + run[2]) as usize])
            })
            .collect()
    }
}

/// What binning needs of one group: per ball its world bounding sphere (centre, radius) and its
/// sort key, and the group's run flags.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GroupBins {
    pub bounds: Vec<(DVec3, f64)>,
    pub keys: Vec<f64>,
    pub flags: u32,
}

impl GroupBins {
    /// The bounds ([`world_bound`], the transform's largest singular value computed once per
    /// group), the keys ‖c − M⁻¹·camera‖ − R and the flags of a group seen from `camera`.
    pub fn new(group: &MetaballGroupParams, camera: &Camera, extent: vk::Extent2D) -> GroupBins {
        let Some(first) = group.balls.first() else { return GroupBins::default() };
        let scale = world_bound(group, 0).1 / first.radius;
        let bounds: Vec<(DVec3, f64)> = group
            .balls
            .iter()
            .map(|b| (group.transform.transform_point(b.centre), b.radius * scale))
            .collect();
        let o = group.transform.inverse.transform_point3(camera.position);
        let keys = group.balls.iter().map(|b| (b.centre - o).length() - b.radius).collect();
        // Every point of the near plane inside the view lies within this distance of the camera.
        let tan = camera.max_slopes(extent.width, extent.height);
        let near_reach = camera.near * (1.0 + tan.x * tan.x + tan.y * tan.y).sqrt() * (1.0 + 1e-3);
        let clear = bounds.iter().all(|(c, r)| (*c - camera.position).length() - r > near_reach);
        let positive = group.balls.iter().all(|b| b.q >= 0.0);
        let trace = if matches!(group.method, CastMethod::SphereTrace { .. }) { RUN_TRACE } else { 0 };
        let lone = if clear && positive { RUN_LONE_BOUND } else { 0 };
        let crowd = if crowded(group) { RUN_CROWDED } else { 0 };
        GroupBins { bounds, keys, flags: lone | trace | crowd }
    }
}

/// Bins every ball to the tiles its world bounding sphere may cover; global indices run over
/// the groups in order.
pub fn bin_balls(camera: &Camera, extent: vk::Extent2D, groups: &[GroupBins]) -> TileLists {
    let (tiles_x, tiles_y) = (extent.width.div_ceil(TILE), extent.height.div_ceil(TILE));
    let n_tiles = (tiles_x * tiles_y) as usize;
    // (global index, group, tile rectangle) of every visible ball, in group order.
    let mut rects: Vec<(u32, u32, [u32; 4])> = Vec::new();
    let mut keys: Vec<f64> = Vec::new();
    for (g, group) in groups.iter().enumerate() {
        for (i, &(centre, radius)) in group.bounds.iter().enumerate() {
            if let Some(rect) = sphere_tiles(camera, extent, centre, radius) {
                rects.push((keys.len() as u32 + i as u32, g as u32, rect));
            }
        }
        keys.extend(group.keys.iter().copied().chain(std::iter::repeat(0.0)).take(group.bounds.len()));
    }
    let for_tiles = |rect: [u32; 4], f: &mut dyn FnMut(usize)| {
        for ty in rect[1]..=rect[3] {
            for tx in rect[0]..=rect[2] {
                f((ty * tiles_x + tx) as usize);
            }
        }
    };
    const NONE: u32 = u32::MAX;
    let mut entry_count = vec![0u32; n_tiles];
    let mut run_count = vec![0u32; n_tiles];
    let mut last_group = vec![NONE; n_tiles];
    for &(_, g, rect) in &rects {
        for_tiles(rect, &mut |t| {
            entry_count[t] += 1;
            if last_group[t] != g {
                last_group[t] = g;
                run_count[t] += 1;
            }
        });
    }
    let total_runs: u32 = run_count.iter().sum();
    let total_entries: u32 = entry_count.iter().sum();
    let active = run_count.iter().filter(|&&c| c > 0).count();
    let mut tiles = vec![[0u32; 4]; active + total_runs as usize];
    let mut run_cursor = vec![0u32; n_tiles];
    let mut entry_cursor = vec![0u32; n_tiles];
    let (mut head, mut run_at, mut entry_at) = (0usize, active as u32, 0u32);
    for t in 0..n_tiles {
        run_cursor[t] = run_at;
        entry_cursor[t] = entry_at;
        if run_count[t] > 0 {
            tiles[head] = [run_at, run_count[t], t as u32 % tiles_x, t as u32 / tiles_x];
            head += 1;
        }
        run_at += run_count[t];
        entry_at += entry_count[t];
    }
    let mut entries = vec![0u32; total_entries as usize];
    last_group.fill(NONE);
    for &(ball, g, rect) in &rects {
        for_tiles(rect, &mut |t| {
            if last_group[t] != g {
                last_group[t] = g;
                tiles[run_cursor[t] as usize] = [g, entry_cursor[t], 0, groups[g as usize].flags];
                run_cursor[t] += 1;
            }
            tiles[run_cursor[t] as usize - 1][2] += 1;
            entries[entry_cursor[t] as usize] = ball;
            entry_cursor[t] += 1;
        });
    }
    for run in &tiles[active..] {
        let list = &mut entries[run[1] as usize..(run[1] + run[2]) as usize];
        list.sort_unstable_by(|a, b| keys[*a as usize].total_cmp(&keys[*b as usize]).then(a.cmp(b)));
    }
    TileLists { tiles_x, tiles_y, active: active as u32, tiles, entries }
}

/// The pass's counters in `FrameStats` (module docs).
pub const DROPPED: &str = "metaballs.dropped";
pub const HITS: &str = "metaballs.hits";
pub const CLIP_STEPS: &str = "metaballs.clip_steps";
pub const CLIP_STEPS_MAX: &str = "metaballs.clip_steps_max";
pub const STREAMED: &str = "metaballs.streamed";
/// Balls a game wrote on the GPU with a value that is not finite, or R ≤ 0: drawn as no ball.
pub const INVALID_BALLS: &str = "metaballs.invalid_balls";

/// What the device counted in the last frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MetaballCounts {
    /// Pixels whose cast could not finish: a surface may be missing there.
    pub dropped: u64,
    /// Pixels where a metaball was the nearest surface.
    pub hits: u64,
    /// Σ and max of the Bézier-clipping steps of those hits (sphere-traced groups: march steps).
    pub clip_steps: u64,
    pub clip_steps_max: u64,
    /// Casts streamed from the tile's run: a ball containing the search's start found none of the
    /// subgroup's 32 slots (more than 32 supports there, or the other rays' balls filled them).
    pub streamed: u64,
    /// Balls of the game's buffer (`DeviceBalls`) that were not valid (`INVALID_BALLS`).
    pub invalid_balls: u64,
}

pub struct MetaballsPass {
    pipeline: Pipeline,
    /// The second dispatch: the crowded pixels' streamed casts (MB_STREAM_PASS).
    stream: Pipeline,
    /// Per frame slot: the device's counters of the frame last recorded in it (host-readable).
    stats: Vec<Buffer>,
    /// Per frame slot: a `PendingRecord` per pixel of every active tile (device-only), and the
    /// streamed dispatch's arguments and tile list (`StreamDispatch`, reset by the host).
    pending: Vec<Buffer>,
    stream_dispatch: Vec<Buffer>,
    /// The frame being recorded's `stream_dispatch` buffer.
    frame_dispatch: vk::Buffer,
    params: MetaballParams,
    /// The tile lists, built on the device (`metaballs_bin`): the stages, each slot's buffers,
    /// the capacity finished frames asked for, and the frame being recorded's state buffer and
    /// push constants.
    /// Made only when the device bins (`Binning::Device`): the host's binning runs none of them.
    bin: Option<BinPipelines>,
    binning: Binning,
    /// Per group, the lone-ball radii of its balls (`gpu_balls_cached`).
    iso: Vec<IsoCache>,
    bin_buffers: Vec<Option<BinBuffers>>,
    wanted: Wanted,
    estimated_for: Option<BinSizes>,
    frame_state: vk::Buffer,
    bin_params: BinParams,
    /// The previous finished frame's dropped count: a frame repeating it does not warn again (the
    /// count is in `FrameStats` every frame).
    warned_dropped: std::sync::atomic::AtomicU64,
    /// With a group drawn from the game's buffer (`DeviceBalls`): the completing pipeline, each
    /// slot's ball table, and the frame being recorded's table and copies.
    device: Option<DeviceBallPipeline>,
    tables: Vec<Option<TexelBuffer>>,
    frame_table: vk::Buffer,
    copies: Vec<DeviceCopy>,
    /// With motion vectors on: the previous frame's groups the casts' motion is measured against.
    motion: Option<MetaballsMotion>,
}

/// Where the tile lists are built.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub enum Binning {
    /// On the host, every frame ([`bin_balls`]): the default. On lavapipe the device's binning
    /// costs the pass more than the host's costs the CPU (docs/PERFORMANCE.md, Metaballs).
    #[default]
    Host,
    /// On the device ([`crate::passes::metaballs_bin`]): the host's work no longer grows with
    /// the balls' screen coverage; the same lists, the same image.
    Device,
}

impl Binning {
    /// `HADOU_METABALLS_BINNING=device` picks [`Binning::Device`], anything else the host's (the
    /// command line's switch; a game sets `effect::Metaballs::binning`).
    pub fn from_env() -> Binning {
        match std::env::var("HADOU_METABALLS_BINNING").as_deref() {
            Ok("device") => Binning::Device,
            _ => Binning::Host,
        }
    }
}

/// Which casts the scene's groups use: (Bézier clipping, sphere tracing).
fn casts(scene: &Scene) -> (bool, bool) {
    let trace = |g: &crate::scene::model::MetaballGroup| matches!(g.method, CastMethod::SphereTrace { .. });
    (scene.metaballs().iter().any(|g| !trace(g)), scene.metaballs().iter().any(trace))
}

/// Whether a group's balls come from the game's buffer: the pass then bins on the device.
pub fn has_device_balls(scene: &Scene) -> bool {
    scene.metaballs().iter().any(|g| g.device.is_some())
}

/// The pass is compiled with only the casts the scene uses, and with the device's binning and the
/// game's balls' completion when a group's balls are the game's: a world that changes either
/// builds it again; so does turning motion vectors on or off (the casts' MB_MOTION variant).
pub fn variant(scene: &Scene) -> String {
    let device = if has_device_balls(scene) { " device balls" } else { "" };
    let motion = if scene.render.motion_vectors { " motion" } else { "" };
    format!("{:?}{device}{motion}", casts(scene))
}

impl MetaballsPass {
    pub fn new(
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        scene: &Scene,
        binning: Binning,
    ) -> GpuResult<Self> {
        // Only the casts the scene's groups use are compiled in.
        let (clip, trace) = casts(scene);
        let motion = scene.render.motion_vectors;
        let with = |b: bool| if b { "1" } else { "0" };
        let mut defines = vec![("MB_WITH_CLIP", with(clip)), ("MB_WITH_TRACE", with(trace))];
        // With motion vectors on the casts write the metaballs' pixels' motion too.
        if motion {
            defines.push(("MB_MOTION", "1"));
        }
        let spirv = compiler.compile("metaballs.comp", &defines)?;
        let push = std::mem::size_of::<MetaballParams>() as u32;
        let pipeline = create_compute_pipeline(ctx, "metaballs", &spirv, push)?;
        defines.push(("MB_STREAM_PASS", "1"));
        let spirv = compiler.compile("metaballs.comp", &defines)?;
        let stream = create_compute_pipeline(ctx, "metaballs streamed", &spirv, push)?;
        // The game's balls have no host copy to bin from.
        let device = if has_device_balls(scene) {
            Some(DeviceBallPipeline::new(ctx, compiler, motion)?)
        } else {
            None
        };
        let motion = motion.then(MetaballsMotion::default);
        let binning = if device.is_some() { Binning::Device } else { binning };
        let bin = match binning {
            Binning::Device => Some(BinPipelines::new(ctx, compiler)?),
            Binning::Host => None,
        };
        Ok(MetaballsPass {
            device,
            motion,
            tables: Vec::new(),
            frame_table: vk::Buffer::null(),
            copies: Vec::new(),
            bin,
            binning,
            iso: Vec::new(),
            bin_buffers: Vec::new(),
            wanted: Wanted::default(),
            estimated_for: None,
            frame_state: vk::Buffer::null(),
            bin_params: BinParams::default(),
            pipeline,
            stream,
            stats: Vec::new(),
            pending: Vec::new(),
            stream_dispatch: Vec::new(),
            frame_dispatch: vk::Buffer::null(),
            params: MetaballParams::default(),
            warned_dropped: Default::default(),
        })
    }

    /// The counters of the frame last recorded in `slot` (after it finished).
    pub fn counts(&self, slot: usize) -> MetaballCounts {
        let Some(words) = self.stats.get(slot).and_then(|b| b.mapped()) else {
            return MetaballCounts::default();
        };
        let word = |i: usize| u32::from_le_bytes(words[4 * i..4 * i + 4].try_into().unwrap_or([0; 4])) as u64;
        MetaballCounts {
            dropped: word(STAT_DROPPED),
            hits: word(STAT_HITS),
            clip_steps: word(STAT_ITERATIONS),
            clip_steps_max: word(STAT_MAX_ITERATIONS),
            streamed: word(STAT_STREAMED),
            invalid_balls: word(STAT_INVALID),
        }
    }
}

impl Pass for MetaballsPass {
    fn name(&self) -> &'static str {
        "metaballs"
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let scene = frame.scene;
        let extent = frame.extent;
        let mut gpu_groups: Vec<GpuMetaGroup> = Vec::with_capacity(scene.metaballs().len());
        // The host's balls; `table_len` counts the game's groups' too (their room in the table,
        // filled on the device), and `host_runs` says where in the table each run of the host's
        // goes (first ball in the table, range in `balls`).
        let mut balls: Vec<GpuMetaBall> = Vec::new();
        let mut table_len = 0usize;
        let mut host_runs: Vec<(usize, std::ops::Range<usize>)> = Vec::new();
        let mut bin_groups = Vec::with_capacity(scene.metaballs().len());
        let groups: Vec<MetaballGroupParams> = scene.metaballs().iter().map(|g| g.at(frame.time)).collect();
        self.iso.resize_with(groups.len(), IsoCache::default);
        self.copies.clear();
        for ((group, params), iso) in scene.metaballs().iter().zip(&groups).zip(&mut self.iso) {
            let first = table_len as u32;
            // A game's records are in its object space as given; the host's balls are placed from
            // a ball of their own (`anchor`).
            let placed_from = table_anchor(params, group.device.is_some());
            let mut gpu =
                gpu_group(params, first, group.material as u32, (scene.camera.position, placed_from));
            let mut bin = BinGroup::new(params, first, &scene.camera, placed_from);
            match group.device {
                // Room in the table for the game's records, copied and completed on the device.
                Some(source) => {
                    (gpu.info[2], bin.info[1]) = (source.count, source.count);
                    table_len += source.count as usize;
                    let kernel = params.kernel;
                    let previous = u32::from(source.previous_centres && self.motion.is_some());
                    self.copies.push(DeviceCopy {
                        source,
                        params: DeviceBallParams {
                            range: [first, source.count, kernel.gpu_id(), previous],
                            values: [params.threshold as f32, kernel.max_slope() as f32, 0.0, 0.0],
                        },
                    });
                }
                None => {
                    let start = balls.len();
                    balls.extend(gpu_balls_cached(params, iso, placed_from));
                    host_runs.push((table_len, start..balls.len()));
                    table_len += balls.len() - start;
                }
            }
            gpu_groups.push(gpu);
            bin_groups.push(bin);
        }
        let sizes = BinSizes::new(table_len as u32, gpu_groups.len() as u32, extent);
        let host_lists = match self.binning {
            Binning::Host => {
                let bins: Vec<GroupBins> =
                    groups.iter().map(|g| GroupBins::new(g, &scene.camera, extent)).collect();
                Some(bin_balls(&scene.camera, extent, &bins))
            }
            Binning::Device => {
                check_ball_count(table_len, gpu_groups.len())?;
                None
            }
        };
        // Before the device has reported how many entries lists of these sizes take: a bound
        // from the host (its only per-ball work, once per size).
        if host_lists.is_none() && self.estimated_for != Some(sizes) {
            // The game's balls are not on the host: the finished frames' totals size their lists.
            let host: Vec<MetaballGroupParams> = (groups.iter().zip(scene.metaballs()))
                .filter(|(_, g)| g.device.is_none())
                .map(|(p, _)| p.clone())
                .collect();
            self.wanted.at_least(estimate(&host, &scene.camera, extent));
            self.estimated_for = Some(sizes);
        }
        self.params = MetaballParams::new(scene);
        // The slot's binning buffers, remade when the frame's size or ball count changed or
        // finished frames needed more entries than they hold.
        let capacity = if host_lists.is_some() { 1 } else { self.wanted.capacity(sizes) };
        while self.bin_buffers.len() <= frame.slot {
            self.bin_buffers.push(None);
        }
        let slot_bins = &mut self.bin_buffers[frame.slot];
        if !slot_bins.as_ref().is_some_and(|b| b.fits(sizes, capacity)) {
            *slot_bins = Some(BinBuffers::new(frame.ctx, frame.memory, sizes, capacity)?);
        }
        let Some(bins) = slot_bins.as_mut() else { unreachable!("made above") };
        bins.reset()?;
        self.bin_params = bins.params(&scene.camera, extent);
        self.frame_state = bins.state.raw;
        let written = bins.written();
        let views = match &host_lists {
            None => bins.views(),
            Some(lists) => {
                // The host's lists in the device's layout: headers and runs apart.
                bins.set_active(lists.active)?;
                let active = lists.active as usize;
                let heads: Vec<[u32; 4]> =
                    lists.tiles[..active].iter().map(|h| [h[0] - lists.active, h[1], h[2], h[3]]).collect();
                [
                    frame.texels("metaballs headers", &heads, Texels::U32x4)?,
                    frame.texels("metaballs entries", &lists.entries, Texels::U32)?,
                    frame.texels("metaballs runs", &lists.tiles[active..], Texels::U32x4)?,
                ]
            }
        };
        // The slot's counters: its previous frame has finished and was reported.
        while self.stats.len() <= frame.slot {
            let name = format!("metaballs stats {}", self.stats.len());
            let back = MemoryLocation::GpuToCpu;
            let size = (4 * STAT_COUNT) as u64;
            self.stats.push(frame.memory.create_buffer(frame.ctx, &name, size, STORAGE, back)?);
        }
        let stats = &mut self.stats[frame.slot];
        stats.write(0, &[0u8; 4 * STAT_COUNT])?;
        let stats = BufferRange::whole(stats.raw);
        // The streamed dispatch's buffers: for the host's active tiles, or for every tile (any
        // may be active).
        let tiles = u64::from(host_lists.as_ref().map_or(sizes.tiles(), |l| l.active)).max(1);
        let pending_bytes = tiles * 64 * std::mem::size_of::<PendingRecord>() as u64;
        let dispatch_bytes = (4 + tiles) * 4;
        while self.pending.len() <= frame.slot {
            self.pending.push(frame.memory.create_buffer(
                frame.ctx,
                "metaballs pending",
                16,
                STORAGE,
                GPU,
            )?);
            let usage = STORAGE | vk::BufferUsageFlags::INDIRECT_BUFFER;
            let dispatch =
                frame.memory.create_buffer(frame.ctx, "metaballs stream dispatch", 16, usage, HOST)?;
            self.stream_dispatch.push(dispatch);
        }
        if self.pending[frame.slot].size < pending_bytes {
            let name = "metaballs pending";
            self.pending[frame.slot] =
                frame.memory.create_buffer(frame.ctx, name, pending_bytes, STORAGE, GPU)?;
        }
        if self.stream_dispatch[frame.slot].size < dispatch_bytes {
            let usage = STORAGE | vk::BufferUsageFlags::INDIRECT_BUFFER;
            let name = "metaballs stream dispatch";
            self.stream_dispatch[frame.slot] =
                frame.memory.create_buffer(frame.ctx, name, dispatch_bytes, usage, HOST)?;
        }
        // No tile listed yet: x = 0 workgroups, y = z = 1, count 0.
        self.stream_dispatch[frame.slot].write(0, bytemuck::cast_slice(&[0u32, 1, 1, 0]))?;
        let pending = BufferRange::whole(self.pending[frame.slot].raw);
        self.frame_dispatch = self.stream_dispatch[frame.slot].raw;
        let dispatch = BufferRange::whole(self.frame_dispatch);
        let quad = Texels::U32x4;
        // The balls: the host's in the ring, or, with the game's, the slot's table.
        let ball_table = if self.device.is_some() {
            while self.tables.len() <= frame.slot {
                self.tables.push(None);
            }
            const BALL: usize = std::mem::size_of::<GpuMetaBall>();
            let host: Vec<(usize, &[u8])> = (host_runs.iter())
                .map(|(first, run)| (first * BALL, bytemuck::cast_slice(&balls[run.clone()])))
                .collect();
            let bytes = (table_len * BALL) as u64;
            let table =
                metaballs_device::table(&mut self.tables[frame.slot], frame.ctx, frame.memory, &host, bytes)?;
            self.frame_table = table.buffer.raw;
            Bound::UniformTexel(table.view)
        } else {
            frame.texels("metaballs balls", &balls, quad)?
        };
        let bin_groups = frame.upload(&bin_groups)?;
        let mut bindings = vec![
            Binding::read_write(Target::Distance),
            Binding::read_write(Target::Hdr),
            Binding::read_write(Target::Normal),
            Binding::read_write(Target::Ids),
            Binding::Bound(Bound::Uniform(frame.uniforms)),
            Binding::Bound(Bound::Storage(frame.materials)),
            Binding::Bound(frame.texels("metaballs groups", &gpu_groups, quad)?),
            Binding::Bound(ball_table),
            Binding::Bound(views[0]),
            Binding::Bound(views[1]),
            Binding::Written(stats, Reader::Host),
            Binding::Written(pending, Reader::Compute),
            Binding::Written(dispatch, Reader::Indirect),
            Binding::Bound(views[2]),
            Binding::Bound(Bound::Storage(bin_groups)),
        ];
        let (lists, rest) = written.split_at(7);
        bindings.extend(lists.iter().map(|&b| Binding::Written(b, Reader::Compute)));
        bindings.push(Binding::Written(rest[0], Reader::Host));
        bindings.push(Binding::Written(rest[1], Reader::Compute));
        // Binding 24: the game's balls' table (bound for the completing pipeline only).
        let table = BufferRange::whole(self.frame_table);
        bindings.push(if self.device.is_some() {
            Binding::Written(table, Reader::Compute)
        } else {
            Binding::Bound(Bound::Storage(BufferRange::whole(vk::Buffer::null())))
        });
        if let Some(motion) = &mut self.motion {
            debug_assert_eq!(bindings.len(), metaballs_motion::FIRST_BINDING);
            bindings.extend(motion.prepare(frame, &groups)?);
        }
        Ok(bindings)
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        let mut all = vec![&self.pipeline, &self.stream];
        all.extend(self.bin.iter().flat_map(BinPipelines::all));
        all.extend(self.device.iter().map(|d| &d.pipeline));
        all
    }

    fn record(&self, pass: &PassRecording) {
        let rec = pass.rec;
        // The game's balls into the table (its set is the last).
        if let Some(device) = &self.device {
            let set = pass.set(self.pipelines().len() - 1);
            metaballs_device::record(rec, device, set, self.frame_table, &self.copies);
        }
        // The tile lists, then one 8×8 workgroup per tile that holds any ball, TILES_PER_ROW
        // tiles per row (the bin state's first words: the scan or the host wrote them).
        if let Some(bin) = &self.bin {
            let bin_sets: Vec<vk::DescriptorSet> = (2..7).map(|i| pass.set(i)).collect();
            crate::passes::metaballs_bin::record(rec, bin, &bin_sets, &self.bin_params);
        }
        rec.bind_pipeline(&self.pipeline, pass.set(0));
        rec.push_constants(&self.pipeline, bytemuck::bytes_of(&self.params));
        rec.dispatch_indirect(self.frame_state, 0);
        // The tiles with a crowded pixel, listed by the first dispatch.
        rec.compute_to_indirect_barrier();
        rec.bind_pipeline(&self.stream, pass.set(1));
        rec.push_constants(&self.stream, bytemuck::bytes_of(&self.params));
        rec.dispatch_indirect(self.frame_dispatch, 0);
    }

    fn finished(&self, slot: usize, stats: &mut FrameStats) {
        if let (Binning::Device, Some(Some(bins))) = (self.binning, self.bin_buffers.get(slot)) {
            self.wanted.note(bins);
        }
        let c = self.counts(slot);
        stats.add(DROPPED, c.dropped);
        stats.add(HITS, c.hits);
        stats.add(CLIP_STEPS, c.clip_steps);
        stats.max(CLIP_STEPS_MAX, c.clip_steps_max);
        stats.add(STREAMED, c.streamed);
        if self.device.is_some() {
            stats.add(INVALID_BALLS, c.invalid_balls);
        }
        let last = self.warned_dropped.swap(c.dropped, std::sync::atomic::Ordering::Relaxed);
        if c.dropped > 0 && c.dropped != last {
            log::warn!(
                "metaballs: {} pixels could not finish their cast (the clipping did not converge, \
                 sphere tracing ran out of steps, or lavapipe's loop limit cut it): a surface may be \
                 missing there",
                c.dropped
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera {
            position: DVec3::new(0.0, 0.0, 10.0),
            look_at: DVec3::ZERO,
            up: DVec3::Y,
            fov_y_deg: 60.0,
            near: 0.1,
            far: 100.0,
            lens: Default::default(),
        }
    }

    const EXTENT: vk::Extent2D = vk::Extent2D { width: 100, height: 60 };

    /// Every pixel whose ray passes within the sphere lies in the tiles `sphere_tiles` gives.
    #[test]
    fn rectangles_cover_every_ray_through_the_sphere() {
        let cam = camera();
        let spheres = [
            (DVec3::new(0.0, 0.0, 0.0), 1.0),
            (DVec3::new(4.0, -2.0, 3.0), 0.7),
            (DVec3::new(-6.0, 3.0, -5.0), 2.5),
            (DVec3::new(1.0, 0.0, 9.0), 0.5), // across the edge of the view, close to the camera
            (DVec3::new(0.3, 0.2, 9.0), 0.95), // crosses the near plane: whole screen
        ];
        for (c, r) in spheres {
            let rect = sphere_tiles(&cam, EXTENT, c, r).expect("visible");
            let mut hit_any = false;
            for y in 0..EXTENT.height {
                for x in 0..EXTENT.width {
                    let (o, d) = cam.pixel_ray(x, y, EXTENT.width, EXTENT.height);
                    let w = c - o;
                    let passes = w.cross(d).length() <= r && w.dot(d) + r > 0.0;
                    if passes {
                        hit_any = true;
                        let (tx, ty) = (x / TILE, y / TILE);
                        assert!(
                            tx >= rect[0] && tx <= rect[2] && ty >= rect[1] && ty <= rect[3],
                            "sphere {c} r {r}: pixel ({x}, {y}) outside {rect:?}"
                        );
                    }
                }
            }
            assert!(hit_any);
        }
        // Tight: a small sphere at the centre covers few tiles.
        let rect = sphere_tiles(&cam, EXTENT, DVec3::ZERO, 0.2).unwrap();
        assert!(rect[2] - rect[0] <= 1 && rect[3] - rect[1] <= 1, "{rect:?}");
    }

    #[test]
    fn hidden_spheres_are_skipped() {
        let cam = camera();
        assert_eq!(sphere_tiles(&cam, EXTENT, DVec3::new(0.0, 0.0, 12.0), 1.0), None); // behind
        assert_eq!(sphere_tiles(&cam, EXTENT, DVec3::new(0.0, 0.0, 9.95), 0.01), None); // before near
        assert_eq!(sphere_tiles(&cam, EXTENT, DVec3::new(40.0, 0.0, 0.0), 1.0), None); // off screen
        assert_eq!(sphere_tiles(&cam, EXTENT, DVec3::new(0.0, 0.0, -200.0), 1.0), None); // past far
                                                                                         // Camera inside the sphere: whole screen.
        let (last_x, last_y) = (EXTENT.width.div_ceil(TILE) - 1, EXTENT.height.div_ceil(TILE) - 1);
        assert_eq!(sphere_tiles(&cam, EXTENT, DVec3::new(0.0, 0.0, 10.5), 1.0), Some([0, 0, last_x, last_y]));
    }

    #[test]
    fn lists_group_runs_by_group() {
        let cam = camera();
        let bins = |bounds: Vec<(DVec3, f64)>| GroupBins { keys: vec![0.0; bounds.len()], bounds, flags: 0 };
        let groups = vec![
            bins(vec![(DVec3::ZERO, 1.0), (DVec3::new(3.0, 0.0, 0.0), 1.0)]),
            bins(vec![(DVec3::new(0.5, 0.0, 0.0), 1.0), (DVec3::new(0.0, 0.0, 20.0), 1.0)]),
        ];
        let lists = bin_balls(&cam, EXTENT, &groups);
        let (tiles_x, tiles_y) = (EXTENT.width.div_ceil(TILE), EXTENT.height.div_ceil(TILE));
        assert_eq!((lists.tiles_x, lists.tiles_y), (tiles_x, tiles_y));
        let mut total = 0;
        for ty in 0..tiles_y {
            for tx in 0..tiles_x {
                let runs = lists.runs(tx, ty);
                let groups: Vec<u32> = runs.iter().map(|r| r.0).collect();
                let mut sorted = groups.clone();
                sorted.dedup();
                assert_eq!(groups, sorted, "one run per group");
                for (g, list) in runs {
                    assert!(!list.is_empty());
                    for &i in list {
                        assert!(if g == 0 { i < 2 } else { i == 2 }, "ball {i} in group {g}");
                    }
                    total += list.len();
                }
            }
        }
        assert_eq!(total, lists.entries.len());
        // The centre tile holds balls 0 and 2 (ball 3 is behind the camera).
        let centre = lists.runs(EXTENT.width / 2 / TILE, EXTENT.height / 2 / TILE);
        assert_eq!(centre.iter().map(|r| r.0).collect::<Vec<_>>(), vec![0, 1]);
        assert!(!lists.entries.contains(&3));
        // Only tiles with balls have headers, each naming its tile.
        let with_runs =
            (0..tiles_x * tiles_y).filter(|t| !lists.runs(t % tiles_x, t / tiles_x).is_empty()).count();
        assert_eq!(lists.active as usize, with_runs);
        assert!(lists.tiles[..with_runs].iter().all(|h| h[1] > 0 && h[2] < tiles_x && h[3] < tiles_y));
    }

    /// Within a run the entries follow the keys, and the flags reach the runs.
    #[test]
    fn runs_are_sorted_by_key_and_carry_flags() {
        let cam = camera();
        let bounds: Vec<(DVec3, f64)> =
            (0..12).map(|i| (DVec3::new(0.1 * i as f64, 0.0, -(i as f64)), 1.0)).collect();
        let keys: Vec<f64> = (0..12).map(|i| ((i * 7) % 12) as f64).collect();
        let lists =
            bin_balls(&cam, EXTENT, &[GroupBins { bounds, keys: keys.clone(), flags: RUN_LONE_BOUND }]);
        let (mut checked, runs) = (0, &lists.tiles[lists.active as usize..]);
        for run in runs {
            assert_eq!(run[3], RUN_LONE_BOUND);
            let list = &lists.entries[run[1] as usize..(run[1] + run[2]) as usize];
            assert!(list.windows(2).all(|w| keys[w[0] as usize] <= keys[w[1] as usize]), "{list:?}");
            checked += list.len();
        }
        assert!(checked >= 12);
    }

    /// RUN_CROWDED: the dense fluid (~58 supports deep on a point of its box) and a crowd of 150
    /// (`testing::crowded_metaballs`, ~38 deep) are crowded; the 4,096-ball swarm and one ball are
    /// not, nor is an empty group; n balls on one centre are n·π/6 deep, so 61 are not and 62
    /// are; the flag reaches the runs.
    #[test]
    fn crowded_groups_are_flagged() {
        let load =
            |path: &str| crate::scene::load_scene(std::path::Path::new(path)).unwrap().metaballs()[0].at(0.0);
        let dense = load("../../assets/scenes/metaballs_dense.toml");
        assert!(crowded(&dense));
        let mut swarm = load("../../assets/scenes/metaballs_4096.toml");
        assert!(!crowded(&swarm));
        let mut rng = crate::testing::Rng(3);
        assert!(crowded(&crate::testing::crowded_metaballs(&mut rng, 150)));
        swarm.balls.truncate(1);
        assert!(!crowded(&swarm));
        let ball = swarm.balls[0];
        swarm.balls = vec![ball; 61];
        assert!(!crowded(&swarm));
        swarm.balls.push(ball);
        assert!(crowded(&swarm));
        swarm.balls.clear();
        assert!(!crowded(&swarm));
        let bins = GroupBins::new(&dense, &camera(), EXTENT);
        assert_eq!(bins.flags & RUN_CROWDED, RUN_CROWDED);
        assert_eq!(
            GroupBins::new(&load("../../assets/scenes/metaballs_4096.toml"), &camera(), EXTENT).flags
                & RUN_CROWDED,
            0
        );
    }

    /// The keys bound every ray's entry into the support from below; flags need q ≥ 0 and a near
    /// plane clear of every support.
    #[test]
    fn group_bins_keys_and_flags() {
        use crate::effects::metaballs::{Ball, Kernel};
        use crate::scene::transform::{Transform, TransformOp};
        let cam = camera();
        let transform = Transform::from_ops(&[
            TransformOp::Scale(DVec3::new(1.5, 0.7, 1.0)),
            TransformOp::Translate(DVec3::new(0.5, 0.0, 1.0)),
        ])
        .unwrap();
        let mut group = MetaballGroupParams {
            threshold: 0.5,
            kernel: Kernel::Wyvill6,
            balls: vec![
                Ball { centre: DVec3::new(0.0, 0.0, 0.0), radius: 1.0, q: 1.0 },
                Ball { centre: DVec3::new(1.0, 1.0, -2.0), radius: 0.5, q: 0.7 },
            ],
            transform,
            method: Default::default(),
        };
        let bins = GroupBins::new(&group, &cam, EXTENT);
        assert_eq!(bins.flags, RUN_LONE_BOUND);
        let o = transform.inverse.transform_point3(cam.position);
        for (b, key) in group.balls.iter().zip(&bins.keys) {
            assert!((key - ((b.centre - o).length() - b.radius)).abs() < 1e-12);
        }
        group.balls[1].q = -0.2;
        assert_eq!(GroupBins::new(&group, &cam, EXTENT).flags, 0);
        group.balls[1].q = 1.0;
        group.balls[1].centre = transform.inverse.transform_point3(cam.position + DVec3::new(0.0, 0.0, -0.3));
        assert_eq!(GroupBins::new(&group, &cam, EXTENT).flags, 0, "a support reaching the near plane");
    }
}
