#include "generator/release/release.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <thread>

#include "common/error.h"
#include "common/files.h"
#include "common/hash.h"
#include "generator/release/release_internal.h"

namespace fs = std::filesystem;

namespace drape {
namespace {

constexpr int kJobs = 12;

// Canonical JSON (the entry digest's input) is nlohmann::json's dump: object keys sorted
// at every depth, arrays kept in order, numbers as nlohmann prints them. Against the
// explicit form for a record with unsorted keys and every value type.
TEST(CanonicalJson, SortsKeysAtEveryDepthAndKeepsArrays) {
  Json j = Json::object();
  j["zeta"] = Json{{"b", 1}, {"a", -2}};
  j["alpha"] = Json::array({3.25, "x", true, nullptr, Json{{"y", 1u}, {"x", 0.1}}});
  j["Mid"] = 18446744073709551615ull;
  EXPECT_EQ(release_detail::CanonicalJson(j),
            R"({"Mid":18446744073709551615,"alpha":[3.25,"x",true,null,{"x":0.1,"y":1}],"zeta":{"a":-2,"b":1}})");
}

std::string Key(int i) { return "garment" + std::to_string(i % 3) + "/tshirt/anchor" + std::to_string(i); }
std::string Id(int i) {
  char buf[16];
  std::snprintf(buf, sizeof(buf), "e%03d", i);
  return buf;
}

ReleaseMeta MakeMeta(const std::string& recipe = "name: unit\nversion: 1.0.0\nseed: 7\n") {
  ReleaseMeta m;
  m.name = "unit";
  m.version = "1.0.0";
  m.seed = 7;
  m.recipe_text = recipe;
  m.code_version = "test-code";
  m.description = "A synthetic release for unit tests.";
  m.recipe_summary = {{"garments", 3}, {"materials", Json::array({"tshirt"})}};
  for (int i = 0; i < kJobs; ++i) m.job_keys.push_back(Key(i));
  return m;
}

Entry MakeEntry(int i) {
  Entry e;
  e.id = Id(i);
  e.key = Key(i);
  e.split = i % 4 == 3 ? "test" : (i % 4 == 2 ? "calibration" : "train");
  e.failed = i == 5;
  if (e.failed) e.failure = "simulation blew up (NaN at step 17)";
  e.record =
      Json{{"category", i % 2 ? "pants" : "shirt"},
           {"garment", i % 2 ? "pants" : "long_sleeve_shirt"},
           {"instance", "garment" + std::to_string(i % 3)},
           {"material", "tshirt"},
           {"anchor", {{"label", "anchor" + std::to_string(i % 5)}, {"vertex", 10 + i}, {"uv", {0.25 * i, 0.5}}}},
           {"grasp_offset", {0.0, 0.001 * i, 0.0}},
           {"seed", 18446744073709551615ull - static_cast<uint64_t>(i)},
           {"hang", {{"steps", 480 + i}, {"settled", true}, {"strain_max", 0.01 * i}}},
           {"fusion", {{"recon_to_truth_mean", 0.0015 + 0.0001 * i}}}};
  e.timing = Json{{"hang_seconds", 0.1 * i}};
  if (!e.failed) {
    std::string ply = "ply\nformat binary_little_endian 1.0\n";
    for (int k = 0; k < 100 + i; ++k) ply += static_cast<char>((k * 7 + i) & 0xff);
    e.files.push_back({"hang.ply", ply});
    e.files.push_back({"feature.bin", std::string(512, static_cast<char>(i))});
    e.files.push_back({"preview.png", "\x89PNG fake " + std::to_string(i)});
    e.files.push_back({"sweep/000000.png", "depth" + std::to_string(i)});
    e.files.push_back({"sweep/cameras.json", "{}"});
  }
  return e;
}

class ReleaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("drape_release_test_" + std::to_string(::getpid()) + "_" +
                                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override {
    // DRAPE_KEEP_TEST_OUTPUT=1 keeps the releases for a look (drape info/ls/verify).
    if (!HasFailure() && !std::getenv("DRAPE_KEEP_TEST_OUTPUT")) fs::remove_all(root_);
  }
  // A full release built sequentially.
  ReleaseWriter::Summary Build(const fs::path& dir, const ReleaseMeta& meta = MakeMeta()) {
    auto w = ReleaseWriter::Open(dir, meta);
    for (int i = 0; i < kJobs; ++i) w->Commit(MakeEntry(i));
    return w->Finalize();
  }
  fs::path root_;
};

std::string Slurp(const fs::path& p) { return ReadFile(p); }

TEST_F(ReleaseTest, DigestIndependentOfCommitOrderAndThreads) {
  const auto a = Build(root_ / "a");
  // Shuffled order from two threads, as a -j2 build would commit.
  {
    auto w = ReleaseWriter::Open(root_ / "b", MakeMeta());
    std::vector<int> order(kJobs);
    for (int i = 0; i < kJobs; ++i) order[i] = i;
    std::mt19937 g(42);
    std::shuffle(order.begin(), order.end(), g);
    std::thread t1([&] {
      for (int k = 0; k < kJobs; k += 2) w->Commit(MakeEntry(order[k]));
    });
    std::thread t2([&] {
      for (int k = 1; k < kJobs; k += 2) w->Commit(MakeEntry(order[k]));
    });
    t1.join();
    t2.join();
    const auto b = w->Finalize();
    EXPECT_EQ(a.digest, b.digest);
    EXPECT_EQ(b.entries, kJobs);
    EXPECT_EQ(b.failed, 1);
  }
  // Not just the digest: every listed file has the same bytes (catalog included).
  EXPECT_EQ(Slurp(root_ / "a" / "SHA256SUMS"), Slurp(root_ / "b" / "SHA256SUMS"));
  EXPECT_EQ(Slurp(root_ / "a" / "catalog.sqlite"), Slurp(root_ / "b" / "catalog.sqlite"));
  EXPECT_FALSE(fs::exists(root_ / "b" / ".drape-build"));
  EXPECT_FALSE(fs::exists(root_ / "b" / ".drape.lock"));
  // The digest changes when content changes.
  ReleaseMeta m = MakeMeta();
  auto w = ReleaseWriter::Open(root_ / "c", m);
  for (int i = 0; i < kJobs; ++i) {
    Entry e = MakeEntry(i);
    if (i == 3) e.record["hang"]["steps"] = 1;
    w->Commit(e);
  }
  EXPECT_NE(w->Finalize().digest, a.digest);
}

TEST_F(ReleaseTest, DigestIgnoresTimingAndCodeVersion) {
  const auto a = Build(root_ / "a");
  ReleaseMeta m = MakeMeta();
  m.code_version = "other-code";
  auto w = ReleaseWriter::Open(root_ / "b", m);
  for (int i = kJobs - 1; i >= 0; --i) {
    Entry e = MakeEntry(i);
    e.timing = Json{{"hang_seconds", 99.0}};
    w->Commit(e);
  }
  EXPECT_EQ(w->Finalize().digest, a.digest);
  EXPECT_EQ(Slurp(root_ / "a" / "catalog.sqlite"), Slurp(root_ / "b" / "catalog.sqlite"));
}

TEST_F(ReleaseTest, ResumeAfterSimulatedCrashGivesSameDigest) {
  const auto ref = Build(root_ / "ref");
  const fs::path dir = root_ / "r";
  {
    auto w = ReleaseWriter::Open(dir, MakeMeta());
    for (int i = 0; i < 7; ++i) w->Commit(MakeEntry(i));
  }  // dropped without Finalize, like Ctrl-C
  // What a kill -9 can leave: a half-written staging folder, a journal cut mid-line.
  fs::create_directories(dir / ".drape-build/staging/e007.999.0/sweep");
  WriteFileAtomic(dir / ".drape-build/staging/e007.999.0/hang.ply", "ply\nhalf");
  {
    std::ofstream j(dir / ".drape-build/journal.jsonl", std::ios::app);
    j << "{\"id\":\"e007\",\"key\":\"garm";
  }
  // And damage from outside: an entry folder without its entry.json is not done.
  fs::create_directories(dir / "entries/e008");
  WriteFileAtomic(dir / "entries/e008/hang.ply", "junk");

  auto w = ReleaseWriter::Open(dir, MakeMeta(), /*resume=*/true);
  const auto done = w->DoneKeys();
  EXPECT_EQ(done.size(), 7u);
  for (int i = 0; i < 7; ++i) EXPECT_TRUE(done.count(Key(i))) << i;
  EXPECT_FALSE(fs::exists(dir / ".drape-build/staging/e007.999.0"));
  EXPECT_FALSE(fs::exists(dir / "entries/e008"));
  for (int i = 7; i < kJobs; ++i) w->Commit(MakeEntry(i));
  const auto s = w->Finalize();
  EXPECT_EQ(s.digest, ref.digest);
  EXPECT_EQ(Slurp(dir / "SHA256SUMS"), Slurp(root_ / "ref" / "SHA256SUMS"));
  EXPECT_TRUE(Verify(dir).ok());
  // Timings of entries whose journal lines survived are in build.json.
  const Json build = Json::parse(Slurp(dir / "build.json"));
  EXPECT_TRUE(build["entry_timing"].contains("e000"));
}

TEST_F(ReleaseTest, SigkillMidBuildThenResumeGivesSameDigest) {
  const auto ref = Build(root_ / "ref");
  const fs::path dir = root_ / "k";
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // Child: commits slowly until killed.
    try {
      auto w = ReleaseWriter::Open(dir, MakeMeta());
      for (int i = 0; i < kJobs; ++i) {
        w->Commit(MakeEntry(i));
        ::usleep(30000);
      }
      ::usleep(10000000);
    } catch (...) {
    }
    ::_exit(0);
  }
  // Kill after a few entries are in (poll the folder).
  for (int t = 0; t < 400; ++t) {
    if (fs::exists(dir / "entries") &&
        std::distance(fs::directory_iterator(dir / "entries"), fs::directory_iterator()) >= 4)
      break;
    ::usleep(5000);
  }
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  // The dead build's lock is gone with it.
  auto w = ReleaseWriter::Open(dir, MakeMeta(), true);
  const auto done = w->DoneKeys();
  EXPECT_GE(done.size(), 4u);
  EXPECT_LT(done.size(), static_cast<size_t>(kJobs));
  for (int i = 0; i < kJobs; ++i)
    if (!done.count(Key(i))) w->Commit(MakeEntry(i));
  EXPECT_EQ(w->Finalize().digest, ref.digest);
}

TEST_F(ReleaseTest, SecondWriterIsRefusedWithHolderPid) {
  const fs::path dir = root_ / "l";
  auto w = ReleaseWriter::Open(dir, MakeMeta());
  try {
    ReleaseWriter::Open(dir, MakeMeta());
    FAIL() << "second writer was not refused";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("another build"), std::string::npos) << msg;
    EXPECT_NE(msg.find("pid " + std::to_string(::getpid())), std::string::npos) << msg;
  }
  // The refused attempt did not disturb the first writer.
  w->Commit(MakeEntry(0));
  w.reset();
  auto w2 = ReleaseWriter::Open(dir, MakeMeta());
  EXPECT_EQ(w2->DoneKeys().size(), 1u);
}

