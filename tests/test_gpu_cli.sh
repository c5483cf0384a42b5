#!/usr/bin/env bash
# The Vulkan backend from the command line (docs/gpu.md), on whatever device the loader finds
# (CI: lavapipe): `render --device vulkan` gives the CPU's image (PSNR >= 40 dB by 'photongi
# compare'), the JSON stats name the device and its passes, a device that does not exist and an
# estimator without a GPU version fail with exit status 1 and a message saying why, and a machine
# without a Vulkan driver gets a clear message instead of a crash.
# With the viewer's path as a second argument, photongi-view --device vulkan headless too.
#   usage: tests/test_gpu_cli.sh path/to/photongi [path/to/photongi-view]   (from the repository root)
set -u

BIN=${1:?usage: test_gpu_cli.sh path/to/photongi}
case $BIN in /*) ;; */*) BIN=$PWD/$BIN ;; esac
. "$(dirname "$0")/lib.sh" test-gpu-cli
run() {
    "$BIN" "$@" >"$TMP/out" 2>"$TMP/err"
    rc=$?
    out=$(cat "$TMP/out")
    err=$(cat "$TMP/err")
}
expect_fail() { # NEEDLE ARGS...: exit 1, stderr contains NEEDLE
    local needle=$1
    shift
    run "$@"
    if [ "$rc" -ne 1 ]; then bad "exit $rc (want 1): $* -- $err"; return; fi
    if ! grep -qiF -- "$needle" "$TMP/err"; then bad "no '$needle' in the message of: $* -- $err"; return; fi
    ok
}

common=(--scene cornell --size 64x48 --photons 20000 --seed 3 -q)
run render "${common[@]}" -o "$TMP/cpu.exr"
[ "$rc" -eq 0 ] && ok || bad "cpu render: $err"
# the device's passes on the CPU tracer's photons (frame_gpu.c's test hook PGI_GPU_CPU_PHOTONS=1): the
# CPU's image
PGI_GPU_CPU_PHOTONS=1 run render "${common[@]}" --device vulkan -o "$TMP/gpu.exr"
[ "$rc" -eq 0 ] && ok || bad "vulkan render (CPU photons): $err"
run compare "$TMP/gpu.exr" "$TMP/cpu.exr" --json
psnr=$(sed -n 's/.*"psnr": *\([^,]*\),.*/\1/p' "$TMP/out")
# null: identical after tone mapping (infinite PSNR)
if [ "$psnr" = null ] || awk -v p="$psnr" 'BEGIN { exit !(p >= 40) }'; then ok; else bad "PSNR $psnr dB < 40: $out"; fi
# the whole frame on the device, photons traced there (their own random numbers: an independent
# photon map of 20k photons, about 27 dB from the CPU's; test_gpu_trace checks 40 dB at 1M)
run render "${common[@]}" --device vulkan -o "$TMP/gpu2.exr" --stats "$TMP/gpu.json"
[ "$rc" -eq 0 ] && ok || bad "vulkan render: $err"
run compare "$TMP/gpu2.exr" "$TMP/cpu.exr" --json
psnr=$(sed -n 's/.*"psnr": *\([^,]*\),.*/\1/p' "$TMP/out")
if [ "$psnr" = null ] || awk -v p="$psnr" 'BEGIN { exit !(p >= 24) }'; then ok; else bad "PSNR $psnr dB < 24: $out"; fi
grep -q '"gpu_trace"' "$TMP/gpu.json" && ok || bad "stats: no gpu_trace pass"
grep -q '"device":[[:space:]]*"[^"c]' "$TMP/gpu.json" && ok || bad "stats: no device name: $(head -c 300 "$TMP/gpu.json")"
# the default estimator's (cluster-trivial) last pass
grep -q '"gpu_radiance"' "$TMP/gpu.json" && ok || bad "stats: no gpu_radiance pass"
grep -q '"gpu_photons"' "$TMP/gpu.json" && ok || bad "stats: no gpu_photons memory"
grep -q '"gpu_view"' "$TMP/gpu.json" && ok || bad "stats: no gpu_view pass"
grep -q '"gpu_direct"' "$TMP/gpu.json" && ok || bad "stats: no gpu_direct pass"
# the GPU frame on a textured mesh scene (when the scenes folder has Sibenik): it renders
if [ -f scenes/sibenik.json ] && [ -f "${PHOTONGI_SCENES:-scenes}/sibenik/sibenik.obj" ]; then
    run render --scene sibenik --size 64x36 --photons 20000 --seed 3 -q --device vulkan -o "$TMP/sib.exr"
    [ "$rc" -eq 0 ] && [ -s "$TMP/sib.exr" ] && ok || bad "vulkan render of sibenik: $err"
