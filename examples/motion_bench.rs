//! What a temporal upscaler's inputs cost on a metaball scene: the scene rendered with motion
//! vectors on (`Renderer::set_motion_vectors`), each pass's GPU time as the p50 over the frames
//! after a warm-up frame. Numbers for docs/PERFORMANCE.md; not a timed test.
//!
//! LP_NUM_THREADS=2 cargo run --release --example motion_bench -- [--scene FILE] [--size N]
//! [--frames N] [--off] (defaults: assets/scenes/metaballs_4096.toml, 256, 10; `--off`: motion
//! vectors off, the baseline)

#[path = "common/bench_util.rs"]
mod bench_util;

use bench_util::{arg, percentile};
use hadou::{FrameRequest, Runtime, RuntimeOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene: String = arg("--scene").unwrap_or_else(|| "assets/scenes/metaballs_4096.toml".into());
    let size: u32 = arg("--size").unwrap_or(256);
    let frames: usize = arg("--frames").unwrap_or(10).max(1);
    let mut rt = Runtime::new(&RuntimeOptions::from_env())?;
    rt.load_scene(hadou::scene::load_scene(std::path::Path::new(&scene))?)?;
    let on = !std::env::args().any(|a| a == "--off");
    rt.renderer().set_motion_vectors(on)?;
    let mut request = FrameRequest::new(size, size);
    request.color = false;
    rt.render(&request)?;
    let mut times: std::collections::BTreeMap<String, Vec<f64>> = Default::default();
    for _ in 0..frames {
        for pass in rt.render(&request)?.stats.passes {
            times.entry(pass.name.to_string()).or_default().push(pass.gpu_ms);
        }
    }
    let state = if on { "on" } else { "off" };
    println!(
        "{scene} at {size}², motion vectors {state}, p50 of {frames} frames ({})",
        rt.device_info().name
    );
    println!("| pass | GPU ms |\n|---|---:|");
    for (name, t) in &times {
        println!("| {name} | {:.3} |", percentile(t, 0.5));
    }
    Ok(())
}
