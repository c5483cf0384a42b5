#!/usr/bin/env bash
# Memory of a long distributed progressive render (docs/distributed.md, "Memory over a long
# render"): photongi-mpi under mpirun -np RANKS renders FRAMES frames of PHOTONS photons of SCENE
# while the resident set of every rank is sampled every 2 s; writes
# bench/results/mpi_memory-<scene>.csv (seconds, rank pid, RSS MiB) and prints, per rank, the
# RSS after the first tenth of the run and at the end, and the peak RSS of the stats.
#   usage: bench/mpi_memory.sh [FRAMES [PHOTONS [SCENE [RANKS [SIZE]]]]]
#          (defaults: 500 200000 sibenik 2 640x360: 100 M photons in all)
set -euo pipefail
cd "$(dirname "$0")/.."
FRAMES=${1:-500}
PHOTONS=${2:-200000}
SCENE=${3:-sibenik}
RANKS=${4:-2}
SIZE=${5:-640x360}
BUILD=${BUILD:-build}
MPIRUN=${MPIRUN:-mpirun}
MPIOPTS=(--oversubscribe --bind-to none)
[ "$(id -u)" -eq 0 ] && MPIOPTS+=(--allow-run-as-root)
TMP=$(mktemp -d "${TMPDIR:-/tmp}/pgi-mpi-memory-XXXXXX")
trap 'rm -rf "$TMP"' EXIT
mkdir -p bench/results
CSV=bench/results/mpi_memory-$SCENE.csv
echo "seconds,pid,rss_mib" >"$CSV"
t0=$(date +%s)
"$MPIRUN" "${MPIOPTS[@]}" -np "$RANKS" "$BUILD/bin/photongi-mpi" render --scene "$SCENE" --photons "$PHOTONS" \
    --progressive "$FRAMES" --size "$SIZE" --threads 1 -o "$TMP/out.exr" --stats "$TMP/stats.json" &
run=$!
while kill -0 "$run" 2>/dev/null; do
    for p in $(pgrep -P "$run" -f photongi-mpi || true); do
        rss=$(awk '/^VmRSS/ {print $2}' "/proc/$p/status" 2>/dev/null || true)
        [ -n "$rss" ] && echo "$(($(date +%s) - t0)),$p,$(echo "scale=1; $rss / 1024" | bc)" >>"$CSV"
    done
    sleep 2
done
wait "$run"
echo "wall: $(($(date +%s) - t0)) s" >&2
python3 - "$CSV" "$TMP/stats.json" <<'PY'
import csv, json, sys
rows = list(csv.DictReader(open(sys.argv[1])))
end = max(int(r["seconds"]) for r in rows)
by = {}
for r in rows:
    by.setdefault(r["pid"], []).append((int(r["seconds"]), float(r["rss_mib"])))
for pid, s in sorted(by.items()):
    early = [v for t, v in s if t >= end / 10][:1] or [s[0][1]]
    print(f"pid {pid}: RSS {early[0]:.1f} MiB at {end // 10} s, {s[-1][1]:.1f} MiB at the end, max {max(v for _, v in s):.1f} MiB")
m = json.load(open(sys.argv[2]))
print(f"photons stored {m['photons']['stored'] if 'photons' in m else '?'}; frames {m.get('frames')}")
for r in m["mpi"]["per_rank"]:
    print(f"rank {r['rank']}: {int(r['frames'])} frames, busy {r['busy_ms'] / 1000:.1f} s, wait {r['wait_ms'] / 1000:.1f} s, "
          f"reduction {r['reduction_ms'] / 1000:.2f} s, sent {r['bytes_sent'] / 1048576:.0f} MiB, peak RSS {r['peak_rss_bytes'] / 1048576:.1f} MiB")
PY
