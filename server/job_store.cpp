// SPDX-License-Identifier: AGPL-3.0-or-later
// JobStore on SQLite: prepared statements, one mutex, errors as io_error naming
// the statement and SQLite's message.
#include "job_store.hpp"

#include <fmt/format.h>
#include <sqlite3.h>

#include <chrono>

namespace pdrmesh::server {
namespace {

constexpr const char* kColumns =
    "id, user, state, phase, progress, options, input_name, input_bytes, created_ms, started_ms, "
    "finished_ms, error, tets, points, leaves_done, leaves_total, seq";

/// A prepared statement, finalized on scope exit.
class Stmt {
 public:
  Stmt(sqlite3* db, const std::string& sql) : db_(db) {
    rc_ = sqlite3_prepare_v2(db, sql.c_str(), static_cast<int>(sql.size()), &s_, nullptr);
  }
  ~Stmt() { sqlite3_finalize(s_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;
  Status prepared(std::string_view what) const {
    if (rc_ == SQLITE_OK) return {};
    return io_error(fmt::format("job database: preparing {}: {}", what, sqlite3_errmsg(db_)));
  }
  void bind(int i, std::string_view v) {
    sqlite3_bind_text(s_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
  }
  void bind(int i, std::int64_t v) { sqlite3_bind_int64(s_, i, v); }
  void bind(int i, double v) { sqlite3_bind_double(s_, i, v); }
  int step() { return sqlite3_step(s_); }
  Status done(int rc, std::string_view what) const {
    if (rc == SQLITE_DONE || rc == SQLITE_ROW) return {};
    return io_error(fmt::format("job database: {}: {}", what, sqlite3_errmsg(db_)));
  }
  std::string text(int i) const {
    const auto* p = sqlite3_column_text(s_, i);
    return p ? std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(sqlite3_column_bytes(s_, i)))
             : std::string();
  }
  std::int64_t i64(int i) const { return sqlite3_column_int64(s_, i); }
  double f64(int i) const { return sqlite3_column_double(s_, i); }

 private:
  sqlite3* db_;
  sqlite3_stmt* s_ = nullptr;
  int rc_;
};

JobRecord read_row(const Stmt& s) {
  JobRecord j;
  j.id = s.text(0);
  j.user = s.text(1);
  j.state = static_cast<JobState>(s.i64(2));
  j.phase = s.text(3);
  j.progress = s.f64(4);
  j.options_json = s.text(5);
  j.input_name = s.text(6);
  j.input_bytes = static_cast<std::uint64_t>(s.i64(7));
  j.created_ms = s.i64(8);
  j.started_ms = s.i64(9);
  j.finished_ms = s.i64(10);
  j.error = s.text(11);
  j.tets = static_cast<std::uint64_t>(s.i64(12));
  j.points = static_cast<std::uint64_t>(s.i64(13));
  j.leaves_done = static_cast<std::uint64_t>(s.i64(14));
  j.leaves_total = static_cast<std::uint64_t>(s.i64(15));
  j.seq = s.i64(16);
  return j;
}

/// Binds every column but seq, as parameters 1..16.
void bind_record(Stmt& s, const JobRecord& j) {
  s.bind(1, j.id);
  s.bind(2, j.user);
  s.bind(3, static_cast<std::int64_t>(j.state));
  s.bind(4, j.phase);
  s.bind(5, j.progress);
  s.bind(6, j.options_json);
  s.bind(7, j.input_name);
  s.bind(8, static_cast<std::int64_t>(j.input_bytes));
  s.bind(9, j.created_ms);
  s.bind(10, j.started_ms);
  s.bind(11, j.finished_ms);
  s.bind(12, j.error);
  s.bind(13, static_cast<std::int64_t>(j.tets));
  s.bind(14, static_cast<std::int64_t>(j.points));
  s.bind(15, static_cast<std::int64_t>(j.leaves_done));
  s.bind(16, static_cast<std::int64_t>(j.leaves_total));
}

Result<std::vector<JobRecord>> query(sqlite3* db, const std::string& sql, std::string_view user,
                                     std::string_view what) {
  Stmt s(db, sql);
  PDR_TRY(s.prepared(what));
  if (!user.empty()) s.bind(1, user);
  std::vector<JobRecord> out;
  int rc;
  while ((rc = s.step()) == SQLITE_ROW) out.push_back(read_row(s));
  PDR_TRY(s.done(rc, what));
  return out;
}

}  // namespace

std::string_view to_string(JobState state) {
  switch (state) {
    case JobState::kQueued: return "queued";
    case JobState::kRunning: return "running";
    case JobState::kSucceeded: return "succeeded";
    case JobState::kFailed: return "failed";
    case JobState::kCancelled: return "cancelled";
  }
  return "unknown";
}

std::int64_t now_unix_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

Result<std::unique_ptr<JobStore>> JobStore::open(const std::filesystem::path& path) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                                 nullptr);
  if (rc != SQLITE_OK) {
    const std::string msg = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
    sqlite3_close(db);
    return io_error(fmt::format("{}: cannot open the job database: {}", path.string(), msg));
  }
  std::unique_ptr<JobStore> store(new JobStore(db));
  sqlite3_busy_timeout(db, 5000);
  PDR_TRY(store->exec("PRAGMA journal_mode=WAL"));
  PDR_TRY(store->exec("PRAGMA synchronous=FULL"));
  PDR_TRY(store->exec(
      "CREATE TABLE IF NOT EXISTS jobs ("
      " seq INTEGER PRIMARY KEY AUTOINCREMENT, id TEXT NOT NULL UNIQUE, user TEXT NOT NULL,"
      " state INTEGER NOT NULL, phase TEXT NOT NULL, progress REAL NOT NULL, options TEXT NOT NULL,"
      " input_name TEXT NOT NULL, input_bytes INTEGER NOT NULL, created_ms INTEGER NOT NULL,"
      " started_ms INTEGER NOT NULL, finished_ms INTEGER NOT NULL, error TEXT NOT NULL,"
      " tets INTEGER NOT NULL, points INTEGER NOT NULL,"
      " leaves_done INTEGER NOT NULL DEFAULT 0, leaves_total INTEGER NOT NULL DEFAULT 0)"));
  // A database made before the leaf counts existed gets their columns.
  for (const char* column : {"leaves_done", "leaves_total"}) {
    Stmt probe(db, fmt::format("SELECT {} FROM jobs LIMIT 0", column));
    if (!probe.prepared("probe").ok()) {
      PDR_TRY(store->exec(fmt::format("ALTER TABLE jobs ADD COLUMN {} INTEGER NOT NULL DEFAULT 0", column).c_str()));
    }
  }
  PDR_TRY(store->exec("CREATE INDEX IF NOT EXISTS jobs_user_state ON jobs(user, state)"));
  return store;
}

JobStore::~JobStore() { sqlite3_close(db_); }

Status JobStore::exec(const char* sql) {
  char* err = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    Status s = io_error(fmt::format("job database: {}: {}", sql, err ? err : "unknown error"));
    sqlite3_free(err);
    return s;
  }
  return {};
}

