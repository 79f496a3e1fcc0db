//! The f32 error model of a metaball cast (`metaballs_f32` module docs) as a bound per ray, shared
//! by the pass's test (tests/gpu_metaballs.rs) and the shader's cast against its twin
//! (tests/metaballs_gpu.rs).

use glam::{DMat3, DVec3};
use hadou::effects::metaballs::{gradient, Kernel, MetaballGroupParams};
use hadou::effects::metaballs_f32::{anchor, BAND_C};

/// How far an f32 cast may lie from the exact hit of `g` at world distance `t` on a ray outside
/// the tangency band: (relative depth, normal angle in radians), from the f32 error model of the
/// band (`metaballs_f32` module docs). In object space (t′ = t·t_scale, unit direction), over the
/// balls whose support holds the hit (R_max the largest radius):
/// - g = F − T is evaluated to within δ = BAND_C·ε·(S + X·G), with S ≤ T + Σ|q|·B (B the largest
///   chord Bernstein coefficient: 104/45 for wyvill6, 8/5 for murakami4; restricting a chord only
///   averages them), X ≤ ‖o′ − a‖ + t′ + 2R_max (a: the group's anchor, where the GPU's
///   positions are measured from) and G = Σ|q|γ/R. Outside the band the root is simple
///   and no extremum comes within δ of zero, so δ moves it by at most δ/|g′(t′)|;
/// - the clipping answers the middle of a bracket ≤ 2⁻²² of an interval that lies in one support
///   chord (≤ 2R_max): 2⁻²²·R_max more; `extra` (object units) is a method's own term;
/// - t = t′/t_scale, in f32 and stored: 4ε relative.
///
/// The normal ∝ −∇F at the f32 hit: the offset Δt′ above turns it by ≤ ‖∇²F‖·Δt′/‖∇F‖ (the
/// Hessian's Frobenius norm at the hit, twice for its change over Δt′); ∇F in f32 sums terms of
/// size ≤ G (BAND_C·ε·G) at a position rounded to ε·X per coordinate (2ε·X·‖∇²F‖); M⁻ᵀ into the
/// world turns an angle by at most cond(M); normalising adds 2ε.
pub fn f32_bound(g: &MetaballGroupParams, o: DVec3, d: DVec3, t: f64, extra: f64) -> (f64, f64) {
    let eps = f64::from(f32::EPSILON);
    let ray = g.transform.ray_to_object(o, d);
    let tp = t * ray.t_scale;
    let p = ray.origin + ray.dir * tp;
    let b_max = match g.kernel {
        Kernel::Wyvill6 => 104.0 / 45.0,
        Kernel::Murakami4 => 1.6,
    };
    let gamma = g.kernel.max_slope();
    let (mut s, mut gs, mut r_max) = (g.threshold, 0.0, 0.0);
    let mut hessian = DMat3::ZERO;
    for b in g.balls.iter().filter(|b| (p - b.centre).length() < b.radius) {
        s += b.q.abs() * b_max;
        gs += b.q.abs() * gamma / b.radius;
        if b.radius > r_max {
            r_max = b.radius;
        }
        // ∇²(q·f(‖x‖²/R²)) = q·(2f′(s)·I/R² + 4f″(s)·x xᵀ/R⁴).
        let (x, r2) = (p - b.centre, b.radius * b.radius);
        let rp = x.length_squared() / r2;
        let f2 = match g.kernel {
            Kernel::Wyvill6 => -8.0 / 3.0 * rp + 34.0 / 9.0,
            Kernel::Murakami4 => 2.0,
        };
        let outer = DMat3::from_cols(x * x.x, x * x.y, x * x.z);
        hessian += DMat3::from_diagonal(DVec3::splat(2.0 * b.q * g.kernel.df(rp) / r2))
            + outer * (4.0 * b.q * f2 / (r2 * r2));
    }
    let h = 2.0 * frobenius(hessian);
    // Positions as the f32 cast holds them: from the group's anchor (`gpu_group`).
    let x = (ray.origin - anchor(g)).length() + tp + 2.0 * r_max;
    let grad = gradient(g, p);
    let dt = BAND_C * eps * (s + x * gs) / grad.dot(ray.dir).abs() + 2f64.powi(-22) * r_max + extra;
    let normal = h * dt + BAND_C * eps * gs + 2.0 * eps * x * h;
    let m = DMat3::from_mat4(g.transform.matrix);
    (dt / tp + 4.0 * eps, condition(m) * normal / grad.length() + 2.0 * eps)
}

/// The angle between two vectors in radians, accurate near 0 (atan2 of |a × b| and a·b: acos
/// of a dot product near 1 loses half the digits).
pub fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

fn frobenius(m: DMat3) -> f64 {
    (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()).sqrt()
}

/// cond₂(M) = σ_max/σ_min, each by 64 power iterations on MᵀM (and on its inverse).
fn condition(m: DMat3) -> f64 {
    let sigma_max = |a: DMat3| {
        let ata = a.transpose() * a;
        let mut v = DVec3::new(0.6, 0.5, 0.62).normalize();
        for _ in 0..64 {
            v = (ata * v).normalize();
        }
        (ata * v).length().sqrt()
    };
    sigma_max(m) * sigma_max(m.inverse())
}
