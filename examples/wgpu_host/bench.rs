//! `--bench`: the wgpu host's frame cost against the ash game prototype's — the same world (game
//! state, boxes, hadou scene), the same scripted play, the same size, two frames in flight, the
//! colour read back every frame by both — in one process, rounds alternating so that both see the
//! same machine load. Only the ratio is meant to be compared across machines.

use std::time::Instant;

use ash::vk;

use super::device::WgpuVulkan;
use super::game::Game;
use super::gpu::GameVk;
use super::gpu::FRAMES_IN_FLIGHT;
use super::headless::{frame, script};
use super::host::{color_texture, WgpuHost};
use super::readback::Readback;

const DT: f64 = 1.0 / 30.0;
const WARMUP: usize = 10;

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default()
}

/// The sum of hadou's pass GPU times of its newest finished frame (ms).
fn hadou_gpu_ms(r: &hadou::Renderer) -> f64 {
    r.latest_timings().map_or(0.0, |t| t.passes.iter().map(|p| p.gpu_ms).sum())
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
    /// `n` frames, all finished and read back; returns (wall ms per frame, hadou GPU ms).
    fn frames(&mut self, n: usize) -> Result<(f64, f64), String> {
        let (start, mut gpu) = (Instant::now(), 0.0);
        for _ in 0..n {
            self.host.update(&script(self.frame), DT)?;
            let slot = self.frame % self.pending.len();
            let readback = frame(&mut self.host, &self.color, &self.view)?;
            // begin_frame waited for this slot's previous frame: its copy maps without blocking.
            if let Some(done) = self.pending[slot].replace(readback) {
                done.read(&self.host.gpu.device)?;
            }
            gpu += hadou_gpu_ms(&self.host.world.as_ref().ok_or("no world")?.hadou);
            self.frame += 1;
        }
        self.host.wait_all()?;
        for done in self.pending.iter_mut().filter_map(Option::take) {
            done.read(&self.host.gpu.device)?;
        }
        Ok((start.elapsed().as_secs_f64() * 1e3 / n as f64, gpu / n as f64))
    }
}

struct Ash {
    game: Game,
    extent: vk::Extent2D,
    frame: usize,
}

impl Ash {
    fn frames(&mut self, n: usize) -> Result<(f64, f64), String> {
        let (start, mut gpu) = (Instant::now(), 0.0);
        for _ in 0..n {
            self.game.update(&script(self.frame), DT)?;
            self.game.offscreen_submit(self.extent, &[])?;
            gpu += hadou_gpu_ms(&self.game.hadou);
            self.frame += 1;
        }
        self.game.offscreen_finish()?;
        Ok((start.elapsed().as_secs_f64() * 1e3 / n as f64, gpu / n as f64))
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

pub fn run((width, height): (u32, u32), frames: usize, rounds: usize) -> Result<(), String> {
    let load_before = load();
    let mut host = WgpuHost::new(WgpuVulkan::new(false)?, FRAMES_IN_FLIGHT)?;
    let color = color_texture(&host.gpu.device, width, height, wgpu::TextureFormat::Rgba8UnormSrgb);
    let view = color.create_view(&Default::default());
    host.state = Default::default();
    let pending = (0..FRAMES_IN_FLIGHT).map(|_| None).collect();
    let mut w = Wgpu { host, color, view, pending, frame: 0 };
    let game = Game::new(GameVk::new(false, &[], &[], &|_, _, _, _| true)?)?;
    let mut a = Ash { game, extent: vk::Extent2D { width, height }, frame: 0 };
    // Pipelines compiled, caches warm, the first shots fired in both.
    w.frames(WARMUP)?;
    a.frames(WARMUP)?;
    println!("{width}x{height}, {frames} frames per round, {FRAMES_IN_FLIGHT} frames in flight; load {load_before}");
    println!("round  ash ms/frame  wgpu ms/frame  wgpu/ash  (hadou GPU ms: ash, wgpu)");
    let mut ratios = Vec::new();
    let (mut ash_ms, mut wgpu_ms) = (Vec::new(), Vec::new());
    for round in 0..rounds {
        // Alternate which goes first, so a drift in machine load falls on both.
        let ((am, ag), (wm, wg)) = if round % 2 == 0 {
            let x = a.frames(frames)?;
            (x, w.frames(frames)?)
        } else {
            let y = w.frames(frames)?;
            (a.frames(frames)?, y)
        };
        println!("{round:>5}  {am:>12.2}  {wm:>13.2}  {:>8.3}  ({ag:.2}, {wg:.2})", wm / am);
        ratios.push(wm / am);
        ash_ms.push(am);
        wgpu_ms.push(wm);
    }
    println!(
        "median: ash {:.2} ms/frame, wgpu {:.2} ms/frame, wgpu/ash {:.3}; load after {}",
        median(ash_ms),
        median(wgpu_ms),
        median(ratios),
        load()
    );
    let Wgpu { host, color, view, .. } = w;
    drop((view, color));
    host.destroy();
    a.game.destroy();
    Ok(())
}
