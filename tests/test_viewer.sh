#!/usr/bin/env bash
# Headless tests of photongi-view: its screenshot equals 'photongi render' of
# the same view, estimator and seed (same float image, same tone map: the PNG
# files are byte-identical), progressive accumulation equals
# 'render --progressive', animated scenes match 'render --time', a window
# opens under SDL's dummy/offscreen video driver when asked for, no display
# without --frames is an error (not an invisible window), output paths are
# checked before rendering, and bad options fail cleanly.
#   usage: tests/test_viewer.sh path/to/photongi-view path/to/photongi   (from the repository root)
set -u
VIEW=${1:?usage: test_viewer.sh photongi-view photongi}
CLI=${2:?usage: test_viewer.sh photongi-view photongi}
case $VIEW in /*) ;; */*) VIEW=$PWD/$VIEW ;; esac
case $CLI in /*) ;; */*) CLI=$PWD/$CLI ;; esac
. "$(dirname "$0")/lib.sh" test-view

# same NAME VIEW_ARGS -- RENDER_ARGS: both must succeed and write identical PNGs.
same() {
    local name=$1
    shift
    local va=() ra=()
    while [ "$1" != "--" ]; do va+=("$1"); shift; done
    shift
    ra=("$@")
    if ! "$VIEW" "${va[@]}" --screenshot "$TMP/$name-view.png" -q 2>"$TMP/err"; then
        bad "$name: photongi-view ${va[*]} failed: $(head -c 300 "$TMP/err")"
        return
    fi
    if ! "$CLI" render "${ra[@]}" -o "$TMP/$name-cli.png" -q 2>"$TMP/err"; then
        bad "$name: photongi render ${ra[*]} failed: $(head -c 300 "$TMP/err")"
        return
    fi
    if cmp -s "$TMP/$name-view.png" "$TMP/$name-cli.png"; then ok; else bad "$name: screenshot differs from render"; fi
}

COMMON=(--size 64x48 --photons 5000 --seed 9)
same single --frames 1 "${COMMON[@]}" --estimator hashgrid -- "${COMMON[@]}" --estimator hashgrid
same tiled --frames 1 "${COMMON[@]}" --estimator tiled --exposure 1.5 -- "${COMMON[@]}" --estimator tiled --exposure 1.5
same progressive --frames 5 "${COMMON[@]}" -- "${COMMON[@]}" --progressive 5
same no-accumulate --frames 3 --no-accumulate "${COMMON[@]}" -- "${COMMON[@]}"
same indirect --frames 1 "${COMMON[@]}" --output indirect -- "${COMMON[@]}" --output indirect
same animated --frames 1 --scene scenes/cornell-moving.json --time 1.5 "${COMMON[@]}" -- \
    --scene scenes/cornell-moving.json --time 1.5 "${COMMON[@]}"
same camera1 --frames 1 --scene giref --camera 0 "${COMMON[@]}" -- --scene giref --camera 0 "${COMMON[@]}"
# Temporal reuse and the filter fade out on a still camera: after --history 4 and the filter's 8
# frames the picture is the progressive average itself; the render options the viewer now takes.
same temporal --frames 10 --temporal on --history 4 --denoise 2 "${COMMON[@]}" -- "${COMMON[@]}" --progressive 10
same filter --frames 1 --filter 2 --jitter off "${COMMON[@]}" -- "${COMMON[@]}" --filter 2 --jitter off
if "$VIEW" --frames 3 --temporal on "${COMMON[@]}" --keys d,d --stats "$TMP/temporal.json" -q 2>"$TMP/err" &&
    grep -q '"temporal":[[:space:]]*{' "$TMP/temporal.json" && grep -q '"filter_passes":[[:space:]]*4' "$TMP/temporal.json"; then
    ok
else bad "--temporal on: no temporal stats: $(head -c 300 "$TMP/err")"; fi

# The screenshot must really depend on the frame count (guards against a no-op 'same').
"$VIEW" --frames 2 "${COMMON[@]}" --screenshot "$TMP/two.png" -q 2>/dev/null
cmp -s "$TMP/two.png" "$TMP/single-view.png" && bad "2 accumulated frames equal 1 frame" || ok

