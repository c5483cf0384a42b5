#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, -DPGI_FUZZ=ON) and runs each for SECONDS (default 60),
# one after the other. Fails on any crash, leak, timeout (10 s an input) or memory blow-up
# (2 GB RSS); the input that did it is left in $WORK/artifacts/.
#
#   tests/fuzz/run.sh [SECONDS] [TARGET...]      TARGET: scene_json, mesh, image, gltf, sidecar
#                                                (default: all)
#
# Environment:
#   PGI_FUZZ_BUILD   build folder (default build-fuzz)
#   PGI_FUZZ_WORK    corpora, logs, artifacts (default $PGI_FUZZ_BUILD/fuzz-work); the corpora
#                    grow from run to run, so a longer run starts where the last one stopped
#   PGI_SHARED       the shared/ folder beside the checkout (default ../shared): seeds from
#                    shared/bad-inputs and the Cornell box of shared/scenes (nothing big)
#   PGI_FUZZ_FLAGS   more libFuzzer flags (e.g. "-jobs=2 -workers=2")
#   PGI_FUZZ_FIXED   1: a fixed number of inputs a target (SECONDS times its rate on a 2-core
#                    machine, at most 4 x SECONDS), so that with -seed=N in PGI_FUZZ_FLAGS and an
#                    empty PGI_FUZZ_WORK a run tries the same inputs on every machine: what CI
#                    runs, a local run reproduces (CI runs it so; a longer run draws its own)
#   JOBS             build parallelism (default 2)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
cd "$ROOT"
SECS=${1:-60}
shift || true
TARGETS=("$@")
[ ${#TARGETS[@]} -gt 0 ] || TARGETS=(scene_json mesh image gltf sidecar)
BUILD=${PGI_FUZZ_BUILD:-build-fuzz}
WORK=${PGI_FUZZ_WORK:-$BUILD/fuzz-work}
SHARED=${PGI_SHARED:-$ROOT/../shared}
SEEDS=$ROOT/tests/fuzz/seeds

if [ ! -f "$BUILD/CMakeCache.txt" ]; then
    CC=${CC:-clang} cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPGI_FUZZ=ON -DPGI_BUILD_TESTS=OFF \
        -DPGI_BUILD_TOOLS=OFF -DPGI_BUILD_BENCH=OFF -DPGI_BUILD_EXAMPLES=OFF -DPGI_INSTALL=OFF >/dev/null
fi
cmake --build "$BUILD" -j "${JOBS:-2}" --target fuzz_scene_json fuzz_mesh fuzz_image fuzz_gltf fuzz_sidecar >/dev/null

# ---- corpora: seeds (rebuilt every run) and the growing corpus of each target
mkdir -p "$WORK"
WORK=$(cd "$WORK" && pwd)
rm -rf "$WORK/seeds" "$WORK/scenes"
for t in scene_json mesh image gltf sidecar; do mkdir -p "$WORK/seeds/$t" "$WORK/corpus/$t"; done
mkdir -p "$WORK/artifacts" "$WORK/scenes"
# Meshes a description may name: the Cornell box only (PHOTONGI_SCENES below), so that a
# description naming Sponza finds nothing rather than spending a minute importing it.
cp "$SEEDS/image/rle.hdr" "$WORK/scenes/sky.hdr"
cp "$ROOT"/scenes/*.json "$SEEDS"/json/*.json "$WORK/seeds/scene_json/"
cp "$SEEDS"/mesh/* "$WORK/seeds/mesh/"
cp "$SEEDS"/image/* "$WORK/seeds/image/"
cp "$SEEDS"/gltf/* "$WORK/seeds/gltf/"
cp "$SEEDS"/sidecar/* "$WORK/seeds/sidecar/"
# obj_mtl NAME OBJ [MTL]: one input of the mesh target (the OBJ, a line "#MTL", the MTL as m.mtl).
obj_mtl() {
    { sed 's/^mtllib .*/mtllib m.mtl/' "$2"; if [ -n "${3:-}" ]; then echo "#MTL"; cat "$3"; fi; } >"$WORK/seeds/mesh/$1"
}
if [ -d "$SHARED/scenes/cornell-box" ]; then
    mkdir -p "$WORK/scenes/cornell-box"
    cp "$SHARED/scenes/cornell-box/"CornellBox-Original.* "$WORK/scenes/cornell-box/"
    obj_mtl cornell.obj "$SHARED/scenes/cornell-box/CornellBox-Original.obj" \
        "$SHARED/scenes/cornell-box/CornellBox-Original.mtl"
else
    echo "fuzz: $SHARED/scenes/cornell-box not found: seeding without it" >&2
fi
BAD=$SHARED/bad-inputs
if [ -d "$BAD" ]; then
    cp "$BAD"/*.bin "$BAD"/*.ply "$WORK/seeds/mesh/"
    for f in m k; do obj_mtl "bad_$f.obj" "$BAD/obj_mtl_map_before_newmtl/$f.obj" "$BAD/obj_mtl_map_before_newmtl/$f.mtl"; done
    obj_mtl bad_m2.obj "$BAD/obj_mtl_map_before_newmtl/m2.obj" "$BAD/obj_mtl_map_before_newmtl/m.mtl"
    # the big ones are cut to the first -max_len bytes: their headers are what matters
    cp "$BAD"/*.pgm "$BAD"/*.tga "$BAD"/*.exr "$WORK/seeds/image/"
else
    echo "fuzz: $BAD not found: seeding without the hostile inputs" >&2
fi

# ---- run
export PHOTONGI_SCENES=$WORK/scenes
export ASAN_OPTIONS=detect_leaks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# Assimp 5.2 leaks on some failed imports (its own code, not photongi's).
export LSAN_OPTIONS=suppressions=$ROOT/tests/lsan-assimp.supp:print_suppressions=0
export OMP_NUM_THREADS=1
status=0
summary=()
for t in "${TARGETS[@]}"; do
    # inputs a second from an empty corpus on a 2-core machine (sanitized build), for PGI_FUZZ_FIXED
    case "$t" in
    scene_json) rate=4000 extra=(-max_len=8192 -dict="$ROOT/tests/fuzz/scene_json.dict") ;;
    mesh) rate=130 extra=(-max_len=16384 -dict="$ROOT/tests/fuzz/mesh.dict") ;;
    image) rate=3500 extra=(-max_len=16384) ;;
    gltf) rate=2500 extra=(-max_len=16384 -dict="$ROOT/tests/fuzz/mesh.dict") ;;
    sidecar) rate=5000 extra=(-max_len=2048 -dict="$ROOT/tests/fuzz/scene_json.dict") ;;
    *) echo "fuzz: unknown target '$t' (scene_json, mesh, image, gltf, sidecar)" >&2; exit 2 ;;
    esac
    limit=(-max_total_time="$SECS")
    [ "${PGI_FUZZ_FIXED:-0}" = 1 ] && limit=(-runs=$((SECS * rate)) -max_total_time=$((SECS * 4)))
    log=$WORK/$t.log
    echo "fuzz_$t: ${SECS} s (log: $log)"
    rc=0
    # shellcheck disable=SC2086
    "$BUILD/fuzz/fuzz_$t" "${limit[@]}" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
        -artifact_prefix="$WORK/artifacts/$t-" "${extra[@]}" ${PGI_FUZZ_FLAGS:-} \
        "$WORK/corpus/$t" "$WORK/seeds/$t" >"$log" 2>&1 || rc=$?
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
    last=$(grep -E '^#[0-9]+' "$log" | tail -1 || true)
    cov=$(printf '%s' "$last" | sed -n 's/.* cov: \([0-9]*\).*/\1/p')
    ft=$(printf '%s' "$last" | sed -n 's/.* ft: \([0-9]*\).*/\1/p')
    corp=$(printf '%s' "$last" | sed -n 's/.* corp: \([0-9]*\).*/\1/p')
    corpus=$(find "$WORK/corpus/$t" -type f | wc -l)
    if [ "$rc" -ne 0 ]; then
        status=1
        echo "FAIL fuzz_$t (exit $rc):"
        # (sed reads to the end: head would end grep with SIGPIPE, which pipefail makes fatal)
        grep -E 'ERROR|SUMMARY|Test unit written|^    #[0-9]' "$log" | sed -n '1,20s/^/    /p'
    fi
    summary+=("$(printf '%-16s %4s %10s execs %7s/s  cov %5s  ft %6s  corpus %5s (%s files)' "fuzz_$t" \
        "$([ "$rc" -eq 0 ] && echo ok || echo FAIL)" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}" \
        "$corpus")")
done
printf '%s\n' "${summary[@]}"
exit "$status"
