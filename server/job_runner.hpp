// SPDX-License-Identifier: AGPL-3.0-or-later
// JobRunner: a pool of threads that runs queued jobs from the JobStore, one job
// per thread, through a MeshEngine (PdrEngine, pdr_engine.hpp: the parallel
// pipeline with its leaves sent through a LeafDispatch), updating the job's
// phase and progress as it goes.
//
// Fairness between users: one FIFO queue in submission order; a free runner
// thread takes the oldest queued job whose user runs fewer than
// max_running_per_user jobs, so a user with many queued jobs cannot hold every
// thread while another user waits.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <initializer_list>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "job_checkpoint.hpp"
#include "job_store.hpp"
#include "pdrmesh/farfield.hpp"
#include "pdrmesh/layers.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh::server {

/// What a client may ask of a job (the options of `pdrmesh run`); stored as
/// JSON in JobRecord::options_json.
struct JobOptions {
  /// Set: the initial mesh alone with this maximum tet volume (the rest is ignored).
  std::optional<double> max_volume;
  double time_limit_s = 600;
  SizingOptions sizing;  ///< size, hmin, hmax, growth
  int depth = -1;        ///< octree depth 0..10; -1: chosen from the target size
  std::string kernel = "native";  ///< leaf kernel: native or tetgen
  bool interface_round = true;
  bool optimize = true;
  /// Boundary names by surface id over the surface file's own (run --names).
  std::map<int, std::string> surface_names;
  /// External flow (run --farfield): the domain around the surface (farfield.hpp).
  std::optional<FarfieldOptions> farfield;
  /// Prism boundary layers (run --layers), resolved on the job's surface by job_domain.
  std::optional<LayerRequest> layers;

  /// invalid_input naming the first option out of range.
  Status validate() const;
  std::string to_json() const;
  /// invalid_input for malformed JSON, a value of the wrong type or out of range.
  static Result<JobOptions> from_json(std::string_view json);
};

/// What a job meshes: the surface and, with layers, their options on it.
struct JobDomain {
  SurfaceMesh surface;
  std::optional<LayerOptions> layers;
};

/// The domain of a job: `surface` (its names merged with the options'), or
/// with options.farfield the domain around it, checked (require_meshable);
/// with options.layers their walls and first height resolved on it (by
/// default every surface of the body). `name` names the upload in messages.
Result<JobDomain> job_domain(SurfaceMesh surface, const JobOptions& options, std::string_view name);

/// Where a job's files live under the data directory.
struct JobPaths {
  static std::filesystem::path dir(const std::filesystem::path& data_dir, std::string_view id);
  /// The uploaded surface, keeping the suffix of `input_name` (it names the format).
  static std::filesystem::path input(const std::filesystem::path& data_dir, const JobRecord& job);
  /// The result in the format named by `suffix` (".meshb" is the one the runner writes).
  static std::filesystem::path result(const std::filesystem::path& data_dir, std::string_view id,
                                      std::string_view suffix = ".meshb");
  /// The running job's last round checkpoint (JobCheckpoint).
  static std::filesystem::path checkpoint(const std::filesystem::path& data_dir, std::string_view id);
};

/// Writes the pieces, one after the other, to `path` + ".tmp", then renames
/// that over `path`: a reader sees the old file or the whole new one.
Status write_file_atomically(const std::filesystem::path& path, std::initializer_list<std::string_view> pieces);

/// Removes a job's directory, then its record (absent: nothing); failures are
/// logged. In this order a job that is gone has no files, and a stop between
/// the two leaves a record that the next delete or sweep removes again.
void remove_job_files(JobStore& store, const std::filesystem::path& data_dir, std::string_view id);

/// Wakes whoever waits for a change of any job (WatchJob). Never loses a change:
/// waiters remember the version they saw.
class ChangeSignal {
 public:
  void notify();
  std::uint64_t version() const;
  /// Returns when the version differs from `seen` or after `timeout`.
  void wait(std::uint64_t seen, std::chrono::milliseconds timeout) const;

 private:
  mutable std::mutex mu_;
  mutable std::condition_variable cv_;
  std::uint64_t version_ = 0;
};

