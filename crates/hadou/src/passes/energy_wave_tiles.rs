//! The energy wave with a tolerance (`effects::energy_wave::tolerance`): four dispatches instead
//! of one per pixel — the exact H at the corners of T×T-pixel tiles (T = 4 or 8)
//! (shaders/energy_wave_corners.comp), one invocation per tile deciding from the error bound
//! whether it may be interpolated (energy_wave_classify.comp: a flag per tile, and the exact
//! tiles appended to a list), then the interpolated tiles (energy_wave_interp.comp, over the whole
//! frame: the pixels of exact tiles skip their stores) and the exact ones (energy_wave.comp with
//! `TILE_LIST`, an indirect dispatch over the list). Every pixel is written by exactly one of the
//! last two.

use std::sync::atomic::{AtomicU32, Ordering};

use crate::effects::energy_wave::tolerance::TILE_SIZES;
use crate::gpu::memory::{Buffer, Memory, MemoryLocation};
use crate::gpu::pipeline::{create_compute_pipeline, BufferRange, Pipeline};
use crate::gpu::recorder::Recorder;
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};

/// Workgroups per row of the indirect dispatches (WAVE_TILES_PER_ROW in
/// common/energy_wave_tiles.glsl).
pub const TILES_PER_ROW: u32 = 64;

/// Words of the tile state: the interpolated tiles' count (word 3), the exact tiles' indirect
/// dispatch (x, y, z: words 4–6) and count (keep in sync with the shaders' `state`).
const STATE_INTERPOLATED: usize = 3;
const STATE_EXACT: usize = 7;
/// The state at the start of a frame: no tile counted, rows of `TILES_PER_ROW` (none yet).
const STATE_START: [u32; 8] = [0, 0, 0, 0, TILES_PER_ROW, 0, 1, 0];

/// Whether a frame takes the tile path. It pays for itself only where most tiles are
/// interpolated (corners, classification and a pass over every pixel come first: on lavapipe at
/// 1920×1080 with 96 % of the tiles interpolated the path costs 55–58 % of the exact pass,
/// docs/PERFORMANCE.md), so after a frame that interpolated fewer than
/// `BREAK_EVEN_PERMILLE`‰ of its tiles the exact pass runs, and the tile path is tried again every
/// `PROBE_EVERY` frames (the camera or the waves may have moved). A game's frame is never more
/// than one probe in `PROBE_EVERY` slower than the exact pass.
#[derive(Debug)]
pub struct PathChoice {
    /// The last tiled frame's interpolated tiles in ‰ (`u32::MAX`: none finished yet).
    last: AtomicU32,
    frame: u32,
}

/// Half the tiles: a ~0.5 overhead plus the exact tiles' share makes the tile path then cost about
/// as much as the exact pass (docs/PERFORMANCE.md, "Energy wave with a tolerance").
pub const BREAK_EVEN_PERMILLE: u32 = 500;
pub const PROBE_EVERY: u32 = 30;

impl Default for PathChoice {
    fn default() -> Self {
        PathChoice { last: AtomicU32::new(u32::MAX), frame: 0 }
    }
}

impl PathChoice {
    /// This frame's choice.
    pub fn tiled(&mut self) -> bool {
        let probe = self.frame % PROBE_EVERY == 0;
        self.frame = self.frame.wrapping_add(1);
        let last = self.last.load(Ordering::Relaxed);
        probe || last == u32::MAX || last >= BREAK_EVEN_PERMILLE
    }

    /// A tiled frame finished with these counts.
    pub fn note(&self, interpolated: u64, exact: u64) {
        if let Some(permille) = (interpolated * 1000).checked_div(interpolated + exact) {
            self.last.store(permille as u32, Ordering::Relaxed);
        }
    }
}

/// The tile grid of a frame of `extent` with tiles of `size` pixels a side.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TileGrid {
    pub tiles_x: u32,
    pub tiles_y: u32,
    pub size: u32,
}

impl TileGrid {
    pub fn of(extent: vk::Extent2D, size: u32) -> TileGrid {
        TileGrid { tiles_x: extent.width.div_ceil(size), tiles_y: extent.height.div_ceil(size), size }
    }

    pub fn tiles(self) -> u32 {
        self.tiles_x * self.tiles_y
    }

    /// Corners: (tiles_x + 1) × (tiles_y + 1).
    pub fn corners(self) -> u64 {
        u64::from(self.tiles_x + 1) * u64::from(self.tiles_y + 1)
    }
}

pub struct TilePipelines {
    corners: Pipeline,
    classify: Pipeline,
    /// Per tile size (`TILE_SIZES`): the workgroup is one tile.
    interpolate: [Pipeline; 2],
    exact: [Pipeline; 2],
}

