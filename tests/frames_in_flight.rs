//! Several hadou frames in flight, the way a game drives a renderer: the host records frame n into
//! the command buffer of slot n mod F and submits it without waiting; it waits only on the fence
//! of frame n − F before reusing that slot (the frame contract). Every frame changes the camera, a
//! wave, an instance transform and the metaball count (the tile lists and the ring grow). Sampled
//! frames are compared with the same world rendered alone by the headless runtime (itself checked
//! against the f64 twins elsewhere) and the energy with the f64 integral of *that frame's* wave —
//! a frame reading another frame's data would fail both. hadou itself never waits: its counted
//! device-idle and fence waits stay at zero after `prepare`. Lavapipe, validation + synchronization
//! validation, zero messages, nothing leaked at shutdown.

mod common;

use common::host::Host;

use ash::vk;
use glam::{DMat4, DQuat, DVec3};
use hadou::effects::energy_wave::line_integral;
use hadou::effects::metaballs::Ball;
use hadou::passes::energy_wave::wave_params;
use hadou::scene::camera::Camera;
use hadou::scene::transform::TransformOp;
use hadou::scene::Scene;
use hadou::testing::Comparison;
use hadou::{Aov, AovImage, ExternalDepth, FrameInputs, FrameRequest, Renderer, RendererOptions, WaveUpdate};

const SCENE: &str = r#"
[camera]
position = [0, 1, 9]
look_at = [0, 0, 0]
fov_y_deg = 50
near = 0.5
far = 60
[[light]]
direction = [-0.3, -1, -0.5]
[[mesh]]
name = "box"
kind = "cube"
size = 2
[[instance]]
mesh = "box"
transform = [{ translate = [2, 0, -1] }]
[[wave]]
origin = [-4, 0, 0]
direction = [1, 0.2, 0]
a = 2
b = 1
core = 0.05
length = 6
[[metaballs]]
balls = [{ centre = [-1, 0, 0], radius = 1.2 }]
"#;

/// The world of frame `i`: what the test hands hadou, and applies to its own copy of the scene.
struct World {
    camera: Camera,
    wave: WaveUpdate,
    transform: DMat4,
    balls: Vec<Ball>,
}

fn world(i: usize) -> World {
    let t = i as f64;
    let angle = 0.05 * t;
    let camera = Camera {
        position: DVec3::new(9.0 * angle.sin(), 1.0 + 0.02 * t, 9.0 * angle.cos()),
        look_at: DVec3::ZERO,
        up: DVec3::Y,
        fov_y_deg: 50.0,
        near: 0.5,
        far: 60.0,
        lens: Default::default(),
    };
    let wave = WaveUpdate {
        origin: DVec3::new(-4.0 + 0.1 * t, 0.3 * (0.3 * t).sin(), 0.0),
        direction: DVec3::new(1.0, 0.2, 0.05 * t.cos()),
        a: 1.0 + 0.05 * t,
        b: 0.5 + 0.02 * t,
        length: 4.0 + 0.1 * t,
    };
    let transform = DMat4::from_translation(DVec3::new(2.0, 0.2 * t.sin(), -1.0))
        * DMat4::from_quat(DQuat::from_rotation_y(0.1 * t));
    // 1, 2, ... 60 balls: the tile lists and the tables outgrow the ring again and again.
    let balls = (0..=i)
        .map(|k| {
            let a = k as f64 * 0.7;
            Ball {
                centre: DVec3::new(-1.0 + 0.8 * a.cos(), 0.6 * a.sin(), 0.3 * (k % 3) as f64),
                radius: 0.6,
                q: 1.0,
            }
        })
        .collect();
    World { camera, wave, transform, balls }
}

fn apply(hadou: &mut Renderer, w: &World) {
    hadou.set_camera(w.camera).unwrap();
    hadou.set_wave(hadou.wave_ids()[0], w.wave).unwrap();
    hadou.set_transform(hadou.instance_ids()[0], w.transform).unwrap();
    hadou.set_metaball_group(hadou.metaballs_ids()[0], &w.balls).unwrap();
}