/// Told by the engine what it is doing. report() may be called often (once per
/// merged leaf): the record is written to the store when the phase changes and
/// at most every few hundred milliseconds otherwise.
class JobProgress {
 public:
  virtual ~JobProgress() = default;
  /// Records the phase and progress (0..1). Returns false when the job must stop
  /// (cancelled, or the coordinator is shutting down): the engine then returns
  /// any error as soon as it can; the runner decides what the job becomes.
  virtual bool report(std::string_view phase, double progress) = 0;
  /// False once the job must stop; cheap, callable from any thread.
  virtual bool keep_going() = 0;
  virtual void mesh_size(std::uint64_t tets, std::uint64_t points) = 0;
  /// Leaves merged of the current round's total (0, 0 outside the rounds).
  virtual void leaves(std::uint64_t done, std::uint64_t total) = 0;
};

/// Turns a checked, meshable surface into a validated volume mesh.
class MeshEngine {
 public:
  virtual ~MeshEngine() = default;
  /// `job`: whose mesh it is (id and user for logs and leaf dispatch).
  /// `checkpoint`: where the engine may store its state after each round and
  /// find the state a former run of the job left (null: nowhere).
  virtual Result<VolumeMesh> mesh(const JobRecord& job, const JobDomain& domain, const JobOptions& options,
                                  JobProgress& progress, const JobCheckpoint* checkpoint) = 0;
};

struct RunnerOptions {
  int threads = 1;                ///< jobs run at once in total; 0: none run (queue only)
  int max_running_per_user = 1;   ///< a user's further jobs wait in the queue
  /// The estimated peak bytes of the running jobs add up to at most this: a
  /// job that does not fit beside them waits (one alone always runs); 0: no budget.
  double memory_budget_bytes = 0;
};

class JobRunner {
 public:
  JobRunner(JobStore& store, std::filesystem::path data_dir, MeshEngine& engine, RunnerOptions options,
            ChangeSignal& changes);
  ~JobRunner();  ///< stops
  JobRunner(const JobRunner&) = delete;
  JobRunner& operator=(const JobRunner&) = delete;

  void start();
  /// Stops taking jobs and joins the threads. A running job is interrupted at
  /// its next phase boundary and goes back to queued (it runs again after a
  /// restart, from its last round checkpoint); the TetGen step itself is not
  /// interrupted.
  void stop();
  /// Appends a queued job (stored already) to the queue, with its estimated
  /// peak bytes (estimate.hpp; 0: unknown, counted as nothing).
  void enqueue(const JobRecord& job, double peak_bytes = 0);
  /// Cancels `job` (read from the store by the caller): a queued job becomes
  /// cancelled now; a running one at its next phase boundary (one that stores
  /// its result first stays succeeded); a final job is returned unchanged.
  /// Returns the job as it is now.
  Result<JobRecord> cancel(const JobRecord& job);
  /// For deleting `job`: a queued job leaves the queue (true: the caller
  /// removes it now); a running one is cancelled and removed (record and
  /// files) by its thread when it stops (false).
  bool cancel_for_removal(const JobRecord& job);

 private:
  struct Entry {
    std::string id;
    std::string user;
    double peak_bytes = 0;
  };
  void loop();
  void run_job(const Entry& entry);
  /// The job's surface, checked and meshed, written as the .meshb result.
  Status mesh_job(JobRecord& job, JobProgress& progress);

  JobStore& store_;
  std::filesystem::path data_dir_;
  MeshEngine& engine_;
  RunnerOptions options_;
  ChangeSignal& changes_;

  std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::deque<Entry> queue_;
  struct Running {
    bool cancel = false;  ///< cancel requested
    bool remove = false;  ///< delete the job when it stops
  };
  std::map<std::string, Running> running_;       ///< job id -> requests
  std::map<std::string, int> running_per_user_;  ///< user -> jobs running
  double running_bytes_ = 0;                     ///< estimated peak bytes of the running jobs
  std::vector<std::thread> threads_;
};

}  // namespace pdrmesh::server
