//! The camera as a game gives it: view and projection matrices (`Renderer::set_view_projection`),
//! turned into hadou's camera — a position and frame from the view, a [`Lens::Matrix`] and the
//! near and far planes from the projection — so every pass and every f64 twin builds the same
//! pixel rays from it (crates/hadou/src/scene/camera.rs). The camera is given once: a game that hands its depth
//! says `DepthConvention::Camera` and the depth convention is the same projection's; one that
//! names a convention of its own is checked against the projection (`depth_convention`).

use glam::{DMat4, DVec2, DVec3};

use super::game_math::GameMatrix;
use super::inputs::{DepthConvention, ExternalDepth};
use super::Renderer;
use crate::scene::camera::{Camera, Lens};
use crate::Error;

fn refused(what: &str, expected: &str) -> Error {
    Error::InvalidUpdate { what: what.into(), expected: expected.into() }
}

/// hadou's camera for a rigid right-handed `view` (world → view, looking down −Z, y up) and a
/// perspective `proj` (view → clip) with depth in [0, 1]: standard (near → 0) or reverse-Z
/// (near → 1), finite or infinite far, y up or flipped for Vulkan (the image keeps view +Y up
/// either way), with any off-centre shift or jitter in its third column.
pub fn camera_from_matrices(view: DMat4, proj: DMat4) -> Result<Camera, Error> {
    if !view.is_finite() || !proj.is_finite() {
        return Err(refused("view or projection matrix", "finite matrices"));
    }
    // Rigid: the rotation's columns orthonormal (to f32 precision: games build views in f32),
    // right-handed, and an affine bottom row.
    let r = glam::DMat3::from_mat4(view);
    let gram = r.transpose() * r;
    let rigid = (gram - glam::DMat3::IDENTITY).to_cols_array().iter().all(|v| v.abs() <= 1e-5)
        && r.determinant() > 0.0
        && view.row(3) == glam::DVec4::W;
    if !rigid {
        return Err(refused(
            "view matrix",
            "a rigid right-handed transform (rotation and translation, orthonormal to 1e-5, bottom row 0 0 0 1)",
        ));
    }
    let inverse = view.inverse();
    let position = inverse.transform_point3(DVec3::ZERO);
    let forward = inverse.transform_vector3(DVec3::NEG_Z).normalize();
    let up = inverse.transform_vector3(DVec3::Y).normalize();
    // Perspective: w_clip = −z_view; x and y scaled and shifted by the third column; depth
    // z_ndc = −c + e/d for view depth d (c, e: the third and fourth columns' z).
    let [c0, c1, c2, c3] = [proj.x_axis, proj.y_axis, proj.z_axis, proj.w_axis];
    let shape = c0.y == 0.0
        && c0.z == 0.0
        && c0.w == 0.0
        && c1.x == 0.0
        && c1.z == 0.0
        && c1.w == 0.0
        && c2.w == -1.0
        && c3.x == 0.0
        && c3.y == 0.0
        && c3.w == 0.0
        && c0.x > 0.0
        && c1.y != 0.0;
    if !shape {
        return Err(refused(
            "projection matrix",
            "a right-handed perspective projection (w_clip = −z_view, x scale > 0, no skew), as \
             glam's perspective_rh / perspective_infinite_rh / perspective_infinite_reverse_rh give, \
             optionally shifted or jittered in its third column",
        ));
    }
    // ndc_x = c0.x·x/d − c2.x; ndc_y (up) from the clip y, flipped when the matrix flips it.
    let scale = DVec2::new(c0.x, c1.y.abs());
    let shift = DVec2::new(-c2.x, if c1.y < 0.0 { c2.y } else { -c2.y });
    // The view depths where z_ndc is 0 and 1: near is the smaller, far the larger (+inf when
    // one of them never is reached).
    let (c, e) = (c2.z, c3.z);
    let depth_at = |z: f64| if z + c == 0.0 { f64::INFINITY } else { e / (z + c) };
    let (d0, d1) = (depth_at(0.0), depth_at(1.0));
    let (near, far) = (d0.min(d1), d0.max(d1));
    // As a scene file's: a near f32 holds as a normal number, a far within the extent the raster
    // resolves (docs/scene-format.md, "Numeric limits"), or infinite.
    let (least, most) = (f64::from(f32::MIN_POSITIVE), 2f64.powi(48));
    if !(near >= least && near <= most && far > near && (far <= most || far.is_infinite())) {
        return Err(refused(
            "projection matrix",
            "depth in [0, 1] over view depths near < far (standard or reverse-Z), near ≥ 1.1754944e-38 \
             and far ≤ 2⁴⁸ or infinite",
        ));
    }
    let fov_y_deg = 2.0 * (1.0 / scale.y).atan().to_degrees();
    let lens = Lens::Matrix { scale, shift };
    Ok(Camera { position, look_at: position + forward, up, fov_y_deg, near, far, lens })
}

