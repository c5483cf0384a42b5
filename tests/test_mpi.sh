#!/usr/bin/env bash
# photongi-mpi (apps/mpi, docs/distributed.md): under mpirun -np 2 and -np 3 (and without
# mpirun: 1 rank), render --progressive 12 and 30 (its last blocks dealt frame by frame) and
# reference --spp 24 (and --continue) write the same bytes as photongi; bad input under MPI exits non-zero with a message, never hangs; a rank that
# fails in the middle of the work ends the job with its rank in the message.
#   usage: tests/test_mpi.sh path/to/photongi path/to/photongi-mpi [path/to/mpirun]
set -u

CLI=${1:?usage: test_mpi.sh photongi photongi-mpi [mpirun]}
MPI=${2:?usage: test_mpi.sh photongi photongi-mpi [mpirun]}
MPIRUN=${3:-mpirun}
# Under make test-sanitize: Open MPI's own allocations are not ours to report.
# Its components stay loaded to the end (mca_base_component_disable_dlclose), so that their
# frames have names the suppressions (lsan-mpi.supp) can match.
export LSAN_OPTIONS="${LSAN_OPTIONS:+$LSAN_OPTIONS:}suppressions=$(cd "$(dirname "$0")" && pwd)/lsan-mpi.supp"
export OMPI_MCA_mca_base_component_disable_dlclose=1
# Open MPI is built without frame pointers: slow unwinding finds the library in each trace.
[ -n "${ASAN_OPTIONS:-}" ] && export ASAN_OPTIONS="$ASAN_OPTIONS:fast_unwind_on_malloc=0"
. "$(dirname "$0")/lib.sh" test-mpi

# mpirun's options: oversubscribe (CI machines have few cores), and as root (CI's containers)
# Open MPI needs --allow-run-as-root.
MPIOPTS=(--oversubscribe)
[ "$(id -u)" -eq 0 ] && MPIOPTS+=(--allow-run-as-root)
# KILLOPTS: after forwarding SIGTERM, Open MPI kills the ranks 1 s later (odls_base_sigkill_timeout);
# under the sanitizers and load, finishing a block and saving can take longer (the SIGINT test).
KILLOPTS=(--mca odls_base_sigkill_timeout 30)
if "$MPIRUN" --version 2>&1 | grep -qiE "open mpi|openrte"; then :; else MPIOPTS=() KILLOPTS=(); fi
# np N ARGS...: photongi-mpi under mpirun -np N (a minute at most: never a hang)
np() {
    local n=$1
    shift
    timeout 120 "$MPIRUN" "${MPIOPTS[@]}" -np "$n" "$MPI" "$@"
}

# rank_sums STATS.json: the whole blocks and the frames of every rank, summed ("mpi" per_rank)
rank_sums() {
    awk '/"per_rank"/ { on = 1 } on && /"blocks"/ { gsub(/[^0-9]/, ""); b += $0 }
        on && /"frames"/ { gsub(/[^0-9]/, ""); f += $0 } END { print b + 0, f + 0 }' "$1"
}

# A small built-in scene, few photons: fast, yet several blocks of frames and samples.
R=(render --scene cornell --size 48x40 --photons 3000 --direct-samples 2 --seed 5 --progressive 12 -q)
"$CLI" "${R[@]}" -o "$TMP/r-ref.exr" && ok || bad "photongi render failed"
"$MPI" "${R[@]}" -o "$TMP/r-1.exr" && ok || bad "photongi-mpi render without mpirun failed"
cmp -s "$TMP/r-ref.exr" "$TMP/r-1.exr" && ok || bad "render: photongi-mpi (1 rank) differs from photongi"
for n in 2 3; do
    np "$n" "${R[@]}" --threads 1 -o "$TMP/r-$n.exr" --stats "$TMP/r-$n.json" 2>"$TMP/err"
    rc=$?
    [ $rc -eq 0 ] && ok || { bad "render -np $n: exit $rc"; head -5 "$TMP/err"; }
    cmp -s "$TMP/r-ref.exr" "$TMP/r-$n.exr" && ok || bad "render: -np $n differs from photongi"
    # the stats carry the per-rank figures
    grep -q '"mpi"' "$TMP/r-$n.json" && grep -q "\"ranks\":[[:space:]]*$n" "$TMP/r-$n.json" &&
        grep -q '"bytes_sent"' "$TMP/r-$n.json" && ok || bad "render -np $n: no \"mpi\" in the stats"
    [ "$(rank_sums "$TMP/r-$n.json" | cut -d' ' -f2)" = 12 ] && ok ||
        bad "render -np $n: the ranks' frames do not add up to 12"
