// catalog.sqlite: written deterministically (one transaction, rows in id order, no
// timestamps) so the same entries give the same bytes.
#include <sqlite3.h>

#include <map>

#include "common/error.h"
#include "common/files.h"
#include "generator/release/release_internal.h"

namespace fs = std::filesystem;

namespace drape::release_detail {
namespace {

class Db {
 public:
  Db(const fs::path& path, int flags) : path_(path.string()) {
    if (sqlite3_open_v2(path_.c_str(), &db_, flags, nullptr) != SQLITE_OK) {
      const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      throw Error(path_ + ": cannot open catalog: " + why);
    }
  }
  ~Db() { sqlite3_close(db_); }
  void Exec(const std::string& sql) {
    char* err = nullptr;
    if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
      const std::string why = err ? err : "?";
      sqlite3_free(err);
      throw Error(path_ + ": " + why + " in: " + sql.substr(0, 200));
    }
  }
  sqlite3_stmt* Prepare(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK)
      throw Error(path_ + ": " + sqlite3_errmsg(db_) +
                  " (not a drape catalog, or truncated/damaged) in: " + sql.substr(0, 200));
    return st;
  }
  void Step(sqlite3_stmt* st) {
    const int rc = sqlite3_step(st);
    if (rc != SQLITE_DONE && rc != SQLITE_ROW) throw Error(path_ + ": " + sqlite3_errmsg(db_));
    sqlite3_reset(st);
    sqlite3_clear_bindings(st);
  }
  const std::string& path() const { return path_; }
  std::string ErrMsg() const { return sqlite3_errmsg(db_); }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
};

// Owns a prepared statement; not copyable, so it is finalized exactly once.
struct Stmt {
  explicit Stmt(sqlite3_stmt* s) : st(s) {}
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;
  ~Stmt() { sqlite3_finalize(st); }
  sqlite3_stmt* st;
};

std::string Quote(const std::string& ident) {
  std::string out = "\"";
  for (char c : ident) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::string Sanitize(const std::string& s) {
  std::string out;
  for (char c : s) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '_') ? c : '_';
  if (out.empty() || std::isdigit(static_cast<unsigned char>(out[0]))) out = "c_" + out;
  return out;
}

// Record leaves: nested object keys joined with '_'; arrays and empty objects as JSON text.
void Flatten(const Json& j, const std::string& prefix, std::vector<std::pair<std::string, const Json*>>* out) {
  if (j.is_object() && !j.empty()) {
    for (auto it = j.begin(); it != j.end(); ++it)
      Flatten(it.value(), prefix.empty() ? it.key() : prefix + "_" + it.key(), out);
  } else {
    out->emplace_back(prefix.empty() ? "record" : prefix, &j);
  }
}

const char* TypeOf(const Json& v) {
  if (v.is_boolean() || v.is_number_integer()) return "INTEGER";  // unsigned counts as integer too
  if (v.is_number_float()) return "REAL";
  return "TEXT";
}

// text_ints: the column holds integers beyond int64 (64-bit seeds), so all its integers
// are stored as exact decimal text.
void Bind(sqlite3_stmt* st, int i, const Json& v, bool text_ints) {
  if (text_ints && (v.is_number_integer())) {
    const std::string s = v.is_number_unsigned() ? std::to_string(v.get<uint64_t>()) : std::to_string(v.get<int64_t>());
    sqlite3_bind_text(st, i, s.c_str(), static_cast<int>(s.size()), SQLITE_TRANSIENT);
  } else if (v.is_null()) {
    sqlite3_bind_null(st, i);
  } else if (v.is_boolean()) {
    sqlite3_bind_int(st, i, v.get<bool>() ? 1 : 0);
  } else if (v.is_number_unsigned()) {
    const uint64_t u = v.get<uint64_t>();
    if (u <= static_cast<uint64_t>(INT64_MAX)) {
      sqlite3_bind_int64(st, i, static_cast<int64_t>(u));
    } else {
      const std::string s = std::to_string(u);  // exact, as text
      sqlite3_bind_text(st, i, s.c_str(), static_cast<int>(s.size()), SQLITE_TRANSIENT);
    }
  } else if (v.is_number_integer()) {
    sqlite3_bind_int64(st, i, v.get<int64_t>());
  } else if (v.is_number_float()) {
    sqlite3_bind_double(st, i, v.get<double>());
  } else {
    const std::string s = v.is_string() ? v.get<std::string>() : v.dump();
    sqlite3_bind_text(st, i, s.c_str(), static_cast<int>(s.size()), SQLITE_TRANSIENT);
  }
}

