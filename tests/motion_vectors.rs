//! A temporal upscaler's inputs (`Renderer::set_motion_vectors`, `set_jitter`): per pixel the
//! motion in pixels from this frame to the previous one, unjittered, against an f64 twin that
//! finds each pixel's surface point along its (jittered) ray at the frame's own distance and
//! carries it back by what moved — an instance's transform, a deforming mesh's vertices, a
//! metaball group's balls, the camera; the reactive mask against the glow's share measured from
//! two renders; the composition mask against the translucent surfaces. Lavapipe, validation and
//! synchronization validation, zero messages (`common::runtime`).
//!
//! Tolerance: `MOTION_TOL` pixels. The GPU takes the motion from clip coordinates interpolated in
//! f32 over the triangle (relative error ~1e-6: ~1e-4 px on these ≤ 128-pixel frames, whose
//! motions are a few pixels) or from the distance and ray in f32 (the twin starts from the same
//! f32 distance); 2e-3 px is 20× that and far below the 1/8 px a TAA resolve would notice.

mod common;

use glam::{DMat4, DVec2, DVec3, DVec4, Vec3};
use hadou::effect::{Binning, Effects, Metaballs, UpscalerInputs};
use hadou::scene::camera::{Camera, Lens};
use hadou::scene::Scene;
use hadou::{Aov, AovImage, Ball, FrameRequest};

const MOTION_TOL: f64 = 2e-3;
const W: u32 = 96;
const H: u32 = 64;

fn camera(position: DVec3) -> Camera {
    Camera {
        position,
        look_at: DVec3::new(0.0, 0.3, 0.0),
        up: DVec3::Y,
        fov_y_deg: 50.0,
        near: 0.5,
        far: 60.0,
        lens: Lens::FovY,
    }
}

/// `camera` shifted by `jitter` pixels (x right, y down) at W × H: what hadou renders with.
fn jittered(camera: Camera, jitter: DVec2) -> Camera {
    let (w, h) = (f64::from(W), f64::from(H));
    let t = (camera.fov_y_deg.to_radians() / 2.0).tan();
    let lens = Lens::Matrix {
        scale: DVec2::new(h / (t * w), 1.0 / t),
        shift: DVec2::new(2.0 * jitter.x / w, -2.0 * jitter.y / h),
    };
    Camera { lens, ..camera }
}

fn pixel(clip: DVec4) -> DVec2 {
    (DVec2::new(clip.x, clip.y) / clip.w * 0.5 + 0.5) * DVec2::new(f64::from(W), f64::from(H))
}

/// The twin: per pixel of a frame seen by `seen` (jittered) at distances `depth`, the motion
/// from `now` (unjittered) to `before` (the previous camera, unjittered) of the point found
/// there, carried back by `back` (None: the sky, the direction itself). Compares with the GPU's
/// motion; returns the pixels compared on a surface and the largest error.
fn check(
    what: &str,
    motion: &AovImage,
    depth: &AovImage,
    (seen, now, before): (&Camera, &Camera, &Camera),
    back: impl Fn(DVec3) -> DVec3,
) -> (usize, f64) {
    let (vp, prev_vp) = (now.view_projection(W, H), before.view_projection(W, H));
    let (mut surface, mut worst) = (0, 0.0f64);
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let (o, u) = seen.pixel_ray(x, y, W, H);
            let t = f64::from(depth.data[i]);
            let (a, b) = if t.is_finite() {
                surface += 1;
                let p = o + t * u;
                (vp * p.extend(1.0), prev_vp * back(p).extend(1.0))
            } else {
                (vp * u.extend(0.0), prev_vp * u.extend(0.0))
            };
            let want = pixel(b) - pixel(a);
            let got = DVec2::new(motion.data[2 * i].into(), motion.data[2 * i + 1].into());
            let err = (got - want).abs().max_element();
            assert!(err <= MOTION_TOL, "{what} ({x}, {y}): motion {got} against {want}");
            worst = worst.max(err);
        }
    }
    (surface, worst)
}

fn render(rt: &mut common::CheckedRuntime, aovs: &[Aov]) -> hadou::FrameOutput {
    let mut request = FrameRequest::new(W, H);
    request.aovs = aovs.to_vec();
    rt.render(&request).unwrap()
}

