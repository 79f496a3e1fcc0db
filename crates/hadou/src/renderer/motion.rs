//! A temporal upscaler's inputs (FSR 2, DLSS, a game's own TAA): the sub-pixel jitter given once
//! per frame, and what the previous frame left that the motion vectors are measured against —
//! each view's unjittered camera and each instance's model matrix, by id (an instance spawned or
//! despawned in between moves nothing else's).

use glam::DVec2;

use super::Renderer;
use crate::gpu::pipeline::BufferRange;
use crate::gpu::vk;
use crate::passes::MotionFrame;
use crate::scene::camera::{Camera, Lens};
use crate::Error;

impl Renderer {
    /// Turns a temporal upscaler's inputs on or off for the following frames: the `motion`,
    /// `reactive` and `composition` AOVs (`Aov::UPSCALER`). The passes that write them are built
    /// here, not in a frame. The first frame after it measures motion against itself (none).
    pub fn set_motion_vectors(&mut self, on: bool) -> Result<(), Error> {
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        loaded.scene.render.motion_vectors = on;
        loaded.prev_models.clear();
        loaded.prev_cameras.clear();
        self.sync_passes()
    }

    /// The sub-pixel jitter of the following frames, in pixels (x right, y down; FSR 2's
    /// `jitterOffset`): every view's projection is shifted by it on top of its camera, and the
    /// motion vectors leave it out. Give the camera unjittered: the jitter is given once, here.
    pub fn set_jitter(&mut self, x: f64, y: f64) -> Result<(), Error> {
        if !(x.is_finite() && y.is_finite() && x.abs() <= 1e4 && y.abs() <= 1e4) {
            return Err(Error::InvalidUpdate {
                what: format!("jitter ({x}, {y})"),
                expected: "finite pixel offsets within ±1e4".into(),
            });
        }
        self.jitter = DVec2::new(x, y);
        Ok(())
    }
}

/// With motion vectors on, each instance's model matrix in the previous frame in the instance
/// table's order (its current one when it is new), and the current ones kept for the next; the
/// table is this frame's (refreshed first).
pub(super) fn prev_model_table(loaded: &mut super::Loaded) -> Option<Vec<[[f32; 4]; 4]>> {
    if !loaded.scene.render.motion_vectors {
        return None;
    }
    let table = loaded.gpu.instance_table();
    let id_of = |record: usize| loaded.instance_ids.get(table[record].ids[0] as usize).copied();
    let prev = (0..table.len())
        .map(|r| id_of(r).and_then(|id| loaded.prev_models.get(&id).copied()).unwrap_or(table[r].model))
        .collect();
    loaded.prev_models = (0..table.len()).filter_map(|r| Some((id_of(r)?, table[r].model))).collect();
    Some(prev)
}

impl Renderer {
    /// The motion inputs of view `view` seen by `camera` (unjittered) at `extent`; `camera` is then
    /// the view's previous one.
    pub(super) fn motion_frame(
        &mut self,
        view: usize,
        camera: Camera,
        extent: vk::Extent2D,
        prev_models: BufferRange,
    ) -> Option<MotionFrame> {
        let loaded = self.loaded.as_mut()?;
        if loaded.prev_cameras.len() <= view {
            loaded.prev_cameras.resize(view + 1, None);
        }
        let prev = loaded.prev_cameras[view].replace(camera).unwrap_or(camera);
        let (w, h) = (extent.width, extent.height);
        Some(MotionFrame {
            view_proj: camera.view_projection(w, h),
            prev_view_proj: prev.view_projection(w, h),
            prev_models,
        })
    }
}

/// `camera` with its projection shifted by `jitter` pixels at `extent` (a symmetric lens becomes
/// the matrix lens it is, shifted); unchanged without jitter.
pub(super) fn jittered(camera: Camera, jitter: DVec2, extent: vk::Extent2D) -> Camera {
    if jitter == DVec2::ZERO {
        return camera;
    }
    let (w, h) = (f64::from(extent.width), f64::from(extent.height));
    // ndc y is up, pixels go down.
    let shift = DVec2::new(2.0 * jitter.x / w, -2.0 * jitter.y / h);
    let lens = match camera.lens {
        Lens::FovY => {
            let t = (camera.fov_y_deg.to_radians() / 2.0).tan();
            Lens::Matrix { scale: DVec2::new(h / (t * w), 1.0 / t), shift }
        }
        Lens::Matrix { scale, shift: s } => Lens::Matrix { scale, shift: s + shift },
    };
    Camera { lens, ..camera }
}
