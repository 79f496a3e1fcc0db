//! A living world: waves and metaball groups spawned and despawned at run time by typed ids, and
//! the passes following them — the first wave spawned brings the energy pass in, the last one
//! despawned takes it out (a pass the world does not use is not run). A pass taken out is kept,
//! built, for the next time the world needs it: spawning an effect of a kind seen before
//! compiles nothing and waits for nothing.

use glam::{DMat4, DVec3};

use super::Renderer;
use crate::effects::metaballs::{Ball, CastMethod, Kernel};
use crate::scene::model::{AnimatedBall, MetaballGroup, Wave, WaveMethod};
use crate::scene::transform::{Transform, TransformOp};
use crate::Error;

/// A wave of the world (from the scene file or `Renderer::spawn_wave`); stale once despawned.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct WaveId(pub(super) u64);

/// A metaball group of the world (from the scene file or `Renderer::spawn_metaballs`); stale once
/// despawned.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GroupId(pub(super) u64);

/// Everything a wave is (seed 004): E(P) = a·k(|P − M|) + b·k(dist(P, segment M → M + ℓD)),
/// k(r) = 1/√(r² + core²), drawn as colour × intensity × the line integral.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveDesc {
    /// M.
    pub origin: DVec3,
    /// D (any non-zero length; normalized).
    pub direction: DVec3,
    /// Sphere strength a ≥ 0.
    pub a: f64,
    /// Line strength b ≥ 0.
    pub b: f64,
    /// Soft core radius ε ≥ 0.
    pub core: f64,
    /// Beam length ℓ > 0 (may be +inf).
    pub length: f64,
    /// Linear RGB colour, each channel ≥ 0.
    pub color: DVec3,
    /// Emission scale ≥ 0.
    pub intensity: f64,
    /// H below which nothing is emitted, ≥ 0 (0: the seed's integral as it is; `[[wave]] cutoff`).
    pub cutoff: f64,
}

/// A metaball group (seed 000): Σ qᵢ f(‖x − cᵢ‖²/Rᵢ²) = threshold in object space, placed by
/// `transform`, shaded with the scene material named `material`.
#[derive(Clone, Debug, PartialEq)]
pub struct MetaballsDesc {
    /// At least one ball: finite centre and q, finite radius > 0.
    pub balls: Vec<Ball>,
    /// T > 0.
    pub threshold: f64,
    /// The name of a material of the loaded scene.
    pub material: String,
    /// Object → world, affine and invertible.
    pub transform: DMat4,
}

fn invalid(what: String, expected: &str) -> Error {
    Error::InvalidUpdate { what, expected: expected.into() }
}

fn check_wave(d: &WaveDesc) -> Result<(), Error> {
    // What the GPU holds: every value and the emission colour × intensity as f32.
    let f32_max = f64::from(f32::MAX);
    let fits = |v: DVec3| v.abs().max_element() <= f32_max;
    let scalars = [d.a, d.b, d.core, d.intensity, d.cutoff];
    let ok = fits(d.origin)
        && fits(d.color * d.intensity)
        && scalars.iter().all(|v| v.abs() <= f32_max)
        && (d.length.is_infinite() || d.length <= f32_max)
        && d.origin.is_finite()
        && d.direction.is_finite()
        && d.direction.length() > 0.0
        && [d.a, d.b, d.core, d.intensity, d.cutoff].iter().all(|v| v.is_finite() && *v >= 0.0)
        && d.length > 0.0
        && !d.length.is_nan()
        && d.color.is_finite()
        && d.color.min_element() >= 0.0;
    if ok {
        Ok(())
    } else {
        Err(invalid(
            format!("wave {d:?}"),
            "a finite origin, a non-zero finite direction, finite a, b, core, intensity, cutoff ≥ 0, length > 0 \
             and a finite colour ≥ 0, each (and colour × intensity) within f32's range (3.4e38)",
        ))
    }
}

impl Renderer {
    /// Adds a wave to the world from the next frame on; the energy pass comes in with the first.
    pub fn spawn_wave(&mut self, desc: &WaveDesc) -> Result<WaveId, Error> {
        check_wave(desc)?;
        let id = self.next_id();
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        loaded.scene.waves_mut().push(Wave {
            name: None,
            origin: desc.origin,
            velocity: DVec3::ZERO,
            direction: desc.direction.normalize(),
            a: desc.a,
            b: desc.b,
            core: desc.core,
            length: desc.length,
            color: desc.color,
            intensity: desc.intensity,
            cutoff: desc.cutoff,
            method: WaveMethod::Analytic,
            tolerance: None,
            keyframes: Vec::new(),
        });
        loaded.wave_ids.push(id);
        self.sync_passes()?;
        Ok(WaveId(id))
    }

    /// Changes a wave (spawned or from the scene file) for every following frame.
    pub fn update_wave(&mut self, id: WaveId, desc: &WaveDesc) -> Result<(), Error> {
        check_wave(desc)?;
        let index = self.wave_index(id)?;
        let wave = &mut self.loaded.as_mut().ok_or(Error::NoScene)?.scene.waves_mut()[index];
        (wave.origin, wave.direction) = (desc.origin, desc.direction.normalize());
        (wave.a, wave.b, wave.core, wave.length) = (desc.a, desc.b, desc.core, desc.length);
        (wave.color, wave.intensity, wave.cutoff) = (desc.color, desc.intensity, desc.cutoff);
        // From now on, at every time: a file wave's keyframes and velocity no longer apply.
        wave.velocity = DVec3::ZERO;
        wave.keyframes.clear();
        Ok(())
    }

