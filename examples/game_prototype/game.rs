//! The game: its state and loop step (charge, fire, the slime's wobble), its own scene drawn by
//! its own raster into its own colour and depth, and hadou embedded on its device for the energy
//! wave, the translucent target and the metaball slime. Windowed (main.rs) or headless
//! (`Game::offscreen_submit`, used by tests/game_prototype.rs). Both run `FRAMES_IN_FLIGHT`
//! frames in flight: the game waits only on the fence of the frame that last used a slot.
#![allow(dead_code)]

use ash::vk;
use glam::{DMat4, DVec3};
use hadou::{
    Aov, Ball, DepthConvention, ExternalColor, ExternalDepth, GroupId, Renderer, View, ViewCamera, WaveDesc,
    WaveId, WaveUpdate,
};

use super::gpu::{GameImage, GameVk, HostBuffer, FRAMES_IN_FLIGHT};
use super::painter::{BoxDraw, GameCamera, PaintTarget, Painter};
use super::slime_sim::{SlimeSim, SLIME_BALLS};

/// hadou's part of the scene: the translucent target (lit from behind), the slime, the wave.
/// The game's own geometry (floor, player, pillars) is not here: hadou sees it through the depth.
pub const HADOU_SCENE: &str = r#"
[render]
exposure = 1.0
ambient = [0.06, 0.06, 0.08]

[camera]
position = [0.5, 3.5, 17]
look_at = [0.5, 1, 0]
fov_y_deg = 50
near = 0.5
far = 100

[[light]]
# From behind the target toward the player and the camera: the target glows through.
direction = [-0.7, -0.35, 0.6]
color = [1.0, 0.9, 0.75]
intensity = 4.0

[[mesh]]
name = "target"
kind = "cube"
size = 1.6

[[material]]
name = "jelly"
kind = "translucent"
albedo = [0.95, 0.55, 0.35]
sigma = [0.6, 1.4, 2.6]
voxel_res = 12

[[material]]
name = "slime"
albedo = [0.25, 0.8, 0.35]

[[instance]]
name = "target"
mesh = "target"
material = "jelly"
transform = [{ rotate = { angle_deg = 20, axis = [0, 1, 0] } }, { translate = [6.5, 1.0, 0] }]

[[metaballs]]
name = "slime"
material = "slime"
transform = [{ translate = [1.5, 0.55, 0.6] }]
balls = [
  { centre = [0, 0, 0], radius = 1.5 },
  { centre = [0.9, 0.2, 0], radius = 1.2 },
  { centre = [-0.7, 0.1, 0.4], radius = 1.1 },
]

"#;

/// The slime's balls at rest (object space), as in HADOU_SCENE.
const SLIME: [([f64; 3], f64); 3] = [([0.0, 0.0, 0.0], 1.5), ([0.9, 0.2, 0.0], 1.2), ([-0.7, 0.1, 0.4], 1.1)];

/// The keys held this frame (README: Space charges, releasing fires; A/D or ←/→ move; R resets).
#[derive(Clone, Copy, Debug, Default)]
pub struct Input {
    pub charge: bool,
    pub left: bool,
    pub right: bool,
    pub reset: bool,
}

impl Input {
    /// A key went down or up: whether it is one of the game's (README: Space, A/D, ←/→, R).
    pub fn key(&mut self, code: winit::keyboard::KeyCode, down: bool) -> bool {
        use winit::keyboard::KeyCode;
        match code {
            KeyCode::Space => self.charge = down,
            KeyCode::KeyA | KeyCode::ArrowLeft => self.left = down,
            KeyCode::KeyD | KeyCode::ArrowRight => self.right = down,
            KeyCode::KeyR => self.reset = down,
            _ => return false,
        }
        true
    }
}

/// A fired shot: where it started and with what charge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shot {
    pub fired_at: f64,
    pub charge: f64,
    pub from: DVec3,
}

#[derive(Clone, Debug, PartialEq)]
pub struct GameState {
    pub time: f64,
    pub player_z: f64,
    /// 0..=1 while Space is held.
    pub charge: f64,
    pub shot: Option<Shot>,
    /// Shots that reached the target.
    pub hits: u32,
}

