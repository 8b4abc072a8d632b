// SPDX-License-Identifier: AGPL-3.0-or-later
// The serial meshing pipeline (see pipeline.hpp).
#include "pdrmesh/pipeline.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <thread>
#include <utility>

#include "pdrmesh/estimate.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/pdr.hpp"
#include "pdrmesh/quality.hpp"
#include "pdrmesh/regions.hpp"
#include "pdrmesh/surface_ids.hpp"
#include "pdrmesh/tet_mesh.hpp"
#include "pdrmesh/stopwatch.hpp"

namespace pdrmesh {

namespace {
using Clock = std::chrono::steady_clock;

/// The plan for the sizing options `o` whose h at the surface points is
/// `surface_h` (with --size: the size, clamped): its depth from the estimated
/// tet count (estimate.hpp: the size rises next to wider triangles, a graded
/// field grows away from the surface; the volume over a tet of the surface's
/// spacing would count a far-field box as refined as the body), and with a
/// size its seeds only where h is the size (PdrPlan::sizing).
Result<PdrPlan> plan_for_field(const SurfaceMesh& surface, const SizingOptions& o, double surface_h,
                               const PdrOptions& pdr, const LeafKernel& kernel) {
  PDR_ASSIGN_OR_RETURN(const MeshEstimate estimate, estimate_mesh(surface, o));
  PDR_ASSIGN_OR_RETURN(PdrPlan plan, plan_pdr(surface, surface_h, pdr, kernel, estimate.tets));
  plan.sizing = o;
  return plan;
}

/// The h a plan sizes leaves by, before the field is built (as surface_spacing
/// does): the size, or SizingField::surface_values' h at the surface points
/// summed in point order; none when those values are not all finite.
std::optional<double> planned_spacing(const SurfaceMesh& surface, const SizingOptions& o) {
  if (o.size)
    return std::clamp(*o.size, o.hmin.value_or(0.0), o.hmax.value_or(std::numeric_limits<double>::infinity()));
  Result<std::vector<double>> h = SizingField::surface_values(surface, o);
  if (!h.ok()) return std::nullopt;
  double sum_h = 0;
  for (double v : *h) {
    if (!std::isfinite(v)) return std::nullopt;
    sum_h += v;
  }
  return sum_h / static_cast<double>(h->size());
}

/// run_pdr's plan from the surface alone (plan_for_field at planned_spacing),
/// or none when the spacing or the plan fails.
std::optional<PdrPlan> plan_from_surface(const SurfaceMesh& surface, const ParallelOptions& options,
                                         const LeafKernel& kernel) {
  const std::optional<double> h = planned_spacing(surface, options.sizing);
  if (!h) return std::nullopt;
  Result<PdrPlan> plan = plan_for_field(surface, options.sizing, *h, options.pdr, kernel);
  if (!plan.ok()) return std::nullopt;
  return std::move(*plan);
}
}  // namespace

namespace {

/// mesh_serial of a surface that is one region; `boundary_mesh`, when given,
/// is tetrahedralize(surface, options.tetgen), made by the caller.
Result<SerialResult> mesh_serial_one(const SurfaceMesh& surface, const SerialOptions& options,
                                     const RefineProgress& progress, VolumeMesh* boundary_mesh = nullptr) {
  PDR_TRY(validate(options.sizing));
  PDR_TRY(validate(options.refine));
  if (options.optimize) PDR_TRY(validate(*options.optimize));
  if (options.time_limit_s < 0 || !std::isfinite(options.time_limit_s))
    return invalid_input(fmt::format("time_limit_s must be >= 0 (0: none), got {}", options.time_limit_s));
  SerialResult out;
  auto t = Clock::now();
  // The whole run's deadline: TetGen gets the time left, the refinement stops
  // between passes, and no step starts past it.
  std::optional<Clock::time_point> deadline;
  if (options.time_limit_s > 0)
    deadline = t + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options.time_limit_s));
  const auto past_deadline = [&](std::string_view step) -> Status {
    if (!deadline || Clock::now() < *deadline) return {};
    return deadline_exceeded(fmt::format("the time limit ran out before the {} was done", step));
  };
  TetgenOptions tetgen = options.tetgen;
  if (deadline) tetgen.time_limit_s = std::min(tetgen.time_limit_s, options.time_limit_s);
  VolumeMesh initial;
  if (boundary_mesh != nullptr) {
    initial = std::move(*boundary_mesh);
  } else {
    PDR_ASSIGN_OR_RETURN(initial, tetrahedralize(surface, tetgen));
  }
  out.seconds_initial = seconds_since(t);
  PDR_TRY(past_deadline("initial mesh"));
  // The optimizer takes boundary id 0 for "not the surface" (surface_ids.hpp).
  PDR_ASSIGN_OR_RETURN(const SurfaceIdMap ids, SurfaceIdMap::to_engine(initial.boundary_ids));
  t = Clock::now();
  PDR_ASSIGN_OR_RETURN(SizingField sizing, SizingField::build(surface, initial, options.sizing));
  out.seconds_sizing = seconds_since(t);
  PDR_TRY(past_deadline("sizing"));
  t = Clock::now();
  PDR_ASSIGN_OR_RETURN(TetMesh mesh, TetMesh::from_volume_mesh(initial));
  initial = VolumeMesh{};
  RefineOptions refine_options = options.refine;
  if (deadline) refine_options.deadline = deadline;
  PDR_ASSIGN_OR_RETURN(out.refine, refine(mesh, sizing, refine_options, progress));
  out.seconds_refine = seconds_since(t);
  if (out.refine.stopped_at_deadline) PDR_TRY(past_deadline("refinement"));
  if (options.optimize) {
    PDR_TRY(past_deadline("refinement"));
    t = Clock::now();
    PDR_ASSIGN_OR_RETURN(out.optimize, pdrmesh::optimize(mesh, &sizing, *options.optimize));
    out.seconds_optimize = seconds_since(t);
  }
  out.mesh = mesh.to_volume_mesh();
  ids.to_user(out.mesh.boundary_ids);
  out.mesh.boundary_names = surface.surface_names;  // keyed by the user's ids, as the boundary now is
  return out;
}

}  // namespace

