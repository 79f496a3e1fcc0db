//! Metaballs: the f64 cast (seed 000's algorithm) against the independent root check on random
//! groups and rays, the hard cases one by one, and the f32 twin of the shader against f64 outside
//! the tangency band. Run with `--nocapture` to see the measured iteration counts and errors.

use glam::DVec3;
use hadou::effects::metaballs::{
    cast, cast_reference, field, gradient, iso_radius, Ball, Kernel, MetaHit, MetaballGroupParams,
};
use hadou::effects::metaballs_f32::{tangency, PackedGroup, MB_STREAMED};
use hadou::scene::transform::{Transform, TransformOp};
use hadou::testing::{Comparison, Rng};

fn ball(centre: DVec3, radius: f64, q: f64) -> Ball {
    Ball { centre, radius, q }
}

fn group(balls: Vec<Ball>) -> MetaballGroupParams {
    MetaballGroupParams {
        threshold: 0.5,
        kernel: Kernel::Wyvill6,
        balls,
        transform: Transform::IDENTITY,
        method: Default::default(),
    }
}

/// A random group: 2–9 balls in a box, some negative, either kernel, a random transform with a
/// non-uniform scale half of the time.
fn random_group(rng: &mut Rng) -> MetaballGroupParams {
    let n = 2 + (rng.next() * 8.0) as usize;
    let balls = (0..n)
        .map(|_| {
            let q = if rng.next() < 0.2 { rng.range(-1.2, -0.3) } else { rng.range(0.6, 2.0) };
            ball(rng.vec(-2.5, 2.5), rng.range(1.0, 3.0), q)
        })
        .collect();
    let mut ops = vec![TransformOp::Rotate { angle_deg: rng.range(0.0, 360.0), axis: rng.unit() }];
    if rng.next() < 0.5 {
        ops.insert(
            0,
            TransformOp::Scale(DVec3::new(rng.range(0.5, 2.0), rng.range(0.5, 2.0), rng.range(0.5, 2.0))),
        );
    }
    ops.push(TransformOp::Translate(rng.vec(-3.0, 3.0)));
    MetaballGroupParams {
        threshold: rng.range(0.3, 0.8),
        kernel: if rng.next() < 0.7 { Kernel::Wyvill6 } else { Kernel::Murakami4 },
        balls,
        transform: Transform::from_ops(&ops).unwrap(),
        method: Default::default(),
    }
}

/// A camera 8–25 units from the group's centre looking at a random point near it.
fn random_ray(rng: &mut Rng, g: &MetaballGroupParams) -> (DVec3, DVec3) {
    let centre = g.transform.transform_point(DVec3::ZERO);
    let origin = centre + rng.unit() * rng.range(8.0, 25.0);
    let target = centre + rng.vec(-4.0, 4.0);
    (origin, (target - origin).normalize())
}

/// The angle between two vectors, accurate near 0 (atan2 of |a × b| and a·b, not acos).
fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b)).to_degrees()
}

/// The hit satisfies F = T (independently of both root finders) and its normal is −∇F.
fn check_on_surface(g: &MetaballGroupParams, o: DVec3, d: DVec3, h: &MetaHit, tol: f64) {
    let ray = g.transform.ray_to_object(o, d);
    let p = ray.origin + ray.dir * (h.t * ray.t_scale);
    let f = field(g, p);
    assert!((f - g.threshold).abs() <= tol, "F = {f} at the hit, T = {}", g.threshold);
    let n = g.transform.transform_normal(-gradient(g, p));
    assert!(angle_deg(n, h.normal) < 1e-6, "normal {} vs −∇F {n}", h.normal);
}

#[test]
fn cast_matches_the_independent_root_check() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut hits, mut misses, mut skipped, mut flat) = (0usize, 0usize, 0usize, 0usize);
    // Both f64 and independent: t to 1e-9 relative, far above the clipping's 2⁻⁴⁴ of a piece and
    // the reference's bisection to adjacent floats; near a double root f64 noise (~1e-16) moves
    // the root by ~1e-16/|g′| with |g′| ≳ √margin ≥ 3e-5 here: 3e-12. Normals to 1e-5°: both
    // −∇F at points ≤ 1e-9 apart.
    let mut t_err = Comparison::new("cast vs cast_reference: relative t");
    let mut n_err = Comparison::new("cast vs cast_reference: normal, degrees");
    let mut iters: Vec<u32> = Vec::new();
    for _ in 0..400 {
        let g = random_group(&mut rng);
        for _ in 0..50 {
            let (o, d) = random_ray(&mut rng, &g);
            // A double root moves by √(noise): compare only rays that do not nearly touch T.
            if tangency(&g, o, d, 0.0, 100.0).margin <= 1e-9 {
                skipped += 1;
                continue;
            }
            let a = cast(&g, o, d, 0.0, 100.0);
            let b = cast_reference(&g, o, d, 0.0, 100.0);
            match (a, b) {
                (Some(a), Some(b)) => {
                    hits += 1;
                    let at = format_args!("{o} {d}: t = {} vs reference {}", a.t, b.t);
                    t_err.rel(at, a.t, b.t);
                    n_err.error(at, angle_deg(a.normal, b.normal));
                    if a.iterations > 0 {
                        iters.push(a.iterations);
                    }
                    flat += usize::from(a.flat_root);
                }
                (None, None) => misses += 1,
                _ => panic!("hit/miss disagree: cast {a:?}, reference {b:?}\n{g:?}\n{o} {d}"),
            }
        }
    }
    let mean = iters.iter().map(|&i| i as f64).sum::<f64>() / iters.len() as f64;
    println!(
        "f64 cast vs reference: {hits} hits ({flat} ended on the noise floor), {misses} misses, {skipped} \
         near-tangent skipped; Bézier clipping on {} hits: mean {mean:.2}, max {} iterations",
        iters.len(),
        iters.iter().copied().fold(0, u32::max)
    );
    assert!(misses > 1000, "{misses} misses: the sample should have both");
    t_err.assert_within(1e-9, 3000);
    n_err.assert_within(1e-5, 3000);
}

