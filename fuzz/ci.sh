#!/usr/bin/env bash
# The sanitizer and fuzz run: the second half of `./setup.sh test` (what CI runs), or
# alone as `./setup.sh sanitize`. With clang-14, ASan + UBSan, -O1, in
# $SAN_BUILD_DIR (default build-san), it builds every unit-test program and every fuzz
# target (not the drape binary, benchmarks or Python module), then:
#   1. every unit-test program under the sanitizers, run directly (not one process
#      per test as CTest does: each program's fixtures are built once), the long ones
#      cut into gtest shards, SAN_JOBS at a time; the few heavy simulations trimmed
#      (SAN_FILTER below);
#   2. every fuzz target over its committed corpus (fuzz/corpus/T, fuzz/seeds/T and the
#      repository's own files): each input that ever found new coverage, or crashed,
#      is replayed;
#   3. every fuzz target for DRAPE_FUZZ_CI_SECONDS (default 10) of new inputs.
# Not here: the end-to-end scripts (they run the Release build's drape binary).
# Exits non-zero on any failure, sanitizer report or crash.
set -euo pipefail
cd "$(dirname "$0")/.."
. fuzz/sanitize_env.sh
FUZZ_TARGETS=(recipe anchors mesh feature sweep release plan)

# Trimmed under the sanitizers (10-20x slower than the Release build): gtest filters of
# the programs whose whole suite would cost minutes of CPU. Each leaves out only cases
# whose code paths the program's other cases (run here) also take; the Release suite
# (./setup.sh test) runs them all. DRAPE_SAN_FULL=1 runs everything.
declare -A SAN_FILTER=(
  # Two more hangs of the towel material (the 2-layer "pants" grid from two anchors:
  # ~350 CPU-s; the same job four times, also in two threads: ~250 CPU-s). Kept: the
  # material fit, a 2-layer towel hung from a corner to rest (collisions, settling,
  # strain checks), blow-up, never-settling and over-stretched failures, bad input.
  [drape_hang_test]="-Hang.PantsFromWaistAndLegDiffer:Hang.SameJobGivesIdenticalBytesAlsoInParallel"
  # Whole tiny builds (label `slow`, ~4 CPU-minutes in the Release build). Kept: the
  # preview renderer; every stage they chain has its own program here.
  [drape_pipeline_test]="Build.PreviewIsAThreePanelPng"
)
[ "${DRAPE_SAN_FULL:-0}" != 1 ] || SAN_FILTER=()

t0=$(date +%s)
san_configure
# Every unit-test program (drape_test in cmake/DrapeTargets.cmake).
mapfile -t UNIT_TESTS < <(ninja -C "$SAN_BUILD_DIR" -t targets all | sed -n 's/^\(drape_[a-z0-9_]*_test\): phony$/\1/p' | sort -u)
cmake --build "$SAN_BUILD_DIR" -j "$SAN_JOBS" --target "${UNIT_TESTS[@]}" $(printf 'fuzz_%s ' "${FUZZ_TARGETS[@]}")
t1=$(date +%s)

# One line per gtest shard: program, shard index, shard count, filter. The programs
# that take minutes under the sanitizers get SAN_JOBS shards (and go first), the others
# one; xargs keeps SAN_JOBS shards running.
san_abs=$(cd "$SAN_BUILD_DIR" && pwd)
# (CPU-seconds under the sanitizers, 2026-12-02: fusion ~330, hang trimmed ~270, folding
# fold 144, cloth world 116, garments 106, registration 89, cloth collision 76.)
LONG=" drape_hang_test drape_cloth_world_test drape_cloth_collision_test drape_garments_test drape_fusion_test "
LONG+=" drape_folding_fold_test drape_registration_test "
for t in "${UNIT_TESTS[@]}"; do
  [[ "$LONG" == *" $t "* ]] && echo 0 "$t" || echo 1 "$t"
done | sort -s -k1,1 | while read -r _ t; do
  p=$(find "$san_abs" -name "$t" -type f -perm -u+x | head -1)
  n=1
  [[ "$LONG" != *" $t "* ]] || n=$SAN_JOBS
  for ((k = 0; k < n; ++k)); do echo "$p" "$k" "$n" "${SAN_FILTER[$t]:-*}"; done
done | xargs -P "$SAN_JOBS" -L1 sh -c 'cd "$(dirname "$0")" && log="$0.$1.log" &&
    if ! GTEST_TOTAL_SHARDS=$2 GTEST_SHARD_INDEX=$1 /usr/bin/time -f "%e s wall, %U+%S CPU-s" -o "$log.time" \
        "$0" --gtest_brief=1 --gtest_filter="$3" > "$log" 2>&1; then
      echo "sanitizers: $(basename "$0") shard $1/$2 failed:"; tail -80 "$log"; exit 255; fi
    echo "sanitizers: $(basename "$0") shard $1/$2 passed $(sed -n "s/^\[  PASSED  \] //p" "$log") ($(tail -1 "$log.time"))"'
t2=$(date +%s)
export DRAPE_FUZZ_NO_BUILD=1 DRAPE_FUZZ_JOBS=$SAN_JOBS
fuzz/run.sh --replay "${FUZZ_TARGETS[@]}"
fuzz/run.sh "${DRAPE_FUZZ_CI_SECONDS:-10}" "${FUZZ_TARGETS[@]}"
t3=$(date +%s)
echo "sanitizers: build $((t1 - t0)) s, unit tests $((t2 - t1)) s, fuzz replay + ${DRAPE_FUZZ_CI_SECONDS:-10} s per target $((t3 - t2)) s"
