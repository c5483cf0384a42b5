#!/usr/bin/env bash
# Command-line tests of the photongi binary: bad input gets a clear message
# naming the problem and exit status 1 or 2 (never a crash: no status >= 128,
# no sanitizer report); good input works.
#   usage: tests/test_cli.sh path/to/photongi     (run from the repository root)
set -u

BIN=${1:?usage: test_cli.sh path/to/photongi}
case $BIN in /*) ;; */*) BIN=$PWD/$BIN ;; esac
. "$(dirname "$0")/lib.sh" test-cli

# run ARGS...: runs the binary, sets $rc, $out (stdout), $err (stderr).
run() {
    "$BIN" "$@" >"$TMP/out" 2>"$TMP/err"
    rc=$?
    out=$(cat "$TMP/out")
    err=$(cat "$TMP/err")
}

# expect_error NEEDLE ARGS...: exit 1 or 2, stderr contains NEEDLE (fixed string,
# case-insensitive), no sanitizer report.
expect_error() {
    local needle=$1
    shift
    run "$@"
    local what="photongi $*"
    if [ "$rc" -ne 1 ] && [ "$rc" -ne 2 ]; then
        bad "$what: exit status $rc (expected 1 or 2)"
        printf '%s\n' "$err" | head -5 | sed 's/^/    /'
        return
    fi
    if ! grep -qiF -- "$needle" "$TMP/err"; then
        bad "$what: stderr does not mention '$needle':"
        printf '%s\n' "$err" | head -5 | sed 's/^/    /'
        return
    fi
    if grep -qE 'AddressSanitizer|runtime error:|LeakSanitizer' "$TMP/err"; then
        bad "$what: sanitizer report"
        return
    fi
    ok
}

# expect_ok ARGS...: exit 0.
expect_ok() {
    run "$@"
    if [ "$rc" -ne 0 ]; then
        bad "photongi $*: exit status $rc (expected 0)"
        printf '%s\n' "$err" | head -5 | sed 's/^/    /'
        return 1
    fi
    ok
    return 0
}

# expect_status CODE NEEDLE ARGS...: exit status CODE exactly (the convention of 'photongi --help':
# 2 usage error, 1 failure), stderr contains NEEDLE, no sanitizer report.
expect_status() {
    local code=$1 needle=$2
    shift 2
    run "$@"
    if [ "$rc" -ne "$code" ]; then
        bad "photongi $*: exit status $rc, expected $code"
        printf '%s\n' "$err" | head -3 | sed 's/^/    /'
    elif ! grep -qiF -- "$needle" "$TMP/err"; then
        bad "photongi $*: stderr does not mention '$needle':"
        printf '%s\n' "$err" | head -3 | sed 's/^/    /'
    elif grep -qE 'AddressSanitizer|runtime error:|LeakSanitizer' "$TMP/err"; then
        bad "photongi $*: sanitizer report"
    else
        ok
    fi
}

# on_tty ARGS...: runs the binary with a terminal as stdin, stdout and stderr (util-linux
# script); what it printed goes to $TMP/tty, its status to $rc. Returns 1 when no terminal
# can be had.
have_tty=0
if command -v script >/dev/null 2>&1 && script -qec true /dev/null </dev/null >/dev/null 2>&1; then have_tty=1; fi
on_tty() {
    [ "$have_tty" = 1 ] || return 1
    local cmd
    cmd=$(printf '%q ' "$BIN" "$@")
    script -qec "$cmd" /dev/null </dev/null >"$TMP/tty" 2>&1
    rc=$?
    return 0
}

R=(render --size 32x32 --photons 1000 -q)

# ------------------------------------------------------------ bad input
expect_error "/nonexistent/x.obj" "${R[@]}" --scene /nonexistent/x.obj -o "$TMP/a.png"

printf 'garbage \x01\x02\nf a b c\nv 1\n' >"$TMP/broken.obj"
expect_error "broken.obj" "${R[@]}" --scene "$TMP/broken.obj" -o "$TMP/a.png"

printf '{\n  "mesh": "x.obj",\n  "lights": [ {"type": "point" ,, ]\n' >"$TMP/syntax.json"
expect_error "syntax.json" "${R[@]}" --scene "$TMP/syntax.json" -o "$TMP/a.png"
run "${R[@]}" --scene "$TMP/syntax.json" -o "$TMP/a.png"
grep -qi "line" "$TMP/err" && ok || bad "syntax error message gives no line: $err"

cat >"$TMP/nomesh.json" <<'EOF'
{"mesh": "not/there/missing-mesh.obj",
 "lights": [{"type": "point", "position": [0, 0, 0], "intensity": [1, 1, 1]}]}
EOF
expect_error "missing-mesh.obj" "${R[@]}" --scene "$TMP/nomesh.json" -o "$TMP/a.png"

expect_error "no-such-estimator" "${R[@]}" --estimator no-such-estimator -o "$TMP/a.png"
expect_error "radius" "${R[@]}" --radius 0 -o "$TMP/a.png"
expect_error "radius" "${R[@]}" --radius -1 -o "$TMP/a.png"
expect_error "radius" "${R[@]}" --radius nan -o "$TMP/a.png"
expect_error "radius" "${R[@]}" --radius inf -o "$TMP/a.png"
expect_error "radius" "${R[@]}" --radius 0.1x -o "$TMP/a.png"
expect_error "photon" "${R[@]}" --photons 0 -o "$TMP/a.png"
expect_error "photon" "${R[@]}" --photons 10000000000 -o "$TMP/a.png"
expect_error "photon" "${R[@]}" --photons -5 -o "$TMP/a.png"
expect_error "size" "${R[@]}" --size 0x10 -o "$TMP/a.png"
expect_error "size" "${R[@]}" --size 100000x100000 -o "$TMP/a.png"
expect_error "size" "${R[@]}" --size abc -o "$TMP/a.png"
expect_error "size" "${R[@]}" --size 64x64x64 -o "$TMP/a.png"
expect_error "--frobnicate" "${R[@]}" --frobnicate 3 -o "$TMP/a.png"
expect_error "-o" "${R[@]}"
expect_error ".bmp" "${R[@]}" -o "$TMP/x.bmp"
expect_error "/nonexistent/dir/x.png" "${R[@]}" -o /nonexistent/dir/x.png
expect_error "camera" "${R[@]}" --camera 99 -o "$TMP/a.png"
expect_error "bounces" "${R[@]}" --bounces 0 -o "$TMP/a.png"
expect_error "threads" "${R[@]}" --threads 0 -o "$TMP/a.png"
expect_error "--radius" "${R[@]}" -o "$TMP/a.png" --radius
expect_error "no-such-command" no-such-command
expect_error "no-such-scene" info --scene no-such-scene
expect_error "/nonexistent/dir/s.json" "${R[@]}" -o "$TMP/a.png" --stats /nonexistent/dir/s.json
# Failed renders must not leave an image behind.
[ ! -e "$TMP/x.bmp" ] && ok || bad "an image was written for -o x.bmp"

