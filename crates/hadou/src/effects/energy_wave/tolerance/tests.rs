//! The tile bound against the f64 closed form: on tiles chosen to break it (near the core,
//! grazing the beam, far from the origin, depth edges, soft and hard cores, endless beams) the
//! interpolated H of every pixel stays within the bound.

use glam::{DVec2, DVec3};

use super::*;
use crate::effects::energy_wave::line_integral;
use crate::effects::tonemap::{aces, srgb_encode};
use crate::scene::camera::RayFrame;

/// A small deterministic generator (xorshift64*).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
    fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

#[test]
fn default_tolerance_keeps_half_an_8_bit_step() {
    let g = |x: f64| srgb_encode(aces(x));
    let mut worst: f64 = 0.0;
    let mut x = 1e-7;
    while x < 64.0 {
        let h = x * 1e-6;
        worst = worst.max(x * (g(x + h) - g(x - h)) / (2.0 * h));
        x *= 1.0002;
    }
    assert!(255.0 * worst * DEFAULT_TOLERANCE < 0.5, "sup x·g' = {worst}");
    // The largest such tolerance, not a smaller one picked at random.
    assert!(255.0 * worst * DEFAULT_TOLERANCE > 0.49, "sup x·g' = {worst}");
}

#[test]
fn angle_to_arc_is_a_lower_bound() {
    let mut rng = Rng(7);
    for _ in 0..2000 {
        let (u, a) = (rng.unit(), rng.unit());
        let b = if rng.next() < 0.2 { (a + rng.unit() * 1e-4).normalize() } else { rng.unit() };
        let bound = angle_to_arc(u, a, b);
        // Points of the segment from a to b (seen from the origin: the arc's directions).
        for i in 0..=200 {
            let p = (a + (b - a) * (i as f64 / 200.0)).normalize();
            let true_angle = u.cross(p).length().atan2(u.dot(p));
            assert!(bound <= true_angle + 1e-12, "{u} {a} {b}: {bound} > {true_angle}");
        }
    }
}

/// A camera ray frame looking along `forward` with a vertical field of view, for a w × h image.
fn ray_frame(forward: DVec3, fov_y_deg: f64, w: u32, h: u32) -> RayFrame {
    let right = forward.cross(DVec3::Y).try_normalize().unwrap_or(DVec3::X);
    let up = right.cross(forward);
    let tan_half = (fov_y_deg.to_radians() / 2.0).tan();
    RayFrame {
        right: right * tan_half * w as f64 / h as f64,
        up: up * tan_half,
        forward,
        offset: DVec2::ZERO,
    }
}

