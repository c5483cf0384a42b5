#!/usr/bin/env bash
# scripts/gpu-bundle.sh [--no-build] [DIR]: everything bench/gpu_suite.sh needs on a machine that has none
# of photongi's libraries (the GPU machine; docs/gpu.md, "Measuring on a GPU machine"), in one archive:
#
#   DIR/photongi-gpu.tar.xz   (DIR default: gpu-bundle/ in the repository root, ignored by git)
#     photongi-gpu/bin/       photongi, photongi-bench, photongi-bench-gpu-{frame,rays,trace}
#     photongi-gpu/tests/     the GPU tests (test_gpu, test_gpu_rays, test_gpu_trace, test_gpu_frame)
#     photongi-gpu/lib/       every shared library they load except glibc's own (the loader, libc,
#                             libm, libpthread, libdl, librt), the Vulkan loader included, and the GL
#                             dispatch libraries NVIDIA's Vulkan driver loads (libGLdispatch, libGLX, ...)
#     photongi-gpu/scenes/    sibenik, crytek-sponza, fireplace-room and cornell-box (meshes, textures)
#                             with their descriptions: what the suite and the GPU tests load
#     photongi-gpu/env.sh     `. env.sh` puts bin/ and tests/ on PATH, lib/ on LD_LIBRARY_PATH and
#                             scenes/ in PHOTONGI_SCENES
#     photongi-gpu/MANIFEST   commit, date, compiler, the newest glibc symbol version needed, the files
#
# Builds first (BUILD, default build/: a Release build with the Vulkan backend, configured if missing)
# unless --no-build. Scenes come from $PHOTONGI_SCENES, else ../shared/scenes. The archive plus the
# tracked tree must travel to the GPU machine in 64 MiB: the script fails above that and warns above
# 45 MiB. XZ_LEVEL (default 6) sets the compression. tests/test_bundle.sh proves the bundle needs
# nothing else (a mount namespace whose library folder holds only glibc's).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

build=1
DIR=""
for a in "$@"; do
    case "$a" in
    --no-build) build=0 ;;
    -h | --help)
        sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//'
        exit 0
        ;;
    -*)
        echo "gpu-bundle: unknown option $a (usage: scripts/gpu-bundle.sh [--no-build] [DIR])" >&2
        exit 2
        ;;
    *) DIR=$a ;;
    esac
done
DIR=${DIR:-$ROOT/gpu-bundle}
BUILD=${BUILD:-build}
SCENES=${PHOTONGI_SCENES:-$(cd .. && pwd)/shared/scenes}
XZ_LEVEL=${XZ_LEVEL:-6}
say() { echo "gpu-bundle: $*" >&2; }
die() {
    say "$*"
    exit 1
}

BINS=(photongi photongi-bench photongi-bench-gpu-frame photongi-bench-gpu-rays photongi-bench-gpu-trace)
TESTS=(test_gpu test_gpu_rays test_gpu_trace test_gpu_frame)
# glibc's own libraries: the target machine has its own (a newer glibc runs what an older one built)
GLIBC_RE='^(linux-vdso\.so\.1|ld-linux-x86-64\.so\.2|libc\.so\.6|libm\.so\.6|libpthread\.so\.0|libdl\.so\.2|librt\.so\.1)$'
# What NVIDIA's Vulkan driver (libGLX_nvidia.so.0) loads besides glibc: a machine image with the driver
# but without the GL userland has these missing (docs/gpu.md).
DRIVER_LIBS=(libGLdispatch.so.0 libGLX.so.0 libX11.so.6 libXext.so.6)
# Loaded with dlopen, so ldd does not list them: TBB's scalable allocator (Embree's tasking).
DLOPEN_LIBS=(libtbbmalloc.so.2)
SCENE_DIRS=(sibenik crytek-sponza fireplace-room cornell-box)
SCENE_JSON=(sibenik crytek-sponza crytek-sponza-paper fireplace-room cornell-box cornell-moving)

# --- the build
if [ "$build" = 1 ]; then
    if [ ! -f "$BUILD/CMakeCache.txt" ]; then
        cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DPGI_VULKAN=ON >/dev/null
    fi
