//! The energy wave with a tolerance: H evaluated exactly at the corners of T×T-pixel tiles and
//! interpolated bilinearly inside a tile wherever a bound on the interpolation error says every
//! pixel stays within the wave's relative tolerance; every other tile is evaluated exactly, pixel
//! by pixel. This is the f64 twin of the bound `shaders/common/energy_wave_tiles.glsl` computes
//! in f32 (`shaders/energy_wave_classify.comp` decides the tiles with it).
//!
//! # The bound
//! Pixel offsets (x, y) ∈ [0, h]² from a tile's first corner (h = T, 4 or 8; corners at pixel
//! centres), the unit ray u(x, y) = v/|v| with v = v₀ + x·vₓ + y·v_y (the camera's ray frame),
//! L(x, y) the pixel's view distance (min(depth, far)). The pass writes, inside the tile,
//! F̃ = bilinear interpolation of the corner values F = H(u, L). Let L̃ be the bilinear
//! interpolation of the corners' L and G(x, y) = H(u(x, y), L̃(x, y)); G equals F at the corners,
//! so F̃ interpolates G too and
//!
//! |F − F̃| ≤ |H(u, L) − H(u, L̃)| + |G − Ĩ\[G\]| ≤ |L − L̃|·E_max + (h²/8)·(sup|G_xx| + sup|G_yy|),
//!
//! the first term because E ≤ E_max on every ray of the tile, the second the bilinear
//! interpolation bound (interpolate in x, then in y: each is linear interpolation, error
//! ≤ h²/8·sup|f''|, and the second does not amplify the first). The first term is measured per
//! pixel (a depth edge, the far plane or an occluder's silhouette crossing the tile makes it large:
//! the tile is then exact); the second is bounded from the closed form's ingredients:
//!
//! G_xx = ∫₀^L̃ (s²·u_xᵀ∇²E·u_x + s·∇E·u_xx) ds + 2·L̃·L̃_x·∇E(end)·u_x + L̃_x²·∇E(end)·u
//!
//! (L̃ is linear along a row, so L̃_xx = 0). Each term of E is k(φ) for φ the distance to a convex
//! set K (the point M; the segment [M, T] or the half-line from M), k(r) = (r² + ε²)^-½:
//! |∇k(φ)| ≤ (φ² + ε²)⁻¹ and |∇²k(φ)| ≤ 2·(φ² + ε²)^-3/2 (k'' = (2φ² − ε²)(φ² + ε²)^-5/2 along
//! ∇φ, k'/φ across it: the Hessian of a distance to a convex set has norm ≤ 1/φ). Along a ray,
//! φ(s) ≥ d (the distance from the tile's cone of rays to K) and φ(s) ≥ t(s), the distance from s
//! to [ρ_min, ρ_max] (the range of distances from the camera O to K: |P − Q| ≥ |s − |Q − O||).
//! With w = max(d, ε), [0, L] splits into s within w of [ρ_min, ρ_max] (bound by d) and the two
//! sides (bound by t ≥ w, with s ≤ ρ_min before and s ≤ ρ_max + t after):
//!
//! ∫ s²(φ² + ε²)^-3/2 ≤ (s₁³ − s₀³)/(3(d² + ε²)^3/2) + ρ_min²/(2w²) + ∫_w^T (ρ_max + t)²/t³ dt
//! ∫ s (φ² + ε²)⁻¹ ≤ (s₁² − s₀²)/(2(d² + ε²)) + ρ_min/w + ∫_w^T (ρ_max + t)/t² dt
//!
//! (s₀, s₁: the middle range's ends within [0, L]; T = L − ρ_max; an endless beam has
//! ρ_max = ∞: the middle range runs to L). The line term has a second, usually much tighter
//! profile of the same shape: its distance to the beam's axis grows as |c|·|s − s*| along the
//! centre ray (c = D × u_c) and a ray within α of it moves by at most α·s, so
//! φ ≥ max(κ₁(s₁ − s), κ₂(s − s₂)) with κ = |c| ± α (`Profile::axis`); the smaller bound is
//! used. d: the tile's rays lie within the angle α of its centre ray (the largest angle to a
//! corner ray: the image rectangle maps to a convex spherical polygon); a point Q of K seen at the
//! angle β_Q ≥ β_K from the centre ray is at least |Q − O|·sin(min(β_Q − α, 90°)) from every
//! ray, so d = ρ_min·sin(clamp(β_K − α, 0, 90°)),
//! β_K the angle from the centre ray to the directions of K (a great-circle arc for a segment).
//! |u_x| ≤ |vₓ|/|v|, |u_xx| ≤ (2/√3)·|vₓ|²/|v|² (the second derivative of v/|v| along a unit w is
//! ((c² − 1)·u − 2c·w⊥)/|v|², norm² (1 − c²)(1 + 3c²) ≤ 4/3), |v| ≥ |v_c| − (h/2)(|vₓ| + |v_y|),
//! |L̃_x| ≤ the larger of the top and bottom edges' slopes, and ∇E(end) ≤ (d² + ε²)⁻¹.
//!
//! A tile is interpolated when, for every wave, bound ≤ τ/(1 + τ)·min(corner H): F̃ is a convex
//! combination of the corners, so F ≥ min(corner H) − bound and the relative error is ≤ τ. Where
//! the clamp rule (mod.rs) could change a corner's integrand (d² + ε² below (2⁻¹⁹·S)², S ≤ the
//! largest distance from O to K's centres plus L) the tile is exact, so G is the function the
//! exact pass evaluates. The core (d → 0), grazing views along the beam (long middle range),
//! depth edges and the far plane all make the bound large, so those tiles are always exact.

