#!/usr/bin/env bash
# The GPU bundle (scripts/gpu-bundle.sh) needs nothing but glibc: it is made from BUILD_DIR, unpacked,
# and run inside a mount namespace (unshare -m, as root) whose system library folder holds only
# glibc's libraries (the loader, libc, libm, libpthread, libdl, librt) and whose ld.so.cache is
# empty: every bundled program must find all its libraries (the dynamic loader's own listing,
# LD_TRACE_LOADED_OBJECTS), `photongi --version` must run, and a tiny CPU render of the bundle's
# Sibenik (its mesh and textures) must write an image. A control run with one library taken out of
# the bundle must fail, so the namespace really hides the system's libraries.
#
#   tests/test_bundle.sh BUILD_DIR [ARCHIVE_DIR]
# ARCHIVE_DIR (default BUILD_DIR/gpu-bundle) keeps the archive for bench/gpu_suite.sh --local (the
# test test_gpu_suite). Exit 77 (skipped) when mount namespaces are not allowed (not root) or the
# scenes are missing.
set -uo pipefail
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:?usage: test_bundle.sh BUILD_DIR [ARCHIVE_DIR]}" && pwd)
ADIR=${2:-$BUILD/gpu-bundle}
. "$SRC/tests/lib.sh" bundle
rm -f "$ADIR/photongi-gpu.tar.xz" # test_gpu_suite runs only what this run made

SCENES=${PHOTONGI_SCENES:-$SRC/../shared/scenes}
if [ ! -d "$SCENES/sibenik" ]; then
    echo "SKIP: no scenes at $SCENES (set PHOTONGI_SCENES): the bundle carries them"
    exit 77
fi
if ! unshare -m true 2>/dev/null; then
    echo "SKIP: mount namespaces are not allowed here (unshare -m needs root): cannot isolate the bundle"
    exit 77
fi

# 1. the bundle, from the tests' build (already built: --no-build)
if ! BUILD="$BUILD" "$SRC/scripts/gpu-bundle.sh" --no-build "$ADIR" >"$TMP/bundle.log" 2>&1; then
    cat "$TMP/bundle.log"
    echo "FAIL: scripts/gpu-bundle.sh"
    exit 1
fi
grep '^bundle:' "$TMP/bundle.log"
mkdir "$TMP/u"
tar -C "$TMP/u" -xJf "$ADIR/photongi-gpu.tar.xz" || {
    echo "FAIL: unpacking $ADIR/photongi-gpu.tar.xz"
    exit 1
}
B=$TMP/u/photongi-gpu
for f in bin/photongi bin/photongi-bench tests/test_gpu lib/libembree3.so.3 lib/libtbbmalloc.so.2 lib/libvulkan.so.1 \
    scenes/sibenik.json scenes/sibenik/sibenik.obj scenes/crytek-sponza/sponza.obj env.sh MANIFEST; do
    [ -e "$B/$f" ] && ok "bundle has $f" || bad "bundle lacks $f"
done
glibc_in=$(find "$B/lib" -regextype egrep -regex '.*/((libc|libm|libpthread|libdl|librt)\.so.*|ld-linux.*)')
[ -z "$glibc_in" ] && ok "no glibc library in the bundle" || bad "bundle holds glibc's own libraries: $glibc_in"

# A control copy without Embree: must fail in the namespace.
cp -a "$B" "$TMP/broken"
rm "$TMP/broken/lib/libembree3.so.3"

# 2. the namespace: only glibc's libraries in the system library folder
LIBDIR=/usr/lib/x86_64-linux-gnu
[ -d "$LIBDIR" ] || LIBDIR=/lib/x86_64-linux-gnu
mkdir "$TMP/glibc"
for l in ld-linux-x86-64.so.2 libc.so.6 libm.so.6 libpthread.so.0 libdl.so.2 librt.so.1; do
    [ -e "$LIBDIR/$l" ] && cp -L "$LIBDIR/$l" "$TMP/glibc/"
