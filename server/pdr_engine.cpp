// SPDX-License-Identifier: AGPL-3.0-or-later
// PdrEngine: mesh_parallel behind the job runner's progress and stop signals.
#include "pdr_engine.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <thread>

#include "pdrmesh/layered_pipeline.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/validate.hpp"

namespace pdrmesh::server {
namespace {

/// See the checkpoint hook in PdrEngine::mesh.
constexpr double kCheckpointSpacing = 20;

/// The job's overall progress (0..1) at a PDR progress report: the rounds take
/// most of the time, leaf by leaf.
double overall(const PdrProgress& p) {
  const double frac = p.leaves_total > 0 ? static_cast<double>(p.leaves_done) / static_cast<double>(p.leaves_total) : 0;
  if (p.phase == "seeds") return 0.18 + 0.02 * frac;
  if (p.phase == "refinement") return 0.2 + 0.4 * frac;
  if (p.phase == "interface round") return 0.6 + 0.1 * frac;
  if (p.phase == "second interface round") return 0.7 + 0.05 * frac;
  if (p.phase == "optimization") return 0.75 + 0.05 * frac;
  if (p.phase == "shifted optimization") return 0.8 + 0.05 * frac;
  return 0.18;  // initial mesh
}

}  // namespace

ParallelOptions parallel_options(const JobOptions& options) {
  ParallelOptions o;
  o.sizing = options.sizing;
  o.pdr.depth = options.depth;
  o.pdr.interface_round = options.interface_round;
  o.pdr.tetgen_time_limit_s = options.time_limit_s;
  if (!options.optimize) o.optimize.reset();
  return o;
}

Result<VolumeMesh> PdrEngine::mesh(const JobRecord& job, const JobDomain& domain, const JobOptions& options,
                                   JobProgress& progress, const JobCheckpoint* checkpoint) {
  const SurfaceMesh& surface = domain.surface;
  const auto start = std::chrono::steady_clock::now();
  const auto deadline = start + std::chrono::duration<double>(options.time_limit_s);
  bool timed_out = false;
  VolumeMesh mesh;
  if (options.max_volume) {
    // The boundary-conforming initial mesh alone, with TetGen's volume bound.
    if (!progress.report("tetrahedralizing", 0.3)) return cancelled("stopped");
    TetgenOptions t;
    t.max_volume = options.max_volume;
    t.time_limit_s = options.time_limit_s;
    PDR_ASSIGN_OR_RETURN(mesh, tetrahedralize(surface, t));
  } else {
    if (!progress.report("sizing", 0.15)) return cancelled("stopped");
    LeafJob leaf_job{job.id, job.user, options.kernel, [&progress] { return progress.keep_going(); }};
    PDR_ASSIGN_OR_RETURN(const std::unique_ptr<LeafKernel> kernel, dispatch_->kernel_for(leaf_job));
    // The optimization's leaf tasks go where the refinement's go (a job's
    // options only switch the optimization on or off: default OptimizeOptions,
    // whose leaf tasks make_leaf_kernel("optimize") runs: leaf_optimize_options(),
    // and its one final task "optimize-final": final_optimize_options()).
    std::unique_ptr<LeafKernel> optimizer, final_optimizer;
    if (options.optimize) {
      leaf_job.kernel = "optimize";
      PDR_ASSIGN_OR_RETURN(optimizer, dispatch_->kernel_for(leaf_job));
      leaf_job.kernel = "optimize-final";
      PDR_ASSIGN_OR_RETURN(final_optimizer, dispatch_->kernel_for(leaf_job));
    }
    ParallelOptions po = parallel_options(options);
    po.pdr.workers = dispatch_->concurrency();
    // Asked again whenever leaf tasks are handed out (on the merging thread):
    // workers that register during the job widen it (the bytes do not depend
    // on it). A change is logged.
    po.pdr.concurrency = [dispatch = dispatch_.get(), &job, last = po.pdr.workers]() mutable {
      const std::size_t now = dispatch->concurrency();
      if (now != last) {
        spdlog::info("job {}: {} leaf task(s) at once, {} before", job.id, now, last);
        last = now;
      }
      return now;
    };
    po.pdr.progress = [&](const PdrProgress& p) {
      if (std::chrono::steady_clock::now() > deadline) {
        timed_out = true;
        return false;
      }
      progress.leaves(p.leaves_done, p.leaves_total);
      progress.mesh_size(p.tets, 0);
      return progress.report(p.phase, overall(p));
    };
    std::optional<PdrCheckpoint> resume;
    if (checkpoint != nullptr) {
      resume = checkpoint->load();
      if (resume) {
        spdlog::info("job {}: resuming after its round {} ({}), {} tets", job.id, resume->rounds_done, resume->round,
                     resume->mesh.tets.size());
        po.pdr.resume = &*resume;
      }
      // A checkpoint is skipped while the time since the last one stored is under
      // kCheckpointSpacing times what storing that one took, so checkpoints cost
      // at most about 1/kCheckpointSpacing of the job (armadillo's 1.4M-tet job
      // stored six of 26-35 MB in 0.10-0.17 s each: 8% of its 9.4 s); a long
      // job's rounds are all stored.
      po.pdr.checkpoint = [&job, checkpoint, since = std::chrono::steady_clock::now(), cost = 0.0,
                           delay = test_checkpoint_delay_](const PdrCheckpoint& c) mutable -> Status {
        const auto t0 = std::chrono::steady_clock::now();
        if (std::chrono::duration<double>(t0 - since).count() < kCheckpointSpacing * cost) {
          spdlog::debug("job {}: no checkpoint after its round {} ({}): the last one is {:.2f} s old", job.id,
                        c.rounds_done, c.round, std::chrono::duration<double>(t0 - since).count());
          return {};
        }
        if (Status s = checkpoint->store(c); !s.ok()) {
          spdlog::warn("job {}: no checkpoint after its round {} ({}): {}", job.id, c.rounds_done, c.round,
                       s.message());
          return {};
        }
        since = std::chrono::steady_clock::now();
        cost = std::chrono::duration<double>(since - t0).count();
        std::error_code ec;
        const auto bytes = std::filesystem::file_size(checkpoint->file(), ec);
        spdlog::info("job {}: checkpoint after its round {} ({}): {:.1f} MB in {:.2f} s", job.id, c.rounds_done,
                     c.round, ec ? 0.0 : static_cast<double>(bytes) / 1e6, cost);
        std::this_thread::sleep_for(delay);
        return {};
      };
    }
    spdlog::debug("job {}: mesh_parallel with the {} kernel, {} leaf task(s) at once", job.id, options.kernel,
                  po.pdr.workers);
    // With layers: the layers made here as `pdrmesh mesh` makes them, the tets
    // that fill the rest by the parallel method.
    Result<VolumeMesh> result = VolumeMesh{};
    if (domain.layers) {
      if (!progress.report("layers", 0.16)) return cancelled("stopped");
      auto layered = mesh_parallel_layered(surface, *domain.layers, po, kernel.get(), optimizer.get(),
                                           final_optimizer.get());
      if (layered.ok()) result = std::move(layered->layered.mesh);
      else result = layered.status();
    } else {
      auto r = mesh_parallel(surface, po, kernel.get(), optimizer.get(), final_optimizer.get());
      if (r.ok()) result = std::move(r->mesh);
      else result = r.status();
    }
    progress.leaves(0, 0);
    if (!result.ok()) {
      if (timed_out) {
        return deadline_exceeded(fmt::format("the job ran past its time limit of {} s ({})", options.time_limit_s,
                                             result.status().message()));
      }
      return result.status();
    }
    mesh = std::move(result).value();
  }
  progress.mesh_size(mesh.tets.size(), mesh.points.size());
  if (!progress.report("validating", 0.9)) return cancelled("stopped");
  const ValidationReport v = validate_mesh(mesh, &surface);
  if (!v.ok()) {
    return internal_error(fmt::format("the generated mesh failed validation (a bug; please report it): {}",
                                      validation_status(v).message()));
  }
  return mesh;
}

}  // namespace pdrmesh::server