use glam::DVec3;

use super::WaveParams;

/// The tile sizes the pass uses (pixels per side, the corner grid's spacing): 8 where the bound
/// lets most tiles through, else 4 (`tile_size`).
pub const TILE_SIZES: [u32; 2] = [4, 8];

/// The tile size for a frame whose pixels span `pixel_angle` radians at the centre and whose
/// smallest wave tolerance is `tolerance`: the bound grows as (T·θ)²/τ, and 8×8 tiles are chosen
/// while (8θ)²/τ ≤ 0.05 (on the seed's scene, by the f64 bound: 86 % of the tiles pass at 8 at
/// 1080p and 1e-3, where (8θ)²/τ = 0.034; 8×8 tiles have a quarter of the corners and bounds of
/// 4×4 ones), else 4.
pub fn tile_size(pixel_angle: f64, tolerance: f64) -> u32 {
    if (8.0 * pixel_angle).powi(2) <= 0.05 * tolerance {
        8
    } else {
        4
    }
}

/// The default tolerance of a wave without a cutoff: the tonemapped output then changes by less
/// than half an 8-bit step. A wave adds at most a pixel's whole radiance r, so a relative error δ
/// of its H changes the exposed x = e·r by at most δ·x; the output code is 255·g(x),
/// g = srgb ∘ aces, and x·g'(x) ≤ 0.28596 for every x ≥ 0 (largest at x ≈ 0.169;
/// `tests::default_tolerance_keeps_half_an_8_bit_step`), so the code moves by at most
/// 255·0.28596·δ < 0.5 for δ < 6.857e-3. Independent of the exposure (x·g'(x) does not change
/// when x is scaled). With a cutoff the emitted radiance is colour·(H − cutoff), whose relative
/// error is unbounded near the cutoff: such a wave is exact unless it gives a tolerance.
pub const DEFAULT_TOLERANCE: f64 = 6.8e-3;

/// The rays of one tile: v(x, y) = v0 + x·vx + y·vy for pixel offsets in [0, T]².
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileRays {
    pub v0: DVec3,
    pub vx: DVec3,
    pub vy: DVec3,
}

