//! The camera contract: a perspective frustum — symmetric with a vertical field of view in
//! degrees and aspect = width / height, or a game's projection matrix ([`Lens::Matrix`]: any
//! scales, off-centre shift and sub-pixel jitter, near and far from the matrix, far possibly
//! infinite) — image row 0 at the top, and the ray of pixel (x, y) through the pixel centre
//! (x + 0.5, y + 0.5). Depth is reverse-Z (near → 1, far → 0).

use glam::{DMat4, DVec2, DVec3, DVec4};

/// The scene's `[camera]`: a symmetric perspective camera (the contract in the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position in world space.
    pub position: DVec3,
    /// The world point at the centre of the image; differs from `position`.
    pub look_at: DVec3,
    /// Any non-zero vector not parallel to the view: the image's up is its part perpendicular to
    /// the view direction.
    pub up: DVec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_y_deg: f64,
    /// Near plane: view depth (along `forward`) > 0, stored as depth 1.
    pub near: f64,
    /// Far plane: view depth > `near`, stored as depth 0; +inf only with [`Lens::Matrix`].
    pub far: f64,
    /// How the view maps onto the image.
    pub lens: Lens,
}

/// How the camera's view maps onto the image.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Lens {
    /// Symmetric: `fov_y_deg` vertically, the image's aspect horizontally.
    #[default]
    FovY,
    /// A game's projection (`Renderer::set_view_projection`): a point at view slopes (x/d, y/d)
    /// — d its view depth, y up — lands at ndc = scale·slope + shift (ndc y up, ±1 the image's
    /// edges), whatever the image's size. An off-centre frustum or a sub-pixel jitter is `shift`.
    Matrix {
        /// > 0 each.
        scale: DVec2,
        /// Finite.
        shift: DVec2,
    },
}

/// Right-handed orthonormal camera frame: `forward` looks at the target, `up` is the image's up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraBasis {
    /// Unit vector toward the image's right edge: forward × up.
    pub right: DVec3,
    /// Unit vector toward the image's top edge.
    pub up: DVec3,
    /// Unit view direction, from `position` toward `look_at`.
    pub forward: DVec3,
}

/// Camera vectors scaled for pixel rays: the unnormalized direction through image point
/// (ndc_x, ndc_y) is `forward + (ndc_x + offset.x)·right + (ndc_y + offset.y)·up`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayFrame {
    /// `CameraBasis::right` / the lens's horizontal scale (tan(fov_y/2) × aspect when symmetric).
    pub right: DVec3,
    /// `CameraBasis::up` / the lens's vertical scale (tan(fov_y/2) when symmetric).
    pub up: DVec3,
    /// `CameraBasis::forward`, unit length: the view axis (view depth = distance · u·forward).
    pub forward: DVec3,
    /// −shift of the lens (0 when symmetric).
    pub offset: DVec2,
}

impl RayFrame {
    /// As f32 vec4s for push constants: right (w: offset.x), up (w: offset.y), forward (w = 0).
    pub fn to_f32(&self) -> [[f32; 4]; 3] {
        let v = |v: DVec3, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
        [v(self.right, self.offset.x), v(self.up, self.offset.y), v(self.forward, 0.0)]
    }
}

impl Camera {
    /// `far` when the scene file gives none.
    pub const DEFAULT_FAR: f64 = 1000.0;

    /// The camera's orthonormal frame.
    pub fn basis(&self) -> CameraBasis {
        let forward = (self.look_at - self.position).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        CameraBasis { right, up, forward }
    }

    /// The vectors compute passes build pixel rays from: the unnormalized direction through image
    /// point (ndc_x, ndc_y) is `forward + (ndc_x + offset.x)·right + (ndc_y + offset.y)·up`
    /// (shaders/common/camera.glsl).
    pub fn ray_frame(&self, width: u32, height: u32) -> RayFrame {
        let b = self.basis();
        match self.lens {
            Lens::FovY => {
                let tan_half = (self.fov_y_deg.to_radians() * 0.5).tan();
                let aspect = width as f64 / height as f64;
                let (right, up) = (b.right * (tan_half * aspect), b.up * tan_half);
                RayFrame { right, up, forward: b.forward, offset: DVec2::ZERO }
            }
            Lens::Matrix { scale, shift } => {
                RayFrame { right: b.right / scale.x, up: b.up / scale.y, forward: b.forward, offset: -shift }
            }
        }
    }

