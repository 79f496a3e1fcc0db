//! hadou recorded into a wgpu frame (examples/wgpu_host), headless on lavapipe, validation and
//! synchronization validation on (wgpu's instance, our messenger, alive until after the device is
//! destroyed, so leaks count): zero errors, zero warnings.
//! Each frame's pixels are compared with hadou's ash embedding path (the game prototype's device)
//! recording the same frame onto the same input images — wgpu's colour and depth, read back just
//! before hadou ran and uploaded into the ash game's images: bit for bit, as the same passes run
//! on the same inputs with the same pipelines' code (one lavapipe). Where hadou drew nothing
//! (no surface, no energy) wgpu's own pixels must be untouched.

#[path = "../examples/wgpu_host/boxes.rs"]
mod boxes;
#[path = "../examples/wgpu_host/device.rs"]
mod device;
#[path = "../examples/game_prototype/game.rs"]
mod game;
#[path = "../examples/game_prototype/gpu.rs"]
mod gpu;
#[path = "../examples/wgpu_host/headless.rs"]
mod headless;
#[path = "../examples/wgpu_host/host.rs"]
mod host;
#[path = "../examples/game_prototype/painter.rs"]
mod painter;
#[path = "../examples/wgpu_host/readback.rs"]
mod readback;
#[path = "../examples/game_prototype/slime_sim.rs"]
mod slime_sim;
#[path = "../examples/wgpu_host/world.rs"]
mod world;

use ash::vk;
use game::{GameState, Input};
use hadou::{Aov, DepthConvention, ExternalColor, ExternalDepth, FrameInputs};
use readback::Readback;

const WIDTH: u32 = 80;
const HEIGHT: u32 = 48;
const FRAMES: usize = 24;
const DT: f64 = 0.1;

/// What one wgpu frame left: wgpu's colour and depth before hadou, the colour after.
struct WgpuFrame {
    state: GameState,
    before_color: Vec<u8>,
    before_depth: Vec<u8>,
    after_color: Vec<u8>,
}

/// Charge for 5 frames, release (fire): frames with a charging wave, a shot in flight, then (the
/// shot hit the target, the wave is despawned) frames without a wave.
fn input(i: usize) -> Input {
    Input { charge: i < 5, right: i % 3 == 0, ..Input::default() }
}

/// FRAMES frames of the wgpu host, two in flight, each read back before and after hadou.
fn wgpu_frames() -> Vec<WgpuFrame> {
    let gpu = device::WgpuVulkan::new(true).unwrap_or_else(|e| panic!("wgpu on Vulkan: {e}"));
    let mut host = host::WgpuHost::new(gpu, gpu::FRAMES_IN_FLIGHT).unwrap();
    let color = host::color_texture(&host.gpu.device, WIDTH, HEIGHT, wgpu::TextureFormat::Rgba8UnormSrgb);
    let view = color.create_view(&Default::default());
    let mut pending = Vec::new();
    for i in 0..FRAMES {
        host.update(&input(i), DT).unwrap();
        let mut encoder = host.begin_frame().unwrap();
        host.record_game(&mut encoder, &color, &view).unwrap();
        let device = host.gpu.device.clone();
        let depth = &host.depth.as_ref().unwrap().texture;
        let before_color = Readback::record(&device, &mut encoder, &color, wgpu::TextureAspect::All);
        let before_depth = Readback::record(&device, &mut encoder, depth, wgpu::TextureAspect::DepthOnly);
        let recorded = host.record_hadou(&mut encoder, &color, &view).unwrap();
        assert!(recorded.recorded);
        let after_color = Readback::record(&device, &mut encoder, &color, wgpu::TextureAspect::All);
        host.submit(encoder, recorded);
        pending.push((host.state.clone(), before_color, before_depth, after_color));
    }
    host.wait_all().unwrap();
    let device = host.gpu.device.clone();
    let frames = pending
        .into_iter()
        .map(|(state, bc, bd, ac)| WgpuFrame {
            state,
            before_color: bc.read(&device).unwrap(),
            before_depth: bd.read(&device).unwrap(),
            after_color: ac.read(&device).unwrap(),
        })
        .collect();
    drop((view, color, device));
    let messages = host.destroy();
    let (errors, warnings) = messages.counts();
    assert!(errors == 0 && warnings == 0, "wgpu host validation: {:?}", messages.texts.lock().unwrap());
    frames
}

/// What hadou's ash embedding path made of one frame: the colour and the AOVs that tell where
/// hadou drew (normal w = 1 on its surfaces, energy > 0 where the wave glows).
struct AshFrame {
    color: Vec<u8>,
    surface: Vec<bool>,
    energy: Option<Vec<f32>>,
}