# ------------------------------------------------------------ outputs checked before any work
# A bad output fails at once, naming the path and the problem, before the scene is read: with a
# broken scene the message is still about the output, and on a terminal no progress line appears.
expect_status 1 "/nonexistent/dir/x.png" render --scene "$TMP/broken.obj" -o /nonexistent/dir/x.png
grep -qi "broken.obj" "$TMP/err" && bad "render -o /nonexistent/dir/x.png read the scene first: $err" || ok
grep -qi "does not exist" "$TMP/err" && ok || bad "render -o /nonexistent/dir/x.png: no 'does not exist': $err"
expect_status 2 "x.jpg" render --scene "$TMP/broken.obj" -o "$TMP/x.jpg"
grep -qiF ".png or .exr" "$TMP/err" && ok || bad "render -o x.jpg does not name the formats: $err"
expect_status 2 "no file extension" render --scene "$TMP/broken.obj" -o "$TMP/noext"
expect_status 1 "/nonexistent/dir/s.json" render --scene "$TMP/broken.obj" -o "$TMP/a.png" --stats /nonexistent/dir/s.json
mkdir -p "$TMP/adir" "$TMP/adir.png"
expect_status 1 "is a folder" render --scene "$TMP/broken.obj" -o "$TMP/adir.png"
expect_status 1 "is a folder" render --scene "$TMP/broken.obj" -o "$TMP/a.png" --stats "$TMP/adir"
expect_status 1 "/nonexistent/dir/r.exr" reference --scene "$TMP/broken.obj" -o /nonexistent/dir/r.exr
expect_status 2 "r.jpg" reference --scene "$TMP/broken.obj" -o "$TMP/r.exr" --png "$TMP/r.jpg"
expect_status 1 "/nonexistent/dir/r.png" reference --scene "$TMP/broken.obj" -o "$TMP/r.exr" --png /nonexistent/dir/r.png
mkdir -p "$TMP/side.exr.json"
expect_status 1 "side.exr.json" reference --scene "$TMP/broken.obj" -o "$TMP/side.exr"
expect_status 1 "/nonexistent/dir/h.png" compare "$TMP/missing-a.png" "$TMP/missing-b.png" --diff /nonexistent/dir/h.png
expect_status 2 "h.jpg" compare "$TMP/missing-a.png" "$TMP/missing-b.png" --diff "$TMP/h.jpg"
if [ "$(id -u)" != 0 ]; then
    mkdir -p "$TMP/ro" && chmod 555 "$TMP/ro"
    expect_status 1 "$TMP/ro" render --scene "$TMP/broken.obj" -o "$TMP/ro/x.png"
    chmod 755 "$TMP/ro"
fi
# Nothing is created or truncated early: a render that fails later keeps the existing file.
printf 'keep me' >"$TMP/keep.png"
expect_status 1 "broken.obj" render --scene "$TMP/broken.obj" -o "$TMP/keep.png"
[ "$(cat "$TMP/keep.png")" = "keep me" ] && ok || bad "a failed render changed the existing output file"
# The issue's case: 2M photons into a missing folder fail before any tracing.
if on_tty render --scene cornell --photons 2000000 -o /nonexistent/dir/x.png; then
    [ "$rc" = 1 ] && ok || bad "render -o /nonexistent/dir/x.png on a terminal: exit status $rc"
    grep -qi "tracing" "$TMP/tty" && bad "render -o /nonexistent/dir/x.png traced photons first" || ok
fi

# ------------------------------------------------------------ exit status convention
# 2: the command line alone is wrong; 1: it is well formed but a file or the work is not.
expect_status 2 "--frobnicate" render --frobnicate 3 -o "$TMP/a.png"
expect_status 2 "--photons" render --photons 0 -o "$TMP/a.png"
expect_status 2 "no-such-command" no-such-command
expect_status 2 "no-such-estimator" render --estimator no-such-estimator -o "$TMP/a.png"
expect_status 2 ".jpg" render -o "$TMP/a.jpg"
expect_status 2 "kdtree" render --estimator tiled --knn 8 -o "$TMP/a.png"
expect_status 2 "exact" render --estimator directional --progressive 2 -o "$TMP/a.png"
expect_status 2 "do not give them" reference --continue "$TMP/none.exr" --scene cornell
expect_status 1 "/nonexistent/x.obj" render --scene /nonexistent/x.obj -o "$TMP/a.png"
expect_status 1 "missing-mesh.obj" "${R[@]}" --scene "$TMP/nomesh.json" -o "$TMP/a.png"
expect_status 1 "broken.obj" "${R[@]}" --scene "$TMP/broken.obj" -o "$TMP/a.png"
expect_status 1 "no-such-scene" render --scene no-such-scene -o "$TMP/a.png"
expect_status 1 "no-such-scene" info --scene no-such-scene
expect_status 1 "/nonexistent/dir/x.png" render -o /nonexistent/dir/x.png
expect_status 1 "camera" "${R[@]}" --camera 99 -o "$TMP/a.png"
expect_status 1 "cannot continue" reference --continue "$TMP/none.exr" --spp 1
expect_status 1 "missing-a.png" compare "$TMP/missing-a.png" "$TMP/missing-b.png"
run --help
printf '%s\n' "$out" | grep -q "usage error" && ok || bad "photongi --help does not explain the exit status"

# ------------------------------------------------------------ help
if expect_ok help; then
    main_help=$out
    run --help
    [ "$out" = "$main_help" ] && ok || bad "'photongi help' differs from 'photongi --help'"
fi
for c in render estimators info reference compare; do
    if expect_ok help "$c"; then
        topic=$out
        run "$c" --help
        [ "$rc" = 0 ] && [ "$out" = "$topic" ] && ok || bad "'photongi help $c' differs from 'photongi $c --help'"
    fi
done
expect_status 2 "nope" help nope
expect_status 2 "one command" help render info

# ------------------------------------------------------------ limits in the messages
expect_status 2 "1..100000000" render --photons 1e12 -o "$TMP/a.png"
expect_status 2 "1..100000000" render --photons 200000000 -o "$TMP/a.png"
expect_status 2 "1..16384" render --size 20000x10 -o "$TMP/a.png"
expect_status 2 "37748736" render --size 16000x16000 -o "$TMP/a.png"
expect_status 2 "1..64" render --bounces 65 -o "$TMP/a.png"
expect_status 2 "1..1024" render --threads 0 -o "$TMP/a.png"
expect_status 2 "1..4096" render --direct-samples 0 -o "$TMP/a.png"
expect_status 2 "0..16" render --filter 17 -o "$TMP/a.png"
expect_status 2 "1..1000000" render --progressive 0 -o "$TMP/a.png"
expect_status 2 "0..18446744073709551615" render --seed -1 -o "$TMP/a.png"
expect_status 2 "4..64" render --estimator bounds25d --polygon 7 -o "$TMP/a.png"
expect_status 2 "finite number above 0" render --cell-size 1e39 -o "$TMP/a.png"
expect_status 2 "1..1099511627776" reference --spp 0 -o "$TMP/r.exr"
expect_status 2 "1..64" reference --bounces 0 -o "$TMP/r.exr"
expect_status 2 "1..16384" reference --size 0x5 -o "$TMP/r.exr"
expect_status 2 "--diff-max" compare "$TMP/a.png" "$TMP/b.png" --diff-max -1
# A count may be written in exponent form.
if expect_ok render --scene cornell --size 16x12 --photons 2e3 -q -o "$TMP/e.png" --stats "$TMP/e.json"; then
    grep -qE '"stored":[[:space:]]*2000,' "$TMP/e.json" && ok || bad "render --photons 2e3 did not store 2000 photons"
fi

# ------------------------------------------------------------ -q: errors only
# A scene that stores no photon (one triangle: no photon has a second hit) warns ...
printf 'v -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 3 2\n' >"$TMP/tri.obj"
printf '{"mesh": "tri.obj", "lights": [{"type": "point", "position": [0, 1, 0], "intensity": [1, 1, 1]}],
 "cameras": [{"eye": [0, 2, 3], "look_at": [0, 0, 0]}]}\n' >"$TMP/lost.json"
if expect_ok render --scene "$TMP/lost.json" --size 8x8 --photons 10 -o "$TMP/lost.png"; then
    grep -q "warning" "$TMP/err" && ok || bad "render of a scene that stores no photon did not warn: $err"
fi
# ... but not with -q, which also drops notes; errors still print.
expect_ok render --scene "$TMP/lost.json" --size 8x8 --photons 10 -q -o "$TMP/lost.png" &&
    { [ -z "$err" ] && ok || bad "render -q printed on stderr: $err"; }