# Animation advances 1/30 s a frame headless; the ball must move.
"$VIEW" --frames 1 --scene scenes/cornell-moving.json "${COMMON[@]}" --screenshot "$TMP/a1.png" -q &&
    "$VIEW" --frames 8 --animate --scene scenes/cornell-moving.json "${COMMON[@]}" --screenshot "$TMP/a8.png" -q &&
    ! cmp -s "$TMP/a1.png" "$TMP/a8.png" && ok || bad "--animate: the scene did not change"

# Photon-count view, statistics file.
if "$VIEW" --frames 1 "${COMMON[@]}" --output counts --screenshot "$TMP/counts.png" --stats "$TMP/s.json" -q 2>"$TMP/err"; then
    [ -s "$TMP/counts.png" ] && grep -q '"contributing"' "$TMP/s.json" && ok || bad "counts: no screenshot or stats"
else
    bad "--output counts failed: $(head -c 300 "$TMP/err")"
fi

# A window under SDL's dummy driver (no display needed).
if SDL_VIDEODRIVER=dummy "$VIEW" --window --frames 2 "${COMMON[@]}" --screenshot "$TMP/win.png" -q 2>"$TMP/err"; then
    cmp -s "$TMP/win.png" "$TMP/two.png" && ok || bad "windowed screenshot differs from the headless one"
else
    bad "--window with SDL_VIDEODRIVER=dummy failed: $(head -c 300 "$TMP/err")"
fi

# In a window, every refused setting is undone, not only the first: more photons than --max-memory
# allows, asked for again and again, leave the previous settings rendering (it quit on the second).
if SDL_VIDEODRIVER=dummy "$VIEW" --window --frames 8 --size 32x24 --photons 20000 --max-memory 3M \
    --keys "+,+,+,+,+,+,+,+" --screenshot "$TMP/refused.png" 2>"$TMP/err" >/dev/null; then
    [ "$(grep -c 'going back to the previous settings' "$TMP/err")" -ge 2 ] && [ -s "$TMP/refused.png" ] && ok ||
        bad "repeated refusals: not each undone ($(head -c 300 "$TMP/err"))"
else
    bad "a second refused setting ended the viewer: $(head -c 300 "$TMP/err")"
fi

# Scripted keys drive every handler (estimator, counts, scale, photons, radius, output,
# camera, light, look); the result must differ from the unmoved view and the run must succeed.
if "$VIEW" --frames 17 --scene giref "${COMMON[@]}" --keys "tab,c,c,r,+,-,],[,o,o,o,w,d,up,pageup,k,shift+tab" \
        --screenshot "$TMP/keys.png" -q 2>"$TMP/err"; then
    "$VIEW" --frames 17 --scene giref "${COMMON[@]}" --screenshot "$TMP/nokeys.png" -q 2>/dev/null
    ! cmp -s "$TMP/keys.png" "$TMP/nokeys.png" && ok || bad "--keys: camera/light moves changed nothing"
else
    bad "--keys run failed: $(head -c 300 "$TMP/err")"
fi
expect_fail_keys() { "$VIEW" --frames 2 --size 8x8 --photons 100 --keys "$1" >/dev/null 2>"$TMP/err"; [ $? -eq 2 ] && grep -q "unknown key" "$TMP/err" && ok || bad "--keys $1 accepted"; }
expect_fail_keys "nosuchkey"

# --help documents the keys, and prints percent signs as such (not printf's '%%').
"$VIEW" --help | grep -q "F12" && ok || bad "--help does not list the keys"
"$VIEW" --help >"$TMP/help" 2>&1
grep -q '%%' "$TMP/help" && bad "--help prints '%%': $(grep '%%' "$TMP/help" | head -2)" || ok
grep -q '25%' "$TMP/help" && ok || bad "--help lost its '25%'"

# No display and no SDL_VIDEODRIVER: SDL would fall back to an invisible offscreen window and
# the session would run until killed; the viewer must say so and exit non-zero at once.
start=$(date +%s)
env -u DISPLAY -u WAYLAND_DISPLAY -u XDG_RUNTIME_DIR -u SDL_VIDEODRIVER timeout 20 "$VIEW" --size 64x48 --photons 1000 \
    >/dev/null 2>"$TMP/err"
rc=$?
secs=$(($(date +%s) - start))
if [ "$rc" -eq 124 ]; then
    bad "no display: still running after 20 s (SDL's offscreen fallback)"
