#!/usr/bin/env bash
# `mpirun -np 3 drape build` (rank 0 coordinates, ranks 1 and 2 simulate) gives the
# same release digest and SHA256SUMS as a plain one-process build of the same recipe;
# a folder rank 0 must refuse gives status 1 from mpirun, printed once, no hang.
#
# --oversubscribe: CI machines have fewer cores than ranks (rank 0 mostly sleeps).
# As root, OpenMPI refuses to start unless told it is deliberate: we set
# OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 (the same as passing
# --allow-run-as-root to mpirun); harmless for other users.
source "$(dirname "$0")/e2e_lib.sh"
recipe="$SRC/tests/recipes/tiny.yaml"
command -v mpirun >/dev/null || fail "mpirun not found (apt-get install openmpi-bin)"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
mpi=(mpirun --oversubscribe -np 3)

ms() { echo $(($(date +%s%N) / 1000000)); }
start=$(ms)
fresh_build "$recipe" "$WORK/plain" -j 2
plain_ms=$(($(ms) - start))

rm -rf "$WORK/mpi"
start=$(ms)
"${mpi[@]}" "$DRAPE" build "$recipe" -o "$WORK/mpi"
mpi_ms=$(($(ms) - start))

dp=$(digest_of "$WORK/plain"); dm=$(digest_of "$WORK/mpi")
echo "plain -j2 $dp (${plain_ms} ms)"
echo "mpirun -np 3 $dm (${mpi_ms} ms)"
[ -n "$dp" ] && [ "$dp" = "$dm" ] || fail "MPI and plain digests differ"
cmp "$WORK/plain/SHA256SUMS" "$WORK/mpi/SHA256SUMS" || fail "MPI and plain SHA256SUMS differ"
grep -q '"mpi_ranks": *3' "$WORK/mpi/build.json" || fail "build.json does not record mpi_ranks 3"
"$DRAPE" verify "$WORK/mpi"

# Rerunning on the finished release: nothing to do, same digest, status 0 on every rank.
"${mpi[@]}" "$DRAPE" build "$recipe" -o "$WORK/mpi" --quiet
[ "$(digest_of "$WORK/mpi")" = "$dp" ] || fail "digest changed after a no-op MPI rebuild"

# Rank 0 cannot open the folder (here: it holds something that is not a release; a
# folder locked by another build takes the same path): every rank exits 1, the reason
# is printed once, and the waiting workers are released instead of hanging.
rm -rf "$WORK/refused"
mkdir -p "$WORK/refused"
echo "not a release" >"$WORK/refused/notes.txt"
set +e
timeout 120 "${mpi[@]}" "$DRAPE" build "$recipe" -o "$WORK/refused" --quiet 2>"$WORK/refused.err"
status=$?
set -e
cat "$WORK/refused.err"
[ "$status" -eq 1 ] || fail "MPI build into a foreign folder: status $status (want 1; 124 = hung)"
[ "$(grep -c '^drape build:' "$WORK/refused.err")" -eq 1 ] || fail "the refusal should be printed once (by rank 0)"
echo "ok"
