//! Speed against error for the energy-wave pass at three sizes: the analytic closed form with and
//! without occluders, then the ray-marched baseline at several step counts, each compared per
//! pixel with the f64 reference. The measurement is `hadou_cli::report::energy_wave::measure`, the
//! same code `hadou report` runs; this prints markdown tables.
//!
//! cargo run --release --example energy_wave_bench [-- --frames N]

use hadou::scene::WaveMethod;
use hadou::{Runtime, RuntimeOptions};
use hadou_cli::report::energy_wave::{measure, with_method, TIME};

const WARMUP: usize = 3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let frames: usize =
        std::env::args().skip_while(|a| a != "--frames").nth(1).and_then(|v| v.parse().ok()).unwrap_or(30);
    let mut runtime = Runtime::new(&RuntimeOptions::from_env())?;
    let info = runtime.device_info().clone();
    println!("device: {} ({}), {frames} frames per row after {WARMUP} warm-up\n", info.name, info.driver);
    let occluded = hadou::scene::load_scene("assets/scenes/energy_wave.toml".as_ref())?;
    let open = hadou::scene::load_scene("assets/scenes/energy_wave_open.toml".as_ref())?;

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
