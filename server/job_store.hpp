// SPDX-License-Identifier: AGPL-3.0-or-later
// JobStore: the coordinator's durable record of jobs, in SQLite (WAL,
// synchronous=FULL: a job acknowledged to a client survives a crash). The
// surface and result files live in the data directory next to the database;
// the store only records their metadata.
//
// Thread-safe: one connection, serialised by a mutex.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pdrmesh/status.hpp"

struct sqlite3;

namespace pdrmesh::server {

enum class JobState : int { kQueued = 1, kRunning = 2, kSucceeded = 3, kFailed = 4, kCancelled = 5 };

std::string_view to_string(JobState state);
inline bool is_final(JobState s) {
  return s == JobState::kSucceeded || s == JobState::kFailed || s == JobState::kCancelled;
}

/// Milliseconds since the Unix epoch (wall clock; for records, never for ordering decisions).
std::int64_t now_unix_ms();

struct JobRecord {
  std::string id;
  std::string user;
  JobState state = JobState::kQueued;
  std::string phase = "queued";
  double progress = 0;
  std::string options_json = "{}";  ///< see JobOptions (job_runner.hpp)
  std::string input_name;           ///< the uploaded file's name (its suffix names the format)
  std::uint64_t input_bytes = 0;
  std::int64_t created_ms = 0;
  std::int64_t started_ms = 0;   ///< 0: not started
  std::int64_t finished_ms = 0;  ///< 0: not final
  std::string error;             ///< kFailed: why
  std::uint64_t tets = 0;
  std::uint64_t points = 0;
  std::uint64_t leaves_done = 0;   ///< while meshing: leaves merged in this round
  std::uint64_t leaves_total = 0;  ///< and the round's leaves
  std::int64_t seq = 0;  ///< insertion order (assigned by create); queues run in this order
};

class JobStore {
 public:
  /// Opens (creating when absent) the database at `path`.
  static Result<std::unique_ptr<JobStore>> open(const std::filesystem::path& path);
  ~JobStore();
  JobStore(const JobStore&) = delete;
  JobStore& operator=(const JobStore&) = delete;

  /// Inserts a new job; `job.seq` is set. An existing id is an internal error.
  Status create(JobRecord& job);
  /// Writes every field of an existing job (not_found when absent).
  Status update(const JobRecord& job);
  /// not_found when there is no job `id` (or it belongs to another user, when
  /// `user` is given: the message is the same).
  Result<JobRecord> get(std::string_view id, std::optional<std::string_view> user = std::nullopt);
  /// The user's jobs, newest first.
  Result<std::vector<JobRecord>> list(std::string_view user);
  /// Number of the user's jobs in `state`.
  Result<std::int64_t> count(std::string_view user, JobState state);
  /// Deletes job `id`'s record (none: ok).
  Status remove(std::string_view id);
  /// Ids of final jobs (any user) that finished before `before_ms`, oldest first.
  Result<std::vector<std::string>> finished_before(std::int64_t before_ms);
  /// After a restart: every running job goes back to queued (phase "queued",
  /// progress 0); returns all queued jobs in submission order.
  Result<std::vector<JobRecord>> recover();

 private:
  explicit JobStore(sqlite3* db) : db_(db) {}
  Status exec(const char* sql);
  std::mutex mu_;
  sqlite3* db_;
};

}  // namespace pdrmesh::server