/// One case: the largest interpolation error over the tile's pixels, the bound, and the smallest
/// corner H.
fn check_case(rng: &mut Rng) -> (f64, f64, f64) {
    let (w, h) = if rng.next() < 0.5 { (256, 256) } else { (1920, 1080) };
    let far_away = rng.next() < 0.2;
    let camera = if far_away { rng.unit() * 1e4 } else { rng.unit() * rng.range(0.0, 5.0) };
    let frame = ray_frame(rng.unit(), rng.range(20.0, 90.0), w, h);
    let (x0, y0) = ((rng.next() * (w - 8) as f64) as u32, (rng.next() * (h - 8) as f64) as u32);
    let rays = TileRays::new(&frame, x0, y0, w, h);
    // The wave near the tile's rays: at some distance along one of them, a little off it.
    let along = rays.ray(rng.range(-4.0, 12.0), rng.range(-4.0, 12.0));
    let dist = rng.range(0.5, 50.0);
    let offset = rng.unit() * dist * 10f64.powf(rng.range(-3.0, 0.0));
    let origin = camera + along * dist + offset;
    // A third of the beams point nearly along the view (grazing), the rest anywhere.
    let direction = if rng.next() < 0.3 { (along + rng.unit() * 0.05).normalize() } else { rng.unit() };
    let core = [0.0, 1e-3, 0.3][(rng.next() * 3.0) as usize];
    let length = if rng.next() < 0.4 { f64::INFINITY } else { rng.range(0.1, 20.0) };
    let (a, b) = match (rng.next() * 3.0) as usize {
        0 => (rng.range(0.1, 2.0), 0.0),
        1 => (0.0, rng.range(0.1, 2.0)),
        _ => (rng.range(0.1, 2.0), rng.range(0.1, 2.0)),
    };
    let wave = WaveParams { origin, direction, a, b, core, length };
    // Depth: open sky at `far`, a plane, or a plane with an occluder's edge across the tile.
    let far = if far_away { 1e5 } else { 1000.0 };
    let normal = rng.unit();
    let plane_d = camera.dot(normal) - rng.range(1.0, 60.0);
    let kind = (rng.next() * 3.0) as usize;
    let edge = (rng.range(0.0, 8.0), rng.range(0.0, 8.0));
    let depth_at = |x: f64, y: f64| {
        let u = rays.ray(x, y);
        let t = (plane_d - camera.dot(normal)) / u.dot(normal);
        let plane = if t > 0.0 { t.min(far) } else { far };
        match kind {
            0 => far,
            1 => plane,
            _ if x + 0.3 * y < edge.0 + edge.1 * 0.3 => plane * 0.5,
            _ => plane,
        }
    };
    let tile = TILE_SIZES[(rng.next() * 2.0) as usize];
    let t = tile as f64;
    let corner_offsets = [(0.0, 0.0), (t, 0.0), (0.0, t), (t, t)];
    let corner_l = corner_offsets.map(|(x, y)| depth_at(x, y));
    let corner_h = corner_offsets.map(|(x, y)| line_integral(&wave, camera, rays.ray(x, y), depth_at(x, y)));
    let mut deviation: f64 = 0.0;
    let mut worst: f64 = 0.0;
    for j in 0..tile {
        for i in 0..tile {
            let (x, y) = (i as f64, j as f64);
            let l = depth_at(x, y);
            deviation = deviation.max((l - bilinear(corner_l, x, y, tile)).abs());
            let exact = line_integral(&wave, camera, rays.ray(x, y), l);
            // f64 rounding of H itself (a few ulps of the larger value).
            let slack = 1e-12 * exact.max(corner_h.iter().copied().fold(0.0, f64::max));
            worst = worst.max((exact - bilinear(corner_h, x, y, tile)).abs() - slack);
        }
    }
    let bound = tile_error_bound(&wave, camera, &rays, &TileDepth { corners: corner_l, deviation }, tile);
    let h_min = corner_h.iter().copied().fold(f64::INFINITY, f64::min);
    (worst, bound, h_min)
}

#[test]
fn bound_holds_on_tiles_chosen_to_break_it() {
    let mut rng = Rng(0x5eed_1234);
    let (mut finite, mut tight, mut usable) = (0, 0.0f64, 0);
    let cases = 4000;
    for case in 0..cases {
        let (worst, bound, h_min) = check_case(&mut rng);
        assert!(worst <= bound, "case {case}: error {worst:e} > bound {bound:e}");
        if bound.is_finite() {
            finite += 1;
            if worst > 0.0 {
                tight = tight.max(worst / bound);
            }
        }
        usable += usize::from(interpolates(bound, [h_min; 4], 1e-3));
    }
    // Not vacuous: most tiles get a finite bound, some would be interpolated at 1e-3 although the
    // waves sit on the tiles' rays, and on the tightest tiles (depth edges, where E is nearly
    // constant along the clipped stretch) the error comes close to the bound.
    assert!(finite > cases * 3 / 4, "{finite} of {cases} finite");
    assert!(usable > cases / 20, "{usable} of {cases} interpolated at 1e-3");
    assert!(tight > 0.05, "largest error/bound {tight}");
}
