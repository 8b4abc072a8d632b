// SPDX-License-Identifier: AGPL-3.0-or-later
// JobRunner, JobOptions, JobPaths, ChangeSignal.
#include "job_runner.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <functional>
#include <fstream>
#include <iterator>
#include <new>
#include <nlohmann/json.hpp>

#include "pdrmesh/boundary_names.hpp"
#include "pdrmesh/boundary_names_io.hpp"
#include "pdrmesh/digest.hpp"
#include "pdrmesh/layered_pipeline.hpp"
#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/surface_check.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"

namespace pdrmesh::server {

// ---------------------------------------------------------------- JobOptions

Status JobOptions::validate() const {
  auto positive = [](double v, std::string_view name) -> Status {
    if (std::isfinite(v) && v > 0) return {};
    return invalid_input(fmt::format("job option {} must be a finite number > 0, got {}", name, v));
  };
  if (max_volume) PDR_TRY(positive(*max_volume, "max_volume"));
  PDR_TRY(positive(time_limit_s, "time_limit_s"));
  if (Status s = pdrmesh::validate(sizing); !s.ok()) return invalid_input("job option: " + s.message());
  if (depth < -1 || depth > 10) {
    return invalid_input(fmt::format("job option depth must be 0..10 (or unset), got {}", depth));
  }
  if (kernel != "native" && kernel != "tetgen") {
    return invalid_input(fmt::format("job option kernel must be 'native' or 'tetgen', got '{}'", kernel));
  }
  if (farfield) PDR_TRY(check_farfield_distance(farfield->distance, "job option farfield"));
  if (layers) {
    if (max_volume) return invalid_input("job option layers: not with max_volume (the initial mesh alone)");
    if (Status s = pdrmesh::validate(*layers); !s.ok()) return invalid_input("job option layers: " + s.message());
  }
  return check_boundary_names(surface_names, "job option surface_names");
}

Result<JobDomain> job_domain(SurfaceMesh surface, const JobOptions& options, std::string_view name) {
  PDR_TRY(merge_boundary_names(surface.surface_names, surface.surface_ids, options.surface_names,
                               "job option surface_names"));
  std::vector<int> body_ids;
  if (options.farfield) {
    PDR_ASSIGN_OR_RETURN(FarfieldDomain domain, make_farfield(surface, *options.farfield));
    body_ids = domain.body_ids();
    surface = std::move(domain.surface);
  }
  PDR_TRY(require_meshable(check_surface(surface), name));
  JobDomain d;
  if (options.layers) {
    auto layers = resolve_layers(*options.layers, surface, body_ids);
    if (!layers.ok()) return invalid_input("job option layers: " + layers.status().message());
    if (Status s = check_layer_regions(surface, *layers); !s.ok())
      return invalid_input("job option layers: " + s.message());
    d.layers = *layers;
  }
  d.surface = std::move(surface);
  return d;
}

std::string JobOptions::to_json() const {
  nlohmann::json j;
  if (max_volume) j["max_volume"] = *max_volume;
  j["time_limit_s"] = time_limit_s;
  if (sizing.size) j["size"] = *sizing.size;
  if (sizing.hmin) j["hmin"] = *sizing.hmin;
  if (sizing.hmax) j["hmax"] = *sizing.hmax;
  j["growth"] = sizing.growth;
  j["depth"] = depth;
  j["kernel"] = kernel;
  j["interface_round"] = interface_round;
  j["optimize"] = optimize;
  // Only when there are names, so that the options of a job without them read as before.
  for (const auto& [id, name] : surface_names) j["surface_names"][std::to_string(id)] = name;
  if (farfield) {
    j["farfield"] = farfield->distance;
    j["farfield_shape"] = to_string(farfield->shape);
  }
  if (layers) {
    nlohmann::json& l = j["layers"];
    l["count"] = layers->layers;
    l[layers->yplus ? "first_height_yplus" : "first_height"] = layers->first_height;
    if (layers->yplus) l["reynolds"] = layers->reynolds;
    if (layers->reference_length > 0) l["reference_length"] = layers->reference_length;
    l["growth_ratio"] = layers->growth_ratio;
    if (layers->max_thickness) l["max_thickness"] = *layers->max_thickness;
    if (!layers->on.empty()) l["on"] = layers->on;
    if (!layers->in.empty()) l["in"] = layers->in;
  }
  return j.dump();
}

namespace {

/// The layers of a job's options JSON (JobOptions::to_json's "layers").
Result<LayerRequest> layers_from_json(const nlohmann::json& j) {
  if (!j.is_object()) return invalid_input("job option layers must be an object");
  LayerRequest r;
  for (const auto& [key, value] : j.items()) {
    if (key == "on" || key == "in") {
      std::vector<std::string>& names = key == "on" ? r.on : r.in;
      for (const auto& name : value.is_array() ? value : nlohmann::json::array({nullptr})) {
        if (!name.is_string()) return invalid_input(fmt::format("job option layers.{} must be an array of names", key));
        names.push_back(name.get<std::string>());
      }
      continue;
    }
    if (key == "count") {
      if (!value.is_number_integer() || value < 1 || value > 1000)
        return invalid_input(fmt::format("job option layers.count must be 1..1000, got {}", value.dump()));
      r.layers = value.get<int>();
      continue;
    }
    if (!value.is_number()) return invalid_input(fmt::format("job option layers.{} must be a number", key));
    const double x = value.get<double>();
    if (key == "first_height" || key == "first_height_yplus") {
      r.first_height = x;
      r.yplus = key == "first_height_yplus";
    } else if (key == "reynolds") {
      r.reynolds = x;
    } else if (key == "reference_length") {
      r.reference_length = x;
    } else if (key == "growth_ratio") {
      r.growth_ratio = x;
    } else if (key == "max_thickness") {
      r.max_thickness = x;
    } else {
      return invalid_input(fmt::format("job option layers: unknown key {}", nlohmann::json(key).dump()));
    }
  }
  return r;
}

}  // namespace

Result<JobOptions> JobOptions::from_json(std::string_view json) {
  const nlohmann::json j = nlohmann::json::parse(json, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) return invalid_input(fmt::format("job options: not a JSON object: {}", json));
  JobOptions o;
  auto number = [&](const char* key, auto& out) -> Status {
    const auto it = j.find(key);
    if (it == j.end()) return {};
    if (!it->is_number()) return invalid_input(fmt::format("job option {} must be a number", key));
    out = it->get<double>();
    return {};
  };
  PDR_TRY(number("max_volume", o.max_volume));
  PDR_TRY(number("time_limit_s", o.time_limit_s));
  PDR_TRY(number("size", o.sizing.size));
  PDR_TRY(number("hmin", o.sizing.hmin));
  PDR_TRY(number("hmax", o.sizing.hmax));
  PDR_TRY(number("growth", o.sizing.growth));
  if (auto it = j.find("depth"); it != j.end()) {
    if (!it->is_number_integer()) return invalid_input("job option depth must be an integer");
    // Range first: get<int>() would wrap 4294967297 to 1 (found by fuzzing).
    if (*it < -1 || *it > 10) {
      return invalid_input(fmt::format("job option depth must be 0..10 (or unset), got {}", it->dump()));
    }
    o.depth = it->get<int>();
  }
  if (auto it = j.find("kernel"); it != j.end()) {
    if (!it->is_string()) return invalid_input("job option kernel must be a string");
    o.kernel = it->get<std::string>();
  }
  for (auto [key, field] : {std::pair{"interface_round", &o.interface_round}, std::pair{"optimize", &o.optimize}}) {
    if (auto it = j.find(key); it != j.end()) {
      if (!it->is_boolean()) return invalid_input(fmt::format("job option {} must be true or false", key));
      *field = it->get<bool>();
    }
  }
  if (auto it = j.find("surface_names"); it != j.end()) {
    if (!it->is_object()) return invalid_input("job option surface_names must be an object of id: name");
    for (const auto& [key, value] : it->items()) {
      int id = 0;
      const auto [p, ec] = std::from_chars(key.data(), key.data() + key.size(), id);
      if (ec != std::errc() || p != key.data() + key.size() || !value.is_string())
        return invalid_input(fmt::format("job option surface_names: expected \"<int id>\": \"<name>\", got {}: {}",
                                         nlohmann::json(key).dump(), value.dump()));
      o.surface_names[id] = value.get<std::string>();
    }
  }
  if (auto it = j.find("farfield"); it != j.end()) {
    if (!it->is_number()) return invalid_input("job option farfield must be a number");
    o.farfield = FarfieldOptions{it->get<double>(), FarfieldShape::kBox};
    if (auto shape = j.find("farfield_shape"); shape != j.end()) {
      const auto parsed = shape->is_string() ? parse_farfield_shape(shape->get<std::string>()) : std::nullopt;
      if (!parsed) return invalid_input(fmt::format("job option farfield_shape must be \"box\" or \"sphere\", got {}",
                                                    shape->dump()));
      o.farfield->shape = *parsed;
    }
  }
  if (auto it = j.find("layers"); it != j.end()) {
    PDR_ASSIGN_OR_RETURN(o.layers, layers_from_json(*it));
  }
  PDR_TRY(o.validate());
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

std::filesystem::path JobPaths::checkpoint(const std::filesystem::path& data_dir, std::string_view id) {
  return dir(data_dir, id) / "checkpoint.pdrck";
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

// ---------------------------------------------------------------- JobRunner

namespace {

}  // namespace

Status write_file_atomically(const std::filesystem::path& path, std::initializer_list<std::string_view> pieces) {
  auto tmp = path;
  tmp += ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    for (std::string_view bytes : pieces) out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) return io_error(fmt::format("{}: cannot write", tmp.string()));
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) return io_error(fmt::format("{}: cannot store: {}", path.string(), ec.message()));
  return {};
}

void remove_job_files(JobStore& store, const std::filesystem::path& data_dir, std::string_view id) {
  std::error_code ec;
  std::filesystem::remove_all(JobPaths::dir(data_dir, id), ec);
  if (ec) spdlog::warn("job {}: cannot remove its files: {}", id, ec.message());
  if (Status s = store.remove(id); !s.ok()) spdlog::warn("job {}: {}", id, s.to_string());
}

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
    const auto now = std::chrono::steady_clock::now();
    const bool new_phase = job_.phase != phase;
    job_.phase = std::string(phase);
    job_.progress = std::max(job_.progress, progress);
    // Every phase change is stored; within a phase (leaf by leaf) at most every 250 ms.
    if (new_phase || now - last_store_ >= std::chrono::milliseconds(250)) {
      last_store_ = now;
      if (Status s = store_.update(job_); !s.ok()) spdlog::warn("job {}: {}", job_.id, s.to_string());
      changes_.notify();
    }
    return true;
  }
  bool keep_going() override { return keep_going_(); }
  void mesh_size(std::uint64_t tets, std::uint64_t points) override {
    job_.tets = tets;
    job_.points = points;
  }
  void leaves(std::uint64_t done, std::uint64_t total) override {
    job_.leaves_done = done;
    job_.leaves_total = total;
  }

 private:
  JobRecord& job_;
  JobStore& store_;
  ChangeSignal& changes_;
  std::function<bool()> keep_going_;
  std::chrono::steady_clock::time_point last_store_{};
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

