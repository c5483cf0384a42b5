#!/usr/bin/env bash
# Quality benchmark: the cluster paper's Table 2 protocol (Moreau et al. 2016), as runs of
# `photongi study` (one per scene and photon count) gathered into one table.
#
# For every scene and photon count (with the paper's radius, scaled to the scene's units; a scene
# or count the paper has no radius for takes the scene's own) every registered estimator except
# brute renders one frame through pixel centres (`study --jitter off --equal-time off`), compared
# with a path-traced pixel-centre reference (SSIM on luma, PSNR on tone-mapped sRGB, LDR-FLIP's
# mean) with the density-estimation time (estimator build + estimate) of that frame. The
# reference is made once per scene, size and spp in two halves (study's) and kept outside the
# repository in $PHOTONGI_CACHE (default ~/.cache/photongi); its halves give its own noise, so
# the CSV also has the PSNR against the noise-free limit (psnr_limit: 10 log10(1 / (MSE - the
# reference's MSE)), the image's error with the reference's noise taken out).
#
# Outputs in --out DIR (default bench/out/quality): quality.csv, quality.md (laid out like the
# paper's Table 2, plus FLIP), quality_<scene>.png plots (SSIM, PSNR, FLIP and build + estimate
# time against photons; needs gnuplot, scripts/install-deps.sh), and each study's folder
# (SCENE/COUNT/: study.md, study.csv and every method's PNG).
#
# Usage: bench/quality.sh [--size WxH] [--spp N] [--scenes "sibenik crytek-sponza-paper"]
#          [--photons "10k 50k 200k 1M 5M"] [--estimators "hashgrid tiled"]
#          [--auto "hashgrid"] [--bin PATH] [--out DIR]
# Defaults: 1920x1080, reference 1024 spp, both scenes, the paper's five counts
# (50M is optional: --photons "... 50M"), every estimator `photongi estimators`
# lists except brute. --auto "E ...": also a row per photon count with the automatic radius
# (docs/radius.md) for the estimators E. Times are one frame's: `photongi-bench` measures them.
#
# Radii: the paper's Table 2 values are in metres (Sibenik in McGuire's archive
# is in metres, 40 m long, and Sponza's radii only make sense in metres for its
# 37 m). Our scenes/sibenik.json is in metres (scale 1), scenes/crytek-sponza*.json
# in centimetres (scale 100). crytek-sponza-paper is Sponza with its point light only: the
# shipped crytek-sponza adds a sun and a sky, which the papers do not have.
set -euo pipefail

here=$(cd "$(dirname "$0")/.." && pwd)
BIN="$here/build/bin/photongi"
SIZE=1920x1080
SPP=1024
SCENES="sibenik crytek-sponza-paper"
PHOTONS="10k 50k 200k 1M 5M"
ESTIMATORS=""
AUTO=""
OUT="$here/bench/out/quality"
while [ $# -gt 0 ]; do
  case "$1" in
    --size) SIZE=$2; shift 2 ;;
    --spp) SPP=$2; shift 2 ;;
    --scenes) SCENES=$2; shift 2 ;;
    --photons) PHOTONS=$2; shift 2 ;;
    --estimators) ESTIMATORS=$2; shift 2 ;;
    --auto) AUTO=$2; shift 2 ;;
    --bin) BIN=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    -h|--help) sed -n '2,/^set -e/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "quality.sh: unknown option '$1' (try --help)" >&2; exit 2 ;;
  esac
done
[ -x "$BIN" ] || { echo "quality.sh: $BIN not found: build first (cmake --build build)" >&2; exit 1; }
[[ "$SIZE" =~ ^[0-9]+x[0-9]+$ ]] || { echo "quality.sh: --size needs WxH, got '$SIZE'" >&2; exit 2; }
[[ "$SPP" =~ ^[0-9]+$ && "$SPP" -ge 1 ]] || { echo "quality.sh: --spp needs a positive number" >&2; exit 2; }
export PHOTONGI_SCENES=${PHOTONGI_SCENES:-$here/../shared/scenes}
CACHE=${PHOTONGI_CACHE:-$HOME/.cache/photongi}
mkdir -p "$CACHE" "$OUT"
cd "$here"   # scene names resolve through ./scenes/<name>.json

if [ -z "$ESTIMATORS" ]; then
  ESTIMATORS=$("$BIN" estimators | grep -vx brute | tr '\n' ' ')