/// The f32 twin against f64 on 20,000 random rays: outside the tangency band hit/miss agree and
/// depths agree to 1e-4 relative, normals to 0.5° (the band's contract, `metaballs_f32` module
/// docs), on at least 19,800 rays and 4,000 hits; the band may take at most 1% of the rays.
#[test]
fn f32_twin_matches_f64_outside_the_tangency_band() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let (mut band_disagree, mut flagged) = (0usize, 0usize);
    let mut agree =
        Comparison::new("f32 vs f64 outside the band: hit/miss or depth beyond 1e-4 (1 = differ)");
    let mut depth = Comparison::new("f32 vs f64 outside the band: relative depth");
    let mut normal = Comparison::new("f32 vs f64 outside the band: normal, degrees");
    let mut iters: Vec<u32> = Vec::new();
    for gi in 0..400 {
        let g = random_group(&mut rng);
        let packed = PackedGroup::new(&g);
        for k in 0..50 {
            let (o, d) = random_ray(&mut rng, &g);
            let t_min = rng.range(0.0, 1.0);
            let a = cast(&g, o, d, t_min, 100.0);
            let b = packed.cast(o, d, t_min, 100.0);
            let band = tangency(&g, o, d, t_min, 100.0);
            let same = match a {
                Some(a) => b.hit() && (f64::from(b.t) - a.t).abs() <= 1e-4 * a.t,
                None => !b.hit(),
            };
            if b.tangent() {
                flagged += 1;
            }
            if band.in_band() {
                agree.exclude();
                band_disagree += usize::from(!same);
                continue;
            }
            let at = format_args!("group {gi} ray {k} (margin {:e}): f64 {a:?} vs f32 {b:?}", band.margin);
            agree.error(at, f64::from(u8::from(!same)));
            assert_eq!(b.flags & MB_STREAMED, 0);
            if let (Some(a), true) = (a, b.hit()) {
                depth.rel(at, f64::from(b.t), a.t);
                normal.error(at, angle_deg(a.normal, b.normal.as_dvec3()));
                if b.iterations > 0 {
                    iters.push(b.iterations);
                }
            }
        }
    }
    let mean = iters.iter().map(|&i| i as f64).sum::<f64>() / iters.len() as f64;
    println!(
        "f32 vs f64: {} in the band ({band_disagree} of them differ); {flagged} flagged MB_TANGENT by the f32 \
         cast; f32 Bézier clipping on {} hits: mean {mean:.2}, max {} iterations",
        agree.excluded(),
        iters.len(),
        iters.iter().copied().fold(0, u32::max)
    );
    // A random ray is in the band when it passes within ~δ/‖∇F‖ ≈ 10⁻⁵ units of grazing the
    // surface: a chance of that order per ray aimed into a ±4-unit box (3 of 20,000 when
    // written); 1% is a thousand times more and still leaves 19,800 rays compared.
    agree.assert_excluded_at_most(0.01);
    agree.assert_within(0.0, 19_800);
    // A quarter of the rays hit (~5,000 when written).
    depth.assert_within(1e-4, 4000);
    normal.assert_within(0.5, 4000);
}