elif [ "$rc" -eq 0 ] || ! grep -q "no display available" "$TMP/err" || [ "$secs" -gt 10 ]; then
    bad "no display: exit $rc after ${secs} s, message: $(head -c 300 "$TMP/err")"
else ok; fi

# Output paths are checked before any frame is rendered: 100000 frames would take minutes.
start=$(date +%s)
timeout 20 "$VIEW" --frames 100000 --size 64x48 --photons 1000 --screenshot /nonexistent/dir/x.png >/dev/null 2>"$TMP/err"
rc=$?
secs=$(($(date +%s) - start))
[ "$rc" -eq 1 ] && [ "$secs" -le 10 ] && grep -q "cannot write the screenshot" "$TMP/err" && ok ||
    bad "--screenshot into a missing folder: exit $rc after ${secs} s: $(head -c 300 "$TMP/err")"
timeout 20 "$VIEW" --frames 100000 --size 64x48 --photons 1000 --stats /nonexistent/dir/s.json >/dev/null 2>"$TMP/err"
rc=$?
[ "$rc" -eq 1 ] && grep -q "cannot write the stats" "$TMP/err" && ok ||
    bad "--stats into a missing folder: exit $rc: $(head -c 300 "$TMP/err")"

# Bad options: exit 2 (1 for a missing scene), a message, no crash.
expect_fail() {
    local want=$1 needle=$2
    shift 2
    "$VIEW" "$@" >/dev/null 2>"$TMP/err"
    local rc=$?
    if [ "$rc" -ne "$want" ] || ! grep -qiF -- "$needle" "$TMP/err"; then
        bad "photongi-view $*: exit $rc (expected $want) or message without '$needle': $(head -c 200 "$TMP/err")"
    else ok; fi
}
expect_fail 2 "unknown option" --bogus
expect_fail 2 "--denoise needs" --frames 1 --denoise 9
expect_fail 2 "--temporal must be" --frames 1 --temporal maybe
expect_fail 2 "unknown option '--progressive'" --frames 1 --progressive 4
expect_fail 2 "--screenshot needs --frames" --screenshot x.png
expect_fail 2 "unknown estimator" --frames 1 --estimator nope
expect_fail 2 "--scale" --frames 1 --scale 0
expect_fail 2 "--frames" --frames 0
expect_fail 2 "camera" --frames 1 --camera 7
expect_fail 1 "cannot load scene" --frames 1 --scene /nonexistent/scene.json
expect_fail 1 "cannot write the screenshot" --frames 1 --size 8x8 --photons 100 --screenshot /nonexistent/dir/x.png
expect_fail 1 "not a folder" --frames 1 --size 8x8 --photons 100 --screenshot "$TMP/single-view.png/x.png"
expect_fail 2 ".png or .exr" --frames 1 --size 8x8 --photons 100 --screenshot "$TMP/shot.jpg"
[ -e "$TMP/shot.jpg" ] && bad "--screenshot shot.jpg wrote a file" || ok

# ------------------------------------------------------------ a camera you can carry (issue 40)
# --eye/--look-at/--up/--fov start from that camera, as 'photongi render' does.
same eye --frames 1 --scene giref --eye 0.5,4,4 --look-at 0,3.5,0 --fov 55 "${COMMON[@]}" -- \
    --scene giref --eye 0.5,4,4 --look-at 0,3.5,0 --fov 55 "${COMMON[@]}"