void add_region(SerialResult& all, const SerialResult& part, bool first) {
  all.seconds_initial += part.seconds_initial;
  all.seconds_sizing += part.seconds_sizing;
  all.seconds_refine += part.seconds_refine;
  all.seconds_optimize += part.seconds_optimize;
  all.refine.passes.insert(all.refine.passes.end(), part.refine.passes.begin(), part.refine.passes.end());
  all.refine.points_added += part.refine.points_added;
  all.refine.seconds += part.refine.seconds;
  all.refine.stopped_at_deadline = all.refine.stopped_at_deadline || part.refine.stopped_at_deadline;
  // The optimization's summary: the first region's, with the extremes of all.
  if (first) {
    all.optimize = part.optimize;
    return;
  }
  OptimizeStats& s = all.optimize;
  s.min_dihedral_before = std::min(s.min_dihedral_before, part.optimize.min_dihedral_before);
  s.min_dihedral_after = std::min(s.min_dihedral_after, part.optimize.min_dihedral_after);
  s.max_dihedral_before = std::max(s.max_dihedral_before, part.optimize.max_dihedral_before);
  s.max_dihedral_after = std::max(s.max_dihedral_after, part.optimize.max_dihedral_after);
  s.bad_before += part.optimize.bad_before;
  s.bad_after += part.optimize.bad_after;
  s.seconds += part.optimize.seconds;
}

