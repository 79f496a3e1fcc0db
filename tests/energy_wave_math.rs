//! The f32 twin of the energy-wave shader against the f64 closed form on hard rays, random
//! parameters (proptest) and the ray-march baseline.
//!
//! The fair reference for the twin is the f64 closed form on the numbers the twin receives: the
//! f32-rounded camera-relative quantities of `gpu_wave` (widened back by `GpuWave::to_frame`) and
//! the f32 ray (u, L). Rounding those inputs is the GPU's unavoidable error and can itself change
//! the answer on ill-conditioned rays (a ray 1e-6·|O − M| from M with ε = 0: one ulp of u moves
//! it by 6 % of that distance); what the twin controls is everything after, so that is what the
//! bounds below test. The error of the rounding itself (f64 on the rounded inputs vs f64 on the
//! exact ones) is printed next to it for information.
//!
//! Run with `--nocapture` to see the table of worst errors per case.

mod common;

use common::march_bound::{raymarch_bound, MarchUlps};
use hadou::testing::{Comparison, Rng};
use std::collections::BTreeMap;
use std::sync::Mutex;

use glam::DVec3;
use hadou::effects::energy_wave::{line_integral, line_integral_frame, raymarch_frame, WaveParams};
use hadou::effects::energy_wave_f32::{gpu_wave, line_integral_f32, raymarch_f32, GpuWave};
use proptest::prelude::*;

/// Relative error bounds of the twin: 1e-4 for every case and 1e-5 for the bulk of ordinary
/// rays. No hard case needs the wider bound (measured worst ≈ 5e-7 everywhere), so the hard rays
/// are held to the bulk bound too.
const EVERY_CASE: f64 = 1e-4;
const BULK: f64 = 1e-5;
const HARD: f64 = BULK;

fn f32x3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

fn widen(v: [f32; 3]) -> DVec3 {
    DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

/// One ray: (twin, fair f64 reference, f64 on the exact inputs).
fn evaluate(w: &WaveParams, camera: DVec3, u: DVec3, l: f64) -> (f64, f64, f64) {
    evaluate_g(&gpu_wave(w, camera), w, camera, f32x3(u), l as f32, u, l)
}

/// The twin and the fair reference on (g, u, l); the f64 closed form on the exact wave, camera,
/// direction and length for the "input rounding" column.
fn evaluate_g(
    g: &GpuWave,
    w: &WaveParams,
    camera: DVec3,
    u: [f32; 3],
    l: f32,
    exact_u: DVec3,
    exact_l: f64,
) -> (f64, f64, f64) {
    let twin = line_integral_f32(g, u, l) as f64;
    let fair = line_integral_frame(&g.to_frame(), widen(u), l as f64);
    (twin, fair, line_integral(w, camera, exact_u, exact_l))
}

fn rel(x: f64, reference: f64) -> f64 {
    if x == reference {
        0.0
    } else {
        (x - reference).abs() / reference.abs()
    }
}

/// One case's comparisons: the twin against the fair f64 reference (asserted), and the fair
/// reference against f64 on the exact inputs (the input rounding, printed for information).
struct Case {
    twin: Comparison,
    rounding: Comparison,
    bound: f64,
}

/// Every ray of each named case, compared (NaN-aware) and asserted at the end of each test.
struct Table(Mutex<BTreeMap<String, Case>>);

impl Table {
    fn new() -> Self {
        Table(Mutex::new(BTreeMap::new()))
    }
    fn record(&self, case: &str, (twin, fair, exact): (f64, f64, f64), bound: f64) {
        assert!(twin >= 0.0, "{case}: twin {twin}");
        assert!(fair >= 0.0, "{case}: f64 {fair}");
        let mut t = self.0.lock().unwrap();
        let c = t.entry(case.to_string()).or_insert_with(|| Case {
            twin: Comparison::new(format!("{case}: twin vs f64")),
            rounding: Comparison::new(format!("{case}: input rounding")),
            bound,
        });
        assert_eq!(c.bound, bound, "{case}: one bound per case");
        let n = c.twin.compared();
        c.twin.rel(format_args!("ray {n}"), twin, fair);
        c.rounding.rel(format_args!("ray {n}"), fair, exact);
    }
    /// Prints the table and asserts every case: all finite, within its bound, and at least
    /// `min_per_case` rays compared in each of the `cases` names expected.
    fn assert_all(&self, title: &str, cases: usize, min_per_case: usize) {
        let t = self.0.lock().unwrap();
        eprintln!("\n{title}\n{:<52} {:>6} {:>12} {:>16}", "case", "rays", "twin vs f64", "(input rounding)");
        for (k, c) in t.iter() {
            eprintln!(
                "{k:<52} {:>6} {:>12.2e} {:>16.2e}",
                c.twin.compared(),
                c.twin.worst(),
                c.rounding.worst()
            );
        }
        for c in t.values() {
            if let Err(failure) = c.twin.check(c.bound, min_per_case) {
                panic!("{failure}");
            }
        }
        assert_eq!(t.len(), cases, "cases seen: {:?}", t.keys().collect::<Vec<_>>());
    }
}

fn random_wave(rng: &mut Rng, finite: bool, core: f64) -> WaveParams {
    WaveParams {
        origin: DVec3::new(rng.range(-50.0, 50.0), rng.range(-50.0, 50.0), rng.range(-50.0, 50.0)),
        direction: rng.unit(),
        a: rng.range(0.1, 100.0),
        b: rng.range(0.1, 100.0),
        core,
        length: if finite { rng.range(1.0, 200.0) } else { f64::INFINITY },
    }
}

fn tag(finite: bool) -> &'static str {
    if finite {
        "l finite"
    } else {
        "l = inf"
    }
}