expect_ok render --scene cornell --size 8x8 --photons 100 --tile 8 -q -o "$TMP/n.png" &&
    { [ -z "$err" ] && ok || bad "render -q printed a note: $err"; }
expect_status 1 "/nonexistent/x.obj" render -q --scene /nonexistent/x.obj -o "$TMP/a.png"

# ------------------------------------------------------------ progress line on a terminal only
# Not when stderr is a file ...
if expect_ok render --scene cornell --size 16x12 --photons 2000 --progressive 2 -o "$TMP/pr.png"; then
    grep -q "tracing" "$TMP/err" && bad "render printed progress to a file: $err" || ok
    grep -q $'\r' "$TMP/err" && bad "render printed a carriage return to a file" || ok
fi
# ... on a terminal a line redrawn as passes and frames go (at most 10 times a second: the first
# report, frame 1's view samples, is the one always drawn), erased before the summary ...
if on_tty render --scene cornell --size 16x12 --photons 2000 --progressive 2 -o "$TMP/pr.png"; then
    [ "$rc" = 0 ] && ok || bad "render on a terminal: exit status $rc"
    grep -qF $'\r[' "$TMP/tty" && grep -qF "frame 1/2: view samples" "$TMP/tty" && ok ||
        bad "render --progressive 2 on a terminal shows no progress: $(head -c 300 "$TMP/tty")"
    grep -qF $'\r\033[K' "$TMP/tty" && ok || bad "render on a terminal does not erase its progress line"
    grep -q "pr.png: cornell" "$TMP/tty" && ok || bad "render on a terminal: no summary"
    on_tty render --scene cornell --size 16x12 --photons 2000 -o "$TMP/pr.png"
    grep -qF "view samples" "$TMP/tty" && ok || bad "render on a terminal shows no progress: $(head -c 300 "$TMP/tty")"
    # ... and with -q nothing at all.
    on_tty render --scene cornell --size 16x12 --photons 2000 -q -o "$TMP/pr.png"
    [ "$rc" = 0 ] && [ ! -s "$TMP/tty" ] && ok || bad "render -q on a terminal printed: $(head -c 300 "$TMP/tty")"
    on_tty reference --scene cornell --size 8x8 --spp 2 -o "$TMP/prr.exr"
    grep -q "2/2 spp" "$TMP/tty" && ok || bad "reference on a terminal shows no progress bar"
else
    echo "note: no terminal (util-linux script); the progress line is not tested"
fi

# ------------------------------------------------------------ good input
if expect_ok estimators; then
    names=$(printf '%s\n' "$out")
    for n in brute hashgrid tiled; do
        printf '%s\n' "$names" | grep -qx "$n" && ok || bad "'photongi estimators' does not list $n"
    done
    # Only names, one a line: every line is a single word.
    if printf '%s\n' "$names" | grep -qvE '^[a-z0-9_-]+$'; then bad "'photongi estimators' prints more than names: $names"; else ok; fi
fi

if expect_ok info --scene cornell; then
    tri=$(printf '%s\n' "$out" | sed -n 's/^triangles:[[:space:]]*\([0-9][0-9]*\)$/\1/p')
    [ -n "$tri" ] && [ "$tri" -gt 0 ] && ok || bad "info --scene cornell: no positive 'triangles:' line in: $out"
fi

if expect_ok render --help; then
    printf '%s\n' "$out" | grep -q -- "--photons" && ok || bad "render --help does not describe --photons"
fi

# Every built-in scene renders at its own defaults (photons included) without a warning: all the
# photons asked for are stored (sphere-and-plane's light once lost too many paths for 200000).
for s in cornell giref sphere-and-plane; do
    if expect_ok render --scene "$s" --size 32x24 -o "$TMP/def.png" --stats "$TMP/def.json"; then
        grep -qi "warning" "$TMP/err" && bad "render --scene $s at its defaults warns: $err" || ok
        if command -v python3 >/dev/null 2>&1; then
            python3 -c 'import json,sys; sys.exit(json.load(open(sys.argv[1]))["photons"]["stored"] != 200000)' \
                "$TMP/def.json" && ok || bad "render --scene $s: fewer than its default 200000 photons stored"
        fi
    fi
done

if expect_ok render --scene cornell --size 64x48 --photons 5000 -o "$TMP/img.png" --stats "$TMP/stats.json" -q; then
    if [ -s "$TMP/img.png" ]; then
        # PNG signature, then the IHDR chunk: width and height as big-endian 32-bit numbers at bytes 16..23.
        sig=$(head -c 8 "$TMP/img.png" | od -An -tx1 | tr -d ' \n')
        [ "$sig" = "89504e470d0a1a0a" ] && ok || bad "img.png: not a PNG signature ($sig)"
        dims=$(od -An -tx1 -j16 -N8 "$TMP/img.png" | tr -d ' \n')
        [ "$dims" = "0000004000000030" ] && ok || bad "img.png: IHDR size bytes $dims, expected 64x48 (0000004000000030)"
    else
        bad "render did not write img.png"
    fi
    if [ -s "$TMP/stats.json" ]; then
        for key in '"contributing"' '"times_ms"'; do
            grep -qF "$key" "$TMP/stats.json" && ok || bad "stats.json has no $key"
        done
        if command -v python3 >/dev/null 2>&1; then
            python3 -c 'import json,sys; json.load(open(sys.argv[1]))' "$TMP/stats.json" && ok || bad "stats.json is not valid JSON"
        fi
    else
        bad "render did not write stats.json"
    fi
fi

# '--stats -' is documented ("'-' = stdout"): the JSON goes to stdout, no file named '-'.
mkdir -p "$TMP/cwd"
if (cd "$TMP/cwd" && "$BIN" render --scene cornell --size 32x24 --photons 2000 -q -o img.png --stats - \
        >"$TMP/out" 2>"$TMP/err"); then
    grep -qF '"contributing"' "$TMP/out" && ok || bad "render --stats -: no statistics on stdout"
    [ ! -e "$TMP/cwd/-" ] && ok || bad "render --stats -: wrote a file named '-' instead of stdout"
else
    bad "render --stats -: exit status $?: $(head -c 300 "$TMP/err")"
fi

# Named scenes (scenes/NAME.json) from any directory: the source tree's scenes/ is searched after
# ./scenes, and the meshes are found in $PHOTONGI_SCENES, or without it next to the source tree.
SRC=$PWD
mkdir -p "$TMP/elsewhere"
if [ -f "$SRC/../shared/scenes/cornell-box/CornellBox-Original.obj" ]; then
    for scenes_env in "PHOTONGI_SCENES=$SRC/../shared/scenes" "-u PHOTONGI_SCENES"; do
        # shellcheck disable=SC2086
        if (cd "$TMP/elsewhere" && env $scenes_env "$BIN" render --scene cornell-box --size 16x16 --photons 1000 -q \
                -o named.png >"$TMP/out" 2>"$TMP/err"); then
            [ -s "$TMP/elsewhere/named.png" ] && ok || bad "render --scene cornell-box from $TMP/elsewhere wrote no image"
        else
            bad "render --scene cornell-box from another directory ($scenes_env) failed: $(head -c 300 "$TMP/err")"
        fi
        rm -f "$TMP/elsewhere/named.png"
    done
    (cd "$TMP/elsewhere" && "$BIN" info --scene cornell-box >"$TMP/out" 2>"$TMP/err") &&
        grep -q "^source: *$SRC/scenes/cornell-box.json$" "$TMP/out" && ok ||
        bad "info --scene cornell-box from another directory: not the source tree's description: $(cat "$TMP/out" "$TMP/err")"