impl TilePipelines {
    /// The pipelines; `extra` defines go to those that add the glow (REACTIVE).
    pub fn new(
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        push: u32,
        extra: &[(&str, &str)],
    ) -> GpuResult<TilePipelines> {
        let mut make = |name: &str, file: &str, defines: &[(&str, &str)]| {
            let spirv = compiler.compile(file, defines)?;
            create_compute_pipeline(ctx, name, &spirv, push)
        };
        let [small, large] = TILE_SIZES.map(|t| t.to_string());
        let with = |defines: &[(&'static str, &'static str)], tile: &str| -> Vec<(String, String)> {
            let mut all: Vec<(String, String)> =
                defines.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
            all.push(("WAVE_TILE".into(), tile.into()));
            all.extend(extra.iter().map(|(k, v)| (k.to_string(), v.to_string())));
            all
        };
        let (i4, i8) = (with(&[], &small), with(&[], &large));
        let (e4, e8) = (with(&[("TILE_LIST", "1")], &small), with(&[("TILE_LIST", "1")], &large));
        Ok(TilePipelines {
            corners: make("energy_wave corners", "energy_wave_corners.comp", &[])?,
            classify: make("energy_wave classify", "energy_wave_classify.comp", &[])?,
            interpolate: [
                make("energy_wave interpolate 4", "energy_wave_interp.comp", &refs(&i4))?,
                make("energy_wave interpolate 8", "energy_wave_interp.comp", &refs(&i8))?,
            ],
            exact: [
                make("energy_wave exact tiles 4", "energy_wave.comp", &refs(&e4))?,
                make("energy_wave exact tiles 8", "energy_wave.comp", &refs(&e8))?,
            ],
        })
    }

    /// In the order of the sets `record` takes (after the pass's own pipeline).
    pub fn all(&self) -> Vec<&Pipeline> {
        let [i4, i8] = &self.interpolate;
        let [e4, e8] = &self.exact;
        vec![&self.corners, &self.classify, i4, i8, e4, e8]
    }
}

/// One frame slot's buffers.
pub struct TileBuffers {
    grid: TileGrid,
    waves: u32,
    /// Per corner: L, then H per wave.
    pub corners: Buffer,
    /// A flag per tile (1: interpolated), then the list of the exact tiles.
    pub lists: Buffer,
    /// Host-visible: the counts and the exact tiles' dispatch (`STATE_START` each frame).
    pub state: Buffer,
}

impl TileBuffers {
    pub fn new(ctx: &GpuContext, memory: &Memory, grid: TileGrid, waves: u32) -> GpuResult<TileBuffers> {
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let corner_bytes = 4 * grid.corners() * u64::from(waves + 1);
        let gpu = MemoryLocation::GpuOnly;
        Ok(TileBuffers {
            grid,
            waves,
            corners: memory.create_buffer(ctx, "energy_wave corners", corner_bytes, storage, gpu)?,
            lists: memory.create_buffer(
                ctx,
                "energy_wave tiles",
                8 * u64::from(grid.tiles()).max(1),
                storage,
                gpu,
            )?,
            state: memory.create_buffer(
                ctx,
                "energy_wave tile state",
                32,
                storage | vk::BufferUsageFlags::INDIRECT_BUFFER,
                MemoryLocation::GpuToCpu,
            )?,
        })
    }

    pub fn fits(&self, grid: TileGrid, waves: u32) -> bool {
        self.grid == grid && self.waves == waves
    }

    /// The frame starts with empty lists (the slot's previous frame has finished).
    pub fn reset(&mut self) -> GpuResult<()> {
        self.state.write(0, bytemuck::cast_slice(&STATE_START))
    }

    pub fn ranges(&self) -> [BufferRange; 3] {
        [self.corners.raw, self.lists.raw, self.state.raw].map(BufferRange::whole)
    }

    /// (interpolated, exact) tiles of the slot's last finished frame.
    pub fn counts(&self) -> (u64, u64) {
        let Some(bytes) = self.state.mapped() else { return (0, 0) };
        let word = |i: usize| u32::from_le_bytes(bytes[4 * i..4 * i + 4].try_into().unwrap_or([0; 4])) as u64;
        (word(STATE_INTERPOLATED), word(STATE_EXACT))
    }
}

/// Records the four dispatches; `sets` are those of `TilePipelines::all`, `push` the pass's
/// push constants, `state` the slot's state buffer.
pub fn record(
    rec: &Recorder,
    p: &TilePipelines,
    sets: &[vk::DescriptorSet],
    push: &[u8],
    grid: TileGrid,
    extent: vk::Extent2D,
    state: vk::Buffer,
) {
    let set = |i: usize| sets.get(i).copied().unwrap_or_default();
    rec.bind_pipeline(&p.corners, set(0));
    rec.push_constants(&p.corners, push);
    rec.dispatch_2d(grid.tiles_x + 1, grid.tiles_y + 1, (8, 8));
    rec.compute_to_compute_barrier();
    rec.bind_pipeline(&p.classify, set(1));
    rec.push_constants(&p.classify, push);
    rec.dispatch_groups(grid.tiles().div_ceil(64), 1);
    rec.compute_to_indirect_barrier();
    // The variants of this frame's tile size.
    let v = usize::from(grid.size == TILE_SIZES[1]);
    // The interpolated tiles: the whole frame, each pixel of an exact tile skipping its stores.
    rec.bind_pipeline(&p.interpolate[v], set(2 + v));
    rec.push_constants(&p.interpolate[v], push);
    rec.dispatch_2d(extent.width, extent.height, (8, 8));
    // The two write disjoint pixels of the same images: ordered for the validation layers.
    rec.compute_to_compute_barrier();
    rec.bind_pipeline(&p.exact[v], set(4 + v));
    rec.push_constants(&p.exact[v], push);
    rec.dispatch_indirect(state, 16);
}

/// Owned defines as the compiler takes them.
fn refs(defines: &[(String, String)]) -> Vec<(&str, &str)> {
    defines.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect()
}
