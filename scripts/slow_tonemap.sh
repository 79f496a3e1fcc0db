#!/usr/bin/env bash
# A copy of shaders/ whose tonemap pass carries a known busy cost, for measuring the frame-time
# gate (docs/PERFORMANCE.md, "Frame-time regression gate"): the image is unchanged, the pass is
# slower by what ITERS dependent iterations per pixel cost.
#   scripts/slow_tonemap.sh ITERS OUT_DIR
#   HADOU_SHADER_DIR=OUT_DIR hadou profile ...      # the slowed pass
set -euo pipefail
iters=${1:?usage: slow_tonemap.sh ITERS OUT_DIR}
out=${2:?usage: slow_tonemap.sh ITERS OUT_DIR}
here=$(cd "$(dirname "$0")/.." && pwd)
rm -rf "$out"
cp -r "$here/shaders" "$out"
# After `void main() {`: a loop the compiler cannot drop (its result decides a return that
# never happens: fract() < 1).
sed -i "/^void main() {/a\\
    float busy = float(gl_GlobalInvocationID.x) * 0.001;\\
    for (int i = 0; i < $iters; ++i) busy = fract(busy * 1.000123 + 0.618034);\\
    if (busy > 2.0) return;" "$out/tonemap.comp"
grep -q "busy > 2.0" "$out/tonemap.comp"
