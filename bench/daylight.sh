#!/usr/bin/env bash
# Daylight frames against Sibenik's: each scene rendered at its defaults (`photongi render --stats`),
# rounds alternated over the scenes and over the builds given, and per build and scene the medians
# of every pass's milliseconds, the paths traced per stored photon, and the frame's ratio to
# Sibenik's (the same build, the same run). docs/emission.md ("Daylight frames") shows a run.
#
# Usage: bench/daylight.sh [--size WxH] [--rounds N] [--scenes "sibenik crytek-sponza ..."]
#          [--bin LABEL=PATH]... [--out DIR] [-- extra render options]
# --bin: a `photongi` to time (more than one: alternated, round by round; default this build's).
# The first scene is the one the ratios divide by. Outputs: DIR/daylight_<size>.md (the table, also
# printed) and every frame's stats JSON. Run it on a quiet machine: every number is a time.
set -euo pipefail

here=$(cd "$(dirname "$0")/.." && pwd)
SIZE=960x540
ROUNDS=3
SCENES="sibenik crytek-sponza fireplace-room"
OUT=${TMPDIR:-/tmp}/photongi-daylight
BINS=()
while [ $# -gt 0 ]; do
  case "$1" in
    --size) SIZE=$2; shift 2 ;;
    --rounds) ROUNDS=$2; shift 2 ;;
    --scenes) SCENES=$2; shift 2 ;;
    --bin) BINS+=("$2"); shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --) shift; break ;;
    -h|--help) sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "daylight.sh: unknown option '$1' (--help)" >&2; exit 2 ;;
  esac
done
[ ${#BINS[@]} -gt 0 ] || BINS=("build=$here/build/bin/photongi")
for b in "${BINS[@]}"; do
  [ -x "${b#*=}" ] || { echo "daylight.sh: '${b#*=}' is not an executable (build first)" >&2; exit 1; }
done
export PHOTONGI_SCENES=${PHOTONGI_SCENES:-$here/../shared/scenes}
mkdir -p "$OUT"
total=$((ROUNDS * ${#BINS[@]} * $(echo $SCENES | wc -w)))
k=0
for r in $(seq 1 "$ROUNDS"); do
  for sc in $SCENES; do
    for b in "${BINS[@]}"; do
      k=$((k + 1))
      printf '\r[%d/%d] %s %s round %d ' "$k" "$total" "${b%%=*}" "$sc" "$r" >&2
      "${b#*=}" render --scene "$sc" --size "$SIZE" -q --stats "$OUT/${b%%=*}_${sc}_${SIZE}_$r.json" \
        -o "$OUT/${b%%=*}_${sc}_$SIZE.exr" "$@"
    done
  done
done
echo >&2
python3 - "$OUT" "$SIZE" "$ROUNDS" "$SCENES" "${BINS[@]}" <<'EOF' | tee "$OUT/daylight_$SIZE.md"
import json, statistics, sys
out, size, rounds, scenes, bins = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4].split(), sys.argv[5:]
keys = ["view", "trace", "build", "estimate", "direct", "total"]
print(f"| {size}, medians of {rounds} | emission used | direct samples | paths / stored photon | "
      + " | ".join(f"{k} ms" for k in keys) + f" | / {scenes[0]} |")
print("|---|---|---|---|" + "---|" * len(keys) + "---|")
for b in bins:
    label = b.split("=", 1)[0]
    base = None
    for sc in scenes:
        st = [json.load(open(f"{out}/{label}_{sc}_{size}_{r}.json")) for r in range(1, rounds + 1)]
        med = {k: statistics.median(s["times_ms"].get(k, 0.0) for s in st) for k in keys}
        ph = st[0]["photons"]
        base = base or med["total"]
        print(f"| {sc} ({label}) | {st[0].get('emission_used', '')} | {st[0]['settings']['direct-samples']} | "
              f"{ph['emitted'] / max(ph['stored'], 1):.2f} | " + " | ".join(f"{med[k]:.0f}" for k in keys)
              + f" | {med['total'] / base:.2f} |")
EOF