done
# the thread count does not matter either (2 ranks x 2 threads)
np 2 "${R[@]}" --threads 2 -o "$TMP/r-2t.exr" && cmp -s "$TMP/r-ref.exr" "$TMP/r-2t.exr" && ok ||
    bad "render: -np 2 --threads 2 differs from photongi"
# guided emission with the automatic radius: a frame's pilot (hence its guide) does not depend on
# the frames its renderer rendered before (each rank renders other frames)
R4=(render --scene cornell --size 48x40 --photons 3000 --direct-samples 2 --emission guided --radius auto --progressive 8 -q)
"$CLI" "${R4[@]}" -o "$TMP/g-ref.exr" && np 2 "${R4[@]}" --threads 1 -o "$TMP/g-2.exr" &&
    cmp -s "$TMP/g-ref.exr" "$TMP/g-2.exr" && ok || bad "render --emission guided --radius auto: -np 2 differs from photongi"
# a PNG and a frame count that leaves a partial last block
R2=(render --scene cornell --size 40x32 --photons 2000 --direct-samples 2 --progressive 7 -q)
"$CLI" "${R2[@]}" -o "$TMP/p-ref.png" && np 3 "${R2[@]}" --threads 1 -o "$TMP/p-3.png" &&
    cmp -s "$TMP/p-ref.png" "$TMP/p-3.png" && ok || bad "render --progressive 7 PNG: -np 3 differs from photongi"

# The last 2R blocks are dealt frame by frame (rank 0 adds the frames into their block sums in frame
# order): 30 frames (8 blocks, the last partial) on 2 and 3 ranks, some blocks split, same bytes.
R3=(render --scene cornell --size 40x32 --photons 2000 --direct-samples 2 --seed 3 --progressive 30 -q)
"$CLI" "${R3[@]}" -o "$TMP/s-ref.exr" || bad "photongi render --progressive 30 failed"
for n in 2 3; do
    np "$n" "${R3[@]}" --threads 1 -o "$TMP/s-$n.exr" --stats "$TMP/s-$n.json" && cmp -s "$TMP/s-ref.exr" "$TMP/s-$n.exr" &&
        ok || bad "render --progressive 30: -np $n differs from photongi"
    # per rank: whole blocks and frames; every frame rendered once, fewer whole blocks than 8
    read -r blocks frames <<<"$(rank_sums "$TMP/s-$n.json")"
    [ "${frames:-0}" -eq 30 ] && [ "${blocks:-8}" -lt 8 ] && ok ||
        bad "render --progressive 30 -np $n: per-rank blocks $blocks, frames $frames (want < 8 and 30)"
done

F=(reference --scene cornell --size 40x32 --spp 24 -q)
"$CLI" "${F[@]}" -o "$TMP/f-ref.exr" && ok || bad "photongi reference failed"
for n in 2 3; do
    np "$n" "${F[@]}" --threads 1 -o "$TMP/f-$n.exr" && ok || bad "reference -np $n failed"
    cmp -s "$TMP/f-ref.exr" "$TMP/f-$n.exr" && cmp -s "$TMP/f-ref.exr.json" "$TMP/f-$n.exr.json" && ok ||
        bad "reference: -np $n differs from photongi"
