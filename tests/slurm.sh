#!/usr/bin/env bash
# Slurm for real: starts a one-node Slurm (munged, slurmctld, slurmd from Debian's
# slurm-wlm, with a slurm.conf written here), then runs the two recipes of
# docs/cluster.md on tests/recipes/tiny.yaml:
#   1. the job array `--shard K/N` + the dependent merge job (sbatch --array,
#      --dependency=afterok), then `drape verify`;
#   2. the `srun --mpi=pmix` direct launch with DRAPE_MPI=1 (3 tasks);
# and compares both digests and SHA256SUMS with a one-process build.
# Runs wherever it can: as root (slurmd runs jobs as their submitting user) with
# slurm-wlm and munge installed (./setup.sh installs them); the daemons listen on free
# ports of their own and are stopped when it ends. About 1-2 minutes on 2 cores.
# DRAPE_SLURM_TEST=0 skips it. Exits 77 (ctest: skipped) with the reason when it cannot
# run here.
source "$(dirname "$0")/e2e_lib.sh"
skip() {
  echo "SKIP: $*"
  exit 77
}
[ "${DRAPE_SLURM_TEST:-1}" != 0 ] || skip "DRAPE_SLURM_TEST=0"
[ "$(id -u)" -eq 0 ] || skip "needs root to run slurmd"
for c in munged slurmctld slurmd sbatch srun squeue scontrol sinfo python3; do
  command -v "$c" >/dev/null || skip "$c not found (apt-get install slurm-wlm munge)"
done
recipe="$SRC/tests/recipes/tiny.yaml"
S=$WORK/slurm
rm -rf "$S"
mkdir -p "$S"/{state,spool,munge,jobs}
host=$(hostname -s)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# Two free TCP ports, so that runs in parallel (other checkouts on one machine) and a
# Slurm already running here are left alone.
read -r ctld_port slurmd_port < <(python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("", 0))
print(*[x.getsockname()[1] for x in s])')

pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap cleanup EXIT

# munge: a fresh key and socket of our own (no system daemon needed).
dd if=/dev/urandom of="$S/munge/munge.key" bs=1024 count=1 status=none
chmod 0400 "$S/munge/munge.key"
munged --foreground --force --key-file="$S/munge/munge.key" --socket="$S/munge/munge.socket" \
  --pid-file="$S/munge/munged.pid" --log-file="$S/munge/munged.log" --seed-file="$S/munge/seed" \
  &>"$S/munge/munged.out" &
pids+=($!)

cat >"$S/slurm.conf" <<CONF
ClusterName=drapetest
SlurmctldHost=$host
AuthType=auth/munge
AuthInfo=socket=$S/munge/munge.socket
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
StateSaveLocation=$S/state
SlurmdSpoolDir=$S/spool
SlurmctldPidFile=$S/slurmctld.pid
SlurmdPidFile=$S/slurmd.pid
SlurmctldLogFile=$S/slurmctld.log
SlurmdLogFile=$S/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
SlurmdParameters=config_overrides
NodeName=$host CPUs=4 State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP OverSubscribe=FORCE:4
CONF
export SLURM_CONF=$S/slurm.conf
for i in $(seq 50); do [ -S "$S/munge/munge.socket" ] && break; sleep 0.2; done
slurmctld -D -i &>"$S/slurmctld.out" &
pids+=($!)
slurmd -D &>"$S/slurmd.out" &
pids+=($!)
for i in $(seq 150); do
  state=$(sinfo -h -N -o %t 2>/dev/null | head -1 || true)
  [ "$state" = idle ] && break
  sleep 0.2
done
[ "$state" = idle ] || { tail -20 "$S"/*.log "$S"/*.out; fail "the Slurm node did not come up (state '$state')"; }
echo "slurm: node $host idle"

wait_jobs() {  # until squeue is empty (timeout seconds)
  local t=$1
  for i in $(seq $((t * 2))); do
    [ -z "$(squeue -h 2>/dev/null)" ] && return 0
    sleep 0.5
  done
  squeue
  fail "Slurm jobs still queued/running after ${t}s"
}

fresh_build "$recipe" "$WORK/plain" -j 2
dp=$(digest_of "$WORK/plain")
echo "one process: $dp"

# 1. docs/cluster.md "Job arrays": build-shards.sh + merge.sh, tiny.yaml, 2 shards.
cd "$S/jobs"
cat >build-shards.sh <<JOB
#!/bin/bash
#SBATCH --job-name=drape-shard
#SBATCH --array=1-2
#SBATCH --cpus-per-task=1
#SBATCH --time=00:20:00
#SBATCH --output=drape-shard-%A_%a.log
set -euo pipefail
cd "\$SLURM_SUBMIT_DIR"
"$DRAPE" build "$recipe" --shard "\${SLURM_ARRAY_TASK_ID}/2" \\
  -o "shards/tiny/\${SLURM_ARRAY_TASK_ID}" -j "\$SLURM_CPUS_PER_TASK" --quiet
JOB
cat >merge.sh <<JOB
#!/bin/bash
#SBATCH --job-name=drape-merge
#SBATCH --time=00:10:00
#SBATCH --output=drape-merge-%j.log
set -euo pipefail
cd "\$SLURM_SUBMIT_DIR"
"$DRAPE" merge shards/tiny/* -o merged
"$DRAPE" verify merged
JOB
jid=$(sbatch --parsable build-shards.sh)
sbatch --parsable --dependency=afterok:"$jid" merge.sh >/dev/null
wait_jobs 900
cat drape-merge-*.log
da=$(digest_of "$S/jobs/merged")
echo "job array + merge: $da"
[ "$da" = "$dp" ] || { cat drape-shard-*.log; fail "job array + merge digest differs from the one-process build"; }
cmp "$WORK/plain/SHA256SUMS" merged/SHA256SUMS || fail "job array + merge SHA256SUMS differ"

# 2. docs/cluster.md "srun direct launch": DRAPE_MPI=1 srun --mpi=pmix, 3 tasks.
srun --mpi=list 2>&1 | grep -q pmix || fail "this Slurm has no pmix plugin (srun --mpi=list)"
cat >build-mpi.sh <<JOB
#!/bin/bash
#SBATCH --job-name=drape-mpi
#SBATCH --ntasks=3
#SBATCH --cpus-per-task=1
#SBATCH --time=00:20:00
#SBATCH --output=drape-mpi-%j.log
set -euo pipefail
cd "\$SLURM_SUBMIT_DIR"
export DRAPE_MPI=1
srun --mpi=pmix "$DRAPE" build "$recipe" -o mpi --quiet
JOB
sbatch --parsable build-mpi.sh >/dev/null
wait_jobs 900
cat drape-mpi-*.log
dm=$(digest_of "$S/jobs/mpi")
echo "srun --mpi=pmix: $dm"
[ "$dm" = "$dp" ] || fail "srun MPI digest differs from the one-process build"
cmp "$WORK/plain/SHA256SUMS" mpi/SHA256SUMS || fail "srun MPI SHA256SUMS differ"
grep -q '"mpi_ranks": *3' mpi/build.json || fail "build.json does not record mpi_ranks 3"
echo "ok"