const CORES: [f64; 4] = [0.0, 1e-6, 1e-3, 0.5];

#[test]
fn hard_rays_twin_vs_f64_on_the_same_inputs() {
    let table = Table::new();
    let mut rng = Rng(0x5eed_0004);
    for finite in [false, true] {
        let t = tag(finite);
        for &core in &CORES {
            for _ in 0..40 {
                let w = random_wave(&mut rng, finite, core);
                // Rays passing δ·|O − M| from M, from 10 to 1e5 units away, clipped before M,
                // near M or far behind it.
                for k in 1..=7 {
                    let dist = rng.pick(&[10.0, 1e3, 1e5]);
                    let o = w.origin + rng.unit() * dist;
                    let v = (w.origin - o).normalize();
                    let target = w.origin + rng.perp(v) * (10f64.powi(-k) * dist);
                    let u = (target - o).normalize();
                    let l = dist * rng.pick(&[0.5, 1.0 + 1e-3, 2.0, 10.0]);
                    table.record(&format!("near M, delta 1e-{k}, {t}"), evaluate(&w, o, u, l), HARD);
                }
                // Exactly through M: camera offset along a coordinate axis (exact in f32) …
                let dist = rng.pick(&[1.0, 100.0, 1e4]);
                let axis = rng.pick(&[DVec3::X, DVec3::Y, DVec3::Z]);
                let sign = rng.pick(&[1.0, -1.0]);
                let o = w.origin + axis * (sign * dist);
                let l = dist * rng.pick(&[0.5, 1.0, 2.0]);
                table.record(&format!("through M, exact, {t}"), evaluate(&w, o, -sign * axis, l), HARD);
                // … and along the f32-rounded direction to M (misses by ~1e-8·|O − M|).
                let o = w.origin + rng.unit() * dist;
                let u = (w.origin - o).normalize();
                table.record(&format!("through M, rounded u, {t}"), evaluate(&w, o, u, 2.0 * dist), HARD);
                // Camera exactly at M.
                let u = rng.unit();
                table.record(&format!("camera at M, {t}"), evaluate(&w, w.origin, u, 50.0), HARD);
                // Parallel and anti-parallel to D (u = ±D exactly as the GPU has it), at a
                // perpendicular distance, starting behind M, inside the beam or past the tip.
                for k in 0..=6 {
                    let perp = 10f64.powi(-k);
                    let q = rng.pick(&[-100.0, 0.5, 30.0, 500.0]) * w.length.min(100.0) / 100.0;
                    let o = w.origin + rng.perp(w.direction) * perp + w.direction * q;
                    let g = gpu_wave(&w, o);
                    let d = [g.dir[0], g.dir[1], g.dir[2]];
                    let l = rng.pick(&[1.0, 100.0, 1e4]);
                    let r = evaluate_g(&g, &w, o, d, l as f32, w.direction, l);
                    table.record(&format!("parallel to D, perp 1e-{k}, {t}"), r, HARD);
                    let anti = [-d[0], -d[1], -d[2]];
                    let r = evaluate_g(&g, &w, o, anti, l as f32, -w.direction, l);
                    table.record(&format!("anti-parallel, perp 1e-{k}, {t}"), r, HARD);
                    // Nearly parallel: tilted by 1e-2 … 1e-6 rad.
                    let tilt = 10f64.powi(-2 - (k % 5));
                    let u = (w.direction + rng.perp(w.direction) * tilt).normalize();
                    table.record(&format!("nearly parallel, perp 1e-{k}, {t}"), evaluate(&w, o, u, l), HARD);
                }
                // Rays lying in the plane I (camera in I, direction perpendicular to D).
                let e1 = rng.perp(w.direction);
                let o = w.origin + e1 * rng.pick(&[1.0, 100.0, 1e4]);
                let u = (-e1 + w.direction.cross(e1) * rng.range(-1.0, 1.0)).normalize();
                table.record(
                    &format!("in the plane I, {t}"),
                    evaluate(&w, o, u, 2.0 * (o - w.origin).length()),
                    HARD,
                );
                // Camera inside the beam, any direction and along the beam.
                let q = if finite { rng.range(0.1, 0.9) * w.length } else { rng.range(0.1, 1e3) };
                let o = w.origin + w.direction * q + rng.perp(w.direction) * rng.pick(&[1e-4, 1e-2, 1.0]);
                let l = rng.pick(&[0.1, 10.0, 1e3]);
                table.record(&format!("camera inside the beam, {t}"), evaluate(&w, o, rng.unit(), l), HARD);
                let u = (rng.pick(&[1.0, -1.0]) * w.direction + rng.perp(w.direction) * 1e-3).normalize();
                table.record(&format!("camera inside the beam, along it, {t}"), evaluate(&w, o, u, l), HARD);
                // Camera 1e5 units from M, looking at the beam.
                let o = w.origin + rng.unit() * 1e5;
                let target = w.origin
                    + w.direction * rng.range(0.0, w.length.min(100.0))
                    + rng.unit() * rng.pick(&[1e-2, 1.0, 10.0]);
                let u = (target - o).normalize();
                table.record(&format!("camera 1e5 from M, {t}"), evaluate(&w, o, u, 2e5), HARD);
                // L = 0.
                let r = evaluate(&w, o, u, 0.0);
                assert_eq!((r.0, r.1), (0.0, 0.0));
                table.record(&format!("L = 0, {t}"), r, 0.0);
                // The clip exactly at the plane I (in f64 on the rounded inputs, then rounded).
                let o = w.origin + rng.unit() * rng.pick(&[1.0, 100.0, 1e4]);
                let g = gpu_wave(&w, o);
                let u64 = rng.unit();
                let u = f32x3(u64);
                let s = -(g.dir[3] as f64) / widen(u).dot(g.to_frame().d);
                if s > 0.0 {
                    let exact_s = -(o - w.origin).dot(w.direction) / u64.dot(w.direction);
                    let r = evaluate_g(&g, &w, o, u, s as f32, u64, exact_s);
                    table.record(&format!("clip at the plane I, {t}"), r, HARD);
                }
                // The beam tip inside the clip interval (finite beams): rays crossing q = ℓ near
                // the axis, from either side.
                if finite {
                    let tip = w.origin + w.direction * w.length;
                    let o = tip + rng.unit() * rng.pick(&[1.0, 100.0, 1e4]);
                    let target = tip + rng.perp(w.direction) * rng.pick(&[1e-4, 1e-1, 1.0]);
                    let u = (target - o).normalize();
                    let l = 2.0 * (o - tip).length();
                    table.record("beam tip inside the clip interval", evaluate(&w, o, u, l), HARD);
                }
            }
        }
    }
    // 2 beam kinds × (7 near M + 3 through or at M + 21 parallel + 6 others) cases, and the tip;
    // 40 waves × 4 cores per case and beam kind (the clip at the plane I only where s > 0: about
    // half, so a quarter of that is the floor).
    table.assert_all(
        "hard rays: worst relative error, f32 twin vs f64 on the same f32 inputs",
        2 * 37 + 1,
        40,
    );
}