TEST_F(ReleaseTest, CommitRejectsBadEntries) {
  auto w = ReleaseWriter::Open(root_ / "x", MakeMeta());
  Entry e = MakeEntry(0);
  e.key = "not/a/job";
  EXPECT_THROW(w->Commit(e), Error);
  e = MakeEntry(0);
  e.id = "../escape";
  EXPECT_THROW(w->Commit(e), Error);
  e = MakeEntry(0);
  e.files.push_back({"entry.json", "{}"});
  EXPECT_THROW(w->Commit(e), Error);
  e = MakeEntry(0);
  e.files.push_back({"../up.ply", "x"});
  EXPECT_THROW(w->Commit(e), Error);
  w->Commit(MakeEntry(0));
  EXPECT_THROW(w->Commit(MakeEntry(0)), Error);  // same key twice
  e = MakeEntry(1);
  e.id = Id(0);
  EXPECT_THROW(w->Commit(e), Error);  // id taken
  try {
    w->Finalize();
    FAIL();
  } catch (const Error& ex) {
    EXPECT_NE(std::string(ex.what()).find("11 of 12 jobs not committed"), std::string::npos) << ex.what();
  }
}

TEST_F(ReleaseTest, VersionIsImmutable) {
  const auto a = Build(root_ / "v");
  try {
    ReleaseWriter::Open(root_ / "v", MakeMeta("name: unit\nversion: 1.0.0\nseed: 8\n"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bump the version"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("recipe_sha256"), std::string::npos) << e.what();
  }
  ReleaseMeta other_code = MakeMeta();
  other_code.code_version = "newer";
  EXPECT_THROW(ReleaseWriter::Open(root_ / "v", other_code), Error);
  // A refused writer leaves the folder as it was.
  EXPECT_FALSE(fs::exists(root_ / "v" / ".drape.lock"));
  EXPECT_FALSE(fs::exists(root_ / "v" / ".drape-build"));
  EXPECT_TRUE(Verify(root_ / "v").ok());
  // Same inputs (also with --resume): everything is done, finalizing again changes nothing.
  const std::string build_json = Slurp(root_ / "v" / "build.json");
  auto w = ReleaseWriter::Open(root_ / "v", MakeMeta(), /*resume=*/true);
  EXPECT_EQ(w->DoneKeys().size(), static_cast<size_t>(kJobs));
  EXPECT_THROW(w->Commit(MakeEntry(0)), Error);
  const auto again = w->Finalize();
  EXPECT_EQ(again.digest, a.digest);
  EXPECT_EQ(again.entries, kJobs);
  EXPECT_EQ(Slurp(root_ / "v" / "build.json"), build_json);  // untouched
  EXPECT_FALSE(fs::exists(root_ / "v" / ".drape.lock"));
  EXPECT_TRUE(Verify(root_ / "v").ok());
  // A non-release folder is not written into.
  fs::create_directories(root_ / "junk");
  WriteFileAtomic(root_ / "junk" / "notes.txt", "mine");
  EXPECT_THROW(ReleaseWriter::Open(root_ / "junk", MakeMeta()), Error);
  EXPECT_FALSE(fs::exists(root_ / "junk" / ".drape.lock"));
  // --resume with nothing to resume.
  EXPECT_THROW(ReleaseWriter::Open(root_ / "none", MakeMeta(), true), Error);
  fs::create_directories(root_ / "empty");
  EXPECT_THROW(ReleaseWriter::Open(root_ / "empty", MakeMeta(), true), Error);
  EXPECT_FALSE(fs::exists(root_ / "empty" / ".drape.lock"));
}

TEST_F(ReleaseTest, VerifyCatchesFlippedDeletedAndAddedFiles) {
  const fs::path dir = root_ / "ok";
  Build(dir);
  const VerifyReport clean = Verify(dir);
  EXPECT_TRUE(clean.ok());
  // Entry files + entry.json, the failed entry's entry.json, 4 top-level files, and the
  // gallery's 5 viewer files when built with three.js (no entry here has the two meshes
  // a 3D view needs).
  EXPECT_EQ(clean.files_checked, (kJobs - 1) * 6 + 1 + 4 + (release_detail::GalleryHas3d() ? 5 : 0));
  EXPECT_EQ(clean.actual_digest, clean.expected_digest);

  auto copy = [&](const std::string& name) {
    fs::copy(dir, root_ / name, fs::copy_options::recursive);
    return root_ / name;
  };
  {
    const fs::path d = copy("flip");
    std::string b = Slurp(d / "entries/e002/hang.ply");
    b[40] ^= 0x01;
    WriteFileAtomic(d / "entries/e002/hang.ply", b);
    const VerifyReport r = Verify(d);
    EXPECT_FALSE(r.ok());
    EXPECT_EQ(r.changed, std::vector<std::string>{"entries/e002/hang.ply"});
    EXPECT_NE(r.actual_digest, r.expected_digest);
    EXPECT_EQ(r.problems.size(), 1u);
  }
  {
    const fs::path d = copy("del");
    fs::remove(d / "entries/e004/sweep/000000.png");
    const VerifyReport r = Verify(d);
    EXPECT_EQ(r.missing, std::vector<std::string>{"entries/e004/sweep/000000.png"});
    EXPECT_TRUE(r.changed.empty());
    EXPECT_FALSE(r.ok());
  }
  {
    const fs::path d = copy("add");
    WriteFileAtomic(d / "entries/e001/stray.txt", "hello");
    const VerifyReport r = Verify(d);
    EXPECT_EQ(r.extra, std::vector<std::string>{"entries/e001/stray.txt"});
    EXPECT_TRUE(r.changed.empty() && r.missing.empty());
    EXPECT_FALSE(r.ok());
  }
  {
    // build.json holds timings and is not covered: editing it is fine.
    const fs::path d = copy("timing");
    WriteFileAtomic(d / "build.json", "{}");
    EXPECT_TRUE(Verify(d).ok());
  }
  {
    // drape calibrate writes its weights beside the release content; a stray file
    // elsewhere at the top level is still extra.
    const fs::path d = copy("calibrated");
    WriteFileAtomic(d / "calibration/weights.json", "{}");
    EXPECT_TRUE(Verify(d).ok());
    WriteFileAtomic(d / "calibration.json", "{}");
    EXPECT_EQ(Verify(d).extra, std::vector<std::string>{"calibration.json"});
  }
}

// Damaged or foreign releases: each a drape::Error (or a verify problem) naming the
// file, never a crash. Each case damages its own copy of one good release.
class BadReleaseTest : public ReleaseTest {
 protected:
  void SetUp() override {
    ReleaseTest::SetUp();
    ok_ = root_ / "ok";
    Build(ok_);
  }
  fs::path Copy(const std::string& name) const {
    fs::copy(ok_, root_ / name, fs::copy_options::recursive);
    return root_ / name;
  }
  static std::string OpenError(const fs::path& d) {
    try {
      Release::Open(d);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  }
  static std::string Problems(const VerifyReport& r) {
    std::string all;
    for (const auto& p : r.problems) all += p + "\n";
    return all;
  }
  fs::path ok_;  // the good release
};

TEST_F(BadReleaseTest, TruncatedCatalogAtEveryCut) {
  EXPECT_EQ(Release::Open(ok_).dataset().value("format_version", 0), 1);
  // Truncated catalog.sqlite: every cut (header, first pages, half).
  const std::string cat = Slurp(ok_ / "catalog.sqlite");
  for (size_t cut : {size_t{0}, size_t{50}, size_t{4096}, cat.size() / 2}) {
    const fs::path d = Copy("trunc" + std::to_string(cut));
    WriteFileAtomic(d / "catalog.sqlite", cat.substr(0, cut));
    const std::string e = OpenError(d);
    EXPECT_NE(e.find((d / "catalog.sqlite").string()), std::string::npos) << cut << ": " << e;
    EXPECT_EQ(Verify(d).changed, std::vector<std::string>{"catalog.sqlite"});
  }
}

TEST_F(BadReleaseTest, MissingEntryFolder) {
  const fs::path d = Copy("no_entry");
  fs::remove_all(d / "entries/e003");
  EXPECT_NE(OpenError(d).find((d / "entries/e003").string() + ": entry folder missing"), std::string::npos)
      << OpenError(d);
  const VerifyReport r = Verify(d);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(std::find(r.missing.begin(), r.missing.end(), "entries/e003/entry.json"), r.missing.end());
}

TEST_F(BadReleaseTest, JobInTwoEntriesAndEntryTwiceInTheCatalog) {
  // The same job in two entry folders (a copied folder renamed, its id edited).
  const fs::path d = Copy("twice");
  fs::copy(d / "entries/e004", d / "entries/e099", fs::copy_options::recursive);
  Json j = Json::parse(Slurp(d / "entries/e099/entry.json"));
  j["id"] = "e099";
  WriteFileAtomic(d / "entries/e099/entry.json", j.dump());
  const VerifyReport r = Verify(d);
  EXPECT_NE(Problems(r).find("entries/e099/entry.json: job '" + Key(4) + "' is also entry 'e004'"), std::string::npos)
      << Problems(r);
  // …and the same entry twice in the catalog.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((d / "catalog.sqlite").c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db,
                         "CREATE TABLE e2 AS SELECT * FROM entries; DROP TABLE entries; "
                         "CREATE TABLE entries AS SELECT * FROM e2 UNION ALL SELECT * FROM e2 WHERE id='e004';",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  EXPECT_NE(OpenError(d).find((d / "catalog.sqlite").string() + ": entry 'e004' is listed twice"), std::string::npos)
      << OpenError(d);
}

TEST_F(BadReleaseTest, BadSha256SumsLines) {
  // SHA256SUMS names a file that is not there; a line twice; a line leaving the folder.
  const fs::path d = Copy("sums");
  const std::string sums = Slurp(d / "SHA256SUMS");
  WriteFileAtomic(d / "SHA256SUMS", sums + std::string(64, 'a') + "  entries/e001/ghost.ply\n");
  EXPECT_EQ(Verify(d).missing, std::vector<std::string>{"entries/e001/ghost.ply"});
  WriteFileAtomic(d / "SHA256SUMS", sums + sums.substr(0, sums.find('\n') + 1));
  EXPECT_NE(
      Problems(Verify(d)).find("SHA256SUMS:" + std::to_string(std::count(sums.begin(), sums.end(), '\n') + 1) + ": '"),
      std::string::npos)
      << Problems(Verify(d));
  EXPECT_NE(Problems(Verify(d)).find("is listed twice"), std::string::npos);
  WriteFileAtomic(d / "SHA256SUMS", std::string(64, 'a') + "  ../../etc/passwd\n");
  EXPECT_NE(Problems(Verify(d)).find("SHA256SUMS:1"), std::string::npos) << Problems(Verify(d));
}

TEST_F(BadReleaseTest, NewerFormatOrNotAnObject) {
  // Written by a newer drape.
  const fs::path d = Copy("newer");
  Json ds = Json::parse(Slurp(d / "dataset.json"));
  ds["format_version"] = 2;
  WriteFileAtomic(d / "dataset.json", ds.dump(2));
  const std::string e = OpenError(d);
  EXPECT_NE(e.find((d / "dataset.json").string() + ": release format 2 was written by a newer drape"),
            std::string::npos)
      << e;
  EXPECT_NE(Problems(Verify(d)).find("newer drape"), std::string::npos);
  WriteFileAtomic(d / "dataset.json", "[1, 2]");
  EXPECT_NE(OpenError(d).find("dataset.json: expected a JSON object"), std::string::npos) << OpenError(d);
  EXPECT_NE(Problems(Verify(d)).find("expected a JSON object"), std::string::npos);
}

// A disk that fills up mid-build (a 192 KiB tmpfs: ~6 entries of 4 KiB pages fit):
// Commit fails with an error naming the file and "No space left on device", the
// committed entries stay intact, and after space is freed the resumed build — and a
// Finalize that itself ran out of space — give the digest of an undisturbed build.
TEST_F(ReleaseTest, DiskFullStopsCleanlyAndResumesToTheSameDigest) {
  const fs::path mnt = root_ / "small_disk";
  fs::create_directories(mnt);
  if (::mount("tmpfs", mnt.c_str(), "tmpfs", 0, "size=192k") != 0)
    GTEST_SKIP() << "cannot mount a tmpfs (" << std::strerror(errno) << "; needs root): disk-full case not run";
  struct Unmount {
    fs::path p;
    ~Unmount() { ::umount2(p.c_str(), MNT_DETACH); }
  } unmount{mnt};
  const std::string want = Build(root_ / "reference").digest;
  const fs::path dir = mnt / "rel";
  int committed = 0;
  std::string error;
  {
    auto w = ReleaseWriter::Open(dir, MakeMeta());
    for (; committed < kJobs; ++committed) {
      try {
        w->Commit(MakeEntry(committed));
      } catch (const std::exception& e) {
        error = e.what();
        break;
      }
    }
  }
  ASSERT_GT(committed, 0);
  ASSERT_LT(committed, kJobs) << "the small disk never filled up";
  EXPECT_NE(error.find("No space left on device"), std::string::npos) << error;
  EXPECT_NE(error.find(dir.string()), std::string::npos) << error;
  for (int i = 0; i < committed; ++i) {
    const Entry e = MakeEntry(i);
    for (const auto& f : e.files) EXPECT_EQ(Slurp(dir / "entries" / e.id / f.path), f.bytes) << e.id << "/" << f.path;
  }
  ASSERT_EQ(::mount("tmpfs", mnt.c_str(), "tmpfs", MS_REMOUNT, "size=4m"), 0) << std::strerror(errno);
  {
    auto w = ReleaseWriter::Open(dir, MakeMeta(), /*resume=*/true);
    EXPECT_EQ(static_cast<int>(w->DoneKeys().size()), committed);
    for (int i = 0; i < kJobs; ++i)
      if (!w->DoneKeys().count(Key(i))) w->Commit(MakeEntry(i));
    // Fill the disk again so that Finalize (catalog, card, gallery) runs out of space.
    int k = 0;
    for (size_t chunk : {64 * 1024, 4096, 1})
      for (;; ++k) {
        try {
          WriteFileAtomic(mnt / ("filler" + std::to_string(k)), std::string(chunk, 'x'));
        } catch (const Error&) {
          break;
        }
      }
    EXPECT_ANY_THROW(w->Finalize());
  }
  EXPECT_FALSE(fs::exists(dir / "SHA256SUMS"));  // not marked finished
  for (const auto& f : fs::directory_iterator(mnt))
    if (f.path().filename().string().rfind("filler", 0) == 0) fs::remove(f.path());
  auto w = ReleaseWriter::Open(dir, MakeMeta(), /*resume=*/true);
  EXPECT_EQ(static_cast<int>(w->DoneKeys().size()), kJobs);
  EXPECT_EQ(w->Finalize().digest, want);
  EXPECT_TRUE(Verify(dir).ok());
}

TEST_F(ReleaseTest, CoreutilsSha256sumAcceptsSha256Sums) {
  const fs::path dir = root_ / "s";
  Build(dir);
  const std::string cmd = "cd '" + dir.string() + "' && sha256sum --quiet --strict -c SHA256SUMS";
  EXPECT_EQ(std::system(cmd.c_str()), 0);
  // Every file but SHA256SUMS and build.json is listed.
  const auto sums = Slurp(dir / "SHA256SUMS");
  int files = 0;
  for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator(); ++it)
    files += it->is_regular_file();
  EXPECT_EQ(std::count(sums.begin(), sums.end(), '\n'), files - 2);
  std::string b = Slurp(dir / "catalog.sqlite");
  b[100] ^= 0x10;
  WriteFileAtomic(dir / "catalog.sqlite", b);
  EXPECT_NE(std::system((cmd + " >/dev/null 2>&1").c_str()), 0);
}

std::map<std::string, int> CatalogSplitCounts(const fs::path& db_path) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(db_path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(db, "SELECT split, COUNT(*) FROM entries GROUP BY split", -1, &st, nullptr);
  std::map<std::string, int> out;
  while (sqlite3_step(st) == SQLITE_ROW)
    out[reinterpret_cast<const char*>(sqlite3_column_text(st, 0))] = sqlite3_column_int(st, 1);
  sqlite3_finalize(st);
  sqlite3_close(db);
  return out;
}

TEST_F(ReleaseTest, DatasetCardAndDatasetJsonCountsMatchCatalog) {
  const fs::path dir = root_ / "card";
  Build(dir);
  const auto catalog = CatalogSplitCounts(dir / "catalog.sqlite");
  EXPECT_EQ(catalog.size(), 3u);
  // YAML front matter: "  - name: S\n    num_examples: N".
  const std::string card = Slurp(dir / "README.md");
  ASSERT_EQ(card.rfind("---\n", 0), 0u);
  const std::string front = card.substr(4, card.find("\n---\n", 4) - 4);
  std::map<std::string, int> from_card;
  const std::regex re("- name: (\\w+)\\n    num_examples: (\\d+)");
  for (std::sregex_iterator it(front.begin(), front.end(), re), end; it != end; ++it)
    from_card[(*it)[1]] = std::stoi((*it)[2]);
  EXPECT_EQ(from_card, catalog);
  EXPECT_NE(front.find("license: cc-by-4.0"), std::string::npos);
  EXPECT_NE(front.find("task_categories:\n- robotics"), std::string::npos);
  const Json ds = Json::parse(Slurp(dir / "dataset.json"));
  std::map<std::string, int> from_json;
  for (auto it = ds["counts"]["splits"].begin(); it != ds["counts"]["splits"].end(); ++it)
    from_json[it.key()] = it.value().get<int>();
  EXPECT_EQ(from_json, catalog);
  EXPECT_EQ(ds["recipe"]["sha256"], Sha256Hex(MakeMeta().recipe_text));
  EXPECT_EQ(ds["recipe"]["text"], MakeMeta().recipe_text);
  // No wall-clock fields in dataset.json.
  const std::string dtext = Slurp(dir / "dataset.json");
  EXPECT_EQ(dtext.find("seconds"), std::string::npos);
  EXPECT_EQ(dtext.find("started"), std::string::npos);
}

TEST_F(ReleaseTest, CatalogHasTypedColumnsAndReaderRoundTrips) {
  const fs::path dir = root_ / "cat";
  Build(dir);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open_v2((dir / "catalog.sqlite").c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db,
                               "SELECT category, anchor_label, anchor_vertex, fusion_recon_to_truth_mean, "
                               "length(feature), seed, hang_settled FROM entries WHERE id='e003'",
                               -1, &st, nullptr),
            SQLITE_OK)
      << sqlite3_errmsg(db);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)), "pants");
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 1)), "anchor3");
  EXPECT_EQ(sqlite3_column_int(st, 2), 13);
  EXPECT_EQ(sqlite3_column_type(st, 3), SQLITE_FLOAT);
  EXPECT_DOUBLE_EQ(sqlite3_column_double(st, 3), 0.0015 + 0.0001 * 3);
  EXPECT_EQ(sqlite3_column_int(st, 4), 512);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 5)), "18446744073709551612");
  EXPECT_EQ(sqlite3_column_int(st, 6), 1);
  sqlite3_finalize(st);
  sqlite3_close(db);

  const Release r = Release::Open(dir);
  ASSERT_EQ(r.entries().size(), static_cast<size_t>(kJobs));
  EXPECT_EQ(r.job_keys(), MakeMeta().job_keys);
  const Entry e = MakeEntry(3);
  const auto* info = r.Find("e003");
  ASSERT_NE(info, nullptr);
  EXPECT_EQ(info->key, e.key);
  EXPECT_EQ(info->record, e.record);
  EXPECT_EQ(r.ReadFile("e003", "hang.ply"), e.files[0].bytes);
  EXPECT_EQ(r.ReadFile("e003", "sweep/000000.png"), "depth3");
  EXPECT_TRUE(r.Find("e005")->failed);
  EXPECT_EQ(ComputeDigest(r.entries()), r.digest());
  EXPECT_THROW(Release::Open(root_ / "nothing"), Error);
}