cmp -s "$TMP/eye-view.png" "$TMP/camera1-view.png" && bad "--eye changed nothing" || ok
# V prints the camera as the JSON block and the 'photongi render' line of the frame shown, and saves
# the block: pasted back, both reproduce the viewer's frame byte for byte. The view is moved (w, k),
# averages --max-frames 2 frames and idles (z and x change no picture), then V: the line carries
# --progressive 2, and the screenshot is that average.
KV=(--frames 6 --max-frames 2 --scene giref "${COMMON[@]}" --keys "w,k,z,x,v" --camera-out "$TMP/cam.json")
if (cd "$TMP" && "$VIEW" "${KV[@]}" --screenshot "$TMP/carry-view.png" -q >"$TMP/carry.out" 2>"$TMP/err"); then
    line=$(sed -n 's/^render: photongi render //p' "$TMP/carry.out")
    block=$(sed -n 's/^camera: //p' "$TMP/carry.out")
    case $line in *"--progressive 2 "*"--eye "*) ok ;; *) bad "V: no render line with --progressive 2 and --eye: $line" ;; esac
    [ "$(cat "$TMP/cam.json" 2>/dev/null)" = "$block" ] && ok || bad "V: $TMP/cam.json does not hold the printed block"
    if (cd "$TMP" && eval "\"$CLI\" render $line -q" 2>"$TMP/err"); then
        cmp -s "$TMP/view.png" "$TMP/carry-view.png" && ok || bad "V: the printed render line does not reproduce the frame"
    else bad "V: the printed render line failed: $line: $(head -c 300 "$TMP/err")"; fi
    printf '{"builtin": "giref", "camera": %s}\n' "$block" >"$TMP/carry.json"
    if "$CLI" render --scene "$TMP/carry.json" "${COMMON[@]}" --progressive 2 -o "$TMP/carry-json.png" -q 2>"$TMP/err"; then
        cmp -s "$TMP/carry-json.png" "$TMP/carry-view.png" && ok || bad "V: the JSON block in a description does not reproduce the frame"
    else bad "V: a description with the printed block failed: $(head -c 300 "$TMP/err")"; fi
    cmp -s "$TMP/carry-view.png" "$TMP/nokeys.png" && bad "V: the moved view equals the unmoved one" || ok
else
    bad "V run failed: $(head -c 300 "$TMP/err")"
fi
# Scripted movement takes fixed steps scaled by the speed keys: x then w moves as far as w twice.
eye_of() { "$VIEW" --frames 3 --size 8x8 --photons 200 --keys "$1" --camera-out "$TMP/c.json" -q | sed -n 's/^camera: {"eye": \[\([^]]*\)\].*/\1/p'; }
e1=$(eye_of "x,w,v") e2=$(eye_of "w,w,v") e0=$(eye_of "w,z,v")
awk -v a="$e1" -v b="$e2" -v c="$e0" 'BEGIN { split(a, p, ", "); split(b, q, ", "); split(c, r, ", ");
    d = 0; e = 0; for (i = 1; i <= 3; i++) { d += (p[i] - q[i]) ^ 2; e += (p[i] - r[i]) ^ 2 }
    exit !(d < 1e-10 && e > 1e-6) }' && ok || bad "speed keys: x,w moved to '$e1', w,w to '$e2', w,z to '$e0'"

# A still view stops rendering at --max-frames: 4 frames rendered of 10 turns, the screenshot and the
# statistics are the 4-frame average ('render --progressive 4').
if "$VIEW" --frames 10 --max-frames 4 "${COMMON[@]}" --screenshot "$TMP/cap.png" --stats "$TMP/cap.json" 2>"$TMP/err"; then
    grep -q "4 frames rendered, then 6 turns idle" "$TMP/err" && ok || bad "--max-frames 4: $(grep frames "$TMP/err")"
    grep -q '"frames":[[:space:]]*4,' "$TMP/cap.json" && ok || bad "--max-frames 4: the stats do not count 4 frames"
    "$CLI" render "${COMMON[@]}" --progressive 4 -o "$TMP/cap-cli.png" -q && cmp -s "$TMP/cap.png" "$TMP/cap-cli.png" &&
        ok || bad "--max-frames 4: the screenshot is not the 4-frame average"
else
    bad "--max-frames run failed: $(head -c 300 "$TMP/err")"
fi
"$VIEW" --frames 6 --max-frames 0 --size 8x8 --photons 200 2>"$TMP/err" >/dev/null
grep -q "idle" "$TMP/err" && bad "--max-frames 0 idled" || ok
# ... and a change wakes it: the key of the last turn renders a frame.
"$VIEW" --frames 6 --max-frames 2 --size 8x8 --photons 200 --keys "z,z,z,z,z,w" --stats "$TMP/wake.json" 2>"$TMP/err" >/dev/null
grep -q "3 frames rendered, then 3 turns idle" "$TMP/err" && grep -q '"frames":[[:space:]]*1,' "$TMP/wake.json" && ok ||
    bad "a key after --max-frames did not render: $(grep -h frames "$TMP/err" "$TMP/wake.json" | head -3)"