fi
[ -f "$BUILD/CMakeCache.txt" ] || die "$BUILD is not a build folder (no CMakeCache.txt): run 'make build' or leave out --no-build"
cache() { sed -n "s/^$1:[A-Z]*=//p" "$BUILD/CMakeCache.txt"; }
[ "$(cache CMAKE_BUILD_TYPE)" = Release ] ||
    die "$BUILD is a '$(cache CMAKE_BUILD_TYPE)' build; the bundle needs Release (BUILD=build-bundle scripts/gpu-bundle.sh configures one)"
[ "$(cache PGI_VULKAN)" = ON ] ||
    die "$BUILD has no Vulkan backend (PGI_VULKAN=$(cache PGI_VULKAN)): install libvulkan-dev and glslc (scripts/install-deps.sh)"
for o in PGI_SANITIZE PGI_TSAN PGI_FUZZ; do
    [ "$(cache $o)" != ON ] || die "$BUILD is built with $o: the bundle needs a plain Release build"
done
if [ "$build" = 1 ]; then
    say "building in $BUILD"
    cmake --build "$BUILD" -j "$(nproc)" --target photongi-cli "${BINS[@]:1}" "${TESTS[@]}" >/dev/null
fi
for b in "${BINS[@]}"; do [ -x "$BUILD/bin/$b" ] || die "$BUILD/bin/$b is missing: build it first (make build)"; done
for t in "${TESTS[@]}"; do [ -x "$BUILD/tests/$t" ] || die "$BUILD/tests/$t is missing: build it first (make build)"; done
[ -d "$SCENES" ] || die "no scenes folder $SCENES (set PHOTONGI_SCENES)"
for s in "${SCENE_DIRS[@]}"; do [ -d "$SCENES/$s" ] || die "$SCENES/$s is missing (set PHOTONGI_SCENES)"; done

