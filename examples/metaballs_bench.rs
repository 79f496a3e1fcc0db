//! The metaball pass's cost and Bézier-clipping statistics on the `generate` swarm of
//! assets/scenes/metaballs_4096.toml with 16 … 16,384 balls at 256² and 512² (numbers for
//! docs/PERFORMANCE.md; not a timed test).
//!
//! LP_NUM_THREADS=2 cargo run --release --example metaballs_bench

use hadou::{FrameRequest, Runtime, RuntimeOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::path::Path::new("assets/scenes/metaballs_4096.toml");
    let text = std::fs::read_to_string(path)?;
    let mut rt = Runtime::new(&RuntimeOptions::from_env())?;
    println!("device: {}", rt.device_info().name);
    println!("| balls | size | metaballs ms (p50 of 5) | hit pixels | clip steps per hit | max | dropped |");
    println!("|---:|---|---:|---:|---:|---:|---:|");
    for count in [16, 256, 4096, 16384] {
        let scene =
            hadou::scene::parse_scene(&text.replace("count = 4096", &format!("count = {count}")), path)?;
        for size in [256u32, 512] {
            rt.load_scene(scene.clone())?;
            let mut req = FrameRequest::new(size, size);
            req.color = false;
            rt.render(&req)?; // warm-up: shader JIT
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..5 {
                let s = rt.render(&req)?.stats;
                times.push(s.passes.iter().find(|p| p.name == "metaballs").map_or(0.0, |p| p.gpu_ms));
                last = Some(s);
            }
            times.sort_by(f64::total_cmp);
            let s = last.expect("five frames");
            println!(
                "| {count} | {size}² | {:.2} | {} | {:.2} | {} | {} |",
                times[2],
                s.metaball_hits,
                s.metaball_clip_steps as f64 / s.metaball_hits.max(1) as f64,
                s.metaball_clip_steps_max,
                s.metaball_overflow
            );
        }
    }
    Ok(())
}
