#!/usr/bin/env bash
# drape fold's errors on bad input: a clear message, exit status 1, before any simulation;
# numbers in them as a person writes them (7, not 7.000000).
source "$(dirname "$0")/e2e_lib.sh"
plan="$SRC/runtime/folding/plans/towel.yaml"
# The whole message line must read "drape fold: MESSAGE" (so "got 7" does not pass for
# "got 7.000000").
expect_error() {
  local message=$1
  shift
  local out status=0
  out=$("$DRAPE" fold "$@" -o "$WORK/out" 2>&1) || status=$?
  [ "$status" -eq 1 ] || fail "fold $*: status $status (want 1), output: $out"
  echo "$out" | grep -qxF -- "drape fold: $message" || fail "fold $*: expected 'drape fold: $message', got: $out"
}
expect_error "--plan is required (see drape fold --help)" towel
# Material constants given instead of fitted come from the options file, checked at their key.
printf 'fold:\n  friction: 7\n' > "$WORK/f7.yaml"
expect_error "$WORK/f7.yaml:2:13: fold.friction: must be in [0, 5) (-1: fitted), got 7" towel --plan "$plan" --config "$WORK/f7.yaml"
printf 'fold:\n  friction: -0.25\n' > "$WORK/f025.yaml"
expect_error "$WORK/f025.yaml:2:13: fold.friction: must be in [0, 5) (-1: fitted), got -0.25" towel --plan "$plan" --config "$WORK/f025.yaml"
printf 'fold:\n  fan: 9\n' > "$WORK/fan9.yaml"
expect_error "fold.fan: no step 9 (plan towel has 2)" towel --plan "$plan" --config "$WORK/fan9.yaml"
expect_error "--material: unknown material 'felt'" towel --plan "$plan" --material felt
# An unfold trial folder whose garment was never placed flat: nothing to fold, and why.
mkdir -p "$WORK/trial_1"
echo '{"placed": false, "place_failure": "a gripper holds no cloth node in the cloth world"}' > "$WORK/trial_1/trace.json"
expect_error "$WORK/trial_1/trace.json: the trial did not place its garment flat on the table (placed: false: a gripper holds no cloth node in the cloth world)" "$WORK/trial_1" --plan "$plan"
