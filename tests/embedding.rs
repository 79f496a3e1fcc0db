//! Embedding: a "game" with its own ash instance, device, queue and command buffer (the game
//! prototype's Vulkan code, not hadou's context) rasterizes a tilted wall into its own standard-Z
//! depth and colour, embeds hadou with `GpuContext::from_raw`, records hadou's frame into its own
//! command buffer and submits it on its own queue. Checked against the f64 references and against
//! the headless `Runtime` rendering the same scene with the wall as a hadou instance.
//! Lavapipe, validation + synchronization validation on (the game's messenger sees hadou's
//! messages too): zero errors, zero warnings.

mod common;

#[path = "../examples/game_prototype/gpu.rs"]
mod gpu;
#[path = "../examples/game_prototype/painter.rs"]
mod painter;

use ash::vk;
use glam::{DMat4, DQuat, DVec3};
use gpu::{GameImage, GameVk, HostBuffer};
use hadou::effects::energy_wave::line_integral;
use hadou::effects::tonemap::{aces, srgb_encode};
use hadou::gpu::{EnabledFeatures, GpuContext, GpuError};
use hadou::passes::depth_import::import_depth;
use hadou::passes::energy_wave::wave_params;
use hadou::scene::Scene;
use hadou::testing::Comparison;
use hadou::{
    Aov, DepthConvention, ExternalColor, ExternalDepth, FrameInputs, FrameRequest, Renderer, WaveUpdate,
};
use painter::{BoxDraw, GameCamera, PaintTarget, Painter};

const COLOR: vk::Format = vk::Format::R8G8B8A8_UNORM;
const DEPTH: vk::Format = vk::Format::D32_SFLOAT;

/// The game's camera (near 1, far 60; standard Z unless a test turns reverse-Z on) — hadou gets
/// the same one.
fn camera() -> GameCamera {
    GameCamera {
        position: DVec3::new(0.0, 1.0, 12.0),
        look_at: DVec3::ZERO,
        fov_y_deg: 50.0,
        near: 1.0,
        far: 60.0,
        reverse_z: false,
    }
}

/// Side of the wall: small enough that the sky shows around it.
const WALL: f64 = 16.0;

/// The wall: the `plane` mesh (XZ, WALL × WALL) rotated 70° about x, then moved to z = -1.
fn wall_matrix() -> DMat4 {
    DMat4::from_translation(DVec3::new(0.0, 0.0, -1.0))
        * DMat4::from_quat(DQuat::from_rotation_x(70f64.to_radians()))
}

const WAVE: &str = r#"
[[wave]]
origin = [-4, -0.5, 2]
direction = [1, 0.1, -0.3]
a = 2
b = 1
core = 0.02
length = 12
intensity = 0.02
"#;

/// hadou's part of the scene: a cube that the wall cuts, and a wave. `with_wall` adds the wall as
/// a hadou instance (the headless twin of the game's wall).
fn scene(with_wall: bool) -> Scene {
    let wall = if with_wall {
        r#"
        [[mesh]]
        name = "wall"
        kind = "plane"
        size = 16
        [[instance]]
        mesh = "wall"
        transform = [{ rotate = { angle_deg = 70, axis = [1, 0, 0] } }, { translate = [0, 0, -1] }]
        "#
    } else {
        ""
    };
    common::parse(&format!(
        r#"
        [camera]
        position = [0, 1, 12]
        look_at = [0, 0, 0]
        fov_y_deg = 50
        near = 1
        far = 60
        [[light]]
        direction = [-0.3, -1, -0.5]
        intensity = 2
        [[mesh]]
        name = "box"
        kind = "cube"
        size = 3
        [[instance]]
        mesh = "box"
        transform = [{{ rotate = {{ angle_deg = 30, axis = [0, 1, 0] }} }}, {{ translate = [-2, 0.5, -1] }}]
        {wall}
        {WAVE}
        "#
    ))
}

/// The game: its own device, images and raster, and hadou embedded on top.
struct Game {
    vk: GameVk,
    painter: Painter,
    color: GameImage,
    depth: GameImage,
    extent: vk::Extent2D,
    /// How hadou is told about the game's depth (the same standard-Z projection either way).
    convention: DepthConvention,
    /// Hand hadou the depth with `write` (depth out).
    write_depth: bool,
}

/// What one game frame read back.
struct Frame {
    color: Vec<u8>,
    depth: Vec<f32>,
    aovs: Vec<(Aov, hadou::AovImage)>,
    recorded: bool,
}

impl Frame {
    fn aov(&self, aov: Aov) -> &[f32] {
        &self.aovs.iter().find(|(a, _)| *a == aov).unwrap().1.data
    }
}

impl Game {
    /// A game rendering with standard Z, or reverse-Z with `reverse_z`.
    fn new(extent: vk::Extent2D, reverse_z: bool) -> Game {
        let vk =
            GameVk::new(true, &[], &[], &|_, _, _, _| true).unwrap_or_else(|e| panic!("game device: {e}"));
        let painter = Painter::new(&vk, COLOR, DEPTH, reverse_z).unwrap();
        let (color, depth) = Self::images(&vk, extent);
        let (near, far) = (camera().near, camera().far);
        let convention = if reverse_z {
            DepthConvention::ReverseZ { near, far }
        } else {
            DepthConvention::Standard { near, far }
        };
        Game { vk, painter, color, depth, extent, convention, write_depth: false }
    }

    fn images(vk: &GameVk, extent: vk::Extent2D) -> (GameImage, GameImage) {
        let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let color = vk.create_image(extent, COLOR, usage).unwrap();
        let usage = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
            | vk::ImageUsageFlags::SAMPLED
            | vk::ImageUsageFlags::TRANSFER_SRC;
        let depth = vk.create_image(extent, DEPTH, usage).unwrap();
        (color, depth)
    }