/// The same world as a scene the headless runtime renders alone: the fields the updates set.
fn scene_of(base: &Scene, w: &World) -> Scene {
    let mut scene = base.clone();
    scene.camera = w.camera;
    let wave = &mut scene.waves_mut()[0];
    wave.origin = w.wave.origin;
    wave.direction = w.wave.direction.normalize();
    wave.a = w.wave.a;
    wave.b = w.wave.b;
    wave.length = w.wave.length;
    let inst = &mut scene.instances[0];
    inst.ops = vec![TransformOp::Matrix(w.transform)];
    inst.transform = hadou::scene::transform::Transform::from_ops(&inst.ops).unwrap();
    let ball = |b: &Ball| hadou::scene::model::AnimatedBall {
        centre: b.centre,
        radius: b.radius,
        q: b.q,
        velocity: DVec3::ZERO,
        q_rate: 0.0,
    };
    scene.metaballs_mut()[0].balls = w.balls.iter().map(ball).collect();
    scene
}

const W: u32 = 64;
const H: u32 = 48;
const AOVS: [Aov; 3] = [Aov::Depth, Aov::Energy, Aov::Normal];

/// 3 slots, 60 frames, all submitted without waiting; every 10th frame is read back and checked.
#[test]
fn sixty_frames_three_in_flight_each_sees_its_own_world() {
    let (_leaks, ctx) = common::context();
    let log = ctx.validation_log();
    let mut host = Host::new(&ctx, 3);
    let options = RendererOptions { frames_in_flight: 3, ..RendererOptions::default() };
    let mut hadou = Renderer::with_options(ctx, &options).unwrap();
    let base = common::parse(SCENE);
    hadou.load_scene(base.clone()).unwrap();
    let inputs = FrameInputs::headless(W, H, 0.0);
    hadou.prepare(&inputs).unwrap();
    let waits = hadou.context().host_waits();
    let mut sampled = Vec::new();
    for i in 0..60 {
        let w = world(i);
        apply(&mut hadou, &w);
        let slot = i % 3;
        let cmd = host.begin(slot);
        let frame = hadou.record_frame(cmd, &inputs).unwrap();
        assert_eq!(frame.frame, i as u64);
        if i % 10 == 9 {
            let readback = hadou.record_aov_readback(cmd, &AOVS).unwrap();
            sampled.push((i, w, readback));
        }
        host.submit(slot);
    }
    assert_eq!(hadou.context().host_waits(), waits, "hadou waited on the device during the frames");
    host.wait_all();
    hadou.frame_finished(59).unwrap();
    let timings = hadou.latest_timings().expect("frame 59 finished");
    assert_eq!(timings.frame, 59);
    // Everything the 60 frames retired (grown rings, per-frame texel views) is freed once their
    // frames are known finished: nothing piles up.
    assert_eq!(hadou.context().retired_count(), 0, "objects still waiting after every frame finished");

    let mut rt = common::runtime();
    let mut metaball_px = Vec::new();
    for (i, w, readback) in &sampled {
        let scene = scene_of(&base, w);
        rt.load_scene(scene.clone()).unwrap();
        let mut request = FrameRequest::new(W, H);
        request.aovs = AOVS.to_vec();
        let alone = rt.render(&request).unwrap();
        for aov in AOVS {
            let got = readback.aov(aov).unwrap();
            let want = alone.aov(aov).unwrap();
            assert!(
                common::same_bits(&got, want),
                "frame {i}: {} differs from the world rendered alone",
                aov.name()
            );
        }
        check_energy(*i, &scene, &readback.aov(Aov::Energy).unwrap(), &readback.aov(Aov::Depth).unwrap());
        let (gpu, twin, footprint) =
            check_metaball_pixels(*i, &scene, &readback.aov(Aov::Normal).unwrap(), w);
        metaball_px.push((gpu, twin, footprint));
    }
    // The metaballs grew with the frame (1, 2, ... 60 balls, each field adding to the others): the
    // 60-ball blob covers more of the image than the 10-ball one (f64 footprint, the box ignored;
    // the camera orbits, so the frames between need not grow), and the sampled frames show
    // metaball surface, except where the box hides the blob (frame 39: 0 in f64 as on the GPU).
    println!("metaball pixels at frames 9, 19, ... 59 (gpu, f64 twin, f64 footprint): {metaball_px:?}");
    let (first, last) = (metaball_px[0].2, metaball_px[5].2);
    assert!(last as f64 > 1.3 * first as f64, "the blob grew: {metaball_px:?}");
    assert!(
        metaball_px.iter().filter(|(gpu, _, _)| *gpu > 20).count() >= 4,
        "most sampled frames show metaball surface: {metaball_px:?}"
    );
    rt.finish();
    drop(sampled);
    host.destroy();
    drop(hadou);
    common::assert_log_clean(&log, "after shutdown (leaks included)");
}

