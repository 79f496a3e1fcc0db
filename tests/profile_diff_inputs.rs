//! `hadou profile-diff` on inputs a broken candidate or a careless CI script produces (issue 24):
//! none may end in `gate: pass`, none may panic or hang. Each case here passed (exit 0), panicked
//! (exit 101) or hung before.

mod common;

use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use common::cli::{s, scratch, text};

/// How long one of these runs may take: each is an error found before any bootstrap, or a
/// bootstrap of a few hundred frames (well under a second in a debug build). A hang (a FIFO read)
/// or an unbounded bootstrap (10⁸ resamples took minutes) fails here instead of stalling.
const LIMIT: Duration = Duration::from_secs(20);

/// `hadou profile-diff ARGS` under `LIMIT` and a 2 GiB address-space cap (a debug hadou maps
/// about 100 MiB; the cap turns a runaway allocation into a failed run, not a swapped machine).
fn profile_diff(args: &[&str]) -> Output {
    let mut cmd = Command::new("prlimit");
    cmd.arg(format!("--as={}", 2u64 << 30)).arg("--").arg(env!("CARGO_BIN_EXE_hadou")).arg("profile-diff");
    cmd.args(args).current_dir(common::root()).env("HADOU_VALIDATION", "1");
    let start = Instant::now();
    let out = common::cli::output_within(&mut cmd, LIMIT);
    eprintln!("profile-diff {args:?}: {:?} in {:.2?}", out.status, start.elapsed());
    out
}

/// Sixty frames around `ms` (± 2 %).
fn series(ms: f64, frames: usize) -> Vec<serde_json::Value> {
    (0..frames).map(|i| serde_json::json!(ms * (1.0 + 0.02 * ((i * 7 % 11) as f64 / 5.0 - 1.0)))).collect()
}

/// A `profile --json`-shaped file with `samples`.
fn write(path: &Path, samples: serde_json::Value) {
    let json = serde_json::json!({
        "scene": "synthetic.toml", "width": 64, "height": 64, "build_profile": "debug",
        "device": {"name": "test"}, "samples": samples,
    });
    std::fs::write(path, json.to_string()).unwrap();
}

/// The baseline: two GPU passes and the CPU frame, 60 frames each.
fn base(path: &Path) {
    write(
        path,
        serde_json::json!({
            "gpu tonemap": {"runs": [series(1.0, 60)]},
            "gpu raster": {"runs": [series(3.0, 60)]},
            "cpu frame": {"runs": [series(9.0, 60)]},
        }),
    );
}

/// Exit 2 with `error:` and `says` in the output, and no `gate: pass`.
fn refused(out: &Output, says: &str) {
    let t = text(out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("error:") && t.contains(says), "expected {says:?}:\n{t}");
    assert!(!t.contains("gate: pass"), "{t}");
}

