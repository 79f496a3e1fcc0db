//! Orbit and fly camera controls on top of the scene's `Camera`. One state serves both modes: a
//! target, a view direction (yaw and pitch about the scene camera's `up`) and a distance, with
//! eye = target − distance · forward. Orbit turns the eye about the target; fly turns the view
//! about the eye and moves both, so switching modes never moves the camera.

use glam::DVec3;
use hadou::scene::camera::Camera;

/// Pitch stays this far from ±90°, so forward never becomes parallel to up (whose cross product
/// builds the camera's right vector) and the basis never degenerates.
pub const PITCH_LIMIT: f64 = 89.0 * std::f64::consts::PI / 180.0;
/// Radians per pixel of mouse drag.
const DRAG_RADIANS_PER_PIXEL: f64 = 0.005;
/// Each wheel line brings the orbit eye this factor closer.
const ZOOM_PER_LINE: f64 = 0.9;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Orbit,
    Fly,
}

/// Movement keys held, as −1/0/+1 along right (A/D), up (Q/E) and forward (S/W).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Motion {
    pub right: f64,
    pub up: f64,
    pub forward: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct CameraControl {
    pub mode: Mode,
    target: DVec3,
    yaw: f64,
    pitch: f64,
    distance: f64,
    /// The scene camera's up (unit) and two unit vectors completing it to a right-handed frame.
    up: DVec3,
    e1: DVec3,
    e2: DVec3,
    base: Camera,
    /// Until the first move the scene's camera is returned bit for bit (so the viewer's first
    /// frames are exactly `hadou render`'s).
    moved: bool,
}

impl CameraControl {
    /// Starts where the scene's camera is.
    pub fn new(camera: &Camera) -> Self {
        let up = camera.up.normalize();
        let e1 = up.any_orthonormal_vector();
        let e2 = up.cross(e1);
        let offset = camera.look_at - camera.position;
        let distance = offset.length();
        let f = offset / distance;
        let pitch = f.dot(up).clamp(-1.0, 1.0).asin().clamp(-PITCH_LIMIT, PITCH_LIMIT);
        let yaw = f.dot(e2).atan2(f.dot(e1));
        let base = *camera;
        CameraControl {
            mode: Mode::Orbit,
            target: camera.look_at,
            yaw,
            pitch,
            distance,
            up,
            e1,
            e2,
            base,
            moved: false,
        }
    }

    pub fn toggle_mode(&mut self) {
        self.mode = if self.mode == Mode::Orbit { Mode::Fly } else { Mode::Orbit };
    }