    /// The image point (ndc, y up) of view slopes (x/d, y/d): the inverse of the ray frame.
    pub fn ndc_of_slopes(&self, slopes: DVec2, width: u32, height: u32) -> DVec2 {
        match self.lens {
            Lens::FovY => {
                let tan_half = (self.fov_y_deg.to_radians() * 0.5).tan();
                let aspect = width as f64 / height as f64;
                DVec2::new(slopes.x / (tan_half * aspect), slopes.y / tan_half)
            }
            Lens::Matrix { scale, shift } => slopes * scale + shift,
        }
    }

    /// The largest |slope| (x/d, y/d) any pixel ray of the image has: at the frustum's corners.
    pub fn max_slopes(&self, width: u32, height: u32) -> DVec2 {
        let f = self.ray_frame(width, height);
        let (sx, sy) = (f.right.length(), f.up.length());
        DVec2::new(sx * (1.0 + f.offset.x.abs()), sy * (1.0 + f.offset.y.abs()))
    }

    /// World-space unit ray through the centre of pixel (x, y) of a width × height image.
    pub fn pixel_ray(&self, x: u32, y: u32, width: u32, height: u32) -> (DVec3, DVec3) {
        self.ray_through(x as f64 + 0.5, y as f64 + 0.5, width, height)
    }

    /// World-space unit ray through the image point (px, py), in pixels from the top-left corner.
    pub fn ray_through(&self, px: f64, py: f64, width: u32, height: u32) -> (DVec3, DVec3) {
        let ndc_x = 2.0 * px / width as f64 - 1.0;
        let ndc_y = 1.0 - 2.0 * py / height as f64;
        let dir = match self.lens {
            Lens::FovY => {
                let b = self.basis();
                let tan_half = (self.fov_y_deg.to_radians() * 0.5).tan();
                let aspect = width as f64 / height as f64;
                b.forward + b.right * (ndc_x * tan_half * aspect) + b.up * (ndc_y * tan_half)
            }
            Lens::Matrix { .. } => {
                let f = self.ray_frame(width, height);
                f.forward + f.right * (ndc_x + f.offset.x) + f.up * (ndc_y + f.offset.y)
            }
        };
        (self.position, dir.normalize())
    }

    /// World → view (right-handed, looking down −Z).
    pub fn view_matrix(&self) -> DMat4 {
        let b = self.basis();
        DMat4::look_at_rh(self.position, self.position + b.forward, b.up)
    }

    /// View → clip for Vulkan: reverse-Z (near → 1, far → 0; an infinite far → 0 at infinity)
    /// and y flipped so row 0 is the top.
    pub fn projection_matrix(&self, aspect: f64) -> DMat4 {
        let (n, fa) = (self.near, self.far);
        let (z_scale, z_offset) = if fa.is_infinite() { (0.0, n) } else { (n / (fa - n), n * fa / (fa - n)) };
        match self.lens {
            Lens::FovY => {
                let f = 1.0 / (self.fov_y_deg.to_radians() * 0.5).tan();
                DMat4::from_cols(
                    DVec4::new(f / aspect, 0.0, 0.0, 0.0),
                    DVec4::new(0.0, -f, 0.0, 0.0),
                    DVec4::new(0.0, 0.0, z_scale, -1.0),
                    DVec4::new(0.0, 0.0, z_offset, 0.0),
                )
            }
            // ndc_x = scale.x·x/d + shift.x and ndc_y (down) = −(scale.y·y/d + shift.y), d = −z.
            Lens::Matrix { scale, shift } => DMat4::from_cols(
                DVec4::new(scale.x, 0.0, 0.0, 0.0),
                DVec4::new(0.0, -scale.y, 0.0, 0.0),
                DVec4::new(-shift.x, shift.y, z_scale, -1.0),
                DVec4::new(0.0, 0.0, z_offset, 0.0),
            ),
        }
    }

