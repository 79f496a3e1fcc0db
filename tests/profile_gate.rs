//! The frame-time regression gate on synthetic samples with known truth, over many seeds (each
//! fixed): it finds a 10 % slowdown, and on A/A it raises no alarm at the 5 % threshold and
//! alarms at its stated rate (one tail of the interval) at threshold 0.

mod common;

use hadou_cli::profile_diff::{diff, GateOptions, Rng, Verdict};

/// Frame times of one run: median `ms` × exp(σ·x) with x an AR(1) series (ρ = 0.5, unit
/// variance): neighbouring frames on lavapipe are correlated, which the block bootstrap must
/// take into account.
fn run(rng: &mut Rng, frames: usize, ms: f64, sigma: f64) -> Vec<f64> {
    let rho: f64 = 0.5;
    let mut x = rng.normal();
    (0..frames)
        .map(|_| {
            x = rho * x + (1.0 - rho * rho).sqrt() * rng.normal();
            ms * (sigma * x).exp()
        })
        .collect()
}

/// Runs of one side, each shifted as a whole by exp(drift·z): the run-to-run spread.
fn side(rng: &mut Rng, runs: usize, frames: usize, ms: f64, sigma: f64, drift: f64) -> Vec<Vec<f64>> {
    (0..runs)
        .map(|_| {
            let shift = (drift * rng.normal()).exp();
            run(rng, frames, ms * shift, sigma)
        })
        .collect()
}

/// Fraction of `seeds` seeds on which the gate says `want`.
fn rate(
    seeds: u64,
    want: Verdict,
    threshold: f64,
    make: impl Fn(&mut Rng) -> (Vec<Vec<f64>>, Vec<Vec<f64>>),
) -> f64 {
    let hits = (0..seeds)
        .filter(|&seed| {
            let mut rng = Rng::new(1000 + seed);
            let (a, b) = make(&mut rng);
            let opts = GateOptions { threshold, resamples: 1000, seed, ..GateOptions::default() };
            diff(&a, &b, &opts).unwrap().verdict == want
        })
        .count();
    let r = hits as f64 / seeds as f64;
    eprintln!("{want:?} at threshold {threshold}: {:.2} % of {seeds} seeds", r * 100.0);
    r
}

// Frame noise σ = 5 % (what a pass shows within one run on lavapipe: docs/PERFORMANCE.md),
// 150 frames a side.
const SIGMA: f64 = 0.05;
const FRAMES: usize = 150;

#[test]
fn a_ten_percent_slowdown_is_found() {
    let found = rate(200, Verdict::Slower, 0.05, |rng| {
        (side(rng, 1, FRAMES, 2.0, SIGMA, 0.0), side(rng, 1, FRAMES, 2.2, SIGMA, 0.0))
    });
    // The interval of the ratio is about ±2.5 % wide here, so 1.10 clears 1.05 nearly always.
    assert!(found >= 0.95, "a 10 % slowdown found on {:.1} % of seeds", found * 100.0);
    // A 10 % speed-up is "faster", never "slower".
    let faster = rate(200, Verdict::Faster, 0.05, |rng| {
        (side(rng, 1, FRAMES, 2.2, SIGMA, 0.0), side(rng, 1, FRAMES, 2.0, SIGMA, 0.0))
    });
    assert!(faster >= 0.95, "{faster}");
}

#[test]
fn a_a_raises_no_alarm_at_the_threshold_and_the_stated_rate_at_zero() {
    let same = |rng: &mut Rng| (side(rng, 1, FRAMES, 2.0, SIGMA, 0.0), side(rng, 1, FRAMES, 2.0, SIGMA, 0.0));
    let alarms = rate(400, Verdict::Slower, 0.05, same);
    assert_eq!(alarms, 0.0, "A/A alarms at 5 %: {:.2} %", alarms * 100.0);
    // At threshold 0 the gate is a one-sided test at (1 − 0.95) / 2 = 2.5 %: over 400 seeds the
    // count is Binomial(400, 0.025) ≈ 10 ± 3; [2, 24] holds it with probability > 99.9 %, while
    // an interval too narrow or too wide by half lands outside it.
    let zero = rate(400, Verdict::Slower, 0.0, same);
    assert!((0.005..=0.06).contains(&zero), "A/A alarms at threshold 0: {:.2} %", zero * 100.0);
}

#[test]
fn runs_that_drift_are_resampled_as_runs() {
    // Eight runs a side, each run shifted by ~8 % as a whole: what a shared machine does.
    let drift = 0.08;
    let same = |rng: &mut Rng| (side(rng, 8, 40, 2.0, SIGMA, drift), side(rng, 8, 40, 2.0, SIGMA, drift));
    let alarms = rate(200, Verdict::Slower, 0.0, same);
    assert!(alarms <= 0.06, "A/A with drifting runs at threshold 0: {:.1} %", alarms * 100.0);
    // The same frames pooled as if from one run each: the interval ignores the drift and
    // alarms far more often. This is why `profile --ab` keeps runs apart.
    let pooled = rate(200, Verdict::Slower, 0.0, |rng| {
        let (a, b) = same(rng);
        (vec![a.concat()], vec![b.concat()])
    });
    assert!(pooled > 2.0 * alarms.max(0.025), "pooled {pooled}, by runs {alarms}");
    // And a 25 % slowdown still shows through the drift at the 5 % threshold.
    let found = rate(200, Verdict::Slower, 0.05, |rng| {
        (side(rng, 8, 40, 2.0, SIGMA, drift), side(rng, 8, 40, 2.5, SIGMA, drift))
    });
    assert!(found >= 0.9, "25 % through drift: {found}");
}

mod cli {
    use std::path::Path;

