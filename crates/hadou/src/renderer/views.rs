//! Several views of one world in one frame (split screen, a headset's two eyes): each with its
//! own camera, size and targets, sharing the world's tables, meshes and bakes. A view records as
//! a frame of its own would, in a slot of its own, so what a pass keeps per slot or per view never
//! mixes two views: two views give the pixels two single-view renderers give (tests/views.rs).

use glam::DMat4;

use super::inputs::{ExternalColor, ExternalDepth, FrameInputs, UpscalerTargets};
use super::view_projection::camera_from_matrices;
use super::Renderer;
use crate::gpu::vk;
use crate::scene::camera::Camera;
use crate::Error;

/// The most views one frame records (`Renderer::record_views`): split screen's four, a headset's
/// two, with room to spare. Each view owns a slot per frame in flight (an upload ring, descriptor
/// and query pools, its passes' per-slot buffers) and its own images.
pub const MAX_VIEWS: usize = 8;

/// Where a view looks from.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum ViewCamera {
    /// The renderer's camera: the last `set_camera` or `set_view_projection`, else the scene's.
    Renderer,
    /// A camera of hadou's own, checked as `Renderer::set_camera` checks it.
    Camera(Camera),
    /// The game's view (world → view) and projection (view → clip) matrices, as
    /// `Renderer::set_view_projection` takes them; the view's depth, handed with
    /// `DepthConvention::Camera`, is read in this projection's convention.
    ViewProjection {
        /// World → view, rigid.
        view: DMat4,
        /// View → clip, perspective.
        projection: DMat4,
    },
}

/// One view of a frame: its camera, its size and the game's images it draws into (None: hadou's
/// own images, read back with `Renderer::record_view_aov_readback`).
#[derive(Clone, Copy, Debug)]
pub struct View {
    /// Where it looks from.
    pub camera: ViewCamera,
    /// The view's size; must match its external images. A 0 × 0 view is skipped.
    pub extent: vk::Extent2D,
    /// As `FrameInputs::depth`, for this view.
    pub depth: Option<ExternalDepth>,
    /// As `FrameInputs::color`, for this view.
    pub color: Option<ExternalColor>,
    /// A temporal upscaler's inputs written into the game's images (motion vectors on).
    pub upscaler: Option<UpscalerTargets>,
}

impl View {
    /// A view of `width` × `height` into hadou's own images.
    pub fn headless(camera: ViewCamera, width: u32, height: u32) -> View {
        View { camera, extent: vk::Extent2D { width, height }, depth: None, color: None, upscaler: None }
    }

    /// The frame inputs this view records with at scene time `time`.
    pub(super) fn inputs(&self, time: f64) -> FrameInputs {
        FrameInputs { extent: self.extent, time, depth: self.depth, color: self.color }
    }
}

/// A view's camera resolved: the camera, and the projection the game gave with it (what
/// `DepthConvention::Camera` means while the view records). None: the renderer's own.
pub(super) type ResolvedCamera = Option<(Camera, Option<DMat4>)>;

impl Renderer {
    /// The camera `camera` stands for, checked.
    pub(super) fn resolve_camera(&self, camera: &ViewCamera) -> Result<ResolvedCamera, Error> {
        Ok(match *camera {
            ViewCamera::Renderer => None,
            ViewCamera::Camera(c) => {
                super::update::check_camera(&c)?;
                Some((c, None))
            }
            ViewCamera::ViewProjection { view, projection } => {
                Some((camera_from_matrices(view, projection)?, Some(projection)))
            }
        })
    }

    /// Runs `body` with `camera` as the scene's camera (what every pass and the depth import read
    /// while a view records), then puts the renderer's own back, whatever `body` returned.
    pub(super) fn with_camera<R>(
        &mut self,
        camera: ResolvedCamera,
        body: impl FnOnce(&mut Self) -> Result<R, Error>,
    ) -> Result<R, Error> {
        let (Some((camera, projection)), Some(loaded)) = (camera, self.loaded.as_mut()) else {
            return body(self);
        };
        let own = (loaded.scene.camera, loaded.game_projection);
        (loaded.scene.camera, loaded.game_projection) = (camera, projection);
        let result = body(self);
        if let Some(loaded) = self.loaded.as_mut() {
            (loaded.scene.camera, loaded.game_projection) = own;
        }
        result
    }
}
