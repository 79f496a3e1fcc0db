//! Speed against error for the energy-wave pass at three sizes: the analytic closed form (every
//! pixel exact) with and without occluders, the same with a tolerance (1e-2, 1e-3, 1e-4; the
//! seed's scene and a distant wave that covers few pixels), then the ray-marched baseline at
//! several step counts, each compared per pixel with the f64 reference. The measurement is `hadou_cli::report::energy_wave::measure`, the
//! same code `hadou report` runs; this prints markdown tables.
//!
//! cargo run --release --example energy_wave_bench [-- --frames N] [--store-only]
//!
//! `--store-only` prints only the last table: the pass with its `energy` AOV read back (stored)
//! and not (the store skipped), frames interleaved.

use hadou::scene::{Scene, WaveMethod};
use hadou::{Aov, FrameRequest, Runtime, RuntimeOptions};
use hadou_cli::report::energy_wave::{measure, with_method, with_tolerance, TIME, TOLERANCES};

const WARMUP: usize = 3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let frames: usize =
        std::env::args().skip_while(|a| a != "--frames").nth(1).and_then(|v| v.parse().ok()).unwrap_or(30);
    let mut runtime = Runtime::new(&RuntimeOptions::from_env())?;
    let info = runtime.device_info().clone();
    println!("device: {} ({}), {frames} frames per row after {WARMUP} warm-up\n", info.name, info.driver);
    let exact = |path: &str| hadou::scene::load_scene(path.as_ref()).map(|s| with_tolerance(&s, 0.0));
    let occluded = exact("assets/scenes/energy_wave.toml")?;
    let open = exact("assets/scenes/energy_wave_open.toml")?;
    // The seed's wave (as at time 1) 20 times farther from the camera, its beam cut to 2,000:
    // under a tenth of the image's width.
    let mut distant = occluded.clone();
    let camera = distant.camera.position;
    for wave in distant.waves_mut() {
        let at = wave.at(TIME);
        wave.origin = camera + (at.origin - camera) * 20.0;
        wave.length = 2000.0;
        wave.keyframes.clear();
    }
    distant.camera.far = 40000.0;
    if std::env::args().any(|a| a == "--store-only") {
        return store_table(&mut runtime, &occluded, frames);
    }

    println!("| size | no occluder (ms) | with occluders (ms) | max rel err | p99 rel err |");
    println!("|---|---:|---:|---:|---:|");
    for size in [(256, 256), (512, 512), (1920, 1080)] {
        let a = measure(&mut runtime, &open, size, WARMUP, frames, TIME)?;
        let b = measure(&mut runtime, &occluded, size, WARMUP, frames, TIME)?;
        println!(
            "| {}×{} | {:.3} | {:.3} | {:.1e} | {:.1e} |",
            size.0,
            size.1,
            a.p50_ms,
            b.p50_ms,
            a.max_rel.max(b.max_rel),
            a.p99_rel.max(b.p99_rel)
        );
    }

    println!("\nwith a tolerance (every wave at τ), with occluders; speed-up over exact in the same run:\n");
    println!("| scene | size | exact ms | τ | ms | speed-up | max rel err |");
    println!("|---|---|---:|---:|---:|---:|---:|");
    for (name, scene) in [("seed 004", &occluded), ("distant wave", &distant)] {
        for size in [(512, 512), (1920, 1080)] {
            let base = measure(&mut runtime, scene, size, WARMUP, frames, TIME)?;
            for tolerance in TOLERANCES {
                let m = measure(&mut runtime, &with_tolerance(scene, tolerance), size, WARMUP, frames, TIME)?;
                println!(
                    "| {name} | {}×{} | {:.3} | {tolerance:e} | {:.3} | {:.2}× | {:.1e} |",
                    size.0,
                    size.1,
                    base.p50_ms,
                    m.p50_ms,
                    base.p50_ms / m.p50_ms,
                    m.max_rel
                );
            }
        }
    }

    println!("\nraymarch baseline vs analytic, 512×512, with occluders (time {TIME}):\n");
    println!("| method | pass ms (p50) | max rel err | p99 rel err |");
    println!("|---|---:|---:|---:|");
    let analytic = measure(&mut runtime, &occluded, (512, 512), WARMUP, frames, TIME)?;
    println!("| analytic | {:.3} | {:.1e} | {:.1e} |", analytic.p50_ms, analytic.max_rel, analytic.p99_rel);
    for steps in [16, 64, 256, 1024] {
        let scene = with_method(&occluded, WaveMethod::Raymarch { steps, jitter: false });
        let m = measure(&mut runtime, &scene, (512, 512), WARMUP, frames.clamp(3, 10), TIME)?;
        println!("| raymarch N = {steps} | {:.3} | {:.1e} | {:.1e} |", m.p50_ms, m.max_rel, m.p99_rel);
    }
    store_table(&mut runtime, &occluded, frames)
}

/// The pass's p50 with `energy` read back (stored) and not, frames interleaved, exact and with a
/// tolerance: what a frame that reads no AOV saves.
fn store_table(
    runtime: &mut Runtime,
    scene: &Scene,
    frames: usize,
) -> Result<(), Box<dyn std::error::Error>> {
    println!("\nthe energy AOV read back or not (seed 004, with occluders), frames interleaved:\n");
    println!("| size | τ | read back: ms | not read: ms | speed-up |");
    println!("|---|---:|---:|---:|---:|");
    for size in [(512, 512), (1920, 1080)] {
        for tolerance in [0.0, 1e-3, 1e-2] {
            runtime.load_scene(with_tolerance(scene, tolerance))?;
            let mut request = FrameRequest::new(size.0, size.1);
            (request.time, request.color) = (TIME, false);
            let (mut read, mut skipped) = (Vec::new(), Vec::new());
            for i in 0..2 * (WARMUP + frames) {
                request.aovs = if i % 2 == 0 { vec![Aov::Energy] } else { Vec::new() };
                let stats = runtime.render(&request)?.stats;
                let ms =
                    stats.passes.iter().filter(|p| p.name == "energy_wave").map(|p| p.gpu_ms).sum::<f64>();
                if i >= 2 * WARMUP {
                    if i % 2 == 0 {
                        read.push(ms)
                    } else {
                        skipped.push(ms)
                    }
                }
            }
            let (a, b) = (median(&mut read), median(&mut skipped));
            println!("| {}×{} | {tolerance:e} | {a:.3} | {b:.3} | {:.2}× |", size.0, size.1, a / b);
        }
    }
    Ok(())
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}