else
    echo "note: $SRC/../shared/scenes/cornell-box missing; named scenes from another directory not tested"
fi
# ... and ./scenes comes first.
mkdir -p "$TMP/elsewhere/scenes"
printf '{"builtin": "giref", "name": "local-one"}\n' >"$TMP/elsewhere/scenes/cornell-box.json"
(cd "$TMP/elsewhere" && "$BIN" info --scene cornell-box >"$TMP/out" 2>"$TMP/err") && grep -q "^scene: *local-one$" "$TMP/out" &&
    ok || bad "info --scene cornell-box did not take ./scenes/cornell-box.json first: $(cat "$TMP/out" "$TMP/err")"
rm -rf "$TMP/elsewhere/scenes"
expect_error "cornell-box" info --scene no-such-scene

if expect_ok render --scene cornell --size 40x30 --photons 2000 --output indirect -o "$TMP/img.exr" -q; then
    [ -s "$TMP/img.exr" ] && ok || bad "render did not write img.exr"
fi

# Progressive mode and scene time.
expect_error "--progressive needs" render --progressive 0 -o "$TMP/x.png"
expect_error "--progressive needs" render --progressive many -o "$TMP/x.png"
expect_error "--time needs" render --time soon -o "$TMP/x.png"
expect_error "--output must be" render --output everything -o "$TMP/x.png"
if expect_ok render --scene cornell --size 32x24 --photons 2000 --progressive 3 -o "$TMP/prog.png" --stats "$TMP/prog.json" -q; then
    grep -qE '"frames":[[:space:]]*3,' "$TMP/prog.json" && ok || bad "render --progressive 3: stats do not say 3 frames"
    grep -qE '"jitter":[[:space:]]*"auto"' "$TMP/prog.json" && ok || bad "render --progressive 3: stats lack jitter auto"
fi
# Pixel sampling: one frame at pixel centres by default, --jitter on/off.
expect_error "--jitter must be" render --jitter sometimes -o "$TMP/x.png"
if expect_ok render --scene cornell --size 32x24 --photons 2000 -o "$TMP/j0.png" --stats "$TMP/j0.json" -q; then
    grep -qE '"jitter":[[:space:]]*"off"' "$TMP/j0.json" && ok || bad "render: one frame's stats lack jitter off"
fi
if expect_ok render --scene cornell --size 32x24 --photons 2000 --jitter on -o "$TMP/j1.png" --stats "$TMP/j1.json" -q; then
    grep -qE '"jitter":[[:space:]]*"on"' "$TMP/j1.json" && ok || bad "render --jitter on: stats lack jitter on"
    cmp -s "$TMP/j0.png" "$TMP/j1.png" && bad "render --jitter on: same image as pixel centres" || ok
fi
if expect_ok render --scene scenes/cornell-moving.json --time 2.5 --size 32x24 --photons 2000 --output counts -o "$TMP/c.exr" -q; then
    [ -s "$TMP/c.exr" ] && ok || bad "render --output counts did not write c.exr"
fi
# Cluster estimators and their options.
expect_error "--cluster-tile" render --scene cornell --estimator cluster --cluster-tile 0 -o "$TMP/c.png"
expect_error "--directional-level" render --scene cornell --estimator directional --directional-level 17 -o "$TMP/c.png"
expect_error "--directional-blur" render --scene cornell --estimator directional --directional-blur x -o "$TMP/c.png"
for est in cluster cluster-cone cluster-trivial directional; do
    if expect_ok render --scene cornell --estimator "$est" --cluster-tile 4 --size 40x30 --photons 2000 -q \
            -o "$TMP/$est.png"; then
        [ -s "$TMP/$est.png" ] && ok || bad "render --estimator $est did not write an image"
    fi
done
expect_ok render --scene cornell --estimator directional --directional-level 0 --directional-blur 0 --size 40x30 \
    --photons 2000 -q -o "$TMP/d.png"
# bvh estimator and radius policies
expect_error "--radius-policy must be" render --radius-policy wide -o "$TMP/x.png"
expect_error "--r-min needs a positive number" render --radius-policy path --r-min -1 -o "$TMP/x.png"
expect_error "--r-max needs a positive number" render --radius-policy path --r-max nan -o "$TMP/x.png"
expect_error "--r-max needs a positive number" render --radius-policy path --r-max inf -o "$TMP/x.png"
expect_error "--smoothing needs a positive number" render --radius-policy differentials --smoothing 0 -o "$TMP/x.png"
expect_status 2 "must not exceed --r-max" render --estimator bvh --radius-policy path --r-min 2 --r-max 1 --size 8x8 \
    --photons 100 -o "$TMP/x.png"
expect_error "per-photon" render --estimator hashgrid --radius-policy differentials --size 8x8 --photons 100 \
    -o "$TMP/x.png"
expect_error "--bvh-build must be" render --estimator bvh --bvh-build sah -o "$TMP/x.png"
expect_error "--leaf-size needs" render --estimator bvh --leaf-size -2 -o "$TMP/x.png"
expect_error "--leaf-size needs" render --estimator bvh --leaf-size 100000 -o "$TMP/x.png"
run render --help
printf '%s' "$out" | grep -qF -- "--radius-policy" && ok || bad "render --help does not mention --radius-policy"
run estimators
printf '%s' "$out" | grep -qx "bvh" && ok || bad "'photongi estimators' does not list bvh"
if expect_ok render --scene cornell --estimator bvh --bvh-build vvh --leaf-size 4 --radius-policy differentials \
        --size 32x24 --photons 3000 -q -o "$TMP/bvh.png" --stats "$TMP/bvh.json"; then
    for key in '"footprint_histogram"' '"bvh_leaf_size"' '"differentials"'; do
        grep -qF "$key" "$TMP/bvh.json" && ok || bad "bvh stats have no $key"
    done
fi

# ---- the default emission is auto: where it keeps uniform emission (the Cornell box) the image is
# uniform's, byte for byte, and --stats says what was used and why
if expect_ok render --scene cornell --size 32x24 --photons 3000 -q -o "$TMP/em-def.exr" --stats "$TMP/em-def.json" &&
    expect_ok render --scene cornell --size 32x24 --photons 3000 -q --emission uniform -o "$TMP/em-uni.exr"; then
    cmp -s "$TMP/em-def.exr" "$TMP/em-uni.exr" && ok || bad "render at the default emission: not uniform's bytes (cornell)"
    grep -qE '"emission":[[:space:]]*"auto"' "$TMP/em-def.json" && grep -qE '"emission_used":[[:space:]]*"uniform"' \
        "$TMP/em-def.json" && grep -qF '"emission_reason"' "$TMP/em-def.json" && ok ||
        bad "render: stats lack emission auto, emission_used uniform or emission_reason"
fi
if expect_ok render --scene window-box-portals --size 32x24 --photons 3000 -q -o "$TMP/em-p.exr" \
    --stats "$TMP/em-p.json"; then
    grep -qE '"emission_used":[[:space:]]*"portal"' "$TMP/em-p.json" && ok ||
        bad "render window-box-portals at the default emission: not portal emission"
fi

# ---- render --from-stats: a frame's statistics render it again, to the byte
for cfg in "exr --scene cornell-box --estimator tiled --tile 8 --radius auto --progressive 3 --seed 7" \
    "png --scene window-box --estimator kdtree --knn 12 --bounces 3 --direct-samples 4" \
    "exr --scene cornell --estimator bvh --radius-policy path --r-max 0.08 --jitter on"; do
    # shellcheck disable=SC2086  # the words of cfg are the extension and options
    set -- $cfg
    ext=$1
    shift
    if expect_ok render "$@" --size 48x32 --photons 3000 -q --stats "$TMP/fs.json" -o "$TMP/fs1.$ext" &&
        expect_ok render --from-stats "$TMP/fs.json" -q -o "$TMP/fs2.$ext"; then
        cmp -s "$TMP/fs1.$ext" "$TMP/fs2.$ext" && ok || bad "render --from-stats ($cfg): not the same bytes"
    fi