impl Renderer {
    /// The camera of the following frames as the game's matrices: `view` (world → view) and
    /// `proj` (view → clip), see [`camera_from_matrices`] for what is accepted. Sub-pixel jitter
    /// (TAA) and off-centre frusta are the projection's third column; hadou's pixel rays, raster
    /// and depth follow it exactly. glam's f32 `Mat4` (or `Affine3A` for the view) is taken as
    /// it is. The game's depth, handed with `DepthConvention::Camera`, is read in this projection's
    /// convention. State is unchanged on error.
    pub fn set_view_projection(&mut self, view: impl GameMatrix, proj: impl GameMatrix) -> Result<(), Error> {
        let proj = proj.to_dmat4();
        let camera = camera_from_matrices(view.to_dmat4(), proj)?;
        self.set_camera(camera)?;
        self.loaded.as_mut().ok_or(Error::NoScene)?.game_projection = Some(proj);
        Ok(())
    }

    /// The convention `depth` is read in this frame: `DepthConvention::Camera` is the projection
    /// given to `set_view_projection`, or, when the camera was set otherwise, hadou's own
    /// projection of it (`Camera::projection_matrix` at the frame's aspect: reverse-Z). A convention
    /// the game names itself must agree with a projection it gave (A within 1e-5, B within 1e-5
    /// relative: f32 rounding of either, not a different near or far), or the frame is refused:
    /// the two could otherwise disagree silently, the game's depth read at wrong distances.
    pub(super) fn depth_convention(
        &self,
        depth: &ExternalDepth,
        aspect: f64,
    ) -> Result<DepthConvention, Error> {
        let loaded = self.loaded.as_ref().ok_or(Error::NoScene)?;
        let own = loaded.game_projection.map(DepthConvention::Projection);
        let convention = match depth.convention {
            DepthConvention::Camera => own.unwrap_or_else(|| {
                DepthConvention::Projection(loaded.scene.camera.projection_matrix(aspect))
            }),
            named => {
                if let Some(own) = own {
                    check_agreement(named, own)?;
                }
                named
            }
        };
        convention.check().map_err(Error::DepthConvention)?;
        Ok(convention)
    }
}

/// `named` and the camera's projection `own` store the same depth for every view depth, to f32
/// rounding: d = −A + B/z, so A and B are compared (A absolutely, it is a depth; B relatively).
fn check_agreement(named: DepthConvention, own: DepthConvention) -> Result<(), Error> {
    const TOLERANCE: f64 = 1e-5;
    let ((a0, b0), (a1, b1)) = (named.coefficients(), own.coefficients());
    let agree = (a0 - a1).abs() <= TOLERANCE && (b0 - b1).abs() <= TOLERANCE * b0.abs().max(b1.abs());
    if agree {
        return Ok(());
    }
    Err(Error::DepthConvention(format!(
        "ExternalDepth.convention {named:?} stores d = {:.7} + {b0:.7}/z, but the projection given to \
         set_view_projection stores d = {:.7} + {b1:.7}/z: give DepthConvention::Camera (the depth is then \
         read in the camera's projection), or the projection the depth was drawn with",
        -a0, -a1
    )))
}
