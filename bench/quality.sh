#!/usr/bin/env bash
# Quality benchmark: the cluster paper's Table 2 protocol (Moreau et al. 2016).
#
# For every scene, photon count (with the paper's radius, scaled to the scene's
# units) and registered estimator except brute: render with `photongi render`,
# compare with a path-traced reference (`photongi compare`: SSIM on luma, PSNR
# on tone-mapped sRGB, LDR-FLIP's mean) and record the density-estimation time (estimator build + estimate) from --stats JSON.
# The reference is rendered once per scene/size/spp and cached outside the
# repository in $PHOTONGI_CACHE (default ~/.cache/photongi); a cached one with
# fewer samples is extended with `reference --continue`.
#
# The reference is the merge of two halves rendered with different seeds; their difference
# gives its own noise, so the CSV also has the PSNR against the noise-free limit (psnr_limit:
# 10 log10(1 / (MSE - MSE(half A, half B) / 4)), the image's error with the reference's noise
# taken out).
#
# Outputs in --out DIR (default bench/out/quality): quality.csv, quality.md
# (laid out like the paper's Table 2, plus FLIP), quality_<scene>.png plots (SSIM, PSNR,
# FLIP and build + estimate time against photons; needs gnuplot, scripts/install-deps.sh),
# the rendered PNGs and the error heat maps.
#
# Usage: bench/quality.sh [--size WxH] [--spp N] [--scenes "sibenik crytek-sponza-paper"]
#          [--photons "10k 50k 200k 1M 5M"] [--estimators "hashgrid tiled"]
#          [--repeat R] [--auto "hashgrid"] [--bin PATH] [--out DIR]
# Defaults: 1920x1080, reference 1024 spp, both scenes, the paper's five counts
# (50M is optional: --photons "... 50M"), every estimator `photongi estimators`
# lists except brute, 1 run (--repeat R: median time of R runs). --auto "E ...": also a row per
# photon count with the automatic radius (docs/radius.md) for the estimators E.
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
REPEAT=1
AUTO=""
OUT="$here/bench/out/quality"
while [ $# -gt 0 ]; do
  case "$1" in
    --size) SIZE=$2; shift 2 ;;
    --spp) SPP=$2; shift 2 ;;
    --scenes) SCENES=$2; shift 2 ;;
    --photons) PHOTONS=$2; shift 2 ;;
    --estimators) ESTIMATORS=$2; shift 2 ;;
    --repeat) REPEAT=$2; shift 2 ;;
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
[[ "$REPEAT" =~ ^[0-9]+$ && "$REPEAT" -ge 1 ]] || { echo "quality.sh: --repeat needs a positive number" >&2; exit 2; }
export PHOTONGI_SCENES=${PHOTONGI_SCENES:-$here/../shared/scenes}
CACHE=${PHOTONGI_CACHE:-$HOME/.cache/photongi}
mkdir -p "$CACHE" "$OUT/img"
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

json_get() {   # json_get FILE KEY[.KEY...] (a number; "null" stays null)
  python3 -c '
import json, sys
v = json.load(open(sys.argv[1]))
for k in sys.argv[2].split("."):
    v = v.get(k) if isinstance(v, dict) else None
print("null" if v is None else v)' "$1" "$2"
}
ref_spp() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["spp"])' "$1"; }

