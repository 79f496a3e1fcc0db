//! `mb_clip_stream` of shaders/common/metaballs.glsl in f32, line by line: Bézier clipping over the
//! ray's chords gathered from the ball list, for rays with more supports on one point than the
//! slots hold. The rounds, the windows and why they end are in the shader's comments.

use std::cmp::Ordering;

use glam::Vec3;

use super::{
    mb_chord_a, mb_delta, mb_first_root, mb_kernel, mb_kernel_deriv, mb_shallow_root, v3, GpuMetaBall,
    GpuMetaGroup, MetaHitF32, MetaRay, MB_ALPHA_TOL, MB_EPS, MB_FLAT_C, MB_KERNEL_WYVILL6, MB_NOT_CONVERGED,
};

/// `MB_STREAM_WALKS`: walks per chord end a streamed cast may spend.
pub const MB_STREAM_WALKS: u32 = 300;
/// `MB_CACHE_BALLS`: the chords a streamed cast keeps per round.
pub const MB_CACHE_BALLS: usize = 128;

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

/// `mb_piece_bernstein`: q·f over the part [t0, t1] of the chord `ct` that holds it, as Bernstein
/// coefficients, from the product form 1 − r′ = 4a·(t − entry)(exit − t)/chord².
fn mb_piece_bernstein(kernel: u32, ct: [f32; 2], a: f32, q: f32, t0: f32, t1: f32) -> [f32; 7] {
    const W6_M0: f32 = 5.0 / 9.0;
    const W6_M1: f32 = 4.0 / 9.0;
    const THIRD: f32 = 1.0 / 3.0;
    const TWO_THIRDS: f32 = 2.0 / 3.0;
    const FIFTEENTH: f32 = 1.0 / 15.0;
    const EIGHT_15THS: f32 = 8.0 / 15.0;
    let inv = 1.0 / (ct[1] - ct[0]);
    let (u0, u1) = ((t0 - ct[0]) * inv, (t1 - ct[0]) * inv);
    let (v0, v1) = ((ct[1] - t0) * inv, (ct[1] - t1) * inv);
    let a4 = 4.0 * a;
    let p0 = a4 * (u0 * v0);
    let p1 = a4 * (0.5 * (u0 * v1 + u1 * v0));
    let p2 = a4 * (u1 * v1);
    let (s0, s1, s2, s3, s4) = (p0 * p0, p0 * p1, (p0 * p2 + 2.0 * (p1 * p1)) * THIRD, p1 * p2, p2 * p2);
    let m = |p: f32| q * if kernel == MB_KERNEL_WYVILL6 { W6_M0 + W6_M1 * p } else { 1.0 };
    let (m0, m1, m2) = (m(p0), m(p1), m(p2));
    [
        s0 * m0,
        (s1 * m0) * TWO_THIRDS + (s0 * m1) * THIRD,
        (s2 * m0) * 0.4 + (s1 * m1) * EIGHT_15THS + (s0 * m2) * FIFTEENTH,
        (s3 * m0) * 0.2 + (s2 * m1) * 0.6 + (s1 * m2) * 0.2,
        (s4 * m0) * FIFTEENTH + (s3 * m1) * EIGHT_15THS + (s2 * m2) * 0.4,
        (s4 * m1) * THIRD + (s3 * m2) * TWO_THIRDS,
        s4 * m2,
    ]
}

/// A chord the windows walk: a cache slot (`mb_cache_chord`, `mb_cache_meta`), or a ball of the
/// list with its chord computed again.
#[derive(Clone, Copy)]
struct Chord {
    ct: [f32; 2],
    a: f32,
    q: f32,
    g_term: f32,
    id: u32,
}

/// The chords of the list's balls that the ray crosses, in list order: what the walks over the
/// whole list see (the shader's sorted walks only leave out balls that cannot meet the window, so
/// that changes the cost, not the sums).
fn list_chords(balls: &[GpuMetaBall], list: &[u32], r: &MetaRay) -> Vec<Chord> {
    list.iter()
        .filter_map(|&id| {
            let ball = &balls[id as usize];
            let (ct, a) = mb_ball_chord(ball, r)?;
            Some(Chord { ct, a, q: ball.coeffs[0], g_term: ball.coeffs[2], id })
        })
        .collect()
}

