#!/usr/bin/env bash
# References that never lose work, and hostile references, sidecars and outputs (issue 42):
#  - a reference stopped by SIGINT (exit 130), SIGTERM (143), SIGKILL (after a --checkpoint) or a
#    full disk (ulimit -f) and continued to the same total has the bytes of one uninterrupted run;
#  - a failed write keeps the previous EXR and sidecar; an EXR and a sidecar that do not belong
#    together, a sidecar out of range or that is a FIFO, NaN pixels: exit 1 within 5 s, naming the file;
#  - compare of NaN images is an error, its --json is JSON; a full standard output is exit 1;
#  - outputs naming the same file are a usage error (2); a name over NAME_MAX is refused at once.
#   usage: tests/test_reference_safety.sh path/to/photongi
set -u

BIN=${1:?usage: test_reference_safety.sh path/to/photongi}
case $BIN in /*) ;; */*) BIN=$PWD/$BIN ;; esac
. "$(dirname "$0")/lib.sh" test-refsafe
R="--size 40x30 --threads 2"

# hostile CODE NEEDLE ARGS...: exit CODE within 5 s, stderr names NEEDLE.
hostile() {
    local code=$1 needle=$2
    shift 2
    timeout 5 "$BIN" "$@" >"$TMP/out" 2>"$TMP/err"
    local rc=$?
    if [ "$rc" -ne "$code" ]; then
        bad "photongi $*: exit status $rc (expected $code)"
        head -3 "$TMP/err" | sed 's/^/    /'
    elif ! grep -qF -- "$needle" "$TMP/err"; then
        bad "photongi $*: stderr does not name '$needle':"
        head -3 "$TMP/err" | sed 's/^/    /'
    else ok; fi
}
spp_of() { sed -n 's/.*"spp":[[:space:]]*"\([0-9]*\)".*/\1/p' "$1.json"; }
# started FILE: wait (up to 60 s) until a run's first checkpoint FILE is there, so that a signal finds
# the run rendering, its handlers installed, whatever the machine's load or the sanitizers' start-up.
started() { for _ in $(seq 1200); do [ -e "$1" ] && return 0; sleep 0.05; done; return 1; }
# same_as_one_run REF WHAT: REF (continued) has the bytes of one run to its sample count.
same_as_one_run() {
    local n
    n=$(spp_of "$1")
    "$BIN" reference $R --spp "$n" -q -o "$TMP/one.exr" || { bad "$2: the uninterrupted run failed"; return; }
    cmp -s "$1" "$TMP/one.exr" && ok || bad "$2: continued to $n spp, not the bytes of one run"
}

# SIGINT: the block of 4 samples finished and saved, exit 130, the count said.
"$BIN" reference $R --spp 1000000 --checkpoint 0.1 -q -o "$TMP/i.exr" 2>"$TMP/err" &
pid=$!
started "$TMP/i.exr"
kill -INT $pid
wait $pid
rc=$?
n=$(spp_of "$TMP/i.exr")
[ "$rc" -eq 130 ] && grep -q "saved with $n samples" "$TMP/err" && [ $((n % 4)) -eq 0 ] && ok ||
    bad "SIGINT: exit $rc, $n spp: $(cat "$TMP/err")"
"$BIN" reference --continue "$TMP/i.exr" --spp 6 -q && same_as_one_run "$TMP/i.exr" "SIGINT"

# Two SIGINTs: only the current pass is finished, still saved, still 130.
"$BIN" reference $R --spp 1000000 --checkpoint 0.1 -q -o "$TMP/ii.exr" 2>"$TMP/err" &
pid=$!
started "$TMP/ii.exr"
kill -INT $pid
kill -INT $pid
wait $pid
rc=$?
n=$(spp_of "$TMP/ii.exr")
[ "$rc" -eq 130 ] && grep -q "saved with $n samples" "$TMP/err" && ok || bad "two SIGINTs: exit $rc, $n spp"
hostile 2 "--checkpoint needs seconds" reference $R --checkpoint -1 -o "$TMP/cp.exr"
hostile 2 "--checkpoint needs seconds" reference $R --checkpoint 1x -o "$TMP/cp.exr"
hostile 2 "--merge takes only" reference --merge "$TMP/i.exr" "$TMP/ii.exr" --checkpoint 5 -o "$TMP/cp.exr"