/// Pixels showing metaball surface: a hit (normal w = 1) whose normal is none of the box's face
/// normals. The raster writes the box's face normal (its rotation, in f32: within 1e-6); a
/// metaball normal within 1e-3 of one of those 6 directions covers a share ~6·π·1e-6/(4π) of the
/// sphere of directions, so this miscounts a handful of pixels at most.
fn metaball_mask(normal: &AovImage, transform: DMat4) -> Vec<bool> {
    let faces = [DVec3::X, DVec3::Y, DVec3::Z].map(|a| transform.transform_vector3(a).normalize());
    normal
        .data
        .chunks_exact(4)
        .map(|n| {
            let v = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
            let on_box = faces.iter().any(|f| (v - *f).length() < 1e-3 || (v + *f).length() < 1e-3);
            n[3] == 1.0 && !on_box
        })
        .collect()
}

/// The f64 distance along a unit ray to the frame's box (the cube of size 2 under `transform`).
fn box_distance(transform: DMat4, o: DVec3, u: DVec3) -> Option<f64> {
    let inv = transform.inverse();
    let (lo, lu) = (inv.transform_point3(o), inv.transform_vector3(u));
    let (a, b) = ((DVec3::NEG_ONE - lo) / lu, (DVec3::ONE - lo) / lu);
    let (near, far) = (DVec3::min(a, b).max_element(), DVec3::max(a, b).min_element());
    (near <= far && far > 0.0).then_some(near)
}

/// The metaball surface the frame shows against its f64 twin: per pixel, the f64 cast of the
/// frame's balls (`effects::metaballs::cast`) nearer than the f64 box. The two classifications
/// may differ only where the f64 one changes between neighbours (a blob or box silhouette, or
/// where the blob meets the box: a pixel-centre decision on a grazing ray). Returns the GPU's
/// count, the twin's, and the twin's footprint of the blob with the box ignored.
fn check_metaball_pixels(i: usize, scene: &Scene, normal: &AovImage, w: &World) -> (usize, usize, usize) {
    let gpu = metaball_mask(normal, w.transform);
    let group = scene.metaballs()[0].at(0.0);
    let cam = &scene.camera;
    let mut footprint = 0;
    let twin: Vec<bool> = (0..W * H)
        .map(|k| {
            let (o, u) = cam.pixel_ray(k % W, k / W, W, H);
            let ball = hadou::effects::metaballs::cast(&group, o, u, cam.near, cam.far).map(|h| h.t);
            footprint += usize::from(ball.is_some());
            ball.is_some_and(|t| box_distance(w.transform, o, u).is_none_or(|b| t < b))
        })
        .collect();
    let at = |x: i64, y: i64| twin[(y.clamp(0, H as i64 - 1) * W as i64 + x.clamp(0, W as i64 - 1)) as usize];
    let mut boundary = 0;
    for k in 0..(W * H) as usize {
        let (x, y) = ((k as u32 % W) as i64, (k as u32 / W) as i64);
        let edge = [(1, 0), (-1, 0), (0, 1), (0, -1)].iter().any(|(dx, dy)| at(x + dx, y + dy) != twin[k]);
        if gpu[k] != twin[k] {
            assert!(edge, "frame {i} ({x}, {y}): metaball surface {} on the GPU, {} in f64", gpu[k], twin[k]);
            boundary += 1;
        }
    }
    let count = |m: &[bool]| m.iter().filter(|&&b| b).count();
    println!(
        "frame {i}: {} metaball pixels, f64 {}, {boundary} differ on a boundary",
        count(&gpu),
        count(&twin)
    );
    (count(&gpu), count(&twin), footprint)
}

