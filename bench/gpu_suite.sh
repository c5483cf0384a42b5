#!/usr/bin/env bash
# bench/gpu_suite.sh: photongi measured on a GPU machine in one command (docs/gpu.md, "Measuring on a
# GPU machine"). Run from the repository root, with the bundle of scripts/gpu-bundle.sh beside it:
#
#   bench/gpu_suite.sh [--local] [--quick] [--bundle FILE|DIR] [--build DIR] [--out DIR] [--budget S]
#
# Steps, in order, each under a time limit of its own so that the whole run ends inside --budget
# seconds (default 480, the report included) whatever fails; a step that fails or times out is reported and the next runs:
#   env, devices   the machine, nvidia-smi, glibc, `photongi devices` (driver and device name)
#   tests          the GPU tests (test_gpu, test_gpu_rays, test_gpu_trace, test_gpu_frame) on the
#                  device the library picks (the first discrete GPU): GPU estimators against the CPU
#                  brute force on identical photons, the GPU frame against the CPU frame
#   frame-*        the GPU frame, Sibenik and Sponza (crytek-sponza-paper: its point light) at
#                  1920x1080, 200k / 1M / 5M photons, every GPU estimator: per-pass medians of 5
#                  frames after a warm-up, the frame, the device's memory (photongi-bench --device)
#   rays, trace    ray rates (photongi-bench-gpu-rays) and photon tracing (photongi-bench-gpu-trace)
#   cpu-scaling    the CPU frame, Sibenik 1080p 200k, the default estimator, at 1, 2, 4, 8, 16 threads
#   limits         photongi-bench --limits on every core
#   images         the same Sibenik frame on the GPU and on the CPU, saved, and the PSNR between them
# Everything goes under $OUT (else --out, else bench/out/gpu-suite-DATE): a markdown report and a
# CSV named DEVICE-DATE (commit them under bench/results/gpu/), the log, the two images and their
# difference, and raw.tar.gz (every step's output); the short table is printed last.
#
#   --local    not on the GPU machine: no driver set-up (.gl packages, ldconfig, VK_DRIVER_FILES),
#              and a CPU Vulkan device (lavapipe) is accepted; without a bundle, uses build/
#   --quick    the same steps at tiny sizes (CI runs --local --quick so that the script cannot rot)
#   --bundle   the archive (default gpu-bundle/photongi-gpu.tar.xz) or an unpacked bundle folder
#   --build    a build folder instead of a bundle (its bin/ and tests/; scenes from $PHOTONGI_SCENES)
# Exit status: 0 when every step passed, 1 when one failed or timed out, 2 on a usage error.
set -uo pipefail
cd "$(dirname "$0")/.." || exit 1
ROOT=$(pwd)
T_START=$(date +%s)

LOCAL=0 QUICK=0 BUNDLE="" BUILD_DIR="" OUTDIR=${OUT:-} BUDGET=480
usage() {
    sed -n '2,29p' "$0" | sed 's/^# \{0,1\}//'
    exit "${1:-0}"
}
value() { # OPTION VALUE: the option's value, or a usage error
    [ -n "${2:-}" ] && [ "${2#--}" = "$2" ] && return 0
    echo "gpu_suite: $1 needs a value" >&2
    exit 2
}
while [ $# -gt 0 ]; do
    case "$1" in
    --local) LOCAL=1 ;;
    --quick) QUICK=1 ;;
    --bundle) value "$1" "${2:-}" && BUNDLE=$2 && shift ;;
    --build) value "$1" "${2:-}" && BUILD_DIR=$2 && shift ;;
    --out) value "$1" "${2:-}" && OUTDIR=$2 && shift ;;
    --budget) value "$1" "${2:-}" && BUDGET=$2 && shift ;;
    -h | --help) usage 0 ;;
    *)
        echo "gpu_suite: unknown argument $1" >&2
        usage 2 >&2
        ;;
    esac
    shift