/// Seed 000: one ball with q = 1, T = 0.5 has its surface at R/2; general q and T at ρ*·R.
#[test]
fn single_ball_radius() {
    let o = DVec3::new(0.0, 0.0, 10.0);
    for kernel in [Kernel::Wyvill6, Kernel::Murakami4] {
        for (q, t, r) in [(1.0, 0.5, 2.0), (2.0, 0.5, 2.0), (1.0, 0.1, 3.0), (3.0, 2.0, 1.5)] {
            let mut g = group(vec![ball(DVec3::ZERO, r, q)]);
            g.kernel = kernel;
            g.threshold = t;
            let rho = iso_radius(kernel, q, t).unwrap();
            if kernel == Kernel::Wyvill6 && q == 1.0 && t == 0.5 {
                assert!((rho - 0.5).abs() <= 2e-16, "{rho}");
            }
            let h = cast(&g, o, -DVec3::Z, 0.0, 100.0).unwrap();
            assert!(
                (h.t - (10.0 - rho * r)).abs() < 1e-13,
                "{kernel:?} q={q} T={t}: {} vs {}",
                h.t,
                10.0 - rho * r
            );
            assert_eq!(h.iterations, 0, "the lone-ball path needs no clipping");
            check_on_surface(&g, o, -DVec3::Z, &h, 1e-13);
            let f = PackedGroup::new(&g).cast(o, -DVec3::Z, 0.0, 100.0);
            assert!(f.hit() && (f64::from(f.t) - h.t).abs() < 1e-6 * h.t);
        }
    }
    // q ≤ T: a lone ball has no surface.
    assert!(cast(&group(vec![ball(DVec3::ZERO, 2.0, 0.5)]), o, -DVec3::Z, 0.0, 100.0).is_none());
}

/// Tangent rays: a double root of the two-ball blend (both balls active, the Bézier path) and of
/// a lone ball's sphere.
#[test]
fn tangent_rays() {
    // Two unequal balls; rays along −z at x = 0.1. For each height y the field along the ray peaks
    // where ∂F/∂z = 0 (bisection on the gradient); y* puts that peak exactly at T, so the ray at
    // y* touches the surface at z*: a double root at t = 10 − z*.
    let g =
        group(vec![ball(DVec3::new(-1.0, 0.0, 0.3), 2.0, 1.0), ball(DVec3::new(1.2, 0.0, -0.4), 1.7, 0.9)]);
    let x = 0.1;
    let peak = |y: f64| {
        let (mut lo, mut hi) = (-1.0f64, 1.0f64);
        for _ in 0..200 {
            let m = 0.5 * (lo + hi);
            if gradient(&g, DVec3::new(x, y, m)).z > 0.0 {
                lo = m;
            } else {
                hi = m;
            }
        }
        0.5 * (lo + hi)
    };
    let (mut lo, mut hi) = (0.0f64, 2.0f64);
    for _ in 0..200 {
        let m = 0.5 * (lo + hi);
        if field(&g, DVec3::new(x, m, peak(m))) > 0.5 {
            lo = m;
        } else {
            hi = m;
        }
    }
    let y = 0.5 * (lo + hi);
    let z = peak(y);
    let t_exact = 10.0 - z;
    let o = DVec3::new(x, y, 10.0);
    let h = cast(&g, o, -DVec3::Z, 0.0, 100.0);
    let f32_hit = PackedGroup::new(&g).cast(o, -DVec3::Z, 0.0, 100.0);
    let band = tangency(&g, o, -DVec3::Z, 0.0, 100.0);
    assert!(band.in_band(), "a tangent ray is in the band (margin {:e})", band.margin);
    println!(
        "tangent ray, two balls (double root at t = {t_exact:.6}): f64 {} error {:.1e}, {} iterations, flat {}; \
         f32 {} error {:.1e}, {} iterations, flags {:#x}; margin {:.1e}",
        if h.is_some() { "hit" } else { "miss" },
        h.map_or(f64::NAN, |h| (h.t - t_exact).abs()),
        h.map_or(0, |h| h.iterations),
        h.is_some_and(|h| h.flat_root),
        if f32_hit.hit() { "hit" } else { "miss" },
        if f32_hit.hit() { (f64::from(f32_hit.t) - t_exact).abs() } else { f64::NAN },
        f32_hit.iterations,
        f32_hit.flags,
        band.margin
    );
    if let Some(h) = h {
        assert!((h.t - t_exact).abs() < 1e-6, "a double root is found to about √ε: {} vs {t_exact}", h.t);
    }
    if f32_hit.hit() {
        assert!((f64::from(f32_hit.t) - t_exact).abs() < 3e-3, "f32 double root: {} vs {t_exact}", f32_hit.t);
    }
    assert!(f32_hit.tangent(), "f32 flags the tangent ray: {f32_hit:?}");
    // Slightly off the tangent, on each side: a clean miss above, two close roots below.
    for (dy, expect) in [(1e-3, false), (-1e-3, true), (1e-6, false), (-1e-6, true)] {
        let o = DVec3::new(x, y + dy, 10.0);
        let a = cast(&g, o, -DVec3::Z, 0.0, 100.0);
        let b = cast_reference(&g, o, -DVec3::Z, 0.0, 100.0);
        assert_eq!(a.is_some(), expect);
        assert_eq!(b.is_some(), expect);
        if let (Some(a), Some(b)) = (a, b) {
            assert!((a.t - b.t).abs() < 1e-9 * b.t, "{} vs {}", a.t, b.t);
            let f = PackedGroup::new(&g).cast(o, -DVec3::Z, 0.0, 100.0);
            println!(
                "near-tangent (dy = {dy}): f64 {} iterations, t error {:.1e}; f32 {} iterations, t error {:.1e}, flags {:#x}",
                a.iterations,
                (a.t - b.t).abs(),
                f.iterations,
                (f64::from(f.t) - b.t).abs(),
                f.flags
            );
        }
    }
    // A lone ball's sphere (ρ*R ≈ 1) touched at height 1: the analytic path. Hit or miss are
    // both right (ρ* rounds to 0.4999999999999999); a hit is at the tangent point.
    let g1 = group(vec![ball(DVec3::ZERO, 2.0, 1.0)]);
    let o1 = DVec3::new(0.0, 1.0, 10.0);
    if let Some(h) = cast(&g1, o1, -DVec3::Z, 0.0, 100.0) {
        assert!((h.t - 10.0).abs() < 1e-7 && h.iterations == 0, "{h:?}");
    }
    assert!(tangency(&g1, o1, -DVec3::Z, 0.0, 100.0).in_band());
    let f = PackedGroup::new(&g1).cast(o1, -DVec3::Z, 0.0, 100.0);
    assert!(f.tangent(), "f32 flags the graze: {f:?}");
}

