// SPDX-License-Identifier: AGPL-3.0-or-later
// JobManager: admission, storage and results of jobs.
#include "job_manager.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>

#include "pdrmesh/boundary_names.hpp"
#include "pdrmesh/boundary_names_io.hpp"
#include "pdrmesh/surface_check.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/volume_io.hpp"

namespace pdrmesh::server {
namespace {

/// 128 random bits as 32 hex digits (ids are not secrets, but must not collide).
std::string new_job_id() {
  std::random_device rd;
  std::string id;
  for (int i = 0; i < 4; ++i) id += fmt::format("{:08x}", static_cast<std::uint32_t>(rd()));
  return id;
}

}  // namespace

Result<std::string> volume_suffix(std::string_view format) {
  static constexpr std::array<std::string_view, 9> kKnown = {".mesh",     ".meshb", ".vtu", ".ugrid", ".lb8.ugrid",
                                                             ".b8.ugrid", ".msh",   ".su2", ".mapbc"};
  const std::string suffix = format.empty() ? std::string(".meshb") : "." + std::string(format);
  for (std::string_view k : kKnown) {
    if (suffix == k) return suffix;
  }
  return unsupported(fmt::format("unknown volume format '{}'; supported: {} (and .mapbc, a UGRID result's names)",
                                 format, volume_format_suffixes()));
}

JobManager::JobManager(ManagerConfig config, std::unique_ptr<JobStore> store, std::unique_ptr<MeshEngine> engine)
    : config_(std::move(config)),
      store_(std::move(store)),
      engine_(std::move(engine)),
      runner_(*store_, config_.data_dir, *engine_,
              RunnerOptions{config_.runner_threads, config_.limits.max_running_jobs, config_.memory_budget_bytes},
              changes_) {}

JobManager::~JobManager() { stop(); }

void JobManager::stop() {
  {
    std::lock_guard lock(sweep_mu_);
    sweep_stop_ = true;
  }
  sweep_cv_.notify_all();
  if (sweeper_.joinable()) sweeper_.join();
  runner_.stop();
}

Result<std::unique_ptr<JobManager>> JobManager::open(ManagerConfig config, std::unique_ptr<MeshEngine> engine) {
  if (config.memory_budget_bytes <= 0) config.memory_budget_bytes = 0.8 * available_memory_bytes();
  spdlog::info("memory budget of the running jobs: {:.1f} GB ({:.3g} tets in one job)",
               config.memory_budget_bytes / 1e9, tets_for_bytes(config.memory_budget_bytes));
  std::error_code ec;
  std::filesystem::create_directories(config.data_dir / "jobs", ec);
  if (ec) return io_error(fmt::format("{}: cannot create the data directory: {}", config.data_dir.string(), ec.message()));
  PDR_ASSIGN_OR_RETURN(auto store, JobStore::open(config.data_dir / "jobs.db"));
  PDR_ASSIGN_OR_RETURN(const auto queued, store->recover());
  std::unique_ptr<JobManager> m(new JobManager(std::move(config), std::move(store), std::move(engine)));
  for (const JobRecord& j : queued) m->runner_.enqueue(j, m->stored_job_peak_bytes(j));
  if (!queued.empty()) spdlog::info("re-queued {} job(s) from the previous run", queued.size());
  m->runner_.start();
  if (m->config_.result_ttl_s > 0) {
    JobManager* self = m.get();
    m->sweeper_ = std::thread([self] {
      std::unique_lock lock(self->sweep_mu_);
      for (;;) {
        lock.unlock();
        if (auto n = self->sweep_expired(); !n.ok()) spdlog::warn("expiry sweep: {}", n.status().to_string());
        lock.lock();
        if (self->sweep_cv_.wait_for(lock, std::chrono::duration<double>(self->config_.sweep_interval_s),
                                     [self] { return self->sweep_stop_; })) {
          return;
        }
      }
    });
  }
  return m;
}

Status JobManager::admit(std::string_view user, std::uint64_t total_bytes) const {
  if (total_bytes > config_.limits.max_upload_bytes) {
    return resource_exhausted(fmt::format("the upload ({} bytes) exceeds the per-user limit max_upload_bytes={}",
                                          total_bytes, config_.limits.max_upload_bytes));
  }
  PDR_ASSIGN_OR_RETURN(const std::int64_t queued, store_->count(user, JobState::kQueued));
  if (queued >= config_.limits.max_queued_jobs) {
    return resource_exhausted(fmt::format("{} has {} queued jobs, the per-user limit max_queued_jobs={}", user,
                                          queued, config_.limits.max_queued_jobs));
  }
  return {};
}

Result<JobRecord> JobManager::submit(std::string_view user, std::string_view file_name, std::string_view bytes,
                                     JobOptions options) {
  const std::string name = std::filesystem::path(file_name).filename().string();
  if (name.empty()) return invalid_input("the upload has no file name");
  PDR_ASSIGN_OR_RETURN(const SurfaceFormat format, surface_format_from_path(name));
  PDR_TRY(options.validate());
  if (options.time_limit_s > config_.max_time_limit_s) {
    return invalid_input(fmt::format("time limit {} s exceeds the coordinator's max_time_limit_s={}",
                                     options.time_limit_s, config_.max_time_limit_s));
  }
  PDR_TRY(admit(user, bytes.size()));
  // The whole check before anything is stored: a broken surface costs nothing else.
  PDR_ASSIGN_OR_RETURN(SurfaceMesh parsed, parse_surface(bytes, format, name));
  PDR_ASSIGN_OR_RETURN(const JobDomain domain, job_domain(std::move(parsed), options, name));
  const SurfaceMesh& surface = domain.surface;
  // What meshing it would cost, before anything is stored (the initial mesh
  // alone, with max_volume, is TetGen's and bounded by its time limit).
  double peak_bytes = 0;
  if (!options.max_volume) {
    PDR_ASSIGN_OR_RETURN(const MeshEstimate estimate, estimate_mesh(surface, options.sizing));
    PDR_TRY(check_estimate(estimate, options.sizing));
    peak_bytes = estimate.peak_bytes;
  }

  JobRecord job;
  job.id = new_job_id();
  job.user = std::string(user);
  job.options_json = options.to_json();
  job.input_name = name;
  job.input_bytes = bytes.size();
  job.created_ms = now_unix_ms();
  const auto dir = JobPaths::dir(config_.data_dir, job.id);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return io_error(fmt::format("{}: cannot create: {}", dir.string(), ec.message()));
  if (Status s = write_file_atomically(JobPaths::input(config_.data_dir, job), {bytes}); !s.ok()) {
    std::filesystem::remove_all(dir, ec);
    return s;
  }
  {
    std::lock_guard lock(admit_mu_);
    Status s = admit(user, bytes.size());  // again: other uploads may have been queued meanwhile
    if (s.ok()) s = store_->create(job);
    if (!s.ok()) {
      std::filesystem::remove_all(dir, ec);
      return s;
    }
  }
  runner_.enqueue(job, peak_bytes);
  changes_.notify();
  spdlog::info("job {} ({}): queued {} ({} bytes)", job.id, job.user, name, bytes.size());
  return job;
}

Status JobManager::check_estimate(const MeshEstimate& estimate, const SizingOptions& sizing) const {
  const double machine = tets_for_bytes(config_.memory_budget_bytes);
  const double user = config_.limits.max_job_tets;
  const bool user_lower = user > 0 && user < machine;
  const Status s = check_tet_limit(estimate, sizing, user_lower ? user : machine,
                                   user_lower ? "max_job_tets, the coordinator's per-user limit"
                                              : "the coordinator's memory budget");
  if (s.ok()) return s;
  return resource_exhausted(s.message());
}

double JobManager::stored_job_peak_bytes(const JobRecord& job) const {
  auto options = JobOptions::from_json(job.options_json);
  if (!options.ok() || options->max_volume) return 0;
  auto surface = read_surface(JobPaths::input(config_.data_dir, job));
  if (!surface.ok()) return 0;
  auto estimate = estimate_mesh(*surface, options->sizing);
  return estimate.ok() ? estimate->peak_bytes : 0;
}

Result<JobRecord> JobManager::get(std::string_view user, std::string_view id) { return store_->get(id, user); }

Result<std::vector<JobRecord>> JobManager::list(std::string_view user) { return store_->list(user); }

Result<JobRecord> JobManager::cancel(std::string_view user, std::string_view id) {
  PDR_ASSIGN_OR_RETURN(const JobRecord job, store_->get(id, user));
  return runner_.cancel(job);
}

Result<JobRecord> JobManager::remove(std::string_view user, std::string_view id, double wait_s) {
  PDR_ASSIGN_OR_RETURN(JobRecord job, store_->get(id, user));
  if (!is_final(job.state) && !runner_.cancel_for_removal(job)) {
    // Running: its thread deletes it once the cancel takes effect.
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(wait_s);
    for (;;) {
      const std::uint64_t seen = changes_.version();
      const auto now = store_->get(id, user);
      if (!now.ok()) break;  // gone
      if (std::chrono::steady_clock::now() > end) {
        spdlog::warn("job {} ({}): still stopping after {} s; it is deleted when it stops", job.id, job.user, wait_s);
        return job;
      }
      changes_.wait(seen, std::chrono::milliseconds(100));
    }
  } else {
    remove_job_files(*store_, config_.data_dir, job.id);
  }
  changes_.notify();
  spdlog::info("job {} ({}): deleted", job.id, job.user);
  return job;
}

Result<std::size_t> JobManager::sweep_expired() {
  if (config_.result_ttl_s <= 0) return std::size_t{0};
  const auto ttl_ms = static_cast<std::int64_t>(config_.result_ttl_s * 1000.0);
  PDR_ASSIGN_OR_RETURN(const auto ids, store_->finished_before(now_unix_ms() - ttl_ms));
  for (const std::string& id : ids) {
    remove_job_files(*store_, config_.data_dir, id);
    spdlog::info("job {}: expired (finished more than {} h ago): deleted", id, config_.result_ttl_s / 3600);
  }
  if (!ids.empty()) changes_.notify();
  return ids.size();
}

Result<std::filesystem::path> JobManager::result_file(std::string_view user, std::string_view id,
                                                      std::string_view format) {
  PDR_ASSIGN_OR_RETURN(const std::string suffix, volume_suffix(format));
  PDR_ASSIGN_OR_RETURN(const JobRecord job, store_->get(id, user));
  if (job.state != JobState::kSucceeded) {
    return not_found(fmt::format("job {} has no result: it is {}", id, to_string(job.state)));
  }
  const auto meshb = JobPaths::result(config_.data_dir, job.id);
  const auto path = JobPaths::result(config_.data_dir, job.id, suffix);
  if (std::filesystem::exists(path)) return path;
  PDR_ASSIGN_OR_RETURN(VolumeMesh mesh, read_volume(meshb));
  // The names the runner put beside the result (Medit holds none).
  if (const auto names = JobPaths::result(config_.data_dir, job.id, ".names"); std::filesystem::exists(names)) {
    PDR_ASSIGN_OR_RETURN(mesh.boundary_names, read_boundary_names(names));
  }
  if (const auto names = JobPaths::result(config_.data_dir, job.id, ".regions"); std::filesystem::exists(names)) {
    PDR_ASSIGN_OR_RETURN(mesh.region_names, read_boundary_names(names));
  }
  // A private temporary name (concurrent fetches of one format each convert), renamed into place.
  const auto tmp = JobPaths::dir(config_.data_dir, job.id) / fmt::format("tmp-{}{}", new_job_id(), suffix);
  std::error_code ec;
  if (suffix == ".mapbc") {
    PDR_TRY(write_file_atomically(tmp, {format_mapbc(mesh)}));
  } else {
    PDR_TRY(write_volume(mesh, tmp));
    if (suffix.ends_with(".ugrid")) std::filesystem::remove(mapbc_path(tmp), ec);  // fetched as "mapbc"
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) return io_error(fmt::format("{}: cannot store: {}", path.string(), ec.message()));
  return path;
}

}  // namespace pdrmesh::server