Result<SerialResult> mesh_serial(const SurfaceMesh& surface, const SerialOptions& options,
                                 const RefineProgress& progress) {
  PDR_ASSIGN_OR_RETURN(const std::vector<SurfaceRegion> regions, surface_regions(surface));
  if (regions.empty()) return mesh_serial_one(surface, options, progress);
  // Each region on its own, within what is left of the time limit.
  const auto start = Clock::now();
  SerialResult out;
  std::vector<VolumeMesh> parts;
  for (const SurfaceRegion& r : regions) {
    SerialOptions o = options;
    if (options.time_limit_s > 0) {
      o.time_limit_s = options.time_limit_s - seconds_since(start);
      if (!(o.time_limit_s > 0))
        return deadline_exceeded(fmt::format("the time limit ran out before region {} was meshed", r.id));
    }
    PDR_ASSIGN_OR_RETURN(SerialResult part, mesh_serial_one(r.domain, o, progress));
    add_region(out, part, parts.empty());
    parts.push_back(std::move(part.mesh));
  }
  PDR_ASSIGN_OR_RETURN(out.mesh, merge_regions(surface, regions, std::move(parts)));
  return out;
}

Status optimize_volume(VolumeMesh& mesh, const SizingField& sizing, const OptimizeOptions& options) {
  PDR_ASSIGN_OR_RETURN(TetMesh tets, TetMesh::from_volume_mesh(mesh));
  PDR_TRY(pdrmesh::optimize(tets, &sizing, options).status());
  mesh = tets.to_volume_mesh();
  return {};
}