/// The same frames through the game prototype's ash device: wgpu's inputs uploaded into the
/// game's images in the layouts the wgpu host hands hadou, hadou recorded as the host records it.
fn ash_frames(frames: &[WgpuFrame]) -> Vec<AshFrame> {
    let vk = gpu::GameVk::new(true, &[], &[], &|_, _, _, _| true).unwrap_or_else(|e| panic!("ash game: {e}"));
    // SAFETY: GameVk enables EnabledFeatures::REQUIRED; the world is dropped before vk.destroy().
    let mut world = unsafe { world::HadouWorld::new(vk.hadou_raw(), gpu::FRAMES_IN_FLIGHT) }.unwrap();
    let e = vk::Extent2D { width: WIDTH, height: HEIGHT };
    let transfer = vk::ImageUsageFlags::TRANSFER_DST;
    // As wgpu's depth texture: an attachment too (its read-only attachment layout needs it).
    let depth_usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | transfer;
    let depth = vk.create_image(e, vk::Format::D32_SFLOAT, depth_usage).unwrap();
    let color_usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC | transfer;
    let color = vk.create_image(e, vk::Format::R8G8B8A8_SRGB, color_usage).unwrap();
    let bytes = u64::from(WIDTH * HEIGHT * 4);
    let (up_color, up_depth, out) = (
        vk.create_host_buffer(bytes).unwrap(),
        vk.create_host_buffer(bytes).unwrap(),
        vk.create_host_buffer(bytes).unwrap(),
    );
    let mut vk = vk;
    let mut results = Vec::new();
    for f in frames {
        world.apply(&f.state).unwrap();
        let frame = world.hadou.next_frame();
        vk.begin_slot(frame as usize % gpu::FRAMES_IN_FLIGHT).unwrap();
        up_color.write(&f.before_color);
        up_depth.write(&f.before_depth);
        for (image, buffer) in [(&color, &up_color), (&depth, &up_depth)] {
            vk.transition(
                image.image,
                image.format,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            );
            let region = vk::BufferImageCopy::default()
                .image_subresource(
                    vk::ImageSubresourceLayers::default()
                        .aspect_mask(gpu::range(image.format).aspect_mask)
                        .layer_count(1),
                )
                .image_extent(vk::Extent3D { width: WIDTH, height: HEIGHT, depth: 1 });
            // SAFETY: the slot's command buffer is recording; image and buffer live until the wait below.
            unsafe {
                vk.device.cmd_copy_buffer_to_image(
                    vk.cmd,
                    buffer.buffer,
                    image.image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[region],
                )
            };
        }
        let (color_state, depth_state) = (host::COLOR_STATE.1, host::DEPTH_STATE.1);
        vk.transition(color.image, color.format, vk::ImageLayout::TRANSFER_DST_OPTIMAL, color_state);
        vk.transition(depth.image, depth.format, vk::ImageLayout::TRANSFER_DST_OPTIMAL, depth_state);
        let cam = game::camera();
        let inputs = FrameInputs {
            extent: e,
            time: f.state.time,
            depth: Some(ExternalDepth {
                image: depth.image,
                view: depth.view,
                format: vk::Format::D32_SFLOAT,
                layout: depth_state,
                final_layout: depth_state,
                convention: DepthConvention::Standard { near: cam.near, far: cam.far },
                write: false,
            }),
            color: Some(ExternalColor {
                image: color.image,
                view: color.view,
                format: color.format,
                layout: color_state,
                final_layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            }),
        };
        world.hadou.record_frame(vk.cmd, &inputs).unwrap();
        let aovs: Vec<Aov> =
            [Aov::Normal, Aov::Energy].into_iter().filter(|a| world.hadou.produces(a.target())).collect();
        let aov_readback = world.hadou.record_aov_readback(vk.cmd, &aovs).unwrap();
        vk.record_copy_to_host(&color, &out);
        vk.submit_slot().unwrap();
        vk.wait_slots().unwrap();
        world.hadou.frame_finished(frame).unwrap();
        let normal = aov_readback.aov(Aov::Normal).expect("a normal AOV");
        results.push(AshFrame {
            color: out.bytes().to_vec(),
            surface: normal.data.chunks_exact(4).map(|n| n[3] == 1.0).collect(),
            energy: aov_readback.aov(Aov::Energy).map(|a| a.data),
        });
    }
    drop(world);
    for b in [up_color, up_depth, out] {
        vk.destroy_buffer(b);
    }
    vk.destroy_image(color);
    vk.destroy_image(depth);
    let messages = vk.messages.clone();
    vk.destroy();
    let (errors, warnings) = messages.counts();
    assert!(errors == 0 && warnings == 0, "ash reference validation: {:?}", messages.texts.lock().unwrap());
    results
}

