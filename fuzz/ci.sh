#!/usr/bin/env bash
# The sanitizer run sized for CI (not in .ci/run yet: docs/testing.md gives its cost
# against CI's 20-minute goal). With clang-14, ASan + UBSan, in
# $SAN_BUILD_DIR (default build-san), it builds only readers of outside input — the
# libraries behind the fuzz targets below — and their unit tests, then:
#   1. those unit tests under the sanitizers;
#   2. every fuzz target over its committed corpus (fuzz/corpus/T, fuzz/seeds/T and the
#      repository's own files): each input that ever found new coverage, or crashed,
#      is replayed;
#   3. every fuzz target for DRAPE_FUZZ_CI_SECONDS (default 10) of new inputs.
# Exits non-zero on any failure, sanitizer report or crash. The whole suite under
# sanitizers and longer fuzz runs: ./setup.sh sanitize (not in CI: too slow).
set -euo pipefail
cd "$(dirname "$0")/.."
. fuzz/sanitize_env.sh
# Not fuzz_recipe (nor the recipe and feature tests): the recipe library pulls in the
# whole simulation stack (cloth, hang, fusion: CGAL, Bullet, OpenVDB), which would
# more than double this build (docs/testing.md); ./setup.sh sanitize covers them.
FUZZ_TARGETS=(anchors mesh feature sweep release plan)
UNIT_TESTS=(drape_common_test drape_garments_test drape_release_test drape_sweep_test)

t0=$(date +%s)
san_configure
cmake --build "$SAN_BUILD_DIR" -j "$SAN_JOBS" --target "${UNIT_TESTS[@]}" $(printf 'fuzz_%s ' "${FUZZ_TARGETS[@]}")
t1=$(date +%s)
# The test programs themselves (each one's whole suite; CTest's names do not say
# which program a test is in), two at a time.
san_abs=$(cd "$SAN_BUILD_DIR" && pwd)
for t in "${UNIT_TESTS[@]}"; do find "$san_abs" -name "$t" -type f -perm -u+x; done |
  xargs -P "$SAN_JOBS" -I{} sh -c 'cd "$(dirname {})" && {} --gtest_brief=1 > "{}.log" 2>&1 ||
    { echo "sanitizers: {} failed:"; tail -60 "{}.log"; exit 1; }; echo "sanitizers: $(basename {}) passed"'
t2=$(date +%s)
fuzz/run.sh --replay "${FUZZ_TARGETS[@]}"
fuzz/run.sh "${DRAPE_FUZZ_CI_SECONDS:-10}" "${FUZZ_TARGETS[@]}"
t3=$(date +%s)
echo "sanitizers: build $((t1 - t0)) s, unit tests $((t2 - t1)) s, fuzz replay + $((${DRAPE_FUZZ_CI_SECONDS:-10})) s per target $((t3 - t2)) s"
