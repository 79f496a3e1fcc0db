//! `hadou report --quick` through the built binary with validation on: every CSV parses and holds
//! every row the report promises, the numbers that must be finite are, and report.md and the
//! decodable PNGs exist; it runs outside the source tree (built-in scenes). A bad `--out` fails
//! clearly and leaves nothing behind.

mod common;

use common::cli::{output_within, scratch};

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

use hadou_cli::report::csv::parse;
use hadou_cli::report::ReportOptions;

fn hadou() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hadou"));
    cmd.current_dir(common::root()).env("HADOU_VALIDATION", "1").env("XDG_RUNTIME_DIR", "/tmp");
    cmd
}

/// A CSV as (header, rows as column → value).
struct Csv {
    rows: Vec<HashMap<String, String>>,
}

impl Csv {
    fn read(path: &Path) -> Csv {
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut lines = parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(lines.len() >= 2, "{}: no rows", path.display());
        let header = lines.remove(0);
        for (i, l) in lines.iter().enumerate() {
            assert_eq!(l.len(), header.len(), "{} row {i}: width", path.display());
        }
        let rows = lines.into_iter().map(|l| header.iter().cloned().zip(l).collect()).collect();
        Csv { rows }
    }

    /// The row whose `key` column is `value`.
    fn row(&self, key: &str, value: &str) -> &HashMap<String, String> {
        self.rows
            .iter()
            .find(|r| r.get(key).map(String::as_str) == Some(value))
            .unwrap_or_else(|| panic!("no row with {key} = {value}"))
    }
}

/// The value of `column` in `row`, which must be a finite number (≥ 0 when `non_negative`).
fn finite(row: &HashMap<String, String>, column: &str) -> f64 {
    let text = row.get(column).unwrap_or_else(|| panic!("no column {column} in {row:?}"));
    let v: f64 = text.parse().unwrap_or_else(|_| panic!("{column} = `{text}` is not a number ({row:?})"));
    assert!(v.is_finite() && v >= 0.0, "{column} = {v} ({row:?})");
    v
}

