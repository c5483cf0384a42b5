#!/usr/bin/env bash
# Honest memory from the command line (docs/memory.md): --max-memory refuses an absurd photon
# count up front (exit 1, a message naming the photons, their bytes and the budget, within
# seconds), a bad --max-memory is a usage error (exit 2), --stats lists every large allocation,
# and the counted total is within a sensible bound of the process's peak resident set.
#   usage: tests/test_memory.sh path/to/photongi     (run from the repository root)
set -u

BIN=${1:?usage: test_memory.sh path/to/photongi}
case $BIN in /*) ;; */*) BIN=$PWD/$BIN ;; esac
. "$(dirname "$0")/lib.sh" test-memory

# run ARGS...: sets $rc and $err (stderr); 60 s at most.
run() {
    timeout 60 "$BIN" "$@" >"$TMP/out" 2>"$TMP/err"
    rc=$?
    err=$(cat "$TMP/err")
}

# expect RC NEEDLE... -- ARGS...: exit status RC and every NEEDLE (fixed strings) in stderr.
expect() {
    local want=$1
    shift
    local needles=()
    while [ "$1" != "--" ]; do
        needles+=("$1")
        shift
    done
    shift
    run "$@"
    if [ "$rc" -ne "$want" ]; then
        bad "photongi $*: exit status $rc (expected $want)"
        printf '%s\n' "$err" | head -5 | sed 's/^/    /'
        return
    fi
    for n in "${needles[@]}"; do
        if ! grep -qF -- "$n" "$TMP/err"; then
            bad "photongi $*: stderr does not say '$n':"
            printf '%s\n' "$err" | head -5 | sed 's/^/    /'
            return
        fi
    done
    ok
}

# The absurd photon count: refused before tracing (tracing 1e8 photons takes minutes).
start=$(date +%s)
expect 1 "photons: 100000000 photons need" "over the memory budget of 2.00 GiB" "--max-memory" "photons fit" -- \
    render --scene cornell --photons 100000000 --max-memory 2G -o "$TMP/a.png"
[ $(($(date +%s) - start)) -le 20 ] || bad "the refused photon count took $(($(date +%s) - start)) s (not up front)"
[ -e "$TMP/a.png" ] && bad "a refused render wrote its image"
# A frame too big before any photon names its largest part.
expect 1 "view_samples: the frame needs" "over the memory budget of 512 MiB" -- \
    render --scene cornell --size 8192x4096 --photons 1000 --max-memory 512M -o "$TMP/a.png"
# Bad sizes are usage errors.
for v in 0 -1G 2X 1.5Q "" G 1e30T; do
    expect 2 "--max-memory needs a size" -- render --scene cornell --max-memory "$v" -o "$TMP/a.png"
done
# Good sizes parse (none, plain bytes, binary units).
for v in none 4294967296 4G 4GiB 4096M 0.5T; do
    expect 0 -- render -q --scene cornell --size 32x24 --photons 1000 --max-memory "$v" -o "$TMP/a.png"
done

# --stats: every large allocation, the budget, the peak resident set; the counted total near it.
run render -q --scene cornell --size 1280x720 --photons 300000 --estimator hashgrid --max-memory 8G \
    -o "$TMP/m.png" --stats "$TMP/m.json"
if [ "$rc" -ne 0 ]; then
    bad "the stats render failed: $err"
else
    for k in scene textures embree_bvh photons trace_scratch view_samples frame_buffers image hash_table \
        sorted_photons sort_keys total counted_bytes counted_peak_bytes peak_rss_bytes counted_over_peak_rss; do
        grep -q "\"$k\":" "$TMP/m.json" || bad "--stats does not list \"$k\""
    done
    grep -q '"budget_bytes":[[:space:]]*8589934592' "$TMP/m.json" || bad "--stats does not give the budget of 8G"
    ratio=$(sed -n 's/.*"counted_over_peak_rss":[[:space:]]*\([0-9.e+-]*\).*/\1/p' "$TMP/m.json")
    # Under a sanitizer the resident set holds its shadow memory: no bound then.
    if [ -z "${PGI_SANITIZE:-}" ]; then
        if awk -v r="$ratio" 'BEGIN { exit !(r >= 0.75 && r <= 1.05) }'; then ok; else
            bad "counted memory / peak resident set = $ratio, outside [0.75, 1.05]"
        fi
    fi
fi

summary test_memory