done
grep -q '"settings"' "$TMP/fs.json" && grep -q '"version"' "$TMP/fs.json" && grep -q '"scene":[[:space:]]*"cornell"' "$TMP/fs.json" &&
    ok || bad "--stats lacks settings, version or the run's scene"
# options after it change it; a file that is not statistics is a failure naming it
if expect_ok render --from-stats "$TMP/fs.json" --photons 1000 -q -o "$TMP/fs3.exr"; then
    cmp -s "$TMP/fs1.exr" "$TMP/fs3.exr" && bad "render --from-stats --photons 1000: the same image" || ok
fi
echo '{"width": 3}' >"$TMP/notstats.json"
expect_status 1 "notstats.json" render --from-stats "$TMP/notstats.json" -o "$TMP/x.png"
expect_status 1 "missing.json" render --from-stats "$TMP/missing.json" -o "$TMP/x.png"

# ---- study: every exact estimator at equal photons and equal time against a reference it makes once
if expect_ok study --scene cornell --size 40x30 --photons 2000 --spp 8 --frames 2 --out "$TMP/study" -q; then
    for e in hashgrid tiled cluster cluster-trivial bvh kdtree bounds3d bounds25d; do
        [ "$(grep -c "^| $e |" "$TMP/study/study.md")" = 2 ] && ok || bad "study.md: not two rows for $e"
    done
    grep -q "^## Equal time" "$TMP/study/study.md" && grep -q "reference's noise" "$TMP/study/study.md" && ok ||
        bad "study.md lacks the equal-time table or the reference's noise"
    [ "$(wc -l <"$TMP/study/study.csv")" -gt 16 ] && grep -q '<polyline' "$TMP/study/study.svg" && ok ||
        bad "study: the CSV or the SVG plot is missing"
    # a second study of the same scene, size and samples reuses the reference
    if expect_ok study --scene cornell --size 40x30 --photons 2000 --spp 8 --frames 2 --estimators tiled,directional \
        --out "$TMP/study"; then
        case $err in *"reusing"*) ok ;; *) bad "study did not reuse its reference: $err" ;; esac
        grep -q "^| directional |" "$TMP/study/study.md" && ok || bad "study --estimators directional: no row"
    fi
    # compare reports a reference's noise from the half study keeps beside it: the half scores against the
    # whole about what the whole scores against the truth (both are the variance of N samples' mean)
    if expect_ok compare "$TMP/study/reference-half.exr" "$TMP/study/reference.exr" --json; then
        awk -v j="$out" 'BEGIN {
            if (match(j, /"psnr": [0-9.]+/)) p = substr(j, RSTART + 8, RLENGTH - 8) + 0; else exit 1
            if (match(j, /"reference_noise_psnr": [0-9.]+/)) q = substr(j, RSTART + 24, RLENGTH - 24) + 0; else exit 1
            exit !(q > 10 && p - q < 3 && q - p < 3) }' && ok ||
            bad "compare --json: no reference_noise_psnr, or far from the half's own PSNR: $out"
    fi
    if expect_ok compare "$TMP/study/reference-half.exr" "$TMP/study/reference.exr"; then
        case $out in *"reference noise: PSNR"*) ok ;; *) bad "compare: no reference noise line: $out" ;; esac
    fi
    mv "$TMP/study/reference-half.exr.json" "$TMP/study/half.json"
    expect_ok compare "$TMP/study/reference-half.exr" "$TMP/study/reference.exr" --json &&
        case $out in *'"reference_noise_psnr": null'*) ok ;; *) bad "compare: noise without the half's sidecar" ;; esac
    mv "$TMP/study/half.json" "$TMP/study/reference-half.exr.json"
fi
expect_status 2 "unknown estimator" study --estimators tiled,nope --out "$TMP/study"
# render settings pass through (radius, pixel centres: the reference too), budgets, the path tracer, variants
if expect_ok study --scene cornell --size 24x16 --photons 2000 --spp 8 --estimators hashgrid+guided,pathtracer \
    --time 5,20 --jitter off --radius 0.1 --reference "$TMP/sref.exr" --out "$TMP/study2" -q; then
    [ "$(grep -c ',time,' "$TMP/study2/study.csv")" = 4 ] && ok || bad "study --time 5,20: not four equal-time rows"
    grep -q '^"cornell",24,16,2000,hashgrid+guided,photons,1,.*,0.1,[0-9.]*,[0-9.]*,off,0$' \
        "$TMP/study2/study.csv" && ok || bad "study: hashgrid+guided's frame is not at radius 0.1, pixel centres"
    grep -q '"jitter":.*false' "$TMP/sref.exr.json" && [ -f "$TMP/sref-half.exr" ] && ok ||
        bad "study --jitter off --reference: not a pixel-centre reference with its half"
    [ -f "$TMP/study2/pathtracer-time-20ms.png" ] && ! [ -f "$TMP/study2/pathtracer-photons.png" ] && ok ||
        bad "study: the path tracer's images are not its equal-time ones"
fi
expect_status 2 "+guided or +view" study --estimators hashgrid+fast --out "$TMP/study"
expect_status 2 "not a setting of study" study --progressive 4 --out "$TMP/study"
expect_status 2 "increasing" study --time 20,5 --out "$TMP/study"
expect_status 2 "--spp" study --spp 1 --out "$TMP/study"

