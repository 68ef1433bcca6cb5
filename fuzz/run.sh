#!/usr/bin/env bash
# Builds the libFuzzer targets (clang-14, ASan + UBSan) and runs them on the corpora:
#   fuzz/run.sh [SECONDS] [TARGET...]   fuzz each target for SECONDS (default 10)
#   fuzz/run.sh --replay [TARGET...]    run each target once over its corpus, no new inputs
# Targets: recipe anchors mesh feature sweep release plan (default: all). The corpus of
# target T: fuzz/corpus/T (committed: minimised finds and crash reproducers),
# fuzz/seeds/T and the repository's own files (fuzz/seed_corpora.sh). New finds go to
# $SAN_BUILD_DIR/fuzz-out/T/corpus (kept between runs; `-merge=1` them into
# fuzz/corpus/T to keep them). Prints executions, coverage and crashes per target;
# exits 1 if any target crashed (the reproducer is $SAN_BUILD_DIR/fuzz-out/T/crash-*:
# fix the reader, add the file to fuzz/corpus/T and a unit test beside the reader).
# Targets run DRAPE_FUZZ_JOBS at a time (default 1: a long run gets one core each);
# DRAPE_FUZZ_NO_BUILD=1 skips the configure + build (fuzz/ci.sh has just built them).
set -euo pipefail
cd "$(dirname "$0")/.."
. fuzz/sanitize_env.sh
MODE=fuzz
SECONDS_PER_TARGET=10
if [ "${1:-}" = --replay ]; then
  MODE=replay
  shift
elif [[ "${1:-}" =~ ^[0-9]+$ ]]; then
  SECONDS_PER_TARGET=$1
  shift
fi
TARGETS=("$@")
[ ${#TARGETS[@]} -gt 0 ] || TARGETS=(recipe anchors mesh feature sweep release plan)

if [ "${DRAPE_FUZZ_NO_BUILD:-0}" != 1 ]; then
  san_configure
  cmake --build "$SAN_BUILD_DIR" -j "$SAN_JOBS" --target $(printf 'fuzz_%s ' "${TARGETS[@]}")
fi
OUT=$SAN_BUILD_DIR/fuzz-out
fuzz/seed_corpora.sh "$OUT/seeds"
# The targets write their inputs to files (fuzz_util.h: Scratch): on tmpfs if there is one.
if [ -z "${TMPDIR:-}" ] && [ -d /dev/shm ] && [ -w /dev/shm ]; then
  export TMPDIR=/dev/shm
fi

# One target: its log in $OUT/T/$MODE.log, its one-line summary (and the first report
# of a finding) in $OUT/T/$MODE.summary; $OUT/T/$MODE.failed if it found anything.
run_target() {
  local t=$1 log=$OUT/$1/$MODE.log sum=$OUT/$1/$MODE.summary args rc execs cov crashes
  mkdir -p "$OUT/$t/corpus" fuzz/corpus/"$t"
  rm -f "$OUT/$t"/crash-* "$OUT/$t"/leak-* "$OUT/$t"/timeout-* "$OUT/$t"/oom-* "$OUT/$t/$MODE.failed"
  # The first folder receives new finds; the others are read only.
  if [ "$MODE" = replay ]; then
    rm -rf "$OUT/$t/replay-new" && mkdir -p "$OUT/$t/replay-new"
    args=("$OUT/$t/replay-new" fuzz/corpus/"$t" "$OUT/seeds/$t" -runs=0)
  else
    args=("$OUT/$t/corpus" fuzz/corpus/"$t" "$OUT/seeds/$t" -max_total_time="$SECONDS_PER_TARGET")
  fi
  set +e
  "$SAN_BUILD_DIR/fuzz/fuzz_$t" "${args[@]}" -timeout=20 -rss_limit_mb=3072 -max_len=1048576 \
    -artifact_prefix="$OUT/$t/" -print_final_stats=1 >"$log" 2>&1
  rc=$?
  set -e
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo "?")
  crashes=$(find "$OUT/$t" -maxdepth 1 -name 'crash-*' -o -maxdepth 1 -name 'leak-*' -o -maxdepth 1 -name 'timeout-*' \
    -o -maxdepth 1 -name 'oom-*' | wc -l)
  if [ "$MODE" = replay ]; then
    echo "fuzz_$t: replayed $execs inputs, coverage $cov edges, $crashes crash/leak/timeout/oom (rc $rc)" >"$sum"
  else
    echo "fuzz_$t: ${SECONDS_PER_TARGET}s, $execs executions, coverage $cov edges, $crashes crash/leak/timeout/oom inputs (rc $rc)" >"$sum"
  fi
  if [ "$rc" -ne 0 ] || [ "$crashes" -ne 0 ]; then
    { grep -m1 -A25 "ERROR\|runtime error\|==ERROR" "$log" || tail -30 "$log"; } >>"$sum"
    touch "$OUT/$t/$MODE.failed"
  fi
}

for t in "${TARGETS[@]}"; do
  while [ "$(jobs -pr | wc -l)" -ge "${DRAPE_FUZZ_JOBS:-1}" ]; do wait -n || true; done
  run_target "$t" &
done
wait
status=0
for t in "${TARGETS[@]}"; do
  cat "$OUT/$t/$MODE.summary" 2>/dev/null || { echo "fuzz_$t: did not finish"; status=1; }
  [ ! -e "$OUT/$t/$MODE.failed" ] || status=1
done
exit $status