const BOX: &str = r#"
[camera]
position = [0, 1, 8]
look_at = [0, 0.3, 0]
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
"#;

#[test]
fn a_moving_instance_seen_by_a_moving_jittered_camera() {
    let mut rt = common::runtime();
    rt.load_scene(common::parse(BOX)).unwrap();
    let id = rt.renderer().instance_ids()[0];
    let a = DMat4::from_translation(DVec3::new(-0.6, 0.1, 0.0)) * DMat4::from_rotation_y(0.3);
    let b = DMat4::from_translation(DVec3::new(0.4, -0.2, 0.5)) * DMat4::from_rotation_y(0.45);
    let (c0, c1) = (camera(DVec3::new(0.3, 1.0, 8.0)), camera(DVec3::new(-0.5, 1.4, 7.6)));
    let (j0, j1) = (DVec2::new(0.25, -0.375), DVec2::new(-0.125, 0.3125));
    let r = rt.renderer();
    r.set_motion_vectors(true).unwrap();
    r.set_transform(id, a).unwrap();
    r.set_camera(c0).unwrap();
    r.set_jitter(j0.x, j0.y).unwrap();
    let first = render(&mut rt, &[Aov::Motion]);
    assert!(first.aov(Aov::Motion).unwrap().data.iter().all(|&m| m == 0.0), "no previous frame: no motion");
    let r = rt.renderer();
    r.set_transform(id, b).unwrap();
    r.set_camera(c1).unwrap();
    r.set_jitter(j1.x, j1.y).unwrap();
    let out = render(&mut rt, &[Aov::Motion, Aov::Depth]);
    let back = |p: DVec3| a.transform_point3(b.inverse().transform_point3(p));
    let cams = (&jittered(c1, j1), &c1, &c0);
    let (surface, worst) =
        check("instance", out.aov(Aov::Motion).unwrap(), out.aov(Aov::Depth).unwrap(), cams, back);
    println!("instance: {surface} surface pixels, largest error {worst:.1e} px");
    assert!(surface > 400, "the box covers the frame's middle: {surface}");
    rt.finish();
}

#[test]
fn a_deforming_mesh_and_moving_metaballs() {
    let scene = format!(
        "{BOX}\n[[material]]\nname = \"slime\"\n[[metaballs]]\nmaterial = \"slime\"\nthreshold = 0.4\n\
         balls = [{{ centre = [2.2, 0, 0], radius = 1.2 }}, {{ centre = [3, 0.5, 0], radius = 1 }}]\n"
    );
    let mut rt = common::runtime();
    rt.load_scene(common::parse(&scene)).unwrap();
    let c = camera(DVec3::new(1.0, 1.0, 8.0));
    let r = rt.renderer();
    r.set_motion_vectors(true).unwrap();
    r.set_camera(c).unwrap();
    let positions: Vec<Vec3> = {
        let scene: &Scene = r.scene().unwrap();
        scene.meshes[0].mesh.positions.iter().map(|p| Vec3::from_array(*p)).collect()
    };
    let group = r.metaballs_ids()[0];
    let balls = |d: DVec3| {
        vec![
            Ball { centre: DVec3::new(2.2, 0.0, 0.0) + d, radius: 1.2, q: 1.0 },
            Ball { centre: DVec3::new(3.0, 0.5, 0.0) + d, radius: 1.0, q: 1.0 },
        ]
    };
    r.set_metaball_group(group, &balls(DVec3::ZERO)).unwrap();
    render(&mut rt, &[Aov::Motion]);
    // The mesh's vertices and the balls move by d: every surface point came from p − d.
    let d = DVec3::new(0.15, -0.1, 0.2);
    let r = rt.renderer();
    let moved: Vec<Vec3> = positions.iter().map(|p| *p + d.as_vec3()).collect();
    r.set_mesh_positions("box", &moved).unwrap();
    r.set_metaball_group(group, &balls(d)).unwrap();
    let out = render(&mut rt, &[Aov::Motion, Aov::Depth]);
    // The f32 vertex positions moved by d in f32: the twin moves by the same f32 difference.
    let df = (moved[0] - positions[0]).as_dvec3();
    let back = |p: DVec3| p - if p.x > 1.05 { d } else { df };
    let (surface, worst) = check(
        "mesh and metaballs",
        out.aov(Aov::Motion).unwrap(),
        out.aov(Aov::Depth).unwrap(),
        (&c, &c, &c),
        back,
    );
    println!("deforming mesh and metaballs: {surface} surface pixels, largest error {worst:.1e} px");
    // Both moved things are in the frame: the metaballs (right of x = 1.05) and the box.
    let depth = out.aov(Aov::Depth).unwrap();
    let balls_seen = (0..W * H)
        .filter(|&i| {
            let (o, u) = c.pixel_ray(i % W, i / W, W, H);
            let t = f64::from(depth.data[i as usize]);
            t.is_finite() && (o + t * u).x > 1.05
        })
        .count();
    assert!(surface > 400 && balls_seen > 100, "{surface} surface pixels, {balls_seen} on the metaballs");
    rt.finish();
}