    /// Sets the relative error of H per pixel the energy pass may trade for speed for a wave
    /// (spawned or from the scene file): 0 evaluates every pixel exactly, None restores the
    /// default (`Wave::effective_tolerance`); in [0, 1). While a frame budget is on
    /// (`set_frame_budget`), the budget's level sets the tolerance of every analytic wave without
    /// a cutoff instead.
    pub fn set_wave_tolerance(&mut self, id: WaveId, tolerance: Option<f64>) -> Result<(), Error> {
        if let Some(t) = tolerance {
            if !(0.0..1.0).contains(&t) {
                return Err(invalid(format!("wave tolerance {t}"), "a number in [0, 1)"));
            }
        }
        let index = self.wave_index(id)?;
        self.loaded.as_mut().ok_or(Error::NoScene)?.scene.waves_mut()[index].tolerance = tolerance;
        self.sync_passes()
    }

    /// Removes a wave (spawned or from the scene file); the energy pass goes out with the last wave.
    pub fn despawn_wave(&mut self, id: WaveId) -> Result<(), Error> {
        let index = self.wave_index(id)?;
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        loaded.scene.waves_mut().remove(index);
        loaded.wave_ids.remove(index);
        self.sync_passes()
    }

    /// Adds a metaball group to the world from the next frame on; the metaballs pass comes in
    /// with the first.
    pub fn spawn_metaballs(&mut self, desc: &MetaballsDesc) -> Result<GroupId, Error> {
        let group = self.metaball_group(desc)?;
        let id = self.next_id();
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        loaded.scene.metaballs_mut().push(group);
        loaded.group_ids.push(id);
        self.sync_passes()?;
        Ok(GroupId(id))
    }

    /// Removes a metaball group (spawned or from the scene file); the metaballs pass goes out with the last group.
    pub fn despawn_metaballs(&mut self, id: GroupId) -> Result<(), Error> {
        let index = self.group_index(id)?;
        let loaded = self.loaded.as_mut().ok_or(Error::NoScene)?;
        loaded.scene.metaballs_mut().remove(index);
        loaded.group_ids.remove(index);
        self.sync_passes()
    }

    /// The ids of the world's waves, in scene order (those of the scene file included).
    pub fn wave_ids(&self) -> Vec<WaveId> {
        self.loaded.iter().flat_map(|l| l.wave_ids.iter().map(|&id| WaveId(id))).collect()
    }

    /// The ids of the world's metaball groups, in scene order (those of the scene file included).
    pub fn metaballs_ids(&self) -> Vec<GroupId> {
        self.loaded.iter().flat_map(|l| l.group_ids.iter().map(|&id| GroupId(id))).collect()
    }

    /// A fresh id, unique in the process: an id of another renderer, or of a scene loaded
    /// before, names nothing here (`Error::StaleId`).
    pub(super) fn next_id(&mut self) -> u64 {
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
        NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    }

    fn metaball_group(&self, desc: &MetaballsDesc) -> Result<MetaballGroup, Error> {
        let scene = &self.loaded.as_ref().ok_or(Error::NoScene)?.scene;
        let material = scene.materials.iter().position(|m| m.name == desc.material).ok_or_else(|| {
            invalid(
                format!("metaballs material \"{}\"", desc.material),
                "the name of a material of the scene",
            )
        })?;
        let valid =
            |b: &Ball| b.centre.is_finite() && b.q.is_finite() && b.radius.is_finite() && b.radius > 0.0;
        if desc.balls.is_empty() || !desc.balls.iter().all(valid) {
            return Err(invalid(
                format!("metaballs with {} balls", desc.balls.len()),
                "at least one ball, each with a finite centre and q and a finite radius > 0",
            ));
        }
        if !(desc.threshold.is_finite() && desc.threshold > 0.0) {
            return Err(invalid(format!("metaballs threshold {}", desc.threshold), "a finite T > 0"));
        }
        let ops = vec![TransformOp::Matrix(desc.transform)];
        let transform =
            Transform::from_ops(&ops).map_err(|e| invalid("metaballs transform".into(), &e.to_string()))?;
        let ball = |b: &Ball| AnimatedBall {
            centre: b.centre,
            radius: b.radius,
            q: b.q,
            velocity: DVec3::ZERO,
            q_rate: 0.0,
        };
        Ok(MetaballGroup {
            name: None,
            threshold: desc.threshold,
            kernel: Kernel::default(),
            material,
            ops,
            transform,
            balls: desc.balls.iter().map(ball).collect(),
            keyframes: Vec::new(),
            method: CastMethod::default(),
            device: None,
        })
    }

    /// Brings the passes in line with the world: those it needs run (taken from the parked ones
    /// when built before with the same variant), the others are parked (kept built, not run).
    pub(super) fn sync_passes(&mut self) -> Result<(), Error> {
        let Some(loaded) = &mut self.loaded else { return Ok(()) };
        loaded.passes.sync(&self.ctx, &self.memory, &mut self.compiler, &self.effects, &loaded.scene)
    }
}
