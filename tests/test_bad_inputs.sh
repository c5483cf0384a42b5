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

# ---- files and meshes (deep hierarchies, checked opens, declared counts)
# expect_fast_ok ARGS...: exit 0 within 5 s (a file read once, however often it is named).
expect_fast_ok() {
    local err rc
    err=$("${LIMIT[@]}" timeout 5 "$BIN" "$@" 2>&1 >/dev/null)
    rc=$?
    if [ "$rc" -ne 0 ]; then
        echo "FAIL photongi $*: exit status $rc (expected 0 within 5 s; 124 = timeout)"
        printf '%s\n' "$err" | head -5 | sed 's/^/    /'
        fail=$((fail + 1))
    else
        pass=$((pass + 1))
    fi
}
if [ -d "$DIR/../bad-inputs-2" ]; then
    expect_clear_error "gltf_deep_nodes.gltf: node 1000 is 1001 levels deep" info --scene "$DIR/../bad-inputs-2/gltf_deep_nodes.gltf"
    expect_clear_error "off_300M_faces.off:2: declares 300000000 vertices" info --scene "$DIR/../bad-inputs-2/off_300M_faces.off"
    expect_clear_error "glb_json_chunk_4GB.glb: GLB JSON chunk declares 4294967280 bytes" \
        info --scene "$DIR/../bad-inputs-2/glb_json_chunk_4GB.glb"
fi
fm="$TMP/fm"
mkdir -p "$fm/a"
tri='v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl light\nf 1 2 3\n'
# Material libraries: a FIFO, a link to /dev/zero (both hung), one 1 MB file named 1000 times on a line.
mkfifo "$fm/fifo.mtl"
ln -s /dev/zero "$fm/zero.mtl"
printf "mtllib fifo.mtl\n$tri" >"$fm/fifo.obj"
printf "mtllib zero.mtl\n$tri" >"$fm/zero.obj"
expect_clear_error "fifo.obj: material library $fm/fifo.mtl: is a FIFO" info --scene "$fm/fifo.obj"
expect_clear_error "zero.obj: material library $fm/zero.mtl: is a device" info --scene "$fm/zero.obj"
{
    printf 'newmtl light\nKe 1 1 1\n'
    for i in $(seq 1 14000); do printf '# padding padding padding padding padding padding padding padding\n'; done
} >"$fm/big.mtl"
{
    printf 'mtllib'
    for i in $(seq 1 1000); do printf ' big.mtl'; done
    printf "\n$tri"
} >"$fm/many.obj"
printf 'newmtl light\nKe 1 1 1\n' >"$fm/many.mtl" # Assimp takes the whole line for one name, then reads this
expect_fast_ok info --scene "$fm/many.obj"
# A glTF whose buffer is a FIFO (hung).
mkfifo "$fm/buf.bin"
printf '{"asset":{"version":"2.0"},"buffers":[{"uri":"buf.bin","byteLength":36}],"bufferViews":[{"buffer":0,"byteLength":36}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0}\n' >"$fm/fifo.gltf"
expect_clear_error "buf.bin: is a FIFO" info --scene "$fm/fifo.gltf"
# A buffer of 3 GB (sparse) behind a 36-byte mesh: Assimp reads all of it.
truncate -s 3G "$fm/big.bin"
sed 's/"buf.bin","byteLength":36/"big.bin","byteLength":3221225472/' "$fm/fifo.gltf" >"$fm/big.gltf"
expect_clear_error "big.gltf: buffer 0 declares 3221225472 bytes, its buffer views use 36" info --scene "$fm/big.gltf"
rm -f "$fm/big.bin"
# JSON nested 100000 deep inside a glTF.
{
    printf '{"asset":{"version":"2.0"},"extras":'
    printf '%.0s[' $(seq 1 100000)
    printf '%.0s]' $(seq 1 100000)
    printf '}\n'
} >"$fm/deep.gltf"
expect_clear_error "deep.gltf:1: JSON nested deeper than 1000 levels" info --scene "$fm/deep.gltf"
# Deep nesting: COLLADA nodes and DirectX .x frames 5000 deep (stack overflows in Assimp).
{
    printf '<?xml version="1.0"?>\n<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">\n<library_visual_scenes><visual_scene id="s">\n'
    for i in $(seq 1 5000); do printf '<node id="n%d">' "$i"; done
    for i in $(seq 1 5000); do printf '</node>'; done
    printf '\n</visual_scene></library_visual_scenes></COLLADA>\n'
} >"$fm/deep.dae"
expect_clear_error "deep.dae:4: XML elements nested deeper than 1000 levels" info --scene "$fm/deep.dae"
{
    printf 'xof 0303txt 0032\n'
    for i in $(seq 1 5000); do printf 'Frame f%d {\n' "$i"; done
    for i in $(seq 1 5000); do printf '}\n'; done
} >"$fm/deep.x"
expect_clear_error "deep.x:1002: braces nested deeper than 1000 levels" info --scene "$fm/deep.x"
# Counts a header declares that the file cannot hold (gigabytes allocated before Assimp fails).
printf 'AC3Db\nMATERIAL "m" rgb 1 1 1 amb 0 0 0 emis 1 1 1 spec 0 0 0 shi 0 trans 0\nOBJECT world\nkids 1\nOBJECT poly\nnumvert 300000000\n0 0 0\n' \
    >"$fm/huge.ac"