void BindText(sqlite3_stmt* st, int i, const std::string& s) {
  sqlite3_bind_text(st, i, s.c_str(), static_cast<int>(s.size()), SQLITE_TRANSIENT);
}

}  // namespace

namespace {

// The entries table's columns beyond the fixed ones: one per record leaf (flattened path,
// in first-seen order over entries sorted by id) and one BLOB per blob file.
struct CatalogColumns {
  std::vector<std::string> rec_paths;                          // flattened path
  std::map<std::string, std::string> col_of, type_of;          // path → column, column → type
  std::set<std::string> big_ints;                              // columns stored as decimal text
  std::vector<std::pair<std::string, std::string>> blob_cols;  // file, column
};

CatalogColumns PlanColumns(const std::vector<Release::EntryInfo>& entries, const std::vector<std::string>& blob_files) {
  CatalogColumns c;
  const std::vector<std::string> fixed = {"id",      "key",          "split",       "failed",
                                          "failure", "entry_digest", "record_json", "files_json"};
  std::set<std::string> used(fixed.begin(), fixed.end());
  for (const auto& e : entries) {
    std::vector<std::pair<std::string, const Json*>> leaves;
    Flatten(e.record, "", &leaves);
    for (const auto& [p, v] : leaves) {
      if (!c.col_of.count(p)) {
        std::string col = Sanitize(p);
        if (used.count(col)) col = "record_" + col;
        for (int k = 2; used.count(col); ++k) col = Sanitize(p) + "_" + std::to_string(k);
        used.insert(col);
        c.col_of[p] = col;
        c.rec_paths.push_back(p);
      }
      const std::string& col = c.col_of[p];
      if (!c.type_of.count(col) && !v->is_null()) c.type_of[col] = TypeOf(*v);
      if (v->is_number_unsigned() && v->get<uint64_t>() > static_cast<uint64_t>(INT64_MAX)) c.big_ints.insert(col);
    }
  }
  for (const auto& b : blob_files) {
    std::string col = Sanitize(fs::path(b).stem().string());
    for (int k = 2; used.count(col); ++k) col = Sanitize(fs::path(b).stem().string()) + "_" + std::to_string(k);
    used.insert(col);
    c.blob_cols.emplace_back(b, col);
  }
  return c;
}

void CreateTables(Db& db, const CatalogColumns& cols) {
  std::string create =
      "CREATE TABLE entries (id TEXT PRIMARY KEY, key TEXT NOT NULL UNIQUE, split TEXT NOT NULL, "
      "failed INTEGER NOT NULL, failure TEXT NOT NULL, entry_digest TEXT NOT NULL";
  for (const auto& p : cols.rec_paths) {
    const std::string& c = cols.col_of.at(p);
    create += ", " + Quote(c) + " " +
              (cols.type_of.count(c) && !cols.big_ints.count(c) ? cols.type_of.at(c) : std::string("TEXT"));
  }
  create += ", record_json TEXT NOT NULL, files_json TEXT NOT NULL";
  for (const auto& [f, c] : cols.blob_cols) create += ", " + Quote(c) + " BLOB";
  create += ")";
  db.Exec(create);
  db.Exec(
      "CREATE TABLE files (id TEXT NOT NULL, path TEXT NOT NULL, sha256 TEXT NOT NULL, "
      "size INTEGER NOT NULL, PRIMARY KEY (id, path))");
  db.Exec("CREATE TABLE jobs (position INTEGER PRIMARY KEY, key TEXT NOT NULL UNIQUE, id TEXT)");
  db.Exec("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)");
}

// One entries row (fixed columns, record leaves, record and files JSON, blobs read from
// the entry folder) and its files rows.
void InsertEntry(Db& db, Stmt& se, Stmt& sf, const Release::EntryInfo& e, const CatalogColumns& cols,
                 const fs::path& release_dir) {
  int i = 1;
  BindText(se.st, i++, e.id);
  BindText(se.st, i++, e.key);
  BindText(se.st, i++, e.split);
  sqlite3_bind_int(se.st, i++, e.failed ? 1 : 0);
  BindText(se.st, i++, e.failure);
  BindText(se.st, i++, e.entry_digest);
  std::vector<std::pair<std::string, const Json*>> leaves;
  Flatten(e.record, "", &leaves);
  std::map<std::string, const Json*> by_path(leaves.begin(), leaves.end());
  for (const auto& p : cols.rec_paths) {
    auto it = by_path.find(p);
    if (it == by_path.end())
      sqlite3_bind_null(se.st, i++);
    else
      Bind(se.st, i++, *it->second, cols.big_ints.count(cols.col_of.at(p)) > 0);
  }
  BindText(se.st, i++, e.record.dump());
  Json files = Json::array();
  for (const auto& f : e.files) files.push_back({{"path", f.path}, {"sha256", f.sha256}, {"size", f.size}});
  BindText(se.st, i++, files.dump());
  for (const auto& [fname, col] : cols.blob_cols) {
    bool have = false;
    for (const auto& f : e.files) have = have || f.path == fname;
    if (!have) {
      sqlite3_bind_null(se.st, i++);
      continue;
    }
    const std::string bytes = ReadFile(release_dir / "entries" / e.id / fname);
    sqlite3_bind_blob(se.st, i++, bytes.data(), static_cast<int>(bytes.size()), SQLITE_TRANSIENT);
  }
  db.Step(se.st);
  for (const auto& f : e.files) {
    BindText(sf.st, 1, e.id);
    BindText(sf.st, 2, f.path);
    BindText(sf.st, 3, f.sha256);
    sqlite3_bind_int64(sf.st, 4, static_cast<int64_t>(f.size));
    db.Step(sf.st);
  }
}

// The jobs table: every job key in order, with its entry id (NULL for another shard's).
void InsertJobs(Db& db, const std::vector<std::string>& job_keys, const std::map<std::string, std::string>& id_of_key) {
  Stmt sj{db.Prepare("INSERT INTO jobs VALUES (?,?,?)")};
  for (size_t k = 0; k < job_keys.size(); ++k) {
    sqlite3_bind_int64(sj.st, 1, static_cast<int64_t>(k));
    BindText(sj.st, 2, job_keys[k]);
    auto it = id_of_key.find(job_keys[k]);
    if (it == id_of_key.end())
      sqlite3_bind_null(sj.st, 3);
    else
      BindText(sj.st, 3, it->second);
    db.Step(sj.st);
  }
}

// The meta table: only content-defining facts, no code version, no times (they vary
// between builds).
void InsertMeta(Db& db, const Json& dataset_meta) {
  Stmt sm{db.Prepare("INSERT INTO meta VALUES (?,?)")};
  const Json m{{"name", dataset_meta.value("name", "")},
               {"version", dataset_meta.value("version", "")},
               {"seed", dataset_meta.value("seed", Json()).dump()},
               {"recipe_sha256", dataset_meta["recipe"].value("sha256", "")},
               {"digest", dataset_meta.value("digest", "")},
               {"digest_algorithm", dataset_meta.value("digest_algorithm", "")}};
  for (auto it = m.begin(); it != m.end(); ++it) {
    BindText(sm.st, 1, it.key());
    BindText(sm.st, 2, it.value().get<std::string>());
    db.Step(sm.st);
  }
}

}  // namespace

