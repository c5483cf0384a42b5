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
expect_clear_error "png_idat_2GB.png: corrupt PNG: chunk 'IDAT' at byte 88 declares 2046820395 bytes" \
    compare "$R/png_idat_2GB.png" "$R/png_idat_2GB.png"
expect_clear_error "gltf_sparse_no_indices/m.gltf: accessor 0: sparse has no \"indices\" object" \
    info --scene "$R/gltf_sparse_no_indices/m.gltf"
for f in "$R"/*; do
    case "$(basename "$f")" in
    README.md | hdr_rle_truncated.hdr | hdr_rle_zero_run.hdr | hdr_rle_header_nul.hdr | hdr_texture | obj_mtl_fallback | obj_nul_mtllib | \
        ply_face_past_end.ply | ply_empty_face.ply | gltf_sparse_no_indices | png_idat_2GB.png) ;;
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
mkfifo "$TMP/fifo.exr"
expect_clear_error "fifo.exr: is a FIFO, not a regular file" compare "$TMP/fifo.exr" "$TMP/fifo.exr"
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

# ---- scene numbers (far coordinates, radii, radiances, descriptions)
# Coordinates beyond PGI_MAX_COORD (1e15; Embree aborted on its ray.valid() assertion beyond about
# 1.8e18), radiances beyond PGI_MAX_RADIANCE (1e12; Inf pixels), description values the renderer
# refuses: the file is at fault, exit 1, the file and the item named (docs/scene-format.md, Numbers).
FAR="$DIR/../bad-inputs-2/camera_far_2e18.json"
if [ ! -f "$FAR" ]; then
    FAR="$TMP/camera_far_2e18.json"
    printf '{"builtin": "cornell", "camera": {"eye": [0,1,2e18], "look_at": [0,1,0]}}\n' >"$FAR"
fi
expect_clear_error "camera_far_2e18.json: camera.eye[2] = 2e+18 is out of range" render --scene "$FAR" \
    -o "$TMP/far.png" --size 16x16
num_case() { # NAME NEEDLE JSON: the description NAME.json holds JSON; render must say NEEDLE
    printf '%s\n' "$3" >"$TMP/$1.json"
    expect_clear_error "$1.json: $2" render --scene "$TMP/$1.json" -o "$TMP/$1.png" --size 16x16 -q
}
num_case light_far "lights[0].position[1] = 1e+30 is out of range" \
    '{"builtin": "cornell", "lights": [{"type": "point", "position": [0, 1e30, 0], "intensity": [1, 1, 1]}]}'
num_case object_far "objects[0].size[0] = 1e+30 is out of range" \
    '{"builtin": "cornell", "objects": [{"shape": "box", "center": [0, 1, 0], "size": [1e30, 1, 1]}]}'
num_case motion_far "objects[0].motion.keyframes[1].translate[0] = 1e+30 is out of range" \
    '{"builtin": "cornell", "objects": [{"shape": "box", "center": [0, 1, 0], "size": [1, 1, 1],
      "motion": {"keyframes": [{"t": 0}, {"t": 1, "translate": [1e30, 0, 0]}]}}]}'
num_case motion_scale_far "animation 'objects[0]': keyframe 1 (translate, scale 1e+06) moves the object to 5e+15" \
    '{"builtin": "cornell", "objects": [{"shape": "box", "center": [0, 1, 0], "size": [1e10, 1, 1],
      "motion": {"keyframes": [{"t": 0}, {"t": 1, "scale": 1e6}]}}]}'
num_case sky_3e38 "sky.color[0] = 3e+38 is out of range (0..1e+12)" \
    '{"builtin": "cornell", "sky": {"color": [3e38, 3e38, 3e38]}}'
num_case sky_intensity "sky: color x intensity (and ground x intensity) = 3e+38 is out of range" \
    '{"builtin": "cornell", "sky": {"color": [1, 1, 1], "intensity": 3e38}}'
num_case light_3e38 "lights[0].intensity[0] = 3e+38 is out of range (0..1e+12)" \
    '{"builtin": "cornell", "lights": [{"type": "point", "position": [0, 1, 0], "intensity": [3e38, 1, 1]}]}'
num_case sun_power "light 0 (sun) has a power of" \
    '{"builtin": "cornell", "objects": [{"shape": "box", "center": [0, 1, 0], "size": [1e14, 1, 1]}],
      "lights": [{"type": "sun", "direction": [0, -1, 0], "irradiance": [1e12, 1, 1]}]}'
num_case emission_3e38 "objects[0].material.emission[0] = 3e+38 is out of range" \
    '{"builtin": "cornell", "objects": [{"shape": "sphere", "center": [0, 1, 0], "radius": 0.1,
      "material": {"emission": [3e38, 0, 0]}}]}'
# An environment map (2x1 Radiance HDR of 1.0) times a scale beyond the radiance range.
printf '#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n\200\200\200\201\200\200\200\201' >"$TMP/one.hdr"
num_case env_scale "environment map $TMP/one.hdr: pixel (0, 0) = 1 times scale 3e+12 is out of range" \
    "{\"builtin\": \"cornell\", \"environment\": {\"map\": \"$TMP/one.hdr\", \"scale\": 3e12}}"
# Portals (docs/scene-format.md): a bad one names the file and the portal.
num_case portal_type "portals must be an array" '{"builtin": "window-box", "portals": {"quad": []}}'
num_case portal_entry "portals[0] must be an object" '{"builtin": "window-box", "portals": [[0, 0, 0]]}'
num_case portal_corners "portals[0].quad is malformed (an array of 4 corners" \
    '{"builtin": "window-box", "portals": [{"quad": [[0, 0, 0], [1, 0, 0], [1, 1, 0]]}]}'
num_case portal_missing "portals[1].quad is missing" \
    '{"builtin": "window-box", "portals": [{"quad": [[-1,0.7,-0.7],[-1,1.5,-0.7],[-1,1.5,0.1],[-1,0.7,0.1]]}, {}]}'
num_case portal_string "portals[0].quad is malformed" \
    '{"builtin": "window-box", "portals": [{"quad": [[0, 0, 0], [1, 0, 0], [1, "1", 0], [0, 1, 0]]}]}'
num_case portal_inf "portals[0].quad is malformed" \
    '{"builtin": "window-box", "portals": [{"quad": [[0, 0, 1e999], [1, 0, 0], [1, 1, 0], [0, 1, 0]]}]}'
num_case portal_far "portals[0].quad is malformed" \
    '{"builtin": "window-box", "portals": [{"quad": [[0, 0, 1e30], [1, 0, 0], [1, 1, 0], [0, 1, 0]]}]}'
num_case portal_line "portals[0].quad is degenerate" \
    '{"builtin": "window-box", "portals": [{"quad": [[0, 0, 0], [1, 0, 0], [2, 0, 0], [1, 0, 0]]}]}'
num_case portal_point "portals[0].quad is degenerate" \
    '{"builtin": "window-box", "portals": [{"quad": [[1, 1, 1], [1, 1, 1], [1, 1, 1], [1, 1, 1]]}]}'
num_case portal_skew "portals[0].quad is not a parallelogram" \
    '{"builtin": "window-box", "portals": [{"quad": [[0, 0, 0], [1, 0, 0], [1.5, 1, 0], [0, 1, 0]]}]}'
num_case portal_key "unknown key 'portals[0].corners'" \
    '{"builtin": "window-box", "portals": [{"corners": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]}]}'
# --emission portal in a scene without portals: the settings are at fault (exit 2), the scene named.
err=$(timeout 20 "$BIN" render --scene window-box --emission portal -o "$TMP/np.png" --size 16x16 -q 2>&1 >/dev/null)
rc=$?
if [ "$rc" -eq 2 ] && printf '%s' "$err" | grep -qF "scene 'window-box' has no portals"; then pass=$((pass + 1)); else
    echo "FAIL photongi render --emission portal without portals: exit $rc (expected 2 and the scene): $err"
    fail=$((fail + 1))
fi
# Description values the renderer refuses: exit 1 (the file), not 2 (the command line).
num_case bounces_1000 "render.bounces must be a non-negative whole number (at most 64)" \
    '{"builtin": "cornell", "render": {"bounces": 1000}}'
num_case width_65536 "render.width must be a non-negative whole number (at most 16384)" \
    '{"builtin": "cornell", "render": {"width": 65536, "height": 64}}'
num_case radius_1e-20 "render.radius 1e-20 is out of range (1e-09..1e+15" \
    '{"builtin": "cornell", "render": {"radius": 1e-20}}'
# --radius 1e-20 is refused from the value alone (pi r^2 underflows whatever the scene): a usage
# error, exit 2, before any file is read.
err=$(timeout 20 "$BIN" render --scene cornell --radius 1e-20 -o "$TMP/r.png" 2>&1 >/dev/null)
rc=$?
if [ "$rc" -eq 2 ] && printf '%s' "$err" | grep -qF "1e-09..1e+15"; then pass=$((pass + 1)); else
    echo "FAIL photongi render --radius 1e-20: exit $rc (expected 2 and the range): $err"
    fail=$((fail + 1))
fi
# 10^5 lights: read in linear time (was quadratic, 16-30 s).
awk 'BEGIN { printf "{\"builtin\": \"cornell\", \"lights\": [";
    for (i = 0; i < 100000; i++) printf "%s{\"type\": \"point\", \"position\": [0, 1, 0], \"intensity\": [1e-5, 1e-5, 1e-5]}", i ? ", " : "";
    print "]}" }' >"$TMP/lights_1e5.json"
t0=$(date +%s)
out=$("${LIMIT[@]}" timeout 20 "$BIN" info --scene "$TMP/lights_1e5.json" 2>&1)
rc=$?
t1=$(date +%s)
if [ "$rc" -eq 0 ] && printf '%s' "$out" | grep -qF "point 100000" && [ $((t1 - t0)) -le 5 ]; then pass=$((pass + 1)); else
    echo "FAIL photongi info on 10^5 lights: exit $rc after $((t1 - t0)) s (expected 0 within 5 s)"
    fail=$((fail + 1))
fi
# 10^5 objects: boxes load in linear time; spheres (2304 triangles each) are refused past 16M triangles.
for shape in box sphere; do
    awk -v shape=$shape 'BEGIN { printf "{\"builtin\": \"cornell\", \"objects\": [";
        for (i = 0; i < 100000; i++) printf "%s{\"shape\": \"%s\", \"center\": [0, 1, 0], %s}", i ? ", " : "", shape,
            shape == "box" ? "\"size\": [0.01, 0.01, 0.01]" : "\"radius\": 0.01";
        print "]}" }' >"$TMP/objects_$shape.json"
done
# (5 s: linear, not quadratic. Not under the sanitizers: making 1.2M triangles there took over
# 4 minutes, which is the sanitizer's cost, not a hang.)
SECS_LINEAR=5
if [ -n "${PGI_SANITIZE:-}" ]; then
    : # skipped: see above
else
t0=$(date +%s)
out=$("${LIMIT[@]}" timeout $((SECS_LINEAR * 4)) "$BIN" info --scene "$TMP/objects_box.json" 2>&1)
rc=$?
t1=$(date +%s)
if [ "$rc" -eq 0 ] && printf '%s' "$out" | grep -qF "triangles:  1200036" && [ $((t1 - t0)) -le $SECS_LINEAR ]; then
    pass=$((pass + 1))
else
    echo "FAIL photongi info on 10^5 boxes: exit $rc after $((t1 - t0)) s (expected 0 within $SECS_LINEAR s)"
    fail=$((fail + 1))
fi
fi
expect_clear_error "objects_sphere.json: objects[7598]: the objects make more than 16777216 triangles" \
    info --scene "$TMP/objects_sphere.json"
# 5*10^6 values (10 MB, "[0,0,0,..."; cJSON takes about 100 bytes each): refused before parsing.
awk 'BEGIN { printf "{\"builtin\": \"cornell\", \"_x\": [0"; for (i = 1; i < 5000000; i++) printf ",0"; print "]}" }' \
    >"$TMP/values_5e6.json"
expect_clear_error "values_5e6.json: about 5000003 JSON values, more than 4000000" info --scene "$TMP/values_5e6.json"
# A scene name's escape sequences are not printed raw (control bytes become '?').
printf '{"builtin": "cornell", "name": "evil\\u001b[31mred\\u001b]0;title\\u0007"}\n' >"$TMP/esc.json"
out=$(timeout 20 "$BIN" info --scene "$TMP/esc.json" 2>&1)
rc=$?
if [ "$rc" -eq 0 ] && printf '%s' "$out" | grep -qF 'scene:      evil?[31mred?]0;title?' &&
    ! printf '%s' "$out" | grep -q $'\x1b'; then pass=$((pass + 1)); else
    echo "FAIL photongi info: a scene name's escape sequences printed raw (exit $rc)"
    fail=$((fail + 1))
fi

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
    # Named with an extension Assimp does not know (or none), a file is checked as what its content
    # is: Assimp would pick its importer by content.
    cp "$DIR/../bad-inputs-2/gltf_deep_nodes.gltf" "$TMP/deep-nodes.dat"
    cp "$DIR/../bad-inputs-2/off_300M_faces.off" "$TMP/faces"
    cp "$DIR/../bad-inputs-2/glb_json_chunk_4GB.glb" "$TMP/chunk.bin.txt"
    expect_clear_error "deep-nodes.dat: node 1000 is 1001 levels deep" info --scene "$TMP/deep-nodes.dat"
    expect_clear_error "faces:2: declares 300000000 vertices" info --scene "$TMP/faces"
    expect_clear_error "chunk.bin.txt: GLB JSON chunk declares 4294967280 bytes" info --scene "$TMP/chunk.bin.txt"
    # Every file of the second set is covered (camera_far_2e18.json: scene numbers, above).
    for f in "$DIR/../bad-inputs-2"/*; do
        case "$(basename "$f")" in
        README.md | camera_far_2e18.json | gltf_deep_nodes.gltf | off_300M_faces.off | glb_json_chunk_4GB.glb) ;;
        *) echo "FAIL $(basename "$f") (bad-inputs-2): a hostile input this test does not try yet"; fail=$((fail + 1)) ;;
        esac
    done
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
# The same files under names Assimp does not know: it would pick the importer by content.
cp "$fm/deep.dae" "$fm/deep-dae.dat"
cp "$fm/deep.x" "$fm/deep-x"
expect_clear_error "deep-dae.dat:4: XML elements nested deeper than 1000 levels" info --scene "$fm/deep-dae.dat"
expect_clear_error "deep-x:1002: braces nested deeper than 1000 levels" info --scene "$fm/deep-x"
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