pub const PLAYER_X: f64 = -5.0;
pub const TARGET_X: f64 = 6.5;
/// Seconds of holding Space to charge fully.
pub const CHARGE_TIME: f64 = 1.5;
/// World units per second of a fired shot.
pub const SHOT_SPEED: f64 = 9.0;

impl Default for GameState {
    fn default() -> Self {
        GameState { time: 0.0, player_z: 0.0, charge: 0.0, shot: None, hits: 0 }
    }
}

impl GameState {
    /// Advances the game by `dt` seconds under `input`.
    pub fn step(&mut self, input: &Input, dt: f64) {
        if input.reset {
            *self = GameState { time: self.time, ..GameState::default() };
        }
        self.time += dt;
        let walk = f64::from(u8::from(input.right)) - f64::from(u8::from(input.left));
        self.player_z = (self.player_z + 3.0 * walk * dt).clamp(-2.0, 2.0);
        if let Some(shot) = self.shot {
            let head = shot.from.x + SHOT_SPEED * (self.time - shot.fired_at);
            if head > TARGET_X + 2.0 {
                self.shot = None;
                self.hits += 1;
            }
            return;
        }
        if input.charge {
            self.charge = (self.charge + dt / CHARGE_TIME).min(1.0);
        } else if self.charge > 0.0 {
            let from = self.hand();
            self.shot = Some(Shot { fired_at: self.time, charge: self.charge, from });
            self.charge = 0.0;
        }
    }

    fn hand(&self) -> DVec3 {
        DVec3::new(PLAYER_X + 0.6, 1.0, self.player_z)
    }

    /// The wave this frame: while charging a and b grow and the beam extends from the hand; once
    /// fired, the wave flies toward the target at SHOT_SPEED, its beam trailing.
    pub fn wave(&self) -> WaveUpdate {
        let direction = DVec3::X;
        match self.shot {
            Some(shot) => {
                let travelled = SHOT_SPEED * (self.time - shot.fired_at);
                WaveUpdate {
                    origin: shot.from + direction * travelled,
                    direction: -direction,
                    a: 0.3 + 3.0 * shot.charge,
                    b: 0.2 + 1.5 * shot.charge,
                    length: (0.5 + 5.0 * shot.charge).min(travelled.max(0.05)),
                }
            }
            None => WaveUpdate {
                origin: self.hand(),
                direction,
                a: 0.02 + 2.0 * self.charge,
                b: 0.02 + 1.0 * self.charge,
                length: 0.3 + 3.0 * self.charge,
            },
        }
    }

    /// The wave hadou draws this frame, if any: the charging wave at the hand, or the shot in
    /// flight; none between shots (hadou's energy pass is then not run).
    pub fn wave_desc(&self) -> Option<WaveDesc> {
        if self.shot.is_none() && self.charge == 0.0 {
            return None;
        }
        let w = self.wave();
        let (color, intensity) = (DVec3::new(0.35, 0.65, 1.0), 0.08);
        Some(WaveDesc {
            origin: w.origin,
            direction: w.direction,
            a: w.a,
            b: w.b,
            core: 0.05,
            length: w.length,
            color,
            intensity,
            cutoff: 0.0,
        })
    }

    /// The slime's balls this frame: each bobs on its own phase, and every few seconds two drops
    /// bud off the blob, drift apart as separate blobs and merge back.
    pub fn slime(&self) -> Vec<Ball> {
        let t = self.time;
        let mut balls: Vec<Ball> = SLIME
            .iter()
            .map(|&(c, radius)| {
                let c = DVec3::from(c);
                let phase = 2.1 * c.x + 1.3 * c.z;
                let bob = DVec3::new(0.12 * (1.7 * t + phase).sin(), 0.18 * (2.3 * t + phase).sin(), 0.0);
                Ball { centre: c + bob, radius, q: 1.0 }
            })
            .collect();
        // 0 → 1 → 0 over a 4 s cycle: how far the drops are from the blob.
        let apart = (0.5 - 0.5 * (std::f64::consts::TAU * t / 4.0).cos()).powi(2);
        for side in [-1.0, 1.0] {
            let centre = DVec3::new(side * (0.4 + 2.2 * apart), 0.3 + 0.8 * apart, 0.2);
            balls.push(Ball { centre, radius: 0.9, q: 1.0 });
        }
        balls
    }