done
[[ "$BUDGET" =~ ^[0-9]+$ ]] && [ "$BUDGET" -ge 30 ] || {
    echo "gpu_suite: --budget must be a whole number of seconds, at least 30" >&2
    exit 2
}
OUTDIR=${OUTDIR:-$ROOT/bench/out/gpu-suite-$(date +%Y%m%d-%H%M%S)}
mkdir -p "$OUTDIR" || exit 1
OUTDIR=$(cd "$OUTDIR" && pwd)
WORK=$(mktemp -d "${TMPDIR:-/tmp}/pgi-gpu-suite.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
LOG=$OUTDIR/suite.log
: >"$LOG"
say() { echo "[gpu_suite $(($(date +%s) - T_START))s] $*" | tee -a "$LOG"; }

# --- the driver (on the GPU machine, before the bundle's libraries are on LD_LIBRARY_PATH: dpkg and
# ldconfig are the system's programs): docs/gpu.md and the device tool's notes
SYS_LD_LIBRARY_PATH=${LD_LIBRARY_PATH:-}
if [ "$LOCAL" = 0 ]; then
    if compgen -G ".gl/*.deb" >/dev/null; then
        say "unpacking the GL/Vulkan loader packages of .gl/"
        for f in .gl/*.deb; do timeout 60 dpkg -x "$f" / >>"$LOG" 2>&1 || say "warning: dpkg -x $f failed"; done
        timeout 60 ldconfig >>"$LOG" 2>&1 || say "warning: ldconfig failed"
    fi
    for d in /usr/local/nvidia/lib64 /usr/local/nvidia/lib; do
        [ -d "$d" ] && SYS_LD_LIBRARY_PATH=${SYS_LD_LIBRARY_PATH:+$SYS_LD_LIBRARY_PATH:}$d
    done
    export LD_LIBRARY_PATH=$SYS_LD_LIBRARY_PATH
    if [ -z "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ] &&
        ! compgen -G "/usr/share/vulkan/icd.d/nvidia*.json" >/dev/null &&
        ! compgen -G "/etc/vulkan/icd.d/nvidia*.json" >/dev/null; then
        for j in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd*.json; do
            [ -f "$j" ] && export VK_DRIVER_FILES=$j && break
        done
    fi
fi
# the system's own programs (tar, python3, nvidia-smi) run without the bundle's libraries (its libz or
# libstdc++ must not shadow theirs)
sys() { env LD_LIBRARY_PATH="$SYS_LD_LIBRARY_PATH" "$@"; }
export SYS_LD_LIBRARY_PATH

# --- the programs: the bundle (unpacked here), or a build folder
if [ -z "$BUILD_DIR" ]; then
    BUNDLE=${BUNDLE:-gpu-bundle/photongi-gpu.tar.xz}
    if [ -f "$BUNDLE" ]; then
        say "unpacking $BUNDLE"
        # (python3's tarfile where the machine has no xz)
        timeout 120 tar -C "$WORK" -xJf "$BUNDLE" 2>>"$LOG" ||
            timeout 120 python3 -c 'import sys, tarfile
t = tarfile.open(sys.argv[1])
t.extractall(sys.argv[2], **({"filter": "data"} if hasattr(tarfile, "data_filter") else {}))' "$BUNDLE" "$WORK" || {
            say "cannot unpack $BUNDLE"
            exit 1
        }
        BUNDLE=$WORK/photongi-gpu
    elif [ ! -f "$BUNDLE/env.sh" ]; then
        if [ "$LOCAL" = 1 ] && [ -x build/bin/photongi ]; then
            BUILD_DIR=build
        else
            say "no bundle at $BUNDLE: make one with scripts/gpu-bundle.sh (or give --bundle / --build)"
            exit 1
        fi
    fi
fi
if [ -n "$BUILD_DIR" ]; then
    BUILD_DIR=$(cd "$BUILD_DIR" && pwd)
    export PATH="$BUILD_DIR/bin:$BUILD_DIR/tests:$PATH"
    export PHOTONGI_SCENES=${PHOTONGI_SCENES:-$(cd .. && pwd)/shared/scenes}
    SOURCE="build folder $BUILD_DIR"
    MANIFEST=""
else
    # shellcheck disable=SC1091
    . "$BUNDLE/env.sh"
    SOURCE="bundle ($(sed -n 's/^commit: *//p' "$BUNDLE/MANIFEST"))"
    MANIFEST=$BUNDLE/MANIFEST
    # a bundle made from another commit measures other code than the tree beside it
    made=$(sed -n 's/^commit: *\([0-9a-f]*\).*/\1/p' "$MANIFEST")
    head=$(git rev-parse --short=12 HEAD 2>/dev/null || true)
    if [ -n "$head" ] && [ -n "$made" ] && [ "$made" != "$head" ]; then
        say "warning: the bundle was made from commit $made, the tree is at $head (remake it: scripts/gpu-bundle.sh)"
    fi
fi
command -v photongi >/dev/null || {
    say "photongi not found in $SOURCE"
    exit 1
}

# --- the GPU probe: the loader found no GPU as set up, so name NVIDIA's driver file outright if there is one
if [ "$LOCAL" = 0 ] && ! timeout -k 2 20 photongi devices 2>>"$LOG" | grep -qE '^ +(discrete|integrated|virtual) GPU;'; then
    for j in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd*.json /usr/share/vulkan/icd.d/nvidia_icd*.json \
        /etc/vulkan/icd.d/nvidia_icd*.json; do
        [ -f "$j" ] && [ "${VK_DRIVER_FILES:-}" != "$j" ] && export VK_DRIVER_FILES=$j && say "VK_DRIVER_FILES=$j" && break
    done
fi

# --- sizes
NPROC=$(nproc)
if [ "$QUICK" = 1 ]; then
    SIZE=160x90 PHOTONS=2000,8000 FRAMES=2 MAXS=5 IMG_SIZE=96x54 IMG_PHOTONS=5000
    THREADS=1,2 RAYS_ARGS=(--rays 20000 --size 64x36) TRACE_PHOTONS=(5000) LIMITS_ARGS=(--size 160x90 --frames 1)
else
    SIZE=1920x1080 PHOTONS=200000,1000000,5000000 FRAMES=5 MAXS=10 IMG_SIZE=1920x1080 IMG_PHOTONS=200000
    THREADS=1,2,4,8,16 RAYS_ARGS=(--rays 1000000 --size 1920x1080) TRACE_PHOTONS=(200000 1000000) LIMITS_ARGS=()
fi
THREADS=$(echo "$THREADS" | tr ',' '\n' | awk -v n="$NPROC" '$1 <= n' | paste -sd,)
TEST_LIMIT=60  # each GPU test program (seconds on a GPU machine)
TESTS_LIMIT=150 # the four together
# --local runs them on lavapipe, on the CPU: about 100 s for test_gpu and 30-60 s for each other on 2
# busy cores, more under load
[ "$LOCAL" = 1 ] && TEST_LIMIT=200 TESTS_LIMIT=420
export SIZE PHOTONS FRAMES MAXS THREADS NPROC WORK OUTDIR TEST_LIMIT

# --- steps: each under `timeout`, its output in $WORK/NAME.out; a row of $WORK/steps.csv each
echo "step,status,seconds,limit" >"$WORK/steps.csv"
RESERVE=25 # for the archive and the report (each under a timeout), and timeout's kill grace
FAILED=0
step() { # NAME LIMIT_SECONDS COMMAND...
    local name=$1 limit=$2
    shift 2
    local left=$((T_START + BUDGET - RESERVE - $(date +%s)))
    if [ "$left" -lt 5 ]; then
        say "$name: skipped (out of time)"
        echo "$name,skipped,0,0" >>"$WORK/steps.csv"
        FAILED=1
        return
    fi
    [ "$limit" -gt "$left" ] && limit=$left
    say "$name (at most ${limit}s)"
    local t0 rc status
    t0=$(date +%s.%N)
    STEP_END=$(($(date +%s) + limit)) timeout -k 5 "$limit" "$@" >"$WORK/$name.out" 2>&1
    rc=$?
    local secs
    secs=$(echo "$(date +%s.%N) $t0" | awk '{printf "%.1f", $1 - $2}')
    case $rc in
    0) status=ok ;;
    124) status=timeout ;;
    137) status="killed (timeout's KILL, or out of memory)" ;;
    *) status="failed (exit $rc)" ;;
    esac
    [ "$rc" -eq 0 ] || FAILED=1
    echo "$name,$status,$secs,$limit" >>"$WORK/steps.csv"
    cat "$WORK/$name.out" >>"$LOG"
    say "$name: $status in ${secs}s"
}

