//! What embedding costs: the game prototype's frame run headless (the game's own raster, then
//! hadou recorded into the game's command buffer), with hadou's per-pass GPU times read from
//! `latest_timings` (never waited for). Prints the p50 of each pass and the share of the two
//! passes only an embedded frame has (depth_import, composite) in hadou's GPU frame.
//!
//! cargo run --release --example embed_overhead [-- --frames N] [--png FILE (the 512×512 frame)]

#[path = "game_prototype/game.rs"]
mod game;
#[path = "game_prototype/gpu.rs"]
mod gpu;
#[path = "game_prototype/painter.rs"]
mod painter;

use std::collections::BTreeMap;

use ash::vk;
use game::{Game, Input};

const WARMUP: usize = 3;

fn p50(values: &mut [f64]) -> f64 {
    values.sort_by(|a, b| a.total_cmp(b));
    values[values.len() / 2]
}

fn main() -> Result<(), String> {
    let frames: usize =
        std::env::args().skip_while(|a| a != "--frames").nth(1).and_then(|v| v.parse().ok()).unwrap_or(20);
    let png: Option<String> = std::env::args().skip_while(|a| a != "--png").nth(1);
    let vk = gpu::GameVk::new(false, &[], &[], &|_, _, _, _| true)?;
    let mut g = Game::new(vk)?;
    let name = g.hadou.context().info.name.clone();
    println!(
        "device: {name}; {frames} frames per size after {WARMUP} warm-up; the wave held at 60 % charge\n"
    );
    println!("| size | pass | p50 ms | share of hadou's GPU frame |");
    println!("|---|---|---:|---:|");
    for (w, h) in [(512u32, 512u32), (1920, 1080)] {
        let extent = vk::Extent2D { width: w, height: h };
        g.state = game::GameState::default();
        let mut per_pass: BTreeMap<String, Vec<f64>> = BTreeMap::new();
        let mut totals = Vec::new();
        for i in 0..WARMUP + frames {
            // Charge for 0.9 s, then keep holding with time stopped: the same frame every time.
            g.update(&Input { charge: true, ..Input::default() }, if i < 9 { 0.1 } else { 0.0 })?;
            g.offscreen_frame(extent, &[])?;
            if i < WARMUP {
                continue;
            }
            let Some(t) = g.hadou.latest_timings() else { continue };
            let mut total = 0.0;
            for p in t.passes.iter().filter(|p| p.name != "readback") {
                per_pass.entry(p.name.clone()).or_default().push(p.gpu_ms);
                total += p.gpu_ms;
            }
            totals.push(total);
        }
        if let (512, Some(path)) = (w, &png) {
            let frame = g.offscreen_frame(extent, &[])?;
            hadou::output::write_png(path.as_ref(), w, h, &frame.color).map_err(|e| e.to_string())?;
        }
        let total = p50(&mut totals);
        for (pass, mut ms) in per_pass {
            let m = p50(&mut ms);
            println!("| {w}×{h} | {pass} | {m:.3} | {:.1} % |", 100.0 * m / total);
        }
        println!("| {w}×{h} | hadou total | {total:.3} | 100 % |");
    }
    let messages = g.destroy();
    let (errors, warnings) = messages.counts();
    if errors + warnings > 0 {
        return Err(format!("validation: {errors} errors, {warnings} warnings"));
    }
    Ok(())
}