    /// The game's own scene: floor, player, two pillars.
    pub fn boxes(&self) -> Vec<BoxDraw> {
        let place = |at: DVec3, size: DVec3, color: DVec3| BoxDraw {
            model: DMat4::from_translation(at) * DMat4::from_scale(size),
            color,
        };
        let glow = 0.3 + 0.7 * self.charge;
        vec![
            place(DVec3::new(0.0, -0.05, 0.0), DVec3::new(30.0, 0.1, 12.0), DVec3::new(0.25, 0.24, 0.22)),
            place(
                DVec3::new(PLAYER_X, 0.75, self.player_z),
                DVec3::new(0.6, 1.5, 0.6),
                DVec3::new(0.2, 0.3, glow),
            ),
            place(DVec3::new(-1.5, 1.5, -2.5), DVec3::new(0.7, 3.0, 0.7), DVec3::new(0.5, 0.45, 0.4)),
            place(DVec3::new(4.0, 1.5, -3.0), DVec3::new(0.7, 3.0, 0.7), DVec3::new(0.5, 0.45, 0.4)),
        ]
    }
}

pub fn camera() -> GameCamera {
    GameCamera {
        position: DVec3::new(0.5, 3.5, 17.0),
        look_at: DVec3::new(0.5, 1.0, 0.0),
        fov_y_deg: 50.0,
        near: 0.5,
        far: 100.0,
        reverse_z: false,
    }
}

/// The wave as `desc` says, now: spawned when it starts (charging), moved while it lives,
/// despawned when it ends; the id it has then.
pub fn sync_wave(
    hadou: &mut Renderer,
    wave: Option<WaveId>,
    desc: Option<WaveDesc>,
) -> Result<Option<WaveId>, String> {
    let err = |e: hadou::Error| e.to_string();
    Ok(match (desc, wave) {
        (Some(desc), None) => Some(hadou.spawn_wave(&desc).map_err(err)?),
        (Some(desc), Some(id)) => {
            hadou.update_wave(id, &desc).map_err(err)?;
            Some(id)
        }
        (None, Some(id)) => {
            hadou.despawn_wave(id).map_err(err)?;
            None
        }
        (None, None) => None,
    })
}

/// The second view of split screen (`Game::split`, `V` in the window): from the right, above the
/// target, looking back along the shot's path at the player and the slime.
pub fn side_camera() -> GameCamera {
    GameCamera {
        position: DVec3::new(12.0, 5.0, 9.0),
        look_at: DVec3::new(0.0, 1.0, 0.0),
        fov_y_deg: 55.0,
        near: 0.5,
        far: 100.0,
        reverse_z: false,
    }
}

/// The cameras of the frame's views: the main one alone, or with split screen the main one on
/// the left and `side_camera` on the right.
pub fn view_cameras(split: bool) -> Vec<GameCamera> {
    if split {
        vec![camera(), side_camera()]
    } else {
        vec![camera()]
    }
}

/// The views' sizes in a `extent` frame: the whole, or its left and right halves.
pub fn view_extents(extent: vk::Extent2D, split: bool) -> Vec<vk::Extent2D> {
    if !split {
        return vec![extent];
    }
    let left = extent.width / 2;
    let height = extent.height;
    vec![vk::Extent2D { width: left, height }, vk::Extent2D { width: extent.width - left, height }]
}

pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
pub const CLEAR: DVec3 = DVec3::new(0.04, 0.04, 0.07);

/// The image the game draws into this frame (a swapchain image or its offscreen one).
#[derive(Clone, Copy, Debug)]
pub struct ColorTarget {
    pub image: vk::Image,
    pub view: vk::ImageView,
    pub format: vk::Format,
    pub extent: vk::Extent2D,
    /// The layout the game leaves it in (PRESENT_SRC_KHR for a swapchain image).
    pub final_layout: vk::ImageLayout,
}

pub struct Game {
    pub vk: GameVk,
    pub hadou: Renderer,
    pub state: GameState,
    /// Split screen: two views side by side, each with its own camera (`view_cameras`), recorded
    /// by hadou in one frame (`Renderer::record_views`).
    pub split: bool,
    /// The main camera sways from side to side with the game's time (`main_camera`): the whole
    /// picture moves, what a temporal resolve must follow (the TAA test).
    pub sway: bool,

