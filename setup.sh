#!/usr/bin/env bash
# drape's one entry point for a fresh Debian 12 machine (as root, or with sudo).
#   ./setup.sh          install packages, build, and build the quickstart release
#   ./setup.sh test     install packages, check the format (./setup.sh format below),
#                       build, run the test suite, then the sanitizer suite
#                       (./setup.sh sanitize below); what CI runs (.ci/run).
#                       DRAPE_SANITIZE=0 skips the sanitizer suite (a quicker local run)
#   ./setup.sh build    install packages and build only
#   ./setup.sh bench    also install what the benchmarks compare against (Open3D), build
#   ./setup.sh sanitize fuzz/ci.sh: every unit-test program under ASan + UBSan
#                       (clang-14, folder build-san; heavy simulations trimmed, see
#                       docs/testing.md), every fuzz corpus replayed, then every fuzz
#                       target for DRAPE_FUZZ_SECONDS (default 10) each
#   ./setup.sh format   check that every C++ file follows .clang-format
#   ./setup.sh tidy     build, then clang-tidy (.clang-tidy's checks) on every source
#                       that changed since its last clean run (tools/tidy.py)
# Safe to run again: packages already present are skipped, the build is incremental.
set -euo pipefail
cd "$(dirname "$0")"
. tools/ccache_launcher.sh

BUILD_DIR=${DRAPE_BUILD_DIR:-build}
JOBS=${DRAPE_JOBS:-$(nproc)}

PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev nlohmann-json3-dev libssl-dev
  libbullet-dev libbullet-extras-dev
  libassimp-dev libembree-dev libtbb-dev
  libopencv-dev
  libopenvdb-dev libboost-iostreams-dev
  libyaml-cpp-dev libsqlite3-dev libdlib-dev
  libsundials-dev     # KINSOL: material fits (generator/hang/fit.cpp)
  libcgal-dev libgmp-dev libmpfr-dev
  libopenmpi-dev openmpi-bin
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev        # the drape command line (cli/)
  python3-numpy
  chromium            # headless check of a release's index.html gallery
  pybind11-dev        # the drape Python package (python/)
  python3-pytest      # its tests, run from CTest
  python3-torch       # drape.torch.GarmentDataset
  python3-open3d      # open3d=True meshes of the Python package, which its tests check
  nodejs              # npm, for three.js (the gallery's 3D view)
  npm                 # (nodesource's nodejs provides it: counted as present)
  zlib1g-dev          # gzip of the gallery's 3D mesh scripts
  clang-14            # sanitizer build and fuzz targets (./setup.sh sanitize, fuzz/run.sh)
  libfuzzer-14-dev    # libFuzzer for clang-14 (fuzz/)
  slurm-wlm           # tests/slurm.sh: a one-node Slurm (runs as root; DRAPE_SLURM_TEST=0 skips it)
  munge               # Slurm's authentication, for tests/slurm.sh
  clang-format        # ./setup.sh format: every C++ file follows .clang-format
  clang-tidy          # ./setup.sh tidy: the checks of .clang-tidy (tools/tidy.py)
  ccache              # a rebuild after a branch switch, and CI's second run, cost little
)

# What the benchmarks need beyond PACKAGES (registration_bench compares with Open3D's ICP;
# python3-open3d is in PACKAGES too now, for the Python tests).
BENCH_PACKAGES=(python3-open3d)

