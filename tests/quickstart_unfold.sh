#!/usr/bin/env bash
# One short unfolding trial on the quickstart release (towel; 36 Kinect frames per turn,
# at most 2 regrasps), its trace and pictures, and the command's errors on bad input.
source "$(dirname "$0")/e2e_lib.sh"
rel="$WORK/../quickstart_reference/quickstart"
[ -f "$rel/dataset.json" ] || fail "the quickstart fixture did not build $rel"
"$DRAPE" calibrate "$rel" -o "$WORK/calibration" > /dev/null
w="$WORK/calibration/weights.json"
rm -rf "$WORK/out"
printf 'unfold:\n  frames: 36\n  max_regrasps: 2\n' > "$WORK/short.yaml"
"$DRAPE" unfold "$rel" --weights "$w" --category towel --trials 1 --config "$WORK/short.yaml" -o "$WORK/out"
t="$WORK/out/towel/trial_1"
for f in trace.json pickup.png step_1.png final.png; do
  [ -s "$t/$f" ] || fail "unfold wrote no $t/$f"
done
grep -q '"regrasps"' "$t/trace.json" || fail "trace has no regrasp count"
grep -q '"predicted_error_m"' "$t/trace.json" || fail "trace has no truth errors per step"
grep -q '"retries"' "$t/trace.json" || fail "trace has no count of half-step retries"
grep -q '"aimed_anchor"' "$t/trace.json" || fail "trace has no aimed anchor per step (plan prior)"
grep -q '"prior_trusted"' "$t/trace.json" || fail "trace has no trusted plan prior per step"
grep -q '"holder_regrasped"' "$t/trace.json" || fail "trace has no holder origin per step"
grep -q '"e_pinch_error_m"' "$t/trace.json" || fail "trace has no error ladder per step"
grep -q '"anchors_uv"' "$t/trace.json" || fail "trace has no test garment anchors"
grep -q '"kept_candidate"' "$t/trace.json" || fail "trace has no registration candidates per step"
grep -q '"decided"' "$t/trace.json" || fail "trace has no decided category per step"
grep -q '"lowest_point"' "$t/trace.json" || fail "trace has no lowest-point record per step"
grep -q 'successful unfolding' "$WORK/out/report.md" || fail "report has no table"

# drape fold takes the garment as the trial left it: placed flat, its key points on the
# folding table (turned upright); a trial that did not place it is a clear error.
plan="$SRC/runtime/folding/plans/towel.yaml"
if grep -q '"placed": true' "$t/trace.json"; then
  for f in placed.json garment.ply garment.anchors.json lying.ply; do
    [ -s "$t/$f" ] || fail "unfold placed the towel but wrote no $t/$f"
  done
  "$DRAPE" fold "$t" --plan "$plan" --key-points-only --trials 1 -o "$WORK/fold" > "$WORK/fold.log" ||
    fail "fold of the placed towel: $(cat "$WORK/fold.log")"
  grep -q "towel-" "$WORK/fold.log" || fail "fold did not read the placed towel: $(cat "$WORK/fold.log")"
  [ -s "$WORK/fold/keypoints_trial0.png" ] || fail "fold wrote no key point picture of the placed towel"
else
  if out=$("$DRAPE" fold "$t" --plan "$plan" -o "$WORK/fold" 2>&1); then fail "fold of an unplaced trial succeeded"; fi
  echo "$out" | grep -q "did not place its garment flat" || fail "fold of an unplaced trial: $out"
fi

# Bad input: a clear error, exit status 1.
expect_error() {
  local pattern=$1
  shift
  if out=$("$DRAPE" unfold "$rel" "$@" 2>&1); then fail "unfold $* succeeded"; fi
  echo "$out" | grep -q "$pattern" || fail "unfold $*: expected '$pattern', got: $out"
}
expect_error "unknown category" --weights "$w" --category socks
expect_error "no desired anchor pair" --weights "$w" --category tshirt
expect_error "database has no 'pants'" --weights "$w" --category pants
expect_error "weights" --weights "$WORK/none/weights.json" --category towel
expect_error "\-\-jobs: '0' is not an integer >= 1" --weights "$w" --category towel --jobs 0
expect_error "\-\-ablations: .*--weights none" --weights none --category towel --ablations
# The loop's settings from the options file: a bad value names the file, line, column and key.
bad_setting() {
  printf 'unfold:\n  %s: %s\n' "$1" "$2" > "$WORK/bad.yaml"
  expect_error "$WORK/bad.yaml:2:[0-9]*: unfold.$1: $3" --weights "$w" --category towel --config "$WORK/bad.yaml"
}
bad_setting plan_prior_top_k 6 "must be in 0..5"
bad_setting candidates 0 "must be in 1..10"
bad_setting refit_absent_penalty -0.5 "must be >= 0"
bad_setting lowest_near_radius 0.5 "must be in \[0, 0.5) m"
bad_setting frame 36 "unknown key (did you mean 'frames'?)"
expect_error "\-\-only: '3' is not a trial number in 1..2" --weights "$w" --category towel --trials 2 --only 1,3
expect_error "\-\-only: 'x' is not an integer >= 1" --weights "$w" --category towel --only x
expect_error "\-\-only: '0' is not an integer >= 1" --weights "$w" --category towel --only 2,0