namespace {

/// mesh_serial with `options`' sizing and optimization, as a ParallelResult:
/// one leaf (tet_regions all 0) and the serial steps' times in the profile.
/// The TetGen options of the boundary-conforming mesh: the serial mesher's
/// initial mesh and the parallel one's background mesh.
TetgenOptions boundary_only(const ParallelOptions& options) {
  TetgenOptions o;
  o.time_limit_s = options.pdr.tetgen_time_limit_s;
  return o;
}

/// mesh_serial of a surface of one region, from its boundary mesh (tetrahedralize with boundary_only).
Result<ParallelResult> serial_as_parallel(const SurfaceMesh& surface, const ParallelOptions& options,
                                          VolumeMesh boundary_mesh, double boundary_s) {
  const auto t0 = Clock::now();
  SerialOptions so;
  so.sizing = options.sizing;
  so.optimize = options.optimize;
  so.tetgen = boundary_only(options);
  PDR_ASSIGN_OR_RETURN(SerialResult serial, mesh_serial_one(surface, so, {}, &boundary_mesh));
  serial.seconds_initial += boundary_s;
  ParallelResult out;
  out.mesh = std::move(serial.mesh);
  out.mesh.tet_regions.assign(out.mesh.tets.size(), 0);
  PdrProfile& p = out.profile;
  p.initial = serial.seconds_initial;
  p.sizing = serial.seconds_sizing;
  p.leaves = serial.seconds_refine;
  p.task_busy = serial.seconds_refine + serial.seconds_optimize;
  p.optimization = p.global_optimization = serial.seconds_optimize;
  p.leaf_count = 1;
  p.max_concurrency = 1;
  p.final_tets = out.mesh.tets.size();
  p.interior_points = out.mesh.points.size() - surface.points.size();
  p.total = boundary_s + seconds_since(t0);
  out.seconds_sizing = serial.seconds_sizing;
  if (options.pdr.progress) options.pdr.progress({"optimization", 1, 1, out.mesh.tets.size()});
  return out;
}

/// mesh_parallel of a surface that is one region.
Result<ParallelResult> mesh_parallel_one(const SurfaceMesh& surface, const ParallelOptions& options,
                                         const LeafKernel* kernel, const LeafKernel* optimize_kernel,
                                         const LeafKernel* final_optimize_kernel) {
  PDR_TRY(validate(options.sizing));
  if (options.optimize) PDR_TRY(validate(*options.optimize));
  std::unique_ptr<LeafKernel> native;
  if (kernel == nullptr) {
    PDR_ASSIGN_OR_RETURN(native, make_leaf_kernel("native"));
    kernel = native.get();
  }
  // run_pdr's plan from the surface alone (none when resuming), from 2 workers
  // on made beside TetGen's boundary-conforming mesh (its own process: this
  // thread only waits for it). A surface too small for leaf tasks (its depth
  // 0) with the native kernel is the serial mesher's job: its steps, its bytes.
  if (options.pdr.resume == nullptr && options.pdr.progress && !options.pdr.progress({"initial mesh", 0, 0, 0}))
    return cancelled("stopped before the initial mesh");
  std::optional<PdrPlan> surface_plan;
  std::optional<std::thread> planner;
  const auto make_plan = [&] {
    if (options.pdr.resume == nullptr) surface_plan = plan_from_surface(surface, options, *kernel);
  };
  if (options.pdr.workers >= 2) planner.emplace(make_plan);
  auto t = Clock::now();
  Result<VolumeMesh> boundary_mesh = tetrahedralize(surface, boundary_only(options));
  const double background_s = seconds_since(t);
  if (planner) {
    planner->join();
  } else {
    make_plan();
  }
  if (!boundary_mesh.ok()) return boundary_mesh.status();
  if (surface_plan && surface_plan->depth == 0 && !options.pdr.checkpoint && kernel->name() == "native" &&
      !kernel->needs_manifold_hull())
    return serial_as_parallel(surface, options, std::move(*boundary_mesh), background_s);
  const VolumeMesh background = std::move(*boundary_mesh);
  ParallelResult out;
  // TetGen's boundary-conforming mesh is the sizing field's background mesh
  // and, with the seed lattice inserted (initial_mesh), the initial mesh: with
  // a seeds-only plan (the native kernel) TetGen runs once. The plan needs
  // only h at the surface points, which the surface alone gives
  // (SizingField::surface_values), so it is made beside TetGen; the seeds
  // need the field itself, built next.
  t = Clock::now();
  PDR_ASSIGN_OR_RETURN(const SizingField sizing, SizingField::build(surface, background, options.sizing));
  const double build_s = seconds_since(t);
  out.seconds_sizing = background_s + build_s;
  out.boundary_points = sizing.boundary_points();
  PdrOptions pdr = options.pdr;
  pdr.optimize = nullptr;
  pdr.optimize_kernel = nullptr;
  std::unique_ptr<LeafKernel> optimizer, final_optimizer;
  if (options.optimize) {
    const OptimizeOptions opt = leaf_optimize_options(*options.optimize);
    if (optimize_kernel == nullptr) {
      optimizer = optimizing_kernel(opt, "optimize");
      optimize_kernel = optimizer.get();
    }
    if (final_optimize_kernel == nullptr) {
      final_optimizer = optimizing_kernel(final_optimize_options(*options.optimize), "optimize-final");
      final_optimize_kernel = final_optimizer.get();
    }
    pdr.optimize_kernel = optimize_kernel;
    pdr.final_optimize_kernel = final_optimize_kernel;
    pdr.optimize = [&sizing, &options](VolumeMesh& m) { return optimize_volume(m, sizing, *options.optimize); };
    pdr.optimize_selects = [bounds = DihedralBounds(opt.target_min_dihedral, opt.target_max_dihedral)](
                               const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
      return bounds.outside(a, b, c, d);
    };
  }
  // The field's own plan where the surface's differs, and as the run that
  // wrote a checkpoint made it: a resumed run goes on over the same grid from
  // the checkpoint's mesh.
  std::optional<PdrPlan> plan = surface_plan;
  if (const double h = surface_spacing(surface, sizing); !plan || h != plan->surface_h) {
    PDR_ASSIGN_OR_RETURN(plan, plan_for_field(surface, options.sizing, h, pdr, *kernel));
  }
  std::optional<InitialMesh> initial;
  double initial_s = 0;
  if (pdr.resume != nullptr) {
    initial = InitialMesh{std::move(pdr.resume->mesh), {}};
  } else {
    t = Clock::now();
    PDR_ASSIGN_OR_RETURN(initial, initial_mesh(surface, *plan, &background, &sizing));
    initial_s = seconds_since(t);
  }
  PDR_ASSIGN_OR_RETURN(out.mesh, run_pdr(surface, sizing, *kernel, pdr, &out.profile, *plan, std::move(*initial),
                                         initial_s));
  out.profile.background = background_s;
  out.profile.sizing = build_s;
  return out;
}

/// Adds a region's profile to the whole run's: times and counts summed, the
/// depth and the concurrency the largest, the rounds in region order.
void add_profile(PdrProfile& all, PdrProfile&& p) {
  for (auto m : {&PdrProfile::initial, &PdrProfile::decomposition, &PdrProfile::fixups, &PdrProfile::partition_swap,
                 &PdrProfile::boundary_extraction, &PdrProfile::leaves, &PdrProfile::merge,
                 &PdrProfile::interface_round, &PdrProfile::optimization, &PdrProfile::optimization_leaves,
                 &PdrProfile::task_busy, &PdrProfile::global_optimization, &PdrProfile::total,
                 &PdrProfile::background, &PdrProfile::sizing, &PdrProfile::overlapped, &PdrProfile::task_cpu})
    all.*m += p.*m;
  for (auto m : {&PdrProfile::initial_tets, &PdrProfile::leaf_count, &PdrProfile::interface_leaf_count,
                 &PdrProfile::fixup_swaps, &PdrProfile::fixup_moves, &PdrProfile::fixup_unresolved,
                 &PdrProfile::interior_points, &PdrProfile::final_tets, &PdrProfile::failed_leaves})
    all.*m += p.*m;
  all.depth = std::max(all.depth, p.depth);
  all.max_leaf_tets = std::max(all.max_leaf_tets, p.max_leaf_tets);
  all.max_concurrency = std::max(all.max_concurrency, p.max_concurrency);
  all.threads = std::max(all.threads, p.threads);
  if (all.first_failure.empty()) all.first_failure = std::move(p.first_failure);
  for (RoundRecord& r : p.rounds) all.rounds.push_back(std::move(r));
}

}  // namespace

