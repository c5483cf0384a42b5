#!/usr/bin/env bash
# bench/gpu_suite.sh --local --quick from the bundle that test_bundle made (on lavapipe here), so that
# the one command a GPU session runs cannot rot between sessions: every step must pass, the report
# must hold each section's figures, and what the suite leaves in its output folder must come back
# through the device tool (at most 8 files, none deeper than two folders, names of letters, digits,
# '.', '_' and '-').
#
#   tests/test_gpu_suite.sh ARCHIVE OUT_DIR
# Exit 77 (skipped) when there is no archive (test_bundle skipped).
set -uo pipefail
SRC=$(cd "$(dirname "$0")/.." && pwd)
ARCHIVE=${1:?usage: test_gpu_suite.sh ARCHIVE OUT_DIR}
OUT=${2:?usage: test_gpu_suite.sh ARCHIVE OUT_DIR}
. "$SRC/tests/lib.sh" gpu-suite
# (test_bundle removes the archive first, and makes it again unless it skips)
[ -f "$ARCHIVE" ] || {
    echo "SKIP: no bundle at $ARCHIVE: test_bundle skipped (no scenes, or no mount namespaces)"
    exit 77
}
rm -rf "$OUT"
mkdir -p "$OUT"
cd "$SRC" || exit 1
bench/gpu_suite.sh --local --quick --budget 840 --bundle "$ARCHIVE" --out "$OUT" >"$OUT.log" 2>&1
rc=$?
tail -15 "$OUT.log"
[ "$rc" -eq 0 ] && ok "gpu_suite.sh --local --quick: every step passed" || bad "gpu_suite.sh exited $rc: $(grep -E 'failed|timeout|skipped' "$OUT.log" | head -5)"

md=$(ls "$OUT"/*.md 2>/dev/null | head -1)
csvf=$(ls "$OUT"/*.csv 2>/dev/null | head -1)
[ -n "$md" ] && ok "report $md" || bad "no markdown report in $OUT"
[ -n "$csvf" ] && ok "CSV $csvf" || bad "no CSV in $OUT"
for s in "## Summary" "## Correctness on the device" "### sibenik" "### crytek-sponza-paper" \
    "## Rays (photongi-bench-gpu-rays)" "## Photon tracing alone" "## The CPU frame by thread count" \
    "## Ray passes against raw Embree" "## The same frame on the GPU and on the CPU"; do
    grep -qF "$s" "${md:-/dev/null}" && ok "report has '$s'" || bad "report lacks '$s'"
done
# four GPU test programs, all passed, on the device
[ "$(grep -cE '^\| test_gpu[a-z_]* \| 0 \|' "${md:-/dev/null}")" = 4 ] && ok "4 GPU test programs passed" ||
    bad "GPU tests: $(grep -E '^\| test_gpu' "${md:-/dev/null}")"
# each GPU estimator on both scenes at both photon counts, and the CPU at 1 and 2 threads
for s in frame-sibenik frame-crytek-sponza-paper; do
    for e in hashgrid cluster-trivial directional tiled; do
        n=$(grep -c "^$s,.*,$e," "${csvf:-/dev/null}")
        [ "$n" = 2 ] && ok "$s $e: 2 rows" || bad "$s $e: $n rows in the CSV (want 2)"
    done
done
[ "$(grep -c '^cpu-scaling,' "${csvf:-/dev/null}")" = 2 ] && ok "cpu-scaling: 2 rows" || bad "cpu-scaling rows: $(grep -c '^cpu-scaling,' "${csvf:-/dev/null}")"
grep -qE '^\| [0-9.]+ \| 0\.[0-9]+ \|' "${md:-/dev/null}" && ok "PSNR/SSIM of the GPU image against the CPU's" ||
    bad "no image comparison in the report"
for f in sibenik-vulkan.png sibenik-cpu.png sibenik-diff.png raw.tar.gz suite.log; do
    [ -s "$OUT/$f" ] && ok "$f" || bad "$f missing"
done
grep -q 'Sibenik .* cluster-trivial: frame' "$OUT.log" && ok "the short table is printed last" || bad "no short table at the end of the output"
# what comes back from the device machine
n=$(find "$OUT" -mindepth 1 | wc -l)
[ "$n" -le 8 ] && ok "$n entries in the output folder (at most 8 come back)" || bad "$n entries in the output folder: at most 8 come back"
odd=$(find "$OUT" -mindepth 1 | sed "s|^$OUT/||" | grep -vE '^[A-Za-z0-9._-]+(/[A-Za-z0-9._-]+){0,2}$')
[ -z "$odd" ] && ok "names the device tool returns" || bad "names or depths the device tool does not return: $odd"

summary test_gpu_suite