Status JobStore::create(JobRecord& job) {
  std::lock_guard lock(mu_);
  Stmt s(db_, fmt::format("INSERT INTO jobs ({}) VALUES (?1,?2,?3,?4,?5,?6,?7,?8,?9,?10,?11,?12,?13,?14,?15,?16, NULL)",
                          kColumns));
  PDR_TRY(s.prepared("insert"));
  bind_record(s, job);
  const int rc = s.step();
  if (rc == SQLITE_CONSTRAINT) return internal_error(fmt::format("job database: job id {} exists", job.id));
  PDR_TRY(s.done(rc, "insert"));
  job.seq = sqlite3_last_insert_rowid(db_);
  return {};
}

Status JobStore::update(const JobRecord& job) {
  std::lock_guard lock(mu_);
  Stmt s(db_,
         "UPDATE jobs SET user=?2, state=?3, phase=?4, progress=?5, options=?6, input_name=?7, input_bytes=?8,"
         " created_ms=?9, started_ms=?10, finished_ms=?11, error=?12, tets=?13, points=?14, leaves_done=?15,"
         " leaves_total=?16 WHERE id=?1");
  PDR_TRY(s.prepared("update"));
  bind_record(s, job);
  PDR_TRY(s.done(s.step(), "update"));
  if (sqlite3_changes(db_) == 0) return not_found(fmt::format("no job {}", job.id));
  return {};
}

