#!/usr/bin/env bash
# Vellum set-up: installs the Debian 12 packages, builds, and runs one job.
#   scripts/setup.sh demo [OUT_DIR]   install + Release build + `vellum demo` (default ./vellum-demo)
#   scripts/setup.sh test [CMAKE_ARGS]  install + build + the whole test suite (ctest);
#                                     extra arguments go to CMake (e.g. -DVELLUM_SANITIZE=ON)
#   scripts/setup.sh deps             install packages only
# Idempotent: re-running skips installed packages and rebuilds incrementally.
# Environment: BUILD_DIR (default ./build), BUILD_TYPE (default Release), JOBS (default nproc),
# BUILD_TARGET (default: everything; the CI's sanitizer job builds vellum_sanitizer_suite).
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake ninja-build pkg-config ccache git ca-certificates
  libvtk9-dev libopencv-dev libcgal-dev libopenmesh-dev libopenvdb-dev libboost-iostreams-dev
  libglfw3-dev libgdcm-dev libgdcm-tools libimgui-dev libeigen3-dev nlohmann-json3-dev
  libcli11-dev libtbb-dev libgtest-dev libbenchmark-dev libegl-dev libgl-dev libegl-mesa0
  libgl1-mesa-dri zlib1g-dev libdeflate-dev libisal-dev xvfb xauth ffmpeg
  snakemake  # `vellum qa --snakemake` and its test (docs/qa.md)
)

install_packages() {
  local missing=()
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if ((${#missing[@]})); then
    echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y --no-install-recommends "${missing[@]}"
  fi
}

BUILD_DIR=${BUILD_DIR:-build}
BUILD_TYPE=${BUILD_TYPE:-Release}
JOBS=${JOBS:-$(nproc)}

build() {
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE="$BUILD_TYPE" "$@"
  cmake --build "$BUILD_DIR" -j "$JOBS" ${BUILD_TARGET:+--target "$BUILD_TARGET"}
}

cmd=${1:-demo}
case "$cmd" in
  deps) install_packages ;;
  demo)
    install_packages
    build -DVELLUM_BUILD_TESTS=OFF -DVELLUM_BUILD_BENCHMARKS=OFF
    out=${2:-vellum-demo}
    "$BUILD_DIR/ui/vellum" demo --out "$out"
    echo "setup: demo outputs are in $(cd "$out" && pwd)"
    ;;
  test)
    install_packages
    shift
    build -DVELLUM_BUILD_TESTS=ON "$@"
    # Under Xvfb so that the GLFW window tests run too (headless EGL tests need no display).
    # CTEST_ARGS: extra ctest arguments (the CI's sanitizer run passes a retry, see .ci/run).
    # shellcheck disable=SC2086
    xvfb-run -a ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS" -LE long ${CTEST_ARGS:-}
    ;;
  *) echo "usage: scripts/setup.sh demo [OUT_DIR] | test | deps" >&2; exit 2 ;;
esac