TEST_F(ReleaseTest, MergeOfShardsEqualsSingleBuildAndRejectsBadShards) {
  const auto single = Build(root_ / "single");
  auto shard = [&](const std::string& name, const std::vector<int>& jobs, int index, int count,
                   const ReleaseMeta& base = MakeMeta()) {
    ReleaseMeta m = base;
    m.shard_index = index;
    m.shard_count = count;
    for (int i : jobs) m.shard_keys.push_back(Key(i));
    auto w = ReleaseWriter::Open(root_ / name, m);
    for (int i : jobs) w->Commit(MakeEntry(i));
    w->Finalize();
    EXPECT_TRUE(Verify(root_ / name).ok());
    return root_ / name;
  };
  std::vector<int> even, odd, all_but_one;
  for (int i = 0; i < kJobs; ++i) (i % 2 ? odd : even).push_back(i);
  const fs::path s0 = shard("s0", even, 0, 2), s1 = shard("s1", odd, 1, 2);
  const auto merged = Merge({s1, s0}, root_ / "merged");
  EXPECT_EQ(merged.digest, single.digest);
  EXPECT_EQ(Slurp(root_ / "merged" / "SHA256SUMS"), Slurp(root_ / "single" / "SHA256SUMS"));
  EXPECT_TRUE(Verify(root_ / "merged").ok());
  EXPECT_TRUE(CompareReleases(Release::Open(root_ / "merged"), Release::Open(root_ / "single")).same());

  auto expect_error = [&](const std::vector<fs::path>& shards, const std::string& out, const std::string& words) {
    try {
      Merge(shards, root_ / out);
      ADD_FAILURE() << "merge into " << out << " did not fail";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  expect_error({s0}, "m_missing", "in no shard");
  const fs::path over = shard("over", {1, 2, 3, 5, 7, 9, 11}, 1, 2);
  expect_error({s0, over}, "m_overlap", "in both");
  const fs::path other = shard("other", odd, 1, 2, MakeMeta("name: unit\nversion: 1.0.0\nseed: 9\n"));
  expect_error({s0, other}, "m_recipe", "different recipe");
  ReleaseMeta code = MakeMeta();
  code.code_version = "other";
  const fs::path other_code = shard("other_code", odd, 1, 2, code);
  expect_error({s0, other_code}, "m_code", "code_version");
}

TEST_F(ReleaseTest, PublishedReferenceComparison) {
  const fs::path dir = root_ / "pub";
  const auto a = Build(dir);
  // The repo keeps only dataset.json + SHA256SUMS of a published release.
  const fs::path ref = root_ / "datasets" / "unit" / "1.0.0";
  fs::create_directories(ref);
  fs::copy_file(dir / "dataset.json", ref / "dataset.json");
  fs::copy_file(dir / "SHA256SUMS", ref / "SHA256SUMS");
  // A rebuild by other code matches the reference on content.
  ReleaseMeta m = MakeMeta();
  m.code_version = "later-commit";
  Build(root_ / "again", m);
  EXPECT_TRUE(CompareToPublished(root_ / "again", ref).ok());
  // Building straight into the reference folder works and reports the match.
  const auto into = Build(ref, m);
  EXPECT_TRUE(into.matches_published);
  EXPECT_EQ(into.published_digest, a.digest);
  // A content change is named.
  ReleaseMeta changed = MakeMeta("name: unit\nversion: 1.0.0\nseed: 8\n");
  auto w = ReleaseWriter::Open(root_ / "changed", changed);
  for (int i = 0; i < kJobs; ++i) {
    Entry e = MakeEntry(i);
    if (i == 2) e.files[0].bytes += "x";
    w->Commit(e);
  }
  w->Finalize();
  const VerifyReport r = CompareToPublished(root_ / "changed", root_ / "again");
  EXPECT_FALSE(r.ok());
  EXPECT_NE(std::find(r.changed.begin(), r.changed.end(), "entries/e002/hang.ply"), r.changed.end());
}

int CountCards(const std::string& html) {
  int n = 0;
  for (size_t p = html.find("class=\"card"); p != std::string::npos; p = html.find("class=\"card", p + 1)) ++n;
  return n;
}

TEST_F(ReleaseTest, GalleryHasOneCardPerEntry) {
  const fs::path dir = root_ / "g";
  Build(dir);
  const std::string html = Slurp(dir / "index.html");
  EXPECT_EQ(CountCards(html), kJobs);
  EXPECT_NE(html.find("src=\"entries/e000/preview.png\""), std::string::npos);
  EXPECT_EQ(html.find("http://"), std::string::npos);  // nothing from the internet
  EXPECT_EQ(html.find("https://"), std::string::npos);
  EXPECT_NE(html.find("fusion error: 1.50 mm"), std::string::npos);
}

std::string FindChromium() {
  for (const char* c : {"/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome"})
    if (fs::exists(c)) return c;
  return "";
}

std::string RunCommand(const std::string& cmd) {
  std::string out;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), p)) > 0) out.append(buf, n);
  ::pclose(p);
  return out;
}