#[test]
fn the_reactive_mask_is_the_glows_share_and_composition_the_translucent_surfaces() {
    let scene = r#"
[camera]
position = [0, 1, 8]
look_at = [0, 0.3, 0]
fov_y_deg = 50
near = 0.5
far = 60
[[light]]
direction = [0.3, -0.5, -1]
[[mesh]]
name = "box"
kind = "cube"
size = 2
[[material]]
name = "jade"
kind = "translucent"
albedo = [0.4, 0.8, 0.5]
sigma = [0.8, 0.5, 0.9]
voxel_res = 8
[[instance]]
mesh = "box"
material = "jade"
transform = [{ translate = [1.2, 0, 0] }]
[[instance]]
mesh = "box"
transform = [{ translate = [-1.5, 0, -1] }]
[[wave]]
origin = [-3, 0.4, 1.5]
direction = [1, 0, 0]
a = 1.5
b = 0.8
core = 0.05
length = 5
intensity = 0.05
"#;
    let mut rt = common::runtime();
    rt.load_scene(common::parse(scene)).unwrap();
    let aovs = [Aov::Hdr, Aov::Reactive, Aov::Composition, Aov::Thickness];
    let with = render(&mut rt, &aovs);
    let wave = rt.renderer().wave_ids()[0];
    let off = hadou::WaveUpdate {
        origin: DVec3::new(-3.0, 0.4, 1.5),
        direction: DVec3::X,
        a: 0.0,
        b: 0.0,
        length: 5.0,
    };
    rt.renderer().set_wave(wave, off).unwrap();
    let without = render(&mut rt, &aovs);
    let luma = |c: &[f32]| 0.2126 * f64::from(c[0]) + 0.7152 * f64::from(c[1]) + 0.0722 * f64::from(c[2]);
    let (hdr, base) = (&with.aov(Aov::Hdr).unwrap().data, &without.aov(Aov::Hdr).unwrap().data);
    let reactive = &with.aov(Aov::Reactive).unwrap().data;
    // The HDR image is f16: the twin's glow is the difference of two f16 colours, the GPU's of
    // f32 ones (one rounding of 2⁻¹¹ relative on each side of the share).
    let (mut glowing, mut worst) = (0, 0.0f64);
    for i in 0..(W * H) as usize {
        let (l, l0) = (luma(&hdr[4 * i..]), luma(&base[4 * i..]));
        let want = if l > 0.0 { ((l - l0) / l).clamp(0.0, 1.0) } else { 0.0 };
        let err = (f64::from(reactive[i]) - want).abs();
        assert!(err <= 2e-3, "pixel {i}: reactive {} against {want}", reactive[i]);
        worst = worst.max(err);
        glowing += usize::from(want > 0.05);
    }
    assert!(without.aov(Aov::Reactive).unwrap().data.iter().all(|&r| r == 0.0), "no glow, no reactive");
    assert!(glowing > 300, "the glow covers part of the frame: {glowing}");
    let composition = &with.aov(Aov::Composition).unwrap().data;
    let thickness = &with.aov(Aov::Thickness).unwrap().data;
    let translucent = thickness.iter().filter(|t| t.is_finite()).count();
    for (c, t) in composition.iter().zip(thickness) {
        assert_eq!(*c == 1.0, t.is_finite(), "composition is 1 exactly on the translucent surface");
    }
    println!(
        "reactive: {glowing} glowing pixels, largest error {worst:.1e}; {translucent} translucent pixels"
    );
    assert!(translucent > 300, "{translucent}");
    rt.finish();
}

