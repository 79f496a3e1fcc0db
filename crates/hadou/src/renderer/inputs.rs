//! What a game hands `Renderer::record_frame` each frame, and what it gets back.

use crate::gpu::vk;

/// How the game's depth buffer maps view depth z (distance along the camera's forward axis) to
/// the stored value d. Every perspective projection stores d = −A + B / z (A, B from its third
/// row), which is what the import inverts: z = B / (d + A).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DepthConvention {
    /// near → 0, far → 1: d = far·(z − near) / (z·(far − near)) (Vulkan's default).
    Standard {
        /// Near plane view depth, > 0.
        near: f64,
        /// Far plane view depth, finite and > `near`.
        far: f64,
    },
    /// near → 1, far → 0: d = near·(far − z) / (z·(far − near)) (hadou's own convention).
    ReverseZ {
        /// Near plane view depth, > 0.
        near: f64,
        /// Far plane view depth, finite and > `near`.
        far: f64,
    },
    /// The game's view → clip perspective matrix (column-major, clip.w = −z_view, depth in
    /// [0, 1]: `glam::DMat4::perspective_rh`, `perspective_infinite_reverse_rh`, ...).
    Projection(glam::DMat4),
    /// The projection of the frame's camera: the one given to `Renderer::set_view_projection`
    /// (the camera given once), or hadou's own camera's (`Camera::projection_matrix`, reverse-Z)
    /// when the camera was set otherwise. Resolved by the renderer each frame.
    Camera,
}

impl DepthConvention {
    /// (A, B) with d = −A + B / z.
    pub fn coefficients(self) -> (f64, f64) {
        match self {
            DepthConvention::Standard { near, far } => (far / (near - far), near * far / (near - far)),
            DepthConvention::ReverseZ { near, far } => (near / (far - near), near * far / (far - near)),
            DepthConvention::Projection(m) => (m.z_axis.z, m.w_axis.z),
            // Unresolved: no depth (the renderer resolves it before reading any depth).
            DepthConvention::Camera => (f64::NAN, f64::NAN),
        }
    }

    /// True when nearer is larger (B > 0): the far plane (sky) is then d ≤ 0, else d ≥ 1.
    pub fn reversed(self) -> bool {
        self.coefficients().1 > 0.0
    }

    /// Why this convention cannot be imported, if it cannot.
    pub fn check(self) -> Result<(), String> {
        match self {
            DepthConvention::Standard { near, far } | DepthConvention::ReverseZ { near, far } => {
                if !(near > 0.0 && far > near && far.is_finite()) {
                    return Err(format!("near {near} and far {far} must satisfy 0 < near < far < inf"));
                }
            }
            DepthConvention::Projection(m) => {
                let perspective =
                    m.z_axis.w == -1.0 && m.w_axis.w == 0.0 && m.x_axis.w == 0.0 && m.y_axis.w == 0.0;
                let (a, b) = (m.z_axis.z, m.w_axis.z);
                if !perspective || !a.is_finite() || !b.is_finite() || b == 0.0 {
                    return Err(format!(
                        "projection {m:?} is not a perspective projection with clip.w = −z_view and a \
                         depth that varies with distance (third column w = −1, fourth column w = 0, \
                         fourth column z ≠ 0)"
                    ));
                }
            }
            DepthConvention::Camera => {
                return Err("DepthConvention::Camera is the renderer's to resolve (the frame's camera)".into())
            }
        }
        Ok(())
    }
}

/// The game's depth image for this frame. hadou samples it in a compute shader, so it needs
/// `VK_IMAGE_USAGE_SAMPLED_BIT`, and `view` must show the depth aspect only.
///
/// Synchronization: hadou's first barrier on it waits for all earlier commands' writes
/// (`ALL_COMMANDS` / `MEMORY_WRITE`) and moves it from `layout` to `SHADER_READ_ONLY_OPTIMAL`; its
/// last moves it to `final_layout`, making hadou's reads visible to all later commands. The game
/// needs no barrier of its own around hadou's commands.
#[derive(Clone, Copy, Debug)]
pub struct ExternalDepth {
    /// The depth image, frame-sized.
    pub image: vk::Image,
    /// A view of `image`'s depth aspect.
    pub view: vk::ImageView,
    /// D32_SFLOAT, D16_UNORM or D24_UNORM_S8_UINT.
    pub format: vk::Format,
    /// Its layout when hadou's commands start.
    pub layout: vk::ImageLayout,
    /// The layout hadou leaves it in.
    pub final_layout: vk::ImageLayout,
    /// How the stored depth maps to view depth.
    pub convention: DepthConvention,
    /// Write hadou's nearest surfaces (instances, metaballs) into this image in `convention`, so
    /// the game's later passes are hidden behind them ("depth out"); the image then also needs
    /// `DEPTH_STENCIL_ATTACHMENT` usage. Where hadou drew nothing the game's depth is kept.
    pub write: bool,
}