done
# --continue: 10 more samples (a partial last block) on top of the 24
cp "$TMP/f-ref.exr" "$TMP/c-ref.exr" && cp "$TMP/f-ref.exr.json" "$TMP/c-ref.exr.json"
cp "$TMP/f-ref.exr" "$TMP/c-3.exr" && cp "$TMP/f-ref.exr.json" "$TMP/c-3.exr.json"
"$CLI" reference --continue "$TMP/c-ref.exr" --spp 10 -q &&
    np 3 reference --continue "$TMP/c-3.exr" --spp 10 --threads 1 -q &&
    cmp -s "$TMP/c-ref.exr" "$TMP/c-3.exr" && grep -q '"spp":.*34' "$TMP/c-3.exr.json" && ok ||
    bad "reference --continue: -np 3 differs from photongi"

# --checkpoint: the reference is saved on the way (each rank goes on from the samples saved) and ends
# with the bytes of one uninterrupted run.
G=(reference --scene cornell --size 24x16 --spp 2000)
"$CLI" "${G[@]}" -q -o "$TMP/g-ref.exr" && ok || bad "photongi reference --spp 2000 failed"
np 2 "${G[@]}" --checkpoint 0.05 --threads 1 -o "$TMP/g-2.exr" 2>"$TMP/err"
rc=$?
[ $rc -eq 0 ] && grep -q "checkpoint: .*g-2.exr saved at" "$TMP/err" && cmp -s "$TMP/g-ref.exr" "$TMP/g-2.exr" &&
    cmp -s "$TMP/g-ref.exr.json" "$TMP/g-2.exr.json" && ok ||
    bad "reference --checkpoint -np 2: exit $rc, or no checkpoint, or not the bytes of one run: $(grep -v ranks "$TMP/err" | head -3)"
# SIGINT to mpirun (it passes SIGTERM to the ranks): the samples so far are saved, a whole number of
# blocks; continued by 4, the bytes of one run of as many. The signal is sent once three checkpoints
# say the ranks are rendering and at least 2 s have passed (a fixed sleep raced the ranks' start-up
# under the sanitizers; right after the first checkpoint, under load, mpirun itself had not yet set
# up its signal forwarding, and SIGINT ended the job unsaved). Open MPI's abort may also end the
# ranks before their last save (its SIGKILL follows SIGTERM after odls_base_sigkill_timeout, 1 s by
# default, KILLOPTS raises it; and its teardown can stop the ranks' final reduction): then no
# "interrupted" line, and the file is the last checkpoint's, which must still be whole blocks that
# continue to the bytes of one run. Either way no more than a checkpoint interval is lost.
I=(reference --scene cornell --size 64x48 --threads 1)
timeout 120 "$MPIRUN" "${MPIOPTS[@]}" "${KILLOPTS[@]}" -np 2 "$MPI" "${I[@]}" --spp 1000000 --checkpoint 0.2 \
    -o "$TMP/i-2.exr" 2>"$TMP/err" &
pid=$!
t0=$(date +%s)
for _ in $(seq 900); do
    [ "$(grep -c "checkpoint: " "$TMP/err" 2>/dev/null)" -ge 3 ] && [ $(($(date +%s) - t0)) -ge 2 ] && break
    sleep 0.1
done
kill -INT $pid
wait $pid
n=$(sed -n 's/.*"spp":[[:space:]]*"\([0-9]*\)".*/\1/p' "$TMP/i-2.exr.json" 2>/dev/null)
last=$(sed -n 's/.*checkpoint: .*i-2.exr saved at \([0-9]*\) spp.*/\1/p' "$TMP/err" | tail -1)
if { grep -q "interrupted (SIGTERM): .*i-2.exr saved with" "$TMP/err" || [ "${n:-0}" = "${last:-x}" ]; } &&
    [ -n "$n" ] && [ "$n" -gt 0 ] && [ $((n % 4)) -eq 0 ]; then
    "$CLI" reference --continue "$TMP/i-2.exr" --spp 4 -q && "$CLI" "${I[@]}" --spp $((n + 4)) -q -o "$TMP/i-1.exr" &&
        cmp -s "$TMP/i-1.exr" "$TMP/i-2.exr" && ok ||
        bad "mpirun SIGINT: $n samples saved; continued by 4 they differ from one run of $((n + 4))"
