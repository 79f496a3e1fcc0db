//! A wave's parameters at a given time (seed 004 section 4: a wave moves by moving M and deforms
//! by changing a, b and D): each keyframed field follows a piecewise-linear track through the
//! keyframes that set it, held before the first and after the last; the others keep the wave's
//! own value; the origin then moves by velocity × time.

use glam::DVec3;

use super::model::{Wave, WaveKeyframe};

/// A wave's parameters at one time, what the energy-wave pass and its CPU twin integrate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaveState {
    /// M(T) = keyframed origin + velocity × T.
    pub origin: DVec3,
    /// D, unit length.
    pub direction: DVec3,
    /// Sphere strength, ≥ 0.
    pub a: f64,
    /// Line strength, ≥ 0.
    pub b: f64,
    /// Soft core radius ε, ≥ 0.
    pub core: f64,
    /// Beam length ℓ > 0, `f64::INFINITY` for the seed's half-infinite beam.
    pub length: f64,
    /// Linear RGB added to HDR per unit of H above `cutoff`: color × intensity.
    pub emission: DVec3,
    /// H below which nothing is emitted (`Wave::cutoff`).
    pub cutoff: f64,
}

impl Wave {
    /// The tolerance the energy pass uses: the one given, else
    /// `effects::energy_wave::tolerance::DEFAULT_TOLERANCE` (the tonemapped image changes by
    /// under half an 8-bit step) for a wave without a cutoff, and 0 (exact) for one with a cutoff
    /// (the emitted colour × (H − cutoff) has no relative bound near the cutoff).
    pub fn effective_tolerance(&self) -> f64 {
        match self.tolerance {
            Some(t) => t,
            None if self.cutoff == 0.0 => crate::effects::energy_wave::tolerance::DEFAULT_TOLERANCE,
            None => 0.0,
        }
    }

    /// The wave at `time` (seconds; any finite value, negative included). For a validated wave the
    /// result has no NaN for any finite `time` (extreme velocity × time can overflow to ±∞).
    pub fn at(&self, time: f64) -> WaveState {
        let keys = &self.keyframes;
        let num =
            |base: f64, get: fn(&WaveKeyframe) -> Option<f64>| track(keys, time, get, lerp).unwrap_or(base);
        let origin = track(keys, time, |k| k.origin, lerp_vec).unwrap_or(self.origin);
        let direction = track(keys, time, |k| k.direction, nlerp).unwrap_or(self.direction);
        WaveState {
            origin: origin + self.velocity * time,
            // A hand-built `Wave` may hold a zero direction; never hand out a NaN for it.
            direction: direction.try_normalize().unwrap_or(DVec3::X),
            a: num(self.a, |k| k.a),
            b: num(self.b, |k| k.b),
            core: num(self.core, |k| k.core),
            length: num(self.length, |k| k.length),
            emission: self.color * num(self.intensity, |k| k.intensity),
            cutoff: self.cutoff,
        }
    }
}

/// The value at `time` of the track through the keyframes (sorted by time) that set a field;
/// `None` when none does.
fn track<T: Copy>(
    keys: &[WaveKeyframe],
    time: f64,
    get: impl Fn(&WaveKeyframe) -> Option<T>,
    mix: fn(T, T, f64) -> T,
) -> Option<T> {
    let mut before: Option<(f64, T)> = None;
    for k in keys {
        let Some(value) = get(k) else { continue };
        if k.time >= time {
            return Some(match before {
                // At or before the first keyframe that sets the field: hold it.
                None => value,
                Some((t0, v0)) => mix(v0, value, fraction(t0, k.time, time)),
            });
        }
        before = Some((k.time, value));
    }
    // After the last one: hold it.
    before.map(|(_, v)| v)
}

/// Where `t` lies in [t0, t1] (t0 < t1, all finite), in [0, 1]. The difference of two distinct
/// floats is never 0; when it overflows (t0 = −1e308, t1 = 1e308) the halves are used instead.
fn fraction(t0: f64, t1: f64, t: f64) -> f64 {
    let span = t1 - t0;
    let s = if span.is_finite() { (t - t0) / span } else { (0.5 * t - 0.5 * t0) / (0.5 * t1 - 0.5 * t0) };
    if s.is_nan() {
        0.0
    } else {
        s.clamp(0.0, 1.0)
    }
}

