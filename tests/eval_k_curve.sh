#!/usr/bin/env bash
# `drape eval` on a release with 2 hangs per anchor (tests/recipes/tiny_k.yaml): report.json
# and report.md carry the K curve; its K' = 2 row is the headline, its K' = 1 row is the eval
# of the same recipe built with one hang per anchor (whose train entries are hang 0's, byte
# for byte: generator/pipeline/pipeline_test.cpp), and tools/results.py puts the curve into the results table.
source "$(dirname "$0")/e2e_lib.sh"
fresh_build "$SRC/tests/recipes/tiny_k.yaml" "$WORK/rel" -j 1
sed 's/hangs_per_anchor: 2/hangs_per_anchor: 1/; /hang_variation/d' "$SRC/tests/recipes/tiny_k.yaml" > "$WORK/k1.yaml"
fresh_build "$WORK/k1.yaml" "$WORK/rel1" -j 1
for r in rel rel1; do
  rm -rf "$WORK/report_$r"
  "$DRAPE" eval "$WORK/$r" --no-registration --no-category-fit -o "$WORK/report_$r" > "$WORK/eval_$r.log"
done
grep -q '^## K curve' "$WORK/report_rel/report.md" || fail "report.md has no K curve"
grep -q '^| 2 | 8 | 2 |' "$WORK/report_rel/report.md" || fail "report.md has no K' = 2 row"
grep -q '^## K curve' "$WORK/report_rel1/report.md" && fail "a K = 1 release's report has a K curve"
python=/usr/bin/python3
[ -x "$python" ] || python=python3
"$python" - "$WORK/report_rel/report.json" "$WORK/report_rel1/report.json" <<'PY'
import json, sys
r, one = (json.load(open(p)) for p in sys.argv[1:])
c = r["k_curve"]
assert c["hangs_per_anchor"] == 2 and [l["hangs"] for l in c["levels"]] == [1, 2], c
assert [l["database_entries"] for l in c["levels"]] == [4, 8], c["levels"]
assert "k_curve" not in one
def figures(report):
    o = report["overall"]
    return [o["pose_accuracy"]["both"], o["pose_accuracy_twin_credited"], o["category_accuracy"]]
for level, report in zip(c["levels"], [one, r]):
    f = level["categories"]["all"]
    assert [f["strict"], f["twin_credited"], f["category_accuracy"]] == figures(report), (level, figures(report))
PY
"$python" "$SRC/tools/results.py" "$WORK/report_rel" > "$WORK/table.md"
grep -q '^| K curve, 2 hangs per anchor (8 database entries)' "$WORK/table.md" || fail "results table has no K curve"