/// Energy vs the f64 closed form of the frame's own wave, up to the GPU's own distance. Bound 1e-4
/// (gpu_energy_wave's argument: f32 pixel rays, ≈ 3e-7, enter H only logarithmically; the closed
/// form is a few f32 ulps). Another frame's wave or camera would be off by far more. Every pixel
/// is compared (nothing excluded).
fn check_energy(i: usize, scene: &Scene, energy: &AovImage, distance: &AovImage) {
    let params = wave_params(&scene.waves()[0].at(0.0));
    let cam = &scene.camera;
    let mut c = Comparison::new(format!("frame {i}: energy vs f64"));
    for y in 0..H {
        for x in 0..W {
            let k = (y * W + x) as usize;
            let (o, u) = cam.pixel_ray(x, y, W, H);
            let d = distance.data[k] as f64;
            let reference = line_integral(&params, o, u, d.min(cam.far));
            let got = energy.data[k] as f64;
            if d.is_nan() {
                // f64::min would turn a NaN distance into `far`: a failure of its own.
                c.error(format_args!("({x}, {y}): distance NaN"), f64::NAN);
            } else if reference > 0.0 {
                c.rel(format_args!("({x}, {y})"), got, reference);
            } else {
                c.error(format_args!("({x}, {y}) where f64 is 0"), got.abs());
            }
        }
    }
    c.assert_within(1e-4, (W * H) as usize);
}

