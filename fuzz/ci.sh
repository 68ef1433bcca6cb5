#!/usr/bin/env bash
# The sanitizer run of CI (.ci/run, after ./setup.sh test; docs/testing.md gives its
# cost). With clang-14, ASan + UBSan, in $SAN_BUILD_DIR (default build-san), it builds
# only the readers of outside input — the libraries behind the fuzz targets below —
# and their unit tests, then:
#   1. those unit tests under the sanitizers;
#   2. every fuzz target over its committed corpus (fuzz/corpus/T, fuzz/seeds/T and the
#      repository's own files): each input that ever found new coverage, or crashed,
#      is replayed;
#   3. every fuzz target for DRAPE_FUZZ_CI_SECONDS (default 10) of new inputs.
# Exits non-zero on any failure, sanitizer report or crash. The whole unit suite under
# sanitizers and longer fuzz runs: ./setup.sh sanitize (not in CI: a second build of
# the whole project).
set -euo pipefail
cd "$(dirname "$0")/.."
. fuzz/sanitize_env.sh
# fuzz_recipe brings the stages whose Options a recipe fills (cloth, hang, fusion:
# Bullet, OpenVDB), about a third of this build; the recipe and feature tests come
# with it almost for free.
FUZZ_TARGETS=(recipe anchors mesh feature sweep release plan)
UNIT_TESTS=(drape_common_test drape_garments_test drape_release_test drape_sweep_test
  drape_recipe_test drape_feature_test)

t0=$(date +%s)
san_configure
cmake --build "$SAN_BUILD_DIR" -j "$SAN_JOBS" --target "${UNIT_TESTS[@]}" $(printf 'fuzz_%s ' "${FUZZ_TARGETS[@]}")
t1=$(date +%s)
# The test programs themselves (each one's whole suite; CTest's names do not say
# which program a test is in), each cut into SAN_JOBS shards (gtest's own sharding:
# drape_garments_test alone is half the work), SAN_JOBS shards at a time.
san_abs=$(cd "$SAN_BUILD_DIR" && pwd)
for t in "${UNIT_TESTS[@]}"; do
  p=$(find "$san_abs" -name "$t" -type f -perm -u+x)
  for ((k = 0; k < SAN_JOBS; ++k)); do echo "$p $k"; done
done | xargs -P "$SAN_JOBS" -L1 sh -c 'cd "$(dirname "$0")" &&
    GTEST_TOTAL_SHARDS='"$SAN_JOBS"' GTEST_SHARD_INDEX=$1 "$0" --gtest_brief=1 > "$0.$1.log" 2>&1 ||
    { echo "sanitizers: $0 (shard $1) failed:"; tail -60 "$0.$1.log"; exit 1; }
    echo "sanitizers: $(basename "$0") shard $1 passed: $(grep -o "PASSED.*" "$0.$1.log")"'
t2=$(date +%s)
export DRAPE_FUZZ_NO_BUILD=1 DRAPE_FUZZ_JOBS=$SAN_JOBS
fuzz/run.sh --replay "${FUZZ_TARGETS[@]}"
fuzz/run.sh "${DRAPE_FUZZ_CI_SECONDS:-10}" "${FUZZ_TARGETS[@]}"
t3=$(date +%s)
echo "sanitizers: build $((t1 - t0)) s, unit tests $((t2 - t1)) s, fuzz replay + $((${DRAPE_FUZZ_CI_SECONDS:-10})) s per target $((t3 - t2)) s"
