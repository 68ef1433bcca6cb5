#!/usr/bin/env bash
# tools/results.py on real reports: the quickstart release (fixture quickstart), its eval
# report (fixture quickstart_eval) and unfolding run (fixture quickstart_unfold), and a
# small fold run made here (towel at 8 cm, the initial trajectories, one trial: about
# a CPU-minute); then the table's tests (tools/results_test.py).
source "$(dirname "$0")/e2e_lib.sh"
export RESULTS_RELEASE="$WORK/../quickstart_reference/quickstart"
export RESULTS_EVAL="$WORK/../quickstart_runtime/report"
export RESULTS_UNFOLD="$WORK/../quickstart_unfold/out"
export RESULTS_FOLD="$WORK/fold"
for d in "$RESULTS_RELEASE" "$RESULTS_EVAL" "$RESULTS_UNFOLD"; do
  [ -d "$d" ] || fail "the fixtures did not make $d"
done
rm -rf "$RESULTS_FOLD"
printf 'fold:\n  edge: 0.08\n  optimise: false\n  fan: none\n' > "$WORK/fold.yaml"
"$DRAPE" fold towel --plan "$SRC/runtime/folding/plans/towel.yaml" --config "$WORK/fold.yaml" --trials 1 \
  -o "$RESULTS_FOLD" > "$WORK/fold.log" || fail "fold: $(tail -n 5 "$WORK/fold.log")"
python=/usr/bin/python3
[ -x "$python" ] || python=python3
export SRC
"$python" -m pytest -q -p no:cacheprovider "$SRC/tools/results_test.py"