/// A new view of the game's depth every frame for 200 frames, the old one destroyed once its frame
/// finished (drivers hand the same handle out again). The views differ: frame i's view is of game
/// depth image i mod 3 (two slots: never the image of the slot's previous frame), which the game
/// clears that frame to a plane at its own distance 6 + 0.5·(i mod 7), so consecutive frames see
/// different planes. Every frame's depth AOV is read back and must show that frame's plane: a
/// stale descriptor (the previous frame's view, or a reused handle left unbound) would show
/// another frame's plane. And hadou never waits.
#[test]
fn a_new_depth_view_every_frame() {
    let (_leaks, ctx) = common::context();
    let device = ctx.device.clone();
    let mut host = Host::new(&ctx, 2);
    let mut hadou = Renderer::with_options(ctx, &RendererOptions::default()).unwrap();
    hadou.load_scene(common::parse(SCENE)).unwrap();
    let extent = vk::Extent2D { width: 32, height: 24 };
    let memory = hadou::gpu::memory::Memory::new(hadou.context()).unwrap();
    let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
    let images: Vec<_> = (0..3)
        .map(|k| {
            let name = format!("game depth {k}");
            memory.create_image(hadou.context(), &name, extent, vk::Format::D32_SFLOAT, usage).unwrap()
        })
        .collect();
    let convention = hadou::DepthConvention::Standard { near: 0.5, far: 60.0 };
    let plane = |i: usize| 6.0 + 0.5 * (i % 7) as f64;
    let first = FrameInputs { extent, time: 0.0, depth: None, color: None };
    hadou.prepare(&first).unwrap();
    let waits = hadou.context().host_waits();
    let mut views: Vec<Option<vk::ImageView>> = vec![None; 2];
    let mut handles = std::collections::HashSet::new();
    let mut reused = 0;
    let range = vk::ImageSubresourceRange::default()
        .aspect_mask(vk::ImageAspectFlags::DEPTH)
        .level_count(1)
        .layer_count(1);
    let mut readbacks = Vec::new();
    for i in 0..200 {
        let slot = i % 2;
        let depth = &images[i % 3];
        let cmd = host.begin(slot);
        // The slot's previous frame finished: its view may go, and a new one is made.
        if let Some(old) = views[slot].take() {
            // SAFETY: the only frame that used the view (the slot's previous one) finished: begin
            // waited for its fence.
            unsafe { device.destroy_image_view(old, None) };
        }
        let info = vk::ImageViewCreateInfo::default()
            .image(depth.raw)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(vk::Format::D32_SFLOAT)
            .subresource_range(range);
        // SAFETY: the image is live on this device (dropped after the views are destroyed).
        let view = unsafe { device.create_image_view(&info, None) }.unwrap();
        reused += usize::from(!handles.insert(vk::Handle::as_raw(view)));
        views[slot] = Some(view);
        // The game "draws" its depth: a clear to the depth of this frame's plane.
        let layout = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
        if i < 3 {
            let barrier = vk::ImageMemoryBarrier2::default()
                .dst_stage_mask(vk::PipelineStageFlags2::CLEAR)
                .dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                .new_layout(layout)
                .image(depth.raw)
                .subresource_range(range);
            let barriers = [barrier];
            // SAFETY: cmd is recording (host.begin); the image is live; `barriers` outlives the call.
            unsafe {
                device.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().image_memory_barriers(&barriers),
                )
            };
        }
        let stored = hadou::passes::depth_import::store_depth(plane(i), convention);
        let clear = vk::ClearDepthStencilValue { depth: stored as f32, stencil: 0 };
        // SAFETY: cmd is recording, outside rendering; the image is live and in TRANSFER_DST layout
        // (the barrier of its first frame, and every frame leaves it there).
        unsafe { device.cmd_clear_depth_stencil_image(cmd, depth.raw, layout, &clear, &[range]) };
        let inputs = FrameInputs {
            extent,
            time: 0.0,
            depth: Some(ExternalDepth {
                image: depth.raw,
                view,
                format: vk::Format::D32_SFLOAT,
                layout,
                final_layout: layout,
                convention,
                write: false,
            }),
            color: None,
        };
        hadou.record_frame(cmd, &inputs).unwrap();
        readbacks.push((i, clear.depth, hadou.record_aov_readback(cmd, &[Aov::Depth]).unwrap()));
        host.submit(slot);
    }
    assert_eq!(hadou.context().host_waits(), waits, "hadou waited on the device");
    host.wait_all();
    println!("{reused} of 200 views reused an earlier handle");
    for (i, stored, readback) in &readbacks {
        check_game_plane(*i, *stored, convention, &readback.aov(Aov::Depth).unwrap());
    }
    drop(readbacks);
    host.destroy();
    // SAFETY: every frame finished (host.destroy waited for all), and the device lives on in hadou.
    views.into_iter().flatten().for_each(|v| unsafe { device.destroy_image_view(v, None) });
    drop(images);
    drop(memory);
    drop(hadou);
}

