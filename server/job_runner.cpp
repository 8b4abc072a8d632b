// SPDX-License-Identifier: AGPL-3.0-or-later
// JobRunner and the serial MeshEngine.
#include "job_runner.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/surface_check.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"

namespace pdrmesh::server {

// ---------------------------------------------------------------- JobOptions

std::string JobOptions::to_json() const {
  nlohmann::json j;
  if (max_volume) j["max_volume"] = *max_volume;
  j["time_limit_s"] = time_limit_s;
  return j.dump();
}

Result<JobOptions> JobOptions::from_json(std::string_view json) {
  const nlohmann::json j = nlohmann::json::parse(json, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) return invalid_input(fmt::format("job options: not a JSON object: {}", json));
  JobOptions o;
  if (auto it = j.find("max_volume"); it != j.end()) {
    if (!it->is_number() || !(it->get<double>() > 0) || !std::isfinite(it->get<double>()))
      return invalid_input("job options: max_volume must be a positive number");
    o.max_volume = it->get<double>();
  }
  if (auto it = j.find("time_limit_s"); it != j.end()) {
    if (!it->is_number() || !(it->get<double>() > 0) || !std::isfinite(it->get<double>()))
      return invalid_input("job options: time_limit_s must be a positive number");
    o.time_limit_s = it->get<double>();
  }
  return o;
}

// ---------------------------------------------------------------- JobPaths

std::filesystem::path JobPaths::dir(const std::filesystem::path& data_dir, std::string_view id) {
  return data_dir / "jobs" / std::string(id);
}

std::filesystem::path JobPaths::input(const std::filesystem::path& data_dir, const JobRecord& job) {
  return dir(data_dir, job.id) / ("input" + std::filesystem::path(job.input_name).extension().string());
}

std::filesystem::path JobPaths::result(const std::filesystem::path& data_dir, std::string_view id,
                                       std::string_view suffix) {
  return dir(data_dir, id) / ("result" + std::string(suffix));
}

// ---------------------------------------------------------------- ChangeSignal

void ChangeSignal::notify() {
  {
    std::lock_guard lock(mu_);
    ++version_;
  }
  cv_.notify_all();
}

std::uint64_t ChangeSignal::version() const {
  std::lock_guard lock(mu_);
  return version_;
}

void ChangeSignal::wait(std::uint64_t seen, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mu_);
  cv_.wait_for(lock, timeout, [&] { return version_ != seen; });
}

// ---------------------------------------------------------------- SerialEngine

Result<VolumeMesh> SerialEngine::mesh(const SurfaceMesh& surface, const JobOptions& options, JobProgress& progress) {
  VolumeMesh mesh;
  if (options.max_volume) {
    // The boundary-conforming initial mesh alone, with TetGen's volume bound.
    if (!progress.report("tetrahedralizing", 0.3)) return internal_error("stopped");
    TetgenOptions t;
    t.max_volume = options.max_volume;
    t.time_limit_s = options.time_limit_s;
    PDR_ASSIGN_OR_RETURN(mesh, tetrahedralize(surface, t));
  } else {
    // The serial pipeline: initial mesh, refinement, final optimization.
    if (!progress.report("refining", 0.2)) return internal_error("stopped");
    SerialOptions serial;
    serial.tetgen.time_limit_s = options.time_limit_s;
    bool stopped = false;
    auto result = mesh_serial(surface, serial, [&](const RefinePassStats& pass) {
      progress.mesh_size(pass.tets, 0);
      // The refiner has no way to stop between passes yet: a cancelled job
      // finishes its refinement and is then dropped.
      stopped = stopped || !progress.report(fmt::format("refining (pass {})", pass.pass), 0.5);
    });
    if (!result.ok()) return result.status();
    if (stopped) return internal_error("stopped");
    mesh = std::move(result).value().mesh;
  }
  progress.mesh_size(mesh.tets.size(), mesh.points.size());
  if (!progress.report("validating", 0.8)) return internal_error("stopped");
  const ValidationReport v = validate_mesh(mesh, &surface);
  if (!v.ok()) {
    return internal_error(fmt::format("the generated mesh failed validation (a bug; please report it): {}",
                                      validation_status(v).message()));
  }
  return mesh;
}

// ---------------------------------------------------------------- JobRunner

namespace {

Result<std::string> read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return io_error(fmt::format("{}: cannot open the stored surface", path.string()));
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return io_error(fmt::format("{}: reading failed", path.string()));
  return bytes;
}

}  // namespace

class RunnerProgress final : public JobProgress {
 public:
  RunnerProgress(JobRecord& job, JobStore& store, ChangeSignal& changes, std::function<bool()> keep_going)
      : job_(job), store_(store), changes_(changes), keep_going_(std::move(keep_going)) {}
  bool report(std::string_view phase, double progress) override {
    if (!keep_going_()) return false;
    job_.phase = std::string(phase);
    job_.progress = progress;
    if (Status s = store_.update(job_); !s.ok()) spdlog::warn("job {}: {}", job_.id, s.to_string());
    changes_.notify();
    return true;
  }
  void mesh_size(std::uint64_t tets, std::uint64_t points) override {
    job_.tets = tets;
    job_.points = points;
  }

 private:
  JobRecord& job_;
  JobStore& store_;
  ChangeSignal& changes_;
  std::function<bool()> keep_going_;
};