install_packages() {
  local missing=() provided
  # Virtual packages provided by an installed one (nodesource's nodejs provides npm).
  provided=$(dpkg-query -W -f='${Status} ${Provides}\n' 2>/dev/null | sed -n 's/^install ok installed //p' | tr ',' '\n')
  for p in "${PACKAGES[@]}" "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" && continue
    echo "$provided" | grep -qE "^ *$p( |\$)" && continue
    missing+=("$p")
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

# three.js for the gallery's 3D view, at the version pinned in package-lock.json; the
# build links it into the drape binary, which copies it into every release.
install_viewer() {
  local dir="$BUILD_DIR/viewer"
  mkdir -p "$dir"
  if [ -f "$dir/node_modules/three/package.json" ] &&
     cmp -s generator/release/viewer/package-lock.json "$dir/package-lock.json"; then
    return
  fi
  cp generator/release/viewer/package.json generator/release/viewer/package-lock.json "$dir/"
  (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error)
}

# Debian's python3 finds the package built in $BUILD_DIR/python (import drape) through
# a drape.pth in its site folder: machine-wide, so written only when there is none (or it
# already names this checkout); one naming another checkout is left alone, with how to
# use this one. DRAPE_PYTHON_PTH=replace points it here; DRAPE_PYTHON_PTH=no skips this.
install_python_path() {
  [ "${DRAPE_PYTHON_PTH:-}" = no ] && return
  local site pkg pth current=""
  site=$(/usr/bin/python3 -c 'import sys; print(f"/usr/local/lib/python{sys.version_info.major}.{sys.version_info.minor}/dist-packages")')
  pkg="$(cd "$BUILD_DIR" && pwd)/python"
  pth="$site/drape.pth"
  [ -f "$pth" ] && current=$(head -n 1 "$pth")
  if [ "$current" = "$pkg" ]; then
    echo "setup: /usr/bin/python3 imports drape from $pkg ($pth)"
    return
  fi
  if [ -n "$current" ] && [ "${DRAPE_PYTHON_PTH:-}" != replace ]; then
    echo "setup: left $pth as it is: /usr/bin/python3 imports drape from $current, not this checkout;" \
      "for this one: export PYTHONPATH=$pkg (or DRAPE_PYTHON_PTH=replace ./setup.sh build to point $pth here)"
    return
  fi
  local sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo mkdir -p "$site"
  echo "$pkg" | $sudo tee "$pth" > /dev/null
  echo "setup: wrote $pth${current:+ (it named $current)}: /usr/bin/python3 imports drape from $pkg"
}

build() {
  install_viewer
  # ccache, when the machine has it, makes a rebuild after a branch switch cheap, and a
  # second clone's build too (tools/ccache_launcher.sh).
  ccache_launcher
  # -Werror said on every configure: a build folder configured before it became the
  # default keeps OFF in its cache otherwise (DRAPE_WERROR=OFF ./setup.sh build opts out).
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDRAPE_WERROR="${DRAPE_WERROR:-ON}" \
    "${DRAPE_LAUNCHER[@]}"
  cmake --build "$BUILD_DIR" -j "$JOBS"
  install_python_path
}

# Every tracked C++ file follows .clang-format; fix with: git ls-files '*.cpp' '*.h' | xargs clang-format -i
check_format() {
  command -v clang-format >/dev/null ||
    { echo "setup: format needs clang-format (apt-get install clang-format)" >&2; exit 2; }
  git ls-files '*.c' '*.cc' '*.cpp' '*.h' '*.hpp' | xargs clang-format --dry-run --Werror
  echo "setup: format: every C++ file follows .clang-format"
}

case "${1:-main}" in
  main)
    install_packages
    build
    # A fresh build each time (the code may have changed since the last one), then the
    # check against the published reference that CI also makes.
    rm -rf "$BUILD_DIR/quickstart"
    "$BUILD_DIR/bin/drape" build recipes/quickstart.yaml -o "$BUILD_DIR/quickstart" -j "$JOBS"
    # The newest published reference, as tests/quickstart_reference.sh picks it.
    "$BUILD_DIR/bin/drape" verify "$BUILD_DIR/quickstart" \
      --published "$(ls -d datasets/quickstart/*/ | sort -V | tail -n 1)"
    echo "setup: the quickstart release is in $BUILD_DIR/quickstart (open its index.html)"
    ;;
  test)
    install_packages
    # First, as it takes seconds: a file that does not follow .clang-format fails CI.
    check_format
    build
    ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS"
    # Then every unit-test program under ASan + UBSan and the fuzz targets (docs/testing.md).
    if [ "${DRAPE_SANITIZE:-1}" != 0 ]; then
      DRAPE_FUZZ_CI_SECONDS=${DRAPE_FUZZ_SECONDS:-10} fuzz/ci.sh
    fi
    ;;
  build)
    install_packages
    build
    ;;
  bench)
    install_packages "${BENCH_PACKAGES[@]}"
    build
    ;;
  sanitize)
    install_packages
    DRAPE_FUZZ_CI_SECONDS=${DRAPE_FUZZ_SECONDS:-10} fuzz/ci.sh
    ;;
  format)
    check_format
    ;;
  tidy)
    install_packages
    build
    tools/tidy.py --build "$BUILD_DIR" -j "$JOBS"
    ;;
  *)
    echo "usage: ./setup.sh [main|test|build|bench|sanitize|format|tidy]" >&2
    exit 2
    ;;
esac