#[test]
fn two_balls_with_the_same_centre() {
    let g = group(vec![ball(DVec3::ZERO, 2.0, 1.0), ball(DVec3::ZERO, 2.0, 1.0)]);
    let rho = iso_radius(Kernel::Wyvill6, 2.0, 0.5).unwrap();
    let o = DVec3::new(0.3, 0.2, 10.0);
    let h = cast(&g, o, -DVec3::Z, 0.0, 100.0).unwrap();
    let expected = 10.0 - ((rho * 2.0f64).powi(2) - 0.13).sqrt();
    assert!((h.t - expected).abs() < 1e-10, "{} vs {expected}", h.t);
    assert!(h.iterations > 0, "two active balls take the Bézier path");
    check_on_surface(&g, o, -DVec3::Z, &h, 1e-12);
    // Different radii around one centre: still a sphere, radius where f(r²/4) + f(r²/1) = 0.5.
    let g = group(vec![ball(DVec3::ZERO, 2.0, 1.0), ball(DVec3::ZERO, 1.0, 0.4)]);
    let h = cast(&g, o, -DVec3::Z, 0.0, 100.0).unwrap();
    let r = cast_reference(&g, o, -DVec3::Z, 0.0, 100.0).unwrap();
    assert!((h.t - r.t).abs() < 1e-10 * r.t);
    check_on_surface(&g, o, -DVec3::Z, &h, 1e-12);
}

#[test]
fn negative_q_carves_into_a_positive_ball() {
    let g = group(vec![ball(DVec3::ZERO, 2.0, 1.0), ball(DVec3::new(1.2, 0.0, 0.0), 1.5, -1.0)]);
    // Along −x from x = 10: without the carving the surface is at x = 1 (t = 9).
    let o = DVec3::new(10.0, 0.0, 0.0);
    let h = cast(&g, o, -DVec3::X, 0.0, 100.0).unwrap();
    let r = cast_reference(&g, o, -DVec3::X, 0.0, 100.0).unwrap();
    assert!((h.t - r.t).abs() < 1e-10 * r.t, "{} vs {}", h.t, r.t);
    assert!(h.t > 9.1, "the negative ball pushes the surface in: t = {}", h.t);
    check_on_surface(&g, o, -DVec3::X, &h, 1e-12);
    // Seen from the side the carved ball still has its far half.
    let o = DVec3::new(-10.0, 0.0, 0.0);
    let h = cast(&g, o, DVec3::X, 0.0, 100.0).unwrap();
    assert!((h.t - 9.0).abs() < 1e-3, "{}", h.t);
    // A negative ball alone has no surface.
    assert!(cast(&group(vec![ball(DVec3::ZERO, 2.0, -1.0)]), o, DVec3::X, 0.0, 100.0).is_none());
}

#[test]
fn camera_inside_the_support_and_inside_the_surface() {
    let g = group(vec![ball(DVec3::ZERO, 2.0, 1.0)]);
    let g2 = group(vec![ball(DVec3::ZERO, 2.0, 1.0), ball(DVec3::new(0.0, 0.0, -3.0), 2.0, 0.3)]);
    for g in [&g, &g2] {
        // Inside the support (r = 1.5), outside the surface (r = 1): the surface at t = 0.5.
        let o = DVec3::new(0.0, 0.0, 1.5);
        let h = cast(g, o, -DVec3::Z, 0.0, 100.0).unwrap();
        let r = cast_reference(g, o, -DVec3::Z, 0.0, 100.0).unwrap();
        assert!((h.t - r.t).abs() < 1e-12, "{} vs {}", h.t, r.t);
        // Inside the surface: the first crossing is the exit, its normal points away from the camera.
        let o = DVec3::new(0.0, 0.0, 0.3);
        for d in [DVec3::Z, -DVec3::Z] {
            let h = cast(g, o, d, 0.0, 100.0).unwrap();
            let r = cast_reference(g, o, d, 0.0, 100.0).unwrap();
            assert!((h.t - r.t).abs() < 1e-11, "{} vs {}", h.t, r.t);
            assert!(h.normal.dot(d) > 0.99, "exit normal {} along {d}", h.normal);
            let f = PackedGroup::new(g).cast(o, d, 0.0, 100.0);
            assert!(f.hit() && (f64::from(f.t) - h.t).abs() < 1e-6, "{f:?}");
        }
    }
    assert!((cast(&g, DVec3::new(0.0, 0.0, 0.3), DVec3::Z, 0.0, 100.0).unwrap().t - 0.7).abs() < 1e-14);
}

