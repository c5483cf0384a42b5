#!/usr/bin/env bash
# Packaging: photongi as a library other projects build against. From an already-built tree:
#   1. `cmake --install` into a temporary prefix; the expected files are there and the
#      installed CLI runs;
#   2. examples/render_frame.c compiled with `pkg-config --cflags --libs photongi` (and
#      with --static) renders a PNG, and examples/engine_loop.c (a scene from arrays, updated
#      every frame, AOVs read back) runs its frames and renders one;
#   3. examples/ configured on its own with find_package(photongi) (CMAKE_PREFIX_PATH = the
#      prefix) renders a PNG;
#   4. a parent project that add_subdirectory()s the source tree (as FetchContent does)
#      builds the library and the example, and none of the tests, tools or install rules.
# Every rendered PNG must be a PNG of the asked size with content (not a blank image).
#   usage: tests/test_install.sh BUILD_DIR SOURCE_DIR CONFIG C_COMPILER VERSION CMAKE [EXTRA_FLAGS]
# EXTRA_FLAGS go to every compile and link of the consumers (the sanitizer build passes
# -fsanitize=...: its libphotongi.a needs the sanitizer runtimes). CTest runs it (test_install).
set -euo pipefail

BUILD=$(cd "${1:?usage: test_install.sh BUILD_DIR SOURCE_DIR CONFIG CC VERSION CMAKE [EXTRA_FLAGS]}" && pwd)
SRC=$(cd "${2:?source dir}" && pwd)
CONFIG=${3:?config}
CC_BIN=${4:?C compiler}
VERSION=${5:?version}
CMAKE=${6:?cmake}
EXTRA=${7:-}

TMP=$(mktemp -d "${TMPDIR:-/tmp}/pgi-test-install-XXXXXX")
trap 'rm -rf "$TMP"' EXIT
PREFIX=$TMP/prefix
SIZE_W=160
SIZE_H=120
t0=$(date +%s)

step() { echo "== [$(($(date +%s) - t0)) s] $*"; }
die() {
    echo "test_install: FAIL: $*" >&2
    exit 1
}

# check_png FILE: a PNG of SIZE_WxSIZE_H (IHDR) and more than a blank image's few hundred bytes.
check_png() {
    local f=$1
    [ -s "$f" ] || die "$f: missing or empty"
    [ "$(od -An -tx1 -N8 "$f" | tr -d ' \n')" = "89504e470d0a1a0a" ] || die "$f: not a PNG"
    local wh
    wh=$(od -An -tu1 -j16 -N8 "$f" | awk '{print $1*16777216+$2*65536+$3*256+$4 "x" $5*16777216+$6*65536+$7*256+$8}')
    [ "$wh" = "${SIZE_W}x${SIZE_H}" ] || die "$f: ${wh}, expected ${SIZE_W}x${SIZE_H}"
    local bytes
    bytes=$(wc -c <"$f")
    [ "$bytes" -gt 2000 ] || die "$f: only $bytes bytes: a blank image?"
    echo "   $f: PNG ${wh}, $bytes bytes"
}

# run_example BINARY TAG: renders the built-in Cornell box (no scene files) and checks the PNG.
run_example() {
    local png=$TMP/$2.png
    (cd "$TMP" && "$1" cornell "$png" "${SIZE_W}x${SIZE_H}") || die "$2: render_frame exited with $?"
    check_png "$png"
}

# run_engine BINARY TAG: the engine-style loop (examples/engine_loop.c): 2 frames, each reported
# with its pixels hit (the AOVs' depth), and the last one's PNG.
run_engine() {
    local png=$TMP/$2-engine.png
    local rc=0
    (cd "$TMP" && "$1" "$png" "${SIZE_W}x${SIZE_H}" 2) >"$TMP/$2-engine.log" || rc=$?
    [ "$rc" -eq 0 ] || {
        cat "$TMP/$2-engine.log"
        die "$2: engine_loop exited with $rc"
    }
    grep -Eq "^frame 1: .* [1-9][0-9]* of $((SIZE_W * SIZE_H)) pixels hit" "$TMP/$2-engine.log" ||
        die "$2: engine_loop did not report its second frame's AOVs: $(cat "$TMP/$2-engine.log")"
    check_png "$png"
}

