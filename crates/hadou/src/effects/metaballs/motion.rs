//! Where a point of a metaball surface was in the previous frame (a temporal upscaler's motion):
//! the f64 twin of shaders/common/metaballs_motion.glsl.

use glam::{DMat4, DVec3};

use super::MetaballGroupParams;

/// World point `p` on `now`'s surface carried back to the previous frame: in the group's object
/// space by the field-weighted motion of the balls whose support holds it,
/// Σ |qᵢ|·f(r′ᵢ)·(cᵢ,before − cᵢ) / Σ |qᵢ|·f(r′ᵢ) (exact for balls moving together; `before[i]` is
/// ball i's previous centre, `None`: the balls' motion is not known), then to the world by the
/// group's previous transform `prev_to_world`. Where no support holds the point (it cannot be on
/// the surface) only the transforms move it.
pub fn previous_point(
    now: &MetaballGroupParams,
    before: Option<&[DVec3]>,
    prev_to_world: DMat4,
    p: DVec3,
) -> DVec3 {
    let o = now.transform.inverse.transform_point3(p);
    let (mut moved, mut weight) = (DVec3::ZERO, 0.0);
    if let Some(before) = before {
        for (b, was) in now.balls.iter().zip(before) {
            let f = b.q.abs() * now.kernel.f((o - b.centre).length_squared() / (b.radius * b.radius));
            moved += f * (*was - b.centre);
            weight += f;
        }
    }
    let back = if weight > 0.0 { o + moved / weight } else { o };
    prev_to_world.transform_point3(back)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::metaballs::{Ball, CastMethod, Kernel};
    use crate::scene::transform::Transform;

    fn group(balls: Vec<Ball>, transform: Transform) -> MetaballGroupParams {
        MetaballGroupParams {
            threshold: 0.4,
            kernel: Kernel::Wyvill6,
            balls,
            transform,
            method: CastMethod::default(),
        }
    }

    #[test]
    fn balls_moving_together_carry_the_point_exactly() {
        let balls = vec![
            Ball { centre: DVec3::ZERO, radius: 1.0, q: 1.0 },
            Ball { centre: DVec3::new(0.8, 0.0, 0.0), radius: 1.2, q: -0.5 },
        ];
        let d = DVec3::new(0.25, -0.5, 0.125);
        let before: Vec<DVec3> = balls.iter().map(|b| b.centre + d).collect();
        let g = group(balls, Transform::default());
        let p = DVec3::new(0.4, 0.3, 0.0);
        assert!((previous_point(&g, Some(&before), DMat4::IDENTITY, p) - (p + d)).length() < 1e-12);
    }

    #[test]
    fn the_weights_are_the_balls_field_terms() {
        // Two balls, the point nearer the first: its motion weighs more, by f(r′) exactly.
        let balls = vec![
            Ball { centre: DVec3::ZERO, radius: 1.0, q: 1.0 },
            Ball { centre: DVec3::X, radius: 1.0, q: 2.0 },
        ];
        let before = [DVec3::new(0.0, 1.0, 0.0), DVec3::new(1.0, 0.0, 1.0)];
        let g = group(balls, Transform::default());
        let p = DVec3::new(0.3, 0.0, 0.0);
        let (f0, f1) = (Kernel::Wyvill6.f(0.09), 2.0 * Kernel::Wyvill6.f(0.49));
        let want = p + (f0 * DVec3::Y + f1 * DVec3::Z) / (f0 + f1);
        assert!((previous_point(&g, Some(&before), DMat4::IDENTITY, p) - want).length() < 1e-12);
        // Unknown ball motion, or no support holding the point: the transforms only.
        let shift = DMat4::from_translation(DVec3::new(0.0, 0.0, -3.0));
        assert_eq!(previous_point(&g, None, shift, p), p + DVec3::new(0.0, 0.0, -3.0));
        let far = DVec3::new(5.0, 0.0, 0.0);
        assert_eq!(previous_point(&g, Some(&before), DMat4::IDENTITY, far), far);
    }
}
