#!/usr/bin/env bash
# drape's one entry point for a fresh Debian 12 machine (as root, or with sudo).
#   ./setup.sh          install packages, build, and build the quickstart release
#   ./setup.sh test     install packages, build, and run the test suite
#   ./setup.sh build    install packages and build only
#   ./setup.sh bench    also install what the benchmarks compare against (Open3D), build
# Safe to run again: packages already present are skipped, the build is incremental.
set -euo pipefail
cd "$(dirname "$0")"

BUILD_DIR=${DRAPE_BUILD_DIR:-build}
JOBS=${DRAPE_JOBS:-$(nproc)}

PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev nlohmann-json3-dev libssl-dev
  libbullet-dev libbullet-extras-dev
  libassimp-dev libembree-dev libtbb-dev
  libopencv-dev libsundials-dev
  libopenvdb-dev libboost-iostreams-dev
  libyaml-cpp-dev libsqlite3-dev libdlib-dev
  libcgal-dev libgmp-dev libmpfr-dev
  libopenmpi-dev openmpi-bin
  libgtest-dev libgmock-dev libbenchmark-dev
  python3-numpy
  chromium            # headless check of a release's index.html gallery
)

# Only the benchmarks need these (registration_bench compares with Open3D's ICP).
BENCH_PACKAGES=(python3-open3d)

install_packages() {
  local missing=()
  for p in "${PACKAGES[@]}" "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then
    echo "setup: all packages present"
    return
  fi
  echo "setup: installing ${missing[*]}"
  local sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

build() {
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release
  cmake --build "$BUILD_DIR" -j "$JOBS"
}

case "${1:-main}" in
  main)
    install_packages
    build
    # A fresh build each time (the code may have changed since the last one), then the
    # check against the published reference that CI also makes.
    rm -rf "$BUILD_DIR/quickstart"
    "$BUILD_DIR/bin/drape" build recipes/quickstart.yaml -o "$BUILD_DIR/quickstart" -j "$JOBS"
    "$BUILD_DIR/bin/drape" verify "$BUILD_DIR/quickstart" --published datasets/quickstart/2.0.0
    echo "setup: the quickstart release is in $BUILD_DIR/quickstart (open its index.html)"
    ;;
  test)
    install_packages
    build
    ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS"
    ;;
  build)
    install_packages
    build
    ;;
  bench)
    install_packages "${BENCH_PACKAGES[@]}"
    build
    ;;
  *)
    echo "usage: ./setup.sh [main|test|build|bench]" >&2
    exit 2
    ;;
esac
