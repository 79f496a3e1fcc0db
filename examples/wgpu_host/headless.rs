//! Headless mode: the game's scripted play (charge, fire) rendered into a wgpu texture, two frames
//! in flight, the last frame read back and written as PNG.
#![allow(dead_code)]

use super::device::WgpuVulkan;
use super::game::Input;
use super::gpu::FRAMES_IN_FLIGHT;
use super::host::{color_texture, WgpuHost};
use super::readback::Readback;

/// The scripted input of frame `i`: charge for 20 frames, release (fire), walk a little.
pub fn script(i: usize) -> Input {
    Input { charge: i % 45 < 20, left: i % 90 >= 60, right: i % 90 < 20, reset: false }
}

/// One headless frame into `color` (wgpu's content, then hadou's), its colour copied for reading.
pub fn frame(
    host: &mut WgpuHost,
    color: &wgpu::Texture,
    view: &wgpu::TextureView,
) -> Result<Readback, String> {
    let mut encoder = host.begin_frame()?;
    host.record_game(&mut encoder, color, view)?;
    let recorded = host.record_hadou(&mut encoder, color, view)?;
    let readback = Readback::record(&host.gpu.device, &mut encoder, color, wgpu::TextureAspect::All);
    host.submit(encoder, recorded);
    Ok(readback)
}

pub fn run((width, height): (u32, u32), frames: usize, out: &std::path::Path) -> Result<(), String> {
    let validation = std::env::var("HADOU_VALIDATION").is_ok_and(|v| v == "1");
    let mut host = WgpuHost::new(WgpuVulkan::new(validation)?, FRAMES_IN_FLIGHT)?;
    let color = color_texture(&host.gpu.device, width, height, wgpu::TextureFormat::Rgba8UnormSrgb);
    let view = color.create_view(&Default::default());
    let mut last = None;
    for i in 0..frames.max(1) {
        host.update(&script(i), 1.0 / 30.0)?;
        last = Some(frame(&mut host, &color, &view)?);
    }
    let pixels = last.ok_or("no frame")?.read(&host.gpu.device)?;
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
    }
    image::save_buffer(out, &pixels, width, height, image::ColorType::Rgba8).map_err(|e| e.to_string())?;
    drop((view, color));
    let messages = host.destroy();
    let (errors, warnings) = messages.counts();
    println!(
        "{frames} frames at {width}x{height} -> {}; validation: {errors} errors, {warnings} warnings",
        out.display()
    );
    Ok(())
}
