#!/usr/bin/env bash
# Builds the libFuzzer targets (clang-14, ASan + UBSan) and runs each for SECONDS
# (default 10) from a seed corpus made of the repository's own files.
#   fuzz/run.sh [SECONDS] [TARGET...]      targets: recipe anchors mesh feature sweep release
# Prints executions, coverage and crashes per target; exits 1 if any target crashed
# (the reproducer is in $SAN_BUILD_DIR/fuzz-out/TARGET/crash-*; make it a regression
# test in fuzz/regressions/TARGET/ — tests/fuzz_regressions.sh replays them).
set -euo pipefail
cd "$(dirname "$0")/.."
. fuzz/sanitize_env.sh
SECONDS_PER_TARGET=${1:-10}
shift || true
TARGETS=("$@")
[ ${#TARGETS[@]} -gt 0 ] || TARGETS=(recipe anchors mesh feature sweep release)

san_configure
cmake --build "$SAN_BUILD_DIR" -j "$SAN_JOBS" --target $(printf 'fuzz_%s ' "${TARGETS[@]}")
OUT=$SAN_BUILD_DIR/fuzz-out
fuzz/seed_corpora.sh "$OUT/seeds"

status=0
for t in "${TARGETS[@]}"; do
  mkdir -p "$OUT/$t/corpus"
  log=$OUT/$t/log.txt
  # The seeds are read-only inputs; new finds go to corpus/ (kept between runs).
  set +e
  "$SAN_BUILD_DIR/fuzz/fuzz_$t" "$OUT/$t/corpus" "$OUT/seeds/$t" -max_total_time="$SECONDS_PER_TARGET" \
    -timeout=20 -rss_limit_mb=3072 -max_len=1048576 -artifact_prefix="$OUT/$t/" -print_final_stats=1 \
    >"$log" 2>&1
  rc=$?
  set -e
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo "?")
  crashes=$(ls "$OUT/$t"/crash-* "$OUT/$t"/leak-* "$OUT/$t"/timeout-* "$OUT/$t"/oom-* 2>/dev/null | wc -l)
  echo "fuzz_$t: ${SECONDS_PER_TARGET}s, $execs executions, coverage $cov edges, $crashes crash/leak/timeout/oom inputs (rc $rc)"
  if [ "$rc" -ne 0 ] || [ "$crashes" -ne 0 ]; then
    status=1
    grep -m1 -A25 "ERROR\|runtime error\|==ERROR" "$log" || tail -30 "$log"
  fi
done
exit $status