void WriteCatalog(const fs::path& path, const fs::path& release_dir, const Json& dataset_meta,
                  const std::vector<Release::EntryInfo>& entries, const std::vector<std::string>& job_keys,
                  const std::vector<std::string>& blob_files) {
  Db db(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  // No rollback journal and no WAL: the file is built once, beside its final name.
  db.Exec("PRAGMA journal_mode=OFF; PRAGMA synchronous=OFF; PRAGMA page_size=4096;");
  db.Exec("BEGIN");
  const CatalogColumns cols = PlanColumns(entries, blob_files);
  CreateTables(db, cols);

  std::string ins = "INSERT INTO entries VALUES (?,?,?,?,?,?";
  for (size_t i = 0; i < cols.rec_paths.size() + 2 + cols.blob_cols.size(); ++i) ins += ",?";
  ins += ")";
  Stmt se{db.Prepare(ins)};
  Stmt sf{db.Prepare("INSERT INTO files VALUES (?,?,?,?)")};
  std::map<std::string, std::string> id_of_key;
  for (const auto& e : entries) {
    id_of_key[e.key] = e.id;
    InsertEntry(db, se, sf, e, cols, release_dir);
  }
  InsertJobs(db, job_keys, id_of_key);
  InsertMeta(db, dataset_meta);
  db.Exec("CREATE INDEX entries_split ON entries(split)");
  if (std::find(cols.rec_paths.begin(), cols.rec_paths.end(), "category") != cols.rec_paths.end())
    db.Exec("CREATE INDEX entries_category ON entries(" + Quote(cols.col_of.at("category")) + ")");
  db.Exec("COMMIT");
}

void ReadCatalog(const fs::path& path, std::vector<Release::EntryInfo>* entries, std::vector<std::string>* job_keys) {
  Db db(path, SQLITE_OPEN_READONLY);
  {
    // A truncated file can still answer queries that touch only its first pages.
    Stmt pc{db.Prepare("SELECT page_count * page_size FROM pragma_page_count(), pragma_page_size()")};
    const int64_t want = sqlite3_step(pc.st) == SQLITE_ROW ? sqlite3_column_int64(pc.st, 0) : -1;
    const auto have = static_cast<int64_t>(fs::file_size(path));
    if (want < 0 || have < want)
      throw Error(db.path() + ": truncated (" + std::to_string(have) + " bytes, its header says " +
                  std::to_string(want) + ")");
  }
  Stmt st{db.Prepare(
      "SELECT id, key, split, failed, failure, entry_digest, record_json, files_json FROM entries ORDER BY id")};
  auto text = [](sqlite3_stmt* s, int i) {
    const unsigned char* t = sqlite3_column_text(s, i);
    return t ? std::string(reinterpret_cast<const char*>(t), sqlite3_column_bytes(s, i)) : std::string();
  };
  entries->clear();
  int rc;
  while ((rc = sqlite3_step(st.st)) == SQLITE_ROW) {
    Release::EntryInfo e;
    e.id = text(st.st, 0);
    e.key = text(st.st, 1);
    e.split = text(st.st, 2);
    e.failed = sqlite3_column_int(st.st, 3) != 0;
    e.failure = text(st.st, 4);
    e.entry_digest = text(st.st, 5);
    try {
      e.record = Json::parse(text(st.st, 6));
      for (const auto& f : Json::parse(text(st.st, 7)))
        e.files.push_back(
            {f.at("path").get<std::string>(), f.at("sha256").get<std::string>(), f.at("size").get<uint64_t>()});
    } catch (const Json::exception& ex) {
      throw Error(db.path() + ": entry '" + e.id + "': " + ex.what());
    }
    entries->push_back(std::move(e));
  }
  if (rc != SQLITE_DONE) throw Error(db.path() + ": cannot read entries: " + db.ErrMsg() + " (truncated or damaged?)");
  Stmt sj{db.Prepare("SELECT key FROM jobs ORDER BY position")};
  job_keys->clear();
  while ((rc = sqlite3_step(sj.st)) == SQLITE_ROW) job_keys->push_back(text(sj.st, 0));
  if (rc != SQLITE_DONE) throw Error(db.path() + ": cannot read jobs: " + db.ErrMsg() + " (truncated or damaged?)");
}

}  // namespace drape::release_detail