fi

count() {   # 10k -> 10000, 5M -> 5000000
  case "$1" in
    *k) echo $(( ${1%k} * 1000 )) ;;
    *M) echo $(( ${1%M} * 1000000 )) ;;
    *) echo "$1" ;;
  esac
}

# Paper radius (metres) for scene and photon label; empty if the paper has none.
paper_radius() {
  case "$1:$2" in
    crytek-sponza*:10k) echo 4.0 ;; crytek-sponza*:50k) echo 2.0 ;; crytek-sponza*:200k) echo 1.2 ;;
    crytek-sponza*:1M) echo 0.7 ;; crytek-sponza*:5M) echo 0.5 ;; crytek-sponza*:50M) echo 0.2 ;;
    sibenik:10k) echo 5.0 ;; sibenik:50k) echo 2.0 ;; sibenik:200k) echo 1.5 ;;
    sibenik:1M) echo 1.0 ;; sibenik:5M) echo 0.6 ;; sibenik:50M) echo 0.2 ;;
    *) echo "" ;;
  esac
}
scene_scale() { case "$1" in crytek-sponza*) echo 100 ;; *) echo 1 ;; esac; }

CSV="$OUT/quality.csv"
echo "scene,photons,radius,estimator,ssim,psnr,density_ms,estimate_ms,build_ms,total_ms,ref_spp,width,height,flip,psnr_limit" > "$CSV"
# study.csv rows -> quality.csv rows (label: the photon count as given; auto: the radius as "auto:R")
gather() {   # gather STUDY.csv LABEL AUTO(0|1)
  python3 - "$1" "$2" "$3" >> "$CSV" <<'PY'
import csv, math, sys
for r in csv.DictReader(open(sys.argv[1])):
    psnr, ref = float(r["psnr"]), float(r["reference_psnr"])
    mse = 10 ** (-psnr / 10) if math.isfinite(psnr) else 0.0
    noise = 10 ** (-ref / 10) if math.isfinite(ref) else 0.0
    lim = "%.4f" % (10 * math.log10(1 / (mse - noise))) if mse > noise else "null"
    rad = ("auto:%.4g" if sys.argv[3] == "1" else "%.6g") % float(r["radius"])
    b, e = float(r["build_ms"]), float(r["estimate_ms"])
    print(",".join([r["scene"], sys.argv[2], rad, r["estimator"], r["ssim"],
                    r["psnr"] if math.isfinite(psnr) else "null", "%.3f" % (b + e), r["estimate_ms"],
                    r["build_ms"], r["ms"], r["reference_spp"], r["width"], r["height"], r["flip"], lim]))
PY
}

for scene in $SCENES; do
  scale=$(scene_scale "$scene")
  # one pixel-centre reference per scene, size and spp (study makes it in two halves and reuses it)
  ref="$CACHE/study_${scene}_${SIZE}_b4_cam0_centre_${SPP}spp.exr"
  for label in $PHOTONS; do
    n=$(count "$label")
    pr=$(paper_radius "$scene" "$label")
    rargs=()
    if [ -n "$pr" ]; then
      rargs=(--radius "$(python3 -c "print($pr * $scale)")")
    else
      echo "quality: no paper radius for $scene $label: the scene's radius" >&2
    fi
    for mode in fixed auto; do
      if [ $mode = auto ]; then
        [ -n "$AUTO" ] || continue
        ests=$AUTO; rargs=(--radius auto); dir="$OUT/$scene/${label}_auto"
      else
        ests=$ESTIMATORS; dir="$OUT/$scene/$label"
      fi
      mkdir -p "$dir"
      nice -n 10 "$BIN" study --scene "$scene" --size "$SIZE" --spp "$SPP" --photons "$n" "${rargs[@]}" \
        --bounces 4 --jitter off --equal-time off --estimators "$(echo $ests | tr ' ' ,)" \
        --reference "$ref" --out "$dir" -q >/dev/null
      gather "$dir/study.csv" "$label" "$([ $mode = auto ] && echo 1 || echo 0)"
      echo "quality: $scene $label ($mode radius): $dir/study.md" >&2
    done
  done
done
have=$(awk -F, 'NR == 2 {print $11}' "$CSV")

# Markdown table laid out like the paper's Table 2.
python3 - "$CSV" "$OUT/quality.md" <<'EOF'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
ests = []
for r in rows:
    if r["estimator"] not in ests: ests.append(r["estimator"])