impl TileRays {
    /// The tile whose first corner is the pixel (x0, y0) of a width × height image, for a camera
    /// ray frame (right, up, forward as `Camera::ray_frame`, offset its ndc shift).
    pub fn new(
        frame: &crate::scene::camera::RayFrame,
        x0: u32,
        y0: u32,
        width: u32,
        height: u32,
    ) -> TileRays {
        let ndc_x = 2.0 * (x0 as f64 + 0.5) / width as f64 - 1.0 + frame.offset.x;
        let ndc_y = 1.0 - 2.0 * (y0 as f64 + 0.5) / height as f64 + frame.offset.y;
        TileRays {
            v0: frame.forward + frame.right * ndc_x + frame.up * ndc_y,
            vx: frame.right * (2.0 / width as f64),
            vy: frame.up * (-2.0 / height as f64),
        }
    }

    /// The unit ray at offset (x, y).
    pub fn ray(&self, x: f64, y: f64) -> DVec3 {
        (self.v0 + self.vx * x + self.vy * y).normalize()
    }
}

/// The view distances of a tile: at its corners (offsets (0, 0), (h, 0), (0, h), (h, h)) and the
/// largest |L − L̃| over its pixels (L̃ the corners' bilinear interpolation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileDepth {
    pub corners: [f64; 4],
    pub deviation: f64,
}

/// Bilinear interpolation of four corner values at offset (x, y) of a tile of side `tile`.
pub fn bilinear(c: [f64; 4], x: f64, y: f64, tile: u32) -> f64 {
    let (fx, fy) = (x / tile as f64, y / tile as f64);
    let top = c[0] + (c[1] - c[0]) * fx;
    let bottom = c[2] + (c[3] - c[2]) * fx;
    top + (bottom - top) * fy
}

/// The angle between two nonzero vectors (accurate near 0 and π).
fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// The smallest angle from the unit `u` to the directions of the points of the arc from the unit
/// `a` to the unit `b` (the shorter great-circle arc: a segment seen from outside it).
pub fn angle_to_arc(u: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ends = angle(u, a).min(angle(u, b));
    let n = a.cross(b);
    let sin_ab = n.length();
    if sin_ab < 1e-3 {
        // Nearly a point or nearly half a great circle (the plane is ill-conditioned): every
        // point is within angle(a, b) of a.
        return (angle(u, a) - angle(a, b)).max(0.0).min(ends);
    }
    let n = n / sin_ab;
    let p = u - n * u.dot(n);
    if a.cross(p).dot(n) >= 0.0 && p.cross(b).dot(n) >= 0.0 {
        u.dot(n).abs().clamp(0.0, 1.0).asin()
    } else {
        ends
    }
}

/// A lower bound on a term's distance along every ray of the tile:
/// φ(s) ≥ max(d, κ₁·(s₁ − s), κ₂·(s − s₂)) with s₁ ≤ s₂ (κ₂ = 0: none past s₂).
#[derive(Clone, Copy, Debug)]
struct Profile {
    s1: f64,
    k1: f64,
    s2: f64,
    k2: f64,
}

impl Profile {
    /// |P − Q| ≥ |s − |Q − O|| for every Q of K: the distance from s to [ρ_min, ρ_max].
    fn radial(rho_min: f64, rho_max: f64) -> Profile {
        let k2 = if rho_max.is_finite() { 1.0 } else { 0.0 };
        Profile { s1: rho_min, k1: 1.0, s2: if rho_max.is_finite() { rho_max } else { rho_min }, k2 }
    }

    /// The distance to the beam's axis (a lower bound for the whole line term): for the centre
    /// ray, |R + s·c| ≥ |c|·|s − s*| (c = D × u_c, s* = −R·c/|c|²), and a ray within α of it
    /// moves P(s) by at most α·s: φ ≥ |c|·|s − s*| − α·s. None when the centre ray is too close
    /// to parallel to the axis for that to grow past s*.
    fn axis(r: DVec3, c: DVec3, alpha: f64) -> Option<Profile> {
        let m = c.length();
        if !(m > alpha) {
            return None;
        }
        let s_star = -r.dot(c) / (m * m);
        let (k1, k2) = (m + alpha, m - alpha);
        Some(Profile { s1: m * s_star / k1, k1, s2: m * s_star / k2, k2 })
    }
}

