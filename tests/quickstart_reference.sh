#!/usr/bin/env bash
# Builds the quickstart recipe (the README's main job) and checks it against the
# published reference in datasets/quickstart/: same digest and content hashes.
# Also checks the release with `drape verify` and coreutils `sha256sum -c`.
source "$(dirname "$0")/e2e_lib.sh"
rel="$WORK/quickstart"
fresh_build "$SRC/recipes/quickstart.yaml" "$rel" -j 2
ref=$(ls -d "$SRC"/datasets/quickstart/*/ | sort -V | tail -n 1)
[ -f "$ref/dataset.json" ] || fail "no published quickstart reference under datasets/quickstart/"
echo "built digest     $(digest_of "$rel")"
echo "published digest $(digest_of "$ref")"
"$DRAPE" verify "$rel" --published "$ref"
(cd "$rel" && sha256sum -c --quiet SHA256SUMS) || fail "sha256sum -c SHA256SUMS"
"$DRAPE" info "$rel"