step "install $BUILD ($CONFIG) into $PREFIX"
"$CMAKE" --install "$BUILD" --config "$CONFIG" --prefix "$PREFIX" >"$TMP/install.log" || {
    cat "$TMP/install.log"
    die "cmake --install failed"
}
PCDIR=$(dirname "$(find "$PREFIX" -name photongi.pc -print -quit)")
[ -f "$PCDIR/photongi.pc" ] || die "no photongi.pc installed"
LIBDIR=$(dirname "$PCDIR")
ls "$LIBDIR"/libphotongi.a "$LIBDIR"/libphotongi.so >/dev/null 2>&1 || ls "$LIBDIR"/libphotongi.* >/dev/null 2>&1 ||
    die "no libphotongi in $LIBDIR"
for h in photongi.h estimator.h status.h metrics.h reference.h version.h; do
    [ -f "$PREFIX/include/photongi/$h" ] || die "include/photongi/$h not installed"
done
grep -q "#define PGI_VERSION_STRING \"$VERSION\"" "$PREFIX/include/photongi/version.h" ||
    die "installed version.h does not say $VERSION"
for f in photongiConfig.cmake photongiConfigVersion.cmake photongiTargets.cmake; do
    [ -f "$LIBDIR/cmake/photongi/$f" ] || die "lib/cmake/photongi/$f not installed"
done
[ "$("$PREFIX/bin/photongi" --version)" = "photongi $VERSION" ] || die "installed bin/photongi --version"
# photongi-mpi is installed with the tools when MPI was found (PGI_MPI); alone it is one rank
if [ -x "$PREFIX/bin/photongi-mpi" ]; then
    [ "$("$PREFIX/bin/photongi-mpi" --version 2>/dev/null)" = "photongi-mpi $VERSION" ] ||
        die "installed bin/photongi-mpi --version"
fi
# A shared libphotongi is found by the consumers below through LD_LIBRARY_PATH (the CMake one
# has an RPATH anyway); a static one makes this a no-op.
export LD_LIBRARY_PATH=$LIBDIR${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}

# The Python package, when the build has it: Debian's python3 imports it from the prefix and renders.
PYPKG=$(find "$PREFIX" -path '*-packages/photongi/__init__.py' -print -quit)
if [ -n "$PYPKG" ]; then
    step "python3: import photongi from $(dirname "$(dirname "$PYPKG")")"
    PY=/usr/bin/python3
    [ -x "$PY" ] || PY=python3
    PYTHONPATH=$(dirname "$(dirname "$PYPKG")") "$PY" -c "
import photongi
assert photongi.__version__ == '$VERSION', photongi.__version__
image, stats = photongi.render('cornell', size=(32, 24), photons=2000)
assert image.shape == (24, 32, 3) and image.mean() > 0 and stats['width'] == 32
print('   photongi', photongi.__version__, 'from', photongi.__file__)" || die "the installed Python package"
fi

step "pkg-config"
export PKG_CONFIG_PATH=$PCDIR
[ "$(pkg-config --modversion photongi)" = "$VERSION" ] || die "pkg-config --modversion photongi"
# shellcheck disable=SC2046,SC2086  # word splitting of the flags is the point
"$CC_BIN" $EXTRA -o "$TMP/render_frame_pc" "$SRC/examples/render_frame.c" $(pkg-config --cflags --libs photongi) ||
    die "compiling the example with \`pkg-config --cflags --libs photongi\`"
run_example "$TMP/render_frame_pc" pkg-config
# shellcheck disable=SC2046,SC2086
"$CC_BIN" $EXTRA -o "$TMP/render_frame_pc_static" "$SRC/examples/render_frame.c" \
    $(pkg-config --static --cflags --libs photongi) ||
    die "compiling the example with \`pkg-config --static --cflags --libs photongi\`"
