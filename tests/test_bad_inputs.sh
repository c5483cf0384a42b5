#!/usr/bin/env bash
# Hostile inputs (../shared/bad-inputs, see its README): each must end in a
# clear error -- exit status 1 (the file is at fault, not the command line: see
# 'photongi --help'), a message naming the file -- within
# seconds and in bounded memory, never a crash, a hang or an OOM.
#   test_bad_inputs.sh PHOTONGI_CLI BAD_INPUTS_DIR
set -u
BIN=$1
DIR=$2
if [ ! -d "$DIR" ]; then
    echo "test_bad_inputs: $DIR not found (the shared/ folder beside the checkout); skipped"
    exit 77
fi
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
pass=0
fail=0
# Bounded memory: 3 GB of address space (not under AddressSanitizer, which
# reserves terabytes of it); bounded time: 20 s.
LIMIT=()
if [ -z "${PGI_SANITIZE:-}" ] && command -v prlimit >/dev/null; then LIMIT=(prlimit --as=3000000000); fi

# expect_clear_error NAME-IN-MESSAGE ARGS...
expect_clear_error() {
    local needle=$1
    shift
    local err rc
    err=$("${LIMIT[@]}" timeout 20 "$BIN" "$@" 2>&1 >/dev/null)
    rc=$?
    if [ "$rc" -ne 1 ]; then
        echo "FAIL photongi $*: exit status $rc (expected 1; 124 = timeout, >128 = signal)"
        printf '%s\n' "$err" | head -5 | sed 's/^/    /'
        fail=$((fail + 1))
    elif ! printf '%s\n' "$err" | grep -qF -- "$needle"; then
        echo "FAIL photongi $*: the message does not name $needle:"
        printf '%s\n' "$err" | head -5 | sed 's/^/    /'
        fail=$((fail + 1))
    else
        pass=$((pass + 1))
    fi
}

# Images: photongi compare reads them with pgi_image_read.
for f in image_pgm16_heap_overflow.pgm compare_pgm16_512_segv.pgm image_tga_21B_3GB.tga image_tga_23B_oom.tga \
         exr_header_1e8x1e8.exr exr_zip_bomb_16384.exr; do
    expect_clear_error "$f" compare "$DIR/$f" "$DIR/$f"
done

# Meshes: photongi info loads them through Assimp.
for f in mesh_ply_hang.ply fuzz_mesh_crash_41853a.bin mesh_obj_assimp_leak.bin; do
    expect_clear_error "$f" info --scene "$DIR/$f"
done
for f in m.obj k.obj m2.obj; do
    # the message names the MTL that is at fault
    expect_clear_error ".mtl" info --scene "$DIR/obj_mtl_map_before_newmtl/$f"
done
# The fuzzer's files hold an OBJ, a line "#MTL", then its MTL: split them as the importer sees them.
for f in fuzz_mesh_crash_41853a.bin mesh_obj_assimp_leak.bin; do
    d="$TMP/${f%.bin}"
    mkdir -p "$d"
    awk -v obj="$d/m.obj" -v mtl="$d/m.mtl" 'BEGIN { out = obj } /^#MTL/ { out = mtl; next } { print > out }' "$DIR/$f"
    expect_clear_error "$d/m." info --scene "$d/m.obj"   # the split MTL or the OBJ, whichever is at fault
done
# Every file of the folder is covered above.
for f in "$DIR"/*; do
    b=$(basename "$f")
    case "$b" in
    README.md | obj_mtl_map_before_newmtl | image_pgm16_heap_overflow.pgm | compare_pgm16_512_segv.pgm | \
        image_tga_21B_3GB.tga | image_tga_23B_oom.tga | exr_header_1e8x1e8.exr | exr_zip_bomb_16384.exr | \
        mesh_ply_hang.ply | fuzz_mesh_crash_41853a.bin | mesh_obj_assimp_leak.bin) ;;
    *) echo "FAIL $b: a hostile input this test does not try yet"; fail=$((fail + 1)) ;;
    esac
done

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