    painter: Option<Painter>,
    /// Per view: its depth, and with split screen its colour (copied into the target's half).
    views: Vec<ViewImages>,
    offscreen: Option<GameImage>,
    /// Per slot: the headless frame in flight there.
    pending: Vec<Option<Pending>>,
    /// The wave hadou draws for the game (spawned while charging or in flight).
    wave: Option<WaveId>,
    /// The scene's metaball group "slime", drawn from the balls `slime_sim` writes on the GPU.
    slime: GroupId,
    slime_sim: Option<SlimeSim>,
    /// The time the slime was simulated at last (its balls' previous centres).
    sim_time: Option<f64>,
    /// Frames in flight (1..=FRAMES_IN_FLIGHT); hadou's renderer has as many slots.
    frames_in_flight: usize,
    /// Wall time of the last `Renderer::record_frame` (ms).
    pub last_record_ms: f64,
    /// This thread's CPU time in the last `Renderer::record_frame` (ms): its own work, without the
    /// time the thread waited to run (a busy machine's preemption is in the wall time only).
    pub last_record_cpu_ms: f64,
    /// The glTF prop dropped into the world at run time (`toggle_prop`), while it is there.
    prop: Option<hadou::SpawnedGltf>,
}

/// The prop `P` drops beside the player: the volume demo's glass and liquid (a glTF file read at
/// run time, its translucent meshes baked in the background while TSM stands in).
pub const PROP: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/gltf/volume_demo.glb");

/// One view's images: the depth the game draws and hadou reads, and with split screen the colour
/// they are drawn into before the copy into the target (hadou's targets are whole images).
struct ViewImages {
    depth: GameImage,
    color: Option<GameImage>,
}

/// What a headless frame read back, and the state it was rendered from.
pub struct OffscreenFrame {
    pub color: Vec<u8>,
    /// Per view (one, or two with split screen), its AOVs.
    pub views: Vec<Vec<(Aov, hadou::AovImage)>>,
    pub state: GameState,
}

impl OffscreenFrame {
    /// The first view's AOVs.
    pub fn aovs(&self) -> &[(Aov, hadou::AovImage)] {
        &self.views[0]
    }
}

/// A headless frame submitted and not yet read.
pub struct Pending {
    frame: u64,
    state: GameState,
    aovs: Vec<Aov>,
    readbacks: Vec<hadou::AovReadback>,
    color: HostBuffer,
}

impl Game {
    /// Embeds hadou on the game's device and loads hadou's part of the scene.
    pub fn new(vk: GameVk) -> Result<Game, String> {
        Self::with_frames_in_flight(vk, FRAMES_IN_FLIGHT)
    }

    /// As `new`, with `frames` frames in flight (1 or 2: benchmarks compare them).
    pub fn with_frames_in_flight(vk: GameVk, frames: usize) -> Result<Game, String> {
        Self::with_effects(vk, frames, hadou::effect::Effects::builtin())
    }

    /// As `with_frames_in_flight`, with the game's own effects registered beside hadou's.
    pub fn with_effects(vk: GameVk, frames: usize, effects: hadou::effect::Effects) -> Result<Game, String> {
        let frames = frames.clamp(1, FRAMES_IN_FLIGHT);
        // SAFETY: GameVk's handles are valid and enable EnabledFeatures::REQUIRED; Game::destroy
        // drops hadou before the device is destroyed.
        let ctx = unsafe { hadou::gpu::GpuContext::from_raw(vk.hadou_raw()) }.map_err(|e| e.to_string())?;
        // GAME_BUDGET_MS=16 fits hadou's GPU frame into 16 ms (the wave's tolerance, the light map).
        let frame_budget_ms = match std::env::var("GAME_BUDGET_MS") {
            Ok(v) => Some(
                v.parse::<f64>().map_err(|e| format!("GAME_BUDGET_MS={v}: {e} (expected milliseconds)"))?,
            ),
            Err(_) => None,
        };
        let options = hadou::RendererOptions {
            frames_in_flight: frames,
            effects,
            frame_budget_ms,
            ..Default::default()
        };
        let mut hadou = Renderer::with_options(ctx, &options).map_err(|e| e.to_string())?;
        let scene = hadou::scene::parse_scene(HADOU_SCENE, "game_prototype.toml".as_ref())
            .map_err(|e| e.to_string())?;
        hadou.load_scene(scene).map_err(|e| e.to_string())?;
        hadou.set_camera(camera().for_hadou()).map_err(|e| e.to_string())?;
        let slime = hadou.metaballs_named("slime").ok_or("the scene has no metaball group \"slime\"")?;
        // The slime moves on the GPU: hadou reads the game's buffer, no host copy.
        let sim = SlimeSim::new(&vk)?;
        let balls =
            hadou::DeviceBalls { buffer: sim.buffer, offset: 0, count: SLIME_BALLS, previous_centres: true };
        if let Err(e) = hadou.set_metaball_buffer(slime, Some(balls)) {
            drop(hadou);
            sim.destroy(&vk);
            return Err(e.to_string());
        }
        let pending = (0..frames).map(|_| None).collect();
        let (painter, views, offscreen) = (None, Vec::new(), None);
        let state = GameState::default();
        Ok(Game {
            vk,
            hadou,
            state,
            split: false,
            sway: false,
            painter,
            views,
            offscreen,
            pending,
            wave: None,
            slime,
            slime_sim: Some(sim),
            sim_time: None,
            frames_in_flight: frames,
            last_record_ms: 0.0,
            last_record_cpu_ms: 0.0,
            prop: None,
        })
    }