    fn resize(&mut self, hadou: &mut Renderer, extent: vk::Extent2D) {
        // SAFETY: the game's live device.
        unsafe { self.vk.device.device_wait_idle() }.unwrap();
        let (color, depth) = Self::images(&self.vk, extent);
        self.vk.destroy_image(std::mem::replace(&mut self.color, color));
        self.vk.destroy_image(std::mem::replace(&mut self.depth, depth));
        // The old depth view is gone (a new view may reuse its handle): hadou binds the view it
        // is handed each frame, so there is nothing to tell it.
        let _ = hadou;
        self.extent = extent;
    }

    /// One frame: the game's wall into its colour and depth, then (with `hadou`) hadou's frame in
    /// the same command buffer, then copies of colour, depth and the AOVs; submit, wait.
    fn frame(&self, hadou: Option<&mut Renderer>, aovs: &[Aov], time: f64) -> Frame {
        let g = &self.vk;
        let e = self.extent;
        g.begin().unwrap();
        let undefined = vk::ImageLayout::UNDEFINED;
        g.transition(self.color.image, COLOR, undefined, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
        g.transition(self.depth.image, DEPTH, undefined, vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL);
        let wall = BoxDraw {
            model: wall_matrix() * DMat4::from_scale(DVec3::new(WALL, 0.0, WALL)),
            color: DVec3::new(0.3, 0.35, 0.4),
        };
        let clear = DVec3::new(0.05, 0.05, 0.1);
        let target = PaintTarget { color: self.color.view, depth: self.depth.view, extent: e, clear };
        let cam = GameCamera { reverse_z: self.painter.reverse_z, ..camera() };
        self.painter.record(g, &target, &cam, &[wall]);
        let mut readback = None;
        let mut recorded = false;
        if let Some(hadou) = hadou {
            let inputs = FrameInputs {
                extent: e,
                time,
                depth: Some(ExternalDepth {
                    image: self.depth.image,
                    view: self.depth.view,
                    format: DEPTH,
                    layout: vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                    final_layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    convention: self.convention,
                    write: self.write_depth,
                }),
                color: Some(ExternalColor {
                    image: self.color.image,
                    view: self.color.view,
                    format: COLOR,
                    layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                    final_layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                }),
            };
            let frame = hadou.record_frame(g.cmd, &inputs).unwrap();
            recorded = frame.recorded;
            if recorded {
                readback = Some((hadou.record_aov_readback(g.cmd, aovs).unwrap(), frame.frame, hadou));
            }
        }
        if !recorded {
            let src = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
            g.transition(self.color.image, COLOR, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL, src);
            g.transition(self.depth.image, DEPTH, vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL, src);
        }
        let pixels = (e.width * e.height) as u64;
        let color_buf = g.create_host_buffer(pixels * 4).unwrap();
        let depth_buf = g.create_host_buffer(pixels * 4).unwrap();
        g.record_copy_to_host(&self.color, &color_buf);
        g.record_copy_to_host(&self.depth, &depth_buf);
        g.submit_and_wait(None, None).unwrap();
        let frame = Frame {
            color: color_buf.bytes().to_vec(),
            depth: floats(&depth_buf),
            aovs: readback
                .map(|(rb, frame, hadou)| {
                    // The game waited on its fence: hadou may read the frame's timings now.
                    hadou.frame_finished(frame).unwrap();
                    aovs.iter().map(|&a| (a, rb.aov(a).unwrap())).collect()
                })
                .unwrap_or_default(),
            recorded,
        };
        g.destroy_buffer(color_buf);
        g.destroy_buffer(depth_buf);
        frame
    }

    fn assert_clean(&self) {
        let (errors, warnings) = self.vk.messages.counts();
        let texts = self.vk.messages.texts.lock().unwrap().join("\n");
        assert!(errors == 0 && warnings == 0, "validation: {errors} errors, {warnings} warnings:\n{texts}");
    }

    /// hadou's objects first, then the game's: the ownership order `from_raw` documents.
    fn finish(self, hadou: Renderer) {
        drop(hadou);
        self.painter.destroy(&self.vk);
        self.vk.destroy_image(self.color);
        self.vk.destroy_image(self.depth);
        let messages = self.vk.messages.clone();
        self.vk.destroy();
        let (errors, warnings) = messages.counts();
        assert!(errors == 0 && warnings == 0, "at shutdown: {:?}", messages.texts.lock().unwrap());
    }
}

fn floats(b: &HostBuffer) -> Vec<f32> {
    b.bytes().chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

/// hadou's own Vulkan calls, counted: `embed` hands hadou a copy of the game's device whose
/// function table routes pipeline creation, fence and device-idle waits and query reads through
/// counters (per device handle; the game's own calls go through its unhooked table and are not
/// counted). What hadou says of itself (`host_waits`) is checked against what it did.
mod calls {
    use ash::vk;
    use ash::vk::Handle;
    use std::sync::Mutex;

    /// What hadou called on one device since `hook`.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct Counts {
        /// Pipelines created (graphics and compute).
        pub pipelines: u64,
        /// vkWaitForFences calls.
        pub fence_waits: u64,
        /// vkDeviceWaitIdle calls.
        pub device_idle: u64,
        /// vkGetQueryPoolResults calls, and those among them with VK_QUERY_RESULT_WAIT_BIT.
        pub query_reads: u64,
        pub query_waits: u64,
    }

    #[derive(Clone, Copy)]
    struct Real {
        graphics: vk::PFN_vkCreateGraphicsPipelines,
        compute: vk::PFN_vkCreateComputePipelines,
        wait_for_fences: vk::PFN_vkWaitForFences,
        device_wait_idle: vk::PFN_vkDeviceWaitIdle,
        query_results: vk::PFN_vkGetQueryPoolResults,
    }

    static HOOKED: Mutex<Vec<(u64, Real, Counts)>> = Mutex::new(Vec::new());

    /// Counts into `device`'s entry and returns its real functions.
    fn count(device: vk::Device, add: impl FnOnce(&mut Counts)) -> Real {
        let mut hooked = HOOKED.lock().unwrap();
        let entry = hooked.iter_mut().find(|(d, _, _)| *d == device.as_raw()).expect("a hooked device");
        add(&mut entry.2);
        entry.1
    }

    /// What hadou called on `device` so far.
    pub fn counts(device: vk::Device) -> Counts {
        HOOKED.lock().unwrap().iter().find(|(d, _, _)| *d == device.as_raw()).expect("a hooked device").2
    }

    /// A copy of `device` whose calls above are counted (from zero).
    pub fn hook(device: &ash::Device) -> ash::Device {
        let mut v1_0 = device.fp_v1_0().clone();
        let real = Real {
            graphics: v1_0.create_graphics_pipelines,
            compute: v1_0.create_compute_pipelines,
            wait_for_fences: v1_0.wait_for_fences,
            device_wait_idle: v1_0.device_wait_idle,
            query_results: v1_0.get_query_pool_results,
        };
        let handle = device.handle().as_raw();
        let mut hooked = HOOKED.lock().unwrap();
        // A handle seen before belonged to a device destroyed since: start it again.
        hooked.retain(|(d, _, _)| *d != handle);
        hooked.push((handle, real, Counts::default()));
        v1_0.create_graphics_pipelines = create_graphics_pipelines;
        v1_0.create_compute_pipelines = create_compute_pipelines;
        v1_0.wait_for_fences = wait_for_fences;
        v1_0.device_wait_idle = device_wait_idle;
        v1_0.get_query_pool_results = get_query_pool_results;
        ash::Device::from_parts_1_3(
            device.handle(),
            v1_0,
            device.fp_v1_1().clone(),
            device.fp_v1_2().clone(),
            device.fp_v1_3().clone(),
        )
    }

    unsafe extern "system" fn create_graphics_pipelines(
        device: vk::Device,
        cache: vk::PipelineCache,
        n: u32,
        infos: *const vk::GraphicsPipelineCreateInfo<'_>,
        allocator: *const vk::AllocationCallbacks<'_>,
        out: *mut vk::Pipeline,
    ) -> vk::Result {
        let real = count(device, |c| c.pipelines += u64::from(n));
        // SAFETY: the real entry point loaded for this device, called with the caller's arguments
        // unchanged (the caller upholds that call's contract).
        unsafe { (real.graphics)(device, cache, n, infos, allocator, out) }
    }

    unsafe extern "system" fn create_compute_pipelines(
        device: vk::Device,
        cache: vk::PipelineCache,
        n: u32,
        infos: *const vk::ComputePipelineCreateInfo<'_>,
        allocator: *const vk::AllocationCallbacks<'_>,
        out: *mut vk::Pipeline,
    ) -> vk::Result {
        let real = count(device, |c| c.pipelines += u64::from(n));
        // SAFETY: as in create_graphics_pipelines.
        unsafe { (real.compute)(device, cache, n, infos, allocator, out) }
    }

    unsafe extern "system" fn wait_for_fences(
        device: vk::Device,
        n: u32,
        fences: *const vk::Fence,
        all: vk::Bool32,
        timeout: u64,
    ) -> vk::Result {
        let real = count(device, |c| c.fence_waits += 1);
        // SAFETY: as in create_graphics_pipelines.
        unsafe { (real.wait_for_fences)(device, n, fences, all, timeout) }
    }

    unsafe extern "system" fn device_wait_idle(device: vk::Device) -> vk::Result {
        let real = count(device, |c| c.device_idle += 1);
        // SAFETY: as in create_graphics_pipelines.
        unsafe { (real.device_wait_idle)(device) }
    }

    #[allow(clippy::too_many_arguments)]
    unsafe extern "system" fn get_query_pool_results(
        device: vk::Device,
        pool: vk::QueryPool,
        first: u32,
        n: u32,
        size: usize,
        data: *mut std::ffi::c_void,
        stride: vk::DeviceSize,
        flags: vk::QueryResultFlags,
    ) -> vk::Result {
        let real = count(device, |c| {
            c.query_reads += 1;
            c.query_waits += u64::from(flags.contains(vk::QueryResultFlags::WAIT));
        });
        // SAFETY: as in create_graphics_pipelines.
        unsafe { (real.query_results)(device, pool, first, n, size, data, stride, flags) }
    }
}

fn embed(game: &Game, scene: Scene) -> Renderer {
    let mut raw = game.vk.hadou_raw();
    raw.device = calls::hook(&raw.device);
    // SAFETY: the game's handles are valid, its features are EnabledFeatures::REQUIRED, and the
    // renderer is dropped before the game destroys its device (Game::finish).
    let ctx = unsafe { GpuContext::from_raw(raw) }.unwrap();
    let mut hadou = Renderer::new(ctx).unwrap();
    hadou.load_scene(scene).unwrap();
    hadou
}

fn extent(width: u32, height: u32) -> vk::Extent2D {
    vk::Extent2D { width, height }
}

/// The f64 distance along pixel (x, y)'s ray to the wall plane (+inf when it misses the
/// wall), and whether the pixel is safely inside it (away from its border).
fn wall_distance(x: u32, y: u32, e: vk::Extent2D) -> (f64, bool) {
    let cam = camera().for_hadou();
    let (o, u) = cam.pixel_ray(x, y, e.width, e.height);
    let m = wall_matrix();
    let p0 = m.transform_point3(DVec3::ZERO);
    let n = m.transform_vector3(DVec3::Y).normalize();
    let t = (p0 - o).dot(n) / u.dot(n);
    let local = m.inverse().transform_point3(o + u * t);
    let half = WALL / 2.0;
    let inside = t > 0.0 && local.x.abs() < half && local.z.abs() < half;
    // A pixel whose ray passes within 0.5 of the border may be covered or not: skipped.
    let safe = local.x.abs() < half - 0.5 && local.z.abs() < half - 0.5;
    let clear = local.x.abs() > half + 0.5 || local.z.abs() > half + 0.5 || t <= 0.0;
    let safe = if inside { safe } else { clear };
    (if inside { t } else { f64::INFINITY }, safe)
}

/// Pixels where hadou's cube is visible: the normal AOV is set and not the wall's.
fn cube_mask(normal: &[f32], wall_normal: Option<DVec3>) -> Vec<bool> {
    normal
        .chunks_exact(4)
        .map(|n| {
            let hit = n[3] == 1.0;
            let is_wall = wall_normal.is_some_and(|w| {
                let v = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
                (v - w).length() < 1e-2 || (v + w).length() < 1e-2
            });
            hit && !is_wall
        })
        .collect()
}

/// True when a pixel or one of its 8 neighbours differs in `mask` from its neighbour: visibility
/// may flip there between two depth paths that agree to 1e-5 (the cube–wall intersection line).
fn near_edge(mask: &[bool], x: u32, y: u32, e: vk::Extent2D) -> bool {
    let at = |x: i64, y: i64| {
        let (x, y) = (x.clamp(0, e.width as i64 - 1), y.clamp(0, e.height as i64 - 1));
        mask[(y * e.width as i64 + x) as usize]
    };
    let c = at(x as i64, y as i64);
    (-2..=2).any(|dy| (-2..=2).any(|dx| at(x as i64 + dx, y as i64 + dy) != c))
}

/// Relative error of two values neither of which is the reference, with 0 for two zeros; NaN when
/// either is NaN or only one is infinite.
fn rel(a: f64, b: f64) -> f64 {
    if a == b {
        0.0
    } else {
        let scale = if a.abs() > b.abs() { a.abs() } else { b.abs() };
        (a - b).abs() / scale
    }
}

/// The key check: the embedded frame gives the headless path's numbers (energy, distance, the
/// cube's visibility) and the f64 references; the depth import matches its f64 twin; the colour
/// is hadou's tonemapped result over the cube and the game's colour plus the wave's glow elsewhere.
#[test]
fn embedded_frame_matches_headless_and_f64() {
    let e = extent(96, 72);
    let game = Game::new(e, false);
    let mut hadou = embed(&game, scene(false));
    let aovs = [Aov::Energy, Aov::Depth, Aov::Normal, Aov::Hdr];
    let before = game.frame(None, &[], 0.0);
    let frame = game.frame(Some(&mut hadou), &aovs, 0.0);
    assert!(frame.recorded);
    game.assert_clean();

    let mut rt = common::runtime();
    rt.load_scene(scene(true)).unwrap();
    let mut req = FrameRequest::new(e.width, e.height);
    req.aovs = vec![Aov::Energy, Aov::Depth, Aov::Normal];
    let headless = rt.render(&req).unwrap();
    common::assert_clean(&rt);

    let cam = camera().for_hadou();
    let wall_n = wall_matrix().transform_vector3(DVec3::Y).normalize();
    let mask_e = cube_mask(frame.aov(Aov::Normal), None);
    let mask_h = cube_mask(&headless.aov(Aov::Normal).unwrap().data, Some(wall_n));
    let params = wave_params(&scene(false).waves()[0].at(0.0));
    let frame_ray = cam.ray_frame(e.width, e.height);
    let conv = DepthConvention::Standard { near: 1.0, far: 60.0 };
    let u = f32::EPSILON as f64 / 2.0;
    let (mut cube_px, mut wall_px) = (0, 0);
    let mut import = Comparison::new("depth import vs its f64 twin, relative to the bound");
    let mut distance = Comparison::new("distance embedded vs headless");
    let mut pair = Comparison::new("energy embedded vs headless");
    let mut energy = Comparison::new("energy vs f64 on wall and sky");
    for y in 0..e.height {
        for x in 0..e.width {
            let i = (y * e.width + x) as usize;
            // Depth import vs its f64 twin, on the depth the game stored. Bound: the shader's
            // z = B / (d + A) (standard Z: A = f/(n − f)) cancels in d + A by |A|/|d + A| = z/n
            // (A rounded to f32 and the sum rounded: ≤ 2 roundings scaled by z/n), plus ~8 in B,
            // the division, the pixel ray's length and the f32 ray frame.
            let ndc_x = 2.0 * (x as f64 + 0.5) / e.width as f64 - 1.0;
            let ndc_y = 1.0 - 2.0 * (y as f64 + 0.5) / e.height as f64;
            let scale = (frame_ray.forward + frame_ray.right * ndc_x + frame_ray.up * ndc_y).length();
            let (want, _) = import_depth(frame.depth[i] as f64, conv, scale, &cam);
            let got_distance = frame.aov(Aov::Depth)[i] as f64;
            if !mask_e[i] {
                if want.is_infinite() {
                    assert!(got_distance.is_infinite(), "({x}, {y}): sky imported as {got_distance}");
                } else {
                    let z = want / scale;
                    let bound = (2.0 * z / 1.0 + 8.0) * u;
                    import.error(
                        format_args!("({x}, {y}): {got_distance} vs f64 {want}"),
                        rel(got_distance, want) / bound,
                    );
                }
            }
            if near_edge(&mask_h, x, y, e) {
                continue;
            }
            // Away from the cube–wall intersection and the cube's silhouette, the cube's visibility
            // is the same in both paths.
            assert_eq!(
                mask_e[i], mask_h[i],
                "({x}, {y}): cube visible embedded {} vs headless {}",
                mask_e[i], mask_h[i]
            );
            let (energy_e, energy_h) =
                (frame.aov(Aov::Energy)[i] as f64, headless.aov(Aov::Energy).unwrap().data[i] as f64);
            let (dist_e, dist_h) = (got_distance, headless.aov(Aov::Depth).unwrap().data[i] as f64);
            // Distances: the headless raster's (≤ 1e-5 relative, gpu_raster) and the import's
            // (the bound above, ≤ 1e-5 for z ≤ 60) agree within 2e-5.
            if dist_h.is_finite() || dist_e.is_finite() {
                distance
                    .error(format_args!("({x}, {y}): {dist_e} vs headless {dist_h}"), rel(dist_e, dist_h));
            }
            // Energy: each path is within 1e-4 of the f64 integral up to its own depth
            // (gpu_energy_wave's bound), and the depths agree within 2e-5 with dH/dL·L/H ≤ 1 — so the
            // two paths agree within 2e-4.
            pair.error(
                format_args!("({x}, {y}): {energy_e} vs headless {energy_h}"),
                rel(energy_e, energy_h),
            );
            if mask_e[i] {
                cube_px += 1;
                continue;
            }
            // On the wall and the sky: the f64 integral up to the f64 wall intersection.
            let (t_wall, safe) = wall_distance(x, y, e);
            if !safe {
                continue;
            }
            wall_px += 1;
            let (o, dir) = cam.pixel_ray(x, y, e.width, e.height);
            let reference = line_integral(&params, o, dir, t_wall.min(cam.far));
            energy.rel(format_args!("({x}, {y})"), energy_e, reference);
        }
    }
    println!("{cube_px} cube and {wall_px} wall/sky pixels");
    assert!(cube_px > 50 && wall_px > 1000, "the scene must show both: {cube_px} cube, {wall_px} wall");
    // Floors: the import on every pixel outside the cube but the sky (most of the image); the
    // pairs on every pixel away from the cube's edges; the f64 energy on the safe wall and sky.
    let pixels = (e.width * e.height) as usize;
    import.assert_within(1.0, pixels / 2);
    distance.assert_within(2e-5, pixels / 2);
    pair.assert_within(2e-4, pixels * 3 / 4);
    energy.assert_within(1e-4, 1000);
    check_composite(&before, &frame, &mask_e, e);
    drop(rt);
    game.finish(hadou);
}

/// Over on hadou's surfaces, added elsewhere (UNORM target: sRGB-encoded tonemapped values).
/// Bound: 1 code — the expected value is computed in f64 from the same f16 HDR texels the shader
/// read, so only the f32 ACES/pow rounding (< 1e-5) and the final rounding to 8 bits differ.
fn check_composite(before: &Frame, after: &Frame, cube: &[bool], e: vk::Extent2D) {
    let hdr = after.aov(Aov::Hdr);
    let mut codes = Comparison::new("composite vs f64, in 8-bit codes");
    let mut unsaturated = 0;
    for i in 0..(e.width * e.height) as usize {
        for c in 0..3 {
            // The shader's max(hdr, 0), keeping a NaN (which then fails the comparison).
            let h = hdr[i * 4 + c] as f64;
            let glow = srgb_encode(aces(if h < 0.0 { 0.0 } else { h }));
            let alpha = hdr[i * 4 + 3] as f64;
            assert_eq!(alpha, if cube[i] { 1.0 } else { 0.0 }, "pixel {i}: alpha {alpha}");
            let dst = before.color[i * 4 + c] as f64 / 255.0;
            let sum = glow + (1.0 - alpha) * dst;
            let want = ((if sum > 1.0 { 1.0 } else { sum }) * 255.0).round();
            let got = after.color[i * 4 + c] as f64;
            codes.abs(format_args!("pixel {i} channel {c}"), got, want);
            unsaturated += usize::from(want < 255.0);
        }
    }
    // Every channel of every pixel compared, and most of them not decided by the clamp at 1 (the
    // wave's intensity keeps its glow in range).
    let channels = (e.width * e.height * 3) as usize;
    codes.assert_within(1.0, channels);
    assert!(unsaturated * 4 >= channels * 3, "only {unsaturated} of {channels} channels below 255");
}

/// A 0 × 0 frame records nothing and is no error; a resize rebuilds hadou's images and the numbers
/// stay right at the new size (the game renders reverse-Z here: its sky is depth 0); latest_timings
/// is None until a frame finished, then names every scope, all without waiting on the queries:
/// hadou's counted calls show no vkGetQueryPoolResults at all (the timestamps reach the host by a
/// copy recorded in the frame, read once the game's fence said so), no fence wait and no
/// device-idle wait; and no pipeline is built again by a resize (the import and composite
/// pipelines are built by the first frame that hands hadou a depth and a colour).
#[test]
fn zero_extent_resize_and_timings() {
    let mut game = Game::new(extent(40, 30), true);
    let mut hadou = embed(&game, scene(false));
    let device = game.vk.device.handle();
    let loaded = calls::counts(device);
    assert!(loaded.pipelines > 0, "the shim sees hadou's pipelines being built: {loaded:?}");
    let said = hadou.context().host_waits();
    assert!(hadou.latest_timings().is_none(), "no frame has run yet");

    game.vk.begin().unwrap();
    let inputs = FrameInputs::headless(0, 0, 0.0);
    let recorded = hadou.record_frame(game.vk.cmd, &inputs).unwrap();
    assert!(!recorded.recorded);
    game.vk.submit_and_wait(None, None).unwrap();
    assert!(hadou.latest_timings().is_none());

    let mut first_frame = None;
    for size in [extent(40, 30), extent(56, 20), extent(40, 30)] {
        game.resize(&mut hadou, size);
        let frame = game.frame(Some(&mut hadou), &[Aov::Energy, Aov::Normal, Aov::Depth], 0.0);
        first_frame.get_or_insert(calls::counts(device));
        assert!(frame.recorded);
        let (_, sky) = check_energy_on_wall(&frame, &scene(false), size, 0);
        assert!(sky > 10, "the game's sky shows at {size:?}: {sky} pixels");
    }
    let timings = hadou.latest_timings().expect("a finished frame has timings");
    let names: Vec<&str> = timings.passes.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["depth_import", "raster", "energy_wave", "composite", "readback"]);
    assert!(timings.passes.iter().all(|p| p.gpu_ms.is_finite() && p.gpu_ms >= 0.0));
    println!("latest frame {}: {:?}", timings.frame, timings.passes);
    let (first_frame, after) = (first_frame.unwrap(), calls::counts(device));
    println!("hadou's calls after load_scene: {loaded:?}, the first frame: {first_frame:?}, all: {after:?}");
    assert_eq!(
        (after.query_reads, after.fence_waits, after.device_idle),
        (loaded.query_reads, loaded.fence_waits, loaded.device_idle),
        "hadou read the queries or waited during the frames"
    );
    assert_eq!(after.query_waits, 0, "a query read waited");
    assert_eq!(after.pipelines, first_frame.pipelines, "a resize rebuilt a pipeline");
    assert_eq!(hadou.context().host_waits(), said, "hadou's own count agrees");
    game.finish(hadou);
}