#[test]
fn motion_vectors_are_off_unless_asked_for() {
    let (_leaks, ctx) = common::context();
    let mut host = common::host::Host::new(&ctx, 1);
    let mut hadou = hadou::Renderer::new(ctx).unwrap();
    hadou.load_scene(common::parse(BOX)).unwrap();
    let cmd = host.begin(0);
    hadou.record_frame(cmd, &hadou::FrameInputs::headless(16, 16, 0.0)).unwrap();
    assert!(!hadou.pass_names().contains(&"motion"));
    let err = hadou.record_aov_readback(cmd, &[Aov::Motion]).map(|_| ()).unwrap_err();
    assert!(err.to_string().contains("set_motion_vectors"), "{err}");
    assert!(hadou.set_jitter(f64::NAN, 0.0).is_err());
    host.submit(0);
    host.wait_all();
    host.destroy();
    drop(hadou);
}

/// A crowd of balls each moving its own way, under a rotated, non-uniformly scaled group
/// transform: ~100 supports hold a point of the surface, the tiles' runs are long and the casts
/// streamed (`metaballs.streamed`). Each pixel's motion is the field-weighted motion of the balls
/// whose support holds its point (`effects::metaballs::motion::previous_point`, f64, over every
/// ball of the group), so a ball the pass's walk over the pixel's tile missed would show; then
/// again from inside the crowd, where every hit is an exit. Each
/// term is rounded in f32 (the weights to a few ε of Σf ≥ T/max q, the centres' differences to
/// ε·|c|): ~1e-5 of the balls' 0.1 spread of motions, ~1e-4 px here, inside `MOTION_TOL`.
#[test]
fn a_crowd_of_balls_each_moving_its_own_way() {
    crowd_moving(Binning::Host);
}

/// The same with the tile lists built on the device (sorted by the device's f32 entry keys,
/// which the walk's early end reads).
#[test]
fn a_crowd_of_balls_each_moving_its_own_way_binned_on_the_device() {
    crowd_moving(Binning::Device);
}

