#!/usr/bin/env bash
# Command-line tests of the photongi binary: bad input gets a clear message
# naming the problem and exit status 1 or 2 (never a crash: no status >= 128,
# no sanitizer report); good input works.
#   usage: tests/test_cli.sh path/to/photongi     (run from the repository root)
set -u

BIN=${1:?usage: test_cli.sh path/to/photongi}
case $BIN in /*) ;; */*) BIN=$PWD/$BIN ;; esac
TMP=$(mktemp -d "${TMPDIR:-/tmp}/pgi-test-cli-XXXXXX")
trap 'rm -rf "$TMP"' EXIT
pass=0
fail=0

ok() { pass=$((pass + 1)); }
bad() {
    fail=$((fail + 1))
    echo "FAIL: $*"
}

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
expect_error "must not exceed r_max" render --estimator bvh --radius-policy path --r-min 2 --r-max 1 --size 8x8 \
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
    fi
    expect_ok render --scene cornell --size 32x16 --photons 2000 -q -o "$TMP/q.png"
    expect_error "sizes differ" compare "$TMP/q.png" "$TMP/r.exr"
    expect_error "missing.png" compare "$TMP/p.png" "$TMP/missing.png"
    expect_error "two images" compare "$TMP/p.png"
    expect_error "unknown option" compare "$TMP/p.png" "$TMP/r.exr" --frobnicate
    grep -qE '"jitter":[[:space:]]*true' "$TMP/r.exr.json" && ok || bad "reference: r.exr.json lacks jitter true"
    printf 'not json' >"$TMP/r.exr.json"
    expect_error "metadata" reference --continue "$TMP/r.exr" --spp 1
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
    sed -e 's/photongi-reference-2/photongi-reference-1/' -e '/"jitter"/d' -e 's/"spp":[[:space:]]*"3",/"spp": "3"/' \
        "$TMP/c.exr.json" >"$TMP/c1.json" && mv "$TMP/c1.json" "$TMP/c.exr.json"
    if expect_ok reference --continue "$TMP/c.exr" --spp 1 -q; then
        grep -qE '"jitter":[[:space:]]*false' "$TMP/c.exr.json" && ok || bad "format-1 reference did not continue at centres"
        grep -q '"spp":[[:space:]]*"4"' "$TMP/c.exr.json" && ok || bad "format-1 reference --continue: spp is not 4"
    fi
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

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
