//! energy_wave: for every pixel, the closed-form line integral H of each wave along the view ray
//! from the camera to the first surface (the `distance` target) or the camera's far distance;
//! adds colour × intensity × H to the HDR colour and writes Σ H to the `energy` target.
//! `method = "raymarch"` waves are sampled instead (the baseline). CPU twins:
//! `effects::energy_wave` (f64) and `effects::energy_wave_f32` (the shader's arithmetic).
//!
//! Built in one of two variants ([`variant`]): exact (one dispatch, every pixel evaluated), or,
//! when every wave is analytic with a tolerance, the tile path of `energy_wave_tiles` (corners
//! exact, smooth tiles interpolated within the tolerance, the rest exact).

use super::energy_wave_tiles::{self, PathChoice, TileBuffers, TileGrid, TilePipelines};
use super::{Binding, FrameContext, Pass, PassRecording, Reader};
use crate::effects::energy_wave::effect::wave_tolerance;
use crate::effects::energy_wave::tolerance::tile_size;
use crate::effects::energy_wave::WaveParams;
use crate::effects::energy_wave_f32::{gpu_wave, GpuWave};
use crate::frame::FrameStats;
use crate::gpu::pipeline::{create_compute_pipeline, Bound, Pipeline};
use crate::gpu::shader::ShaderCompiler;
use crate::gpu::{vk, GpuContext, GpuResult};
use crate::scene::{Scene, WaveMethod, WaveState};
use crate::targets::Target;

/// How a wave is drawn: `WaveStyle` in shaders/energy_wave.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WaveStyle {
    /// rgb: colour × intensity; w: the cutoff.
    pub emission: [f32; 4],
    /// x: 0 analytic, 1 raymarch; y: steps; z: jitter (0/1).
    pub method: [u32; 4],
    /// x: the tolerance (0: exact); y, z, w: 0.
    pub adaptive: [f32; 4],
}

crate::gpu::layout::gpu_layout!(WaveStyle as "WaveStyle" { emission, method, adaptive });

/// Push constants (size checked against shaders/energy_wave.comp when the pipeline is made). The
/// camera's ray frame, the frame size and the far distance are the frame's uniforms
/// (`FrameUniforms`: `ray_right`, `ray_up`, `ray_forward`, `counts`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct EnergyWaveParams {
    /// x: the wave count (the live waves uploaded); with a tolerance y, z: the tile grid's
    /// size, w: the tile size (else 0).
    pub counts: [u32; 4],
    /// x: 1 when something reads `energy` after the pass (a later pass, or the host: else the
    /// AOV is not stored, a storage-image store per pixel saved); y, z, w: 0.
    pub flags: [u32; 4],
}

crate::gpu::layout::gpu_layout!(EnergyWaveParams as "EnergyWaveParams" { counts, flags });

const _: () = {
    assert!(std::mem::size_of::<WaveStyle>() == 48);
    assert!(std::mem::size_of::<EnergyWaveParams>() == 32);
};

/// The f64 parameters of a wave's state (what the references integrate).
pub fn wave_params(state: &WaveState) -> WaveParams {
    WaveParams {
        origin: state.origin,
        direction: state.direction,
        a: state.a,
        b: state.b,
        core: state.core,
        length: state.length,
    }
}

pub fn wave_style(state: &WaveState, method: WaveMethod, tolerance: f64) -> WaveStyle {
    let e = state.emission;
    let method = match method {
        WaveMethod::Analytic => [0, 0, 0, 0],
        WaveMethod::Raymarch { steps, jitter } => [1, steps, u32::from(jitter), 0],
    };
    let adaptive = [tolerance as f32, 0.0, 0.0, 0.0];
    WaveStyle { emission: [e.x as f32, e.y as f32, e.z as f32, state.cutoff as f32], method, adaptive }
}

/// The variant of the pass `scene` needs: "tolerance" when it has waves and every one is
/// analytic with a tolerance above 0 (`wave_tolerance`), else exact; " reactive" after
/// it with motion vectors on (the glow's share in the reactive mask).
pub fn variant(scene: &Scene) -> String {
    let tolerant =
        |w: &crate::scene::Wave| w.method == WaveMethod::Analytic && wave_tolerance(scene, w) > 0.0;
    let waves = scene.waves();
    let tolerance = !waves.is_empty() && waves.iter().all(tolerant);
    let reactive = scene.render.motion_vectors;
    format!("{}{}", if tolerance { "tolerance" } else { "" }, if reactive { " reactive" } else { "" })
}