# ---- reference and compare
expect_error "--spp" reference --scene cornell --spp 0 -o "$TMP/r.exr"
expect_error ".exr" reference --scene cornell --spp 1 -o "$TMP/r.png"
expect_error "no output" reference --scene cornell --spp 1
expect_error "--time" reference --scene cornell --time -3 -o "$TMP/r.exr"
expect_error "cannot continue" reference --continue "$TMP/none.exr" --spp 1
expect_error "do not give them" reference --continue "$TMP/none.exr" --scene cornell
if expect_ok reference --scene cornell --size 24x16 --spp 2 -q -o "$TMP/r.exr" --png "$TMP/r.png"; then
    grep -q '"spp":[[:space:]]*"2"' "$TMP/r.exr.json" && ok || bad "reference: r.exr.json lacks spp 2"
    [ -s "$TMP/r.png" ] && ok || bad "reference did not write --png"
    if expect_ok reference --continue "$TMP/r.exr" --spp 3 -q; then
        grep -q '"spp":[[:space:]]*"5"' "$TMP/r.exr.json" && ok || bad "reference --continue: spp is not 5"
        grep -q '"scene":[[:space:]]*"cornell"' "$TMP/r.exr.json" && ok || bad "reference --continue lost the scene"
    fi
    expect_ok render --scene cornell --size 24x16 --photons 2000 -q -o "$TMP/p.png"
    if expect_ok compare "$TMP/p.png" "$TMP/r.exr" --json --diff "$TMP/heat.png"; then
        case $out in *'"ssim"'*'"psnr"'*|*'"psnr"'*'"ssim"'*) ok ;; *) bad "compare --json: no ssim/psnr: $out" ;; esac
        [ -s "$TMP/heat.png" ] && ok || bad "compare did not write the heat map"
        case $out in *'"flip": 0.'[0-9]*'"flip_weighted_median"'*) ok ;; *) bad "compare --json: no flip: $out" ;; esac
        # the pixel-area reference's sidecar: a note for a single pixel-centre frame
        case $err in *"pixel-area reference"*) ok ;; *) bad "compare of a frame with a reference: no sampling note: $err" ;; esac
    fi
    # FLIP: an image against itself is 0; the FLIP map is written; a bad --ppd is a usage error
    if expect_ok compare "$TMP/p.png" "$TMP/p.png" --flip-map "$TMP/flip.png"; then
        case $out in *'FLIP 0.000000 '*) ok ;; *) bad "compare of an image with itself: FLIP not 0: $out" ;; esac
        [ -s "$TMP/flip.png" ] && ok || bad "compare did not write the FLIP map"
    fi
    # the PNG and the EXR of one render are identical at the render's exposure (window-box sets 2)
    if expect_ok render --scene window-box --size 40x24 --photons 3000 -q -o "$TMP/wb.png" &&
        expect_ok render --scene window-box --size 40x24 --photons 3000 -q -o "$TMP/wb.exr"; then
        for e in 2 0.5; do
            if expect_ok render --scene window-box --size 40x24 --photons 3000 --exposure $e -q -o "$TMP/wb$e.png" &&
                expect_ok compare "$TMP/wb$e.png" "$TMP/wb.exr" --exposure $e; then
                case $out in *'PSNR inf dB'*) ok ;; *) bad "compare PNG vs its EXR at exposure $e: $out" ;; esac
                case $err in *"8-bit image"*) ok ;; *) bad "compare PNG vs EXR: no note: $err" ;; esac
            fi
        done
        expect_ok compare "$TMP/wb.png" "$TMP/wb.exr" --exposure 2 --json
        case $out in *'"psnr": null'*) ok ;; *) bad "compare PNG vs its EXR (scene exposure 2): $out" ;; esac
    fi
    expect_status 2 "--ppd" compare "$TMP/p.png" "$TMP/r.exr" --ppd 0
    expect_status 2 "--flip-map" compare "$TMP/p.png" "$TMP/r.exr" --flip-map "$TMP/flip.jpg"
    expect_ok render --scene cornell --size 32x16 --photons 2000 -q -o "$TMP/q.png"
    expect_status 1 "sizes differ" compare "$TMP/q.png" "$TMP/r.exr"
    expect_error "missing.png" compare "$TMP/p.png" "$TMP/missing.png"
    expect_error "two images" compare "$TMP/p.png"
    expect_error "unknown option" compare "$TMP/p.png" "$TMP/r.exr" --frobnicate
    # --merge: two seeds' samples averaged, their counts summed; same seed or other settings refused
    if expect_ok reference --scene cornell --size 24x16 --spp 3 --seed 9 -q -o "$TMP/r9.exr"; then
        if expect_ok reference --merge "$TMP/r.exr" "$TMP/r9.exr" -o "$TMP/rm.exr" -q; then
            grep -q '"spp":[[:space:]]*"8"' "$TMP/rm.exr.json" && ok || bad "reference --merge: spp is not 5 + 3"
        fi
        expect_status 1 "same samples" reference --merge "$TMP/r9.exr" "$TMP/r9.exr" -o "$TMP/rm.exr"
        expect_status 2 "two references" reference --merge "$TMP/r9.exr" -o "$TMP/rm.exr"
        expect_status 2 "only the two" reference --merge "$TMP/r.exr" "$TMP/r9.exr" --spp 2 -o "$TMP/rm.exr"
    fi
    expect_ok reference --scene cornell --size 20x16 --spp 1 --seed 9 -q -o "$TMP/r20.exr"
    expect_status 1 "sizes differ" reference --merge "$TMP/r.exr" "$TMP/r20.exr" -o "$TMP/rm.exr"
    grep -qE '"jitter":[[:space:]]*true' "$TMP/r.exr.json" && ok || bad "reference: r.exr.json lacks jitter true"
    printf 'not json' >"$TMP/r.exr.json"
    expect_error "metadata" reference --continue "$TMP/r.exr" --spp 1
fi
# --continue twice in a row keeps the scene (giref: not the default, so a lost name would show)
# and adds up the samples.
if expect_ok reference --scene giref --size 8x8 --spp 1 -q -o "$TMP/g.exr"; then
    for n in 2 3; do
        if expect_ok reference --continue "$TMP/g.exr" --spp 1 -q; then
            grep -q "\"spp\":[[:space:]]*\"$n\"" "$TMP/g.exr.json" && ok || bad "reference --continue (to $n spp): wrong spp"
            grep -q '"scene":[[:space:]]*"giref"' "$TMP/g.exr.json" && ok ||
                bad "reference --continue (to $n spp) lost the scene: $(cat "$TMP/g.exr.json")"
        fi
    done
fi
# Reference at pixel centres: kept by --continue; a format-1 sidecar (an older photongi) continues
# as centres; --continue takes the jitter from the sidecar.
expect_error "--jitter must be" reference --scene cornell --spp 1 --jitter maybe -o "$TMP/c.exr"
if expect_ok reference --scene cornell --size 24x16 --spp 2 --jitter off -q -o "$TMP/c.exr"; then
    grep -qE '"jitter":[[:space:]]*false' "$TMP/c.exr.json" && ok || bad "reference --jitter off: no jitter false"
    expect_error "do not give them" reference --continue "$TMP/c.exr" --jitter on --spp 1
    if expect_ok reference --continue "$TMP/c.exr" --spp 1 -q; then
        grep -qE '"jitter":[[:space:]]*false' "$TMP/c.exr.json" && ok || bad "reference --continue lost jitter false"
    fi
    sed -e 's/photongi-reference-2/photongi-reference-1/' -e '/"jitter"/d' -e '/"specular"/d' -e '/"exr_/d' -e 's/"spp":[[:space:]]*"3",/"spp": "3"/' \
        "$TMP/c.exr.json" >"$TMP/c1.json" && mv "$TMP/c1.json" "$TMP/c.exr.json"
    if expect_ok reference --continue "$TMP/c.exr" --spp 1 -q; then
        grep -qE '"jitter":[[:space:]]*false' "$TMP/c.exr.json" && ok || bad "format-1 reference did not continue at centres"
        grep -q '"spp":[[:space:]]*"4"' "$TMP/c.exr.json" && ok || bad "format-1 reference --continue: spp is not 4"
    fi
fi
# --specular: the mesh's illum-2 materials as microfacet plastic (default) or the papers' Blinn-Phong.
expect_error "--specular must be" render --specular blinn -o "$TMP/x.png"
expect_error "--specular must be" reference --specular blinn -o "$TMP/x.exr"
printf 'newmtl floor\nKd 0.8 0.8 0.8\nKs 0.04 0.04 0.04\nNs 198\nillum 2\n' >"$TMP/g.mtl"
printf 'mtllib g.mtl\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nusemtl floor\nf 1 4 3 2\n' >"$TMP/g.obj"
printf '{"mesh": "%s", "camera": {"eye": [0, 0.5, 2], "look_at": [0, 0, 0]},\n "lights": [{"type": "point", "position": [0, 1, -0.5], "intensity": [1, 1, 1]}]%s}\n' \
    "$TMP/g.obj" "" >"$TMP/g.json"
printf '{"mesh": "%s", "camera": {"eye": [0, 0.5, 2], "look_at": [0, 0, 0]},\n "lights": [{"type": "point", "position": [0, 1, -0.5], "intensity": [1, 1, 1]}]%s}\n' \
    "$TMP/g.obj" ', "specular": "phong"' >"$TMP/gp.json"
if expect_ok info --scene "$TMP/g.json"; then
    printf '%s\n' "$out" | grep -q 'glossy: *1 mesh materials as microfacet plastic (ggx)' && ok || bad "info: no ggx line"
fi
if expect_ok info --scene "$TMP/gp.json"; then
    printf '%s\n' "$out" | grep -q 'glossy: *1 mesh materials as Blinn-Phong (phong)' && ok || bad "info: no phong line"