/// Distance and energy on wall and sky pixels away from the cube vs the f64 wall distance and the
/// f64 integral up to it. Returns the number of pixels checked and how many of them were sky.
fn check_energy_on_wall(frame: &Frame, scene: &Scene, e: vk::Extent2D, wave: usize) -> (usize, usize) {
    let cam = camera().for_hadou();
    let params = wave_params(&scene.waves()[wave].at(0.0));
    let mask = cube_mask(frame.aov(Aov::Normal), None);
    let (mut checked, mut sky) = (0, 0);
    for y in 0..e.height {
        for x in 0..e.width {
            let i = (y * e.width + x) as usize;
            let (t_wall, safe) = wall_distance(x, y, e);
            if near_edge(&mask, x, y, e) || mask[i] || !safe {
                continue;
            }
            // The imported distance: +inf for the game's sky (its far-plane depth), else the f64
            // wall distance within the import bound (≤ 1e-5 for z ≤ 60, see above).
            let distance = frame.aov(Aov::Depth)[i] as f64;
            if t_wall.is_infinite() {
                assert!(distance.is_infinite(), "({x}, {y}) at {e:?}: sky imported as {distance}");
                sky += 1;
            } else {
                assert!(rel(distance, t_wall) <= 2e-5, "({x}, {y}) at {e:?}: {distance} vs f64 {t_wall}");
            }
            let (o, dir) = cam.pixel_ray(x, y, e.width, e.height);
            let reference = line_integral(&params, o, dir, t_wall.min(cam.far));
            let got = frame.aov(Aov::Energy)[i] as f64;
            assert!(rel(got, reference) <= 1e-4, "({x}, {y}) at {e:?}: {got} vs f64 {reference}");
            checked += 1;
        }
    }
    assert!(checked as u32 > e.width * e.height / 2, "{checked} pixels checked");
    (checked, sky)
}