# SIGTERM: 143.
"$BIN" reference $R --spp 1000000 --checkpoint 0.1 -q -o "$TMP/t.exr" 2>"$TMP/err" &
pid=$!
started "$TMP/t.exr"
kill -TERM $pid
wait $pid
rc=$?
[ "$rc" -eq 143 ] && grep -q "SIGTERM" "$TMP/err" && [ -s "$TMP/t.exr" ] && ok || bad "SIGTERM: exit $rc"

# SIGKILL: the last checkpoint is there, whole, with its sidecar; no temporary file is left but the one
# being written when killed.
"$BIN" reference $R --spp 1000000 --checkpoint 0.2 -q -o "$TMP/k.exr" &
pid=$!
started "$TMP/k.exr"
sleep 0.5
kill -KILL $pid
wait $pid 2>/dev/null
n=$(spp_of "$TMP/k.exr")
if [ -n "$n" ] && [ "$n" -gt 0 ] && [ $((n % 4)) -eq 0 ]; then
    ok
    "$BIN" reference --continue "$TMP/k.exr" --spp 5 -q && same_as_one_run "$TMP/k.exr" "SIGKILL"
else bad "SIGKILL after checkpoints: no checkpoint ($n spp)"; fi
# What killed writers left: the next write of the file removes the temporary files of processes
# that are gone (a dead process id), and keeps a live writer's (this shell's).
host=$(uname -n | tr './' '__')
sh -c 'exit 0' &
dead=$!
wait $dead
stale="$TMP/.k.exr.pgi-tmp-$host-$dead.AbC123" live="$TMP/.k.exr.pgi-tmp-$host-$$.XyZ789"
other="$TMP/.kk.exr.pgi-tmp-$host-$dead.AbC123"
touch "$stale" "$live" "$other"
"$BIN" reference --continue "$TMP/k.exr" --spp 4 -q
[ ! -e "$stale" ] && [ -e "$live" ] && [ -e "$other" ] && ok ||
    bad "stale temporary files: $(ls -A "$TMP" | grep pgi-tmp | tr '\n' ' ')"
rm -f "$live" "$other"

# A full disk (a file size limit) during --continue: exit 1, the reference as it was, nothing left
# behind; continued again later, the bytes of one run.
"$BIN" reference $R --spp 8 -q -o "$TMP/f.exr"
cp "$TMP/f.exr" "$TMP/f0.exr" && cp "$TMP/f.exr.json" "$TMP/f0.json"
(
    ulimit -f 8
    exec "$BIN" reference --continue "$TMP/f.exr" --spp 8 -q
) 2>"$TMP/err"
rc=$?
[ "$rc" -eq 1 ] && grep -q "f.exr" "$TMP/err" && cmp -s "$TMP/f.exr" "$TMP/f0.exr" &&
    cmp -s "$TMP/f.exr.json" "$TMP/f0.json" && [ -z "$(ls -A "$TMP" | grep pgi-tmp)" ] && ok ||
    bad "full disk: exit $rc, reference changed or a temporary file left: $(cat "$TMP/err")"
"$BIN" reference --continue "$TMP/f.exr" --spp 8 -q && same_as_one_run "$TMP/f.exr" "full disk"

# A failed --png after --continue: the EXR and its sidecar agree (the new count), exit 1.
ln -s /dev/full "$TMP/full.png"
hostile 1 "full.png" reference --continue "$TMP/f.exr" --spp 4 --png "$TMP/full.png"
[ "$(spp_of "$TMP/f.exr")" = 20 ] && "$BIN" reference --continue "$TMP/f.exr" --spp 4 -q && ok ||
    bad "--png failed: the EXR and its sidecar disagree"
# A failed write never deletes what -o names.
cp "$TMP/f0.exr" "$TMP/prev.exr"
(
    ulimit -f 8
    exec "$BIN" render $R -q -o "$TMP/prev.exr"
) 2>/dev/null
cmp -s "$TMP/f0.exr" "$TMP/prev.exr" && ok || bad "a failed render -o changed or deleted the previous file"

# The EXR and the sidecar must belong together (a kill between their renames, a replaced EXR).
cp "$TMP/f.exr" "$TMP/m.exr" && cp "$TMP/f0.json" "$TMP/m.exr.json"
hostile 1 "do not belong together" reference --continue "$TMP/m.exr" --spp 1