#[test]
fn group_behind_the_camera() {
    let g = group(vec![ball(DVec3::ZERO, 2.0, 1.0), ball(DVec3::new(0.0, 1.0, 0.0), 2.0, 1.0)]);
    let o = DVec3::new(0.0, 0.0, 10.0);
    assert!(cast(&g, o, DVec3::Z, 0.0, 100.0).is_none());
    assert!(cast_reference(&g, o, DVec3::Z, 0.0, 100.0).is_none());
    assert!(!PackedGroup::new(&g).cast(o, DVec3::Z, 0.0, 100.0).hit());
    // Facing it, but t_max stops short (the depth buffer holds something nearer).
    assert!(cast(&g, o, -DVec3::Z, 0.0, 8.0).is_none());
    assert!(!PackedGroup::new(&g).cast(o, -DVec3::Z, 0.0, 8.0).hit());
}

#[test]
fn ball_on_the_near_plane() {
    let g = group(vec![ball(DVec3::ZERO, 2.0, 1.0), ball(DVec3::new(0.5, 0.0, 0.0), 1.0, 0.2)]);
    let o = DVec3::new(0.0, 0.0, 10.0);
    let first = cast_reference(&g, o, -DVec3::Z, 0.0, 100.0).unwrap();
    // t_min exactly at the surface: the hit is t_min itself.
    let h = cast(&g, o, -DVec3::Z, first.t, 100.0).unwrap();
    assert!((h.t - first.t).abs() < 1e-12, "{} vs {}", h.t, first.t);
    // t_min at the centre (the near plane through the ball): the ray starts inside, exits at R/2.
    let h = cast(&g, o, -DVec3::Z, 10.0, 100.0).unwrap();
    let r = cast_reference(&g, o, -DVec3::Z, 10.0, 100.0).unwrap();
    assert!((h.t - r.t).abs() < 1e-11 && h.t > 10.9 && h.t < 11.1, "{} vs {}", h.t, r.t);
    let f = PackedGroup::new(&g).cast(o, -DVec3::Z, 10.0, 100.0);
    assert!(f.hit() && (f64::from(f.t) - h.t).abs() < 1e-5, "{f:?}");
}

#[test]
fn ellipsoidal_metaballs() {
    // Scale x by 3: the lone ball's surface is the ellipsoid with semi-axes (3, 1, 1).
    let mut g = group(vec![ball(DVec3::ZERO, 2.0, 1.0)]);
    g.transform = Transform::from_ops(&[TransformOp::Scale(DVec3::new(3.0, 1.0, 1.0))]).unwrap();
    let h = cast(&g, DVec3::new(20.0, 0.0, 0.0), -DVec3::X, 0.0, 100.0).unwrap();
    assert!((h.t - 17.0).abs() < 1e-12 && (h.normal - DVec3::X).length() < 1e-12, "{h:?}");
    // An oblique ray: the normal is M⁻ᵀ applied to the object normal (seed 002).
    let o = DVec3::new(10.0, 0.5, 6.0);
    let d = (DVec3::new(1.0, 0.5, 0.0) - o).normalize();
    let h = cast(&g, o, d, 0.0, 100.0).unwrap();
    let p = o + d * h.t;
    let ellipsoid = (p.x / 3.0).powi(2) + p.y * p.y + p.z * p.z;
    assert!((ellipsoid - 1.0).abs() < 1e-12, "{ellipsoid}");
    let n = DVec3::new(p.x / 9.0, p.y, p.z).normalize();
    assert!(angle_deg(n, h.normal) < 1e-9);
    // With two balls (the Bézier path) the reference agrees too.
    g.balls.push(ball(DVec3::new(0.0, 1.5, 0.0), 1.5, 0.8));
    let h = cast(&g, o, d, 0.0, 100.0).unwrap();
    let r = cast_reference(&g, o, d, 0.0, 100.0).unwrap();
    assert!((h.t - r.t).abs() < 1e-10 * r.t);
    let f = PackedGroup::new(&g).cast(o, d, 0.0, 100.0);
    assert!(
        f.hit()
            && (f64::from(f.t) - h.t).abs() < 1e-4 * h.t
            && angle_deg(f.normal.as_dvec3(), h.normal) < 0.5
    );
}