done
cat >"$TMP/inside.sh" <<'EOF'
# Runs in the namespace; bash is already loaded, so only builtins and the bundle's programs run here.
set -u
# (the library folder last: mount itself needs libraries from it)
[ -d /usr/local/lib ] && { mount -t tmpfs none /usr/local/lib || exit 91; }
[ -f /etc/ld.so.cache ] && { mount --bind /dev/null /etc/ld.so.cache || exit 92; }
mount --bind "$GLIBC" "$LIBDIR" || exit 90
export LD_LIBRARY_PATH="$B/lib" PHOTONGI_SCENES="$B/scenes" PATH=/nonexistent
unset LD_PRELOAD
for f in "$B"/bin/* "$B"/tests/*; do
    echo "== $f"
    LD_TRACE_LOADED_OBJECTS=1 "$f" 2>&1
    echo "rc $?"
done >"$OUTDIR/ldd.txt"
"$B/bin/photongi" --version >"$OUTDIR/version.txt" 2>&1
echo $? >"$OUTDIR/version.rc"
"$B/bin/photongi" render --scene "$B/scenes/sibenik.json" --size 48x27 --photons 2000 --threads 2 -q \
    -o "$OUTDIR/sibenik.png" >"$OUTDIR/render.txt" 2>&1
echo $? >"$OUTDIR/render.rc"
LD_LIBRARY_PATH="$BROKEN/lib" "$BROKEN/bin/photongi" --version >"$OUTDIR/broken.txt" 2>&1
echo $? >"$OUTDIR/broken.rc"
EOF
mkdir "$TMP/out"
GLIBC=$TMP/glibc LIBDIR=$LIBDIR B=$B BROKEN=$TMP/broken OUTDIR=$TMP/out unshare -m bash "$TMP/inside.sh"
rc=$?
[ "$rc" -eq 0 ] && ok "namespace set up" || bad "namespace set-up failed (rc $rc)"

# 3. what happened inside
if [ -f "$TMP/out/ldd.txt" ]; then
    if grep -q 'not found' "$TMP/out/ldd.txt"; then
        bad "libraries missing from the bundle: $(grep 'not found' "$TMP/out/ldd.txt" | sort -u | tr '\n' ' ')"
    else
        ok "every bundled program finds all its libraries ($(grep -c '^==' "$TMP/out/ldd.txt") programs)"
    fi
    # every library resolved from the bundle or glibc's folder, nothing else
    others=$(grep '=> /' "$TMP/out/ldd.txt" | awk '{print $3}' | grep -v "^$B/lib/" |
        grep -vE "^(/usr)?/lib(64)?/(x86_64-linux-gnu/)?(ld-linux-x86-64\.so\.2|libc\.so\.6|libm\.so\.6|libpthread\.so\.0|libdl\.so\.2|librt\.so\.1)$" |
        sort -u)
    [ -z "$others" ] && ok "libraries come from the bundle and glibc only" || bad "libraries from elsewhere: $others"
else
    bad "no loader listing"
fi
[ "$(cat "$TMP/out/version.rc" 2>/dev/null)" = 0 ] && grep -q '^photongi [0-9]' "$TMP/out/version.txt" &&
    ok "photongi --version: $(cat "$TMP/out/version.txt")" ||
    bad "photongi --version in the namespace: $(cat "$TMP/out/version.txt" 2>/dev/null)"
[ "$(cat "$TMP/out/render.rc" 2>/dev/null)" = 0 ] && [ -s "$TMP/out/sibenik.png" ] &&
    ok "a CPU render of the bundle's Sibenik in the namespace" ||
    bad "render in the namespace: $(cat "$TMP/out/render.txt" 2>/dev/null)"
[ "$(cat "$TMP/out/broken.rc" 2>/dev/null)" != 0 ] && grep -q 'libembree3.so.3' "$TMP/out/broken.txt" &&
    ok "control: the bundle without libembree3.so.3 fails in the namespace" ||
    bad "control: the bundle without Embree ran in the namespace (the system's libraries are not hidden): $(cat "$TMP/out/broken.txt" 2>/dev/null)"

summary test_bundle
