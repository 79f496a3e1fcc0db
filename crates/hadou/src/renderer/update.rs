//! Per-frame changes without rebuilding pipelines: camera, instance transforms, waves, metaballs.
//! Each edits the loaded scene; the next `record_frame` uploads it into the existing buffers.

use glam::DVec3;

use super::game_math::{GameMatrix, GameVector};
use super::ids::MaterialId;
use super::instances::{InstanceId, LightId};
use super::world::{GroupId, WaveId};
use super::Renderer;
use crate::scene::camera::Camera;
use crate::scene::transform::{Transform, TransformOp};
use crate::scene::{Light, LightKind, MaterialKind};
use crate::Error;

/// A wave's state from now on, at every time: keyframes and velocity are dropped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveUpdate {
    /// M.
    pub origin: DVec3,
    /// D (any non-zero length; normalized).
    pub direction: DVec3,
    /// Sphere strength a ≥ 0.
    pub a: f64,
    /// Line strength b ≥ 0.
    pub b: f64,
    /// Beam length ℓ > 0 (may be +inf).
    pub length: f64,
}

/// A symmetric lens needs a finite far; a matrix lens, finite scales > 0 and finite shifts.
fn lens_ok(camera: &Camera) -> bool {
    match camera.lens {
        crate::scene::camera::Lens::FovY => camera.far.is_finite(),
        crate::scene::camera::Lens::Matrix { scale, shift } => {
            scale.is_finite() && scale.min_element() > 0.0 && shift.is_finite()
        }
    }
}

/// Why `camera` cannot be rendered from, if it cannot.
pub(super) fn check_camera(camera: &Camera) -> Result<(), Error> {
    let finite = [camera.position, camera.look_at, camera.up].iter().all(|v| v.is_finite());
    let forward = camera.look_at - camera.position;
    if !finite
        || forward.length() == 0.0
        || forward.cross(camera.up).length() == 0.0
        || !(camera.fov_y_deg > 0.0 && camera.fov_y_deg < 180.0)
        || !(camera.near > 0.0 && camera.near.is_finite() && camera.far > camera.near)
        || !lens_ok(camera)
    {
        return Err(Error::InvalidUpdate {
            what: format!("camera {camera:?}"),
            expected: "finite vectors, look_at ≠ position, up not along the view, 0 < fov_y_deg < 180, \
                       0 < near < far, far finite unless the lens is a matrix, a matrix lens's scales \
                       finite > 0 and shifts finite"
                .into(),
        });
    }
    Ok(())
}

impl Renderer {
    fn loaded_mut(&mut self) -> Result<&mut super::Loaded, Error> {
        self.loaded.as_mut().ok_or(Error::NoScene)
    }

    /// The camera of the following frames (the game's camera, so hadou's pixels line up with its).
    pub fn set_camera(&mut self, camera: Camera) -> Result<(), Error> {
        check_camera(&camera)?;
        let loaded = self.loaded_mut()?;
        loaded.scene.camera = camera;
        // The game's projection no longer describes the camera.
        loaded.game_projection = None;
        Ok(())
    }

    /// Places instance `id` by the affine `matrix` (object → world) from the next frame on.
    /// Any instance moves, translucent ones included: their tables are in object space (exact
    /// under any affine transform) and the light's view is fitted again each frame.
    pub fn set_transform(&mut self, id: InstanceId, matrix: impl GameMatrix) -> Result<(), Error> {
        self.set_transform_ops(id, &[TransformOp::Matrix(matrix.to_dmat4())])
    }

    /// Places instance `id` by transform operations, applied in the order listed (as in scene
    /// files); as `set_transform`.
    pub fn set_transform_ops(&mut self, id: InstanceId, ops: &[TransformOp]) -> Result<(), Error> {
        let index = self.instance_index(id)?;
        let transform = Transform::from_ops(ops).map_err(|e| Error::InvalidUpdate {
            what: format!("instance {index}"),
            expected: e.to_string(),
        })?;
        let loaded = self.loaded_mut()?;
        let instance = &mut loaded.scene.instances[index];
        instance.ops = ops.to_vec();
        instance.transform = transform;
        loaded.tables_dirty = true;
        Ok(())
    }