#[test]
fn hadou_in_a_wgpu_frame_matches_the_ash_embedding_bit_for_bit() {
    let wgpu = wgpu_frames();
    let ash = ash_frames(&wgpu);
    let pixels = (WIDTH * HEIGHT) as usize;
    let mut with_wave = 0;
    for (i, (w, a)) in wgpu.iter().zip(&ash).enumerate() {
        let t = w.state.time;
        let px = |bytes: &[u8], p: usize| <[u8; 4]>::try_from(&bytes[4 * p..4 * p + 4]).unwrap();
        // wgpu drew its boxes: the floor covers much of the frame (not the clear colour).
        let clear = px(&w.before_color, 0);
        let game_pixels = (0..pixels).filter(|&p| px(&w.before_color, p) != clear).count();
        assert!(game_pixels > pixels / 8, "frame {i}: wgpu drew {game_pixels} of {pixels} pixels");
        // hadou's pixels: the same bits as its ash embedding on the same inputs.
        let differ = (0..pixels).filter(|&p| px(&w.after_color, p) != px(&a.color, p)).count();
        assert_eq!(differ, 0, "frame {i} (t={t}): {differ} pixels differ from the ash embedding");
        // hadou drew: its surfaces (target, slime) change many pixels.
        let changed = (0..pixels).filter(|&p| px(&w.after_color, p) != px(&w.before_color, p)).count();
        let surfaces = a.surface.iter().filter(|&&s| s).count();
        assert!(
            surfaces > pixels / 100 && changed >= surfaces / 2,
            "frame {i}: {surfaces} surface pixels, {changed} changed"
        );
        // Where hadou drew nothing, wgpu's pixels are untouched. While a wave lives its glow
        // reaches every pixel (energy > 0 everywhere), so that is where no wave and no surface is.
        if a.energy.is_some() {
            with_wave += 1;
            continue;
        }
        let untouched: Vec<usize> = (0..pixels).filter(|&p| !a.surface[p]).collect();
        assert!(untouched.len() > pixels / 2, "frame {i}: only {} pixels without hadou", untouched.len());
        let moved = untouched.iter().filter(|&&p| px(&w.after_color, p) != px(&w.before_color, p)).count();
        assert_eq!(moved, 0, "frame {i} (t={t}): {moved} of wgpu's pixels changed where hadou drew nothing");
    }
    assert!(with_wave >= 10 && with_wave + 3 <= FRAMES, "frames with a wave: {with_wave} of {FRAMES}");
}

/// The window's resize, headless: frames at one size, another, and the first again (the host
/// makes its depth texture again, hadou its images of the new size, the old ones retired with
/// the frames that used them), two in flight; each frame's colour has hadou's surfaces over
/// wgpu's; zero validation messages.
#[test]
fn frames_across_resizes_stay_valid() {
    let gpu = device::WgpuVulkan::new(true).unwrap_or_else(|e| panic!("wgpu on Vulkan: {e}"));
    let mut host = host::WgpuHost::new(gpu, gpu::FRAMES_IN_FLIGHT).unwrap();
    let format = wgpu::TextureFormat::Rgba8UnormSrgb;
    let mut pending = Vec::new();
    for (i, (w, h)) in
        [(64, 40), (64, 40), (96, 56), (96, 56), (96, 56), (64, 40), (64, 40)].into_iter().enumerate()
    {
        let color = host::color_texture(&host.gpu.device, w, h, format);
        let view = color.create_view(&Default::default());
        host.update(&input(i), DT).unwrap();
        let mut encoder = host.begin_frame().unwrap();
        host.record_game(&mut encoder, &color, &view).unwrap();
        let device = host.gpu.device.clone();
        let before = Readback::record(&device, &mut encoder, &color, wgpu::TextureAspect::All);
        let recorded = host.record_hadou(&mut encoder, &color, &view).unwrap();
        let after = Readback::record(&device, &mut encoder, &color, wgpu::TextureAspect::All);
        host.submit(encoder, recorded);
        // The texture may be dropped now: wgpu keeps it until the frame that uses it finished.
        pending.push(((w, h), before, after));
    }
    host.wait_all().unwrap();
    let device = host.gpu.device.clone();
    for (i, ((w, h), before, after)) in pending.into_iter().enumerate() {
        let (before, after) = (before.read(&device).unwrap(), after.read(&device).unwrap());
        assert_eq!(after.len(), (w * h * 4) as usize);
        let changed = before.chunks_exact(4).zip(after.chunks_exact(4)).filter(|(b, a)| b != a).count();
        assert!(changed > (w * h / 100) as usize, "frame {i} at {w}x{h}: hadou changed {changed} pixels");
    }
    drop(device);
    let messages = host.destroy();
    let (errors, warnings) = messages.counts();
    assert!(errors == 0 && warnings == 0, "validation: {:?}", messages.texts.lock().unwrap());
}