Result<ParallelOptions> region_by_region(const ParallelOptions& options, const SurfaceMesh& surface,
                                         std::size_t regions) {
  if (options.pdr.resume != nullptr)
    return invalid_input(fmt::format("{}: a surface of {} regions cannot resume from a checkpoint", surface.name,
                                     regions));
  ParallelOptions o = options;
  o.pdr.checkpoint = nullptr;
  return o;
}

void add_region(ParallelResult& all, ParallelResult&& part) {
  add_profile(all.profile, std::move(part.profile));
  all.boundary_points += part.boundary_points;
  all.seconds_sizing += part.seconds_sizing;
}

Result<ParallelResult> mesh_parallel(const SurfaceMesh& surface, const ParallelOptions& options,
                                     const LeafKernel* kernel, const LeafKernel* optimize_kernel,
                                     const LeafKernel* final_optimize_kernel) {
  PDR_ASSIGN_OR_RETURN(const std::vector<SurfaceRegion> regions, surface_regions(surface));
  if (regions.empty()) {
    // The engine's tet_regions are the leaves that made the tets: bookkeeping,
    // not material regions, so they do not leave the pipeline.
    PDR_ASSIGN_OR_RETURN(ParallelResult one, mesh_parallel_one(surface, options, kernel, optimize_kernel, final_optimize_kernel));
    one.mesh.tet_regions.clear();
    return one;
  }
  // Each region through the whole parallel method with the same workers, one
  // after the other.
  PDR_ASSIGN_OR_RETURN(const ParallelOptions o, region_by_region(options, surface, regions.size()));
  ParallelResult out;
  std::vector<VolumeMesh> parts;
  for (const SurfaceRegion& r : regions) {
    PDR_ASSIGN_OR_RETURN(ParallelResult part, mesh_parallel_one(r.domain, o, kernel, optimize_kernel, final_optimize_kernel));
    parts.push_back(std::move(part.mesh));
    add_region(out, std::move(part));
  }
  PDR_ASSIGN_OR_RETURN(out.mesh, merge_regions(surface, regions, std::move(parts)));
  out.profile.final_tets = out.mesh.tets.size();
  out.profile.interior_points = out.mesh.points.size() - surface.points.size();
  return out;
}

}  // namespace pdrmesh