    /// Drops the glTF file at `path` into the world beside the player, or takes the one dropped
    /// before out again (instances, then meshes, materials and lights, by the ids it came with).
    /// Returns whether a prop is there now.
    pub fn toggle_prop(&mut self, path: &std::path::Path) -> Result<bool, String> {
        let err = |e: hadou::Error| e.to_string();
        if let Some(prop) = self.prop.take() {
            for id in prop.instances {
                self.hadou.despawn_instance(id).map_err(err)?;
            }
            for id in prop.meshes {
                self.hadou.despawn_mesh(id).map_err(err)?;
            }
            for id in prop.materials {
                self.hadou.despawn_material(id).map_err(err)?;
            }
            for id in prop.lights {
                self.hadou.despawn_light(id).map_err(err)?;
            }
            return Ok(false);
        }
        let at = DMat4::from_translation(DVec3::new(PLAYER_X + 1.5, 0.0, self.state.player_z + 1.5));
        self.prop = Some(self.hadou.spawn_gltf(path, at).map_err(err)?);
        Ok(true)
    }

    /// Steps the state and hands hadou this frame's wave (no pipeline rebuilt); the slime moves on
    /// the GPU (`record`).
    pub fn update(&mut self, input: &Input, dt: f64) -> Result<(), String> {
        self.state.step(input, dt);
        let err = |e: hadou::Error| e.to_string();
        self.wave = sync_wave(&mut self.hadou, self.wave, self.state.wave_desc())?;
        if self.sway {
            self.hadou.set_camera(self.main_camera().for_hadou()).map_err(err)?;
        }
        Ok(())
    }

    /// The main view's camera: `camera()`, swayed sideways with the time when `sway` is on.
    pub fn main_camera(&self) -> GameCamera {
        let mut c = camera();
        if self.sway {
            let s = 1.5 * (0.8 * self.state.time).sin();
            c.position.x += s;
            c.look_at.x += s;
        }
        c
    }

    /// The painter for `format`, and each view's images for its size in a `extent` frame.
    fn ensure(&mut self, format: vk::Format, extent: vk::Extent2D) -> Result<(), String> {
        if self.painter.as_ref().is_none_or(|p| p.color_format != format) {
            // SAFETY: the game's live device.
            unsafe { self.vk.device.device_wait_idle() }.map_err(|e| e.to_string())?;
            if let Some(p) = self.painter.take() {
                p.destroy(&self.vk);
            }
            self.painter = Some(Painter::new(&self.vk, format, DEPTH_FORMAT, false)?);
        }
        let extents = view_extents(extent, self.split);
        let fits = self.views.len() == extents.len()
            && self.views.iter().zip(&extents).all(|(v, e)| {
                v.depth.extent == *e && v.color.as_ref().map(|c| c.format) == self.split.then_some(format)
            });
        if !fits {
            // SAFETY: the game's live device.
            unsafe { self.vk.device.device_wait_idle() }.map_err(|e| e.to_string())?;
            for v in self.views.drain(..) {
                v.color.into_iter().chain([v.depth]).for_each(|i| self.vk.destroy_image(i));
            }
            for e in extents {
                let usage = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED;
                let depth = self.vk.create_image(e, DEPTH_FORMAT, usage)?;
                let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
                let color = if self.split { Some(self.vk.create_image(e, format, usage)?) } else { None };
                self.views.push(ViewImages { depth, color });
            }
        }
        Ok(())
    }

