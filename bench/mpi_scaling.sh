#!/usr/bin/env bash
# Scaling of photongi-mpi (docs/distributed.md): one progressive render timed as
#   1 rank  x T threads  (plain photongi, --threads T: the baseline)
#   1 rank  x T threads  (photongi-mpi without mpirun: the launcher's own overhead)
#   R ranks x 1 thread   (mpirun -np R, R = T: the same cores)
#   2R ranks x 1 thread  (oversubscribed: per-rank work and communication separately)
# (and 1 process x 1 thread, the serial time) with wall times, efficiencies and each rank's frames, busy,
# wait (and of it: for r0, after its last unit) and reduction milliseconds, bytes sent and peak
# resident set from the "mpi" stats; checks
# that every run wrote the baseline's bytes. Writes bench/results/mpi_scaling-<scene>-<size>.csv.
#   usage: bench/mpi_scaling.sh [FRAMES [SIZE [SCENE [CORES]]]]    (defaults: 64 640x360 sibenik 2)
#   env:   REPEAT (rounds, the fastest run of each kept; default 1), BUILD (default build),
#          MPIRUN (default mpirun), PHOTONGI_SCENES
set -euo pipefail
cd "$(dirname "$0")/.."
FRAMES=${1:-64}
SIZE=${2:-640x360}
SCENE=${3:-sibenik}
CORES=${4:-2}
BUILD=${BUILD:-build}
MPIRUN=${MPIRUN:-mpirun}
CLI=$BUILD/bin/photongi
MPI=$BUILD/bin/photongi-mpi
[ -x "$MPI" ] || { echo "mpi_scaling: $MPI not built (configure with MPI installed: PGI_MPI)" >&2; exit 1; }
MPIOPTS=(--oversubscribe --bind-to none)
[ "$(id -u)" -eq 0 ] && MPIOPTS+=(--allow-run-as-root)
TMP=$(mktemp -d "${TMPDIR:-/tmp}/pgi-mpi-scaling-XXXXXX")
trap 'rm -rf "$TMP"' EXIT
mkdir -p bench/results
CSV=bench/results/mpi_scaling-$SCENE-$SIZE.csv
ARGS=(render --scene "$SCENE" --size "$SIZE" --progressive "$FRAMES" -q)