# --- stage
mkdir -p "$DIR"
DIR=$(cd "$DIR" && pwd)
STAGE=$(mktemp -d "${TMPDIR:-/tmp}/pgi-bundle.XXXXXX")
trap 'rm -rf "$STAGE"' EXIT
B=$STAGE/photongi-gpu
mkdir -p "$B/bin" "$B/tests" "$B/lib" "$B/scenes"
for b in "${BINS[@]}"; do cp "$BUILD/bin/$b" "$B/bin/"; done
for t in "${TESTS[@]}"; do cp "$BUILD/tests/$t" "$B/tests/"; done
strip --strip-unneeded "$B"/bin/* "$B"/tests/* 2>/dev/null || true

# The libraries: each ELF's closure as the dynamic loader resolves it here (ldd), less glibc's.
declare -A seen=()
add_closure() { # ELF...
    local line name path
    while read -r line; do
        case "$line" in
        *"=> not found"*) die "$(echo "$line" | awk '{print $1}') (needed by $1) is not installed here" ;;
        *"=> /"*)
            name=$(echo "$line" | awk '{print $1}')
            path=$(echo "$line" | awk '{print $3}')
            [[ "$name" =~ $GLIBC_RE ]] && continue
            [ -n "${seen[$name]:-}" ] && continue
            seen[$name]=1
            cp -L "$path" "$B/lib/$name"
            ;;
        esac
    done < <(ldd "$@" 2>/dev/null | grep '=>' | sort -u)
}
add_closure "$B"/bin/* "$B"/tests/*
ldconfig -p >"$STAGE/ldcache.txt"
for l in "${DRIVER_LIBS[@]}" "${DLOPEN_LIBS[@]}"; do
    # (awk reads the whole listing: leaving early would end a pipe with SIGPIPE under pipefail)
    p=$(awk -v n="$l" '$1 == n && /x86-64/ && !p {p = $NF} END {print p}' "$STAGE/ldcache.txt")
    if [ -z "$p" ]; then
        say "warning: $l is not installed here (Debian: libglvnd0, libglx0, libx11-6, libxext6, libtbbmalloc2); left out"
        continue
    fi
    [ -n "${seen[$l]:-}" ] || { seen[$l]=1; cp -L "$p" "$B/lib/$l"; }
    add_closure "$p"
done
chmod 0644 "$B"/lib/*

# The scenes: meshes and textures, and the descriptions beside them (meshes resolve against the
# description's folder, so `--scene $PHOTONGI_SCENES/sibenik.json` and `--scene sibenik` both work).
for s in "${SCENE_DIRS[@]}"; do cp -rL "$SCENES/$s" "$B/scenes/"; done
for j in "${SCENE_JSON[@]}"; do cp "scenes/$j.json" "$B/scenes/"; done
[ -f "$SCENES/SOURCES.md" ] && cp "$SCENES/SOURCES.md" "$B/scenes/"
chmod -R u+w "$B/scenes"

cat >"$B/env.sh" <<'EOF'
# . photongi-gpu/env.sh: photongi's binaries, libraries and scenes from this bundle
PGI_BUNDLE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
export PGI_BUNDLE
export PATH="$PGI_BUNDLE/bin:$PGI_BUNDLE/tests:$PATH"
export LD_LIBRARY_PATH="$PGI_BUNDLE/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export PHOTONGI_SCENES="$PGI_BUNDLE/scenes"
EOF

# The newest glibc symbol version any bundled file needs: the target's glibc must be at least that.
glibc_need=$(for f in "$B"/bin/* "$B"/tests/* "$B"/lib/*; do
    readelf -V --wide "$f" 2>/dev/null | grep -o 'GLIBC_[0-9][0-9.]*' || true
done | sort -u -V | tail -1)
commit=$(git rev-parse --short=12 HEAD 2>/dev/null || echo unknown)
git diff --quiet HEAD 2>/dev/null || commit="$commit (with uncommitted changes)"
{
    echo "photongi GPU bundle"
    echo "commit:   $commit"
    echo "made:     $(date -u +%Y-%m-%dT%H:%M:%SZ) on $(. /etc/os-release 2>/dev/null && echo "$PRETTY_NAME")"
    echo "compiler: $(sed -n 's/^CMAKE_C_COMPILER:[A-Z]*=//p' "$BUILD/CMakeCache.txt") ($(cc --version | head -1))"
    echo "glibc:    needs $glibc_need or newer"
    echo "files:"
    (cd "$B" && find . -type f ! -path './scenes/*' -printf '  %P %s\n' | sort)
    echo "scenes:   ${SCENE_DIRS[*]} ($(du -sb "$B/scenes" | cut -f1) bytes)"
} >"$B/MANIFEST"

# --- the archive
raw=$(du -sb "$B" | cut -f1)
say "compressing $((raw / 1048576)) MiB (xz -$XZ_LEVEL)"
tar -C "$STAGE" --owner=0 --group=0 -cf - photongi-gpu | xz -T0 "-$XZ_LEVEL" >"$DIR/photongi-gpu.tar.xz.part"
mv "$DIR/photongi-gpu.tar.xz.part" "$DIR/photongi-gpu.tar.xz"
arch=$(stat -c %s "$DIR/photongi-gpu.tar.xz")
tree=$(git ls-files -z 2>/dev/null | (xargs -0 stat -c %s 2>/dev/null || true) | awk '{s += $1} END {print s + 0}')
total=$((arch + tree))
mib() { awk -v b="$1" 'BEGIN {printf "%.1f MiB", b / 1048576}'; }
echo "bundle: $DIR/photongi-gpu.tar.xz $(mib "$arch") ($(mib "$raw") unpacked: $(du -sb "$B/lib" | cut -f1 | xargs -I{} awk 'BEGIN{printf "%.1f", {}/1048576}') MiB libraries, ${#seen[@]} of them; $(mib "$(du -sb "$B/scenes" | cut -f1)") scenes); with the tracked tree ($(mib "$tree")): $(mib "$total") of the 64 MiB that travel; glibc $glibc_need or newer"
if [ "$total" -gt $((64 * 1048576)) ]; then
    die "the bundle and the tree ($(mib "$total")) exceed the 64 MiB that travel to the GPU machine"
elif [ "$total" -gt $((45 * 1048576)) ]; then
    say "warning: the bundle and the tree ($(mib "$total")) are over 45 MiB: little room is left under 64 MiB"
fi