/// The angle one pixel spans at the image's centre (the ray frame's right vector over half the
/// width): what the tile size is chosen by.
fn pixel_angle(scene: &Scene, extent: vk::Extent2D) -> f64 {
    let frame = scene.camera.ray_frame(extent.width, extent.height);
    frame.right.length() * 2.0 / f64::from(extent.width.max(1))
}

/// Tiles interpolated and evaluated exactly by the tile path, in `FrameStats`.
pub const TILES_INTERPOLATED: &str = "energy_wave.tiles_interpolated";
pub const TILES_EXACT: &str = "energy_wave.tiles_exact";

pub struct EnergyWavePass {
    pipeline: Pipeline,
    /// The tile path's pipelines, in the "tolerance" variant.
    tiles: Option<TilePipelines>,
    /// Per frame slot, the tile path's buffers (made for the frame's grid and wave count).
    buffers: Vec<Option<TileBuffers>>,
    params: EnergyWaveParams,
    /// The frame's size: the dispatch.
    extent: vk::Extent2D,
    /// The slot this frame records into.
    slot: usize,
    /// Per view (`FrameContext::view`): whether its frames take the tile path, from its own last
    /// counts. Per slot: whether its last frame took the tile path, and whose view it was.
    paths: Vec<PathChoice>,
    tiled_slots: Vec<(bool, usize)>,
    /// Writes the glow's share into the reactive mask (motion vectors on).
    reactive: bool,
}

impl EnergyWavePass {
    /// The pass; with `tolerance`, the tile path's pipelines too (the "tolerance" variant); with
    /// `reactive`, every pipeline that adds the glow writes its share (REACTIVE).
    pub fn new(
        ctx: &GpuContext,
        compiler: &mut ShaderCompiler,
        tolerance: bool,
        reactive: bool,
    ) -> GpuResult<Self> {
        let defines: &[(&str, &str)] = if reactive { &[("REACTIVE", "1")] } else { &[] };
        let spirv = compiler.compile("energy_wave.comp", defines)?;
        let push = std::mem::size_of::<EnergyWaveParams>() as u32;
        let pipeline = create_compute_pipeline(ctx, "energy_wave", &spirv, push)?;
        let tiles = if tolerance { Some(TilePipelines::new(ctx, compiler, push, defines)?) } else { None };
        let extent = vk::Extent2D::default();
        Ok(EnergyWavePass {
            pipeline,
            tiles,
            buffers: Vec::new(),
            params: EnergyWaveParams::default(),
            extent,
            slot: 0,
            paths: Vec::new(),
            tiled_slots: Vec::new(),
            reactive,
        })
    }

    /// The tile path's buffers for this frame's slot, made (again) when the grid or the wave
    /// count changed, reset for the frame.
    fn tile_buffers(&mut self, frame: &FrameContext, grid: TileGrid, waves: u32) -> GpuResult<&TileBuffers> {
        if self.buffers.len() <= frame.slot {
            self.buffers.resize_with(frame.slot + 1, || None);
        }
        let fits = self.buffers[frame.slot].as_ref().is_some_and(|b| b.fits(grid, waves));
        if !fits {
            self.buffers[frame.slot] = Some(TileBuffers::new(frame.ctx, frame.memory, grid, waves)?);
        }
        let buffers = self.buffers[frame.slot].as_mut().expect("made above");
        buffers.reset()?;
        Ok(buffers)
    }
}