fi
if expect_ok render --scene "$TMP/g.json" --size 32x24 --photons 2000 -q -o "$TMP/g.exr" &&
    expect_ok render --scene "$TMP/g.json" --specular ggx --size 32x24 --photons 2000 -q -o "$TMP/g2.exr" &&
    expect_ok render --scene "$TMP/g.json" --specular phong --size 32x24 --photons 2000 -q -o "$TMP/g3.exr" &&
    expect_ok render --scene "$TMP/gp.json" --size 32x24 --photons 2000 -q -o "$TMP/g4.exr"; then
    cmp -s "$TMP/g.exr" "$TMP/g2.exr" && ok || bad "render --specular ggx differs from the default"
    cmp -s "$TMP/g.exr" "$TMP/g3.exr" && bad "render --specular phong: same image as ggx" || ok
    cmp -s "$TMP/g3.exr" "$TMP/g4.exr" && ok || bad "render --specular phong differs from \"specular\": \"phong\""
fi
if expect_ok reference --scene "$TMP/g.json" --specular phong --size 16x12 --spp 1 -q -o "$TMP/gr.exr"; then
    grep -qE '"specular":[[:space:]]*"phong"' "$TMP/gr.exr.json" && ok || bad "reference --specular phong: not in the .json"
    expect_error "do not give them" reference --continue "$TMP/gr.exr" --specular ggx --spp 1
    if expect_ok reference --continue "$TMP/gr.exr" --spp 1 -q; then
        grep -qE '"specular":[[:space:]]*"phong"' "$TMP/gr.exr.json" && ok || bad "reference --continue lost specular"
    fi
fi
# --camera NAME|I: a description's camera "name" (or a glTF camera node's); an unknown name lists the cameras.
printf '{"builtin": "cornell", "cameras": [{"eye": [0.6, 1, 3.6], "look_at": [0, 1, 0], "name": "side"},\n  {"eye": [0, 1, 3.9], "look_at": [0, 1, 0], "fov_y": 39, "name": "front"}]}\n' >"$TMP/named.json"
if expect_ok render --scene "$TMP/named.json" --camera front --size 32x24 --photons 2000 -q -o "$TMP/cf.exr" &&
    expect_ok render --scene "$TMP/named.json" --camera 1 --size 32x24 --photons 2000 -q -o "$TMP/c1.exr" &&
    expect_ok render --scene "$TMP/named.json" --camera side --size 32x24 --photons 2000 -q -o "$TMP/cs.exr"; then
    cmp -s "$TMP/cf.exr" "$TMP/c1.exr" && ok || bad "render --camera front differs from --camera 1"
    cmp -s "$TMP/cf.exr" "$TMP/cs.exr" && bad "render --camera side: the same image as front" || ok
fi
expect_status 1 "no camera named 'back' in scene named; its cameras: 0 'side', 1 'front'" \
    render --scene "$TMP/named.json" --camera back --size 32x24 -o "$TMP/x.png"
expect_status 1 "its cameras: 0 'side', 1 'front'" reference --scene "$TMP/named.json" --camera back --spp 1 -o "$TMP/x.exr"
expect_status 1 "the scene has 2" render --scene "$TMP/named.json" --camera 2 --size 32x24 -o "$TMP/x.png"
expect_status 2 "--camera needs a camera name or index" render --camera "" -o "$TMP/x.png"
if expect_ok reference --scene "$TMP/named.json" --camera front --size 16x12 --spp 1 -q -o "$TMP/cr.exr"; then
    grep -qE '"camera":[[:space:]]*1' "$TMP/cr.exr.json" && ok || bad "reference --camera front: not camera 1 in the .json"
fi
if expect_ok info --scene "$TMP/named.json"; then
    printf '%s\n' "$out" | grep -q "^camera 1: *'front' eye (0, 1, 3.9)" && ok || bad "info does not list camera 1 'front'"
fi
# one warning line names what the file holds that is not used or not found (-q silences it)
printf 'mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >"$TMP/nomtl.obj"
printf '{"mesh": "%s", "lights": [{"type": "point", "position": [0.2, 0.2, 1], "intensity": [1, 1, 1]}]}\n' \
    "$TMP/nomtl.obj" >"$TMP/nomtl.json"
if expect_ok render --scene "$TMP/nomtl.json" --size 16x12 --photons 500 -o "$TMP/w.png"; then
    [ "$(grep -c 'warning: .*nomtl.obj: not found: material library gone.mtl' "$TMP/err")" = 1 ] && ok ||
        bad "render: no single warning naming the missing gone.mtl"
fi
if expect_ok render --scene "$TMP/nomtl.json" --size 16x12 --photons 500 -q -o "$TMP/w.png"; then
    grep -q 'gone.mtl' "$TMP/err" && bad "render -q still warns about gone.mtl" || ok
fi
# kernels, subsampling, filter, k-NN, polygon bounds
expect_error "--knn" render --estimator kdtree --knn 0 -o "$TMP/x.png"
expect_error "--knn" render --estimator kdtree --knn -3 -o "$TMP/x.png"
expect_error "--knn" render --estimator kdtree --knn many -o "$TMP/x.png"
expect_error "kdtree" render --estimator tiled --knn 8 --size 32x24 --photons 1000 -o "$TMP/x.png"
expect_error "kernel" render --kernel gaussian -o "$TMP/x.png"
expect_error "--subsample" render --subsample 0 -o "$TMP/x.png"
expect_error "--subsample" render --subsample 65 -o "$TMP/x.png"
expect_error "subsampling" render --estimator bounds3d --subsample 2 --size 32x24 --photons 1000 -o "$TMP/x.png"
# the default estimator (cluster-trivial) takes neither: the message names it and those that do
expect_error "(the default) does not support --kernel" render --kernel cone --size 32x24 --photons 1000 -o "$TMP/x.png"
expect_error "brute, hashgrid, tiled, kdtree" render --kernel cone --size 32x24 --photons 1000 -o "$TMP/x.png"
expect_error "do: hashgrid, tiled, kdtree" render --subsample 2 --size 32x24 --photons 1000 -o "$TMP/x.png"
expect_ok render --scene cornell --size 40x30 --photons 2000 --kernel constant --subsample 1 -o "$TMP/d.png" -q
expect_error "subsampling" render --estimator kdtree --knn 4 --subsample 2 --size 32x24 --photons 1000 -o "$TMP/x.png"
expect_error "--filter" render --filter 17 -o "$TMP/x.png"
expect_error "--filter" render --filter -1 -o "$TMP/x.png"
expect_error "--polygon" render --estimator bounds25d --polygon 7 -o "$TMP/x.png"
expect_error "--polygon" render --estimator bounds25d --polygon 2 -o "$TMP/x.png"
for e in kdtree bounds3d bounds25d; do
    run estimators
    printf '%s\n' "$out" | grep -qx "$e" && ok || bad "estimators does not list $e"
done
expect_ok render --scene cornell --size 40x30 --photons 2000 --estimator kdtree --knn 16 --kernel cone -o "$TMP/k.png" -q &&
    { [ -s "$TMP/k.png" ] && ok || bad "kdtree --knn did not write k.png"; }
expect_ok render --scene cornell --size 40x30 --photons 2000 --estimator bounds25d --polygon 12 --kernel epanechnikov \
    -o "$TMP/b.png" -q && { [ -s "$TMP/b.png" ] && ok || bad "bounds25d did not write b.png"; }
expect_ok render --scene cornell --size 40x30 --photons 2000 --estimator hashgrid --subsample 3 --filter 2 \
    -o "$TMP/s.png" -q && { [ -s "$TMP/s.png" ] && ok || bad "subsample+filter did not write s.png"; }
run render --help
for f in --kernel --subsample --filter --knn --polygon; do
    printf '%s\n' "$out" | grep -qF -- "$f" && ok || bad "render --help does not mention $f"
done

