#!/usr/bin/env bash
# Installs the Debian 12 packages photongi needs, if any are missing.
# Runs apt-get only when something is absent (needs root or sudo then).
set -euo pipefail

PKGS=(build-essential cmake pkg-config libembree-dev libassimp-dev libstb-dev libopenexr-dev
      libcjson-dev libcmocka-dev)
PKGS+=(libsdl2-dev)   # photongi-view (optional for the library and CLI)
PKGS+=(libopenmpi-dev openmpi-bin)   # photongi-mpi, the MPI launcher (optional; tests/test_mpi.sh)
# scikit-image validates compare's SSIM/PSNR (test_metrics_skimage);
# gnuplot draws the quality benchmark's plots (bench/quality.sh).
PKGS+=(python3-skimage python3-numpy gnuplot-nox)
# clang-format 14 formats and checks the C sources (scripts/format.sh, .clang-format).
PKGS+=(clang-format)
# clang 14 builds the libFuzzer targets (make fuzz: libFuzzer, ASan, UBSan come in
# libclang-rt-14-dev, which clang only recommends) and the ThreadSanitizer job (make test-tsan:
# LLVM's OpenMP runtime libomp and its TSan tool libarcher.so, both in libomp-14-dev).
PKGS+=(clang libclang-rt-14-dev libomp-dev)
# The Vulkan compute backend (--device vulkan, docs/gpu.md): the loader and headers, glslc to compile
# the shaders, and Mesa's lavapipe (a CPU Vulkan device) so that the GPU tests run without a GPU.
PKGS+=(libvulkan-dev glslc mesa-vulkan-drivers vulkan-tools)
# The GPU machine's bundle (scripts/gpu-bundle.sh): xz, and the GL dispatch and X11 libraries NVIDIA's
# Vulkan driver loads, packed with it for machine images that lack them.
PKGS+=(xz-utils libglvnd0 libglx0 libx11-6 libxext6)
# The Python package (python/photongi, docs/python.md): Python's headers and NumPy to build it,
# pytest for its tests, matplotlib for the example that plots the estimators against each other.
PKGS+=(python3-dev python3-numpy python3-pytest python3-matplotlib)

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "photongi: installing missing packages: ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "photongi: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
