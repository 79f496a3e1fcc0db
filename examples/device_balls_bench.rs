//! The host's per-frame work and the metaballs pass's GPU time with the `generate` swarm of
//! assets/scenes/metaballs_4096.toml at COUNT balls, three ways in one run: the balls on the host
//! binned on the host (the default), on the host binned on the device, and in a buffer of the
//! game's (`Renderer::set_metaball_buffer`: copied and completed on the device, binned there).
//! The game's buffer here is filled once from the host; hadou copies it every frame as it would
//! a simulation's. Numbers for docs/PERFORMANCE.md; not a timed test.
//!
//! LP_NUM_THREADS=2 cargo run --release --example device_balls_bench [-- COUNT [SIZE [FRAMES]]]

use hadou::effect::{Binning, Effects, EnergyWave, Metaballs, Translucency};
use hadou::effects::metaballs_f32::gpu_balls;
use hadou::gpu::memory::{Buffer, Memory, MemoryLocation};
use hadou::gpu::vk;
use hadou::{DeviceBall, DeviceBalls, FrameRequest, Runtime, RuntimeOptions};

fn runtime(binning: Binning) -> Result<Runtime, Box<dyn std::error::Error>> {
    let effects =
        Effects::none().with(Metaballs::with_binning(binning))?.with(Translucency)?.with(EnergyWave)?;
    Ok(Runtime::new(&RuntimeOptions { effects, ..RuntimeOptions::from_env() })?)
}

/// Medians over `frames` frames after 3 warm-up ones: (cpu record ms, metaballs GPU ms).
fn measure(rt: &mut Runtime, size: u32, frames: usize) -> Result<(f64, f64), Box<dyn std::error::Error>> {
    let mut req = FrameRequest::new(size, size);
    req.color = false;
    let (mut cpu, mut gpu) = (Vec::new(), Vec::new());
    for i in 0..frames + 3 {
        let stats = rt.render(&req)?.stats;
        if i >= 3 {
            cpu.push(stats.cpu_record_ms);
            gpu.push(stats.passes.iter().filter(|p| p.name == "metaballs").map(|p| p.gpu_ms).sum::<f64>());
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Ok((median(&mut cpu), median(&mut gpu)))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<u32> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let count = args.first().copied().unwrap_or(10_000);
    let size = args.get(1).copied().unwrap_or(256);
    let frames = args.get(2).copied().unwrap_or(20) as usize;
    let path = std::path::Path::new("assets/scenes/metaballs_4096.toml");
    let text = std::fs::read_to_string(path)?.replace("count = 4096", &format!("count = {count}"));
    let scene = hadou::scene::parse_scene(&text, path)?;
    println!("{count} balls, {size}², {frames} frames after 3 warm-up, medians\n");
    println!("| balls from | binned on | cpu record ms | metaballs GPU ms |");
    println!("|---|---|---:|---:|");
    for binning in [Binning::Host, Binning::Device] {
        let mut rt = runtime(binning)?;
        rt.load_scene(scene.clone())?;
        let (cpu, gpu) = measure(&mut rt, size, frames)?;
        println!("| the host | {binning:?} | {cpu:.3} | {gpu:.2} |");
    }
    // The same balls in a buffer of the "game's" (host-visible here, filled once).
    let mut rt = runtime(Binning::Host)?;
    rt.load_scene(scene.clone())?;
    let records: Vec<DeviceBall> = gpu_balls(&scene.metaballs()[0].at(0.0))
        .iter()
        .map(|b| DeviceBall { centre_radius: b.centre_radius, q: [b.coeffs[0], 0.0, 0.0, 0.0] })
        .collect();
    let memory = Memory::new(rt.context())?;
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
    let bytes: &[u8] = bytemuck::cast_slice(&records);
    let mut buffer: Buffer = memory.create_buffer(
        rt.context(),
        "game balls",
        bytes.len() as u64,
        usage,
        MemoryLocation::CpuToGpu,
    )?;
    buffer.write(0, bytes)?;
    let group = rt.renderer().metaballs_ids()[0];
    let source =
        DeviceBalls { buffer: buffer.raw, offset: 0, count: records.len() as u32, previous_centres: false };
    rt.renderer().set_metaball_buffer(group, Some(source))?;
    // A game whose balls live on the GPU keeps none on the host: one stands in for the f64 tools.
    let stand_in = hadou::Ball { centre: glam::DVec3::ZERO, radius: 1.0, q: 1.0 };
    rt.renderer().set_metaball_group(group, &[stand_in])?;
    let (cpu, gpu) = measure(&mut rt, size, frames)?;
    println!("| the game's buffer | Device | {cpu:.3} | {gpu:.2} |");
    rt.wait_all()?;
    // The buffer goes before the device it was made on.
    drop(buffer);
    drop(rt);
    Ok(())
}
