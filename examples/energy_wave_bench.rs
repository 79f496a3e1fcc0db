//! Speed against error for the energy-wave pass: the analytic closed form vs the ray-marched
//! baseline at several step counts, each timed over many frames and compared per pixel with the
//! f64 reference. Prints markdown tables (docs/PERFORMANCE.md quotes them).
//!
//! cargo run --release --example energy_wave_bench [-- --frames N]

use hadou::effects::energy_wave::line_integral;
use hadou::passes::energy_wave::wave_params;
use hadou::profile::Summary;
use hadou::scene::{Scene, WaveMethod};
use hadou::{Aov, FrameRequest, Runtime, RuntimeOptions};

struct Measured {
    p50_ms: f64,
    max_rel: f64,
    p99_rel: f64,
}

fn reference(scene: &Scene, depth: &[f32], w: u32, h: u32, time: f64) -> Vec<f64> {
    let states: Vec<_> = scene.waves.iter().map(|wave| wave_params(&wave.at(time))).collect();
    let cam = &scene.camera;
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (o, u) = cam.pixel_ray(x, y, w, h);
            let l = (depth[(y * w + x) as usize] as f64).min(cam.far);
            states.iter().map(|p| line_integral(p, o, u, l)).sum()
        })
        .collect()
}

fn measure(runtime: &mut Runtime, scene: &Scene, size: (u32, u32), frames: usize, time: f64) -> Measured {
    runtime.load_scene(scene.clone()).expect("load");
    let mut req = FrameRequest::new(size.0, size.1);
    req.time = time;
    req.color = false;
    let mut times = Vec::new();
    for i in 0..frames + 3 {
        let stats = runtime.render(&req).expect("render").stats;
        if i >= 3 {
            times.extend(stats.passes.iter().filter(|p| p.name == "energy_wave").map(|p| p.gpu_ms));
        }
    }
    req.aovs = vec![Aov::Energy, Aov::Depth];
    let frame = runtime.render(&req).expect("render");
    let energy = &frame.aov(Aov::Energy).unwrap().data;
    let depth = &frame.aov(Aov::Depth).unwrap().data;
    let refs = reference(scene, depth, size.0, size.1, time);
    let mut rel: Vec<f64> = energy
        .iter()
        .zip(&refs)
        .map(|(&g, &r)| if r > 0.0 { (g as f64 - r).abs() / r } else { g.abs() as f64 })
        .collect();
    rel.sort_by(|a, b| a.total_cmp(b));
    let p99 = rel[((rel.len() as f64 * 0.99).ceil() as usize).clamp(1, rel.len()) - 1];
    Measured {
        p50_ms: Summary::of(&times).map(|s| s.p50).unwrap_or(f64::NAN),
        max_rel: rel[rel.len() - 1],
        p99_rel: p99,
    }
}

fn with_method(scene: &Scene, method: WaveMethod) -> Scene {
    let mut s = scene.clone();
    s.waves.iter_mut().for_each(|w| w.method = method);
    s
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let frames: usize =
        std::env::args().skip_while(|a| a != "--frames").nth(1).and_then(|v| v.parse().ok()).unwrap_or(30);
    let mut runtime = Runtime::new(&RuntimeOptions::from_env())?;
    let info = runtime.device_info().clone();
    println!("device: {} ({}), {frames} frames per row after 3 warm-up\n", info.name, info.driver);
    let occluded = hadou::scene::load_scene("assets/scenes/energy_wave.toml".as_ref())?;
    let open = hadou::scene::load_scene("assets/scenes/energy_wave_open.toml".as_ref())?;

    println!("| size | no occluder (ms) | with occluders (ms) | max rel err | p99 rel err |");
    println!("|---|---:|---:|---:|---:|");
    for size in [(256, 256), (512, 512), (1920, 1080)] {
        let a = measure(&mut runtime, &open, size, frames, 1.0);
        let b = measure(&mut runtime, &occluded, size, frames, 1.0);
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

    println!("\nraymarch baseline vs analytic, 512×512, with occluders (time 1):\n");
    println!("| method | pass ms (p50) | max rel err | p99 rel err |");
    println!("|---|---:|---:|---:|");
    let analytic = measure(&mut runtime, &occluded, (512, 512), frames, 1.0);
    println!("| analytic | {:.3} | {:.1e} | {:.1e} |", analytic.p50_ms, analytic.max_rel, analytic.p99_rel);
    for steps in [16, 64, 256, 1024] {
        let scene = with_method(&occluded, WaveMethod::Raymarch { steps, jitter: false });
        let m = measure(&mut runtime, &scene, (512, 512), frames.clamp(3, 10), 1.0);
        println!("| raymarch N = {steps} | {:.3} | {:.1e} | {:.1e} |", m.p50_ms, m.max_rel, m.p99_rel);
    }
    Ok(())
}