/// The update API: a new wave (origin, a, b, length, direction) and a moved cube change the
/// picture as the f64 reference predicts, with no pipeline rebuilt. The game hands its depth
/// convention as its projection matrix here.
#[test]
fn update_api_changes_the_picture_as_predicted() {
    let e = extent(48, 36);
    let mut game = Game::new(e, false);
    // The game's projection matrix itself, instead of near/far.
    game.convention = DepthConvention::Projection(camera().projection(e.width as f64 / e.height as f64));
    let mut hadou = embed(&game, scene(false));
    let device = game.vk.device.handle();
    let first = game.frame(Some(&mut hadou), &[Aov::Energy, Aov::Normal], 0.0);
    let built = calls::counts(device).pipelines;
    assert!(built > 0, "the shim sees hadou's pipelines");
    let cube_before = cube_mask(first.aov(Aov::Normal), None).iter().filter(|&&c| c).count();
    assert!(cube_before > 20);

    let update = WaveUpdate {
        origin: DVec3::new(2.0, 1.0, 0.5),
        direction: DVec3::new(-1.0, 0.4, 0.2),
        a: 5.0,
        b: 0.5,
        length: 4.0,
    };
    let (wave, cube) = (hadou.wave_ids()[0], hadou.instance_ids()[0]);
    hadou.set_wave(wave, update).unwrap();
    // Out of view: the cube leaves the picture.
    hadou.set_transform(cube, DMat4::from_translation(DVec3::new(500.0, 0.0, 0.0))).unwrap();
    let second = game.frame(Some(&mut hadou), &[Aov::Energy, Aov::Normal, Aov::Depth], 0.0);
    let cube_after = cube_mask(second.aov(Aov::Normal), None).iter().filter(|&&c| c).count();
    assert_eq!(cube_after, 0, "the moved cube is out of view");
    assert_eq!(calls::counts(device).pipelines, built, "an update rebuilt a pipeline");
    let mut moved = scene(false);
    let w = &mut moved.waves_mut()[0];
    (w.origin, w.direction, w.a, w.b, w.length) =
        (update.origin, update.direction.normalize(), 5.0, 0.5, 4.0);
    let (checked, _) = check_energy_on_wall(&second, &moved, e, 0);
    // The picture did change: the old wave's energy is far from the new one's somewhere.
    let changed = first
        .aov(Aov::Energy)
        .iter()
        .zip(second.aov(Aov::Energy))
        .any(|(a, b)| rel(*a as f64, *b as f64) > 0.1);
    assert!(changed && checked > 0);
    // Bad updates are refused with a message, not a panic.
    let bad = WaveUpdate { a: -1.0, ..update };
    assert!(hadou.set_wave(wave, bad).unwrap_err().to_string().contains("wave 0"));
    assert!(hadou.set_transform(cube, DMat4::ZERO).is_err());
    game.finish(hadou);
}

