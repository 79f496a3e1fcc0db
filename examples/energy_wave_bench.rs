//! Speed against error for the energy-wave pass at three sizes: the analytic closed form (every
//! pixel exact) with and without occluders, the same with a tolerance (1e-2, 1e-3, 1e-4; the
//! seed's scene and a distant wave that covers few pixels), then the ray-marched baseline at
//! several step counts, each compared per pixel with the f64 reference. The measurement is `hadou_cli::report::energy_wave::measure`, the
//! same code `hadou report` runs; this prints markdown tables.
//!
//! cargo run --release --example energy_wave_bench [-- --frames N]

use hadou::scene::WaveMethod;
use hadou::{Runtime, RuntimeOptions};
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
    Ok(())
}
