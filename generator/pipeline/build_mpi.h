// Multi-process builds over MPI: `mpirun -np N drape build RECIPE [-o DIR]`.
//
// Rank 0 only coordinates: it opens the release writer (lock, resume and refusal
// rules as for a one-process build), hands out job indices one at a time to the
// ranks that ask (dynamic scheduling: a rank asks, gets the next job not yet done
// or "stop"), commits the entries they send back and finalizes the release. Ranks
// 1..N−1 each run one job at a time (BuildEntry, single-threaded stages) with their
// own JobCache. So `-np N` gives N−1 simulating processes: on one machine use
// np = cores + 1 (rank 0 mostly sleeps). Entries depend only on the recipe and job,
// so the digest equals a one-process build's. All ranks exit with the same status.
//
// Messages (MPI_COMM_WORLD; every rank loads the same recipe itself):
//   worker → 0  kReady   fingerprint (recipe sha256, code version, job count): first ask
//   worker → 0  kResult  uint64 length, then kData chunks (≤ 1 GiB each) of a result
//                        frame: the finished entry (SerializeEntry) or the job's error;
//                        a result is also the ask for the next job
//   0 → worker  kJob     int32 job index | kStop (no more work)
//   0 → worker  kFinal   JSON: rank 0's outcome (report fields, or its error)
// Waiting ranks poll (MPI_Iprobe + a short sleep) instead of blocking in MPI, since
// OpenMPI's blocking calls spin a core that the simulating ranks need.
//
// MPI is initialised only when the environment says the process runs under mpirun
// with more than one rank (OMPI_COMM_WORLD_SIZE > 1), or DRAPE_MPI=1 forces it (e.g.
// `srun --mpi=pmix` direct launch); plain runs never touch MPI. Without MPI support
// compiled in (DRAPE_HAVE_MPI, set when CMake finds MPI::MPI_CXX) a run under
// mpirun is refused with a message instead of N processes racing for the folder.
#pragma once

#include <string>
#include <string_view>

#include "generator/pipeline/build.h"
#include "generator/recipe/recipe.h"
#include "generator/release/entry.h"

namespace drape {

// True if this binary was built with MPI support.
bool MpiCompiled();

// True when this process should run an MPI build: the launcher says it runs under
// mpirun with more than one rank (OMPI_COMM_WORLD_SIZE > 1), or DRAPE_MPI=1 forces
// it (e.g. `srun --mpi=pmix` direct launch, where OpenMPI's variables come only with
// MPI_Init). DRAPE_MPI=0 forces a plain build.
bool MpiRequested();
// This process's rank as announced by the launcher before MPI_Init
// (OMPI_COMM_WORLD_RANK, SLURM_PROCID, PMIX_RANK or PMI_RANK); 0 when none is set.
int MpiLaunchRank();

struct MpiBuildOutcome {
  bool coordinator = true;  // rank 0: `report` is the build's report, print as usual
  // On every rank: rank 0's report (workers get its summary fields: output,
  // total/shard jobs, already_done, built, failed, interrupted, aborted, error,
  // finalized, digest, release_failed; `failures` only on rank 0).
  BuildReport report;
  // Workers: the exit status rank 0 takes when it failed with an exception (1 bad
  // input, e.g. a locked folder; 3 internal error); −1 = derive it from `report`.
  int exit_status = -1;
  int ranks = 1;
};

// Runs the build across the MPI world (MPI_Init … MPI_Finalize; callable once per
// process). On rank 0 an exception (drape::Error for bad input, a locked folder, …)
// is rethrown after every rank has been told; workers never throw for it (they get
// exit_status instead), so the error is printed once. options.threads is ignored
// (one job per worker rank at a time); stop (SIGINT) is honoured on rank 0.
MpiBuildOutcome RunBuildMpi(const Recipe& recipe, const BuildOptions& options);

// Length-prefixed binary form of an Entry: a magic word, then id, key, split, failed,
// failure, record and timing (as CBOR, so numbers round-trip exactly), and the files
// (path, bytes). Lengths are 64-bit little-endian. Same-architecture ranks assumed
// only in that doubles inside CBOR are IEEE-754 (always true in practice).
std::string SerializeEntry(const Entry& entry);
// Inverse of SerializeEntry; throws drape::Error naming `where` on truncated or
// malformed bytes.
Entry DeserializeEntry(std::string_view bytes, const std::string& where);

}  // namespace drape