expect_clear_error "huge.ac:6: declares 300000000 vertices" info --scene "$fm/huge.ac"
printf 'v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 1\nresolution 64 64\nl 0 0 5\nf 1 1 1 1 0 0 0 0\np 400000000\n0 0 0\n' \
    >"$fm/huge.nff"
expect_clear_error "huge.nff:10: declares 400000000 polygon vertices" info --scene "$fm/huge.nff"
printf 'MD5Version 10\ncommandline ""\nnumJoints 1\nnumMeshes 1\njoints {\n"r" -1 ( 0 0 0 ) ( 0 0 0 )\n}\nmesh {\nnumverts 500000000\n}\n' \
    >"$fm/huge.md5mesh"
expect_clear_error "huge.md5mesh:9: declares 500000000 vertices" info --scene "$fm/huge.md5mesh"
printf 'xof 0303txt 0032\nMesh m {\n 400000000;\n 0.0;0.0;0.0;;\n}\n' >"$fm/huge.x"
expect_clear_error "huge.x:3: declares 400000000 items" info --scene "$fm/huge.x"
printf '*3DSMAX_ASCIIEXPORT 200\n*GEOMOBJECT {\n*MESH {\n*MESH_NUMVERTEX 400000000\n}\n}\n' >"$fm/huge.ase"
expect_clear_error "huge.ase:4: declares 400000000 items" info --scene "$fm/huge.ase"
sed 's/count="9"/count="900000000"/' >"$fm/huge.dae" <<'DAE'
<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<library_geometries><geometry id="g"><mesh><source id="p"><float_array id="pa" count="9">0 0 0 1 0 0 0 1 0</float_array>
</source></mesh></geometry></library_geometries>
</COLLADA>
DAE
expect_clear_error "huge.dae:3: declares 900000000 items" info --scene "$fm/huge.dae"
# Many materials (Assimp's OBJ import is quadratic in them: 50k took 28 s).
{
    for i in $(seq 0 10000); do printf 'newmtl m%d\nKe 1 1 1\n' "$i"; done
} >"$fm/mats.mtl"
printf "mtllib mats.mtl\n$tri" >"$fm/mats.obj"
expect_clear_error "mats.mtl:20001: more than 10000 materials" info --scene "$fm/mats.obj"
# One texture named by 40 materials through "a/../" aliases is decoded once, and a texture over
# the budget is refused before it is decoded.
if command -v python3 >/dev/null 2>&1; then
    python3 - "$fm/t.png" 2048 <<'PY'
import struct, sys, zlib
w = int(sys.argv[2])
def chunk(t, d):
    return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
raw = zlib.compress((b"\0" + b"\x80" * (3 * w)) * w, 9)
open(sys.argv[1], "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, w, 8, 2, 0, 0, 0)) +
                              chunk(b"IDAT", raw) + chunk(b"IEND", b""))
PY
    {
        printf 'mtllib tex.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n'
        for i in $(seq 1 40); do printf 'usemtl m%d\nf 1/1 2/2 3/3\n' "$i"; done
    } >"$fm/tex.obj"
    {
        alias=""
        for i in $(seq 1 40); do
            alias="a/../$alias"
            printf 'newmtl m%d\nKe 1 1 1\nmap_Kd %st.png\n' "$i" "$alias"
        done
    } >"$fm/tex.mtl"
    expect_fast_ok render --scene "$fm/tex.obj" --max-memory 120M --size 16x16 --photons 1000 -o "$fm/tex.exr"
    expect_clear_error "texture '$fm/a/../t.png' (2048x2048) needs 32.0 MiB" \
        render --scene "$fm/tex.obj" --max-memory 16M --size 16x16 --photons 1000 -o "$fm/tex.exr"
fi

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
