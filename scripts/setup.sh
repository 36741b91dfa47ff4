#!/usr/bin/env bash
# Installs the Debian 12 packages TextureMontage needs, and only those that are missing.
# Safe to run twice: it asks dpkg first and calls apt-get only when something is absent.
# Usage: scripts/setup.sh [--with-tools] [--with-blender]
#   --with-tools    adds xvfb, assimp-utils and the armadillo data used by tests and benchmarks
#   --with-blender  adds Blender (87 MB installed), for the test that imports the exports into it
set -euo pipefail

BUILD_PKGS=(
  build-essential cmake pkg-config
  libglfw3-dev libimgui-dev libglm-dev libopenmesh-dev libeigen3-dev libstb-dev
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev libopencv-photo-dev libopencv-calib3d-dev libnanoflann-dev
  nlohmann-json3-dev libcli11-dev libtinygltf-dev libassimp-dev libgtest-dev
  libsuitesparse-dev libopenblas-dev libtbb-dev libpng-dev libjpeg-dev libtiff-dev liblcms2-dev libexif-dev
  libgl-dev
)
TOOL_PKGS=(xvfb xauth xdotool assimp-utils libcgal-demo nodejs python3-opencv python3-scipy python3-skimage tuxpaint-stamps-default parallel)  # parallel: scripts/batch.sh and the batch test; python3-opencv, -scipy: scripts/make_demo.py; xdotool: editor_ui_test (real keys); python3-skimage, tuxpaint-stamps-default: the face and tiger cases' photos (tests, tm_subject_bench)

want=("${BUILD_PKGS[@]}")
for arg in "$@"; do
  case "$arg" in
    --with-tools) want+=("${TOOL_PKGS[@]}") ;;
    --with-blender) want+=(blender) ;;
    *) echo "setup: unknown option $arg (expected --with-tools, --with-blender)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${want[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "setup: all ${#want[@]} packages present"
  exit 0
fi

echo "setup: installing ${missing[*]}"
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
