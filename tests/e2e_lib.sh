# Shared helpers for the end-to-end tests (sourced). DRAPE is the drape binary,
# WORK a scratch folder for this test, SRC the repository root.
set -euo pipefail
: "${DRAPE:?}" "${WORK:?}" "${SRC:?}"
mkdir -p "$WORK"

# The release digest recorded in RELEASE/dataset.json.
digest_of() {
  sed -n 's/^ *"digest": *"\([0-9a-f]\{64\}\)".*/\1/p' "$1/dataset.json" | head -n 1
}

fail() {
  echo "FAIL: $*" >&2
  exit 1
}

# Builds RECIPE into DIR from scratch with extra build flags.
fresh_build() {
  local recipe=$1 dir=$2
  shift 2
  rm -rf "$dir"
  "$DRAPE" build "$recipe" -o "$dir" --quiet "$@"
}