step_env() {
    echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
    echo "host: $(uname -srm); $( (. /etc/os-release && echo "$PRETTY_NAME") 2>/dev/null)"
    echo "glibc: $(sys ldd --version 2>/dev/null | head -1)"
    echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $NPROC cores"
    echo "memory: $(awk '/^MemTotal:/ {printf "%.0f GiB", $2 / 1048576}' /proc/meminfo)"
    if command -v nvidia-smi >/dev/null; then
        echo "nvidia-smi: $(sys timeout 15 nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm,clocks.max.mem \
            --format=csv,noheader 2>&1 | head -1)"
    fi
    echo "VK_DRIVER_FILES: ${VK_DRIVER_FILES:-(unset)}"
    [ -n "${MANIFEST:-}" ] && head -5 "$MANIFEST"
    photongi --version
}
step_devices() {
    photongi devices || return 1
    if ! timeout 20 photongi devices | grep -qE '^ +(discrete|integrated|virtual) GPU;'; then
        echo "no GPU among the Vulkan devices; the loader says:"
        VK_LOADER_DEBUG=error,warn timeout 20 photongi devices 2>&1 | head -40
        [ "${LOCAL:-0}" = 1 ] || return 1
    fi
}
step_tests() {
    local rc=0 t
    echo "test,exit,passed,failed,device,seconds" >"$WORK/tests.csv"
    for t in test_gpu test_gpu_rays test_gpu_trace test_gpu_frame; do
        local t0 r lim
        # each test ends before the step's own limit, so that its row is written
        lim=$((STEP_END - $(date +%s) - 8))
        [ "$lim" -gt "$TEST_LIMIT" ] && lim=$TEST_LIMIT
        if [ "$lim" -lt 5 ]; then
            echo "$t,skipped (out of time),,,,0" >>"$WORK/tests.csv"
            rc=1
            continue
        fi
        t0=$(date +%s.%N)
        timeout -k 3 "$lim" "$t" >"$WORK/$t.log" 2>&1
        r=$?
        [ "$r" -eq 0 ] || rc=1
        printf '%s,%s,%s,%s,"%s",%s\n' "$t" "$r" \
            "$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test.*/\1/p' "$WORK/$t.log" | tail -1)" \
            "$(sed -n 's/^\[  FAILED  \] \([0-9]*\) test.*/\1/p' "$WORK/$t.log" | tail -1)" \
            "$(sed -n 's/^device: \(.*\) (timestamps.*/\1/p' "$WORK/$t.log" | head -1)" \
            "$(echo "$(date +%s.%N) $t0" | awk '{printf "%.1f", $1 - $2}')" >>"$WORK/tests.csv"
        echo "== $t: exit $r"
        grep -E '^\[ +(FAILED|PASSED|  OK|ERROR) |^device:' "$WORK/$t.log" | grep -v '^\[       OK \]' | head -40
    done
    cat "$WORK/tests.csv"
    return $rc
}
step_frame() { # SCENE
    photongi-bench --scenes "$1" --device vulkan --size "$SIZE" --photons "$PHOTONS" --frames "$FRAMES" \
        --max-seconds "$MAXS" --csv "$WORK/frame-$1.csv"
}
step_rays() { photongi-bench-gpu-rays --scene sibenik --threads "$NPROC" "${RAYS_ARGS[@]}"; }
step_trace() {
    local rc=0 p s
    for p in "${TRACE_PHOTONS[@]}"; do
        for s in sibenik crytek-sponza-paper; do
            photongi-bench-gpu-trace --scene "$s" --photons "$p" --threads "$NPROC" --runs 3 || rc=1
        done
    done
    return $rc
}
step_cpu() {
    photongi-bench --scenes sibenik --estimators default --size "$SIZE" --photons "${PHOTONS%%,*}" \
        --threads "$THREADS" --frames "$FRAMES" --max-seconds "$MAXS" --csv "$WORK/cpu-scaling.csv"
}
step_limits() { photongi-bench --limits --threads "$NPROC" "${LIMITS_ARGS[@]}" --csv "$WORK/limits.csv"; }
step_images() {
    local d rc=0
    for d in vulkan cpu; do
        photongi render --scene sibenik --device "$d" --size "$IMG_SIZE" --photons "$IMG_PHOTONS" -q \
            -o "$WORK/$d.exr" --stats "$WORK/$d-stats.json" || rc=1
        photongi render --scene sibenik --device "$d" --size "$IMG_SIZE" --photons "$IMG_PHOTONS" -q \
            -o "$OUTDIR/sibenik-$d.png" || rc=1
    done
    [ "$rc" = 0 ] || return 1
    photongi compare "$WORK/vulkan.exr" "$WORK/cpu.exr" --json --diff "$OUTDIR/sibenik-diff.png" >"$WORK/compare.json"
    r=$?
    cat "$WORK/compare.json"
    return $r
}
export -f sys step_env step_devices step_tests step_frame step_rays step_trace step_cpu step_limits step_images
export LOCAL MANIFEST IMG_SIZE IMG_PHOTONS
export RAYS_ARGS_S="${RAYS_ARGS[*]}" TRACE_PHOTONS_S="${TRACE_PHOTONS[*]}" LIMITS_ARGS_S="${LIMITS_ARGS[*]}"
# arrays do not cross `bash -c`: the steps rebuild them from these strings
pre='read -ra RAYS_ARGS <<<"$RAYS_ARGS_S"; read -ra TRACE_PHOTONS <<<"$TRACE_PHOTONS_S"; read -ra LIMITS_ARGS <<<"$LIMITS_ARGS_S";'