/// Frame `i`'s depth AOV shows the game's plane (stored as the f32 `stored`) wherever hadou drew
/// nothing nearer (its own box and balls cover part of it), and nothing lies beyond the plane.
/// Against the f64 twin `import_depth` of the stored value: the shader's z = B / (d + A)
/// (standard Z: A = f/(n − f)) cancels in d + A by |A|/|d + A| = z/n (A and the sum rounded: ≤ 2
/// roundings scaled by z/n), plus ~8 roundings in B, the division, the pixel ray's length and
/// the f32 ray frame: relative (2·z/n + 8)·u, u = 2⁻²⁴ (tests/embedding.rs argues the same). The
/// next frame's plane lies 0.5 (≥ 5 %) away, thousands of times that bound.
fn check_game_plane(i: usize, stored: f32, convention: hadou::DepthConvention, d: &AovImage) {
    use hadou::passes::depth_import::import_depth;
    let cam = common::parse(SCENE).camera;
    let (w, h) = (d.width, d.height);
    let ray = cam.ray_frame(w, h);
    let u = f32::EPSILON as f64 / 2.0;
    let hadou::DepthConvention::Standard { near, .. } = convention else { unreachable!() };
    let mut c = Comparison::new(format!("frame {i}: the game's plane, relative to its bound"));
    for y in 0..h {
        for x in 0..w {
            let ndc_x = 2.0 * (x as f64 + 0.5) / w as f64 - 1.0;
            let ndc_y = 1.0 - 2.0 * (y as f64 + 0.5) / h as f64;
            let scale = (ray.forward + ray.right * ndc_x + ray.up * ndc_y).length();
            let (want, _) = import_depth(stored as f64, convention, scale, &cam);
            let bound = (2.0 * (want / scale) / near + 8.0) * u;
            let got = d.data[(y * w + x) as usize] as f64;
            if got < want * (1.0 - bound) {
                // hadou's own surface, nearer than the plane.
                c.exclude();
            } else {
                c.error(format_args!("({x}, {y}): {got} vs f64 {want}"), (got - want).abs() / want / bound);
            }
        }
    }
    // ≥ 200 of the 768 pixels are the plane (the sky around hadou's box and balls).
    c.assert_within(1.0, 200);
}

/// 20 resizes while 3 frames are in flight: old images are retired with the frames that use them
/// (no wait), every frame has the size it asked for.
#[test]
fn resize_twenty_times_with_three_in_flight() {
    let (_leaks, ctx) = common::context();
    let log = ctx.validation_log();
    let mut host = Host::new(&ctx, 3);
    let options = RendererOptions { frames_in_flight: 3, ..RendererOptions::default() };
    let mut hadou = Renderer::with_options(ctx, &options).unwrap();
    hadou.load_scene(common::load("assets/scenes/showcase.toml")).unwrap();
    hadou.prepare(&FrameInputs::headless(40, 30, 0.0)).unwrap();
    let waits = hadou.context().host_waits();
    let mut reads = Vec::new();
    for i in 0..20u32 {
        let (w, h) = (24 + 7 * (i % 5), 16 + 5 * (i % 4));
        let slot = (i % 3) as usize;
        let cmd = host.begin(slot);
        hadou.record_frame(cmd, &FrameInputs::headless(w, h, 0.1 * i as f64)).unwrap();
        reads.push(((w, h), hadou.record_aov_readback(cmd, &[Aov::Depth, Aov::Energy]).unwrap()));
        host.submit(slot);
    }
    assert_eq!(hadou.context().host_waits(), waits, "a resize waited on the device");
    host.wait_all();
    for ((w, h), r) in &reads {
        let d = r.aov(Aov::Depth).unwrap();
        assert_eq!((d.width, d.height), (*w, *h));
        assert!(r.aov(Aov::Energy).unwrap().data.iter().all(|v| v.is_finite() && *v >= 0.0));
    }
    drop(reads);
    host.destroy();
    drop(hadou);
    common::assert_log_clean(&log, "after shutdown (leaks included)");
}

const JADE: &str = r#"
[camera]
position = [0, 0.6, 5]
look_at = [0, 0, 0]
fov_y_deg = 40
near = 0.1
far = 50
[[light]]
direction = [0.2, -0.25, 1]
intensity = 4
[[mesh]]
name = "block"
kind = "cube"
size = 1.2
[[material]]
name = "jade"
kind = "translucent"
albedo = [0.55, 0.85, 0.65]
sigma = [3.0, 1.2, 2.2]
voxel_res = 32
[[instance]]
name = "jade"
mesh = "block"
material = "jade"
"#;