    /// Sets the shape of wave `id` (its colour, intensity, core and cutoff kept) for every
    /// following frame; `update_wave` sets all of it.
    pub fn set_wave(&mut self, id: WaveId, update: WaveUpdate) -> Result<(), Error> {
        let index = self.wave_index(id)?;
        let wave = &mut self.loaded_mut()?.scene.waves_mut()[index];
        let u = update;
        let ok = u.origin.is_finite()
            && u.direction.is_finite()
            && u.direction.length() > 0.0
            && u.a.is_finite()
            && u.a >= 0.0
            && u.b.is_finite()
            && u.b >= 0.0
            && u.length > 0.0;
        if !ok {
            return Err(Error::InvalidUpdate {
                what: format!("wave {index}: {u:?}"),
                expected: "a finite origin, a non-zero finite direction, finite a ≥ 0 and b ≥ 0, and \
                           length > 0"
                    .into(),
            });
        }
        wave.origin = u.origin;
        wave.direction = u.direction.normalize();
        wave.a = u.a;
        wave.b = u.b;
        wave.length = u.length;
        wave.velocity = DVec3::ZERO;
        wave.keyframes.clear();
        Ok(())
    }

    /// Sets ball `ball` (its place in the group's list) of metaball group `id`: its object-space
    /// centre and coefficient q, for every following frame. The group's keyframes and the ball's
    /// rates are dropped (the other balls then hold their time-0 values plus their own
    /// velocities). A ball past the group's list is `Error::UnknownId`.
    pub fn set_metaball(
        &mut self,
        id: GroupId,
        ball: usize,
        centre: impl GameVector,
        q: f64,
    ) -> Result<(), Error> {
        let centre = centre.to_dvec3();
        let group = self.group_index(id)?;
        let g = &mut self.loaded_mut()?.scene.metaballs_mut()[group];
        let balls = g.balls.len();
        let Some(b) = g.balls.get_mut(ball) else {
            return Err(Error::UnknownId { kind: "ball of the metaball group", index: ball, count: balls });
        };
        if !centre.is_finite() || !q.is_finite() {
            return Err(Error::InvalidUpdate {
                what: format!("metaball group {group} ball {ball}"),
                expected: "a finite centre and q".into(),
            });
        }
        b.centre = centre;
        b.q = q;
        b.velocity = DVec3::ZERO;
        b.q_rate = 0.0;
        g.keyframes.clear();
        Ok(())
    }

    /// Replaces every ball of metaball group `id` (object space) for every following frame:
    /// the group may grow or shrink. Keyframes and rates are dropped. Refused (state unchanged)
    /// when the list is empty or a ball is not finite with a radius > 0.
    pub fn set_metaball_group(
        &mut self,
        id: GroupId,
        balls: &[crate::effects::metaballs::Ball],
    ) -> Result<(), Error> {
        let group = self.group_index(id)?;
        let g = &mut self.loaded_mut()?.scene.metaballs_mut()[group];
        let valid = |b: &crate::effects::metaballs::Ball| {
            b.centre.is_finite() && b.q.is_finite() && b.radius.is_finite() && b.radius > 0.0
        };
        if balls.is_empty() || !balls.iter().all(valid) {
            return Err(Error::InvalidUpdate {
                what: format!("metaball group {group}: {} balls", balls.len()),
                expected: "at least one ball, each with a finite centre and q and a finite radius > 0".into(),
            });
        }
        g.balls = balls
            .iter()
            .map(|b| crate::scene::model::AnimatedBall {
                centre: b.centre,
                radius: b.radius,
                q: b.q,
                velocity: DVec3::ZERO,
                q_rate: 0.0,
            })
            .collect();
        g.keyframes.clear();
        Ok(())
    }

    /// Draws group `id` from balls the game writes on the GPU (a simulation): `balls` names the
    /// game's buffer and its records (`DeviceBall`, see `DeviceBalls` for the buffer's usage and
    /// synchronization); each frame copies them on the device, no host copy. `None` draws the
    /// group's own balls again. The group is then binned on the device (the metaballs pass is
    /// rebuilt for it here, not in a frame). Refused, state unchanged: a null buffer, or a count
    /// outside 1..=`BIN_MAX_BALLS`.
    pub fn set_metaball_buffer(
        &mut self,
        id: GroupId,
        balls: Option<crate::effects::metaballs::device::DeviceBalls>,
    ) -> Result<(), Error> {
        let group = self.group_index(id)?;
        let max = crate::passes::metaballs_bin::BIN_MAX_BALLS;
        if let Some(b) = balls {
            if b.buffer == crate::gpu::vk::Buffer::null() || !(1..=max).contains(&b.count) {
                return Err(Error::InvalidUpdate {
                    what: format!("metaball group {group}: device balls {b:?}"),
                    expected: format!("a buffer of the game's and 1..={max} balls"),
                });
            }
        }
        self.loaded_mut()?.scene.metaballs_mut()[group].device = balls;
        self.sync_passes()
    }