CSV="$OUT/quality.csv"
echo "scene,photons,radius,estimator,ssim,ssim_rgb,psnr,density_ms,estimate_ms,build_ms,total_ms,ref_spp,width,height,flip,psnr_limit" > "$CSV"
W=${SIZE%x*}; H=${SIZE#*x}
for scene in $SCENES; do
  # The reference: two halves of SPP/2 samples with seeds 1 and 2, merged. Their difference
  # measures the merged reference's own noise (MSE(A, B) / 4 for equal halves), which the PSNR
  # against the noise-free limit removes from each image's MSE.
  for seed in 1 2; do
    half="$CACHE/ref_${scene}_${SIZE}_b4_cam0_s${seed}.exr"
    if [ -f "$half" ] && [ -f "$half.json" ]; then
      hv=$(ref_spp "$half.json")
      if [ "$hv" -lt $(( (SPP + 1) / 2 )) ]; then
        echo "quality: extending $half from $hv to $(( (SPP + 1) / 2 )) spp" >&2
        nice -n 10 "$BIN" reference --continue "$half" --spp $(( (SPP + 1) / 2 - hv )) -q
      fi
    else
      echo "quality: rendering the half reference $half ($(( (SPP + 1) / 2 )) spp; cached for later runs)" >&2
      # --jitter off: pixel centres, as the single frames compared with it (the estimators' error
      # only, not the aliasing every single frame shares)
      nice -n 10 "$BIN" reference --scene "$scene" --size "$SIZE" --bounces 4 --seed "$seed" --jitter off \
        --spp $(( (SPP + 1) / 2 )) -o "$half" -q
    fi
  done
  base="$CACHE/ref_${scene}_${SIZE}_b4_cam0"
  ref="${base}_s1+2.exr"
  "$BIN" reference --merge "${base}_s1.exr" "${base}_s2.exr" -o "$ref" -q
  "$BIN" compare "${base}_s1.exr" "${base}_s2.exr" --json > "$OUT/cmp.json"
  # A and B of nA and nB samples: MSE(A, B) = s2 (1/nA + 1/nB), the merge's noise s2 / (nA + nB)
  na=$(ref_spp "${base}_s1.exr.json"); nb=$(ref_spp "${base}_s2.exr.json")
  ref_noise=$(python3 -c "print($(json_get "$OUT/cmp.json" mse) * $na * $nb / ($na + $nb) ** 2)")
  have=$(ref_spp "$ref.json")
  scale=$(scene_scale "$scene")
  for label in $PHOTONS; do
    pr=$(paper_radius "$scene" "$label")
    if [ -z "$pr" ]; then echo "quality: no paper radius for $scene $label, skipped" >&2; continue; fi
    r=$(python3 -c "print($pr * $scale)")
    n=$(count "$label")
    for run in $(for e in $ESTIMATORS; do echo "$e:$r"; done) $(for e in $AUTO; do echo "$e:auto"; done); do
      est=${run%%:*}; rarg=${run#*:}
      tag=$label; [ "$rarg" = auto ] && tag="${label}_auto"
      img="$OUT/img/${scene}_${est}_${tag}.png"
      times=()
      for rep in $(seq "$REPEAT"); do
        "$BIN" render --scene "$scene" --size "$SIZE" --estimator "$est" --photons "$n" --radius "$rarg" \
          --bounces 4 --seed 1 --stats "$OUT/stats.json" -o "$img" -q
        e_ms=$(json_get "$OUT/stats.json" times_ms.estimate); b_ms=$(json_get "$OUT/stats.json" times_ms.build)
        times+=("$(python3 -c "print($e_ms + $b_ms)") $e_ms $b_ms $(json_get "$OUT/stats.json" times_ms.total)")
      done
      # the radius: the paper's, or "auto:R" with the one the automatic radius chose
      rcol=$r; [ "$rarg" = auto ] && rcol="auto:$(python3 -c "print('%.4g' % $(json_get "$OUT/stats.json" radius))")"
      # The run with the median density-estimation time (build + estimate: the splatting
      # methods do their photon work in build, the gather methods in estimate).
      read -r dens_ms est_ms build_ms total_ms < <(printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$0} END {print a[int((NR+1)/2)]}')
      "$BIN" compare "$img" "$ref" --json --diff "$OUT/img/${scene}_${est}_${tag}_diff.png" > "$OUT/cmp.json"
      ssim=$(json_get "$OUT/cmp.json" ssim); ssim_rgb=$(json_get "$OUT/cmp.json" ssim_rgb)
      psnr=$(json_get "$OUT/cmp.json" psnr); flip=$(json_get "$OUT/cmp.json" flip)
      # PSNR against the noise-free limit: the reference's noise taken out of the MSE ("null"
      # when the image is no farther from the reference than the reference's own noise)
      psnr_limit=$(python3 -c "
import math; e = $(json_get "$OUT/cmp.json" mse) - $ref_noise
print('%.4f' % (10 * math.log10(1 / e)) if e > 0 else 'null')")
      echo "$scene,$label,$rcol,$est,$ssim,$ssim_rgb,$psnr,$dens_ms,$est_ms,$build_ms,$total_ms,$have,$W,$H,$flip,$psnr_limit" >> "$CSV"
      printf 'quality: %-14s %5s r=%-10s %-10s SSIM %.4f PSNR %6.2f dB (limit %s) FLIP %.4f  build+estimate %8.1f ms\n' \
        "$scene" "$label" "$rcol" "$est" "$ssim" "$psnr" "$psnr_limit" "$flip" "$dens_ms" >&2
    done
  done
done
rm -f "$OUT/stats.json" "$OUT/cmp.json"

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
              "FLIP (LDR-FLIP mean, lower is better), density-estimation time (estimator build + estimate) in ms (median of runs). Radii in scene units (paper's metres scaled).\n\n"
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
          n = $2; sub(/k$/, "e3", n); sub(/M$/, "e6", n); print n, 100 * $5, ($7 == "null" ? 99 : $7), $8, $15 }' "$CSV" >> "$dat"
      printf '\n\n' >> "$dat"
    done
    nblocks=$(echo $ESTIMATORS | wc -w)
    gnuplot <<EOF
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
