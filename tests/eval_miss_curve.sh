#!/usr/bin/env bash
# `drape eval` on a release whose recipe has a miss curve (tests/recipes/tiny_miss.yaml):
# report.json and report.md carry the curve beside the headline (the test split), each
# level's figures are those of its own split (the ladder evaluates the same splits), and
# tools/results.py puts the protocol and the curve into the results table.
source "$(dirname "$0")/e2e_lib.sh"
fresh_build "$SRC/tests/recipes/tiny_miss.yaml" "$WORK/rel" -j 1
rm -rf "$WORK/report"
"$DRAPE" eval "$WORK/rel" --ladder --no-registration --no-category-fit -o "$WORK/report" > "$WORK/eval.log"
grep -q '^## Miss curve' "$WORK/report/report.md" || fail "report.md has no miss curve"
grep -q '^| 10 mm | 2 |' "$WORK/report/report.md" || fail "report.md has no 10 mm row"
python=/usr/bin/python3
[ -x "$python" ] || python=python3
"$python" - "$WORK/report/report.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
c = r["miss_curve"]
assert [l["miss_mm"] for l in c["levels"]] == [0, 10], c["levels"]
assert [l["split"] for l in c["levels"]] == ["test_miss_0mm", "test_miss_10mm"]
head = c["headline"]
assert head["split"] == "test" and "grasp miss σ 10 mm per axis" in head["differs"], head
assert head["categories"]["all"]["strict"] == r["overall"]["pose_accuracy"]["both"]
ladder = {row["split"]: row for row in r["ladder"]["all"]}
for l in c["levels"]:
    f = l["categories"]["all"]
    assert f["queries"] == 2, l
    assert f["strict"]["unweighted"] == ladder[l["split"]]["pose_unweighted"], (l, ladder)
    assert f["twin_credited"]["unweighted"] == ladder[l["split"]]["pose_unweighted_twin_credited"]
    assert f["category_accuracy"] == ladder[l["split"]]["category_accuracy"]
PY
"$python" "$SRC/tools/results.py" "$WORK/report" > "$WORK/table.md"
grep -q '^| miss curve, grasp 10 mm from the anchor' "$WORK/table.md" || fail "results table has no miss curve"
grep -q '^| test protocol of the pose rows above | Kinect noise, grasp miss σ 10 mm per axis' "$WORK/table.md" ||
  fail "results table does not name the protocol"