# Sidecars out of range or that are not files.
"$BIN" reference $R --spp 4 --seed 2 -q -o "$TMP/s.exr"
for edit in 's/"spp":[^,]*/"spp": "-1"/' 's/"spp":[^,]*/"spp": "18446744073709551616"/' \
    's/"spp":[^,]*/"spp": "0"/' 's/"width":[^,]*/"width": 1e9/' 's/"height":[^,]*/"height": 1.5/' \
    's/"bounces":[^,]*/"bounces": 1000/' 's/"camera":[^,]*/"camera": -1/' 's/"seed":[^,]*/"seed": "1x"/'; do
    sed "$edit" "$TMP/s.exr.json" >"$TMP/b.exr.json" && cp "$TMP/s.exr" "$TMP/b.exr"
    hostile 1 "b.exr.json" reference --continue "$TMP/b.exr" --spp 1
    hostile 1 "b.exr.json" reference --merge "$TMP/b.exr" "$TMP/f.exr" -o "$TMP/mm.exr"
done
[ ! -e "$TMP/mm.exr" ] && ok || bad "--merge of a bad sidecar wrote an image"
cp "$TMP/s.exr" "$TMP/fifo.exr" && mkfifo "$TMP/fifo.exr.json"
hostile 1 "fifo.exr.json" reference --continue "$TMP/fifo.exr" --spp 1
cp "$TMP/s.exr.json" "$TMP/fifo2.exr.json" && mkfifo "$TMP/fifo2.exr"
hostile 1 "fifo2.exr: not a regular file" reference --continue "$TMP/fifo2.exr" --spp 1
# A relative scene path is the sidecar's folder's: another gloss.json in the current folder is not
# mixed in (the reference continues with the scene it was made of).
mkdir -p "$TMP/a" "$TMP/b"
printf '{"builtin": "cornell", "render": {"width": 40, "height": 30}}\n' >"$TMP/a/sc.json"
printf 'not a scene\n' >"$TMP/b/sc.json"
(cd "$TMP/a" && "$BIN" reference --scene sc.json --spp 4 --threads 2 -q -o r.exr) || bad "reference of a file scene"
(cd "$TMP/b" && timeout 5 "$BIN" reference --continue ../a/r.exr --spp 4 -q) && ok ||
    bad "--continue from another folder used that folder's sc.json"
sed 's|"scene":[^,]*|"scene": "sc.json"|' "$TMP/a/r.exr.json" >"$TMP/a/x" && mv "$TMP/a/x" "$TMP/a/r.exr.json"
(cd "$TMP/b" && timeout 5 "$BIN" reference --continue ../a/r.exr --spp 4 -q) && ok ||
    bad "a relative scene in a sidecar was not resolved against the sidecar's folder"

# NaN pixels: an uncompressed scanline EXR written here (python3), refused by --continue, --merge
# and compare with their count.
if command -v python3 >/dev/null; then
    python3 - "$TMP/nan.exr" <<'EOF'
import struct, sys
w, h = 16, 16
def attr(name, typ, data): return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(data)) + data
ch = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in "BGR") + b"\0"
box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
hdr = (struct.pack("<ii", 20000630, 2) + attr("channels", "chlist", ch) + attr("compression", "compression", b"\0")
       + attr("dataWindow", "box2i", box) + attr("displayWindow", "box2i", box) + attr("lineOrder", "lineOrder", b"\0")
       + attr("pixelAspectRatio", "float", struct.pack("<f", 1)) + attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0))
       + attr("screenWindowWidth", "float", struct.pack("<f", 1)) + b"\0")
rows = []
for y in range(h):
    vals = [float("nan") if (x + y) % 5 == 0 else 0.5 for x in range(w)]
    data = b"".join(struct.pack("<%df" % w, *vals) for c in range(3))
    rows.append(struct.pack("<ii", y, len(data)) + data)
off, table = len(hdr) + 8 * h, b""
for r in rows:
    table += struct.pack("<Q", off)
    off += len(r)
open(sys.argv[1], "wb").write(hdr + table + b"".join(rows))
EOF
    printf '{"format": "photongi-reference-2", "scene": "cornell", "width": 16, "height": 16, "bounces": 4, "camera": 0, "seed": "3", "spp": "4", "jitter": true}\n' >"$TMP/nan.exr.json"
    hostile 1 "52 pixels of 256 with NaN" reference --continue "$TMP/nan.exr" --spp 1
    hostile 1 "nan.exr has 52 pixels" reference --merge "$TMP/nan.exr" "$TMP/f.exr" -o "$TMP/mm.exr"
    hostile 1 "nan.exr has 52 pixels" compare "$TMP/nan.exr" "$TMP/f.exr"
    hostile 1 "nan.exr has 52 pixels" compare "$TMP/f.exr" "$TMP/nan.exr" --json
    "$BIN" compare "$TMP/f.exr" "$TMP/f.exr" --json >"$TMP/c.json" &&
        python3 -c 'import json,sys; json.load(open(sys.argv[1]))' "$TMP/c.json" && ok ||
        bad "compare --json of identical images is not JSON: $(cat "$TMP/c.json")"
