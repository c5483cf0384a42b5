#!/usr/bin/env bash
# Equal-time curves: runs photongi-bench-equal-time on each scene (every exact estimator's
# progressive mode and the path tracer at the same wall-time budgets, against a converged
# path-traced reference) and plots FLIP, PSNR and relMSE against time (gnuplot).
#
# Usage: bench/equal_time.sh [--scenes "cornell sibenik"] [--budgets 0.25,1,4,16]
#          [--estimators exact|all|a,b] [--ref-spp N] [--bin-dir DIR] [--out DIR]
#          [--emission-variants] [--tag T]
# --emission-variants: each estimator with uniform/guided emission, storing all photons or only
# those in view (RADIUS_<scene> gives the radius that needs, e.g. RADIUS_two_rooms=0.1); --tag T
# names the outputs equal_time_<scene>_T.*.
# Sizes: cornell 256x256, sibenik 480x270, others their own (SIZE_<scene> overrides, e.g.
# SIZE_sibenik=960x540). Outputs: DIR/equal_time_<scene>.csv and .png (default bench/results).
# The references are cached in $PHOTONGI_CACHE (default ~/.cache/photongi). Run it on a quiet
# machine: every number is a wall time.
set -euo pipefail

here=$(cd "$(dirname "$0")/.." && pwd)
BIN_DIR="$here/build/bin"
SCENES="cornell sibenik"
BUDGETS=0.25,1,4,16
ESTIMATORS=exact
REF_SPP=1024
OUT="$here/bench/results"
VARIANTS=""
TAG=""
while [ $# -gt 0 ]; do
  case "$1" in
    --scenes) SCENES=$2; shift 2 ;;
    --budgets) BUDGETS=$2; shift 2 ;;
    --estimators) ESTIMATORS=$2; shift 2 ;;
    --ref-spp) REF_SPP=$2; shift 2 ;;
    --bin-dir) BIN_DIR=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --emission-variants) VARIANTS=--emission-variants; shift ;;
    --tag) TAG=_$2; shift 2 ;;
    -h|--help) sed -n '2,/^set -e/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "equal_time.sh: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
done
BIN="$BIN_DIR/photongi-bench-equal-time"
[ -x "$BIN" ] || { echo "equal_time.sh: $BIN not found: build first (cmake --build build)" >&2; exit 1; }
export PHOTONGI_SCENES=${PHOTONGI_SCENES:-$here/../shared/scenes}
mkdir -p "$OUT"
cd "$here"   # scene names resolve through ./scenes/<name>.json

default_size() { case "$1" in cornell) echo 256x256 ;; sibenik) echo 480x270 ;; *) echo "" ;; esac; }

for scene in $SCENES; do
  var="SIZE_${scene//-/_}"
  size=${!var:-$(default_size "$scene")}
  rvar="RADIUS_${scene//-/_}"
  radius=${!rvar:-}
  csv="$OUT/equal_time_${scene}${TAG}.csv"
  "$BIN" --scene "$scene" ${size:+--size "$size"} --budgets "$BUDGETS" --estimators "$ESTIMATORS" \
    --ref-spp "$REF_SPP" --csv "$csv" ${radius:+--radius "$radius"} $VARIANTS
  if ! command -v gnuplot >/dev/null 2>&1; then
    echo "equal_time.sh: gnuplot not found (scripts/install-deps.sh installs gnuplot-nox): no plot" >&2
    continue
  fi
  # one data block per method: time, FLIP, PSNR, relMSE
  dat="$OUT/equal_time_${scene}${TAG}.dat"
  methods=$(awk -F, 'NR > 1 && !seen[$2]++ { print $2 }' "$csv")
  : > "$dat"
  for m in $methods; do
    echo "\"$m\"" >> "$dat"
    awk -F, -v m="$m" 'NR > 1 && $2 == m { print $4, $8, ($6 == "inf" ? 99 : $6), $9 }' "$csv" >> "$dat"
    printf '\n\n' >> "$dat"
  done
  n=$(echo $methods | wc -w)
  read -r W H REF < <(awk -F, 'NR == 2 { print $10, $11, $13 }' "$csv")
  gnuplot <<EOF
set terminal pngcairo size 1500,450 font ",10"
set output "$OUT/equal_time_${scene}${TAG}.png"
set multiplot layout 1,3 title "$scene ${W}x${H}: error against a ${REF}-spp path-traced reference at equal wall time ($(nproc) cores)"
set logscale x
set xlabel "wall time (s)"
set grid
set key top right
set ylabel "FLIP (mean)"
plot for [i=0:$((n - 1))] "$dat" index i using 1:2 with linespoints title columnheader(1)
set ylabel "PSNR (dB)"
set key bottom right
plot for [i=0:$((n - 1))] "$dat" index i using 1:3 with linespoints title columnheader(1)
set ylabel "relMSE"
set logscale y
set key top right
plot for [i=0:$((n - 1))] "$dat" index i using 1:4 with linespoints title columnheader(1)
unset multiplot
EOF
  rm -f "$dat"
  echo "equal_time.sh: wrote $csv and $OUT/equal_time_${scene}${TAG}.png" >&2
done