#[test]
fn quick_report_has_every_row() {
    // Run in a folder of its own, not the source tree: the scenes are the built-in ones, as for an
    // installed binary.
    let dir = scratch("quick");
    let out = dir.join("report");
    let start = std::time::Instant::now();
    // It took 28 s on the loaded 2-core test machine; 20 minutes is only a hang guard.
    let run = output_within(
        hadou().current_dir(&dir).args(["report", "--quick", "--out", "report"]),
        Duration::from_secs(1200),
    );
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "hadou report failed:\n{stderr}");
    println!("hadou report --quick took {:.1} s", start.elapsed().as_secs_f64());
    assert!(!stderr.contains("report: ["), "a progress bar on a stderr that is not a terminal:\n{stderr}");
    let opts = ReportOptions::new(true);

    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    for needle in ["# Speed against error", "quick", "| device |", "| git revision |", "| CPU |"] {
        assert!(md.contains(needle), "report.md lacks `{needle}`");
    }

    let energy = Csv::read(&out.join("energy_wave.csv"));
    let mut labels = vec!["analytic, exact".to_string()];
    labels.extend(opts.raymarch_steps.iter().map(|n| format!("raymarch N = {n}")));
    for label in &labels {
        let row = energy.row("variant", label);
        for column in ["pass ms p50", "max rel err", "p99 rel err", "GFLOP/s", "% of FMA ceiling"] {
            finite(row, column);
        }
    }
    // The tolerance rows: time and error (no ceiling fraction: their arithmetic depends on how
    // many tiles are interpolated), each within its tolerance (plus the exact pass's 1e-4).
    for tolerance in hadou_cli::report::energy_wave::TOLERANCES {
        let row = energy.row("variant", &format!("tolerance {tolerance:e}"));
        finite(row, "pass ms p50");
        assert!(
            finite(row, "max rel err") <= (tolerance + 1e-4) * (1.0 + tolerance),
            "tolerance {tolerance:e}"
        );
    }
    assert_eq!(energy.rows.len(), labels.len() + hadou_cli::report::energy_wave::TOLERANCES.len());
    // The closed form is accurate to f32 rounding of the pixel ray (docs/PERFORMANCE.md: 6e-6 at
    // most): 1e-4 only catches a broken measurement, not a regression of the pass.
    assert!(finite(energy.row("variant", "analytic, exact"), "max rel err") < 1e-4);

    let tl = Csv::read(&out.join("translucency.csv"));
    let mut labels: Vec<String> = opts.voxel_res.iter().map(|r| format!("lut {r}")).collect();
    labels.extend(opts.peel_res.iter().map(|r| format!("peel {r}")));
    labels.extend(opts.pairs_res.iter().map(|r| format!("pairs {r}")));
    labels.push("tsm".into());
    for label in &labels {
        let row = tl.row("variant", label);
        assert!(finite(row, "pixels") > 0.0, "{label}: no translucent pixel");
        for column in [
            "translucency ms",
            "light_id ms",
            "thickness err mean (voxels)",
            "p95 (voxels)",
            "max (voxels)",
            "p95 (world)",
            "colour err mean",
            "colour max",
        ] {
            finite(row, column);
        }
        assert!(finite(row, "light map") >= 256.0);
        if label.starts_with("lut") || label.starts_with("pairs") {
            assert!(finite(row, "memory bytes") > 0.0);
            finite(row, "bake s");
            assert_eq!(row["peel ms"], "", "{label}: no peel pass");
        } else if label.starts_with("peel") {
            assert!(finite(row, "memory bytes") > 0.0, "{label}: the crossing lists");
            assert_eq!(row["bake s"], "", "{label}: nothing baked");
            finite(row, "peel ms");
        } else {
            assert_eq!(row["memory bytes"], "", "TSM has no table");
            assert_eq!(row["peel ms"], "", "TSM has no peel pass");
        }
    }
    assert_eq!(tl.rows.len(), labels.len());

    let mb = Csv::read(&out.join("metaballs.csv"));
    let variants = hadou_cli::report::metaballs::variant_methods();
    for (label, _) in &variants {
        let row = mb.row("variant", label);
        for column in ["pass ms p50", "hit mismatch %", "depth max rel err", "depth p99 rel err"] {
            finite(row, column);
        }
        assert!(finite(row, "reference hit pixels") > 0.0);
    }
    assert_eq!(mb.rows.len(), variants.len());

    let frame = Csv::read(&out.join("frame.csv"));
    for (w, h) in &opts.frame_sizes {
        let size = format!("{w}x{h}");
        for pass in ["raster", "light_id", "metaballs", "translucency", "energy_wave", "tonemap", "gpu frame"]
        {
            let row = frame
                .rows
                .iter()
                .find(|r| r["size"] == size && r["pass"] == pass)
                .unwrap_or_else(|| panic!("frame.csv: no row for {pass} at {size}"));
            for column in ["ms p50", "ms p95", "ms p99"] {
                finite(row, column);
            }
        }
    }

    // The frame budget: every level of both effects pinned, and three budgets' picks.
    let fronts = Csv::read(&out.join("budget_fronts.csv"));
    let levels = hadou::effects::energy_wave::effect::BUDGET_LEVELS.len()
        + hadou::effects::translucency_budget::BUDGET_LEVELS.len();
    assert_eq!(fronts.rows.len(), levels);
    for row in &fronts.rows {
        finite(row, "passes ms p50");
        finite(row, "error bound");
    }
    assert!(fronts.rows.iter().any(|r| r["on the front"] == "yes"));
    let picks = Csv::read(&out.join("budget_picks.csv"));
    assert_eq!(picks.rows.len(), hadou_cli::report::budget::BUDGET_SHARES.len());
    for row in &picks.rows {
        for column in ["budget ms", "gpu frame ms p50", "predicted ms", "summed error bound"] {
            finite(row, column);
        }
        assert!(row["levels"].contains("energy_wave") && row["levels"].contains("translucency"), "{row:?}");
    }

    let ceilings = Csv::read(&out.join("ceilings.csv"));
    for kernel in ["fma", "fma+add", "copy"] {
        let row = ceilings.row("kernel", kernel);
        assert!(finite(row, "best") > 0.0 && finite(row, "p50") > 0.0, "{kernel}: {row:?}");
    }
    // The arithmetic kernels' loop rounds were calibrated (a whole number, at least one).
    for kernel in ["fma", "fma+add"] {
        let rounds = finite(ceilings.row("kernel", kernel), "loop rounds");
        assert!(rounds >= 1.0 && rounds.fract() == 0.0, "{kernel}: {rounds} loop rounds");
    }

    for plot in ["energy_wave", "translucency", "metaballs", "metaballs_mismatch", "budget"] {
        let path = out.join(format!("{plot}.png"));
        let img = image::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(img.width() > 100 && img.height() > 100);
        assert!(md.contains(&format!("({plot}.png)")), "report.md does not show {plot}.png");
    }
    // Nothing but the report is left in the folder it ran in (no staging folder, no stray file).
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn out_that_is_a_file_is_refused_before_measuring() {
    let dir = scratch("bad-out");
    let file = dir.join("not_a_dir");
    std::fs::write(&file, b"keep me").unwrap();
    // Refused before any measurement: with no Vulkan driver to find, a run that reached the device
    // would fail on that instead.
    let mut cmd = hadou();
    cmd.args(["report", "--quick", "--out"]).arg(&file).env("VK_DRIVER_FILES", dir.join("no_driver.json"));
    let run = output_within(&mut cmd, Duration::from_secs(120));
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("not_a_dir") && stderr.contains("not a directory"), "{stderr}");
    assert_eq!(std::fs::read(&file).unwrap(), b"keep me");
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "something was left beside the file");
    std::fs::remove_dir_all(&dir).unwrap();
}