JobRunner::JobRunner(JobStore& store, std::filesystem::path data_dir, MeshEngine& engine, RunnerOptions options,
                     ChangeSignal& changes)
    : store_(store), data_dir_(std::move(data_dir)), engine_(engine), options_(options), changes_(changes) {}

JobRunner::~JobRunner() { stop(); }

void JobRunner::start() {
  std::lock_guard lock(mu_);
  stopping_ = false;
  for (int i = 0; i < options_.threads; ++i) threads_.emplace_back([this] { loop(); });
}

void JobRunner::stop() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  for (auto& t : threads_) t.join();
  threads_.clear();
}

void JobRunner::enqueue(const JobRecord& job) {
  {
    std::lock_guard lock(mu_);
    queue_.push_back({job.id, job.user});
  }
  cv_.notify_all();
}

Result<JobRecord> JobRunner::cancel(const JobRecord& job) {
  if (is_final(job.state)) return job;
  {
    std::lock_guard lock(mu_);
    if (auto it = running_.find(job.id); it != running_.end()) {
      it->second = true;  // the job's thread ends it at the next phase boundary
      return job;
    }
    const auto it = std::find_if(queue_.begin(), queue_.end(), [&](const Entry& e) { return e.id == job.id; });
    if (it == queue_.end()) return job;  // finishing right now: whatever it ends as stands
    queue_.erase(it);
  }
  JobRecord j = job;
  j.state = JobState::kCancelled;
  j.phase = "cancelled";
  j.finished_ms = now_unix_ms();
  PDR_TRY(store_.update(j));
  changes_.notify();
  return j;
}

void JobRunner::loop() {
  for (;;) {
    Entry entry;
    {
      std::unique_lock lock(mu_);
      auto pick = [&] {
        return std::find_if(queue_.begin(), queue_.end(), [&](const Entry& e) {
          return running_per_user_[e.user] < options_.max_running_per_user;
        });
      };
      cv_.wait(lock, [&] { return stopping_ || pick() != queue_.end(); });
      if (stopping_) return;
      const auto it = pick();
      entry = *it;
      queue_.erase(it);
      running_[entry.id] = false;
      ++running_per_user_[entry.user];
    }
    run_job(entry);
    {
      std::lock_guard lock(mu_);
      running_.erase(entry.id);
      --running_per_user_[entry.user];
    }
    cv_.notify_all();
  }
}

Status JobRunner::mesh_job(JobRecord& job, JobProgress& progress) {
  PDR_ASSIGN_OR_RETURN(const JobOptions options, JobOptions::from_json(job.options_json));
  PDR_ASSIGN_OR_RETURN(const SurfaceFormat format, surface_format_from_path(job.input_name));
  if (!progress.report("reading", 0.05)) return internal_error("stopped");
  PDR_ASSIGN_OR_RETURN(const std::string bytes, read_file(JobPaths::input(data_dir_, job)));
  PDR_ASSIGN_OR_RETURN(const SurfaceMesh surface, parse_surface(bytes, format, job.input_name));
  if (!progress.report("checking", 0.1)) return internal_error("stopped");
  PDR_TRY(require_meshable(check_surface(surface), job.input_name));
  PDR_ASSIGN_OR_RETURN(const VolumeMesh mesh, engine_.mesh(surface, options, progress));
  if (!progress.report("writing", 0.9)) return internal_error("stopped");
  const auto final_path = JobPaths::result(data_dir_, job.id);
  auto tmp = final_path;
  tmp += ".tmp";
  PDR_TRY(write_volume(mesh, tmp.string() + ".meshb"));
  std::error_code ec;
  std::filesystem::rename(tmp.string() + ".meshb", final_path, ec);
  if (ec) return io_error(fmt::format("{}: cannot store the result: {}", final_path.string(), ec.message()));
  return {};
}

void JobRunner::run_job(const Entry& entry) {
  auto loaded = store_.get(entry.id);
  if (!loaded.ok()) {
    spdlog::error("job {}: {}", entry.id, loaded.status().to_string());
    return;
  }
  JobRecord job = std::move(loaded).value();
  bool cancelled = false;
  bool stopped = false;
  auto keep_going = [&] {
    std::lock_guard lock(mu_);
    cancelled = running_[entry.id];
    stopped = stopping_;
    return !cancelled && !stopped;
  };
  job.state = JobState::kRunning;
  job.started_ms = now_unix_ms();
  RunnerProgress progress(job, store_, changes_, keep_going);
  spdlog::info("job {} ({}): running", job.id, job.user);
  const Status status = mesh_job(job, progress);
  keep_going();  // reads the latest cancel and stop requests
  if (status.ok()) {  // the result is stored: a cancel or stop that came later changes nothing
    job.state = JobState::kSucceeded;
    job.phase = "done";
    job.progress = 1;
  } else if (cancelled) {
    job.state = JobState::kCancelled;
    job.phase = "cancelled";
  } else if (stopped) {
    job.state = JobState::kQueued;  // runs again after the restart
    job.phase = "queued";
    job.progress = 0;
    job.started_ms = 0;
  } else {
    job.state = JobState::kFailed;
    job.phase = "failed";
    job.error = status.to_string();
  }
  if (is_final(job.state)) job.finished_ms = now_unix_ms();
  if (Status s = store_.update(job); !s.ok()) spdlog::error("job {}: {}", job.id, s.to_string());
  spdlog::info("job {} ({}): {}{}{}", job.id, job.user, to_string(job.state), job.error.empty() ? "" : ": ",
               job.error);
  changes_.notify();
}

}  // namespace pdrmesh::server