say "photongi GPU suite: $SOURCE, $( [ "$QUICK" = 1 ] && echo quick || echo full) sizes, budget ${BUDGET}s, results in $OUTDIR"
step env 20 bash -c "$pre step_env"
step devices 30 bash -c "$pre step_devices"
step tests "$TESTS_LIMIT" bash -c "$pre step_tests"
step frame-sibenik 110 bash -c "$pre step_frame sibenik"
step frame-sponza 110 bash -c "$pre step_frame crytek-sponza-paper"
step rays 40 bash -c "$pre step_rays"
step trace 60 bash -c "$pre step_trace"
step cpu-scaling 90 bash -c "$pre step_cpu"
step limits 60 bash -c "$pre step_limits"
step images 40 bash -c "$pre step_images"

# --- the report (python3: the standard library only); the short table is printed last
sys timeout 10 tar -C "$WORK" --exclude='photongi-gpu' --exclude='*.exr' -czf "$OUTDIR/raw.tar.gz" . 2>>"$LOG" ||
    say "warning: raw.tar.gz is incomplete"
# the device the frames ran on (the library's pick), else the first listed
DEVICE=$(sed -n 's/^device: //p' "$WORK/frame-sibenik.out" "$WORK/frame-sponza.out" 2>/dev/null | grep -v '^cpu$' | head -1)
[ -n "$DEVICE" ] || DEVICE=$(sed -n 's/^vulkan:[0-9]*: //p' "$WORK/devices.out" 2>/dev/null | head -1)
say "done in $(($(date +%s) - T_START))s, $( [ "$FAILED" = 0 ] && echo "every step ok" || echo "a step failed or timed out"): $OUTDIR"
sys timeout 15 python3 bench/gpu_report.py --work "$WORK" --out "$OUTDIR" --device "${DEVICE:-unknown}" \
    --mode "$( [ "$QUICK" = 1 ] && echo quick || echo full)$( [ "$LOCAL" = 1 ] && echo ", local")" \
    --source "$SOURCE" 2>&1 | tee -a "$LOG"
[ "${PIPESTATUS[0]}" = 0 ] || FAILED=1
exit $FAILED