    /// World → clip for a width × height image: `projection_matrix` × `view_matrix`.
    pub fn view_projection(&self, width: u32, height: u32) -> DMat4 {
        self.projection_matrix(width as f64 / height as f64) * self.view_matrix()
    }
}

/// Pixels [x0, x1) × [y0, y1) of an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect {
    /// First column.
    pub x0: u32,
    /// First row (row 0 is the top).
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl PixelRect {
    /// Every pixel of a width × height image.
    pub fn full(width: u32, height: u32) -> Self {
        PixelRect { x0: 0, y0: 0, x1: width, y1: height }
    }

    /// Columns covered: x1 − x0.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// Rows covered: y1 − y0.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }
}

impl Camera {
    /// The pixels of a width × height image whose centre rays can meet the convex hull of
    /// `points`: the bounding rectangle of their projections, widened by one pixel on each side
    /// (the raster's f32 projection differs from this f64 one by far less). The whole image when a
    /// point lies nearer than the near plane (on or behind the camera's plane its projection is not
    /// bounded) or is not finite; `None` when the rectangle misses the image or `points` is empty.
    pub fn pixel_bounds(&self, points: &[DVec3], width: u32, height: u32) -> Option<PixelRect> {
        let b = self.basis();
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for &p in points {
            let d = p - self.position;
            let z = d.dot(b.forward);
            // In front of the near plane (where nothing is rasterized) the projection stops being
            // a useful bound; on or behind the camera's plane it is none.
            if !d.is_finite() || !z.is_finite() || z < self.near {
                return Some(PixelRect::full(width, height));
            }
            // Inverse of `ray_through`, pixels from the top left.
            let ndc = self.ndc_of_slopes(DVec2::new(d.dot(b.right), d.dot(b.up)) / z, width, height);
            let px = DVec2::new((ndc.x + 1.0) * 0.5 * width as f64, (1.0 - ndc.y) * 0.5 * height as f64);
            lo = lo.min(px);
            hi = hi.max(px);
        }
        if points.is_empty() {
            return None;
        }
        // Pixel x has its centre at x + 0.5: keep those in [lo − 1, hi + 1].
        let first = |v: f64, n: u32| (v - 1.5).ceil().clamp(0.0, n as f64) as u32;
        let end = |v: f64, n: u32| ((v + 0.5).floor() + 1.0).clamp(0.0, n as f64) as u32;
        let rect = PixelRect {
            x0: first(lo.x, width),
            y0: first(lo.y, height),
            x1: end(hi.x, width),
            y1: end(hi.y, height),
        };
        (rect.x0 < rect.x1 && rect.y0 < rect.y1).then_some(rect)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether the ray (o, u) meets the box [lo, hi] (slab test).
    fn ray_meets_box(o: DVec3, u: DVec3, lo: DVec3, hi: DVec3) -> bool {
        let (a, b) = ((lo - o) / u, (hi - o) / u);
        let (near, far) = (a.min(b).max_element(), a.max(b).min_element());
        near <= far && far >= 0.0
    }

    #[test]
    fn pixel_bounds_hold_every_pixel_whose_ray_meets_the_points_box() {
        let c = cam();
        let (w, h) = (64, 48);
        for (lo, hi) in [
            (DVec3::new(-0.3, 0.2, -0.4), DVec3::new(0.5, 0.9, 0.1)),
            (DVec3::new(-4.0, -1.0, -2.0), DVec3::new(-2.5, 0.5, -1.0)), // partly off the image
            (DVec3::new(0.1, 0.4, 0.0), DVec3::new(0.1001, 0.4001, 0.0001)), // under a pixel
        ] {
            let corners: Vec<DVec3> = (0..8)
                .map(|k| DVec3::new([lo.x, hi.x][k & 1], [lo.y, hi.y][(k >> 1) & 1], [lo.z, hi.z][k >> 2]))
                .collect();
            let r = c.pixel_bounds(&corners, w, h).unwrap();
            assert!(r.width() < w && r.height() < h, "{r:?}");
            let mut inside = 0;
            for y in 0..h {
                for x in 0..w {
                    let (o, u) = c.pixel_ray(x, y, w, h);
                    if ray_meets_box(o, u, lo, hi) {
                        inside += 1;
                        assert!(x >= r.x0 && x < r.x1 && y >= r.y0 && y < r.y1, "({x}, {y}) outside {r:?}");
                    }
                }
            }
            assert!(inside > 0 || r.width() <= 3, "{r:?}");
        }
    }

    #[test]
    fn pixel_bounds_of_points_behind_beside_or_missing() {
        let c = cam();
        let full = Some(PixelRect::full(32, 32));
        // Behind the camera, on its plane, or not finite: the projection is not bounded.
        assert_eq!(c.pixel_bounds(&[DVec3::ZERO, DVec3::new(1.0, 2.0, 9.0)], 32, 32), full);
        assert_eq!(c.pixel_bounds(&[c.position + c.basis().right], 32, 32), full);
        assert_eq!(c.pixel_bounds(&[DVec3::NAN], 32, 32), full);
        // Far to the side of the view: no pixel.
        let side = c.position + c.basis().forward + c.basis().right * 50.0;
        assert_eq!(c.pixel_bounds(&[side, side + DVec3::Y * 0.1], 32, 32), None);
        assert_eq!(c.pixel_bounds(&[], 32, 32), None);
    }

    fn cam() -> Camera {
        Camera {
            position: DVec3::new(1.0, 2.0, 5.0),
            look_at: DVec3::new(0.0, 0.5, 0.0),
            up: DVec3::Y,
            fov_y_deg: 50.0,
            near: 0.1,
            far: 100.0,
            lens: Lens::FovY,
        }
    }

    /// The raster projection and the CPU pixel ray must describe the same frustum: a point on
    /// the ray of pixel (x, y) projects to that pixel's centre, at reverse-Z depth.
    #[test]
    fn projection_matches_pixel_rays() {
        let c = cam();
        let (w, h) = (64u32, 48u32);
        let vp = c.view_projection(w, h);
        for &(x, y) in &[(0, 0), (63, 47), (10, 30), (32, 24)] {
            let (o, d) = c.pixel_ray(x, y, w, h);
            for dist in [0.1, 1.0, 7.0, 100.0] {
                let clip = vp * (o + d * dist).extend(1.0);
                let ndc = clip.truncate() / clip.w;
                let px = (ndc.x + 1.0) * 0.5 * w as f64;
                let py = (ndc.y + 1.0) * 0.5 * h as f64;
                assert!((px - (x as f64 + 0.5)).abs() < 1e-9, "x {px}");
                assert!((py - (y as f64 + 0.5)).abs() < 1e-9, "y {py}");
                // Reverse-Z: the view-space depth (not the ray distance) maps near → 1, far → 0.
                let z_view = (d * dist).dot(c.basis().forward);
                let expect = c.near * (c.far - z_view) / (z_view * (c.far - c.near));
                assert!((ndc.z - expect).abs() < 1e-12);
            }
        }
        let near_clip = vp * (c.position + c.basis().forward * c.near).extend(1.0);
        assert!((near_clip.z / near_clip.w - 1.0).abs() < 1e-12);
        let far_clip = vp * (c.position + c.basis().forward * c.far).extend(1.0);
        assert!((far_clip.z / far_clip.w).abs() < 1e-12);
    }

    /// The ray frame the compute passes use gives the same rays as pixel_ray.
    #[test]
    fn ray_frame_matches_pixel_rays() {
        let c = cam();
        let f = c.ray_frame(64, 48);
        for &(x, y) in &[(0u32, 0u32), (63, 47), (10, 30)] {
            let ndc_x = 2.0 * (x as f64 + 0.5) / 64.0 - 1.0;
            let ndc_y = 1.0 - 2.0 * (y as f64 + 0.5) / 48.0;
            let d = (f.forward + f.right * ndc_x + f.up * ndc_y).normalize();
            assert!((d - c.pixel_ray(x, y, 64, 48).1).length() < 1e-15);
        }
    }

    #[test]
    fn row_zero_is_top() {
        let c = cam();
        let (_, top) = c.pixel_ray(32, 0, 64, 48);
        let (_, bottom) = c.pixel_ray(32, 47, 64, 48);
        assert!(top.dot(c.basis().up) > 0.0 && bottom.dot(c.basis().up) < 0.0);
    }
}
