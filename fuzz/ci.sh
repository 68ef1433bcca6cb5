#!/usr/bin/env bash
# The sanitizer run of CI (.ci/run, after ./setup.sh test; docs/testing.md gives its
# cost), also `./setup.sh sanitize`. With clang-14, ASan + UBSan, -O1, no LTO, in
# $SAN_BUILD_DIR (default build-san), it builds every unit-test program and every fuzz
# target (not the drape binary, benchmarks or Python module), then:
#   1. the unit suite (CTest label `unit`, not `slow`) under the sanitizers, ctest -j;
#   2. every fuzz target over its committed corpus (fuzz/corpus/T, fuzz/seeds/T and the
#      repository's own files): each input that ever found new coverage, or crashed,
#      is replayed;
#   3. every fuzz target for DRAPE_FUZZ_CI_SECONDS (default 10) of new inputs.
# Left out (docs/testing.md, "Sanitizers"): drape_pipeline_test (label `slow`: whole
# tiny builds, ~5 CPU-minutes in the Release build alone; their parts are each tested
# under the sanitizers in their own programs), the end-to-end scripts (they run the
# drape binary of the Release build), and, until they have been run clean under the
# sanitizers, the runtime's programs (SKIP_PROGRAMS below; ./setup.sh sanitize with
# DRAPE_SAN_ALL=1 builds and runs them too).
# Exits non-zero on any failure, sanitizer report or crash.
set -euo pipefail
cd "$(dirname "$0")/.."
. fuzz/sanitize_env.sh
FUZZ_TARGETS=(recipe anchors mesh feature sweep release plan)
SKIP_PROGRAMS=(drape_pipeline_test)
[ "${DRAPE_SAN_ALL:-0}" = 1 ] || SKIP_PROGRAMS+=(drape_pipeline_mpi_test drape_optim_test drape_registration_test
  drape_recognition_test drape_unfolding_test drape_folding_test drape_folding_fold_test drape_hardware_test)

t0=$(date +%s)
san_configure
# Every unit-test program (drape_test in cmake/DrapeTargets.cmake) but the skipped ones.
mapfile -t UNIT_TESTS < <(ninja -C "$SAN_BUILD_DIR" -t targets all | sed -n 's/^\(drape_[a-z0-9_]*_test\): phony$/\1/p' |
  grep -vxF "$(printf '%s\n' "${SKIP_PROGRAMS[@]}")" | sort -u)
cmake --build "$SAN_BUILD_DIR" -j "$SAN_JOBS" --target "${UNIT_TESTS[@]}" $(printf 'fuzz_%s ' "${FUZZ_TARGETS[@]}")
t1=$(date +%s)
echo "sanitizers: ${#UNIT_TESTS[@]} test programs built (${SKIP_PROGRAMS[*]} left out)"
ctest --test-dir "$SAN_BUILD_DIR" -L unit -LE slow -j "$SAN_JOBS" --output-on-failure --no-tests=error
t2=$(date +%s)
export DRAPE_FUZZ_NO_BUILD=1 DRAPE_FUZZ_JOBS=$SAN_JOBS
fuzz/run.sh --replay "${FUZZ_TARGETS[@]}"
fuzz/run.sh "${DRAPE_FUZZ_CI_SECONDS:-10}" "${FUZZ_TARGETS[@]}"
t3=$(date +%s)
echo "sanitizers: build $((t1 - t0)) s, unit tests $((t2 - t1)) s, fuzz replay + ${DRAPE_FUZZ_CI_SECONDS:-10} s per target $((t3 - t2)) s"