/// 10,000 balls strung along one ray: the sweep stays linear-ish (a sanity check, not timed).
#[test]
fn ten_thousand_balls_along_one_ray() {
    let line =
        |q: f64| group((0..10_000).map(|k| ball(DVec3::new(0.0, 0.0, -0.5 * k as f64), 1.0, q)).collect());
    let o = DVec3::new(0.0, 0.0, 5.0);
    // q = 0.1: about four overlapping balls give F ≈ 0.2 < T everywhere: a miss after all 20,000 events.
    let g = line(0.1);
    let start = std::time::Instant::now();
    assert!(cast(&g, o, -DVec3::Z, 0.0, 1e4).is_none());
    assert!(cast_reference(&g, o, -DVec3::Z, 0.0, 1e4).is_none());
    println!("10,000 balls, miss: f64 cast + reference in {:?}", start.elapsed());
    // q = 0.3: the first blob is hit before the 32 nearest balls run out, f32 included.
    let g = line(0.3);
    let h = cast(&g, o, -DVec3::Z, 0.0, 1e4).unwrap();
    let r = cast_reference(&g, o, -DVec3::Z, 0.0, 1e4).unwrap();
    assert!((h.t - r.t).abs() < 1e-9 * r.t, "{} vs {}", h.t, r.t);
    let f = PackedGroup::new(&g).cast(o, -DVec3::Z, 0.0, 1e4);
    assert!(f.hit() && (f64::from(f.t) - h.t).abs() < 1e-4 * h.t, "{f:?} vs {h:?}");
    // The f32 cast holds 32 supports at a time: it goes on round by round (four supports contain
    // any point, so nothing is streamed) and reaches the end.
    let f = PackedGroup::new(&line(0.1)).cast(o, -DVec3::Z, 0.0, 1e4);
    assert!(!f.hit() && f.flags & MB_STREAMED == 0, "{f:?}");
}

/// Rays near silhouettes, where f32 and f64 may legitimately disagree: for random groups, find
/// the silhouette between a hit and a miss by bisecting a sideways shift of the ray (f64), then
/// cast at shifts 10⁻³ … 10⁻¹⁰ away from it on both sides. Outside the tangency band the f32
/// twin must agree; inside it, disagreements are counted.
#[test]
fn silhouettes_f32_vs_f64() {
    let mut rng = Rng(0x51_1f_4e_77_e1_1b_0b_5e);
    let eps = f64::from(f32::EPSILON);
    let (mut outside, mut inside, mut inside_differ, mut flagged_in_band, mut flagged_outside) =
        (0, 0, 0, 0, 0);
    let mut smallest_differ = f64::INFINITY;
    let mut largest_differ = 0.0f64;
    let mut hist = std::collections::BTreeMap::new();
    let mut depth = Comparison::new("silhouettes, f32 vs f64 outside the band: relative depth");
    let mut normal = Comparison::new("silhouettes, f32 vs f64 outside the band: normal, degrees");
    for _ in 0..150 {
        let g = random_group(&mut rng);
        let packed = PackedGroup::new(&g);
        for _ in 0..10 {
            let (o, d) = random_ray(&mut rng, &g);
            let Some(_) = cast(&g, o, d, 0.0, 100.0) else { continue };
            // Shift sideways until the ray misses.
            let side = d.cross(rng.unit()).normalize();
            let mut far = 1.0;
            while cast(&g, o + side * far, d, 0.0, 100.0).is_some() && far < 64.0 {
                far *= 2.0;
            }
            if far >= 64.0 {
                continue;
            }
            let (mut lo, mut hi) = (0.0f64, far);
            for _ in 0..60 {
                let m = 0.5 * (lo + hi);
                if cast(&g, o + side * m, d, 0.0, 100.0).is_some() {
                    lo = m;
                } else {
                    hi = m;
                }
            }
            for k in 2..=20 {
                for sign in [-1.0, 1.0] {
                    let shift = 0.5 * (lo + hi) + sign * 10f64.powf(-k as f64 / 2.0);
                    let oo = o + side * shift;
                    let a = cast(&g, oo, d, 0.0, 100.0);
                    let b = packed.cast(oo, d, 0.0, 100.0);
                    let band = tangency(&g, oo, d, 0.0, 100.0);
                    let same = match a {
                        Some(a) => b.hit() && (f64::from(b.t) - a.t).abs() <= 1e-4 * a.t,
                        None => !b.hit(),
                    };
                    if !same {
                        if band.margin / eps > largest_differ {
                            largest_differ = band.margin / eps;
                        }
                        let bucket =
                            ((band.margin / eps).clamp(1e-3, f64::MAX).log2().floor() as i32).clamp(-10, 10);
                        *hist.entry(bucket).or_insert(0usize) += 1;
                    }
                    if band.in_band() {
                        inside += 1;
                        inside_differ += usize::from(!same);
                        flagged_in_band += usize::from(b.tangent());
                        continue;
                    }
                    flagged_outside += usize::from(b.tangent());
                    if !same {
                        smallest_differ = smallest_differ.min(band.margin / eps);
                    }
                    assert!(
                        same,
                        "outside the band (margin {:.1}ε): f64 {a:?} vs f32 {b:?}\n{g:?}\n{oo} {d}",
                        band.margin / eps
                    );
                    outside += 1;
                    if let Some(a) = a {
                        let at = format_args!("{oo} {d} (margin {:.1}ε)", band.margin / eps);
                        depth.rel(at, f64::from(b.t), a.t);
                        normal.error(at, angle_deg(a.normal, b.normal.as_dvec3()));
                    }
                }
            }
        }
    }
    println!(
        "silhouettes: {outside} rays outside the band agree; {inside} in the band, {inside_differ} of them \
         differ; MB_TANGENT raised on \
         {flagged_in_band} in-band and {flagged_outside} outside-band rays"
    );
    println!("largest margin of a disagreement: {largest_differ:.2}ε; by log2(margin/ε): {hist:?}");
    assert!(inside > 100 && outside > 1000, "{inside} in the band, {outside} outside");
    // The band's contract (`metaballs_f32` module docs); half the rays outside the band hit.
    depth.assert_within(1e-4, 500);
    normal.assert_within(0.5, 500);
}