/// The camera given once: the game hands its view and projection (`set_view_projection`) and its
/// depth with `DepthConvention::Camera`, and hadou reads the depth in that projection's convention:
/// the wall's imported distances and energy match the f64 twin as in the other embedding tests.
/// The same matrices as glam f32 (game math) are taken too: they differ from the f64 ones by a
/// rounding of each entry (2⁻²⁴ relative), which moves the import z = B/(d + A) by at most
/// (|A|/|d + A| + 2)·2⁻²⁴ ≈ (z + 2)·6e-8 — under 2e-6 at the wall's z ≤ 25 — and the pixel rays
/// by a few 2⁻²⁴, so the two frames' distances agree to 1e-5 (margin 5×). A convention named
/// beside the projection that disagrees (another far plane) is refused with both named; one that
/// agrees to f32 rounding is taken.
#[test]
fn camera_given_once() {
    let e = extent(48, 36);
    let mut game = Game::new(e, false);
    let mut hadou = embed(&game, scene(false));
    let cam = camera();
    let view = DMat4::look_at_rh(cam.position, cam.look_at, DVec3::Y);
    let proj = cam.projection(e.width as f64 / e.height as f64);
    hadou.set_view_projection(view, proj).unwrap();
    game.convention = DepthConvention::Camera;
    let aovs = [Aov::Energy, Aov::Depth, Aov::Normal];
    let f64_frame = game.frame(Some(&mut hadou), &aovs, 0.0);
    let (checked, sky) = check_energy_on_wall(&f64_frame, &scene(false), e, 0);
    assert!(checked > 0 && sky > 0, "{checked} wall pixels, {sky} sky");

    hadou.set_view_projection(view.as_mat4(), proj.as_mat4()).unwrap();
    let f32_frame = game.frame(Some(&mut hadou), &aovs, 0.0);
    let mut compared = 0;
    for (a, b) in f64_frame.aov(Aov::Depth).iter().zip(f32_frame.aov(Aov::Depth)) {
        if a.is_finite() {
            assert!(rel(*a as f64, *b as f64) <= 1e-5, "f64 matrices {a}, f32 matrices {b}");
            compared += 1;
        } else {
            assert_eq!(a, b, "sky in one frame only");
        }
    }
    assert!(compared > 0);

    // A convention of the game's own beside the projection: checked against it, before any
    // recording (`prepare` runs the frame's checks).
    let inputs = |convention| FrameInputs {
        extent: e,
        time: 0.0,
        depth: Some(ExternalDepth {
            image: game.depth.image,
            view: game.depth.view,
            format: DEPTH,
            layout: vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
            final_layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            convention,
            write: false,
        }),
        color: None,
    };
    let (near, far) = (cam.near, cam.far);
    hadou.prepare(&inputs(DepthConvention::Standard { near, far })).unwrap();
    let err = hadou.prepare(&inputs(DepthConvention::Standard { near, far: 2.0 * far })).unwrap_err();
    assert!(matches!(err, hadou::Error::DepthConvention(_)), "{err:?}");
    let text = err.to_string();
    assert!(text.contains("set_view_projection") && text.contains("DepthConvention::Camera"), "{text}");
    let err = hadou.prepare(&inputs(DepthConvention::ReverseZ { near, far })).unwrap_err();
    assert!(matches!(err, hadou::Error::DepthConvention(_)), "{err:?}");
    game.finish(hadou);
}