    /// The unit view direction.
    pub fn forward(&self) -> DVec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        (self.e1 * cy + self.e2 * sy) * cp + self.up * sp
    }

    pub fn eye(&self) -> DVec3 {
        self.target - self.forward() * self.distance
    }

    #[cfg(test)]
    pub fn distance(&self) -> f64 {
        self.distance
    }

    #[cfg(test)]
    pub fn pitch(&self) -> f64 {
        self.pitch
    }

    /// Mouse drag by (dx, dy) pixels: orbit turns the eye about the target, fly turns the view.
    pub fn drag(&mut self, dx: f64, dy: f64) {
        if !(dx.is_finite() && dy.is_finite()) {
            return;
        }
        let eye = self.eye();
        self.moved = true;
        self.yaw = (self.yaw - dx * DRAG_RADIANS_PER_PIXEL).rem_euclid(std::f64::consts::TAU);
        self.pitch = (self.pitch - dy * DRAG_RADIANS_PER_PIXEL).clamp(-PITCH_LIMIT, PITCH_LIMIT);
        if self.mode == Mode::Fly {
            self.target = eye + self.forward() * self.distance;
        }
    }

    /// Wheel by `lines` (positive: away from the user): orbit zooms toward the target, never
    /// nearer than twice the near plane nor farther than half the far plane; fly moves forward.
    pub fn wheel(&mut self, lines: f64) {
        if !lines.is_finite() {
            return;
        }
        self.moved = true;
        match self.mode {
            Mode::Orbit => {
                let (lo, hi) = (2.0 * self.base.near, 0.5 * self.base.far);
                self.distance = (self.distance * ZOOM_PER_LINE.powf(lines)).clamp(lo, hi.max(lo));
            }
            Mode::Fly => self.target += self.forward() * (lines * 0.1 * self.distance.max(1.0)),
        }
    }

    /// Moves along the view axes for `dt` seconds of held keys, at a speed that scales with the
    /// distance to the target (both modes: in orbit it pans the target with the eye).
    pub fn fly(&mut self, motion: Motion, dt: f64) {
        if !dt.is_finite() || dt <= 0.0 {
            return;
        }
        let f = self.forward();
        let right = f.cross(self.up).normalize();
        let speed = 0.75 * self.distance.max(1.0);
        let step = (right * motion.right + self.up * motion.up + f * motion.forward) * (speed * dt);
        if step.is_finite() && step != DVec3::ZERO {
            self.moved = true;
            self.target += step;
        }
    }

    /// The scene camera moved to the controller's eye and target (lens unchanged).
    pub fn camera(&self) -> Camera {
        if !self.moved {
            return self.base;
        }
        Camera { position: self.eye(), look_at: self.target, up: self.up, ..self.base }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene_camera() -> Camera {
        Camera {
            position: DVec3::new(0.0, 4.5, 10.0),
            look_at: DVec3::new(0.0, 0.8, 0.0),
            up: DVec3::Y,
            fov_y_deg: 45.0,
            near: 0.1,
            far: 40.0,
            lens: Default::default(),
        }
    }

    /// Only f64 rounding separates the controller's camera from the scene's: a few ulps of the
    /// coordinates (≈ 10), so 1e-12 is a bound with margin and far below any visible change.
    #[test]
    fn starts_at_the_scene_camera() {
        let mut c = CameraControl::new(&scene_camera());
        assert_eq!(c.camera(), scene_camera(), "unmoved: the scene's camera exactly");
        assert!((c.eye() - scene_camera().position).length() < 1e-12, "{:?}", c.eye());
        c.fly(Motion::default(), 0.1);
        assert_eq!(c.camera(), scene_camera(), "no key held: no move");
    }

    #[test]
    fn orbit_keeps_the_distance_to_the_target() {
        let mut c = CameraControl::new(&scene_camera());
        let d0 = c.distance();
        for (dx, dy) in [(120.0, 0.0), (-40.0, 35.0), (500.0, -900.0), (3.0, 2000.0)] {
            c.drag(dx, dy);
            let cam = c.camera();
            assert!(((cam.position - cam.look_at).length() - d0).abs() < 1e-12 * d0);
            assert_eq!(cam.look_at, scene_camera().look_at, "orbit never moves the target");
        }
    }

    #[test]
    fn fly_moves_along_the_view_axes() {
        let mut c = CameraControl::new(&scene_camera());
        c.toggle_mode();
        let before = c.camera();
        let b = before.basis();
        let speed = 0.75 * c.distance();
        c.fly(Motion { forward: 1.0, ..Default::default() }, 0.5);
        let moved = c.camera().position - before.position;
        assert!((moved - b.forward * speed * 0.5).length() < 1e-12, "W moves along forward: {moved:?}");
        let before = c.camera();
        c.fly(Motion { right: 1.0, ..Default::default() }, 0.5);
        let moved = c.camera().position - before.position;
        assert!((moved - before.basis().right * speed * 0.5).length() < 1e-12, "D moves along right");
        let before = c.camera();
        c.fly(Motion { up: -1.0, ..Default::default() }, 0.5);
        let moved = c.camera().position - before.position;
        assert!((moved + DVec3::Y * speed * 0.5).length() < 1e-12, "Q moves down along up");
    }

    #[test]
    fn fly_drag_turns_about_the_eye_and_mode_switch_keeps_the_camera() {
        let mut c = CameraControl::new(&scene_camera());
        c.toggle_mode();
        let eye = c.eye();
        c.drag(80.0, -30.0);
        assert!((c.eye() - eye).length() < 1e-12);
        let cam = c.camera();
        c.toggle_mode();
        assert_eq!(c.camera(), cam);
    }

    /// However far the mouse goes, pitch stays inside ±89°: forward and up are never parallel, so
    /// the camera basis (a cross product, normalized) has no NaN.
    #[test]
    fn pitch_is_clamped_and_the_basis_never_degenerates() {
        for mode in [Mode::Orbit, Mode::Fly] {
            let mut c = CameraControl::new(&scene_camera());
            c.mode = mode;
            for dy in [1e6, -1e6, 1e9, f64::MAX, -f64::MAX] {
                c.drag(0.0, dy);
                assert!(c.pitch().abs() <= PITCH_LIMIT);
                let b = c.camera().basis();
                assert!(b.right.is_finite() && b.up.is_finite() && b.forward.is_finite(), "{b:?}");
                assert!(b.forward.dot(DVec3::Y).abs() < 89.5f64.to_radians().sin());
            }
            c.drag(f64::NAN, f64::INFINITY);
            c.wheel(f64::NAN);
            c.fly(Motion { forward: 1.0, ..Default::default() }, f64::INFINITY);
            assert!(c.camera().position.is_finite() && c.camera().look_at.is_finite());
        }
    }

    #[test]
    fn zoom_stays_between_the_clip_planes() {
        let mut c = CameraControl::new(&scene_camera());
        c.wheel(1000.0);
        assert!((c.distance() - 0.2).abs() < 1e-12, "2 × near");
        c.wheel(-1000.0);
        assert!((c.distance() - 20.0).abs() < 1e-12, "far / 2");
    }
}