# brute (the O(photons x pixels) oracle) is not reachable by Tab, Shift+Tab or the number keys,
# and --estimator brute is announced with its cost.
n=$("$CLI" estimators | wc -l)
keys=tab
reach=""
for i in $(seq 1 "$n"); do
    "$VIEW" --frames "$i" --size 8x8 --photons 200 --keys "$keys" --stats "$TMP/tab.json" -q 2>/dev/null
    reach="$reach $(sed -n 's/^[[:space:]]*"estimator":[[:space:]]*"\([^"]*\)".*/\1/p' "$TMP/tab.json" | head -1)"
    keys="$keys,tab"
done
for k in 1 2 3 4 5 6 7 8 9 shift+tab; do
    "$VIEW" --frames 1 --size 8x8 --photons 200 --keys "$k" --stats "$TMP/tab.json" -q 2>/dev/null
    reach="$reach $(sed -n 's/^[[:space:]]*"estimator":[[:space:]]*"\([^"]*\)".*/\1/p' "$TMP/tab.json" | head -1)"
done
case " $reach " in *" brute "*) bad "brute is reachable by keys:$reach" ;; *) ok ;; esac
[ "$(printf '%s\n' $reach | sort -u | wc -l)" -ge $((n - 1)) ] && ok || bad "Tab and 1-9 do not reach the other estimators:$reach"
"$VIEW" --frames 1 --size 8x8 --photons 200 --estimator brute 2>"$TMP/err" >/dev/null
grep -q "O(photons x pixels) oracle" "$TMP/err" && ok || bad "--estimator brute: not announced: $(head -c 300 "$TMP/err")"

# Input abandons the frame in progress: a brute frame of 960x540 pixels and 200 000 photons (about
# 10^11 photon reads, minutes) gets Tab one second in; the frame stops within a second of it and the
# next estimator's frame is the one finished (the whole run well inside the timeout).
timeout 120 "$VIEW" --frames 1 --size 960x540 --photons 200000 --radius 0.05 --estimator brute --keys "tab@1" \
    --stats "$TMP/cut.json" 2>"$TMP/err" >/dev/null
rc=$?
late=$(sed -n 's/.*frame abandoned .* it stopped \([0-9.]*\) ms after the request.*/\1/p' "$TMP/err")
est=$(sed -n 's/^[[:space:]]*"estimator":[[:space:]]*"\([^"]*\)".*/\1/p' "$TMP/cut.json" 2>/dev/null | head -1)
if [ "$rc" -eq 0 ] && [ -n "$late" ] && [ -n "$est" ] && [ "$est" != brute ] &&
    awk -v l="$late" 'BEGIN { exit !(l < 1000) }'; then
    ok
    echo "  brute 960x540 abandoned ${late} ms after a key; then $est rendered"
else bad "input during a brute frame: exit $rc, stopped after '${late}' ms, then '$est': $(grep -v note "$TMP/err" | head -3)"; fi

# An automatic camera that sees nothing lit (outside a closed room) is warned about.
write_closed_room "$TMP"
"$VIEW" --frames 1 --scene "$TMP/room.obj" --size 32x24 --photons 2000 2>"$TMP/err" >/dev/null
grep -q "gives no camera.*--eye X,Y,Z --look-at X,Y,Z" "$TMP/err" && ok ||
    bad "viewer: automatic camera outside a closed room: no warning: $(head -c 300 "$TMP/err")"
"$VIEW" --frames 1 --scene "$TMP/room.obj" --size 32x24 --photons 2000 --eye 0,0,0.9 --look-at 0,0,-1 2>"$TMP/err" >/dev/null
grep -q "warning" "$TMP/err" && bad "viewer: a camera inside the room was warned about" || ok

expect_fail 2 "--eye needs X,Y,Z" --frames 1 --eye 1,2
expect_fail 2 "--fov needs" --frames 1 --fov 200
expect_fail 2 "--max-frames" --frames 1 --max-frames -1
expect_fail 1 "same point" --frames 1 --size 8x8 --photons 100 --eye 0,1,0 --look-at 0,1,0
expect_fail 1 "cannot write the camera file" --frames 1 --size 8x8 --photons 100 --camera-out /nonexistent/dir/c.json

summary test_viewer
