#include "generator/pipeline/build_mpi.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <optional>
#include <sstream>
#include <thread>
#include <vector>

#include "common/cpu_time.h"
#include "common/error.h"
#include "common/hash.h"
#include "common/json.h"
#include "common/timing.h"
#include "common/version.h"
#include "generator/pipeline/build.h"
#include "generator/recipe/jobs.h"
#include "generator/release/release.h"

#ifdef DRAPE_HAVE_MPI
#include <mpi.h>
#endif

namespace drape {

// ---------------------------------------------------------------------------------
// Entry serialization (no MPI needed; tested on its own).

namespace {

constexpr char kEntryMagic[8] = {'D', 'R', 'P', 'E', 'N', 'T', '1', '\n'};

void PutU64(std::string& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
void PutStr(std::string& out, std::string_view s) {
  PutU64(out, s.size());
  out.append(s);
}
std::string Cbor(const Json& j) {
  const std::vector<std::uint8_t> v = Json::to_cbor(j);
  return std::string(v.begin(), v.end());
}

class ByteReader {
 public:
  ByteReader(std::string_view bytes, const std::string& where) : b_(bytes), where_(where) {}
  uint64_t U64(const char* what) {
    Need(8, what);
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(static_cast<unsigned char>(b_[pos_ + i])) << (8 * i);
    pos_ += 8;
    return v;
  }
  std::string_view Str(const char* what) {
    const uint64_t n = U64(what);
    Need(n, what);
    std::string_view s = b_.substr(pos_, n);
    pos_ += n;
    return s;
  }
  std::string_view Raw(size_t n, const char* what) {
    Need(n, what);
    std::string_view s = b_.substr(pos_, n);
    pos_ += n;
    return s;
  }
  Json CborJson(const char* what) {
    const std::string_view s = Str(what);
    try {
      return Json::from_cbor(s.begin(), s.end());
    } catch (const std::exception& ex) {
      throw Error(where_ + ": " + what + ": bad CBOR: " + ex.what());
    }
  }
  bool AtEnd() const { return pos_ == b_.size(); }
  size_t pos() const { return pos_; }

 private:
  void Need(uint64_t n, const char* what) {
    if (n > b_.size() - pos_)
      throw Error(where_ + ": truncated entry bytes reading " + what + " (need " + std::to_string(n) +
                  " bytes at offset " + std::to_string(pos_) + " of " + std::to_string(b_.size()) + ")");
  }
  std::string_view b_;
  std::string where_;
  size_t pos_ = 0;
};

}  // namespace

std::string SerializeEntry(const Entry& e) {
  const std::string record = Cbor(e.record), timing = Cbor(e.timing);
  size_t size = sizeof kEntryMagic + 9 * sizeof(uint64_t) + e.id.size() + e.key.size() + e.split.size() +
                e.failure.size() + record.size() + timing.size();
  for (const auto& f : e.files) size += 16 + f.path.size() + f.bytes.size();
  std::string out;
  out.reserve(size);
  out.append(kEntryMagic, sizeof kEntryMagic);
  PutStr(out, e.id);
  PutStr(out, e.key);
  PutStr(out, e.split);
  PutU64(out, e.failed ? 1 : 0);
  PutStr(out, e.failure);
  PutStr(out, record);
  PutStr(out, timing);
  PutU64(out, e.files.size());
  for (const auto& f : e.files) {
    PutStr(out, f.path);
    PutStr(out, f.bytes);
  }
  return out;
}

Entry DeserializeEntry(std::string_view bytes, const std::string& where) {
  ByteReader r(bytes, where);
  if (r.Raw(sizeof kEntryMagic, "magic") != std::string_view(kEntryMagic, sizeof kEntryMagic))
    throw Error(where + ": not a serialized drape entry (bad magic)");
  Entry e;
  e.id = r.Str("id");
  e.key = r.Str("key");
  e.split = r.Str("split");
  const uint64_t failed = r.U64("failed");
  if (failed > 1) throw Error(where + ": bad 'failed' flag " + std::to_string(failed));
  e.failed = failed == 1;
  e.failure = r.Str("failure");
  e.record = r.CborJson("record");
  e.timing = r.CborJson("timing");
  const uint64_t n = r.U64("file count");
  // Every file takes at least 16 bytes: a corrupt count cannot make us allocate wildly.
  if (n > bytes.size() / 16) throw Error(where + ": bad file count " + std::to_string(n));
  e.files.reserve(n);
  for (uint64_t i = 0; i < n; ++i) {
    EntryFile f;
    f.path = r.Str("file path");
    f.bytes = r.Str("file bytes");
    e.files.push_back(std::move(f));
  }
  if (!r.AtEnd())
    throw Error(where + ": " + std::to_string(bytes.size() - r.pos()) + " trailing bytes after the entry");
  return e;
}

// ---------------------------------------------------------------------------------
// Launcher environment.

namespace {

const char* Env(const char* name) {
  const char* v = std::getenv(name);
  return v && *v ? v : nullptr;
}

long EnvLong(const char* name, long fallback) {
  const char* v = Env(name);
  if (!v) return fallback;
  char* end = nullptr;
  const long x = std::strtol(v, &end, 10);
  return *end ? fallback : x;
}

}  // namespace

bool MpiRequested() {
  const char* force = Env("DRAPE_MPI");
  if (force && std::string(force) == "0") return false;
  if (force && std::string(force) == "1") return true;
  return EnvLong("OMPI_COMM_WORLD_SIZE", 1) > 1;
}

int MpiLaunchRank() {
  for (const char* name : {"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK", "SLURM_PROCID"}) {
    const long r = EnvLong(name, -1);
    if (r >= 0) return static_cast<int>(r);
  }
  return 0;
}

#ifndef DRAPE_HAVE_MPI

bool MpiCompiled() { return false; }

MpiBuildOutcome RunBuildMpi(const Recipe&, const BuildOptions&) {
  throw Error(
      "this drape was built without MPI support (CMake did not find MPI, or DRAPE_WITH_MPI=OFF), but it runs "
      "under an MPI launcher: rebuild with OpenMPI (libopenmpi-dev), run it without mpirun, or split the "
      "build with --shard K/N and drape merge (docs/cluster.md)");
}

#else  // DRAPE_HAVE_MPI

bool MpiCompiled() { return true; }

namespace {

enum Tag : int { kReady = 1, kResult = 2, kData = 3, kJob = 4, kStop = 5, kFinal = 6 };

// MPI counts are ints: byte strings go in chunks of at most 1 GiB.
constexpr size_t kChunk = size_t(1) << 30;

[[noreturn]] void Abort(const std::string& why) {
  std::cerr << "drape build (MPI): " << why << "; aborting every rank\n" << std::flush;
  MPI_Abort(MPI_COMM_WORLD, 3);
  std::abort();
}

void SendBytes(const std::string& bytes, int dest, int tag) {
  const uint64_t n = bytes.size();
  MPI_Send(&n, 1, MPI_UINT64_T, dest, tag, MPI_COMM_WORLD);
  for (size_t off = 0; off < n; off += kChunk) {
    const int count = static_cast<int>(std::min(kChunk, n - off));
    MPI_Send(bytes.data() + off, count, MPI_BYTE, dest, kData, MPI_COMM_WORLD);
  }
}

// Receives what SendBytes sent (its header message has been probed: `source`, `tag`).
std::string RecvBytes(int source, int tag) {
  uint64_t n = 0;
  MPI_Recv(&n, 1, MPI_UINT64_T, source, tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  std::string s(n, '\0');
  for (size_t off = 0; off < n; off += kChunk) {
    const int count = static_cast<int>(std::min(kChunk, n - off));
    MPI_Recv(s.data() + off, count, MPI_BYTE, source, kData, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  }
  return s;
}

// Waits for the next message from `source` without spinning a core (OpenMPI's
// blocking receive busy-polls): probe, then sleep a little longer each time, up to 5 ms.
MPI_Status WaitMessage(int source) {
  for (int idle = 0;; ++idle) {
    int flag = 0;
    MPI_Status st;
    MPI_Iprobe(source, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
    if (flag) return st;
    std::this_thread::sleep_for(std::chrono::microseconds(idle < 50 ? 100 : 5000));
  }
}

// What every rank must agree on before it may compute entries for rank 0.
std::string Fingerprint(const Recipe& recipe, const BuildOptions& options, size_t jobs) {
  const std::string code = options.code_version.empty() ? std::string(GitVersion()) : options.code_version;
  return "recipe sha256 " + Sha256Hex(recipe.text) + ", code " + code + ", " + std::to_string(jobs) + " jobs";
}

// A worker's result frame: kind (0 entry, 1 error), job index, payload.
std::string ResultFrame(char kind, int job, const std::string& payload) {
  std::string out;
  out.reserve(payload.size() + 9);
  out.push_back(kind);
  PutU64(out, static_cast<uint64_t>(job));
  out.append(payload);
  return out;
}

int StatusOf(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const Error&) {
    return 1;
  } catch (...) {
    return 3;
  }
}

std::string WhatOf(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& ex) {
    return ex.what();
  } catch (...) {
    return "unknown exception";
  }
}

// The entry in a worker's result frame (kind byte, job index, payload): deserialized, or
// for an error with keep_going a failed entry; nullopt (and *error) when the build stops.
std::optional<Entry> ResultEntry(const std::string& frame, const Job& job, int rank, bool keep_going,
                                 std::string* error) {
  const std::string_view payload = std::string_view(frame).substr(9);
  std::optional<Entry> entry;
  if (frame[0] == 0) {
    try {
      entry = DeserializeEntry(payload, job.key + " from MPI rank " + std::to_string(rank));
    } catch (const std::exception& ex) {
      *error = ex.what();
    }
  } else {
    *error = std::string(payload);
    if (keep_going) entry = FailedEntry(job, *error);  // as in RunBuild
  }
  if (entry && (entry->key != job.key || entry->id != job.id)) {
    *error = "MPI rank " + std::to_string(rank) + " returned entry " + entry->key + " for job " + job.key;
    entry.reset();
  }
  return entry;
}

// What rank 0 tells every worker at the end: the error, or the build's report.
Json FinalMessage(const BuildReport& report, const std::exception_ptr& error) {
  if (error) return {{"error", WhatOf(error)}, {"status", StatusOf(error)}};
  return {{"output", report.output.string()},
          {"total_jobs", report.total_jobs},
          {"shard_jobs", report.shard_jobs},
          {"already_done", report.already_done},
          {"built", report.built},
          {"failed", report.failed},
          {"interrupted", report.interrupted},
          {"aborted", report.aborted},
          {"error", report.error},
          {"finalized", report.finalized},
          {"digest", report.digest},
          {"release_failed", report.release_failed},
          {"wall_seconds", report.wall_seconds}};
}

// Rank 0 serving jobs to the worker ranks: hands out job indices, commits the entries
// that come back, and keeps the progress line (Coordinate below starts and finishes).
class JobServer {
 public:
  JobServer(const Recipe& recipe, const BuildOptions& options, int size, Clock::time_point t0, std::ostream& log,
            ProgressMode mode, BuildStart& start, std::string expected, BuildReport& report, std::exception_ptr& error)
      : options_(options),
        workers_(size - 1),
        t0_(t0),
        log_(log),
        mode_(mode),
        start_(start),
        expected_(std::move(expected)),
        report_(report),
        error_(error),
        running_(size, -1),
        position_(size, -1),
        started_(size),
        active_(size - 1),
        eta_(MakeEtaClock(recipe, start, size - 1, options)),
        progress_line_(log, mode, options.progress_interval) {}

  // Until every worker has been told to stop.
  void Serve() {
    auto last_tick = Clock::now() - std::chrono::seconds(1);
    while (active_ > 0) {
      int flag = 0;
      MPI_Status st;
      MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
      NoteStop();
      if (!flag) {
        if (Since(last_tick) >= 0.5) {
          Progress(false);
          last_tick = Clock::now();
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      const int w = st.MPI_SOURCE;
      if (st.MPI_TAG == kReady) {
        OnReady(w);
      } else if (st.MPI_TAG == kResult) {
        OnResult(w);
      } else {
        Abort("unexpected message tag " + std::to_string(st.MPI_TAG) + " from rank " + std::to_string(w));
      }
    }
    Progress(true);
  }

 private:
  bool Stopping() const { return error_ || report_.aborted || (options_.stop && options_.stop->load()); }
  void FailBuild(const std::string& why) {
    if (!report_.aborted) report_.error = why;
    report_.aborted = true;
  }
  int InFlight() const {
    int in_flight = 0;
    for (int j : running_) in_flight += j >= 0;
    return in_flight;
  }
  // The next job for worker w, or stop.
  void HandOut(int w) {
    if (!Stopping() && next_ < start_.todo.size()) {
      position_[w] = static_cast<int>(next_);
      const int32_t j = start_.todo[next_++];
      MPI_Send(&j, 1, MPI_INT32_T, w, kJob, MPI_COMM_WORLD);
      running_[w] = j;
      started_[w] = Clock::now();
    } else {
      MPI_Send(nullptr, 0, MPI_BYTE, w, kStop, MPI_COMM_WORLD);
      running_[w] = -1;
      --active_;
    }
  }
  void NoteStop() {
    if (mode_ == ProgressMode::kQuiet || error_ || stop_noted_ || !options_.stop || !options_.stop->load()) return;
    stop_noted_ = true;
    log_ << (mode_ == ProgressMode::kTty ? "\n" : "") << "drape build: interrupted; letting " << InFlight()
         << " running job(s) finish and commit (--resume continues)\n";
  }
  void Progress(bool over) {
    if (error_) return;
    const double eta = eta_.Remaining();
    progress_line_.Print(report_.already_done + finished_, report_.shard_jobs, report_.failed, Since(t0_), eta, over,
                         ", " + std::to_string(InFlight()) + "/" + std::to_string(workers_) + " ranks busy");
  }
  // A worker is ready: it must have read the same recipe with the same binary.
  void OnReady(int w) {
    const std::string fingerprint = RecvBytes(w, kReady);
    if (!error_ && fingerprint != expected_)
      FailBuild("MPI rank " + std::to_string(w) + " differs from rank 0 (" + fingerprint + " vs " + expected_ +
                "): every rank must read the same recipe with the same drape binary");
    HandOut(w);
  }
  // A worker's result: commit its entry (or fail the build), then its next job.
  void OnResult(int w) {
    const std::string frame = RecvBytes(w, kResult);
    const int job_index = running_[w];
    if (frame.size() < 9 || job_index < 0) Abort("malformed result from rank " + std::to_string(w));
    ByteReader header(std::string_view(frame).substr(1, 8), "result");
    if (static_cast<int>(header.U64("job")) != job_index)
      Abort("rank " + std::to_string(w) + " returned a job it was not given");
    const Job& job = start_.jobs[job_index];
    std::string err;
    std::optional<Entry> entry = ResultEntry(frame, job, w, options_.keep_going, &err);
    const double c0 = ThreadCpuSeconds();
    if (entry) {
      try {
        start_.writer->Commit(*entry);
      } catch (const std::exception& ex) {
        entry.reset();
        err = std::string("committing ") + job.key + ": " + ex.what();
      }
    }
    if (!entry) {
      FailBuild(job.key + ": " + err);
    } else {
      ++finished_;
      eta_.Done(position_[w], Since(started_[w]));
      report_.commit_cpu_seconds += ThreadCpuSeconds() - c0;
      CountEntry(*entry, job, report_);
    }
    HandOut(w);
  }

  const BuildOptions& options_;
  const int workers_;
  const Clock::time_point t0_;
  std::ostream& log_;
  const ProgressMode mode_;
  BuildStart& start_;
  const std::string expected_;
  BuildReport& report_;
  std::exception_ptr& error_;
  std::vector<int> running_;   // job index each worker is computing
  std::vector<int> position_;  // and its position in start_.todo
  std::vector<Clock::time_point> started_;
  int active_;  // workers not yet told to stop
  size_t next_ = 0;
  int finished_ = 0;
  EtaClock eta_;
  ProgressLine progress_line_;
  bool stop_noted_ = false;
};

// Rank 0: opens the release, serves jobs, commits entries, finalizes, tells every
// worker the outcome. An exception is stored in `error` (rethrown by the caller
// after MPI_Finalize) so that the workers are always released.
MpiBuildOutcome Coordinate(const Recipe& recipe, const BuildOptions& options, int size, std::exception_ptr& error) {
  const auto t0 = Clock::now();
  std::ostream& log = options.log ? *options.log : std::cerr;
  MpiBuildOutcome out;
  out.coordinator = true;
  out.ranks = size;
  BuildReport& report = out.report;
  report.output = options.output.empty() ? DefaultOutput(recipe) : options.output;
  const int workers = size - 1;
  const ProgressMode mode = ResolveProgressMode(options.progress, log);

  BuildStart start;
  std::string expected;
  try {
    start = StartBuild(recipe, options, report);
    expected = Fingerprint(recipe, options, start.jobs.size());
    if (mode != ProgressMode::kQuiet) {
      LogBuildStart(log, recipe, options, report, start.todo.size());
      log << workers << " MPI worker rank" << (workers > 1 ? "s" : "") << " (rank 0 coordinates"
          << (options.threads > 1 ? "; -j is ignored: one job per worker rank" : "") << ")\n";
      log.flush();
    }
  } catch (...) {
    error = std::current_exception();
    start.todo.clear();
  }
  JobServer(recipe, options, size, t0, log, mode, start, expected, report, error).Serve();

  if (!error) {
    try {
      start.writer->SetBuildInfo("threads", 1);
      start.writer->SetBuildInfo("mpi_ranks", size);
      start.writer->SetBuildInfo("mpi_workers", workers);
      FinishBuild(*start.writer, report, mode, log);
    } catch (...) {
      error = std::current_exception();
    }
  }
  start.writer.reset();  // releases the lock before the workers are let go
  report.wall_seconds = Since(t0);

  const std::string bytes = FinalMessage(report, error).dump();
  for (int w = 1; w < size; ++w) SendBytes(bytes, w, kFinal);
  return out;
}

// Ranks 1..N−1: ask for jobs, compute them, send the entries back.
MpiBuildOutcome Work(const Recipe& recipe, const BuildOptions& options, int rank, int size) {
  MpiBuildOutcome out;
  out.coordinator = false;
  out.ranks = size;
  std::vector<Job> jobs;
  std::string fingerprint;
  try {
    jobs = ExpandJobs(recipe);
    fingerprint = Fingerprint(recipe, options, jobs.size());
  } catch (const std::exception& ex) {
    fingerprint = std::string("error: ") + ex.what();  // rank 0 sees the mismatch and stops the build
  }
  SendBytes(fingerprint, 0, kReady);
  JobCache cache;
  for (;;) {
    const MPI_Status st = WaitMessage(0);
    if (st.MPI_TAG == kStop) {
      MPI_Recv(nullptr, 0, MPI_BYTE, 0, kStop, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      break;
    }
    if (st.MPI_TAG != kJob) Abort("rank " + std::to_string(rank) + ": unexpected tag " + std::to_string(st.MPI_TAG));
    int32_t j = -1;
    MPI_Recv(&j, 1, MPI_INT32_T, 0, kJob, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    if (j < 0 || j >= static_cast<int32_t>(jobs.size())) Abort("rank 0 sent job index " + std::to_string(j));
    std::string frame;
    try {
      Entry e = BuildEntry(recipe, jobs[j], cache);
      e.timing["mpi_rank"] = rank;  // machine facts go in timing (never hashed)
      frame = ResultFrame(0, j, SerializeEntry(e));
    } catch (const std::exception& ex) {
      frame = ResultFrame(1, j, ex.what());
    } catch (...) {
      frame = ResultFrame(1, j, "unknown exception");
    }
    SendBytes(frame, 0, kResult);
  }

  const MPI_Status st = WaitMessage(0);
  if (st.MPI_TAG != kFinal) Abort("rank " + std::to_string(rank) + ": expected the final message");
  const Json final = Json::parse(RecvBytes(0, kFinal));
  if (final.contains("status")) {
    out.exit_status = final.at("status").get<int>();
    out.report.error = final.value("error", "");
    return out;
  }
  BuildReport& r = out.report;
  r.output = final.value("output", "");
  r.total_jobs = final.value("total_jobs", 0);
  r.shard_jobs = final.value("shard_jobs", 0);
  r.already_done = final.value("already_done", 0);
  r.built = final.value("built", 0);
  r.failed = final.value("failed", 0);
  r.interrupted = final.value("interrupted", false);
  r.aborted = final.value("aborted", false);
  r.error = final.value("error", "");
  r.finalized = final.value("finalized", false);
  r.digest = final.value("digest", "");
  r.release_failed = final.value("release_failed", 0);
  r.wall_seconds = final.value("wall_seconds", 0.0);
  return out;
}

}  // namespace

MpiBuildOutcome RunBuildMpi(const Recipe& recipe, const BuildOptions& options) {
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (finalized) throw Error("MPI build: MPI is already finalized (one MPI build per process)");
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (!initialized) MPI_Init(nullptr, nullptr);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);

  MpiBuildOutcome out;
  std::exception_ptr error;
  if (size == 1) {
    try {
      out.report = RunBuild(recipe, options);
    } catch (...) {
      error = std::current_exception();
    }
  } else if (rank == 0) {
    out = Coordinate(recipe, options, size, error);
  } else {
    out = Work(recipe, options, rank, size);
  }
  MPI_Finalize();
  if (error) std::rethrow_exception(error);
  return out;
}

#endif  // DRAPE_HAVE_MPI

}  // namespace drape