/// assets/scenes/metaballs.toml keeps seed 000's metaball.cfg balls, a carving (negative q) group
/// and an ellipsoidal one; metaballs_4096.toml has 4,096 moving balls.
#[test]
fn metaball_assets() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
    let scene = hadou::scene::load_scene(&root.join("metaballs.toml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.metaballs().len(), 3);
    let seed = &scene.metaballs()[0];
    assert_eq!((seed.balls[0].centre, seed.balls[0].radius), (DVec3::ZERO, 2.0));
    assert_eq!((seed.balls[1].centre, seed.balls[1].radius), (DVec3::new(0.0, 4.0, 0.0), 2.0));
    // The top of the (0, 4, 0) ball is covered by its support alone: the lone-ball sphere, R/2.
    let p = seed.at(0.0);
    let h = cast(&p, DVec3::new(-5.0, 20.0, 0.0), -DVec3::Y, 0.0, 100.0).unwrap();
    assert!((h.t - 15.0).abs() < 1e-12, "{}", h.t);
    // At T = 1 the keyframes have lowered it by 0.6.
    let h = cast(&seed.at(1.0), DVec3::new(-5.0, 20.0, 0.0), -DVec3::Y, 0.0, 100.0).unwrap();
    assert!((h.t - 15.6).abs() < 1e-12, "{}", h.t);
    assert!(scene.metaballs()[1].balls.iter().any(|b| b.q < 0.0));
    let m = scene.metaballs()[2].transform.matrix;
    assert!((m.x_axis.truncate().length() - m.y_axis.truncate().length()).abs() > 0.5, "not ellipsoidal");
    assert_eq!(scene.metaballs()[2].kernel, Kernel::Murakami4);
    let swarm = hadou::scene::load_scene(&root.join("metaballs_4096.toml")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(swarm.metaballs()[0].balls.len(), 4096);
    assert!(swarm.metaballs()[0]
        .balls
        .iter()
        .all(|b| b.velocity.length() <= 0.4 && b.velocity != DVec3::ZERO));
}

/// The sphere-tracing baseline (f64 twin of the shader's) against the exact cast on random rays.
/// Its steps never jump over a root (|F − T| changes by at most L per unit until the next chord
/// entry), except its least step (2⁻¹⁰·T/L), which can only skip a sliver where F − T stays
/// within 2⁻¹⁰·T of zero: rays whose tangency margin (min |F − T|/(S + X·G), S ≥ T) is at most
/// 2⁻¹⁰ are left out. Elsewhere hit/miss agree, and a hit lies in a bracket one least step wide
/// bisected 16 times: |t′ − root| ≤ 2⁻¹⁰·T/L·2⁻¹⁷ with L ≥ the smallest |q|γ/R of the group
/// (a ball is active wherever F ≠ 0), mapped to world distance by 1/‖M⁻¹d‖.
#[test]
fn sphere_tracing_finds_the_exact_first_root() {
    use hadou::effects::metaballs_trace::{trace, TRACE_BISECT, TRACE_MIN_STEP};
    let mut rng = Rng(0x7472_6163_6531);
    let (mut hits, mut left_out, mut steps) = (0usize, 0usize, Vec::new());
    let mut error = Comparison::new("sphere tracing vs the exact cast: |t′ − t| / its bound");
    for _ in 0..200 {
        let g = random_group(&mut rng);
        let gamma = g.kernel.max_slope();
        let l_min = g.balls.iter().map(|b| b.q.abs() * gamma / b.radius).fold(f64::INFINITY, f64::min);
        for _ in 0..50 {
            let (o, d) = random_ray(&mut rng, &g);
            let tr = trace(&g, o, d, 0.0, 100.0, 100_000);
            assert!(!tr.exhausted, "100,000 steps must do");
            if tangency(&g, o, d, 0.0, 100.0).margin <= 2f64.powi(-10) {
                left_out += 1;
                continue;
            }
            let exact = cast(&g, o, d, 0.0, 100.0);
            assert_eq!(tr.hit.is_some(), exact.is_some(), "ray {o} {d}: trace {tr:?}, exact {exact:?}");
            if let (Some(h), Some(r)) = (tr.hit, exact) {
                hits += 1;
                steps.push(tr.steps);
                let ts = g.transform.ray_to_object(o, d).t_scale;
                let bound = TRACE_MIN_STEP * g.threshold / l_min * 0.5f64.powi(TRACE_BISECT as i32 + 1) / ts;
                // The bound, with f64 rounding: 1e-9 of it and 1e-12 of t.
                let err = (h.t - r.t).abs();
                error.error(
                    format_args!("ray {o} {d}: trace {} vs exact {}, bound {bound:.2e}", h.t, r.t),
                    err / (bound * (1.0 + 1e-9) + 1e-12 * r.t),
                );
                assert!(angle_deg(h.normal, r.normal) <= 1e-3, "normal {} vs {}", h.normal, r.normal);
            }
        }
    }
    steps.sort_unstable();
    println!(
        "sphere tracing: {hits} hits, steps per hit median {} max {}; {left_out} rays within 2^-10 of \
         tangency left out",
        steps[steps.len() / 2],
        steps[steps.len() - 1]
    );
    error.assert_within(1.0, 2000);
}

/// Crowds of 48 and 500 overlapping supports (`testing::crowded_metaballs`: every ray through the
/// middle is inside all of them at once, far more than the 32 slots, and at 500 more than the
/// streamed cast's cache of 128 chords holds) in front of and around two dense balls, and a tube
/// of 400 supports a ray meets one after another (`testing::crowded_tube`: ~118 on each point,
/// gathered in several rounds of the cache): the f32 twin streams the crowded part (MB_STREAMED)
/// and must agree with f64 outside the tangency band like any other ray — nothing behind the
/// crowd is lost.
#[test]
fn crowded_supports_f32_twin_matches_f64() {
    let mut rng = Rng(0x0c20_3d0d_5eed_0048);
    for (k, tube) in [(48usize, false), (500, false), (400, true)] {
        let (mut agree, mut streamed, mut hits, mut in_band) = (0usize, 0usize, 0usize, 0usize);
        let mut depth = Comparison::new(format!("{k} supports, f32 vs f64: relative depth"));
        let mut normal = Comparison::new(format!("{k} supports, f32 vs f64: normal, degrees"));
        // Fewer groups of 500 (each ray costs ~500 × its streamed walks, in f64 and f32).
        for _ in 0..(if k > 100 { 1 } else { 3 }) {
            let g = if tube {
                hadou::testing::crowded_tube(&mut rng, k)
            } else {
                hadou::testing::crowded_metaballs(&mut rng, k)
            };
            let packed = PackedGroup::new(&g);
            let centre = g.transform.transform_point(DVec3::new(0.05, -0.05, -1.35));
            // Cameras on the fog's side (+z in object space) so every ray crosses it first.
            let eye = g.transform.transform_point(DVec3::new(0.0, 0.0, 12.0));
            for _ in 0..40 {
                let target = centre + rng.vec(-1.0, 1.0);
                let (o, d) = (eye, (target - eye).normalize());
                let a = cast(&g, o, d, 0.1, 100.0);
                let b = packed.cast(o, d, 0.1, 100.0);
                streamed += (b.flags & MB_STREAMED != 0) as usize;
                if tangency(&g, o, d, 0.1, 100.0).in_band() {
                    in_band += 1;
                    continue;
                }
                match a {
                    Some(a) => {
                        assert!(b.hit(), "k = {k}: f64 hits at {} but f32 misses ({b:?})", a.t);
                        let at = format_args!("{o} {d}");
                        depth.rel(at, f64::from(b.t), a.t);
                        normal.error(at, angle_deg(a.normal, b.normal.as_dvec3()));
                        hits += 1;
                    }
                    None => assert!(!b.hit(), "k = {k}: f32 hits at {} where f64 misses", b.t),
                }
                agree += 1;
            }
        }
        println!("{k} supports (tube: {tube}): {agree} rays agree ({hits} hits, {streamed} streamed, {in_band} in the band)");
        // The band's contract (`metaballs_f32` module docs); 67 and 30 hits when written.
        depth.assert_within(1e-4, 20);
        normal.assert_within(0.5, 20);
        assert!(hits > 20 && streamed > 30, "the sample must cross the crowd and hit behind it");
    }
}
