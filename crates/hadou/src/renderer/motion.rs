//! A temporal upscaler's inputs (FSR 2, DLSS, a game's own TAA): the sub-pixel jitter given once
//! per frame, and what the previous frame left that the motion vectors are measured against —
//! each view's unjittered camera and each instance's model matrix, by id (an instance spawned or
//! despawned in between moves nothing else's).

use glam::{DMat4, DVec2, DVec3};

use super::Renderer;
use crate::gpu::pipeline::BufferRange;
use crate::gpu::vk;
use crate::passes::gpu_structs::mat4_f32;
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

/// With motion vectors on, each instance's model matrix this frame and in the previous frame (its
/// current one when it is new), in f64 and in the instance table's order; the current ones are
/// kept for the next. The table is this frame's (refreshed first).
pub(super) fn model_pairs(loaded: &mut super::Loaded) -> Option<Vec<(DMat4, DMat4)>> {
    if !loaded.scene.render.motion_vectors {
        return None;
    }
    let table = loaded.gpu.instance_table();
    let instances = &loaded.scene.instances;
    // The scene's f64 matrix of each record (the table is built from it; its f32 copy otherwise).
    let f64_of = |m: &[[f32; 4]; 4]| DMat4::from_cols_array_2d(&m.map(|c| c.map(f64::from)));
    let now: Vec<DMat4> = table
        .iter()
        .map(|r| instances.get(r.ids[0] as usize).map_or_else(|| f64_of(&r.model), |i| i.transform.matrix))
        .collect();
    let id_of = |record: usize| loaded.instance_ids.get(table[record].ids[0] as usize).copied();
    let pairs = (0..table.len())
        .map(|r| (now[r], id_of(r).and_then(|id| loaded.prev_models.get(&id).copied()).unwrap_or(now[r])))
        .collect();
    loaded.prev_models = (0..table.len()).filter_map(|r| Some((id_of(r)?, now[r]))).collect();
    Some(pairs)
}

/// The model matrices of `pairs` (this frame's, the previous frame's) relative to `origin` (the
/// view's camera): T(−origin)·M composed in f64, then rounded to f32, two per instance. Far from
/// the world's origin the f32 world position of a vertex would be rounded to ~ε·|x| (10⁻² of a
/// unit at 10⁵), and the motion with it; relative to the camera only to ε of its distance.
pub(super) fn relative_models(pairs: &[(DMat4, DMat4)], origin: DVec3) -> Vec<[[f32; 4]; 4]> {
    let shift = DMat4::from_translation(-origin);
    pairs.iter().flat_map(|(now, before)| [mat4_f32(shift * *now), mat4_f32(shift * *before)]).collect()
}

impl Renderer {
    /// The motion inputs of view `view` seen by `camera` (unjittered) at `extent`, with its
    /// instances' relative model matrices `models` (`relative_models` of `camera.position`);
    /// `camera` is then the view's previous one.
    pub(super) fn motion_frame(
        &mut self,
        view: usize,
        camera: Camera,
        extent: vk::Extent2D,
        models: BufferRange,
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
            origin: camera.position,
            models,
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