# ------------------------------------------------------------ a camera on the command line
# --eye/--look-at/--up/--fov render what the same camera in a scene description renders, byte for
# byte (issue 40); the parts not given are the scene camera's (cornell's up is 0,1,0, as the JSON
# loader's default); a different eye gives a different image, so the comparison can fail.
CAM=(--size 40x30 --photons 3000 --seed 5 -q)
printf '%s\n' '{"builtin": "cornell", "camera": {"eye": [0.25, 1.1, 3.2], "look_at": [-0.1, 0.7, 0], "fov_y": 41.5}}' \
    >"$TMP/cam.json"
if expect_ok render --scene cornell "${CAM[@]}" --eye 0.25,1.1,3.2 --look-at -0.1,0.7,0 --fov 41.5 -o "$TMP/cam-cli.png" &&
    expect_ok render --scene "$TMP/cam.json" "${CAM[@]}" -o "$TMP/cam-json.png" &&
    expect_ok render --scene cornell "${CAM[@]}" --eye 0.25,1.1,3.3 --look-at -0.1,0.7,0 --fov 41.5 -o "$TMP/cam-far.png" &&
    expect_ok render --scene cornell "${CAM[@]}" -o "$TMP/cam-scene.png"; then
    cmp -s "$TMP/cam-cli.png" "$TMP/cam-json.png" && ok || bad "render --eye/--look-at/--fov differs from the JSON camera"
    cmp -s "$TMP/cam-cli.png" "$TMP/cam-far.png" && bad "another --eye gave the same image" || ok
    cmp -s "$TMP/cam-cli.png" "$TMP/cam-scene.png" && bad "--eye/--look-at/--fov changed nothing" || ok
fi
# --stats records the camera given (run.view) and --from-stats renders from it again.
if expect_ok render --scene cornell "${CAM[@]}" --eye 0.25,1.1,3.2 --look-at -0.1,0.7,0 --up 0.1,1,0 --fov 41.5 \
    -o "$TMP/cam-st.png" --stats "$TMP/cam-st.json" && expect_ok render --from-stats "$TMP/cam-st.json" -q -o "$TMP/cam-fs.png"; then
    cmp -s "$TMP/cam-st.png" "$TMP/cam-fs.png" && ok || bad "--from-stats lost the camera given with --eye"
fi
# Only --fov given: eye, look-at and up stay the scene camera's (cornell's: eye 0,1,3.9, look-at
# 0,1,0, fov 39), so it equals a JSON copy of that camera with the other fov.
printf '%s\n' '{"builtin": "cornell", "camera": {"eye": [0, 1, 3.9], "look_at": [0, 1, 0], "fov_y": 30}}' \
    >"$TMP/cam-fov.json"
expect_ok render --scene cornell "${CAM[@]}" --fov 30 -o "$TMP/fov-cli.png" &&
    expect_ok render --scene "$TMP/cam-fov.json" "${CAM[@]}" -o "$TMP/fov-json.png" &&
    { cmp -s "$TMP/fov-cli.png" "$TMP/fov-json.png" && ok || bad "render --fov alone differs from the JSON camera"; }
expect_status 2 "--eye needs X,Y,Z" "${R[@]}" --eye 1,2 -o "$TMP/a.png"
expect_status 2 "--eye needs X,Y,Z" "${R[@]}" --eye 1,2,3,4 -o "$TMP/a.png"
expect_status 2 "--eye needs X,Y,Z" "${R[@]}" --eye nan,0,0 -o "$TMP/a.png"
expect_status 2 "--look-at needs X,Y,Z" "${R[@]}" --look-at 0,inf,0 -o "$TMP/a.png"
expect_status 2 "within +-1e+15" "${R[@]}" --eye 2e15,0,0 -o "$TMP/a.png"
expect_status 2 "--up needs X,Y,Z" "${R[@]}" --up 0,,1 -o "$TMP/a.png"
expect_status 2 "--fov needs" "${R[@]}" --fov 180 -o "$TMP/a.png"
expect_status 2 "--fov needs" "${R[@]}" --fov 0 -o "$TMP/a.png"
expect_status 2 "--fov needs" "${R[@]}" --fov 30deg -o "$TMP/a.png"
expect_status 1 "same point" "${R[@]}" --eye 0,1,0 --look-at 0,1,0 -o "$TMP/a.png"
expect_status 1 "parallel to the view direction" "${R[@]}" --eye 0,3,0 --look-at 0,0,0 -o "$TMP/a.png"
expect_status 1 "parallel to the view direction" "${R[@]}" --up 0,0,0 -o "$TMP/a.png"
[ -e "$TMP/a.png" ] && bad "a refused camera wrote an image" || ok

# An automatic camera (a mesh without one) outside a closed room: a warning that names the way out.
write_closed_room "$TMP"
if expect_ok render --scene "$TMP/room.obj" --size 32x24 --photons 2000 -o "$TMP/room.png"; then
    grep -q "gives no camera.*--eye X,Y,Z --look-at X,Y,Z" "$TMP/err" && ok ||
        bad "automatic camera outside a closed room: no warning: $(head -c 300 "$TMP/err")"
fi
if expect_ok render --scene "$TMP/room.obj" --size 32x24 --photons 2000 --eye 0,0,0.9 --look-at 0,0,-1 \
    -o "$TMP/room-in.png"; then
    grep -qi "warning" "$TMP/err" && bad "a camera inside the room was warned about: $(head -c 300 "$TMP/err")" || ok
fi

# The reference records a camera given on the command line: --continue goes on from it (the
# sidecar's "view"; 4 + 4 samples equal 8 at once, bit for bit) and --merge refuses another one.
RC=(--scene cornell --size 24x16 --eye 0.2,1,3 --look-at 0,0.8,0 --fov 50 -q)
if expect_ok reference "${RC[@]}" --spp 8 -o "$TMP/v8.exr" && expect_ok reference "${RC[@]}" --spp 4 \
    -o "$TMP/v44.exr" && expect_ok reference --continue "$TMP/v44.exr" --spp 4 -q &&
    expect_ok reference --scene cornell --size 24x16 --spp 4 -q -o "$TMP/v0.exr"; then
    grep -q '"view"' "$TMP/v44.exr.json" && grep -q '"fov_y":[[:space:]]*50' "$TMP/v44.exr.json" && ok ||
        bad "reference --eye: the sidecar has no view: $(cat "$TMP/v44.exr.json")"
    cmp -s "$TMP/v8.exr" "$TMP/v44.exr" && ok || bad "reference --continue with a view: 4 + 4 samples differ from 8"
    cmp -s "$TMP/v0.exr" "$TMP/v44.exr" && bad "reference --eye changed nothing" || ok
    expect_ok reference "${RC[@]}" --spp 4 --seed 2 -o "$TMP/v4b.exr"
    expect_ok reference "${RC[@]}" --spp 4 --seed 3 -o "$TMP/v4c.exr" &&
        expect_ok reference --merge "$TMP/v4b.exr" "$TMP/v4c.exr" -o "$TMP/vm.exr"
    expect_ok reference --scene cornell --size 24x16 --eye 0.2,1,3 --look-at 0,0.8,0 --fov 51 --spp 4 --seed 2 -q \
        -o "$TMP/v4d.exr" && expect_status 1 "cameras differ" reference --merge "$TMP/v4c.exr" "$TMP/v4d.exr" -o "$TMP/vn.exr"
    expect_status 1 "cameras differ" reference --merge "$TMP/v4c.exr" "$TMP/v0.exr" -o "$TMP/vn.exr"
    expect_status 2 "do not give them" reference --continue "$TMP/v8.exr" --eye 1,1,1
fi
expect_status 2 "--fov needs" reference --scene cornell --fov -1 --spp 1 -o "$TMP/vx.exr"

summary test_cli