/// A run-time bake put in use compiles and waits for nothing: the frame that swaps in the new
/// thickness tables rebuilds the translucency passes on them with the pipelines the scene's memo
/// kept (a compile there was an 18–45 ms hitch on lavapipe, 138 ms under validation), and a pair
/// table's image is copied by that frame's own commands (it was a one-off copy waited on its
/// fence). Counted on the hooked device from after the spawn to after the switch-over: no
/// pipeline created, no fence or device wait; for a field table and for the first pair table
/// (whose pipeline variant the spawn made ahead).
#[test]
fn a_bake_put_in_use_compiles_and_waits_for_nothing() {
    let game = Game::new(extent(48, 36), false);
    let scene = common::parse(
        r#"
        [camera]
        position = [0, 1, 12]
        look_at = [0, 0, 0]
        near = 1
        far = 60
        [[light]]
        direction = [-0.3, -1, -0.5]
        intensity = 2
        [[mesh]]
        name = "box"
        kind = "cube"
        size = 2
        [[mesh]]
        name = "hollow"
        kind = "cavity_cube"
        size = 2
        cavity_radius = 0.5
        segments = 12
        rings = 6
        [[material]]
        name = "jade"
        kind = "translucent"
        albedo = [0.5, 0.9, 0.6]
        sigma = [1, 0.5, 0.8]
        voxel_res = 10
        [[material]]
        name = "glass"
        kind = "translucent"
        thickness = "pairs"
        albedo = [0.8, 0.8, 0.9]
        sigma = [0.6, 0.6, 0.4]
        voxel_res = 8
        [[instance]]
        mesh = "box"
        material = "jade"
        "#,
    );
    let mut hadou = embed(&game, scene);
    let device = game.vk.device.handle();
    game.frame(Some(&mut hadou), &[], 0.0);
    // A field table (`lut`), then the first pair table (its image staged, copied by a frame).
    for (material, x) in [("jade", 2.5), ("glass", -2.5)] {
        hadou.spawn_instance("hollow", material, DMat4::from_translation(DVec3::new(x, 0.0, 0.0))).unwrap();
        assert!(!hadou.bakes_in_progress().is_empty(), "the {material} table bakes in the background");
        let before = calls::counts(device);
        let mut frames = 0;
        while !hadou.bakes_in_progress().is_empty() {
            game.frame(Some(&mut hadou), &[], 0.0);
            frames += 1;
            assert!(frames < 3000, "the bake never came");
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        // The switch-over happened in the last frame's record_frame (the passes were rebuilt there).
        game.frame(Some(&mut hadou), &[], 0.0);
        let after = calls::counts(device);
        assert_eq!(
            after.pipelines, before.pipelines,
            "{material}: a pipeline was compiled at the switch-over"
        );
        assert_eq!(after.fence_waits, before.fence_waits, "{material}: hadou waited on a fence");
        assert_eq!(after.device_idle, before.device_idle, "{material}: hadou waited for the device");
    }
    game.assert_clean();
    game.finish(hadou);
}

/// A device without a feature hadou needs is refused by name, before anything is created.
#[test]
fn from_raw_names_a_missing_feature() {
    let game = Game::new(extent(8, 8), false);
    let mut raw = game.vk.hadou_raw();
    raw.enabled = EnabledFeatures { host_query_reset: false, ..EnabledFeatures::REQUIRED };
    // SAFETY: the game's valid handles; `enabled` understates the device (a feature it has left
    // out), which from_raw refuses before creating anything.
    let err = unsafe { GpuContext::from_raw(raw) }.err().expect("refused").to_string();
    assert!(err.contains("hostQueryReset"), "{err}");
    let mut raw = game.vk.hadou_raw();
    raw.queue_family = 99;
    // SAFETY: the game's valid handles; the family that is not the device's is refused by from_raw's
    // bounds check before any call uses it.
    let err = unsafe { GpuContext::from_raw(raw) }.err().expect("refused");
    assert!(matches!(err, GpuError::RawQueue { field: "queue_family", .. }), "{err:?}");
    let err = err.to_string();
    assert!(err.contains("queue family"), "{err}");
    let hadou = embed(&game, scene(false));
    game.finish(hadou);
}

/// Depth out: with `ExternalDepth::write` hadou's nearest surfaces land in the game's depth in the
/// game's convention (standard and reverse-Z), so the game's later passes are hidden behind them;
/// elsewhere the game's depth is left as it was. Against the f64 twin `store_depth` of the view
/// depth hadou read back: the shader's d = −A + B/z is a handful of f32 operations on values of
/// magnitude ≤ |A| + |B/z|, and z = distance / |ray| carries two more roundings into B/z, so
/// |Δd| ≤ 16·u·(|A| + |B/z|) with u = 2⁻²⁴ (D32 stores the f32 exactly).
#[test]
fn depth_out_writes_hadous_surfaces_in_the_games_convention() {
    use hadou::passes::depth_import::store_depth;
    let e = extent(80, 60);
    for reverse in [false, true] {
        let mut game = Game::new(e, reverse);
        let mut hadou = embed(&game, scene(false));
        let kept = game.frame(Some(&mut hadou), &[Aov::Depth, Aov::Normal], 0.0);
        game.write_depth = true;
        let frame = game.frame(Some(&mut hadou), &[Aov::Depth, Aov::Normal], 0.0);
        let surface = cube_mask(frame.aov(Aov::Normal), None);
        let cam = camera().for_hadou();
        let ray = cam.ray_frame(e.width, e.height);
        let (a, b) = game.convention.coefficients();
        let u = f32::EPSILON as f64 / 2.0;
        let mut written = 0;
        let mut depth =
            Comparison::new(format!("reverse {reverse}: depth out vs f64, relative to the bound"));
        for y in 0..e.height {
            for x in 0..e.width {
                let i = (y * e.width + x) as usize;
                if !surface[i] {
                    assert_eq!(
                        frame.depth[i].to_bits(),
                        kept.depth[i].to_bits(),
                        "({x}, {y}): the game's depth changed"
                    );
                    continue;
                }
                let ndc_x = 2.0 * (x as f64 + 0.5) / e.width as f64 - 1.0;
                let ndc_y = 1.0 - 2.0 * (y as f64 + 0.5) / e.height as f64;
                let scale = (ray.forward + ray.right * ndc_x + ray.up * ndc_y).length();
                let z = frame.aov(Aov::Depth)[i] as f64 / scale;
                let want = store_depth(z, game.convention);
                let got = frame.depth[i] as f64;
                let bound = 16.0 * u * (a.abs() + (b / z).abs());
                depth.error(format_args!("({x}, {y}): {got} vs f64 {want}"), (got - want).abs() / bound);
                // Nearer than what the game drew there (or the game's sky).
                let nearer = if reverse { got >= kept.depth[i] as f64 } else { got <= kept.depth[i] as f64 };
                assert!(nearer, "({x}, {y}): hadou's surface {got} behind the game's {}", kept.depth[i]);
                written += 1;
            }
        }
        assert!(written > 50, "the cube shows: {written}");
        depth.assert_within(1.0, written);
        game.finish(hadou);
    }
}

/// `exposure = "auto"` in a game's frame (issue 26): the composite measures hadou's frame on the
/// GPU (exposure.comp before it draws) and adapts across frames without waiting for any of them.
/// A still scene gives the same bits frame after frame (the adaptation a + (m − a)·w keeps a when
/// m = a); after the light gets 16× brighter the next frames — 1/30 s apart in scene time, which
/// the adaptation follows (not the wall clock) — are brighter than the same scene exposed from its
/// own frame (the exposure lags), and darken toward it frame by frame.
#[test]
fn auto_exposure_adapts_across_a_games_frames_without_waiting() {
    let e = extent(64, 48);
    let game = Game::new(e, false);
    let mut s = scene(false);
    s.render.exposure_mode = hadou::scene::ExposureMode::Auto;
    let mut hadou = embed(&game, s.clone());
    let device = game.vk.device.handle();
    let aovs = [Aov::Normal];
    let first = game.frame(Some(&mut hadou), &aovs, 0.0);
    let loaded = calls::counts(device);
    let cube = cube_mask(first.aov(Aov::Normal), None);
    assert!(cube.iter().filter(|&&c| c).count() > 100, "the cube is in view");
    let mean = |f: &Frame| {
        let codes: Vec<f64> =
            (0..cube.len()).filter(|&i| cube[i]).map(|i| f.color[i * 4 + 1] as f64).collect();
        codes.iter().sum::<f64>() / codes.len() as f64
    };
    for _ in 0..4 {
        let f = game.frame(Some(&mut hadou), &aovs, 0.0);
        assert!(f.color == first.color, "a still scene changed under the automatic exposure");
    }
    let still = mean(&first);
    println!("auto exposure, still: the cube's mean green code {still:.1}");
    assert!((40.0..=220.0).contains(&still), "{still}");

    let light = hadou.scene().unwrap().lights[0];
    let id = hadou.light_ids()[0];
    hadou.set_light(id, light.direction, light.color, light.intensity * 16.0).unwrap();
    let after: Vec<f64> =
        (1..=6).map(|k| mean(&game.frame(Some(&mut hadou), &aovs, f64::from(k) / 30.0))).collect();
    let after_calls = calls::counts(device);
    assert_eq!(
        (after_calls.fence_waits, after_calls.device_idle, after_calls.query_waits),
        (loaded.fence_waits, loaded.device_idle, loaded.query_waits),
        "hadou waited during the frames"
    );
    let mut bright = s.clone();
    bright.lights[0].intensity *= 16.0;
    let mut fresh = embed(&game, bright);
    let own = mean(&game.frame(Some(&mut fresh), &aovs, 0.0));
    println!("after the light got 16x brighter: {after:.1?}; exposed from its own frame: {own:.1}");
    assert!(after[0] > own + 2.0, "the exposure lags: {} vs {own}", after[0]);
    assert!(after.windows(2).all(|w| w[1] <= w[0]), "darkening toward it: {after:?}");
    assert!(after[5] < after[0] - 1.0, "darkening toward it: {after:?}");
    drop(fresh);
    game.finish(hadou);
}