run_example "$TMP/render_frame_pc_static" pkg-config-static
# shellcheck disable=SC2046,SC2086
"$CC_BIN" $EXTRA -o "$TMP/engine_loop_pc" "$SRC/examples/engine_loop.c" $(pkg-config --cflags --libs photongi) -lm ||
    die "compiling examples/engine_loop.c with \`pkg-config --cflags --libs photongi\`"
run_engine "$TMP/engine_loop_pc" pkg-config
unset PKG_CONFIG_PATH

# The consumers' own CMake runs: the flags of this build's compiler and EXTRA only.
cmake_consumer_args=(-DCMAKE_BUILD_TYPE="$CONFIG" -DCMAKE_C_COMPILER="$CC_BIN" -DCMAKE_C_FLAGS="$EXTRA"
    -DCMAKE_EXE_LINKER_FLAGS="$EXTRA")

step "find_package(photongi) (examples/CMakeLists.txt, CMAKE_PREFIX_PATH=$PREFIX)"
"$CMAKE" -S "$SRC/examples" -B "$TMP/find-package" -DCMAKE_PREFIX_PATH="$PREFIX" "${cmake_consumer_args[@]}" \
    >"$TMP/fp.log" 2>&1 || {
    cat "$TMP/fp.log"
    die "configuring examples/ with find_package"
}
pkgdir=$(sed -n 's/^photongi_DIR:PATH=//p' "$TMP/find-package/CMakeCache.txt")
case $pkgdir in "$PREFIX"/*) ;; *) die "find_package found photongi in '$pkgdir', not in $PREFIX" ;; esac
"$CMAKE" --build "$TMP/find-package" --config "$CONFIG" >"$TMP/fp-build.log" 2>&1 || {
    cat "$TMP/fp-build.log"
    die "building examples/ with find_package"
}
run_example "$(find "$TMP/find-package" -name render_frame -type f -perm -u+x -print -quit)" find-package
run_engine "$(find "$TMP/find-package" -name engine_loop -type f -perm -u+x -print -quit)" find-package

step "add_subdirectory(source tree) in a parent project"
mkdir -p "$TMP/parent"
cat >"$TMP/parent/CMakeLists.txt" <<EOF
cmake_minimum_required(VERSION 3.16)
project(pgi_parent LANGUAGES C)
add_subdirectory("$SRC" photongi)
add_subdirectory("$SRC/examples" example)
if(NOT TARGET photongi::photongi)
  message(FATAL_ERROR "no photongi::photongi after add_subdirectory")
endif()
foreach(t photongi-cli photongi-view photongi-mpi photongi-bench test_scene)
  if(TARGET \${t})
    message(FATAL_ERROR "a subproject photongi defines \${t} (tools, benches and tests are top-level only)")
  endif()
endforeach()
EOF
"$CMAKE" -S "$TMP/parent" -B "$TMP/parent-build" "${cmake_consumer_args[@]}" >"$TMP/parent.log" 2>&1 || {
    cat "$TMP/parent.log"
    die "configuring the add_subdirectory parent"
}
[ ! -e "$TMP/parent-build/photongi/tests" ] || die "a subproject photongi configured its tests"
! grep -q "libphotongi" "$TMP/parent-build/photongi/cmake_install.cmake" || die "a subproject photongi added install rules"
"$CMAKE" --build "$TMP/parent-build" --config "$CONFIG" -j 2 >"$TMP/parent-build.log" 2>&1 || {
    cat "$TMP/parent-build.log"
    die "building the add_subdirectory parent"
}
run_example "$(find "$TMP/parent-build/example" -name render_frame -type f -perm -u+x -print -quit)" add-subdirectory
run_engine "$(find "$TMP/parent-build/example" -name engine_loop -type f -perm -u+x -print -quit)" add-subdirectory

step "done"