// Slow-ish (~2 s): starts a real headless browser on the gallery.
TEST_F(ReleaseTest, GalleryInHeadlessChromium) {
  const std::string chromium = FindChromium();
  if (chromium.empty()) GTEST_SKIP() << "chromium not installed (apt-get install chromium)";
  const fs::path dir = root_ / "chrome";
  Build(dir);
  const std::string base = chromium +
                           " --headless --no-sandbox --disable-gpu --user-data-dir=" + (root_ / "profile").string() +
                           " --dump-dom 'file://" + fs::absolute(dir).string() + "/index.html";
  const std::string all = RunCommand(base + "' 2>/dev/null");
  EXPECT_EQ(CountCards(all), kJobs) << all.substr(0, 500);
  EXPECT_NE(all.find("(filters ready)"), std::string::npos);  // the script ran
  EXPECT_NE(all.find("<span id=\"shown\">12</span>"), std::string::npos);
  // Filtering by split through the URL: test entries are i % 4 == 3 → 3 of 12.
  const std::string test = RunCommand(base + "#split=test' 2>/dev/null");
  EXPECT_NE(test.find("<span id=\"shown\">3</span>"), std::string::npos);
  const std::string pants = RunCommand(base + "#split=train&category=pants' 2>/dev/null");
  EXPECT_NE(pants.find("<span id=\"shown\">3</span>"), std::string::npos);  // i = 1, 5, 9
}

}  // namespace
}  // namespace drape