#[test]
fn bulk_rays_twin_vs_f64() {
    let table = Table::new();
    let mut rng = Rng(0xb01c);
    for i in 0..20_000 {
        let finite = i % 2 == 0;
        let core = if i % 4 < 2 { 0.0 } else { rng.range(0.0, 5.0) };
        let w = random_wave(&mut rng, finite, core);
        let o = w.origin + rng.unit() * rng.range(0.0, 1e3);
        let target = w.origin + w.direction * rng.range(-50.0, 150.0) + rng.unit() * rng.range(0.0, 30.0);
        let u = (target - o).normalize();
        let l = rng.range(0.0, 3.0) * (target - o).length();
        table.record(&format!("bulk, {}", tag(finite)), evaluate(&w, o, u, l), BULK);
    }
    table.assert_all("bulk rays: worst relative error, f32 twin vs f64 on the same f32 inputs", 2, 10_000);
}

/// The f32 twin against f64 on the same f32 inputs (a sequential f32 sum, as the twin and GLSL).
const TWIN_MARCH: MarchUlps = MarchUlps { fixed: 10.0, per_s: 12.0, per_om: 0.0 };

#[test]
fn raymarch_twin_matches_f64_and_converges() {
    let mut rng = Rng(0x3a7c);
    // Each case's error over its own derived bound (`raymarch_bound`): ≤ 1, all 300 compared.
    let mut march = Comparison::new("raymarch twin vs f64 on the same inputs, error / derived bound");
    let mut relative = Comparison::new("raymarch twin vs f64 on the same inputs, relative");
    for case in 0..300 {
        let (finite, core) = (rng.next() < 0.5, rng.range(0.1, 3.0));
        let w = random_wave(&mut rng, finite, core);
        let o = w.origin + rng.unit() * rng.range(1.0, 200.0);
        let u = f32x3(rng.unit());
        let l = rng.range(0.0, 400.0) as f32;
        let steps = rng.pick(&[1u32, 7, 64, 1000, 4096]);
        let offset = rng.pick(&[0.0f32, 0.5, 0.25]);
        let g = gpu_wave(&w, o);
        let twin = raymarch_f32(&g, u, l, steps, offset) as f64;
        let fair = raymarch_frame(&g.to_frame(), widen(u), l as f64, steps, offset as f64);
        assert!(twin >= 0.0, "case {case}: {twin}");
        let bound = raymarch_bound(&g.to_frame(), widen(u), l as f64, steps, offset as f64, &TWIN_MARCH);
        let at = format_args!("case {case} (steps {steps}, bound {bound:.2e})");
        let e = relative.rel(at, twin, fair);
        march.error(format_args!("case {case} (steps {steps}, rel {e:.2e}, bound {bound:.2e})"), e / bound);
    }
    eprintln!("{}", relative.summary());
    march.assert_within(1.0, 300);

    // Convergence to the closed form on a smooth case (ε > 0), in f32 and in f64.
    let w = WaveParams {
        origin: DVec3::new(3.0, -1.0, 2.0),
        direction: DVec3::new(2.0, -1.0, 2.0) / 3.0,
        a: 5.0,
        b: 3.0,
        core: 0.3,
        length: 6.0,
    };
    let o = DVec3::new(-6.0, 4.0, -2.0);
    let u = f32x3((w.origin + 4.0 * w.direction + DVec3::new(0.0, 0.2, -0.1) - o).normalize());
    let l = 25.0f32;
    let g = gpu_wave(&w, o);
    let closed = line_integral_f32(&g, u, l) as f64;
    let closed64 = line_integral_frame(&g.to_frame(), widen(u), l as f64);
    let mut last = (f64::MAX, f64::MAX);
    for n in [16u32, 64, 256, 1024] {
        let e32 = rel(raymarch_f32(&g, u, l, n, 0.5) as f64, closed);
        let e64 = rel(raymarch_frame(&g.to_frame(), widen(u), l as f64, n, 0.5), closed64);
        eprintln!("raymarch n = {n:5}: f32 {e32:.2e}, f64 {e64:.2e}");
        // Midpoint rule: O(1/N²), 16× per 4× steps; allow 8× (and the f32 floor).
        assert!(e64 < last.1 / 8.0, "f64 n = {n}: {e64:e}");
        assert!(e32 < last.0 / 8.0 || e32 < 1e-5, "f32 n = {n}: {e32:e}");
        last = (e32, e64);
    }
    assert!(last.0 < 1e-4 && last.1 < 1e-4);
}