/// Exact at both ends, and clamped between them so rounding never leaves the segment (nor
/// overflows to ∞ between two huge values).
fn lerp(v0: f64, v1: f64, s: f64) -> f64 {
    (v0 * (1.0 - s) + v1 * s).clamp(v0.min(v1), v0.max(v1))
}

fn lerp_vec(v0: DVec3, v1: DVec3, s: f64) -> DVec3 {
    DVec3::new(lerp(v0.x, v1.x, s), lerp(v0.y, v1.y, s), lerp(v0.z, v1.z, s))
}

/// Normalized lerp of unit vectors. Parsing refuses consecutive directions with a dot product
/// ≤ −0.99, so the lerp stays ≥ √0.005 long; an exactly opposite pair (only from a hand-built
/// `Wave`) switches at the midpoint instead of dividing by zero.
fn nlerp(u0: DVec3, u1: DVec3, s: f64) -> DVec3 {
    lerp_vec(u0, u1, s).try_normalize().unwrap_or(if s < 0.5 { u0 } else { u1 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::model::WaveMethod;

    fn wave() -> Wave {
        Wave {
            name: None,
            origin: DVec3::new(1.0, 2.0, 3.0),
            velocity: DVec3::ZERO,
            direction: DVec3::X,
            a: 60.0,
            b: 30.0,
            core: 0.5,
            length: f64::INFINITY,
            color: DVec3::new(0.5, 1.0, 2.0),
            intensity: 0.25,
            cutoff: 0.0,
            method: WaveMethod::Analytic,
            tolerance: None,
            keyframes: Vec::new(),
        }
    }

    fn key(time: f64) -> WaveKeyframe {
        WaveKeyframe { time, ..WaveKeyframe::default() }
    }

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-12
    }

    #[test]
    fn without_keyframes_the_wave_is_constant() {
        let w = wave();
        for t in [-5.0, 0.0, 3.5] {
            let s = w.at(t);
            assert_eq!(s.origin, w.origin);
            assert_eq!(s.direction, DVec3::X);
            assert_eq!((s.a, s.b, s.core, s.length), (60.0, 30.0, 0.5, f64::INFINITY));
            assert_eq!(s.emission, DVec3::new(0.125, 0.25, 0.5));
        }
    }

    #[test]
    fn keyframed_fields_interpolate_linearly_and_hold_outside() {
        let mut w = wave();
        w.keyframes = vec![
            WaveKeyframe { a: Some(10.0), origin: Some(DVec3::new(0.0, 0.0, 280.0)), ..key(0.0) },
            WaveKeyframe { origin: Some(DVec3::new(0.0, 0.0, 70.0)), ..key(1.0) },
            WaveKeyframe { a: Some(30.0), intensity: Some(1.0), ..key(2.0) },
            WaveKeyframe { origin: Some(DVec3::new(0.0, 0.0, -140.0)), ..key(3.0) },
        ];
        let z = |t: f64| w.at(t).origin.z;
        assert_eq!([z(0.0), z(1.0), z(3.0)], [280.0, 70.0, -140.0]);
        // Origin keys are at 0, 1, 3 (the keyframe at 2 does not set it).
        assert!((z(0.5) - 175.0).abs() < 1e-12);
        assert!((z(2.0) - (-35.0)).abs() < 1e-12);
        // Held before the first and after the last keyframe that sets the field.
        assert_eq!([z(-10.0), z(1e6)], [280.0, -140.0]);
        // `a` keys at 0 and 2.
        let a = |t: f64| w.at(t).a;
        assert_eq!([a(-1.0), a(0.0), a(2.0), a(9.0)], [10.0, 10.0, 30.0, 30.0]);
        assert!((a(0.5) - 15.0).abs() < 1e-12);
        // `intensity` has one key: held at every time, before it too.
        assert_eq!(w.at(-3.0).emission, w.color);
        assert_eq!(w.at(7.0).emission, w.color);
        // Fields without keys keep the wave's own values.
        assert_eq!((w.at(1.3).b, w.at(1.3).core, w.at(1.3).direction), (30.0, 0.5, DVec3::X));
    }

    #[test]
    fn a_single_keyframe_holds_its_value_at_all_times() {
        let mut w = wave();
        w.keyframes = vec![WaveKeyframe { length: Some(200.0), core: Some(2.0), ..key(5.0) }];
        for t in [-100.0, 0.0, 5.0, 100.0] {
            assert_eq!((w.at(t).length, w.at(t).core), (200.0, 2.0));
        }
    }

    #[test]
    fn velocity_moves_the_keyframed_origin() {
        let mut w = wave();
        w.velocity = DVec3::new(0.0, 0.0, -60.0);
        assert!(close(w.at(2.0).origin, DVec3::new(1.0, 2.0, 3.0 - 120.0)));
        assert!(close(w.at(-1.0).origin, DVec3::new(1.0, 2.0, 63.0)));
        w.keyframes = vec![
            WaveKeyframe { origin: Some(DVec3::ZERO), ..key(0.0) },
            WaveKeyframe { origin: Some(DVec3::new(10.0, 0.0, 0.0)), ..key(1.0) },
        ];
        assert!(close(w.at(0.5).origin, DVec3::new(5.0, 0.0, -30.0)));
        assert!(close(w.at(3.0).origin, DVec3::new(10.0, 0.0, -180.0)));
    }

    #[test]
    fn direction_uses_normalized_lerp() {
        let mut w = wave();
        w.keyframes = vec![
            WaveKeyframe { direction: Some(DVec3::X), ..key(0.0) },
            WaveKeyframe { direction: Some(DVec3::Y), ..key(2.0) },
        ];
        let half = w.at(1.0).direction;
        assert!(close(half, DVec3::new(1.0, 1.0, 0.0).normalize()));
        // nlerp is not slerp: at a quarter the angle is atan(1/3), not 22.5°.
        let quarter = w.at(0.5).direction;
        assert!(close(quarter, DVec3::new(3.0, 1.0, 0.0).normalize()));
        for t in [-1.0, 0.0, 0.3, 1.7, 2.0, 5.0] {
            assert!((w.at(t).direction.length() - 1.0).abs() < 1e-12);
        }
        assert_eq!((w.at(-1.0).direction, w.at(5.0).direction), (DVec3::X, DVec3::Y));
        // About the sharpest turn parsing allows still gives a unit vector mid-way.
        let u1 = DVec3::new(-0.9899, (1.0f64 - 0.9899 * 0.9899).sqrt(), 0.0);
        w.keyframes[1].direction = Some(u1);
        assert!((w.at(1.0).direction.length() - 1.0).abs() < 1e-12);
        // Exactly opposite (a hand-built wave): no NaN, it switches at the midpoint.
        w.keyframes[1].direction = Some(-DVec3::X);
        assert_eq!((w.at(0.99).direction, w.at(1.0).direction), (DVec3::X, -DVec3::X));
    }

    #[test]
    fn extreme_times_never_give_nan() {
        let mut w = wave();
        w.velocity = DVec3::new(1e300, 0.0, -1e300);
        w.keyframes = vec![
            WaveKeyframe { origin: Some(DVec3::splat(f64::MAX)), a: Some(f64::MAX), ..key(-f64::MAX) },
            WaveKeyframe { origin: Some(DVec3::splat(f64::MAX)), a: Some(0.0), ..key(-1e-300) },
            WaveKeyframe { direction: Some(DVec3::Y), ..key(0.0) },
            WaveKeyframe { direction: Some(DVec3::Z), a: Some(f64::MAX), ..key(5e-324) },
            WaveKeyframe { origin: Some(DVec3::splat(-f64::MAX)), ..key(f64::MAX) },
        ];
        for t in [-f64::MAX, -1e308, -1.0, -1e-300, 0.0, 2.5e-324, 5e-324, 1.0, 1e308, f64::MAX] {
            let s = w.at(t);
            let all = [s.origin.to_array(), s.direction.to_array(), s.emission.to_array()].concat();
            assert!(all.iter().chain(&[s.a, s.b, s.core, s.length]).all(|x| !x.is_nan()), "t = {t}: {s:?}");
            assert!((s.direction.length() - 1.0).abs() < 1e-12);
            assert!(s.a >= 0.0 && s.a.is_finite());
        }
    }
}
