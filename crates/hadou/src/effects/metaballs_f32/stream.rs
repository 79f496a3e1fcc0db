//! `mb_clip_stream` of shaders/common/metaballs.glsl in f32, line by line: Bézier clipping read
//! straight from the ball list, for rays with more supports on one point than the slots hold.
//! The window logic and why it ends are in the shader's comment.

use glam::Vec3;

use super::{
    mb_chord_a, mb_chord_bernstein, mb_delta, mb_first_root, mb_kernel, mb_kernel_deriv, mb_restrict,
    mb_shallow_root, v3, GpuMetaBall, GpuMetaGroup, MetaHitF32, MetaRay, MB_ALPHA_TOL, MB_EPS, MB_FLAT_C,
    MB_NOT_CONVERGED,
};

/// `MB_STREAM_WALKS`: walks per chord end a streamed cast may spend.
pub const MB_STREAM_WALKS: u32 = 300;

/// `mb_ball_chord`: the support chord [en, ex] and a = D/R², or None when the ray misses it.
fn mb_ball_chord(ball: &GpuMetaBall, r: &MetaRay) -> Option<([f32; 2], f32)> {
    let w = v3(ball.centre_radius) - r.o;
    let tc = w.dot(r.d);
    let cr = w.cross(r.d);
    let h2 = cr.dot(cr);
    let radius = ball.centre_radius[3];
    let dd = radius * radius - h2;
    let half_chord = dd.max(0.0).sqrt();
    let ct = [tc - half_chord, tc + half_chord];
    let a = mb_chord_a(ct, radius);
    (dd > 0.0).then_some((ct, a))
}

/// The list's balls in order (the twin reads the whole list: `MB_LIST_SORTED` only skips balls
/// that cannot meet the window, so it changes the cost, not the answer).
fn walk<'a>(balls: &'a [GpuMetaBall], list: &'a [u32]) -> impl Iterator<Item = &'a GpuMetaBall> + 'a {
    list.iter().map(move |&id| &balls[id as usize])
}

/// `mb_clip_stream`: the first crossing of F = T with t′ ∈ [t0, t_end] over every ball of `list`.
#[allow(clippy::too_many_arguments)]
pub(super) fn clip_stream(
    g: &GpuMetaGroup,
    balls: &[GpuMetaBall],
    list: &[u32],
    r: &MetaRay,
    dir: Vec3,
    t0: f32,
    t_end: f32,
    mut hit: MetaHitF32,
) -> MetaHitF32 {
    let kernel = g.info[0];
    let tt = g.params[0];
    let x = r.o.length();
    let (mut t_cur, mut t_hi) = (t0, t_end);
    let mut walks = 0u32;
    let max_walks = MB_STREAM_WALKS * (2 * (list.len() as u32).min(1 << 20) + 1);
    let mut found = None;
    while found.is_none() && t_cur < t_end {
        if walks >= max_walks {
            hit.flags |= MB_NOT_CONVERGED;
            return hit;
        }
        walks += 1;
        let mut t_next = t_end;
        let mut bound = 0.0f32;
        for ball in walk(balls, list) {
            let Some((ct, a)) = mb_ball_chord(ball, r) else { continue };
            if !(ct[1] > t_cur && ct[0] < t_hi) {
                continue;
            }
            t_next = t_next.min(if ct[0] > t_cur { ct[0] } else { ct[1] });
            let half_chord = 0.5 * (ct[1] - ct[0]);
            let mid = ct[0] + half_chord;
            let s0 = (t_cur.max(ct[0]) - mid) / half_chord;
            let s1 = (t_hi.min(ct[1]) - mid) / half_chord;
            let s2 = if s0 <= 0.0 && s1 >= 0.0 { 0.0 } else { (s0 * s0).min(s1 * s1) };
            bound += ball.coeffs[0].max(0.0) * mb_kernel(kernel, 1.0 - a * (1.0 - s2));
        }
        if bound < tt - mb_delta(bound + tt, x + t_hi, 0.0) {
            let width = t_hi - t_cur;
            t_cur = t_hi;
            t_hi = (t_cur + 2.0 * width).min(t_end);
            continue;
        }
        t_hi = t_hi.min(t_next);
        let mut c = [-tt; 7];
        let mut scale = [0.0f32; 7];
        let mut gsum = 0.0f32;
        for ball in walk(balls, list) {
            let Some((ct, a)) = mb_ball_chord(ball, r) else { continue };
            if !(ct[0] <= t_cur && ct[1] > t_cur) {
                continue;
            }
            let chord = ct[1] - ct[0];
            let mut dj = [0.0f32; 7];
            mb_chord_bernstein(kernel, a, ball.coeffs[0], &mut dj);
            mb_restrict(
                &mut dj,
                ((t_cur - ct[0]) / chord).clamp(0.0, 1.0),
                ((t_hi - ct[0]) / chord).clamp(0.0, 1.0),
            );
            for k in 0..7 {
                c[k] += dj[k];
                scale[k] += dj[k].abs();
            }
            gsum += ball.coeffs[2];
        }
        let s = scale.iter().fold(0.0f32, |m, &v| m.max(v));
        let delta = mb_delta(s + tt, x + t_hi, gsum);
        let tol = g.params[1];
        let alpha_tol = if tol > 0.0 { MB_ALPHA_TOL.max(tol * r.ts / (t_hi - t_cur)) } else { MB_ALPHA_TOL };
        let floor = MB_FLAT_C * MB_EPS * (s + tt);
        let mut steps = 0u32;
        let alpha = mb_first_root(&c, floor, delta, alpha_tol, &mut steps, &mut hit.flags);
        hit.iterations += steps;
        if hit.flags & MB_NOT_CONVERGED != 0 {
            return hit;
        }
        if alpha >= 0.0 {
            if mb_shallow_root(&c, alpha, delta) {
                hit.flags |= super::MB_TANGENT;
            }
            found = Some(t_cur + alpha * (t_hi - t_cur));
        } else {
            let width = t_hi - t_cur;
            t_cur = t_hi;
            t_hi = (t_cur + 2.0 * width).min(t_end);
        }
    }
    let Some(t_found) = found else { return hit };
    let p = r.o + r.d * t_found;
    let mut grad = Vec3::ZERO;
    for ball in walk(balls, list) {
        let w = p - v3(ball.centre_radius);
        let inv_r2 = 1.0 / (ball.centre_radius[3] * ball.centre_radius[3]);
        grad += w * (2.0 * ball.coeffs[0] * inv_r2 * mb_kernel_deriv(kernel, w.dot(w) * inv_r2));
    }
    super::finish_grad(&mut hit, g, r, dir, grad, t_found);
    hit
}
