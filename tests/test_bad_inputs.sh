#!/usr/bin/env bash
# Hostile inputs (../shared/bad-inputs, see its README): each must end in a
# clear error -- exit status 1 (the file is at fault, not the command line: see
# 'photongi --help'), a message naming the file -- within
# seconds and in bounded memory, never a crash, a hang or an OOM.
#   test_bad_inputs.sh PHOTONGI_CLI BAD_INPUTS_DIR [REPO_BAD_INPUTS_DIR]
# BAD_INPUTS_DIR is ../shared/bad-inputs (skipped when absent); REPO_BAD_INPUTS_DIR is
# tests/bad-inputs (found by the fuzzers, see its README.md); the cases at the end need no file.
set -u
BIN=$1
DIR=$2
REPO_DIR=${3:-$(dirname "$0")/bad-inputs}
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

# ---- ../shared/bad-inputs
shared_inputs() {
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
}
if [ -d "$DIR" ]; then
    shared_inputs
else
    echo "test_bad_inputs: $DIR not found (the shared/ folder beside the checkout): its files skipped"
fi

# ---- tests/bad-inputs (see its README.md)
R=$REPO_DIR
for f in hdr_rle_truncated.hdr hdr_rle_zero_run.hdr hdr_rle_header_nul.hdr; do
    expect_clear_error "$f: corrupt Radiance HDR data" compare "$R/$f" "$R/$f"
done
expect_clear_error "hdr_texture/t.hdr: corrupt Radiance HDR data" info --scene "$R/hdr_texture/m.obj"
expect_clear_error "obj_mtl_fallback/m.mtl:1: 'map_Kd' before any 'newmtl'" info --scene "$R/obj_mtl_fallback/m.obj"
expect_clear_error "obj_nul_mtllib/m.mtl:1: 'map_Kd' before any 'newmtl'" info --scene "$R/obj_nul_mtllib/m.obj"
expect_clear_error "ply_face_past_end.ply: PLY face 0 refers to vertex" info --scene "$R/ply_face_past_end.ply"
expect_clear_error "ply_empty_face.ply: PLY face 0 has 0 vertices" info --scene "$R/ply_empty_face.ply"
for f in "$R"/*; do
    case "$(basename "$f")" in
    README.md | hdr_rle_truncated.hdr | hdr_rle_zero_run.hdr | hdr_rle_header_nul.hdr | hdr_texture | obj_mtl_fallback | obj_nul_mtllib | \
        ply_face_past_end.ply | ply_empty_face.ply) ;;
    *) echo "FAIL $f: a hostile input this test does not try yet"; fail=$((fail + 1)) ;;
    esac
done

# ---- no file needed: what a path names, and a light that is not one
mkfifo "$TMP/fifo.json" "$TMP/fifo.obj"
ln -s /dev/zero "$TMP/zero.json"
mkdir "$TMP/dir.obj" "$TMP/dir.json"
expect_clear_error "fifo.json: is a FIFO, not a regular file" info --scene "$TMP/fifo.json"
expect_clear_error "zero.json: is a device, not a regular file" info --scene "$TMP/zero.json"
expect_clear_error "fifo.obj: is a FIFO, not a regular file" info --scene "$TMP/fifo.obj"
expect_clear_error "dir.obj: is a directory" info --scene "$TMP/dir.obj"
expect_clear_error "dir.json: is a directory" info --scene "$TMP/dir.json"
printf '{"mesh": "dir.obj", "sky": {}}\n' >"$TMP/mesh-dir.json"
expect_clear_error "mesh 'dir.obj': $TMP/dir.obj is a directory" info --scene "$TMP/mesh-dir.json"
printf '{"mesh": "%s", "sky": {}}\n' "$TMP/fifo.obj" >"$TMP/mesh-fifo.json"
expect_clear_error "mesh '$TMP/fifo.obj' is a FIFO, not a regular file" info --scene "$TMP/mesh-fifo.json"
# The only emissive triangle has zero area (three points on a line): say so, not "no emissive material".
printf 'mtllib deg.mtl\nv 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nusemtl light\nf 1 2 3\nusemtl white\nf 4 5 6\n' \
    >"$TMP/deg.obj"
printf 'newmtl light\nKe 1 1 1\nnewmtl white\nKd 0.8 0.8 0.8\n' >"$TMP/deg.mtl"
expect_clear_error "deg.obj: the emissive triangles (1, MTL Ke) all have zero area" info --scene "$TMP/deg.obj"
printf '{"mesh": "deg.obj"}\n' >"$TMP/deg.json"
expect_clear_error "deg.json: the scene has no lights: its emissive triangles (1) all have zero area" \
    info --scene "$TMP/deg.json"

# ---- references, outputs, compare
# (the rest, with signals, a full disk and byte-identical continuation: test_reference_safety.sh)
if "$BIN" reference --size 24x16 --spp 4 --threads 2 -q -o "$TMP/ref.exr"; then
    cp "$TMP/ref.exr" "$TMP/fifo-ref.exr" && mkfifo "$TMP/fifo-ref.exr.json"
    expect_clear_error "fifo-ref.exr.json: not a reference's metadata file (not a regular file)" \
        reference --continue "$TMP/fifo-ref.exr" --spp 1
    for spp in -1 18446744073709551616; do
        sed "s/\"spp\":[^,]*/\"spp\": \"$spp\"/" "$TMP/ref.exr.json" >"$TMP/wrap.exr.json" && cp "$TMP/ref.exr" "$TMP/wrap.exr"
        expect_clear_error "wrap.exr.json: not a photongi reference metadata file" reference --continue "$TMP/wrap.exr" --spp 1
        expect_clear_error "wrap.exr.json" reference --merge "$TMP/wrap.exr" "$TMP/ref.exr" -o "$TMP/merged.exr"
    done
    cp "$TMP/ref.exr.json" "$TMP/other.exr.json" && "$BIN" render --size 24x16 -q -o "$TMP/other.exr"
    expect_clear_error "other.exr and $TMP/other.exr.json do not belong together" \
        reference --continue "$TMP/other.exr" --spp 1
    expect_clear_error "the name is 304 characters" reference --spp 1 -o "$TMP/$(printf 'n%.0s' $(seq 300)).exr"
else
    echo "FAIL a 24x16 reference"
    fail=$((fail + 1))
fi

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