else echo "python3 missing: NaN EXR cases skipped"; fi

# Standard output full: exit 1 with a message.
for c in "compare $TMP/f.exr $TMP/f.exr" info "estimators" "--help"; do
    timeout 5 "$BIN" $c >/dev/full 2>"$TMP/err"
    rc=$?
    [ "$rc" -eq 1 ] && grep -q "standard output" "$TMP/err" && ok || bad "photongi $c >/dev/full: exit $rc"
done

# Outputs that name the same file: a usage error before anything renders; names over NAME_MAX.
hostile 2 "name the same file" render $R --stats "$TMP/s.png" -o "$TMP/s.png"
ln -s o.png "$TMP/link.png"
hostile 2 "name the same file" render $R --stats "$TMP/link.png" -o "$TMP/o.png"
hostile 2 "name the same file" render $R --stats "$TMP/./o.png" -o "$TMP/o.png"
ln -s x.exr "$TMP/x.png"
hostile 2 "name the same file" reference $R --spp 1 --png "$TMP/x.png" -o "$TMP/x.exr"
"$BIN" render $R -q -o "$TMP/p.png"
hostile 2 "name the same file" compare "$TMP/p.png" "$TMP/p.png" --diff "$TMP/d.png" --flip-map "$TMP/d.png"
hostile 2 "name the same file" compare "$TMP/p.png" "$TMP/f.exr" --diff "$TMP/p.png"
"$BIN" compare "$TMP/p.png" "$TMP/p.png" >/dev/null && ok || bad "compare --diff overwrote the image compared"
long=$(printf 'n%.0s' $(seq 300))
hostile 1 "the name is" reference $R --spp 1 -o "$TMP/$long.exr"
hostile 1 "the name is" reference $R --spp 1 -o "$TMP/${long:0:252}.exr"
hostile 1 "the name is" render $R -o "$TMP/$long.png"

# A progressive render stopped by SIGINT writes the average of the frames it finished: the image of
# --progressive K itself, byte for byte, and says K; exit 130.
P="render --scene cornell --size 32x24 --photons 2000 --threads 2 -q"
"$BIN" $P --progressive 1000000 --checkpoint 0.1 -o "$TMP/p.exr" 2>"$TMP/err" &
pid=$!
started "$TMP/p.exr"
kill -INT $pid
wait $pid
rc=$?
k=$(sed -n 's/.*with the average of \([0-9]*\) of 1000000 frames.*/\1/p' "$TMP/err")
if [ "$rc" -eq 130 ] && [ -n "$k" ] && [ "$k" -ge 1 ]; then
    "$BIN" $P --progressive "$k" -o "$TMP/pk.exr" && cmp -s "$TMP/p.exr" "$TMP/pk.exr" && ok ||
        bad "progressive SIGINT: the average of $k frames differs from --progressive $k"
else bad "progressive SIGINT: exit $rc: $(cat "$TMP/err")"; fi

# --checkpoint: a progressive render killed (SIGKILL) leaves its last checkpoint, the image of
# --progressive K byte for byte for the K it names; no temporary file is left once the next
# render of that file has run.
"$BIN" ${P% -q} --progressive 1000000 --checkpoint 0.2 -o "$TMP/c.exr" 2>"$TMP/err" &
pid=$!
started "$TMP/c.exr"
sleep 0.5
kill -KILL $pid
wait $pid 2>/dev/null
k=$(sed -n 's/.*c.exr written with the average of \([0-9]*\) frames.*/\1/p' "$TMP/err" | tail -1)
if [ -n "$k" ] && [ "$k" -ge 1 ]; then
    "$BIN" $P --progressive "$k" -o "$TMP/ck.exr" && cmp -s "$TMP/c.exr" "$TMP/ck.exr" && ok ||
        bad "progressive checkpoint: the checkpoint of $k frames differs from --progressive $k"
else bad "progressive checkpoint: no checkpoint written: $(cat "$TMP/err")"; fi
"$BIN" $P --progressive 2 -o "$TMP/c.exr" && [ -z "$(ls -A "$TMP" | grep 'c.exr.pgi-tmp')" ] && ok ||
    bad "progressive checkpoint: a temporary file is left: $(ls -A "$TMP" | grep pgi-tmp)"
hostile 2 "--checkpoint needs --progressive" render $R --checkpoint 5 -o "$TMP/x.png"

summary test_reference_safety
