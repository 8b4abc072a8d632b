// SPDX-License-Identifier: AGPL-3.0-or-later
// JobManager: the coordinator's logic, with no transport. It admits uploads
// (per-user limits, surface check before a job exists), stores jobs and their
// files, runs them through the JobRunner, and serves results in any volume
// format. The gRPC service is a thin adapter on top; tests call this directly.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <string>
#include <string_view>
#include <vector>

#include "job_runner.hpp"
#include "job_store.hpp"
#include "pdrmesh/estimate.hpp"
#include "pdrmesh/status.hpp"

namespace pdrmesh::server {

/// Per-user limits; hitting one is resource_exhausted naming it.
struct UserLimits {
  std::uint64_t max_upload_bytes = 256ULL << 20;  ///< size of one surface file
  int max_queued_jobs = 16;                       ///< queued jobs at once
  int max_running_jobs = 1;                       ///< running at once (more wait queued)
  int max_open_streams = 16;                      ///< uploads, watches and downloads open at once
  double max_upload_s = 600;                      ///< one upload, first byte to last
  /// Estimated tets of one job (estimate.hpp), checked at upload; 0: only the
  /// coordinator's memory budget limits them.
  double max_job_tets = 0;
};

struct ManagerConfig {
  std::filesystem::path data_dir;  ///< jobs.db and jobs/<id>/ live here
  UserLimits limits;
  int runner_threads = 1;  ///< 0: jobs are queued but never run (tests, drain)
  /// Bytes the running jobs' estimated peaks may add up to (a job that does
  /// not fit waits; one over it alone is refused at upload); 0: 80% of the
  /// memory available when the coordinator starts.
  double memory_budget_bytes = 0;
  double default_time_limit_s = 600;
  double max_time_limit_s = 3600;  ///< a job asking for more is refused
  /// Finished jobs older than this (seconds since they finished) are deleted,
  /// record and files, by a sweep every sweep_interval_s; 0: kept until deleted.
  double result_ttl_s = 0;
  double sweep_interval_s = 60;
};

class JobManager {
 public:
  /// Opens the store in `config.data_dir` (created when absent), re-queues the
  /// jobs that were queued or running when the coordinator stopped, and starts
  /// the runner.
  static Result<std::unique_ptr<JobManager>> open(ManagerConfig config, std::unique_ptr<MeshEngine> engine);
  ~JobManager();

  /// Cheap checks before any byte is received: the upload size and the user's
  /// queued-job count against the limits.
  Status admit(std::string_view user, std::uint64_t total_bytes) const;
  /// Checks the surface (parse + surface check) and creates a queued job; a
  /// defective surface is invalid_input naming the defects and creates nothing.
  /// A job whose estimate (estimate.hpp) is over max_job_tets or the memory
  /// budget is resource_exhausted with the estimate and the smallest sensible
  /// size, and creates nothing.
  Result<JobRecord> submit(std::string_view user, std::string_view file_name, std::string_view bytes,
                           JobOptions options);
  Result<JobRecord> get(std::string_view user, std::string_view id);
  Result<std::vector<JobRecord>> list(std::string_view user);
  Result<JobRecord> cancel(std::string_view user, std::string_view id);
  /// Deletes the job's record and files and returns it as it was. A running
  /// job is cancelled first; this waits (at most `wait_s`) for it to stop, and
  /// its thread deletes it when it stops if that takes longer.
  Result<JobRecord> remove(std::string_view user, std::string_view id, double wait_s = 30);
  /// Deletes every job that finished more than result_ttl_s ago (nothing when
  /// the TTL is 0); returns how many. The periodic sweep calls this.
  Result<std::size_t> sweep_expired();
  /// The result file of a succeeded job in the format named by `format`
  /// ("vtu", "lb8.ugrid", ...; empty: meshb), converted once and kept.
  /// not_found unless the job succeeded.
  Result<std::filesystem::path> result_file(std::string_view user, std::string_view id, std::string_view format);

  ChangeSignal& changes() { return changes_; }
  const ManagerConfig& config() const { return config_; }
  /// Stops the expiry sweep and the runner (see JobRunner::stop). Idempotent.
  void stop();

 private:
  JobManager(ManagerConfig config, std::unique_ptr<JobStore> store, std::unique_ptr<MeshEngine> engine);
  /// The refusal of a job whose estimate is over the limits; ok otherwise.
  Status check_estimate(const MeshEstimate& estimate, const SizingOptions& sizing) const;
  /// The estimated peak bytes of a stored job (0 when it cannot be estimated).
  double stored_job_peak_bytes(const JobRecord& job) const;

  ManagerConfig config_;
  std::unique_ptr<JobStore> store_;
  std::unique_ptr<MeshEngine> engine_;
  ChangeSignal changes_;
  JobRunner runner_;
  std::mutex admit_mu_;  ///< makes count-then-create atomic per coordinator
  std::mutex sweep_mu_;
  std::condition_variable sweep_cv_;
  bool sweep_stop_ = false;
  std::thread sweeper_;  ///< runs while result_ttl_s > 0
};

/// The canonical suffix (".vtu", ".lb8.ugrid", ...) of a volume format given
/// without the dot; empty means ".meshb". unsupported for anything else.
Result<std::string> volume_suffix(std::string_view format);

}  // namespace pdrmesh::server
