#!/usr/bin/env bash
# Seed corpora from the repository's own files: fuzz/seed_corpora.sh OUT
# (OUT/<target>/ for each fuzz target; committed seeds in fuzz/seeds/<target>/ too).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=$1
rm -rf "$OUT"
for t in recipe anchors mesh feature sweep release plan; do
  mkdir -p "$OUT/$t"
  [ -d "fuzz/seeds/$t" ] && cp fuzz/seeds/"$t"/* "$OUT/$t/" 2>/dev/null || true
done
cp recipes/*.yaml tests/recipes/*.yaml generator/recipe/testdata/*.yaml "$OUT/recipe/"
# Meshes drape wrote (small ones: the fuzzer mutates them many times per second).
find garments/testdata -name '*.ply' -size -100k -exec cp {} "$OUT/mesh/" \;
git ls-files '*.anchors.json' | head -20 | xargs -r cp -t "$OUT/anchors/"
cp datasets/quickstart/*/dataset.json "$OUT/release/" 2>/dev/null || true
cp runtime/folding/plans/*.yaml "$OUT/plan/"