now() { date +%s.%N; }
# run NAME CMD...: runs CMD (which writes $TMP/NAME.exr and $TMP/NAME.json through @OUT@ and
# @STATS@), keeping the fastest of the repeats in $TMP/best-NAME.{exr,json,wall}
run() {
    local name=$1 w u s
    shift
    local cmd=()
    for a in "$@"; do
        a=${a//@OUT@/$TMP/$name.exr}
        cmd+=("${a//@STATS@/$TMP/$name.json}")
    done
    # wall, user and system seconds (every rank's: mpirun reaps them)
    local times cpu
    times=$({ TIMEFORMAT='%R %U %S'; time "${cmd[@]}" >"$TMP/$name.log" 2>&1; } 2>&1) ||
        { cat "$TMP/$name.log" >&2; exit 1; }
    read -r w u s <<<"$times"
    cpu=$(echo "$u + $s" | bc -l)
    echo "  $name: $w s wall, $cpu s CPU (load $(cut -d' ' -f1 /proc/loadavg))" >&2
    if [ ! -e "$TMP/best-$name.wall" ] || [ "$(echo "$w < $(cat "$TMP/best-$name.wall")" | bc -l)" -eq 1 ]; then
        echo "$w" >"$TMP/best-$name.wall"
        echo "$cpu" >"$TMP/best-$name.cpu"
        cp "$TMP/$name.exr" "$TMP/best-$name.exr"
        cp "$TMP/$name.json" "$TMP/best-$name.json"
    fi
}

# The configurations in turn, REPEAT times (default 1), the fastest run of each kept: other work
# on the machine only ever slows a run down.
REPEAT=${REPEAT:-1}
for rep in $(seq 1 "$REPEAT"); do
    echo "round $rep of $REPEAT" >&2
    run b1 "$CLI" "${ARGS[@]}" --threads 1 -o @OUT@ --stats @STATS@
    run bC "$CLI" "${ARGS[@]}" --threads "$CORES" -o @OUT@ --stats @STATS@
    run m1 "$MPI" "${ARGS[@]}" --threads "$CORES" -o @OUT@ --stats @STATS@
    run mR "$MPIRUN" "${MPIOPTS[@]}" -np "$CORES" "$MPI" "${ARGS[@]}" --threads 1 -o @OUT@ --stats @STATS@
    run m2R "$MPIRUN" "${MPIOPTS[@]}" -np $((2 * CORES)) "$MPI" "${ARGS[@]}" --threads 1 -o @OUT@ --stats @STATS@
done

echo "config,ranks,threads_per_rank,wall_s,efficiency,vs_threads,cpu_s,cpu_efficiency,rank,frames,busy_ms,wait_ms,wait_r0_ms,wait_end_ms,reduction_ms,bytes_sent,peak_rss_mib,same_bytes" >"$CSV"
# efficiency = T(1 process x 1 thread) / (cores used x T): the classic parallel efficiency on
# min(ranks x threads, CORES) cores; vs_threads = T(1 process x CORES threads) / T: MPI ranks
# against OpenMP threads on the same cores; cpu_efficiency = CPU(1 process x 1 thread) / CPU (all
# ranks, waits included: Open MPI spins while a rank waits, unless oversubscribed), which other
# work on the machine disturbs much less than wall times.
T11=$(cat "$TMP/best-b1.wall")
T1C=$(cat "$TMP/best-bC.wall")
cp "$TMP/best-b1.exr" "$TMP/base.exr"
rss() { python3 -c "import json,sys; print(round(json.load(open(sys.argv[1]))['memory']['peak_rss_bytes']/1048576,1))" "$1" 2>/dev/null || echo ""; }
fmt() { printf %.3f "$(echo "$1" | bc -l)"; }
C11=$(cat "$TMP/best-b1.cpu")
echo "photongi,1,1,$(fmt "$T11"),1.000,$(fmt "$T1C / $T11"),$(fmt "$C11"),1.000,0,$FRAMES,,,,,,0,$(rss "$TMP/best-b1.json"),yes" >>"$CSV"
same=no
cmp -s "$TMP/base.exr" "$TMP/best-bC.exr" && same=yes
echo "photongi,1,$CORES,$(fmt "$T1C"),$(fmt "$T11 / ($CORES * $T1C)"),1.000,$(fmt "$(cat "$TMP/best-bC.cpu")"),$(fmt "$C11 / $(cat "$TMP/best-bC.cpu")"),0,$FRAMES,,,,,,0,$(rss "$TMP/best-bC.json"),$same" >>"$CSV"

# row CONFIG NAME RANKS THREADS: the per-rank rows of the best run of NAME
row() {
    local same=no used=$(($3 * $4)) wall
    [ "$used" -gt "$CORES" ] && used=$CORES
    wall=$(cat "$TMP/best-$2.wall")
    cmp -s "$TMP/base.exr" "$TMP/best-$2.exr" && same=yes
    local eff vs
    eff=$(echo "$T11 / ($used * $wall)" | bc -l)
    vs=$(echo "$T1C / $wall" | bc -l)
    local cpu
    cpu=$(cat "$TMP/best-$2.cpu")
    python3 - "$1" "$3" "$4" "$wall" "$eff" "$vs" "$TMP/best-$2.json" "$same" "$cpu" "$C11" >>"$CSV" <<'PY'
import json, sys
cfg, ranks, threads, wall, eff, vs, path, same, cpu, c11 = sys.argv[1:]
m = json.load(open(path))["mpi"]
for r in m["per_rank"]:
    print(f"{cfg},{ranks},{threads},{float(wall):.3f},{float(eff):.3f},{float(vs):.3f},{float(cpu):.3f},"
          f"{float(c11) / float(cpu):.3f},{r['rank']},{int(r['frames'])},"
          f"{r['busy_ms']:.0f},{r['wait_ms']:.0f},{r.get('wait_r0_ms', 0):.0f},{r.get('wait_end_ms', 0):.0f},"
          f"{r['reduction_ms']:.0f},{int(r['bytes_sent'])},"
          f"{r['peak_rss_bytes']/1048576:.1f},{same}")
PY
}
row photongi-mpi-alone m1 1 "$CORES"
row "mpirun-np$CORES" mR "$CORES" 1
row "mpirun-np$((2 * CORES))-oversubscribed" m2R $((2 * CORES)) 1
echo "wrote $CSV (fastest of $REPEAT)" >&2
column -s, -t "$CSV"