impl Pass for EnergyWavePass {
    fn name(&self) -> &'static str {
        "energy_wave"
    }

    fn prepare(&mut self, frame: &mut FrameContext) -> GpuResult<Vec<Binding>> {
        let scene = frame.scene;
        let camera = scene.camera.position;
        // A wave with a = b = 0 integrates to 0 everywhere: it is not uploaded or looped over.
        let live: Vec<(WaveState, WaveMethod, f64)> = scene
            .waves()
            .iter()
            .map(|w| (w.at(frame.time), w.method, wave_tolerance(scene, w)))
            .filter(|(s, _, _)| s.a != 0.0 || s.b != 0.0)
            .collect();
        let waves: Vec<GpuWave> = live.iter().map(|(s, _, _)| gpu_wave(&wave_params(s), camera)).collect();
        // The glow is pre-exposed as the frame's other radiances (`effects::tonemap::pre_exposure`).
        let p = frame.pre_exposure;
        let styles: Vec<WaveStyle> = live
            .iter()
            .map(|(s, m, t)| wave_style(&WaveState { emission: s.emission * p, ..*s }, *m, *t))
            .collect();
        // The tile pipelines' sets need the tile buffers even in a frame that runs exact.
        // Bound whenever the tile pipelines exist (their sets are written every frame), even in a
        // frame whose waves are all off (a = b = 0: none uploaded), which runs exact.
        let tile_buffers = self.tiles.is_some();
        if self.paths.len() <= frame.view {
            self.paths.resize_with(frame.view + 1, PathChoice::default);
        }
        let tiled = tile_buffers && !waves.is_empty() && self.paths[frame.view].tiled();
        if self.tiled_slots.len() <= frame.slot {
            self.tiled_slots.resize(frame.slot + 1, (false, 0));
        }
        self.tiled_slots[frame.slot] = (tiled, frame.view);
        let least = live.iter().map(|(_, _, t)| *t).fold(f64::INFINITY, f64::min);
        let grid = TileGrid::of(frame.extent, tile_size(pixel_angle(scene, frame.extent), least));
        self.params = if tiled {
            EnergyWaveParams {
                counts: [waves.len() as u32, grid.tiles_x, grid.tiles_y, grid.size],
                flags: [0; 4],
            }
        } else {
            EnergyWaveParams { counts: [waves.len() as u32, 0, 0, 0], flags: [0; 4] }
        };
        self.extent = frame.extent;
        self.slot = frame.slot;
        // The shader reads wave 0 before its loop (count 0 still binds one, zeroed, unused).
        let (waves, styles) = if waves.is_empty() {
            (vec![bytemuck::Zeroable::zeroed()], vec![WaveStyle::default()])
        } else {
            (waves, styles)
        };
        let mut bindings = vec![
            Binding::read(Target::Distance),
            Binding::read_write(Target::Hdr),
            Binding::write(Target::Energy),
            Binding::Bound(Bound::Storage(frame.upload(&waves)?)),
            Binding::Bound(Bound::Storage(frame.upload(&styles)?)),
            Binding::Bound(Bound::Uniform(frame.uniforms)),
        ];
        if tile_buffers {
            let [corners, lists, state] = self.tile_buffers(frame, grid, waves.len() as u32)?.ranges();
            // The state is also the exact tiles' indirect dispatch (its barrier is recorded by
            // `energy_wave_tiles::record`); declared for the host, which reads the counts.
            bindings.extend([
                Binding::Written(corners, Reader::Compute),
                Binding::Written(lists, Reader::Compute),
                Binding::Written(state, Reader::Host),
            ]);
        }
        if self.reactive {
            // Binding 9; without the tile buffers 6–8 hold nothing (the exact pass declares none).
            bindings.resize(9, Binding::Bound(Bound::Unused));
            bindings.push(Binding::write(Target::Reactive));
        }
        Ok(bindings)
    }

    fn pipelines(&self) -> Vec<&Pipeline> {
        let mut all = vec![&self.pipeline];
        all.extend(self.tiles.iter().flat_map(TilePipelines::all));
        all
    }

    fn record(&self, pass: &PassRecording) {
        let params = EnergyWaveParams {
            flags: [u32::from(pass.is_read_after(Target::Energy)), 0, 0, 0],
            ..self.params
        };
        let push = bytemuck::bytes_of(&params);
        let buffers = self.buffers.get(self.slot).and_then(Option::as_ref);
        if let (Some(tiles), Some(buffers), true) = (&self.tiles, buffers, self.params.counts[3] > 0) {
            let sets: Vec<vk::DescriptorSet> = (1..7).map(|i| pass.set(i)).collect();
            let [_, tiles_x, tiles_y, size] = self.params.counts;
            let grid = TileGrid { tiles_x, tiles_y, size };
            energy_wave_tiles::record(pass.rec, tiles, &sets, push, grid, self.extent, buffers.state.raw);
            return;
        }
        let vk::Extent2D { width, height } = self.extent;
        pass.rec.bind_pipeline(&self.pipeline, pass.set(0));
        pass.rec.push_constants(&self.pipeline, push);
        pass.rec.dispatch_2d(width, height, (8, 8));
    }

    fn finished(&self, slot: usize, stats: &mut FrameStats) {
        let (tiled, view) = self.tiled_slots.get(slot).copied().unwrap_or((false, 0));
        if let (true, Some(Some(buffers)), Some(path)) = (tiled, self.buffers.get(slot), self.paths.get(view))
        {
            let (interpolated, exact) = buffers.counts();
            path.note(interpolated, exact);
            stats.add(TILES_INTERPOLATED, interpolated);
            stats.add(TILES_EXACT, exact);
        }
    }
}