    /// Records the frame into the game's command buffer (begun by the caller): per view the game's
    /// raster, then hadou's frame of every view (depth import, its passes, composite into the
    /// view's colour), then with split screen the views' colours copied side by side into
    /// `target` (which then needs TRANSFER_DST usage). A 0 × 0 target records nothing.
    pub fn record(&mut self, target: &ColorTarget) -> Result<(), String> {
        let e = target.extent;
        if e.width == 0 || e.height == 0 {
            return Ok(());
        }
        self.ensure(target.format, e)?;
        let Some(painter) = &self.painter else { return Ok(()) };
        let g = &self.vk;
        let undefined = vk::ImageLayout::UNDEFINED;
        let (attachment, depth_attachment) =
            (vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL, vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL);
        let mut cameras = view_cameras(self.split);
        cameras[0] = self.main_camera();
        let mut views = Vec::new();
        for (i, (v, cam)) in self.views.iter().zip(&cameras).enumerate() {
            // With split screen the view's own colour, copied into the target after; else the target.
            let (image, view, color_format, final_layout) = match &v.color {
                Some(c) => (c.image, c.view, c.format, vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
                None => (target.image, target.view, target.format, target.final_layout),
            };
            g.transition(image, color_format, undefined, attachment);
            g.transition(v.depth.image, DEPTH_FORMAT, undefined, depth_attachment);
            let extent = v.depth.extent;
            let paint = PaintTarget { color: view, depth: v.depth.view, extent, clear: CLEAR };
            painter.record(g, &paint, cam, &self.state.boxes());
            // The first view is hadou's own camera (set at load); the others are named per frame.
            let camera = if i == 0 { ViewCamera::Renderer } else { ViewCamera::Camera(cam.for_hadou()) };
            views.push(View {
                camera,
                extent,
                depth: Some(ExternalDepth {
                    image: v.depth.image,
                    view: v.depth.view,
                    format: DEPTH_FORMAT,
                    layout: depth_attachment,
                    final_layout: depth_attachment,
                    convention: DepthConvention::Standard { near: cam.near, far: cam.far },
                    write: false,
                }),
                color: Some(ExternalColor {
                    image,
                    view,
                    format: color_format,
                    layout: attachment,
                    final_layout,
                }),
                upscaler: None,
            });
        }
        // The slime's balls at this frame's time, written before hadou's frame reads them.
        if let Some(sim) = &self.slime_sim {
            sim.record(g, self.state.time, self.sim_time.unwrap_or(self.state.time));
        }
        self.sim_time = Some(self.state.time);
        let (start, cpu_start) = (std::time::Instant::now(), thread_cpu_ms());
        self.hadou.record_views(g.cmd, self.state.time, &views).map_err(|e| e.to_string())?;
        self.last_record_ms = start.elapsed().as_secs_f64() * 1e3;
        self.last_record_cpu_ms = thread_cpu_ms() - cpu_start;
        if self.split {
            let dst = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
            g.transition(target.image, target.format, undefined, dst);
            let mut x = 0;
            for color in self.views.iter().filter_map(|v| v.color.as_ref()) {
                g.record_copy_image(color, target.image, x);
                x += color.extent.width as i32;
            }
            g.transition(target.image, target.format, dst, target.final_layout);
        }
        Ok(())
    }

    /// Records and submits one headless frame into the game's own offscreen image (colour and
    /// `aovs` read back) in the next slot, without waiting for it. Returns the frame that used the
    /// slot before, now finished (the wait for it is the game's frame-in-flight wait).
    pub fn offscreen_submit(
        &mut self,
        extent: vk::Extent2D,
        aovs: &[Aov],
    ) -> Result<Option<OffscreenFrame>, String> {
        let format = vk::Format::R8G8B8A8_SRGB;
        if self.offscreen.as_ref().is_none_or(|o| o.extent != extent) {
            let done = self.offscreen_finish()?;
            if !done.is_empty() {
                return Err("resize the offscreen image only after offscreen_finish".into());
            }
            if let Some(o) = self.offscreen.take() {
                self.vk.destroy_image(o);
            }
            let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT
                | vk::ImageUsageFlags::TRANSFER_SRC
                | vk::ImageUsageFlags::TRANSFER_DST;
            self.offscreen = Some(self.vk.create_image(extent, format, usage)?);
        }
        let slot = self.hadou.next_frame() as usize % self.frames_in_flight;
        self.vk.begin_slot(slot)?;
        let done = self.pending[slot].take().map(|p| self.collect(p)).transpose()?;
        let Some(image) = &self.offscreen else { return Err("no offscreen image".into()) };
        let target = ColorTarget {
            image: image.image,
            view: image.view,
            format,
            extent,
            final_layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
        };
        let frame = self.hadou.next_frame();
        self.record(&target)?;
        // Only what this frame's world produces (no wave: no energy pass, no energy AOV).
        let aovs: Vec<Aov> = aovs.iter().copied().filter(|a| self.hadou.produces(a.target())).collect();
        let readbacks = (0..self.views.len())
            .map(|v| self.hadou.record_view_aov_readback(self.vk.cmd, v, &aovs))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| e.to_string())?;
        let color = self.vk.create_host_buffer(extent.width as u64 * extent.height as u64 * 4)?;
        if let Some(image) = &self.offscreen {
            self.vk.record_copy_to_host(image, &color);
        }
        self.vk.submit_slot()?;
        let state = self.state.clone();
        self.pending[slot] = Some(Pending { frame, state, aovs, readbacks, color });
        Ok(done)
    }