else bad "mpirun SIGINT: nothing saved ($n spp, last checkpoint ${last:-none}): $(grep -v ranks "$TMP/err" | head -3)"; fi

# Bad input under MPI: a message, a non-zero exit, no hang, no output.
np 2 render --scene "$TMP/missing.obj" -o "$TMP/x.png" 2>"$TMP/err"
rc=$?
[ $rc -ne 0 ] && [ $rc -ne 124 ] && grep -q "missing.obj" "$TMP/err" && [ ! -e "$TMP/x.png" ] && ok ||
    bad "missing scene under -np 2: exit $rc, $(head -1 "$TMP/err")"
np 3 reference --spp 0 -o "$TMP/x.exr" 2>"$TMP/err"
rc=$?
[ $rc -eq 2 ] && grep -q -- "--spp" "$TMP/err" && ok || bad "reference --spp 0 under -np 3: exit $rc"
np 2 frobnicate 2>"$TMP/err"
rc=$?
[ $rc -eq 2 ] && grep -q "unknown command" "$TMP/err" && ok || bad "unknown command under -np 2: exit $rc"
# A rank that fails in the middle of the work ends the job (MPI_Abort), naming its rank.
PHOTONGI_MPI_FAIL_RANK=2 timeout 120 "$MPIRUN" "${MPIOPTS[@]}" -x PHOTONGI_MPI_FAIL_RANK -np 3 "$MPI" \
    render --scene cornell --size 32x24 --photons 1000 --progressive 40 --threads 1 -q -o "$TMP/y.png" 2>"$TMP/err"
rc=$?
[ $rc -ne 0 ] && [ $rc -ne 124 ] && grep -q "rank 2 of 3" "$TMP/err" && [ ! -e "$TMP/y.png" ] && ok ||
    bad "a failing rank: exit $rc, $(head -1 "$TMP/err")"
# Ranks that read different files under one path (each its own machine's copy; here each rank its
# own folder): refused before the work, naming the rank, never a mixed image.
for r in 0 1; do mkdir -p "$TMP/rank$r"; done
echo '{"builtin": "cornell"}' >"$TMP/rank0/s.json"
echo '{"builtin": "giref"}' >"$TMP/rank1/s.json"
printf '#!/bin/sh\ncd "%s/rank$OMPI_COMM_WORLD_RANK" && exec "%s" "$@"\n' "$TMP" "$MPI" >"$TMP/rankdir.sh"
chmod +x "$TMP/rankdir.sh"
if [ ${#MPIOPTS[@]} -gt 0 ]; then # Open MPI: OMPI_COMM_WORLD_RANK
    for cmd in "render --progressive 4 --photons 1000" "reference --spp 4"; do
        # shellcheck disable=SC2086
        timeout 120 "$MPIRUN" "${MPIOPTS[@]}" -np 2 "$TMP/rankdir.sh" $cmd --scene s.json --size 16x16 -q \
            -o "$TMP/mixed.exr" 2>"$TMP/err"
        rc=$?
        [ $rc -eq 1 ] && grep -q "rank 1 loaded a different scene from s.json than rank 0" "$TMP/err" &&
            [ ! -e "$TMP/mixed.exr" ] && ok || bad "${cmd%% *}: ranks with different scenes: exit $rc, $(head -1 "$TMP/err")"
    done
fi

"$MPI" --help | grep -q "mpirun -np R photongi-mpi render" && ok || bad "photongi-mpi --help"
"$MPI" render --help | grep -q -- "--progressive N" && ok || bad "photongi-mpi render --help"

summary test_mpi