fi
# what the GPU frame does not have: refused by name
expect_fail "--filter" render "${common[@]}" --device vulkan --filter 2 -o "$TMP/x.png"
# gpu = vulkan, vulkan:0 = the first device: the same image as the automatic choice when there is one device
run render "${common[@]}" --device gpu --progressive 2 -o "$TMP/gpu2.png"
[ "$rc" -eq 0 ] && ok || bad "--device gpu --progressive 2: $err"
run devices
[ "$rc" -eq 0 ] && grep -q '^vulkan:0: ' "$TMP/out" && ok || bad "devices: $out $err"
# each device's type, driver and Vulkan version on the line below its name
grep -A1 '^vulkan:0: ' "$TMP/out" | grep -q '; driver .*; Vulkan [0-9]' && ok || bad "devices (driver line): $out"
run render --help
grep -qF -- '--device cpu|gpu|vulkan[:N]' "$TMP/out" && ok || bad "render --help has no --device"
# estimators -v: each estimator's devices, from the library's device table
run estimators -v
grep -A3 '^hashgrid ' "$TMP/out" | grep -qF 'devices: cpu, vulkan (without --subsample)' && ok ||
    bad "estimators -v (hashgrid's devices): $out"
grep -A3 '^kdtree ' "$TMP/out" | grep -qE 'devices: cpu$' && ok || bad "estimators -v (kdtree's devices): $out"
expect_fail "does not exist" render "${common[@]}" --device vulkan:99 -o "$TMP/x.png"
expect_fail "0: " render "${common[@]}" --device vulkan:99 -o "$TMP/x.png"
expect_fail "no GPU version" render "${common[@]}" --device vulkan --estimator kdtree -o "$TMP/x.png"
# a device whose memory cannot hold the frame (PGI_GPU_HEAP_LIMIT, gpu.c's test hook: a 2 MB heap):
# refused by name and size before the driver is asked, nothing written
PGI_GPU_HEAP_LIMIT=2000000 expect_fail "gpu_trace_scratch needs 2.6 MiB of device memory" render "${common[@]}" \
    --device vulkan -o "$TMP/heap.png"
[ ! -e "$TMP/heap.png" ] && ok || bad "a refused device frame wrote its image"
run render "${common[@]}" --device metal -o "$TMP/x.png"
[ "$rc" -eq 2 ] && ok || bad "--device metal: exit $rc (want 2)"
# no Vulkan driver at all: the loader finds no ICD
VK_DRIVER_FILES=$TMP/none.json VK_ICD_FILENAMES=$TMP/none.json expect_fail "no Vulkan device" \
    render "${common[@]}" --device vulkan -o "$TMP/x.png"
[ -e "$TMP/x.png" ] && bad "a failed render wrote its image" || ok

VIEW=${2:-}
if [ -n "$VIEW" ]; then
    "$VIEW" --scene cornell --size 64x48 --photons 20000 --device vulkan --frames 2 --stats "$TMP/view.json" \
        >"$TMP/out" 2>"$TMP/err"
    rc=$?
    [ "$rc" -eq 0 ] && grep -q '"device":[[:space:]]*"[^"c]' "$TMP/view.json" && ok ||
        bad "photongi-view --device vulkan: exit $rc $(cat "$TMP/err")"
    "$VIEW" --scene cornell --device vulkan --estimator kdtree --frames 1 >"$TMP/out" 2>"$TMP/err"
    rc=$?
    [ "$rc" -eq 1 ] && grep -q "no GPU version" "$TMP/err" && ok || bad "photongi-view kdtree on vulkan: exit $rc"
fi

summary test_gpu_cli