    /// Sets light `id`: the direction it travels (any non-zero length; a spot light's axis, unused
    /// by a point light), its colour and intensity (a point or spot light's in candela); its kind,
    /// position, range and cone are kept (`set_light_with` changes them). The translucent objects'
    /// light view follows it from the next frame.
    pub fn set_light(
        &mut self,
        id: LightId,
        direction: DVec3,
        color: DVec3,
        intensity: f64,
    ) -> Result<(), Error> {
        let index = self.light_index(id)?;
        let light = self.loaded_mut()?.scene.lights[index];
        let light = checked_light(index, Light { direction, color, intensity, ..light })?;
        self.loaded_mut()?.scene.lights[index] = light;
        Ok(())
    }

    /// Replaces light `id` with `light` (any kind: a directional light may become a point or spot
    /// light and back), checked as `spawn_light_with` checks it. State is unchanged on error.
    pub fn set_light_with(&mut self, id: LightId, light: Light) -> Result<(), Error> {
        let index = self.light_index(id)?;
        let light = checked_light(index, light)?;
        self.loaded_mut()?.scene.lights[index] = light;
        // Which light translucent materials are lit through may have changed.
        self.sync_passes()
    }

    /// Light `id` as it is now.
    pub fn light(&self, id: LightId) -> Result<Light, Error> {
        let index = self.light_index(id)?;
        Ok(self.loaded.as_ref().ok_or(Error::NoScene)?.scene.lights[index])
    }

    /// Sets material `id`'s albedo and, for a translucent material, its extinction σ per world
    /// unit (`None` keeps it). The kind of a material (lambert or translucent, its voxel_res and
    /// thickness mode) is fixed at load: those decide which passes and tables exist.
    pub fn set_material(&mut self, id: MaterialId, albedo: DVec3, sigma: Option<DVec3>) -> Result<(), Error> {
        let index = self.material_index(id)?;
        let loaded = self.loaded_mut()?;
        let material = &mut loaded.scene.materials[index];
        let albedo_ok = albedo.is_finite() && albedo.min_element() >= 0.0 && albedo.max_element() <= 1.0;
        let sigma_ok = sigma.is_none_or(|s| s.is_finite() && s.min_element() > 0.0);
        let translucent = matches!(material.kind, MaterialKind::Translucent { .. });
        if !albedo_ok || !sigma_ok || (sigma.is_some() && !translucent) {
            return Err(Error::InvalidUpdate {
                what: format!("material {index}: albedo {albedo}, sigma {sigma:?}"),
                expected: "an albedo in [0, 1] and, for a translucent material only, a finite σ > 0".into(),
            });
        }
        material.albedo = albedo;
        if let (Some(new), MaterialKind::Translucent { sigma, .. }) = (sigma, &mut material.kind) {
            *sigma = new;
        }
        loaded.tables_dirty = true;
        Ok(())
    }
}

/// `light` as a scene file would accept it (its direction normalized), or the error naming light
/// `index`: finite numbers within f32's range (however bright, the lights fit the HDR image: the
/// frame is pre-exposed, `effects::tonemap::pre_exposure`), a non-zero direction, a position
/// within `MAX_EXTENT`, a range in [2⁻⁶³, 2⁶³] (its square a normal f32), cone half-angles in
/// [0, π/2] with the outer one > 0.
pub(super) fn checked_light(index: usize, light: Light) -> Result<Light, Error> {
    let f32_max = f64::from(f32::MAX);
    let extent = crate::scene::file::MAX_EXTENT;
    let half_pi = std::f64::consts::FRAC_PI_2;
    let cone_ok = match light.kind {
        LightKind::Spot { inner_cone, outer_cone } => {
            (0.0..=half_pi).contains(&inner_cone) && outer_cone > 0.0 && outer_cone <= half_pi
        }
        _ => true,
    };
    let ok = light.direction.is_finite()
        && light.direction.length() > 0.0
        && light.position.is_finite()
        && light.position.abs().max_element() <= extent
        && light.color.is_finite()
        && light.color.min_element() >= 0.0
        && light.color.max_element() <= f32_max
        && light.intensity.is_finite()
        && (0.0..=f32_max).contains(&light.intensity)
        && light.range.is_none_or(|r| (1.0842021724855044e-19..=9.223372036854776e18).contains(&r))
        && cone_ok;
    if !ok {
        return Err(Error::InvalidUpdate {
            what: format!("light {index}: {light:?}"),
            expected: "a finite non-zero direction, a position within 2.8e14, a colour and an intensity ≥ 0 \
                       within f32's range (3.4e38), a range in [1.08e-19, 9.22e18] or none, spot cone \
                       half-angles in [0, π/2] with the outer one > 0"
                .into(),
        });
    }
    // A unit direction (a scene's, `Light::spot`'s) is kept bit for bit: normalizing again may move
    // its last bits, and a light set from the scene would then differ from it.
    let unit = (light.direction.length_squared() - 1.0).abs() <= 4.0 * f64::EPSILON;
    Ok(Light { direction: if unit { light.direction } else { light.direction.normalize() }, ..light })
}
