//! Helpers shared by hadou's tests, examples and benchmarks (not part of the supported API).

use glam::DVec3;

pub mod comparison;
pub use comparison::Comparison;

/// xorshift64*: deterministic random numbers without a dependency, so every test and
/// measurement draws the same cases on every machine.
pub struct Rng(pub u64);

impl Rng {
    /// Uniform in [0, 1), 53 bits. (Not an Iterator: the stream never ends and callers draw
    /// mixed quantities from it.)
    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [a, b).
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }

    /// Each component uniform in [a, b).
    pub fn vec(&mut self, a: f64, b: f64) -> DVec3 {
        DVec3::new(self.range(a, b), self.range(a, b), self.range(a, b))
    }

    /// A uniformly distributed unit vector (rejection from the unit ball, away from the centre).
    pub fn unit(&mut self) -> DVec3 {
        loop {
            let v = self.vec(-1.0, 1.0);
            if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }

    /// A unit vector perpendicular to the unit vector `d`.
    pub fn perp(&mut self, d: DVec3) -> DVec3 {
        let n = self.unit();
        (n - n.dot(d) * d).normalize()
    }

    /// One of `xs`, uniformly.
    pub fn pick<T: Copy>(&mut self, xs: &[T]) -> T {
        xs[((self.next() * xs.len() as f64) as usize).min(xs.len() - 1)]
    }
}

/// A metaball group whose supports crowd along a tube: `k` faint balls (radii 1–1.2, centres
/// within 0.2 of the z axis, spread evenly over z ∈ [−0.5, 7], listed from +z down: nearest first
/// for rays from +z, as the metaballs pass sorts its runs) in front of the two dense balls of
/// [`crowded_metaballs`], under a random scale, rotation and translation. A ray from +z in object
/// space meets all k supports one after another, about k/3.4 of them on each point (more than the
/// 32 slots), so a streamed cast of it gathers its chords in several rounds of the cache
/// (`MB_CACHE_BALLS` = 128 when k > 128). Σq on a point stays near 0.1, under T = 0.5.
pub fn crowded_tube(rng: &mut Rng, k: usize) -> crate::effects::metaballs::MetaballGroupParams {
    use crate::effects::metaballs::Ball;
    let mut group = crowded_metaballs(rng, 0);
    let per_point = k as f64 / 3.4;
    let mut balls: Vec<Ball> = (0..k)
        .map(|i| {
            let z = 7.0 - 7.5 * (i as f64 + rng.range(0.0, 1.0)) / k as f64;
            Ball {
                centre: DVec3::new(rng.range(-0.2, 0.2), rng.range(-0.2, 0.2), z),
                radius: rng.range(1.0, 1.2),
                q: 0.35 / per_point,
            }
        })
        .collect();
    balls.append(&mut group.balls);
    group.balls = balls;
    group
}

/// A metaball group whose supports crowd: `k` faint balls (Σq = 0.35 < T = 0.5, so no surface of
/// their own) with centres within 0.3 of (0, 0, 0.8) and radii 2–2.4 — every point within 1.4
/// of that centre lies in all k supports — in front of and around two dense balls near
/// (0, 0, −1.35), under a random non-uniform scale, rotation and translation. Rays from +z in
/// object space cross the crowd before they reach the surface.
pub fn crowded_metaballs(rng: &mut Rng, k: usize) -> crate::effects::metaballs::MetaballGroupParams {
    use crate::effects::metaballs::{Ball, Kernel, MetaballGroupParams};
    use crate::scene::transform::{Transform, TransformOp};
    let mut balls: Vec<Ball> = (0..k)
        .map(|_| Ball {
            centre: rng.vec(-0.3, 0.3) + DVec3::new(0.0, 0.0, 0.8),
            radius: rng.range(2.0, 2.4),
            q: 0.35 / k as f64,
        })
        .collect();
    balls.push(Ball { centre: DVec3::new(-0.4, 0.1, -1.2), radius: 1.2, q: 1.4 });
    balls.push(Ball { centre: DVec3::new(0.5, -0.2, -1.5), radius: 1.0, q: 1.1 });
    let ops = [
        TransformOp::Scale(DVec3::new(rng.range(0.6, 1.5), rng.range(0.6, 1.5), rng.range(0.6, 1.5))),
        TransformOp::Rotate { angle_deg: rng.range(0.0, 360.0), axis: rng.unit() },
        TransformOp::Translate(rng.vec(-2.0, 2.0)),
    ];
    MetaballGroupParams {
        threshold: 0.5,
        kernel: Kernel::Wyvill6,
        balls,
        transform: Transform::from_ops(&ops).expect("a scale ≥ 0.6 is invertible"),
        method: Default::default(),
    }
}
