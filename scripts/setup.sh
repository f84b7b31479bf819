#!/usr/bin/env bash
# Installs every Debian package lookboth needs to build, test and run.
# Idempotent and quiet when everything is already there; uses sudo when not root.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config clang-format time
  universal-ctags  # function lengths (scripts/check-function-length.sh)
  libeigen3-dev libceres-dev libsuitesparse-dev libopengv-dev
  libmrpt-dev mrpt-apps
  libopencv-dev libopencv-contrib-dev
  libjpeg-dev  # libjpeg's errors made exceptions (libs/dataset/src/jpeg_errors.cpp)
  opencv-doc  # real ArUco photographs for the detect tests
  libwxgtk3.2-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  librosbag-storage-dev libroscpp-core-dev
  libsensor-msgs-dev libnav-msgs-dev libgeometry-msgs-dev libstd-msgs-dev libtf2-msgs-dev
  libfastcdr-dev libsqlite3-dev liblz4-dev libzstd-dev zlib1g-dev  # ROS 2 bags (libs/dataset/src/ros2_*.cpp)
  libavformat-dev libavcodec-dev libswscale-dev libavutil-dev  # video files (libs/dataset/src/video.cpp)
  ffmpeg  # writes the tests' and the demo's videos (scripts/frames_to_video.py)
  chromium xvfb xauth
  python3 python3-yaml  # scripts/*.py (benchmark helpers)
  colmap liburdfdom-tools python3-jsonschema  # exports read by their consumers (tests/export)
  clang libclang-rt-14-dev llvm  # sanitizer build and libFuzzer targets (scripts/fuzz.sh)
)

missing=()
for p in "${PACKAGES[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done

if [[ ${#missing[@]} -eq 0 ]]; then
  exit 0
fi

SUDO=""
if [[ $(id -u) -ne 0 ]]; then
  if command -v sudo >/dev/null 2>&1; then
    SUDO="sudo"
  else
    echo "setup.sh: need root or sudo to install: ${missing[*]}" >&2
    exit 1
  fi
fi

echo "setup.sh: installing ${#missing[@]} missing package(s): ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup.sh: done"