/// One term of E seen from the tile: its strength, d (the least distance from the tile's rays to
/// its set K) and the distance profiles that hold along them.
struct Term {
    strength: f64,
    d: f64,
    profiles: Vec<Profile>,
}

/// What a term adds to sup|G_xx| (per unit of θ₁², θ₂ and the depth slope terms) and to E_max.
struct TermBounds {
    /// ∫ s²·2(φ² + ε²)^-3/2 ds.
    hessian: f64,
    /// ∫ s·(φ² + ε²)⁻¹ ds.
    gradient: f64,
    /// (d² + ε²)⁻¹: |∇E| at the ray's end.
    end: f64,
    /// (d² + ε²)^-½: E anywhere on the tile's rays.
    value: f64,
    /// d² + ε².
    d2: f64,
}

/// (∫ s²·2(φ² + ε²)^-3/2, ∫ s·(φ² + ε²)⁻¹) over [0, L] for φ ≥ max(d, profile), w = max(d, ε):
/// bound by d where the profile is below w, by the profile (t ≥ w, t³ ≤ (φ² + ε²)^3/2) outside,
/// with s ≤ s₁ before and s = s₂ + t/κ₂ after.
fn integrals(p: &Profile, d2: f64, w: f64, l: f64) -> (f64, f64) {
    let before = p.s1 - w / p.k1;
    let a0 = before.clamp(0.0, l);
    let a1 = if p.k2 > 0.0 { (p.s2 + w / p.k2).clamp(a0, l) } else { l };
    let span = a1 - a0;
    let mut hessian = span * (a1 * a1 + a1 * a0 + a0 * a0) / (3.0 * d2 * d2.sqrt());
    let mut gradient = span * (a1 + a0) / (2.0 * d2);
    if before > 0.0 {
        hessian += p.s1 * p.s1 / (2.0 * p.k1 * w * w);
        gradient += p.s1 / (p.k1 * w);
    }
    if p.k2 > 0.0 && a1 < l {
        // s = s₂ + t/κ₂ from s = a₁ (t₀ = κ₂(a₁ − s₂) ≥ w, s ≥ 0) to L (T = κ₂(L − s₂)),
        // integrated exactly.
        let k = p.k2;
        let (t0, t) = (k * (a1 - p.s2), k * (l - p.s2));
        let log = (t / t0).ln();
        hessian += (p.s2 * p.s2 * (0.5 / (t0 * t0) - 0.5 / (t * t))
            + 2.0 * p.s2 / k * (1.0 / t0 - 1.0 / t)
            + log / (k * k))
            / k;
        gradient += (p.s2 * (1.0 / t0 - 1.0 / t) + log / k) / k;
    }
    (2.0 * hessian, gradient)
}

fn term_bounds(t: &Term, eps: f64, l: f64) -> TermBounds {
    let d2 = t.d * t.d + eps * eps;
    let w = t.d.max(eps);
    let (mut hessian, mut gradient) = (f64::INFINITY, f64::INFINITY);
    for p in &t.profiles {
        let (h, g) = integrals(p, d2, w, l);
        hessian = hessian.min(h);
        gradient = gradient.min(g);
    }
    TermBounds { hessian, gradient, end: 1.0 / d2, value: 1.0 / d2.sqrt(), d2 }
}

/// d = ρ_min·sin(clamp(β_K − α, 0, 90°)) (module docs).
fn cone_distance(rho_min: f64, beta: f64, alpha: f64) -> f64 {
    rho_min * (beta - alpha).clamp(0.0, std::f64::consts::FRAC_PI_2).sin()
}