fn crowd_moving(binning: Binning) {
    use hadou::effects::metaballs::motion::previous_point;
    use hadou::effects::metaballs::{CastMethod, Kernel, MetaballGroupParams};
    use hadou::scene::transform::{Transform, TransformOp};
    let scene =
        "[camera]\nposition = [0, 1, 8]\nlook_at = [0, 0.3, 0]\nfov_y_deg = 50\nnear = 0.5\nfar = 60\n\
                 [[light]]\ndirection = [-0.3, -1, -0.5]\n[[material]]\nname = \"slime\"\n[[metaballs]]\n\
                 material = \"slime\"\nthreshold = 0.4\nkernel = \"wyvill6\"\n\
                 transform = [{ scale = [1, 1.3, 0.8] }, { rotate = { angle_deg = 25, axis = [0, 0, 1] } }]\n\
                 balls = [{ centre = [0, 0, 0], radius = 1 }]\n";
    let ops = [
        TransformOp::Scale(DVec3::new(1.0, 1.3, 0.8)),
        TransformOp::Rotate { angle_deg: 25.0, axis: DVec3::Z },
    ];
    let transform = Transform::from_ops(&ops).unwrap();
    let effects =
        Effects::none().with(Metaballs::with_binning(binning)).and_then(|e| e.with(UpscalerInputs)).unwrap();
    let mut rt = common::runtime_with_effects(effects);
    rt.load_scene(common::parse(scene)).unwrap();
    let c = camera(DVec3::new(0.0, 1.0, 8.0));
    rt.renderer().set_camera(c).unwrap();
    rt.renderer().set_motion_vectors(true).unwrap();
    // 360 balls along x, ~100 supports on a point of the axis; ball i moves by its own d(i).
    let k = 360;
    let crowd = |moved: bool| -> Vec<Ball> {
        (0..k)
            .map(|i| {
                let f = i as f64;
                let at = DVec3::new(-2.6 + 5.2 * f / k as f64, 0.3 * (0.9 * f).sin(), 0.3 * (1.7 * f).cos());
                let d = 0.05 * DVec3::new((1.3 * f).sin(), (0.7 * f).cos(), (2.1 * f).sin());
                let radius = 1.0 + 0.2 * (0.37 * f).sin().abs();
                Ball { centre: if moved { at + d } else { at }, radius, q: 0.05 }
            })
            .collect()
    };
    let group = rt.renderer().metaballs_ids()[0];
    rt.renderer().set_metaball_group(group, &crowd(false)).unwrap();
    render(&mut rt, &[Aov::Motion]);
    rt.renderer().set_metaball_group(group, &crowd(true)).unwrap();
    let out = render(&mut rt, &[Aov::Motion, Aov::Depth]);
    let now = MetaballGroupParams {
        threshold: 0.4,
        kernel: Kernel::Wyvill6,
        balls: crowd(true),
        transform,
        method: CastMethod::default(),
    };
    let before: Vec<DVec3> = crowd(false).iter().map(|b| b.centre).collect();
    let back = |p: DVec3| previous_point(&now, Some(&before), now.transform.matrix, p);
    let (motion, depth) = (out.aov(Aov::Motion).unwrap(), out.aov(Aov::Depth).unwrap());
    let (surface, worst) = check("a crowd", motion, depth, (&c, &c, &c), back);
    let streamed = out.stats.counter("metaballs.streamed");
    println!("a crowd: {surface} surface pixels, {streamed} casts streamed, largest error {worst:.1e} px");
    assert!(surface > 800 && streamed > 0, "{surface} surface pixels, {streamed} streamed");
    assert_eq!(out.stats.counter("metaballs.dropped"), 0);
    // From inside the crowd, looking along it: every hit is where a ray leaves the surface.
    let inside =
        Camera { look_at: transform.transform_point(DVec3::new(2.0, 0.0, 0.0)), ..camera(DVec3::ZERO) };
    rt.renderer().set_camera(inside).unwrap();
    rt.renderer().set_metaball_group(group, &crowd(false)).unwrap();
    render(&mut rt, &[Aov::Motion]);
    rt.renderer().set_metaball_group(group, &crowd(true)).unwrap();
    let out = render(&mut rt, &[Aov::Motion, Aov::Depth]);
    let (motion, depth) = (out.aov(Aov::Motion).unwrap(), out.aov(Aov::Depth).unwrap());
    let (surface, worst) = check("inside the crowd", motion, depth, (&inside, &inside, &inside), back);
    println!("inside the crowd: {surface} surface pixels, largest error {worst:.1e} px");
    assert!(surface > 3000, "{surface} surface pixels seen from inside");
    assert_eq!(out.stats.counter("metaballs.dropped"), 0);
    rt.finish();
}

