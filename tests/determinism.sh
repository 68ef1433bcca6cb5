#!/usr/bin/env bash
# The same recipe gives the same release digest for -j1 and -j2, after a build killed
# with SIGKILL and resumed, and when built as shards and merged.
source "$(dirname "$0")/e2e_lib.sh"
recipe="$SRC/tests/recipes/tiny.yaml"

fresh_build "$recipe" "$WORK/j1" -j 1
fresh_build "$recipe" "$WORK/j2" -j 2
d1=$(digest_of "$WORK/j1"); d2=$(digest_of "$WORK/j2")
echo "-j1 $d1"; echo "-j2 $d2"
[ -n "$d1" ] && [ "$d1" = "$d2" ] || fail "-j1 and -j2 digests differ"
cmp "$WORK/j1/SHA256SUMS" "$WORK/j2/SHA256SUMS" || fail "-j1 and -j2 SHA256SUMS differ"

# Kill a build mid-way (after its first entry lands), then resume it.
rm -rf "$WORK/killed"
"$DRAPE" build "$recipe" -o "$WORK/killed" -j 2 --quiet &
pid=$!
for _ in $(seq 1 600); do
  if [ -n "$(ls -A "$WORK/killed/entries" 2>/dev/null)" ]; then break; fi
  sleep 0.1
done
kill -9 "$pid" 2>/dev/null || true
wait "$pid" 2>/dev/null || true
[ ! -f "$WORK/killed/SHA256SUMS" ] || echo "note: the build finished before it was killed"
"$DRAPE" build "$recipe" -o "$WORK/killed" -j 2 --resume --quiet
dk=$(digest_of "$WORK/killed"); echo "killed+resumed $dk"
[ "$dk" = "$d1" ] || fail "resumed digest differs"

# Shards, merged.
for k in 1 2 3; do fresh_build "$recipe" "$WORK/shard$k" -j 1 --shard "$k/3"; done
rm -rf "$WORK/merged"
"$DRAPE" merge "$WORK/shard1" "$WORK/shard2" "$WORK/shard3" -o "$WORK/merged"
dm=$(digest_of "$WORK/merged"); echo "shards merged $dm"
[ "$dm" = "$d1" ] || fail "merged digest differs"
"$DRAPE" verify "$WORK/merged"
