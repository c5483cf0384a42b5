#!/usr/bin/env bash
# Equal-time curves: `photongi study` on each scene (every exact estimator's progressive mode and
# the path tracer at the same rendering-time budgets, against a converged path-traced reference),
# its equal-time rows gathered into one CSV a scene, and FLIP, PSNR and relMSE plotted against
# time (gnuplot).
#
# Usage: bench/equal_time.sh [--scenes "cornell sibenik"] [--budgets 0.25,1,4,16]
#          [--estimators exact|all|a,b] [--ref-spp N] [--photons N] [--bin PATH] [--out DIR]
#          [--emission-variants] [--tag T]
# --budgets: seconds. --emission-variants: each estimator (named in --estimators) with uniform and
# guided emission, storing all photons or only those in view (NAME, NAME+guided, NAME+view,
# NAME+guided+view; RADIUS_<scene> gives the radius that storing in view needs, e.g.
# RADIUS_two_rooms=0.1); --tag T names the outputs equal_time_<scene>_T.*.
# Sizes: cornell 256x256, sibenik 480x270, others their own (SIZE_<scene> overrides, e.g.
# SIZE_sibenik=960x540). Outputs: DIR/equal_time_<scene>.csv (scene, method, budget_s, time_s,
# steps, psnr, ssim, flip, relmse, width, height, photons, ref_spp) and .png (default
# bench/results), and the study's folder DIR/equal_time_<scene>/ (study.md, every image). The
# references are kept in $PHOTONGI_CACHE (default ~/.cache/photongi). Run it on a quiet machine:
# every number is a time.
set -euo pipefail

here=$(cd "$(dirname "$0")/.." && pwd)
BIN="$here/build/bin/photongi"
SCENES="cornell sibenik"
BUDGETS=0.25,1,4,16
ESTIMATORS=exact
REF_SPP=1024
PHOTONS=""
OUT="$here/bench/results"
VARIANTS=0
TAG=""
while [ $# -gt 0 ]; do
  case "$1" in
    --scenes) SCENES=$2; shift 2 ;;
    --budgets) BUDGETS=$2; shift 2 ;;
    --estimators) ESTIMATORS=$2; shift 2 ;;
    --ref-spp) REF_SPP=$2; shift 2 ;;
    --photons) PHOTONS=$2; shift 2 ;;
    --bin) BIN=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --emission-variants) VARIANTS=1; shift ;;
    --tag) TAG=_$2; shift 2 ;;
    -h|--help) sed -n '2,/^set -e/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "equal_time.sh: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
done
[ -x "$BIN" ] || { echo "equal_time.sh: $BIN not found: build first (cmake --build build)" >&2; exit 1; }
export PHOTONGI_SCENES=${PHOTONGI_SCENES:-$here/../shared/scenes}
CACHE=${PHOTONGI_CACHE:-$HOME/.cache/photongi}
mkdir -p "$OUT" "$CACHE"
cd "$here"   # scene names resolve through ./scenes/<name>.json

# the budgets in milliseconds, for study --time
BUDGETS_MS=$(python3 -c 'import sys; print(",".join("%g" % (float(b) * 1000) for b in sys.argv[1].split(",")))' "$BUDGETS")
METHODS=$ESTIMATORS
if [ "$VARIANTS" = 1 ]; then
  case ",$ESTIMATORS," in *,exact,*|*,all,*)
    echo "equal_time.sh: --emission-variants needs --estimators names (e.g. hashgrid)" >&2; exit 2 ;;
  esac
  METHODS=$(echo "$ESTIMATORS" | tr , '\n' | awk '{ printf "%s%s,%s+guided,%s+view,%s+guided+view", NR > 1 ? "," : "", $0, $0, $0, $0 }')
fi

default_size() { case "$1" in cornell) echo 256x256 ;; sibenik) echo 480x270 ;; *) echo "" ;; esac; }

for scene in $SCENES; do
  var="SIZE_${scene//-/_}"
  size=${!var:-$(default_size "$scene")}
  rvar="RADIUS_${scene//-/_}"
  radius=${!rvar:-}
  dir="$OUT/equal_time_${scene}${TAG}"
  csv="$OUT/equal_time_${scene}${TAG}.csv"
  mkdir -p "$dir"
  "$BIN" study --scene "$scene" ${size:+--size "$size"} ${PHOTONS:+--photons "$PHOTONS"} \
    ${radius:+--radius "$radius"} --estimators "$METHODS,pathtracer" --time "$BUDGETS_MS" --spp "$REF_SPP" \
    --reference "$CACHE/study_${scene}_${size:-default}_${REF_SPP}spp.exr" --out "$dir" >/dev/null
  # study.csv's equal-time rows, in seconds
  python3 - "$dir/study.csv" "$csv" <<'PY'
import csv, sys
out = open(sys.argv[2], "w")
out.write("scene,method,budget_s,time_s,steps,psnr,ssim,flip,relmse,width,height,photons,ref_spp\n")
for r in csv.DictReader(open(sys.argv[1])):
    if r["mode"] != "time":
        continue
    psnr = "inf" if r["psnr"] in ("inf", "null") else "%.3f" % float(r["psnr"])
    out.write("%s,%s,%g,%.4f,%s,%s,%s,%s,%s,%s,%s,%s,%s\n" % (
        r["scene"], r["estimator"], float(r["budget_ms"]) / 1000, float(r["ms"]) / 1000, r["frames"], psnr,
        r["ssim"], r["flip"], r["relmse"], r["width"], r["height"], r["photons"], r["reference_spp"]))
PY
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
  gnuplot <<EOF || echo "equal_time.sh: gnuplot failed for $scene: no plot" >&2
set terminal pngcairo size 1500,450 font ",10"
set output "$OUT/equal_time_${scene}${TAG}.png"
set multiplot layout 1,3 title "$scene ${W}x${H}: error against a ${REF}-spp path-traced reference at equal rendering time ($(nproc) cores)"
set logscale x
set xlabel "rendering time (s)"
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
  echo "equal_time.sh: wrote $csv, $dir/study.md and $OUT/equal_time_${scene}${TAG}.png" >&2
done