    use super::common;
    use common::cli::{hadou, s, scratch, text};

    /// A profile file with synthetic samples: tonemap at `ms` ± 2 %, raster at 3 ms ± 2 %.
    fn synthetic(path: &Path, ms: f64) {
        let series = |m: f64| -> Vec<f64> {
            (0..60).map(|i| m * (1.0 + 0.02 * ((i * 7 % 11) as f64 / 5.0 - 1.0))).collect()
        };
        let json = serde_json::json!({
            "scene": "synthetic.toml", "width": 64, "height": 64, "build_profile": "release",
            "device": {"name": "test"},
            "samples": {
                "gpu tonemap": {"runs": [series(ms)]},
                "gpu raster": {"runs": [series(3.0)]},
                "cpu frame": {"runs": [series(9.0)]},
            }
        });
        std::fs::write(path, json.to_string()).unwrap();
    }

    #[test]
    fn profile_diff_flags_the_slower_pass_and_only_it() {
        let dir = scratch("diff");
        let (base, slow) = (dir.join("base.json"), dir.join("slow.json"));
        synthetic(&base, 1.0);
        synthetic(&slow, 1.2);
        let out = hadou(&["profile-diff", s(&base), s(&slow), "--threshold", "5%"]);
        assert_eq!(out.status.code(), Some(1), "{}", text(&out));
        let t = text(&out);
        let row = |name: &str| t.lines().find(|l| l.starts_with(name)).unwrap_or_default().to_string();
        assert!(row("gpu tonemap").ends_with("SLOWER") && row("gpu tonemap").contains("+20.0%"), "{t}");
        assert!(row("gpu raster").ends_with("within noise"), "{t}");
        assert!(t.contains("gate: FAIL: 1 slower"), "{t}");
        // The threshold is respected: +20 % is inside 25 %.
        assert_eq!(hadou(&["profile-diff", s(&base), s(&slow), "--threshold", "25%"]).status.code(), Some(0));
        // The other way round it is faster, which passes.
        let out = hadou(&["profile-diff", s(&slow), s(&base)]);
        assert_eq!(out.status.code(), Some(0), "{}", text(&out));
        assert!(text(&out).contains("faster"), "{}", text(&out));
        // Files without raw samples, or not profiles at all, are errors naming them.
        let old = dir.join("old.json");
        std::fs::write(&old, r#"{"scene": "s.toml", "width": 1, "height": 1}"#).unwrap();
        let out = hadou(&["profile-diff", s(&old), s(&base)]);
        assert_eq!(out.status.code(), Some(2));
        assert!(text(&out).contains("old.json: no raw per-frame samples"), "{}", text(&out));
        let junk = dir.join("junk.json");
        std::fs::write(&junk, "[1, 2").unwrap();
        let out = hadou(&["profile-diff", s(&base), s(&junk)]);
        assert_eq!(out.status.code(), Some(2));
        assert!(text(&out).contains("junk.json: not a `hadou profile --json` file"), "{}", text(&out));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Every run with HADOU_VALIDATION=1 (`common::cli::hadou`; the A/B children inherit it):
    /// `profile` exits non-zero on any validation error or warning, so each success asserted
    /// here is also a clean validation log (tests/cli.rs shows the check failing a run).
    #[test]
    fn profile_keeps_raw_samples_and_ab_interleaves_runs() {
        let dir = scratch("ab");
        let json = dir.join("p.json");
        let scene = "assets/scenes/single_cube.toml";
        let out = hadou(&[
            "profile",
            scene,
            "--size",
            "32x32",
            "--frames",
            "4",
            "--warmup",
            "1",
            "--json",
            s(&json),
        ]);
        assert!(out.status.success(), "{}", text(&out));
        let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let raster = &v["samples"]["gpu raster"]["runs"];
        assert_eq!(raster.as_array().unwrap().len(), 1);
        assert_eq!(raster[0].as_array().unwrap().len(), 4, "{v}");
        assert!(v["samples"]["cpu frame"]["runs"][0][3].as_f64().unwrap() > 0.0);

        // This binary against itself, two rounds: pooled runs in both files, and a verdict. Two
        // rounds of 4 frames give 8 a side, above the 6 a 95 % interval needs (fewer cannot pass).
        let (a, b) = (dir.join("a.json"), dir.join("b.json"));
        let bin = env!("CARGO_BIN_EXE_hadou");
        let out = hadou(&[
            "profile",
            scene,
            "--size",
            "32x32",
            "--frames",
            "4",
            "--warmup",
            "1",
            "--ab",
            bin,
            "--rounds",
            "2",
            "--threshold",
            "1000%",
            "--json",
            s(&a),
            "--json-other",
            s(&b),
        ]);
        assert_eq!(out.status.code(), Some(0), "{}", text(&out));
        assert!(
            text(&out).contains("2 rounds of 4 frames each, interleaved")
                && text(&out).contains("gate: pass")
        );
        for f in [&a, &b] {
            let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(f).unwrap()).unwrap();
            assert_eq!(v["samples"]["gpu raster"]["runs"].as_array().unwrap().len(), 2, "{v}");
        }
        // An OTHER that is not a hadou is an error (exit 2), and nothing is written.
        let (c, d) = (dir.join("c.json"), dir.join("d.json"));
        let out = hadou(&[
            "profile",
            scene,
            "--size",
            "32x32",
            "--frames",
            "2",
            "--ab",
            "/bin/false",
            "--json",
            s(&c),
            "--json-other",
            s(&d),
        ]);
        assert_eq!(out.status.code(), Some(2), "{}", text(&out));
        assert!(text(&out).contains("/bin/false profile failed"), "{}", text(&out));
        assert!(!c.exists() && !d.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