out = open(sys.argv[2], "w")
if rows:
    out.write("Quality against a path-traced reference (%sx%s, reference %s spp): SSIM on luma in %%, PSNR in dB,\n"
              "in brackets the PSNR against the noise-free limit (the reference's own noise taken out of the MSE),\n"
              "FLIP (LDR-FLIP mean, lower is better), density-estimation time (estimator build + estimate) of one frame in ms. Radii in scene units (paper's metres scaled).\n\n"
              % (rows[0]["width"], rows[0]["height"], rows[0]["ref_spp"]))
out.write("| Scene | Photons | Radius | " + " | ".join("%s SSIM | %s PSNR | %s FLIP | %s ms" % (e, e, e, e) for e in ests) + " |\n")
out.write("|---|---|---|" + "---|---|---|---|" * len(ests) + "\n")
keys = []
for r in rows:
    k = (r["scene"], r["photons"], r["radius"])
    if k not in keys: keys.append(k)
last = None
for k in keys:
    cells = []
    for e in ests:
        m = [r for r in rows if (r["scene"], r["photons"], r["radius"]) == k and r["estimator"] == e]
        if m:
            r = m[0]
            psnr = "inf" if r["psnr"] == "null" else "%.1f" % float(r["psnr"])
            psnr += " (%s)" % ("-" if r["psnr_limit"] == "null" else "%.1f" % float(r["psnr_limit"]))
            cells += ["%.1f" % (100 * float(r["ssim"])), psnr, "%.4f" % float(r["flip"]), "%.1f" % float(r["density_ms"])]
        else:
            cells += ["", "", "", ""]
    out.write("| %s | %s | %s | %s |\n" % (k[0] if k[0] != last else "", k[1], k[2], " | ".join(cells)))
    last = k[0]
out.close()
EOF

# Plots: SSIM, PSNR and build + estimate time against photons, one file per scene.
if command -v gnuplot >/dev/null 2>&1; then
  for scene in $SCENES; do
    dat="$OUT/quality_${scene}.dat"
    : > "$dat"
    for est in $ESTIMATORS; do
      echo "\"$est\"" >> "$dat"
      awk -F, -v s="$scene" -v e="$est" 'NR > 1 && $1 == s && $4 == e && $3 !~ /^auto/ {
          n = $2; sub(/k$/, "e3", n); sub(/M$/, "e6", n); print n, 100 * $5, ($6 == "null" ? 99 : $6), $7, $14 }' "$CSV" >> "$dat"
      printf '\n\n' >> "$dat"
    done
    nblocks=$(echo $ESTIMATORS | wc -w)
    # a single photon count has no curve to draw (and a log axis of one point): the table says it
    if [ "$(awk -F, -v s="$scene" 'NR > 1 && $1 == s && $3 !~ /^auto/ {print $2}' "$CSV" | sort -u | wc -l)" -lt 2 ]; then
      echo "quality: $scene has fewer than two photon counts: no plot" >&2
      continue
    fi
    gnuplot <<EOF || echo "quality: gnuplot failed for $scene: no plot" >&2
set terminal pngcairo size 1900,450 font ",10"
set output "$OUT/quality_${scene}.png"
set multiplot layout 1,4 title "$scene, ${SIZE}, reference ${have} spp"
set logscale x
set xlabel "photons"
set key bottom right
set grid
set ylabel "SSIM (%)"
plot for [i=0:$((nblocks - 1))] "$dat" index i using 1:2 with linespoints title columnheader(1)
set ylabel "PSNR (dB)"
plot for [i=0:$((nblocks - 1))] "$dat" index i using 1:3 with linespoints title columnheader(1)
set ylabel "FLIP (mean)"
set key top right
plot for [i=0:$((nblocks - 1))] "$dat" index i using 1:5 with linespoints title columnheader(1)
set ylabel "build + estimate (ms)"
set logscale y
set key top left
plot for [i=0:$((nblocks - 1))] "$dat" index i using 1:4 with linespoints title columnheader(1)
unset multiplot
EOF
  done
else
  echo "quality: gnuplot not found (scripts/install-deps.sh installs gnuplot-nox): no plots" >&2
fi
echo "quality: wrote $CSV, $OUT/quality.md and plots in $OUT" >&2