#[test]
fn a_broken_candidate_never_passes() {
    let dir = scratch("pd-broken");
    let b = dir.join("base.json");
    base(&b);
    let case = |name: &str, samples: serde_json::Value| {
        let p = dir.join(name);
        write(&p, samples);
        p
    };
    // No rows at all.
    let empty = case("empty.json", serde_json::json!({}));
    refused(&profile_diff(&[s(&b), s(&empty)]), "empty.json: /samples has no rows");
    // Every pass renamed: nothing of the base is in the candidate.
    let renamed = case(
        "renamed.json",
        serde_json::json!({
            "gpu tonemap v2": {"runs": [series(1.0, 60)]},
            "gpu raster v2": {"runs": [series(3.0, 60)]},
            "cpu frame": {"runs": [series(9.0, 60)]},
        }),
    );
    let out = profile_diff(&[s(&b), s(&renamed)]);
    refused(&out, "the gate cannot judge 2 gated rows of");
    assert!(text(&out).contains("gpu tonemap: only in base (missing or renamed"), "{}", text(&out));
    // One pass dropped, the other fine: still not a pass.
    let dropped = case(
        "dropped.json",
        serde_json::json!({"gpu raster": {"runs": [series(3.0, 60)]}, "cpu frame": {"runs": [series(9.0, 60)]}}),
    );
    refused(&profile_diff(&[s(&b), s(&dropped)]), "gpu tonemap: only in base");
    // Empty runs, and runs of untimed frames only.
    let runs = case(
        "empty_runs.json",
        serde_json::json!({
            "gpu tonemap": {"runs": []},
            "gpu raster": {"runs": [[], [null, null]]},
            "cpu frame": {"runs": [[]]},
        }),
    );
    refused(&profile_diff(&[s(&b), s(&runs)]), "gpu raster: new has 0 timed frame(s), fewer than the 6");
    // One frame 20 % slower: before, a zero-width interval and "SLOWER" (exit 1); one frame
    // cannot show a change. Five frames are still too few at 95 %, six are enough.
    let one = case(
        "one.json",
        serde_json::json!({"gpu tonemap": {"runs": [[1.2]]}, "gpu raster": {"runs": [[3.0]]}}),
    );
    refused(&profile_diff(&[s(&b), s(&one)]), "gpu tonemap: new has 1 timed frame(s)");
    let five = case(
        "five.json",
        serde_json::json!({"gpu tonemap": {"runs": [series(1.0, 5)]}, "gpu raster": {"runs": [series(3.0, 5)]}}),
    );
    refused(&profile_diff(&[s(&b), s(&five)]), "new has 5 timed frame(s), fewer than the 6");
    // As a baseline too: the gate cannot judge against a baseline it cannot measure.
    refused(&profile_diff(&[s(&five), s(&b)]), "base has 5 timed frame(s)");
    let six = case(
        "six.json",
        serde_json::json!({"gpu tonemap": {"runs": [series(1.0, 6)]}, "gpu raster": {"runs": [series(3.0, 6)]}}),
    );
    let out = profile_diff(&[s(&b), s(&six)]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    assert!(text(&out).contains("gate: pass"), "{}", text(&out));
    // A candidate of CPU rows only leaves no GPU row of the base judged.
    let cpu = case("cpu.json", serde_json::json!({"cpu frame": {"runs": [series(9.0, 60)]}}));
    refused(&profile_diff(&[s(&b), s(&cpu)]), "the gate cannot judge 2 gated rows");
    // And a baseline with nothing gated cannot pass anything.
    refused(&profile_diff(&[s(&cpu), s(&cpu)]), "the base has no `gpu …` rows");
    // A median of 0 ms makes no ratio.
    let zero = case(
        "zero.json",
        serde_json::json!({"gpu tonemap": {"runs": [vec![0.0; 60]]}, "gpu raster": {"runs": [series(3.0, 60)]}}),
    );
    refused(&profile_diff(&[s(&b), s(&zero)]), "gpu tonemap: the new median is 0 ms");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn samples_that_are_not_times_are_refused_by_their_json_pointer() {
    let dir = scratch("pd-negative");
    let b = dir.join("base.json");
    base(&b);
    let mut frames = series(1.0, 60);
    frames[7] = serde_json::json!(-0.5);
    let neg = dir.join("negative.json");
    write(
        &neg,
        serde_json::json!({"gpu tone/map": {"runs": [series(1.0, 60), frames]}, "gpu raster": {"runs": [series(3.0, 60)]}}),
    );
    refused(
        &profile_diff(&[s(&b), s(&neg)]),
        "negative.json: /samples/gpu tone~1map/runs/1/7: -0.5 is not a frame time",
    );
    // Every sample negative: before, the row was "no timed frames on one side" and passed.
    let all: Vec<f64> = (0..60).map(|i| -1.0 - i as f64).collect();
    write(
        &neg,
        serde_json::json!({"gpu tonemap": {"runs": [all]}, "gpu raster": {"runs": [series(3.0, 60)]}}),
    );
    refused(&profile_diff(&[s(&neg), s(&b)]), "/samples/gpu tonemap/runs/0/0: -1 is not a frame time");
    // JSON has no NaN or infinity; a number beyond f64 is a parse error naming the place.
    let text = std::fs::read_to_string(&b).unwrap().replacen("1.0", "1e999", 1);
    let huge = dir.join("huge.json");
    std::fs::write(&huge, text).unwrap();
    refused(&profile_diff(&[s(&b), s(&huge)]), "huge.json: not a `hadou profile --json` file");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn resamples_are_bounded() {
    let dir = scratch("pd-resamples");
    let b = dir.join("base.json");
    base(&b);
    // usize::MAX panicked (capacity overflow, exit 101); 10⁸ ran for minutes.
    for n in ["18446744073709551615", "100000000", "100001"] {
        let out = profile_diff(&[s(&b), s(&b), "--resamples", n]);
        refused(&out, &format!("--resamples {n}: expected at most 100000"));
    }
    refused(&profile_diff(&[s(&b), s(&b), "--resamples", "99"]), "--resamples 99: expected at least 100");
    // The maximum itself runs (3 rows of 60 frames: well under the limit).
    let out = profile_diff(&[s(&b), s(&b), "--resamples", "100000"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn inputs_that_are_not_regular_files_are_refused_without_blocking() {
    let dir = scratch("pd-fifo");
    let b = dir.join("base.json");
    base(&b);
    let fifo = dir.join("new.json");
    let ok = Command::new("mkfifo").arg(&fifo).status().unwrap().success();
    assert!(ok, "mkfifo");
    // Before: blocked forever in open(2), waiting for a writer.
    refused(&profile_diff(&[s(&b), s(&fifo)]), "new.json: not a regular file");
    refused(&profile_diff(&[s(&fifo), s(&b)]), "new.json: not a regular file");
    // A device never ends; a folder is not a file.
    refused(&profile_diff(&[s(&b), "/dev/zero"]), "/dev/zero: not a regular file");
    refused(&profile_diff(&[s(&dir), s(&b)]), "not a regular file");
    std::fs::remove_dir_all(&dir).unwrap();
}
