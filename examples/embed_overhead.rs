//! What embedding costs and what frames in flight buy: the game prototype's frame run headless
//! (the game's own raster, then hadou recorded into the game's command buffer, a simulated game
//! CPU frame of `--cpu-ms` between frames), once with 1 frame in flight (the game waits for each
//! frame before recording the next: what hadou allowed before frame slots) and once with 2.
//! Prints, per variant: the host's fence wait per frame for a slot, the time inside
//! `vkQueueSubmit` (lavapipe runs the frame's commands there, on the submitting thread),
//! `record_frame` p50/p99, frames per second, and the p50 of each of hadou's passes (GPU
//! timestamps of finished frames, never waited for) with the share of the embedded-only passes
//! (depth_import, composite).
//!
//! LP_NUM_THREADS=1 cargo run --release --example embed_overhead -- [--frames N] [--size WxH]
//! [--cpu-ms MS] [--png FILE (the last frame)] [--split] (split screen: two views of half the
//! width each, one hadou frame of both, `Renderer::record_views`)

#[path = "common/bench_util.rs"]
mod bench_util;
#[path = "game_prototype/game.rs"]
mod game;
#[path = "game_prototype/gpu.rs"]
mod gpu;
#[path = "game_prototype/painter.rs"]
mod painter;
#[path = "game_prototype/slime_sim.rs"]
mod slime_sim;

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use ash::vk;
use bench_util::{arg, percentile};
use game::{Game, Input};

const WARMUP: usize = 5;

/// Busy CPU work standing in for the game's own simulation and scene recording.
fn game_cpu_work(ms: f64) {
    let end = Instant::now() + Duration::from_secs_f64(ms / 1e3);
    let mut x = 1u64;
    while Instant::now() < end {
        x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
    }
}

fn main() -> Result<(), String> {
    let frames: usize = arg("--frames").unwrap_or(40);
    let cpu_ms: f64 = arg("--cpu-ms").unwrap_or(10.0);
    let size: String = arg("--size").unwrap_or_else(|| "640x360".into());
    let (w, h) = size
        .split_once('x')
        .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))
        .ok_or("--size WxH")?;
    let png: Option<String> = arg("--png");
    let split = std::env::args().any(|a| a == "--split");
    let extent = vk::Extent2D { width: w, height: h };
    let views = if split { ", split screen (two views)" } else { "" };
    println!(
        "{w}×{h}{views}, {frames} frames after {WARMUP} warm-up, {cpu_ms} ms of game CPU work per frame\n"
    );
    println!(
        "| frames in flight | fence wait / frame p50 | p99 | vkQueueSubmit p50 | record_frame p50 | p99 | frames/s | hadou GPU frame p50 |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut shares = Vec::new();
    for in_flight in [1usize, 2] {
        let vk = gpu::GameVk::new(false, &[], &[], &|_, _, _, _| true)?;
        let mut g = Game::with_frames_in_flight(vk, in_flight)?;
        g.split = split;
        let (mut waits, mut records, mut gpu, mut submits) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut per_pass: BTreeMap<String, Vec<f64>> = BTreeMap::new();
        let mut start = Instant::now();
        let mut last_seen = None;
        for i in 0..WARMUP + frames {
            if i == WARMUP {
                start = Instant::now();
            }
            // Charge for 0.9 s, then keep holding with time stopped: the same frame every time.
            g.update(&Input { charge: true, ..Input::default() }, if i < 9 { 0.1 } else { 0.0 })?;
            game_cpu_work(cpu_ms);
            g.offscreen_submit(extent, &[])?;
            if i < WARMUP {
                continue;
            }
            waits.push(g.vk.last_wait_ms);
            submits.push(g.vk.last_submit_ms);
            records.push(g.last_record_ms);
            if let Some(t) = g.hadou.latest_timings().filter(|t| Some(t.frame) != last_seen) {
                last_seen = Some(t.frame);
                let mut total = 0.0;
                for p in &t.passes {
                    per_pass.entry(p.name.clone()).or_default().push(p.gpu_ms);
                    total += p.gpu_ms;
                }
                gpu.push(total);
            }
        }
        let last = g.offscreen_finish()?;
        let fps = frames as f64 / start.elapsed().as_secs_f64();
        if let (2, Some(path), Some(frame)) = (in_flight, &png, last.last()) {
            hadou::output::write_png(path.as_ref(), w, h, &frame.color).map_err(|e| e.to_string())?;
        }
        let p = |v: &[f64], q| percentile(v, q);
        println!(
            "| {in_flight} | {:.2} ms | {:.2} ms | {:.2} ms | {:.3} ms | {:.3} ms | {fps:.1} | {:.2} ms |",
            p(&waits, 0.5),
            p(&waits, 0.99),
            p(&submits, 0.5),
            p(&records, 0.5),
            p(&records, 0.99),
            p(&gpu, 0.5)
        );
        shares.push((in_flight, per_pass, p(&gpu, 0.5)));
        let messages = g.destroy();
        let (errors, warnings) = messages.counts();
        if errors + warnings > 0 {
            return Err(format!("validation: {errors} errors, {warnings} warnings"));
        }
    }
    println!("\n| frames in flight | pass | p50 ms | share of hadou's GPU frame |");
    println!("|---:|---|---:|---:|");
    for (in_flight, per_pass, total) in shares {
        for (pass, ms) in per_pass {
            let m = percentile(&ms, 0.5);
            println!("| {in_flight} | {pass} | {m:.3} | {:.1} % |", 100.0 * m / total);
        }
    }
    Ok(())
}