Result<JobRecord> JobStore::get(std::string_view id, std::optional<std::string_view> user) {
  std::lock_guard lock(mu_);
  Stmt s(db_, fmt::format("SELECT {} FROM jobs WHERE id=?1", kColumns));
  PDR_TRY(s.prepared("get"));
  s.bind(1, id);
  const int rc = s.step();
  PDR_TRY(s.done(rc, "get"));
  if (rc != SQLITE_ROW) return not_found(fmt::format("no job {}", id));
  JobRecord j = read_row(s);
  if (user && j.user != *user) return not_found(fmt::format("no job {}", id));
  return j;
}

Result<std::vector<JobRecord>> JobStore::list(std::string_view user) {
  std::lock_guard lock(mu_);
  return query(db_, fmt::format("SELECT {} FROM jobs WHERE user=?1 ORDER BY seq DESC", kColumns), user, "list");
}

Result<std::int64_t> JobStore::count(std::string_view user, JobState state) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT COUNT(*) FROM jobs WHERE user=?1 AND state=?2");
  PDR_TRY(s.prepared("count"));
  s.bind(1, user);
  s.bind(2, static_cast<std::int64_t>(state));
  const int rc = s.step();
  PDR_TRY(s.done(rc, "count"));
  return s.i64(0);
}

Status JobStore::remove(std::string_view id) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "DELETE FROM jobs WHERE id=?1");
  PDR_TRY(s.prepared("delete"));
  s.bind(1, id);
  return s.done(s.step(), "delete");
}

Result<std::vector<std::string>> JobStore::finished_before(std::int64_t before_ms) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT id FROM jobs WHERE state IN (?1, ?2, ?3) AND finished_ms < ?4 ORDER BY finished_ms, seq");
  PDR_TRY(s.prepared("expired"));
  s.bind(1, static_cast<std::int64_t>(JobState::kSucceeded));
  s.bind(2, static_cast<std::int64_t>(JobState::kFailed));
  s.bind(3, static_cast<std::int64_t>(JobState::kCancelled));
  s.bind(4, before_ms);
  std::vector<std::string> ids;
  int rc;
  while ((rc = s.step()) == SQLITE_ROW) ids.push_back(s.text(0));
  PDR_TRY(s.done(rc, "expired"));
  return ids;
}

Result<std::vector<JobRecord>> JobStore::recover() {
  std::lock_guard lock(mu_);
  Stmt s(db_, "UPDATE jobs SET state=?1, phase='queued', progress=0, started_ms=0, leaves_done=0, leaves_total=0"
              " WHERE state=?2");
  PDR_TRY(s.prepared("recover"));
  s.bind(1, static_cast<std::int64_t>(JobState::kQueued));
  s.bind(2, static_cast<std::int64_t>(JobState::kRunning));
  PDR_TRY(s.done(s.step(), "recover"));
  return query(db_,
               fmt::format("SELECT {} FROM jobs WHERE state={} ORDER BY seq", kColumns,
                           static_cast<int>(JobState::kQueued)),
               "", "recover");
}

}  // namespace pdrmesh::server