/// The game's colour target: hadou draws its result over it (as a colour attachment, so any
/// colour-attachment format works). What is written depends on the format:
/// `*_SRGB`: hadou's tonemapped linear colour (the hardware encodes); `*_UNORM`: the same,
/// sRGB-encoded by hadou; float formats: hadou's linear HDR × exposure, not tonemapped (the game
/// tonemaps). Pixels where hadou drew a surface (its instances, metaballs, translucent objects,
/// with the wave in front) are drawn *over* the game's colour; elsewhere the wave's glow is
/// *added* to it (premultiplied alpha: src + (1 − α_src)·dst, α = 1 on hadou's surfaces, 0 elsewhere).
/// The image needs `VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT`. Synchronization as for `ExternalDepth`
/// (`layout` → `COLOR_ATTACHMENT_OPTIMAL` → `final_layout`).
pub type ExternalColor = ExternalImage;

/// One of the game's images hadou writes into, frame-sized: the colour target (`ExternalColor`, a
/// colour attachment) or an upscaler input (`UpscalerTargets`, a storage image: it needs
/// `VK_IMAGE_USAGE_STORAGE_BIT`). Synchronization as for `ExternalDepth` (`layout` → what hadou
/// writes it as → `final_layout`).
#[derive(Clone, Copy, Debug)]
pub struct ExternalImage {
    /// The image, frame-sized.
    pub image: vk::Image,
    /// A colour view of `image`.
    pub view: vk::ImageView,
    /// `image`'s format (what each use takes is said there).
    pub format: vk::Format,
    /// Its layout when hadou's commands start.
    pub layout: vk::ImageLayout,
    /// The layout hadou leaves it in.
    pub final_layout: vk::ImageLayout,
}

/// A temporal upscaler's inputs written into the game's own images (motion vectors on,
/// `Renderer::set_motion_vectors`), for its FSR / DLSS / TAA to read on the GPU: `motion`
/// (R16G16_SFLOAT or R32G32_SFLOAT) gets hadou's motion where hadou drew a surface and keeps the
/// game's own elsewhere; `reactive` and `composition` (R8_UNORM, R16_SFLOAT or R32_SFLOAT) get the
/// larger of the game's value and hadou's (`Aov::UPSCALER` says what each holds).
#[derive(Clone, Copy, Debug)]
pub struct UpscalerTargets {
    /// The game's motion vectors (`Aov::Motion`'s convention).
    pub motion: ExternalImage,
    /// The game's reactive mask, if it has one.
    pub reactive: Option<ExternalImage>,
    /// The game's transparency-and-composition mask, if it has one.
    pub composition: Option<ExternalImage>,
}

/// One frame to record.
#[derive(Clone, Copy, Debug)]
pub struct FrameInputs {
    /// The frame's size; must match the external images. 0 × 0 (a minimized window) records
    /// nothing and returns `RecordedFrame { recorded: false, .. }`.
    pub extent: vk::Extent2D,
    /// Scene time in seconds (keyframes, velocities).
    pub time: f64,
    /// The game's depth: hadou's instances are depth-tested against it and the wave stops at it.
    /// None: hadou's own depth only (the headless path).
    pub depth: Option<ExternalDepth>,
    /// The game's colour target to composite into. None: tonemapped into hadou's own `Ldr` image.
    pub color: Option<ExternalColor>,
}

impl FrameInputs {
    /// A frame with hadou's own images only (the headless runtime's).
    pub fn headless(width: u32, height: u32, time: f64) -> Self {
        FrameInputs { extent: vk::Extent2D { width, height }, time, depth: None, color: None }
    }
}

/// What `record_frame` recorded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RecordedFrame {
    /// False when nothing was recorded (0 × 0 extent).
    pub recorded: bool,
    /// Counts recorded frames; `FrameTimings::frame` refers to it.
    pub frame: u64,
    /// Whether this frame writes timestamps (a query pool was free).
    pub timed: bool,
}
