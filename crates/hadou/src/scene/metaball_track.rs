//! A metaball group at a given time: each ball's centre and q follow the piecewise-linear tracks
//! through the keyframes that set them (held before the first and after the last), else keep the
//! ball's own value; then the centre moves by velocity × T and q changes by q_rate × T.

use glam::DVec3;

use super::model::{MetaballGroup, MetaballKeyframe};
use crate::effects::metaballs::{Ball, MetaballGroupParams};

impl MetaballGroup {
    /// The group at `time` (seconds, any finite value): what the metaballs pass and its CPU
    /// references cast rays against. Radii, threshold, kernel and transform are not animated.
    pub fn at(&self, time: f64) -> MetaballGroupParams {
        let centres = track(&self.keyframes, time, |k| k.centres.as_deref());
        let qs = track(&self.keyframes, time, |k| k.q.as_deref());
        let balls = self
            .balls
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let centre = centres.as_ref().map_or(b.centre, |(s, v0, v1)| lerp_vec(v0[i], v1[i], *s));
                let q = qs.as_ref().map_or(b.q, |(s, v0, v1)| lerp(v0[i], v1[i], *s));
                Ball { centre: centre + b.velocity * time, radius: b.radius, q: q + b.q_rate * time }
            })
            .collect();
        MetaballGroupParams {
            threshold: self.threshold,
            kernel: self.kernel,
            balls,
            transform: self.transform,
            method: self.method,
        }
    }
}

/// The two keyframe values around `time` among the keyframes that set a field, and where `time`
/// lies between them (0 when held); `None` when no keyframe sets it.
fn track<'a, T>(
    keys: &'a [MetaballKeyframe],
    time: f64,
    get: impl Fn(&'a MetaballKeyframe) -> Option<&'a [T]>,
) -> Option<(f64, &'a [T], &'a [T])> {
    let mut before: Option<(f64, &[T])> = None;
    for k in keys {
        let Some(value) = get(k) else { continue };
        if k.time >= time {
            return Some(match before {
                None => (0.0, value, value),
                Some((t0, v0)) => (fraction(t0, k.time, time), v0, value),
            });
        }
        before = Some((k.time, value));
    }
    before.map(|(_, v)| (0.0, v, v))
}

/// Where `t` lies in [t0, t1] (t0 < t1, finite), in [0, 1]; the halves are used when the span
/// overflows.
fn fraction(t0: f64, t1: f64, t: f64) -> f64 {
    let span = t1 - t0;
    let s = if span.is_finite() { (t - t0) / span } else { (0.5 * t - 0.5 * t0) / (0.5 * t1 - 0.5 * t0) };
    if s.is_nan() {
        0.0
    } else {
        s.clamp(0.0, 1.0)
    }
}

fn lerp(a: f64, b: f64, s: f64) -> f64 {
    a * (1.0 - s) + b * s
}

fn lerp_vec(a: DVec3, b: DVec3, s: f64) -> DVec3 {
    a * (1.0 - s) + b * s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::metaballs::Kernel;
    use crate::scene::model::AnimatedBall;
    use crate::scene::transform::Transform;

    fn group(keyframes: Vec<MetaballKeyframe>) -> MetaballGroup {
        let ball = |x: f64| AnimatedBall {
            centre: DVec3::new(x, 0.0, 0.0),
            radius: 2.0,
            q: 1.0,
            velocity: DVec3::new(0.0, 1.0, 0.0),
            q_rate: 0.5,
        };
        MetaballGroup {
            name: None,
            threshold: 0.5,
            kernel: Kernel::Wyvill6,
            material: 0,
            ops: Vec::new(),
            transform: Transform::IDENTITY,
            balls: vec![ball(0.0), ball(4.0)],
            keyframes,
            method: Default::default(),
            device: None,
        }
    }

    #[test]
    fn velocity_and_rate_without_keyframes() {
        let p = group(Vec::new()).at(2.0);
        assert_eq!(p.balls[1].centre, DVec3::new(4.0, 2.0, 0.0));
        assert_eq!(p.balls[1].q, 2.0);
        assert_eq!(p.balls[1].radius, 2.0);
    }

    #[test]
    fn keyframes_interpolate_and_hold() {
        let keys = vec![
            MetaballKeyframe { time: 0.0, centres: Some(vec![DVec3::ZERO, DVec3::X]), q: None },
            MetaballKeyframe { time: 1.0, centres: None, q: Some(vec![2.0, 3.0]) },
            MetaballKeyframe {
                time: 2.0,
                centres: Some(vec![DVec3::Z * 2.0, DVec3::X * 3.0]),
                q: Some(vec![0.0, 1.0]),
            },
        ];
        let g = group(keys);
        // T = 1: centres halfway between the keyframes at 0 and 2 (plus velocity), q at its key.
        let p = g.at(1.0);
        assert_eq!(p.balls[0].centre, DVec3::new(0.0, 1.0, 1.0));
        assert_eq!(p.balls[1].centre, DVec3::new(2.0, 1.0, 0.0));
        assert_eq!(p.balls[0].q, 2.0 + 0.5);
        // Before the first q keyframe q holds its first value; after the last, everything holds.
        assert_eq!(g.at(0.0).balls[1].q, 3.0);
        let late = g.at(10.0);
        assert_eq!(late.balls[0].centre, DVec3::new(0.0, 10.0, 2.0));
        assert_eq!(late.balls[1].q, 1.0 + 5.0);
    }
}
