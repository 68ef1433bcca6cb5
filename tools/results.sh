#!/usr/bin/env bash
# The whole chain on the paper recipe, then the README's results table from its reports:
#
#   tools/results.sh [OUT]          (default OUT: results-out)
#
#   1. drape build RECIPE -o OUT/release        the release (build.json: wall and CPU time)
#   2. drape calibrate OUT/release              weights and height gates
#   3. drape eval OUT/release -o OUT/eval       pose, category, registration, query time
#   4. drape unfold OUT/release -o OUT/unfold   every test category, TRIALS trials, seed SEED
#   5. drape fold G --plan ... -o OUT/fold/G    for each garment in FOLD (10 perturbed trials)
#   6. tools/results.py OUT/release OUT/eval OUT/unfold OUT/fold/* --readme README
#
# A step whose output is already there is skipped, so an interrupted chain resumes (drape
# build resumes its own release); remove OUT to run everything again. Each step's log is
# OUT/logs/STEP.log. On 2 cores the paper recipe costs about an hour of CPU to build and
# a few more for unfolding and folding: run it as `nice -n 5 tools/results.sh`.
#
# Environment: DRAPE (default build/bin/drape), RECIPE (recipes/paper.yaml), JOBS (nproc),
# TRIALS (10), SEED (1), FOLD (towel pants shorts long_sleeve_shirt), README (README.md;
# empty: print the table instead).
set -euo pipefail
# Paths given relative to the caller's folder stay so; the defaults are the repository's.
OUT=$(realpath -m "${1:-results-out}")
[ -z "${DRAPE:-}" ] || DRAPE=$(realpath -m "$DRAPE")
[ -z "${RECIPE:-}" ] || RECIPE=$(realpath -m "$RECIPE")
[ -z "${README:-}" ] || README=$(realpath -m "$README")
cd "$(dirname "$0")/.."

DRAPE=${DRAPE:-build/bin/drape}
RECIPE=${RECIPE:-recipes/paper.yaml}
JOBS=${JOBS:-$(nproc)}
TRIALS=${TRIALS:-10}
SEED=${SEED:-1}
FOLD=${FOLD:-towel pants shorts long_sleeve_shirt}
README=${README-README.md}

[ -x "$DRAPE" ] || { echo "results.sh: no drape binary at $DRAPE (run ./setup.sh build)" >&2; exit 1; }
mkdir -p "$OUT/logs" "$OUT/fold"

# step NAME DONE_FILE COMMAND...: runs COMMAND (log in OUT/logs/NAME.log) unless DONE_FILE exists.
step() {
  local name=$1 done_file=$2
  shift 2
  if [ -e "$done_file" ]; then
    echo "results.sh: $name: skipped ($done_file exists)"
    return
  fi
  echo "results.sh: $name: $*"
  local t0=$SECONDS
  if ! "$@" > "$OUT/logs/$name.log" 2>&1; then
    echo "results.sh: $name failed; the end of $OUT/logs/$name.log:" >&2
    tail -n 20 "$OUT/logs/$name.log" >&2
    exit 1
  fi
  echo "results.sh: $name: done in $((SECONDS - t0)) s"
}

# Mesh edge and optimisation budget per garment (the options file's fold section): the
# settings docs/folding.md measured.
fold_config() {
  case $1 in
    long_sleeve_shirt) printf 'fold:\n  edge: 0.03\n  max_sims: 22\n  fan: none\n' ;;
    *) printf 'fold:\n  edge: 0.03\n  fan: none\n' ;;
  esac
}

step build "$OUT/release/SHA256SUMS" "$DRAPE" build "$RECIPE" -o "$OUT/release" -j "$JOBS"
step calibrate "$OUT/release/calibration/weights.json" "$DRAPE" calibrate "$OUT/release"
step eval "$OUT/eval/report.json" "$DRAPE" eval "$OUT/release" -o "$OUT/eval"
step unfold "$OUT/unfold/report.json" "$DRAPE" unfold "$OUT/release" --trials "$TRIALS" --seed "$SEED" \
  --jobs "$JOBS" -o "$OUT/unfold"
# One garment's fold run; OUT/fold/G.done marks it finished (trajectories.json is written
# before the trials too).
fold_one() {
  local g=$1
  fold_config "$g" > "$OUT/fold/$g.yaml"
  "$DRAPE" fold "$g" --plan "runtime/folding/plans/$g.yaml" --config "$OUT/fold/$g.yaml" \
    --trials "$TRIALS" --seed "$SEED" -o "$OUT/fold/$g" && touch "$OUT/fold/$g.done"
}
for g in $FOLD; do
  step "fold-$g" "$OUT/fold/$g.done" fold_one "$g"
done

folds=()
for g in $FOLD; do folds+=("$OUT/fold/$g"); done
if [ -n "$README" ]; then
  python3 tools/results.py "$OUT/release" "$OUT/eval" "$OUT/unfold" "${folds[@]}" --readme "$README"
else
  python3 tools/results.py "$OUT/release" "$OUT/eval" "$OUT/unfold" "${folds[@]}"
fi