fn unit_vec() -> impl Strategy<Value = DVec3> {
    (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
        .prop_filter("not too short", |(x, y, z)| x * x + y * y + z * z > 1e-3)
        .prop_map(|(x, y, z)| DVec3::new(x, y, z).normalize())
}

fn coord(max: f64) -> impl Strategy<Value = DVec3> {
    (-max..max, -max..max, -max..max).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

/// The worst relative error the proptest has seen (f64 bits), printed as it grows.
static PROPTEST_WORST: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

proptest! {
    #![proptest_config(ProptestConfig { cases: 20_000, ..ProptestConfig::default() })]

    #[test]
    fn twin_is_finite_nonnegative_and_close_to_f64(
        a in 0.0f64..1e3,
        b in 0.0f64..1e3,
        core in prop_oneof![Just(0.0), 0.0f64..10.0],
        length in prop_oneof![Just(f64::INFINITY), 1e-3f64..1e3],
        origin in coord(1e3),
        direction in unit_vec(),
        camera in coord(1e4),
        u in unit_vec(),
        l in prop_oneof![Just(0.0), 0.0f64..1e4],
    ) {
        let w = WaveParams { origin, direction, a, b, core, length };
        let (twin, fair, _) = evaluate(&w, camera, u, l);
        prop_assert!(twin.is_finite() && twin >= 0.0, "twin {}", twin);
        // Every term is a sum of positive pieces, so relative accuracy holds down to 0; the
        // absolute floor only covers results that underflow f32.
        prop_assert!((twin - fair).abs() <= EVERY_CASE * fair + 1e-30, "twin {:e} f64 {:e}", twin, fair);
        let e = rel(twin, fair);
        let old = PROPTEST_WORST.fetch_max(e.to_bits(), std::sync::atomic::Ordering::Relaxed);
        if e.to_bits() > old {
            eprintln!("proptest: new worst relative error, twin vs f64: {e:.2e}");
        }
    }
}