/// Balls a game writes on the GPU (`set_metaball_buffer`) with their previous centres in their
/// records (`DeviceBalls::previous_centres`): the surface's motion follows them as it follows the
/// host's balls; without them the group moves by its transform only (here: not at all).
#[test]
fn metaballs_from_the_games_buffer_move_with_their_previous_centres() {
    use hadou::gpu::memory::{Memory, MemoryLocation};
    use hadou::gpu::vk;
    use hadou::{DeviceBall, DeviceBalls};
    let scene =
        "[camera]\nposition = [0, 1, 8]\nlook_at = [0, 0.3, 0]\nfov_y_deg = 50\nnear = 0.5\nfar = 60\n\
                 [[light]]\ndirection = [-0.3, -1, -0.5]\n[[material]]\nname = \"slime\"\n[[metaballs]]\n\
                 material = \"slime\"\nthreshold = 0.4\nballs = [{ centre = [0, 0, 0], radius = 1 }]\n";
    let mut rt = common::runtime();
    rt.load_scene(common::parse(scene)).unwrap();
    let c = camera(DVec3::new(0.0, 1.0, 8.0));
    rt.renderer().set_camera(c).unwrap();
    rt.renderer().set_motion_vectors(true).unwrap();
    let rest = [[-0.6f32, 0.0, 0.0, 1.2], [0.5, 0.3, 0.0, 1.0], [0.0, -0.4, 0.3, 1.1]];
    let records = |d: [f32; 3], prev: [f32; 3]| -> Vec<DeviceBall> {
        rest.iter()
            .map(|r| DeviceBall {
                centre_radius: [r[0] + d[0], r[1] + d[1], r[2] + d[2], r[3]],
                q: [1.0, r[0] + prev[0], r[1] + prev[1], r[2] + prev[2]],
            })
            .collect()
    };
    let memory = Memory::new(rt.context()).unwrap();
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
    let mut buffer =
        memory.create_buffer(rt.context(), "game balls", 96, usage, MemoryLocation::CpuToGpu).unwrap();
    let group = rt.renderer().metaballs_ids()[0];
    let source = DeviceBalls { buffer: buffer.raw, offset: 0, count: 3, previous_centres: true };
    rt.renderer().set_metaball_buffer(group, Some(source)).unwrap();
    buffer.write(0, bytemuck::cast_slice(&records([0.0; 3], [0.0; 3]))).unwrap();
    render(&mut rt, &[Aov::Motion]);
    let d = [0.2f32, 0.1, -0.15];
    buffer.write(0, bytemuck::cast_slice(&records(d, [0.0; 3]))).unwrap();
    let out = render(&mut rt, &[Aov::Motion, Aov::Depth]);
    let df = DVec3::new(d[0].into(), d[1].into(), d[2].into());
    let (motion, depth) = (out.aov(Aov::Motion).unwrap(), out.aov(Aov::Depth).unwrap());
    let (surface, worst) = check("the game's balls", motion, depth, (&c, &c, &c), |p| p - df);
    println!("the game's balls: {surface} surface pixels, largest error {worst:.1e} px");
    assert!(surface > 150, "{surface}");
    // The same frame without previous centres: the group did not move, so neither did its surface.
    let source = DeviceBalls { previous_centres: false, ..source };
    rt.renderer().set_metaball_buffer(group, Some(source)).unwrap();
    let still = render(&mut rt, &[Aov::Motion]);
    assert!(still.aov(Aov::Motion).unwrap().data.iter().all(|&m| m == 0.0));
    // The game's buffer goes before the device (the renderer draws no more frames from it).
    drop((buffer, memory));
    rt.finish();
}