/// A translucent instance (a block) rotated, scaled non-uniformly (mirrored in some frames) and
/// moved every frame, two frames in flight: each sampled frame's thickness AOV equals, bit for
/// bit, the same world loaded still and rendered alone — moving costs no accuracy, because the
/// tables are in object space (exact under any affine transform) and the light's view, the
/// instance matrices and the light map are made again each frame. The thickness itself is
/// compared with the exact f64 thickness of that frame's transform and its error printed; the
/// LUT's own accuracy bound is issue 13's: even still, this block under this back light has a p95
/// of 1.2 voxels at some orientations (tests/gpu_translucency.rs asserts ≤ 1 on its placements).
#[test]
fn a_moving_translucent_instance_renders_as_the_same_world_still() {
    use hadou_cli::report::translucency::{abs_stats, sample_set, world_voxel};
    let (_leaks, ctx) = common::context();
    let log = ctx.validation_log();
    let mut host = Host::new(&ctx, 2);
    let mut hadou = Renderer::with_options(ctx, &RendererOptions::default()).unwrap();
    let mut scene = common::parse(JADE);
    hadou.load_scene(scene.clone()).unwrap();
    let (w, h) = (200u32, 150u32);
    let inputs = FrameInputs::headless(w, h, 0.0);
    hadou.prepare(&inputs).unwrap();
    let waits = hadou.context().host_waits();
    let mut sampled = Vec::new();
    for i in 0..12 {
        let t = i as f64;
        let mirror = if i % 4 == 3 { -1.0 } else { 1.0 };
        let matrix =
            DMat4::from_translation(DVec3::new(
                0.25 * (0.7 * t).sin(),
                0.1 * t - 0.5,
                -0.3 * (0.5 * t).cos(),
            )) * DMat4::from_quat(DQuat::from_axis_angle(DVec3::new(0.3, 1.0, 0.2).normalize(), 0.35 * t))
                * DMat4::from_scale(DVec3::new(mirror * (1.0 + 0.05 * t), 0.8 + 0.03 * t, 1.1));
        hadou.set_transform(hadou.instance_ids()[0], matrix).unwrap();
        let ops = vec![TransformOp::Matrix(matrix)];
        scene.instances[0].transform = hadou::scene::transform::Transform::from_ops(&ops).unwrap();
        scene.instances[0].ops = ops;
        let slot = i % 2;
        let cmd = host.begin(slot);
        hadou.record_frame(cmd, &inputs).unwrap();
        if i % 4 >= 2 {
            let readback = hadou.record_aov_readback(cmd, &[Aov::Thickness, Aov::Depth]).unwrap();
            sampled.push((i, scene.clone(), readback));
        }
        host.submit(slot);
    }
    assert_eq!(hadou.context().host_waits(), waits, "moving a translucent instance waited");
    host.wait_all();
    let mut rt = common::runtime();
    for (i, scene, readback) in &sampled {
        let thickness = readback.aov(Aov::Thickness).unwrap();
        let depth = readback.aov(Aov::Depth).unwrap();
        rt.load_scene(scene.clone()).unwrap();
        let mut request = FrameRequest::new(w, h);
        request.aovs = vec![Aov::Thickness];
        let still = rt.render(&request).unwrap();
        assert!(
            common::same_bits(&thickness, still.aov(Aov::Thickness).unwrap()),
            "frame {i}: differs from the still world"
        );
        // ≥ 1000 translucent pixels compared, ≤ 1/16 left out as silhouettes (sample_set's cap).
        let set = sample_set(scene, (w, h), &thickness.data, &depth.data).unwrap();
        println!("frame {i}: {}", set.assert_usable(1000));
        let samples = set.samples;
        let voxel = world_voxel(scene, 0).unwrap();
        let (mean, p95, max) = abs_stats(samples.iter().map(|s| (s.gpu - s.exact) / voxel));
        println!(
            "frame {i}: {} px, |error| mean {mean:.3}, p95 {p95:.3}, max {max:.2} voxels",
            samples.len()
        );
        assert!(mean.is_finite() && max.is_finite(), "frame {i}: every thickness finite");
    }
    common::assert_clean(&rt);
    drop(sampled);
    host.destroy();
    drop(hadou);
    common::assert_log_clean(&log, "after shutdown (leaks included)");
}
