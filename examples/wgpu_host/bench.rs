//! `--bench`: the wgpu host's frame cost against the ash game prototype's — the same world (game
//! state, boxes, hadou scene), the same scripted play, the same size, two frames in flight, the
//! colour read back every frame by both — in one process, rounds alternating so that both see the
//! same machine load. Only ratios are meant to be compared across machines.

use std::time::Instant;

use ash::vk;

use super::device::WgpuVulkan;
use super::game::{thread_cpu_ms, Game};
use super::gpu::{GameVk, FRAMES_IN_FLIGHT};
use super::headless::{frame, script};
use super::host::{color_texture, WgpuHost};
use super::readback::Readback;

const DT: f64 = 1.0 / 30.0;
const WARMUP: usize = 10;

fn load() -> String {
    let text = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    text.split_whitespace().take(3).collect::<Vec<_>>().join(" ")
}

/// The sum of hadou's pass GPU times of its newest finished frame (ms).
fn hadou_gpu_ms(r: &hadou::Renderer) -> f64 {
    r.latest_timings().map_or(0.0, |t| t.passes.iter().map(|p| p.gpu_ms).sum())
}

/// Per frame, averaged over a round: wall time (every frame finished and read back), hadou's GPU
/// time (its timestamps), and the CPU time of the host's thread (update, record, submit, read).
#[derive(Clone, Copy, Default)]
struct Cost {
    wall: f64,
    gpu: f64,
    cpu: f64,
}

/// Runs `n` frames of `frame` on `state` and the final `drain`, returning their cost per frame.
fn measure<T>(
    n: usize,
    state: &mut T,
    frame: impl Fn(&mut T) -> Result<f64, String>,
    drain: impl FnOnce(&mut T) -> Result<(), String>,
) -> Result<Cost, String> {
    let (start, cpu, mut gpu) = (Instant::now(), thread_cpu_ms(), 0.0);
    for _ in 0..n {
        gpu += frame(state)?;
    }
    drain(state)?;
    let per = |x: f64| x / n as f64;
    Ok(Cost {
        wall: per(start.elapsed().as_secs_f64() * 1e3),
        gpu: per(gpu),
        cpu: per(thread_cpu_ms() - cpu),
    })
}

struct Wgpu {
    host: WgpuHost,
    color: wgpu::Texture,
    view: wgpu::TextureView,
    /// Per slot: the colour copy of the frame that last used it, read when the slot comes round.
    pending: Vec<Option<Readback>>,
    frame: usize,
}

impl Wgpu {
    fn one(&mut self) -> Result<f64, String> {
        self.host.update(&script(self.frame), DT)?;
        let slot = self.frame % self.pending.len();
        let readback = frame(&mut self.host, &self.color, &self.view)?;
        // begin_frame waited for this slot's previous frame: its copy maps without blocking.
        if let Some(done) = self.pending[slot].replace(readback) {
            done.read(&self.host.gpu.device)?;
        }
        self.frame += 1;
        Ok(hadou_gpu_ms(&self.host.world.as_ref().ok_or("no world")?.hadou))
    }

    fn drain(&mut self) -> Result<(), String> {
        self.host.wait_all()?;
        let pending: Vec<Readback> = self.pending.iter_mut().filter_map(Option::take).collect();
        pending.into_iter().try_for_each(|done| done.read(&self.host.gpu.device).map(drop))
    }

    fn frames(&mut self, n: usize) -> Result<Cost, String> {
        measure(n, self, Self::one, Self::drain)
    }
}

struct Ash {
    game: Game,
    /// The slime, handed to hadou from the host as the wgpu host does.
    slime: hadou::GroupId,
    extent: vk::Extent2D,
    frame: usize,
}

impl Ash {
    /// The prototype with its slime handed to hadou from the host each frame, as the wgpu host
    /// does (wgpu 26 gives no raw VkBuffer for hadou to read balls from): its own GPU slime is
    /// detached from hadou (its compute dispatch still runs, writing 5 balls nobody reads).
    fn new(extent: vk::Extent2D) -> Result<Ash, String> {
        let mut game = Game::new(GameVk::new(false, &[], &[], &|_, _, _, _| true)?)?;
        let slime = game.hadou.metaballs_named("slime").ok_or("no slime")?;
        game.hadou.set_metaball_buffer(slime, None).map_err(|e| e.to_string())?;
        Ok(Ash { game, slime, extent, frame: 0 })
    }

    fn one(&mut self) -> Result<f64, String> {
        self.game.update(&script(self.frame), DT)?;
        let balls = self.game.state.slime();
        self.game.hadou.set_metaball_group(self.slime, &balls).map_err(|e| e.to_string())?;
        self.game.offscreen_submit(self.extent, &[])?;
        self.frame += 1;
        Ok(hadou_gpu_ms(&self.game.hadou))
    }

    fn frames(&mut self, n: usize) -> Result<Cost, String> {
        measure(n, self, Self::one, |a| a.game.offscreen_finish().map(drop))
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

pub fn run((width, height): (u32, u32), frames: usize, rounds: usize) -> Result<(), String> {
    let load_before = load();
    let host = WgpuHost::new(WgpuVulkan::new(false)?, FRAMES_IN_FLIGHT)?;
    let color = color_texture(&host.gpu.device, width, height, wgpu::TextureFormat::Rgba8UnormSrgb);
    let view = color.create_view(&Default::default());
    let pending = (0..FRAMES_IN_FLIGHT).map(|_| None).collect();
    let mut w = Wgpu { host, color, view, pending, frame: 0 };
    let mut a = Ash::new(vk::Extent2D { width, height })?;
    // Pipelines compiled, caches warm, the first shots fired in both.
    w.frames(WARMUP)?;
    a.frames(WARMUP)?;
    println!("{width}x{height}, {frames} frames per round, {FRAMES_IN_FLIGHT} frames in flight; load {load_before}");
    println!("round | ms/frame ash wgpu ratio | hadou GPU ms ash wgpu | host thread CPU ms ash wgpu ratio");
    let mut rows = Vec::new();
    for round in 0..rounds {
        // Alternate which goes first, so that a drift in machine load falls on both.
        let (ac, wc) = if round % 2 == 0 {
            let x = a.frames(frames)?;
            (x, w.frames(frames)?)
        } else {
            let y = w.frames(frames)?;
            (a.frames(frames)?, y)
        };
        println!(
            "{round:>5} | {:>6.2} {:>6.2} {:>5.3} | {:>6.2} {:>6.2} | {:>5.2} {:>5.2} {:>5.3}",
            ac.wall,
            wc.wall,
            wc.wall / ac.wall,
            ac.gpu,
            wc.gpu,
            ac.cpu,
            wc.cpu,
            wc.cpu / ac.cpu
        );
        rows.push((ac, wc));
    }
    let col = |f: &dyn Fn(&(Cost, Cost)) -> f64| median(rows.iter().map(f).collect());
    println!(
        "median | {:.2} {:.2} {:.3} | {:.2} {:.2} | {:.2} {:.2} {:.3}; load after {}",
        col(&|r| r.0.wall),
        col(&|r| r.1.wall),
        col(&|r| r.1.wall / r.0.wall),
        col(&|r| r.0.gpu),
        col(&|r| r.1.gpu),
        col(&|r| r.0.cpu),
        col(&|r| r.1.cpu),
        col(&|r| r.1.cpu / r.0.cpu),
        load()
    );
    let Wgpu { host, color, view, .. } = w;
    drop((view, color));
    host.destroy();
    a.game.destroy();
    Ok(())
}