/// The inputs written into a game's own images (`View::upscaler`) for its upscaler to read on the
/// GPU: the motion image gets hadou's motion where hadou drew a surface and keeps the game's value
/// elsewhere; the masks get the larger of the game's and hadou's (an R8 mask within half a step).
/// A format the pass cannot write, and targets without motion vectors on, are refused.
#[test]
fn upscaler_targets_are_written_into_the_games_images() {
    use hadou::gpu::barriers::{cmd_barriers, image_barrier, memory_barrier, ImageAccess};
    use hadou::gpu::memory::{ImageHandles, Memory, MemoryLocation};
    use hadou::gpu::recorder::Recorder;
    use hadou::gpu::vk;
    use hadou::{ExternalImage, UpscalerTargets, View, ViewCamera};
    let (w, h) = (64u32, 48u32);
    let extent = vk::Extent2D { width: w, height: h };
    let (_leaks, ctx) = common::context();
    let memory = Memory::new(&ctx).unwrap();
    let usage =
        vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST;
    let image = |name: &str, format| memory.create_image(&ctx, name, extent, format, usage).unwrap();
    let (motion, reactive) =
        (image("game motion", vk::Format::R32G32_SFLOAT), image("game reactive", vk::Format::R8_UNORM));
    let readback = |name: &str, bytes: u64| {
        let usage = vk::BufferUsageFlags::TRANSFER_DST;
        memory.create_buffer(&ctx, name, bytes * u64::from(w * h), usage, MemoryLocation::GpuToCpu).unwrap()
    };
    let (motion_back, reactive_back) = (readback("motion back", 8), readback("reactive back", 1));
    let mut host = common::host::Host::new(&ctx, 1);
    let mut hadou = hadou::Renderer::new(ctx).unwrap();
    hadou.load_scene(common::parse(BOX)).unwrap();
    let external = |i: &hadou::gpu::memory::Image| ExternalImage {
        image: i.raw,
        view: i.view,
        format: i.format,
        layout: vk::ImageLayout::GENERAL,
        final_layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
    };
    let handles =
        |i: &hadou::gpu::memory::Image| ImageHandles { raw: i.raw, view: i.view, format: i.format, extent };
    let targets =
        UpscalerTargets { motion: external(&motion), reactive: Some(external(&reactive)), composition: None };
    let view = View { upscaler: Some(targets), ..View::headless(ViewCamera::Renderer, w, h) };
    // Refused: no motion vectors yet; then a format the pass cannot write.
    let cmd = host.begin(0);
    assert!(hadou.record_views(cmd, 0.0, &[view]).unwrap_err().to_string().contains("set_motion_vectors"));
    hadou.set_motion_vectors(true).unwrap();
    let bad = UpscalerTargets {
        motion: ExternalImage { format: vk::Format::R8G8B8A8_UNORM, ..targets.motion },
        ..targets
    };
    let err = hadou.record_views(cmd, 0.0, &[View { upscaler: Some(bad), ..view }]).unwrap_err().to_string();
    assert!(err.contains("View.upscaler.motion.format"), "{err}");
    assert_eq!(hadou.next_frame(), 0);
    host.submit(0);
    let (game_motion, game_reactive) = ([7.0f32, -3.0, 0.0, 0.0], [0.25f32, 0.0, 0.0, 0.0]);
    let mut aovs = None;
    for (i, position) in [DVec3::new(0.3, 1.0, 8.0), DVec3::new(-0.4, 1.3, 7.7)].into_iter().enumerate() {
        hadou.set_camera(camera(position)).unwrap();
        let cmd = host.begin(0);
        // The game's own values, then hadou's frame.
        let rec = Recorder { ctx: hadou.context(), cmd };
        let to_general: Vec<_> = [&motion, &reactive]
            .iter()
            .filter_map(|i| {
                image_barrier(i.raw, i.format, ImageAccess::UNDEFINED, ImageAccess::CLEAR_GENERAL)
            })
            .collect();
        cmd_barriers(&hadou.context().device, cmd, &to_general, &[]);
        rec.clear_general_image(&handles(&motion), vk::ClearColorValue { float32: game_motion });
        rec.clear_general_image(&handles(&reactive), vk::ClearColorValue { float32: game_reactive });
        hadou.record_views(cmd, 0.0, &[view]).unwrap();
        if i == 1 {
            aovs = Some(hadou.record_aov_readback(cmd, &[Aov::Motion, Aov::Reactive, Aov::Normal]).unwrap());
            let rec = Recorder { ctx: hadou.context(), cmd };
            rec.copy_image_to_buffer(&handles(&motion), &motion_back);
            rec.copy_image_to_buffer(&handles(&reactive), &reactive_back);
            let to_host = memory_barrier(
                vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::TRANSFER_WRITE,
                vk::PipelineStageFlags2::HOST,
                vk::AccessFlags2::HOST_READ,
            );
            cmd_barriers(&hadou.context().device, cmd, &[], &[to_host]);
        }
        host.submit(0);
        host.wait_all();
    }
    let aovs = aovs.unwrap();
    let (m, r, n) =
        (aovs.aov(Aov::Motion).unwrap(), aovs.aov(Aov::Reactive).unwrap(), aovs.aov(Aov::Normal).unwrap());
    let got_motion: &[f32] = bytemuck::cast_slice(motion_back.mapped().unwrap());
    let got_reactive = reactive_back.mapped().unwrap();
    let (mut surface, mut moving) = (0, 0);
    for i in 0..(w * h) as usize {
        let want = if n.data[4 * i + 3] == 1.0 { [m.data[2 * i], m.data[2 * i + 1]] } else { [7.0, -3.0] };
        assert_eq!([got_motion[2 * i], got_motion[2 * i + 1]], want, "pixel {i}: motion");
        surface += usize::from(n.data[4 * i + 3] == 1.0);
        moving += usize::from(want[0] != 0.0 && want[0] != 7.0);
        let want = r.data[i].max(0.25);
        assert!(
            (f32::from(got_reactive[i]) / 255.0 - want).abs() <= 0.5 / 255.0 + 1e-6,
            "pixel {i}: reactive"
        );
    }
    assert!(surface > 150 && moving > 150, "{surface} surface pixels, {moving} moving");
    drop(aovs);
    host.destroy();
    drop((motion, reactive, motion_back, reactive_back, memory));
    drop(hadou);
}