    /// Waits for the frames in flight and returns them, oldest first.
    pub fn offscreen_finish(&mut self) -> Result<Vec<OffscreenFrame>, String> {
        self.vk.wait_slots()?;
        let mut pending: Vec<Pending> = self.pending.iter_mut().filter_map(Option::take).collect();
        pending.sort_by_key(|p| p.frame);
        pending.into_iter().map(|p| self.collect(p)).collect()
    }

    /// One headless frame, waited for (benchmarks that want every frame's numbers at once).
    pub fn offscreen_frame(&mut self, extent: vk::Extent2D, aovs: &[Aov]) -> Result<OffscreenFrame, String> {
        self.offscreen_submit(extent, aovs)?;
        self.offscreen_finish()?.pop().ok_or_else(|| "no frame".into())
    }

    /// Reads a finished frame and tells hadou it finished (its timings, its retired objects).
    fn collect(&mut self, p: Pending) -> Result<OffscreenFrame, String> {
        self.hadou.frame_finished(p.frame).map_err(|e| e.to_string())?;
        let views = p
            .readbacks
            .iter()
            .map(|r| p.aovs.iter().filter_map(|&a| r.aov(a).map(|img| (a, img))).collect())
            .collect();
        let frame = OffscreenFrame { color: p.color.bytes().to_vec(), views, state: p.state };
        self.vk.destroy_buffer(p.color);
        Ok(frame)
    }

    /// hadou's objects first, then the game's, then the device (`from_raw`'s ownership rule).
    pub fn destroy(self) -> std::sync::Arc<super::gpu::Messages> {
        let Game { vk, hadou, painter, views, offscreen, pending, slime_sim, .. } = self;
        // SAFETY: the game's device is live until `vk.destroy()` below.
        unsafe {
            let _ = vk.device.device_wait_idle();
        }
        for p in pending.into_iter().flatten() {
            vk.destroy_buffer(p.color);
        }
        drop(hadou);
        if let Some(sim) = slime_sim {
            sim.destroy(&vk);
        }
        if let Some(p) = painter {
            p.destroy(&vk);
        }
        let view_images = views.into_iter().flat_map(|v| v.color.into_iter().chain([v.depth]));
        for image in view_images.chain(offscreen) {
            vk.destroy_image(image);
        }
        let messages = vk.messages.clone();
        vk.destroy();
        messages
    }
}

/// The CPU time the calling thread has used, in ms (`CLOCK_THREAD_CPUTIME_ID`).
pub fn thread_cpu_ms() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `ts` is a valid, writable timespec; the clock id is one Linux always has.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID)");
    ts.tv_sec as f64 * 1e3 + ts.tv_nsec as f64 * 1e-6
}