/// A bound on |H − interpolated H| over the pixels of a tile for one wave seen from `camera`
/// (module docs); +∞ where the tile must be exact (the clamp could act, the camera is at M).
pub fn tile_error_bound(w: &WaveParams, camera: DVec3, rays: &TileRays, depth: &TileDepth, tile: u32) -> f64 {
    let h = tile as f64;
    let centre_v = rays.v0 + (rays.vx + rays.vy) * (h / 2.0);
    let uc = centre_v.normalize();
    let alpha = [(0.0, 0.0), (h, 0.0), (0.0, h), (h, h)]
        .iter()
        .map(|&(x, y)| 2.0 * ((rays.ray(x, y) - uc).length() / 2.0).min(1.0).asin())
        .fold(0.0, f64::max);
    let vmin = centre_v.length() - h / 2.0 * (rays.vx.length() + rays.vy.length());
    if !(vmin > 0.0) {
        return f64::INFINITY;
    }
    let theta1 = [rays.vx.length() / vmin, rays.vy.length() / vmin];
    let theta2 = theta1.map(|t| 2.0 / 3f64.sqrt() * t * t);
    let c = depth.corners;
    let l = c.iter().copied().fold(0.0, f64::max).min(super::MAX_LENGTH);
    let slope =
        [(c[1] - c[0]).abs().max((c[3] - c[2]).abs()) / h, (c[2] - c[0]).abs().max((c[3] - c[1]).abs()) / h];

    let m = w.origin - camera;
    let rho_m = m.length();
    if !(rho_m > 0.0) {
        return f64::INFINITY;
    }
    let finite = w.length.is_finite();
    let t = w.origin + w.direction * w.length;
    let rho_t = if finite { (t - camera).length() } else { f64::INFINITY };
    // The camera's projection onto the beam's axis: q₀ = (O − M)·D.
    let q0 = -m.dot(w.direction);
    let axis = w.direction.cross(-m).length();
    let rho_line_min = if q0 >= 0.0 && (!finite || q0 <= w.length) { axis } else { rho_m.min(rho_t) };
    let end_dir = if finite { (t - camera).normalize() } else { w.direction };
    let line_profiles = [
        Some(Profile::radial(rho_line_min, rho_m.max(rho_t))),
        Profile::axis(w.direction.cross(-m), w.direction.cross(uc), alpha),
    ];
    let terms = [
        Term {
            strength: w.a,
            d: cone_distance(rho_m, angle(uc, m), alpha),
            profiles: vec![Profile::radial(rho_m, rho_m)],
        },
        Term {
            strength: w.b,
            d: cone_distance(rho_line_min, angle_to_arc(uc, m / rho_m, end_dir), alpha),
            profiles: line_profiles.into_iter().flatten().collect(),
        },
    ];
    // The clamp acts nowhere on the tile's rays when d² + ε² ≥ F², F = 2⁻²⁰·S (2⁻¹⁹ for margin).
    let s_bound = rho_m + if finite { w.length } else { 0.0 } + l;
    let clamp2 = (2f64.powi(-19) * s_bound).max(super::CLAMP_MIN).powi(2);
    let (mut gxx, mut gyy, mut e_max) = (0.0, 0.0, 0.0);
    for term in terms.iter().filter(|t| t.strength > 0.0) {
        let b = term_bounds(term, w.core, l);
        if !(b.d2 >= clamp2) {
            return f64::INFINITY;
        }
        let axis = |i: usize| {
            theta1[i] * theta1[i] * b.hessian
                + theta2[i] * b.gradient
                + (2.0 * l * slope[i] * theta1[i] + slope[i] * slope[i]) * b.end
        };
        gxx += term.strength * axis(0);
        gyy += term.strength * axis(1);
        e_max += term.strength * b.value;
    }
    let bound = h * h / 8.0 * (gxx + gyy) + depth.deviation * e_max;
    if bound.is_nan() {
        f64::INFINITY
    } else {
        bound
    }
}

/// Whether a tile whose corners' H (per wave) are `corner_h` may be interpolated at tolerance τ:
/// every wave's bound ≤ τ/(1 + τ)·min(corner H).
pub fn interpolates(bound: f64, corner_h: [f64; 4], tolerance: f64) -> bool {
    let h_min = corner_h.iter().copied().fold(f64::INFINITY, f64::min);
    tolerance > 0.0 && bound <= tolerance / (1.0 + tolerance) * h_min
}

#[cfg(test)]
mod tests;
