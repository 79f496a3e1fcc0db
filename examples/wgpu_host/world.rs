//! The world the wgpu host shows: the game prototype's (its state, its boxes, hadou's part of the
//! scene), so that the wgpu host and the ash prototype render the same frames and their costs
//! compare. Here: hadou embedded on a device and fed each frame's state.
#![allow(dead_code)]

use hadou::{GroupId, Renderer, WaveId};

use super::game::{camera, sync_wave, GameState, HADOU_SCENE};

/// hadou's world of one host: the renderer and the ids the game state moves.
pub struct HadouWorld {
    pub hadou: Renderer,
    wave: Option<WaveId>,
    slime: GroupId,
}

impl HadouWorld {
    /// hadou on the host's device with `frames` frames in flight, the prototype's scene loaded.
    ///
    /// # Safety
    /// As `GpuContext::from_raw`: valid handles with `EnabledFeatures::REQUIRED` enabled; the
    /// world is dropped before the device is destroyed.
    pub unsafe fn new(raw: hadou::gpu::RawVulkan, frames: usize) -> Result<Self, String> {
        // SAFETY: the caller's contract.
        let ctx = unsafe { hadou::gpu::GpuContext::from_raw(raw) }.map_err(|e| e.to_string())?;
        let options = hadou::RendererOptions { frames_in_flight: frames, ..Default::default() };
        let mut hadou = Renderer::with_options(ctx, &options).map_err(|e| e.to_string())?;
        let scene =
            hadou::scene::parse_scene(HADOU_SCENE, "wgpu_host.toml".as_ref()).map_err(|e| e.to_string())?;
        hadou.load_scene(scene).map_err(|e| e.to_string())?;
        hadou.set_camera(camera().for_hadou()).map_err(|e| e.to_string())?;
        let slime = hadou.metaballs_named("slime").ok_or("the scene has no metaball group \"slime\"")?;
        Ok(HadouWorld { hadou, wave: None, slime })
    }

    /// Hands hadou the state's wave (spawned, moved or despawned) and slime, as `Game::update` does.
    pub fn apply(&mut self, state: &GameState) -> Result<(), String> {
        let err = |e: hadou::Error| e.to_string();
        self.wave = sync_wave(&mut self.hadou, self.wave, state.wave_desc())?;
        self.hadou.set_metaball_group(self.slime, &state.slime()).map_err(err)
    }
}

/// The game camera's view → clip matrix for wgpu (clip y up: wgpu flips the viewport itself, where
/// the ash game's projection flips y), f32 column-major.
pub fn wgpu_view_projection(width: u32, height: u32) -> glam::Mat4 {
    let flip = glam::DMat4::from_scale(glam::DVec3::new(1.0, -1.0, 1.0));
    (flip * camera().view_projection(width, height)).as_mat4()
}