/// The first two tests' motions 10⁴ and 10⁵ units from the world's origin: a box moving and
/// turning and two balls moving, seen by a moving camera a few units away, within `MOTION_TOL`
/// like the others. Every position the raster and the motion passes handle is relative to the
/// camera, composed with its position in f64 (FrameUniforms, MotionFrame, `gpu_group`); with
/// world-space f32 products the errors were, at 10⁴ and 10⁵: the balls 0.010 and 0.13 px, the
/// box 0.030 and 0.20 px (measured when written); now ~2e-5 px at both.
#[test]
fn far_from_the_origin() {
    for far in [1.0e4, 1.0e5] {
        let at = DVec3::new(far, 0.0, -far);
        let scene = format!(
            "[camera]\nposition = [{cx}, 1, {cz}]\nlook_at = [{x}, 0.3, {z}]\nfov_y_deg = 50\nnear = 0.5\nfar = 60\n\
             [[light]]\ndirection = [-0.3, -1, -0.5]\n[[mesh]]\nname = \"box\"\nkind = \"cube\"\nsize = 2\n\
             [[instance]]\nmesh = \"box\"\n[[material]]\nname = \"slime\"\n[[metaballs]]\nmaterial = \"slime\"\n\
             threshold = 0.4\ntransform = [{{ translate = [{x}, 0, {z}] }}]\n\
             balls = [{{ centre = [2.2, 0, 0], radius = 1.2 }}, {{ centre = [3, 0.5, 0], radius = 1 }}]\n",
            x = at.x,
            z = at.z,
            cx = at.x + 1.0,
            cz = at.z + 8.0,
        );
        let mut rt = common::runtime();
        rt.load_scene(common::parse(&scene)).unwrap();
        let id = rt.renderer().instance_ids()[0];
        let group = rt.renderer().metaballs_ids()[0];
        let place = DMat4::from_translation(at);
        let a = place * DMat4::from_translation(DVec3::new(-0.6, 0.1, 0.0)) * DMat4::from_rotation_y(0.3);
        let b = place * DMat4::from_translation(DVec3::new(-0.4, -0.2, 0.5)) * DMat4::from_rotation_y(0.45);
        let cam = |p: DVec3| Camera { look_at: at + DVec3::new(0.5, 0.3, 0.0), ..camera(at + p) };
        let (c0, c1) = (cam(DVec3::new(1.3, 1.0, 8.0)), cam(DVec3::new(0.5, 1.4, 7.6)));
        let balls = |d: DVec3| {
            vec![
                Ball { centre: DVec3::new(2.2, 0.0, 0.0) + d, radius: 1.2, q: 1.0 },
                Ball { centre: DVec3::new(3.0, 0.5, 0.0) + d, radius: 1.0, q: 1.0 },
            ]
        };
        let d = DVec3::new(0.15, -0.1, 0.2);
        let r = rt.renderer();
        r.set_motion_vectors(true).unwrap();
        r.set_transform(id, a).unwrap();
        r.set_camera(c0).unwrap();
        r.set_metaball_group(group, &balls(DVec3::ZERO)).unwrap();
        render(&mut rt, &[Aov::Motion]);
        let r = rt.renderer();
        r.set_transform(id, b).unwrap();
        r.set_camera(c1).unwrap();
        r.set_metaball_group(group, &balls(d)).unwrap();
        let out = render(&mut rt, &[Aov::Motion, Aov::Depth]);
        // The balls lie right of the box's reach (its half-diagonal √2 from x = −0.4).
        let on_balls = |p: DVec3| p.x - at.x > 1.2;
        let back =
            |p: DVec3| if on_balls(p) { p - d } else { a.transform_point3(b.inverse().transform_point3(p)) };
        let (motion, depth) = (out.aov(Aov::Motion).unwrap(), out.aov(Aov::Depth).unwrap());
        let (surface, worst) = check(&format!("at {far}"), motion, depth, (&c1, &c1, &c0), back);
        let balls_seen = (0..W * H)
            .filter(|&i| {
                let (o, u) = c1.pixel_ray(i % W, i / W, W, H);
                let t = f64::from(depth.data[i as usize]);
                t.is_finite() && on_balls(o + t * u)
            })
            .count();
        println!(
            "at {far}: {surface} surface pixels ({balls_seen} on the balls), largest error {worst:.1e} px"
        );
        assert!(surface > 600 && balls_seen > 150, "{surface} surface pixels, {balls_seen} on the balls");
        assert_eq!(out.stats.counter("metaballs.dropped"), 0);
        rt.finish();
    }
}
