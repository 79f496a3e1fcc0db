#!/usr/bin/env python3
"""Measures the frame-time gate on this machine (docs/PERFORMANCE.md, "Frame-time regression
gate"): how often `hadou profile-diff` (one run each side) and `hadou profile --ab` (interleaved
runs) flag a pass as slower when nothing changed (A/A: false positives) and when the tonemap pass
carries a known busy cost (A/B: detections).

    python3 scripts/gate_detection.py [--trials 20] [--bin target/release/hadou] > table.md

A and B are the same binary; B compiles its shaders from a copy whose tonemap has ITERS busy
iterations per pixel (scripts/slow_tonemap.sh), A from an unmodified copy, so only that cost
differs. The busy cost itself is measured first, in alternating long runs."""
import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def sh(cmd, env=None, check=True):
    r = subprocess.run(cmd, env={**os.environ, **(env or {})}, capture_output=True, text=True)
    if check and r.returncode not in (0, 1):
        sys.exit(f"{' '.join(map(str, cmd))} failed ({r.returncode}): {r.stderr[-800:]}")
    return r


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=str(ROOT / "target/release/hadou"))
    ap.add_argument("--scene", default="assets/scenes/showcase.toml")
    ap.add_argument("--size", default="160x90")
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--ab-trials", type=int, default=10)
    ap.add_argument("--iters", default="6,16")
    ap.add_argument("--frames", default="30,120")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="hadou-gate-"))
    dirs = {0: tmp / "shaders0"}
    sh(["bash", ROOT / "scripts/slow_tonemap.sh", "0", dirs[0]])
    iters = [int(i) for i in args.iters.split(",")]
    for it in iters:
        dirs[it] = tmp / f"shaders{it}"
        sh(["bash", ROOT / "scripts/slow_tonemap.sh", str(it), dirs[it]])

    def profile(it, frames, out):
        cmd = [args.bin, "profile", args.scene, "--size", args.size, "--frames", str(frames), "--warmup", "5",
               "--json", str(out)]
        sh(cmd, env={"HADOU_SHADER_DIR": str(dirs[it])})

    def p50(path, row):
        v = sorted(x for x in json.loads(Path(path).read_text())["samples"][row]["runs"][0] if x is not None)
        return v[len(v) // 2]

    # The true cost of each busy variant: 6 alternating runs of 200 frames.
    truth = {}
    for it in iters:
        base, slow = [], []
        for r in range(6):
            for side, lst in ((0, base), (it, slow)) if r % 2 == 0 else ((it, slow), (0, base)):
                profile(side, 200, tmp / "t.json")
                lst.append(p50(tmp / "t.json", "gpu tonemap"))
        base.sort(), slow.sort()
        truth[it] = (base[3] + base[2]) / 2, (slow[3] + slow[2]) / 2
        print(f"busy {it}: tonemap p50 {truth[it][0]:.3f} -> {truth[it][1]:.3f} ms "
              f"({(truth[it][1] / truth[it][0] - 1) * 100:+.1f} %), runs {base} / {slow}", file=sys.stderr)

    def flagged(stdout):
        # Rows the gate calls SLOWER.
        return {line.split("  ")[0].strip() for line in stdout.splitlines() if line.rstrip().endswith("SLOWER")}

    rows = []
    for frames in [int(f) for f in args.frames.split(",")]:
        for it in [0] + iters:
            any_fp, tone = 0, 0
            for t in range(args.trials):
                a, b = tmp / "a.json", tmp / "b.json"
                # Alternate which side runs first, as a CI job would not: here only the order's
                # bias is removed, the drift between two runs remains.
                if t % 2 == 0:
                    profile(0, frames, a), profile(it, frames, b)
                else:
                    profile(it, frames, b), profile(0, frames, a)
                r = sh([args.bin, "profile-diff", str(a), str(b), "--threshold", "5%"])
                f = flagged(r.stdout)
                tone += "gpu tonemap" in f
                any_fp += bool(f - {"gpu tonemap", "gpu frame"}) if it else bool(f)
            rows.append(("profile-diff, 1 run each", frames, it, args.trials, tone, any_fp))
            print(rows[-1], file=sys.stderr)
    wrapper = tmp / "hadou-slow"
    for it in [0] + iters:
        wrapper.write_text(f"#!/bin/sh\nHADOU_SHADER_DIR={dirs[it]} exec {args.bin} \"$@\"\n")
        wrapper.chmod(0o755)
        frames = int(args.frames.split(",")[0])
        tone, any_fp = 0, 0
        for t in range(args.ab_trials):
            r = sh([args.bin, "profile", args.scene, "--size", args.size, "--frames", str(frames), "--warmup", "5",
                    "--ab", str(wrapper), "--rounds", "6", "--threshold", "5%"],
                   env={"HADOU_SHADER_DIR": str(dirs[0])})
            f = flagged(r.stdout)
            tone += "gpu tonemap" in f
            any_fp += bool(f - {"gpu tonemap", "gpu frame"}) if it else bool(f)
        rows.append((f"profile --ab, 6 rounds", frames, it, args.ab_trials, tone, any_fp))
        print(rows[-1], file=sys.stderr)

    print("| gate | frames per run | tonemap slowed by | trials | tonemap flagged | other rows flagged |")
    print("|---|---|---|---|---|---|")
    for gate, frames, it, n, tone, fp in rows:
        slowed = "0 (A/A)" if it == 0 else f"{(truth[it][1] / truth[it][0] - 1) * 100:+.0f} % ({it} iterations)"
        print(f"| {gate} | {frames} | {slowed} | {n} | {tone}/{n} | {fp}/{n} |")


if __name__ == "__main__":
    main()
