#!/usr/bin/env bash
# The runtime over the quickstart release the fixture built: RankSVM calibration,
# one recognition query, and the evaluation report.
source "$(dirname "$0")/e2e_lib.sh"
rel="$WORK/../quickstart_reference/quickstart"
[ -f "$rel/dataset.json" ] || fail "the quickstart fixture did not build $rel"
"$DRAPE" calibrate "$rel"
test_entry=$("$DRAPE" ls "$rel" --split test | awk 'NR>1 && $1 ~ /^[0-9][0-9][0-9][0-9][0-9]-/ {print $1; exit}')
[ -n "$test_entry" ] || fail "no test entry listed"
"$DRAPE" recognize "$rel" --entry "$test_entry"
rm -rf "$WORK/report"
"$DRAPE" eval "$rel" -o "$WORK/report"
for f in report.md report.json accuracy.png; do
  [ -s "$WORK/report/$f" ] || fail "eval wrote no $f"
done
# The calibration weights live beside the release content: verify still passes.
"$DRAPE" verify "$rel"