void JobRunner::enqueue(const JobRecord& job, double peak_bytes) {
  {
    std::lock_guard lock(mu_);
    queue_.push_back({job.id, job.user, peak_bytes});
  }
  cv_.notify_all();
}

Result<JobRecord> JobRunner::cancel(const JobRecord& job) {
  if (is_final(job.state)) return job;
  {
    std::lock_guard lock(mu_);
    if (auto it = running_.find(job.id); it != running_.end()) {
      it->second.cancel = true;  // the job's thread ends it at its next progress report
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

bool JobRunner::cancel_for_removal(const JobRecord& job) {
  std::lock_guard lock(mu_);
  if (auto it = running_.find(job.id); it != running_.end()) {
    it->second.cancel = true;
    it->second.remove = true;
    return false;
  }
  const auto it = std::find_if(queue_.begin(), queue_.end(), [&](const Entry& e) { return e.id == job.id; });
  if (it != queue_.end()) queue_.erase(it);
  return true;
}

void JobRunner::loop() {
  for (;;) {
    Entry entry;
    {
      std::unique_lock lock(mu_);
      // The oldest job whose user is under the running limit and that fits in
      // the memory budget beside the running jobs (a job alone always fits:
      // admission refused the ones over the budget).
      auto pick = [&] {
        return std::find_if(queue_.begin(), queue_.end(), [&](const Entry& e) {
          const bool fits = options_.memory_budget_bytes <= 0 || running_.empty() ||
                            running_bytes_ + e.peak_bytes <= options_.memory_budget_bytes;
          return running_per_user_[e.user] < options_.max_running_per_user && fits;
        });
      };
      cv_.wait(lock, [&] { return stopping_ || pick() != queue_.end(); });
      if (stopping_) return;
      const auto it = pick();
      entry = *it;
      queue_.erase(it);
      running_[entry.id] = Running{};
      ++running_per_user_[entry.user];
      running_bytes_ += entry.peak_bytes;
    }
    run_job(entry);
    {
      std::lock_guard lock(mu_);
      running_.erase(entry.id);
      --running_per_user_[entry.user];
      running_bytes_ = running_.empty() ? 0 : running_bytes_ - entry.peak_bytes;
    }
    cv_.notify_all();
  }
}

Status JobRunner::mesh_job(JobRecord& job, JobProgress& progress) {
  PDR_ASSIGN_OR_RETURN(const JobOptions options, JobOptions::from_json(job.options_json));
  PDR_ASSIGN_OR_RETURN(const SurfaceFormat format, surface_format_from_path(job.input_name));
  if (!progress.report("reading", 0.05)) return internal_error("stopped");
  PDR_ASSIGN_OR_RETURN(const std::string bytes, read_file(JobPaths::input(data_dir_, job)));
  PDR_ASSIGN_OR_RETURN(SurfaceMesh parsed, parse_surface(bytes, format, job.input_name));
  if (!progress.report("checking", 0.1)) return internal_error("stopped");
  PDR_ASSIGN_OR_RETURN(const JobDomain domain, job_domain(std::move(parsed), options, job.input_name));
  // The result depends on the input, the options and the engine's build alone.
  const JobCheckpoint checkpoint(JobPaths::checkpoint(data_dir_, job.id),
                                 fmt::format("pdrmesh {} build {:016x}\noptions {}\ninput {:016x}\n",
                                             PDRMESH_VERSION, executable_digest(), job.options_json,
                                             content_digest(bytes)));
  PDR_ASSIGN_OR_RETURN(const VolumeMesh mesh, engine_.mesh(job, domain, options, progress, &checkpoint));
  if (!progress.report("writing", 0.95)) return internal_error("stopped");
  const auto final_path = JobPaths::result(data_dir_, job.id);
  auto tmp = final_path;
  tmp += ".tmp";
  PDR_TRY(write_volume(mesh, tmp.string() + ".meshb"));
  // Medit holds no names: they go beside the result (the regions' in
  // result.regions), in place before it is.
  if (!mesh.boundary_names.empty())
    PDR_TRY(write_file_atomically(JobPaths::result(data_dir_, job.id, ".names"),
                                  {format_boundary_names(mesh.boundary_names)}));
  if (!mesh.region_names.empty())
    PDR_TRY(write_file_atomically(JobPaths::result(data_dir_, job.id, ".regions"),
                                  {format_boundary_names(mesh.region_names)}));
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
  // Read from leaf threads too (LeafJob::keep_going): atomics.
  std::atomic<bool> cancelled = false;
  std::atomic<bool> stopped = false;
  bool remove = false;
  auto keep_going = [&] {
    std::lock_guard lock(mu_);
    const Running& r = running_[entry.id];
    cancelled = r.cancel;
    remove = r.remove;
    stopped = stopping_;
    return !cancelled && !stopped;
  };
  job.state = JobState::kRunning;
  job.started_ms = now_unix_ms();
  RunnerProgress progress(job, store_, changes_, keep_going);
  spdlog::info("job {} ({}): running", job.id, job.user);
  // An allocation failure (or any exception) in one job's steps fails that
  // job, not the coordinator: the job's memory is freed as the stack unwinds.
  Status status;
  try {
    status = mesh_job(job, progress);
  } catch (const std::bad_alloc&) {
    status = resource_exhausted(fmt::format("out of memory while meshing (in phase '{}'; a larger --size or "
                                            "fewer jobs at once needs less)", job.phase));
  } catch (const std::exception& e) {
    status = internal_error(fmt::format("unexpected error while meshing (in phase '{}'): {}", job.phase, e.what()));
  }
  keep_going();  // reads the latest cancel and stop requests
  job.leaves_done = job.leaves_total = 0;
  if (remove) {  // DeleteJob asked while it ran: the record and files go
    remove_job_files(store_, data_dir_, job.id);
    spdlog::info("job {} ({}): deleted", job.id, job.user);
    changes_.notify();
    return;
  }
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
  if (job.state != JobState::kSucceeded) {
    // No mesh came of it: the tets merged so far (progress reports carry no
    // point count) would stand beside points 0, and neither describes a result.
    job.tets = job.points = 0;
  }
  if (is_final(job.state)) {
    job.finished_ms = now_unix_ms();
    std::error_code ec;  // a restart resumes from the checkpoint; nothing else does
    std::filesystem::remove(JobPaths::checkpoint(data_dir_, job.id), ec);
  }
  if (Status s = store_.update(job); !s.ok()) spdlog::error("job {}: {}", job.id, s.to_string());
  spdlog::info("job {} ({}): {}{}{}", job.id, job.user, to_string(job.state), job.error.empty() ? "" : ": ",
               job.error);
  changes_.notify();
}

}  // namespace pdrmesh::server