/// The gather (`mb_cache_gather` over the list): the first [`MB_CACHE_BALLS`] chords meeting
/// [t_cur, limit), in list order, and `limit`: the entry of the first one left out.
fn gather(balls: &[GpuMetaBall], list: &[u32], r: &MetaRay, t_cur: f32, t_end: f32) -> (Vec<Chord>, f32) {
    let mut cache = Vec::with_capacity(MB_CACHE_BALLS);
    let mut limit = t_end;
    for chord in list_chords(balls, list, r) {
        if chord.ct[1] > t_cur && chord.ct[0] < limit {
            if cache.len() < MB_CACHE_BALLS {
                cache.push(chord);
            } else {
                limit = limit.min(chord.ct[0]);
            }
        }
    }
    (cache, limit)
}

/// `MB_CLIP_WINDOWS`: Bézier clipping by windows over `chords` from t_cur to t_end; the root's t′,
/// or None (with `MB_NOT_CONVERGED` in `hit` when the walks ran out). `count`: what the shader's
/// guard counts (the cache's chords, or the whole list's balls).
fn clip_windows(
    g: &GpuMetaGroup,
    chords: &[Chord],
    count: usize,
    r: &MetaRay,
    t_cur: &mut f32,
    t_end: f32,
    hit: &mut MetaHitF32,
) -> Option<f32> {
    let kernel = g.info[0];
    let tt = g.params[0];
    let x = r.o.length();
    let mut t_hi = t_end;
    let mut walks = 0u32;
    let max_walks = MB_STREAM_WALKS * (2 * (count.min(1 << 20) as u32) + 1);
    while *t_cur < t_end {
        if walks >= max_walks {
            hit.flags |= MB_NOT_CONVERGED;
            return None;
        }
        walks += 1;
        // Walk 1 (mb_bound_step): the next chord end and the field bound over the window.
        let mut t_next = t_end;
        let mut bound = 0.0f32;
        for ch in chords {
            let ct = ch.ct;
            if !(ct[1] > *t_cur && ct[0] < t_hi) {
                continue;
            }
            t_next = t_next.min(if ct[0] > *t_cur { ct[0] } else { ct[1] });
            let half_chord = 0.5 * (ct[1] - ct[0]);
            let mid = ct[0] + half_chord;
            let s0 = (t_cur.max(ct[0]) - mid) / half_chord;
            let s1 = (t_hi.min(ct[1]) - mid) / half_chord;
            let s2 = if s0 <= 0.0 && s1 >= 0.0 { 0.0 } else { (s0 * s0).min(s1 * s1) };
            bound += ch.q.max(0.0) * mb_kernel(kernel, 1.0 - ch.a * (1.0 - s2));
        }
        // mb_window_skip
        let window = t_hi - *t_cur;
        if bound < tt - mb_delta(bound + tt, x + t_hi, 0.0) {
            *t_cur = t_hi;
            t_hi = (*t_cur + 2.0 * window).min(t_end);
            continue;
        }
        t_hi = t_hi.min(t_next);
        // Walk 2 (mb_piece_step): the piece's coefficients.
        let mut c = [-tt; 7];
        let mut scale = [0.0f32; 7];
        let mut gsum = 0.0f32;
        for ch in chords {
            let ct = ch.ct;
            if !(ct[0] <= *t_cur && ct[1] > *t_cur) {
                continue;
            }
            let dj = mb_piece_bernstein(kernel, ct, ch.a, ch.q, *t_cur, t_hi);
            for k in 0..7 {
                c[k] += dj[k];
                scale[k] += dj[k].abs();
            }
            gsum += ch.g_term;
        }
        // mb_piece_clip
        let s = scale.iter().fold(0.0f32, |m, &v| m.max(v));
        let delta = mb_delta(s + tt, x + t_hi, gsum);
        let tol = g.params[1];
        let alpha_tol = if tol > 0.0 { MB_ALPHA_TOL.max(tol * r.ts / (t_hi - *t_cur)) } else { MB_ALPHA_TOL };
        let floor = MB_FLAT_C * MB_EPS * (s + tt);
        let mut steps = 0u32;
        let alpha = mb_first_root(&c, floor, delta, alpha_tol, &mut steps, &mut hit.flags);
        hit.iterations += steps;
        if hit.flags & MB_NOT_CONVERGED != 0 {
            return None;
        }
        if alpha >= 0.0 {
            if mb_shallow_root(&c, alpha, delta) {
                hit.flags |= super::MB_TANGENT;
            }
            return Some(*t_cur + alpha * (t_hi - *t_cur));
        }
        let width = (t_hi - *t_cur).max(0.125 * window);
        *t_cur = t_hi;
        t_hi = (*t_cur + 2.0 * width).min(t_end);
    }
    None
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
    let mut t_cur = t0;
    // Rounds over the cache; where more than MB_CACHE_BALLS chords contain t_cur, the rest by
    // windows over the whole list. `cached`: the chords of the round that found the root.
    let (found, cached) = loop {
        let (chords, limit) = gather(balls, list, r, t_cur, t_end);
        // The shader's `!(limit > t_cur)`, NaN included.
        if limit.partial_cmp(&t_cur) != Some(Ordering::Greater) {
            break (
                clip_windows(g, &list_chords(balls, list, r), list.len(), r, &mut t_cur, t_end, &mut hit),
                None,
            );
        }
        let found = clip_windows(g, &chords, chords.len(), r, &mut t_cur, limit, &mut hit);
        if found.is_some() || hit.flags & MB_NOT_CONVERGED != 0 {
            break (found, Some(chords));
        }
        t_cur = limit;
        if t_cur.partial_cmp(&t_end) != Some(Ordering::Less) {
            break (None, None);
        }
    };
    if hit.flags & MB_NOT_CONVERGED != 0 {
        return hit;
    }
    let Some(t_found) = found else { return hit };
    // The normal: ∇F over the round's cached balls when the cache found it (every ball containing
    // the point is there), else over the whole list (the others add nothing).
    let p = r.o + r.d * t_found;
    let ids: Vec<u32> = match cached {
        Some(chords) => chords.iter().map(|c| c.id).collect(),
        None => list.to_vec(),
    };
    let mut grad = Vec3::ZERO;
    for id in ids {
        let ball = &balls[id as usize];
        let w = p - v3(ball.centre_radius);
        let inv_r2 = 1.0 / (ball.centre_radius[3] * ball.centre_radius[3]);
        grad += w * (2.0 * ball.coeffs[0] * inv_r2 * mb_kernel_deriv(kernel, w.dot(w) * inv_r2));
    }
    super::finish_grad(&mut hit, g, r, dir, grad, t_found);
    hit
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::metaballs_f32::{gpu_balls, PackedGroup};
    use crate::testing::{crowded_metaballs, crowded_tube, Rng};
    use glam::DVec3;

    /// `mb_piece_bernstein` against q·f(r′) in f64 from the same f32 inputs, on parts anywhere in
    /// the chord (touching either end, tiny, the whole chord), both kernels, q of either sign.
    /// Every coefficient is a sum of products of non-negative factors (times q), ≤ 12 roundings
    /// deep, so the polynomial is within 12ε·max|d_k| of the exact one; the bound asserted is
    /// 16ε·max|d_k| (plus the f64 evaluation's own, negligible).
    #[test]
    fn piece_coefficients_match_f64() {
        let mut rng = Rng(11);
        let kernel_f64 = |kernel: u32, rp: f64| {
            if kernel == MB_KERNEL_WYVILL6 {
                (1.0 - rp).powi(2) * (1.0 - 4.0 / 9.0 * rp)
            } else {
                (1.0 - rp).powi(2)
            }
        };
        let mut worst = 0.0f64;
        for case in 0..4000 {
            let kernel = (case % 2) as u32;
            let en = rng.range(-50.0, 50.0) as f32;
            let chord = rng.range(1e-3, 10.0) as f32;
            let ex = en + chord;
            let a = rng.range(1e-4, 1.0) as f32;
            let q = rng.range(-2.0, 2.0) as f32;
            let (mut t0, mut t1) = (rng.range(0.0, 1.0), rng.range(0.0, 1.0));
            match case % 5 {
                0 => t0 = 0.0,
                1 => t1 = 1.0,
                2 => t1 = t0 + 1e-4,
                3 => (t0, t1) = (0.0, 1.0),
                _ => {}
            }
            let (lo, hi) = (t0.min(t1), t0.max(t1).min(1.0));
            let (t0, t1) = (en + (lo as f32) * (ex - en), en + (hi as f32) * (ex - en));
            if !(en <= t0 && t0 <= t1 && t1 <= ex) {
                continue;
            }
            let d = mb_piece_bernstein(kernel, [en, ex], a, q, t0, t1);
            let scale = d.iter().fold(0.0f64, |m, &v| m.max(f64::from(v).abs()));
            for k in 0..=8 {
                let u = k as f64 / 8.0;
                let t = f64::from(t0) + u * (f64::from(t1) - f64::from(t0));
                let (en, ex, c) = (f64::from(en), f64::from(ex), f64::from(ex) - f64::from(en));
                let rp = 1.0 - 4.0 * f64::from(a) * (t - en) * (ex - t) / (c * c);
                let exact = f64::from(q) * kernel_f64(kernel, rp);
                let binom = [1.0, 6.0, 15.0, 20.0, 15.0, 6.0, 1.0];
                let poly: f64 = (0..7)
                    .map(|i| binom[i] * u.powi(i as i32) * (1.0 - u).powi(6 - i as i32) * f64::from(d[i]))
                    .sum();
                let err = (poly - exact).abs() / (f64::from(f32::EPSILON) * scale.max(f64::MIN_POSITIVE));
                worst = worst.max(if scale == 0.0 { 0.0 } else { err });
            }
        }
        assert!(worst <= 16.0, "worst error {worst} ε·max|d|");
    }

    /// The object-space ray from +z through the middle of a crowd (as the tests' rays go).
    fn ray_through(g: &crate::effects::metaballs::MetaballGroupParams) -> MetaRay {
        let ray = g.transform.ray_to_object(
            g.transform.transform_point(DVec3::new(0.0, 0.0, 10.0)),
            g.transform.transform_point(DVec3::new(0.05, -0.05, -1.35))
                - g.transform.transform_point(DVec3::new(0.0, 0.0, 10.0)),
        );
        MetaRay { o: ray.origin.as_vec3(), d: ray.dir.as_vec3(), ts: ray.t_scale as f32 }
    }

    /// The crowds the tests cast do take each way through `clip_stream`: a crowd of 150 puts more
    /// chords than the cache holds on one point (the rest of the ray walks the whole list), a tube
    /// of 300 fills the cache with chords met one after another (several rounds), a crowd of 48
    /// fits in one round.
    #[test]
    fn the_test_crowds_take_every_path() {
        let mut rng = Rng(7);
        let rounds = |g: &crate::effects::metaballs::MetaballGroupParams| {
            let balls = gpu_balls(g);
            let list: Vec<u32> = (0..balls.len() as u32).collect();
            let r = ray_through(g);
            let (mut t_cur, mut rounds) = (0.1 * r.ts, 0);
            loop {
                let (chords, limit) = gather(&balls, &list, &r, t_cur, 100.0 * r.ts);
                rounds += 1;
                if limit <= t_cur {
                    return (rounds, true);
                }
                if limit >= 100.0 * r.ts {
                    return (rounds, false);
                }
                assert_eq!(chords.len(), MB_CACHE_BALLS);
                t_cur = limit;
            }
        };
        assert_eq!(rounds(&crowded_metaballs(&mut rng, 48)), (1, false));
        assert!(rounds(&crowded_metaballs(&mut rng, 150)).1, "150 on a point: past the cache");
        let (n, past) = rounds(&crowded_tube(&mut rng, 300));
        assert!(n >= 2 && !past, "the tube: {n} rounds");
        // And the twin's whole cast goes through the rounds to the surface behind the tube.
        let g = crowded_tube(&mut rng, 300);
        let eye = g.transform.transform_point(DVec3::new(0.0, 0.0, 10.0));
        let target = g.transform.transform_point(DVec3::new(0.05, -0.05, -1.35));
        let hit = PackedGroup::new(&g).cast(eye, (target - eye).normalize(), 0.1, 100.0);
        assert!(hit.hit() && hit.flags & super::super::MB_STREAMED != 0, "{hit:?}");
    }
}
