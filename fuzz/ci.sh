#!/usr/bin/env bash
# The sanitizer and fuzz run: the second half of `./setup.sh test` (what CI runs), or
# alone as `./setup.sh sanitize`. With clang-14, ASan + UBSan, -O2 (fuzz/sanitize_env.sh), in
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

# Trimmed under the sanitizers (several times slower than the Release build): gtest filters of
# the programs whose whole suite would cost minutes of CPU. Each leaves out only cases
# whose code paths the program's other cases (run here) also take: a second or third
# simulation of a kind already run, or a fast path compared with its slow reference
# where the fast path itself runs in other cases (and its kernels are compared with
# scalar ones). The Release suite (./setup.sh test) runs them all; DRAPE_SAN_FULL=1
# runs everything here too. CPU-seconds under the sanitizers (2026-12-03, -O1 with
# comparison tracing: about a third of that now) in brackets.
declare -A SAN_FILTER=(
  # Kept: the material fit, a 2-layer towel hung from a corner to rest (collisions,
  # settling, strain checks), blow-up, never-settling and over-stretched failures, bad
  # input. Out: the 2-layer "pants" grid from two anchors [350]; the same job four
  # times, also in two threads [250]; a second, softer material fit [45] and one at
  # 8 cm; the cantilever strips and the lab's drape, incline and crease runs (the fine
  # strip alone [256], 2026-12-06; the hinge force they use runs whole in
  # drape_cloth_bending_test).
  [drape_hang_test]="-Hang.PantsFromWaistAndLegDiffer:Hang.SameJobGivesIdenticalBytesAlsoInParallel:Fit.ReproducesMeasuredStretch:Fit.ReproducesTheStretchOnEdgesWiderThanHalfTheStrip:Cantilever.*:Lab.AStiffDiscBarelyDrapesAndALimpOneDoes:Lab.ASheetOnASheetStaysLevelAndSlidesOffASteepIncline:Lab.AFoldCreasesOnlyPastTheYield"
  # Whole tiny builds (label `slow`, ~4 CPU-minutes in the Release build). Kept: the
  # preview renderer; every stage they chain has its own program here.
  [drape_pipeline_test]="Build.PreviewIsAThreePanelPng"
  # Out: the broad-phase and collision shortcuts compared byte for byte over a whole
  # hang [111] (the crumpling comparison stays).
  [drape_cloth_collision_test]="-CollisionApply.ShortcutsChangeNoByteWhenHanging"
  # Out: four hand-over falls onto itself [94]; the second one-grip hang [41] (the
  # centre grip, the two-gripper hang and the table cases stay).
  [drape_cloth_world_test]="-ClothWorld.HandOverFallOntoItselfStaysBounded:ClothWorld.HeldAtTheMiddleOfAStitchedEdgeItStaysWithinTheStrainBound"
  # Out: the optimiser's nine fold simulations [73] and the replay test's optimised run
  # and two replays (one fold simulation and the optimiser's own tests in
  # drape_folding_test stay).
  [drape_folding_fold_test]="-Fold.OptimisationNeverEndsWorse:Replay.TheRunsOwnTrajectoriesOnItsOwnGarmentReproduceItExactly"
  # Out: the fast path against the reference fusion on whole sweeps [66] (the fast path
  # on sweeps, and each kernel against its scalar one, stay).
  [drape_fusion_test]="-Fusion.FastPathMatchesReferenceOnKinectSweeps"
  # Out: garment depth against a brute-force ray cast [62] (analytic depths stay).
  [drape_sweep_test]="-Sweep.GarmentDepthMatchesBruteForceAndBackProjectsOntoSurface"
  # Out: a garment fused and featured at every rotation [45] (rotated features stay).
  [drape_feature_test]="-Feature.FusedGarmentRotatedMatchesWithinAFewBits"
  # Out: pants held by both leg ends placed flat [320] (6.6 s in the Release build); the
  # same placing path (back, lift clear, spread, carry, lay, the on-table check) runs in
  # the towel placed by two corners.
  [drape_hardware_test]="-SimHardware.PantsHeldByBothLegEndsAreLiftedClearOfTheTableAndPlaced"
)
[ "${DRAPE_SAN_FULL:-0}" != 1 ] || SAN_FILTER=()

t0=$(date +%s)
san_configure
# Every unit-test program (drape_test in cmake/DrapeTargets.cmake).
mapfile -t UNIT_TESTS < <(ninja -C "$SAN_BUILD_DIR" -t targets all | sed -n 's/^\(drape_[a-z0-9_]*_test\): phony$/\1/p' | sort -u)
cmake --build "$SAN_BUILD_DIR" -j "$SAN_JOBS" --target "${UNIT_TESTS[@]}" $(printf 'fuzz_%s ' "${FUZZ_TARGETS[@]}")
t1=$(date +%s)

# One line per gtest shard: program, shard index, shard count, filter; the longest
# shards first, so that the SAN_JOBS workers (xargs) end together. SAN_CPU: CPU-seconds
# of each program's filtered suite under the sanitizers (2026-12-07, -O2 without
# comparison tracing, a 2-core AMD EPYC without AVX-512, so fusion's kernels ran as AVX2;
# others ~5 or less), for that order only. Programs of 90 CPU-s or more are cut into
# SAN_JOBS shards; not the hang test, whose every case first needs the same material fit.
san_abs=$(cd "$SAN_BUILD_DIR" && pwd)
declare -A SAN_CPU=(
  [drape_hang_test]=162 [drape_fusion_test]=110 [drape_cloth_world_test]=101 [drape_hardware_test]=76
  [drape_garments_test]=75 [drape_cloth_collision_test]=54 [drape_registration_test]=41 [drape_folding_fold_test]=26
  [drape_recognition_test]=25 [drape_sweep_test]=22 [drape_unfolding_test]=19 [drape_cloth_broad_phase_test]=5
)
[ "${DRAPE_SAN_FULL:-0}" != 1 ] || SAN_CPU[drape_hang_test]=600
for t in "${UNIT_TESTS[@]}"; do
  c=${SAN_CPU[$t]:-10}
  n=1
  if [ "$c" -ge 90 ] && { [ "$t" != drape_hang_test ] || [ -z "${SAN_FILTER[$t]:-}" ]; }; then n=$SAN_JOBS; fi
  p=$(find "$san_abs" -name "$t" -type f -perm -u+x | head -1)
  for ((k = 0; k < n; ++k)); do echo "$((c / n))" "$p" "$k" "$n" "${SAN_FILTER[$t]:-*}"; done
done | sort -s -k1,1nr | cut -d' ' -f2- | xargs -P "$SAN_JOBS" -L1 sh -c 'cd "$(dirname "$0")" && log="$0.$1.log" &&
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
