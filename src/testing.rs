//! Helpers shared by hadou's tests, examples and benchmarks (not part of the supported API).

use glam::DVec3;

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
