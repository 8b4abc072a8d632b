// SPDX-License-Identifier: AGPL-3.0-or-later
// The PDR engine: initial mesh, buffered rounds (or frozen leaves with fix-ups
// and interface rounds), merge, optimization rounds. See pdr.hpp for the
// numbering and determinism argument.
#include "pdrmesh/pdr.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <oneapi/tbb/parallel_for.h>

#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/refine.hpp"
#include "pdrmesh/stopwatch.hpp"
#include "pdrmesh/surface_ids.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/validate.hpp"
#include "rounds.hpp"

namespace pdrmesh {

namespace {
using Clock = std::chrono::steady_clock;

/// Sweeps of buffered rounds at most (PdrOptions::buffered).
constexpr int kMaxSweeps = 3;
/// The final optimization's grid is this many levels coarser than the
/// refinement's: its tasks' selections (bad tets and their halo) and buffers
/// reach several tets beyond a leaf, and in a grid as fine as the
/// refinement's two buffers of one round would meet and block each other.
/// A coarser grid makes a few tasks the long pole of their rounds.
constexpr int kFinalCoarsening = 2;
/// The seed rounds' leaves are at least this many seed lattice spacings wide.
constexpr double kSeedLeafSpacings = 6;
/// Where the final grid would be shallower than this, one task takes the
/// whole selection: with few leaves per colour the rounds cost more than the
/// task, and next to wide input triangles (hinge at diag/100, depth 4) the
/// rounds' cuts leave worse angles than the single task.
constexpr int kMinFinalDepth = 3;
/// Tets per point in a refined mesh, a little under what quality meshes have.
constexpr double kTetsPerPoint = 5;
/// Room for this many times the plan's estimated tets: room costs address
/// space, not memory, and an estimate a few percent short (armadillo at
/// --size 0.12%: 1.0e8 for 1.08e8) would have the last rounds copy the mesh.
constexpr double kRoomOverEstimate = 1.25;

/// Room for n items in v, so that it grows in place up to n: a vector that
/// outgrows its room is copied whole by one thread, into memory that one
/// thread first touches. Only room: where the memory is not to be had, v
/// grows as it goes.
template <class Vector>
void reserve_room(Vector& v, std::size_t n) noexcept {
  try {
    v.reserve(n);
  } catch (const std::exception&) {  // std::bad_alloc, std::length_error
  }
}

/// The tets to make room for when a plan expects `tets`.
std::size_t room_for(double tets) {
  return static_cast<std::size_t>(std::clamp(tets * kRoomOverEstimate, 0.0, double{std::numeric_limits<Index>::max()}));
}

/// Room in `m` for the `tets` a plan expects and their points.
void reserve_for(VolumeMesh& m, double tets) {
  const std::size_t n = room_for(tets);
  reserve_room(m.tets, n);
  reserve_room(m.tet_regions, n);
  reserve_room(m.points, static_cast<std::size_t>(static_cast<double>(n) / kTetsPerPoint));
}

}  // namespace

double surface_spacing(const SurfaceMesh& surface, const SizingField& sizing) {
  if (const std::optional<double> size = sizing.requested_size()) return *size;  // the volume's h, not the rise
  // The queries side by side, summed in point order: the same sum on any number of threads.
  std::vector<double> h(surface.points.size());
  tbb::parallel_for(std::size_t{0}, h.size(), [&](std::size_t i) { h[i] = sizing.at(surface.points[i]); });
  double sum_h = 0;
  for (double v : h) sum_h += v;
  return sum_h / static_cast<double>(surface.points.size());
}

Result<PdrPlan> plan_pdr(const SurfaceMesh& surface, double surface_h, const PdrOptions& options,
                         const LeafKernel& kernel, double estimated_tets) {
  if (options.depth > kMaxDepth) {
    return invalid_input(fmt::format("octree depth {} is outside [0, {}] (or -1)", options.depth, kMaxDepth));
  }
  if (!(options.min_leaf_width >= 0) || !std::isfinite(options.min_leaf_width)) {
    return invalid_input(fmt::format("min_leaf_width must be finite and not negative, got {}", options.min_leaf_width));
  }
  if (!(options.initial_volume_divisor > 0) || !std::isfinite(options.initial_volume_divisor)) {
    return invalid_input(fmt::format("initial_volume_divisor must be positive, got {}", options.initial_volume_divisor));
  }
  if (surface.points.empty() || surface.triangles.empty()) {
    return invalid_input(fmt::format("{}: the surface is empty", surface.name));
  }
  const Box bb = surface.bounds();
  const double side = std::max({bb.hi[0] - bb.lo[0], bb.hi[1] - bb.lo[1], bb.hi[2] - bb.lo[2]});
  PdrPlan plan;
  plan.surface_h = surface_h;
  plan.depth = options.depth;
  const bool buffered = options.buffered && !options.fixups.value_or(kernel.needs_manifold_hull());
  const double volume = enclosed_volume(surface);
  const double estimate = estimated_tets >= 0 ? estimated_tets : volume / regular_tet_volume(surface_h);
  const double capped = std::isfinite(estimate) ? std::clamp(estimate, 0.0, 1e15) : 0.0;
  plan.estimated_tets = capped;
  if (plan.depth < 0) {
    const std::size_t per_leaf =
        options.final_tets_per_leaf > 0 ? options.final_tets_per_leaf : buffered ? 5000 : 20000;
    plan.depth = capped < static_cast<double>(options.min_parallel_tets)
                     ? 0
                     : default_depth(static_cast<std::size_t>(capped), per_leaf,
                                     [&](int d) { return occupied_leaves_estimate(surface.points, volume, d); });
  }
  if (options.min_leaf_width > 0 && std::isfinite(surface_h) && surface_h > 0) {
    const int asked = plan.depth;
    while (plan.depth > 0 && side / static_cast<double>(1 << plan.depth) < options.min_leaf_width * surface_h)
      --plan.depth;
    if (plan.depth != asked) plan.requested_depth = asked;
  }
  TetgenOptions& tg = plan.tetgen;
  const double leaf_side = side / static_cast<double>(1 << plan.depth);
  plan.seed_min_tets = options.initial_min_volume_factor.value_or(buffered ? 16 : 2);
  tg.max_volume = std::max(leaf_side * leaf_side * leaf_side / options.initial_volume_divisor,
                           plan.seed_min_tets * regular_tet_volume(surface_h));
  tg.time_limit_s = options.tetgen_time_limit_s;
  tg.radius_edge = options.initial_radius_edge;
  tg.seeds_only = options.initial_seeds_only.value_or(!kernel.needs_manifold_hull());
  if (!(*tg.max_volume > 0) || !std::isfinite(*tg.max_volume)) tg.max_volume.reset();
  // One leaf needs no seeds to balance: start from the boundary-conforming
  // mesh that the serial pipeline refines (with seeds sphere966, depth 0 by
  // default, made 0.963 times the serial tets).
  if (plan.depth == 0 && tg.seeds_only) tg.max_volume.reset();
  plan.leaf_seeds = tg.seeds_only && tg.max_volume && buffered && plan.depth > 0 && kernel.name() == "native";
  return plan;
}

Result<InitialMesh> initial_mesh(const SurfaceMesh& surface, const PdrPlan& plan, const VolumeMesh* background,
                                 const SizingField* sizing) {
  InitialMesh out;
  if (!plan.tetgen.seeds_only || !plan.tetgen.max_volume) {
    PDR_ASSIGN_OR_RETURN(out.mesh, tetrahedralize(surface, plan.tetgen));
    return out;
  }
  std::optional<VolumeMesh> made;
  if (background == nullptr) {
    TetgenOptions boundary_only;
    boundary_only.time_limit_s = plan.tetgen.time_limit_s;
    PDR_ASSIGN_OR_RETURN(made, tetrahedralize(surface, boundary_only));
    background = &*made;
  }
  std::optional<SizingField> built;
  if (sizing == nullptr) {
    PDR_ASSIGN_OR_RETURN(built, SizingField::build(surface, *background, plan.sizing));
    sizing = &*built;
  }
  const SizingField& h = *sizing;
  // No seed denser than seed_min_tets regular tets of the local h: the lattice
  // thins out where the field is coarser than the plan's surface_h.
  const auto widest = [&h, tets = plan.seed_min_tets](const Vec3& p) {
    return seed_spacing(tets * regular_tet_volume(h.at(p)));
  };
  PDR_ASSIGN_OR_RETURN(std::vector<Vec3> seeds, seed_points(surface, *plan.tetgen.max_volume, widest));
  if (const std::optional<double> size = h.requested_size(); plan.sizing.size && size && !h.uniform()) {
    std::vector<char> rises(seeds.size());
    tbb::parallel_for(std::size_t{0}, seeds.size(), [&](std::size_t i) { rises[i] = h.at(seeds[i]) > *size; });
    std::size_t kept = 0;
    for (std::size_t i = 0; i < seeds.size(); ++i)
      if (!rises[i]) seeds[kept++] = seeds[i];
    seeds.resize(kept);
  }
  if (plan.leaf_seeds) {
    std::vector<Vec3> coarse;
    for (std::size_t i = 0; i < seeds.size(); ++i)
      (insertion_round(i) < kInsertionRounds - 1 ? coarse : out.leaf_seeds).push_back(seeds[i]);
    seeds = std::move(coarse);
  }
  PDR_ASSIGN_OR_RETURN(TetMesh mesh, TetMesh::from_volume_mesh(*background));
  made.reset();
  PDR_TRY(insert_points(mesh, seeds).status());
  out.mesh = mesh.to_volume_mesh();
  out.mesh.boundary_names = surface.surface_names;
  return out;
}

Result<VolumeMesh> run_pdr(const SurfaceMesh& surface, const SizingField& sizing, const LeafKernel& kernel,
                           const PdrOptions& options, PdrProfile* profile) {
  const auto t0 = Clock::now();
  if (surface.points.empty() || surface.triangles.empty()) {
    return invalid_input(fmt::format("{}: the surface is empty", surface.name));
  }
  PDR_ASSIGN_OR_RETURN(const PdrPlan plan, plan_pdr(surface, surface_spacing(surface, sizing), options, kernel));
  if (options.resume != nullptr) {
    return run_pdr(surface, sizing, kernel, options, profile, plan, InitialMesh{std::move(options.resume->mesh), {}}, 0);
  }
  if (options.progress && !options.progress({"initial mesh", 0, 0, 0})) {
    return cancelled("stopped before the initial mesh");
  }
  Result<InitialMesh> initial = initial_mesh(surface, plan, nullptr, &sizing);
  if (!initial.ok()) return initial.status();
  return run_pdr(surface, sizing, kernel, options, profile, plan, std::move(*initial), seconds_since(t0));
}

Result<VolumeMesh> run_pdr(const SurfaceMesh& surface, const SizingField& sizing, const LeafKernel& kernel,
                           const PdrOptions& options, PdrProfile* profile, const PdrPlan& plan, InitialMesh initial,
                           double initial_s) {
  using namespace round_detail;
  const auto t_total = Clock::now();
  PdrProfile local;
  PdrProfile& prof = profile ? *profile : local;
  prof = PdrProfile{};
  const int depth = plan.depth;
  prof.depth = depth;
  prof.requested_depth = plan.requested_depth;
  prof.threads = static_cast<std::size_t>(tbb::this_task_arena::max_concurrency());
  const auto report = [&](std::string_view phase, std::size_t tets) {
    return !options.progress || options.progress({phase, 0, 0, tets});
  };
  prof.initial = initial_s;
  prof.initial_tets = initial.mesh.tets.size();
  VolumeMesh cur = std::move(initial.mesh);
  reserve_for(cur, plan.estimated_tets);
  RoundScratch scratch;  // the rounds' copies of the tets of no task, room for the whole mesh
  const std::size_t room = room_for(plan.estimated_tets);
  reserve_room(scratch.outside, room);
  reserve_room(scratch.outside_leaf, room);
  if (options.resume != nullptr && cur.tet_regions.size() != cur.tets.size()) {
    return invalid_input("PDR checkpoint: its mesh has no leaf for each tet");
  }
  // Leaf tasks mark interfaces with id 0, so the surface gets engine ids >= 1
  // (surface_ids.hpp), given back to the user's at the end.
  PDR_ASSIGN_OR_RETURN(SurfaceIdMap ids, SurfaceIdMap::to_engine(cur.boundary_ids));
  const FaceIdTable boundary(cur.boundary, cur.boundary_ids);
  const bool fixups = options.fixups.value_or(kernel.needs_manifold_hull());

  // The grid's root cube: every point lies inside the surface, so a resumed
  // run's mesh gives the initial mesh's cube.
  Box bounds;
  for (const Vec3& p : cur.points) bounds.add(p);
  const Box box1 = root_cube(bounds);
  Box box2 = box1;
  const double half = 0.5 * (box1.hi[0] - box1.lo[0]) / static_cast<double>(1 << depth);
  for (int k = 0; k < 3; ++k) {
    box2.lo[k] += half;
    box2.hi[k] += half;
  }
  // Each step below is one round: skipped when the checkpoint resumed from
  // did it, followed by the checkpoint hook (the surface's own ids there).
  const int resumed_rounds = options.resume != nullptr ? options.resume->rounds_done : 0;
  int rounds_done = 0;
  const auto step = [&](std::string_view name, const std::function<Status()>& body) -> Status {
    if (++rounds_done <= resumed_rounds) return {};
    PDR_TRY(body());
    if (!options.checkpoint) return {};
    ids.to_user(cur.boundary_ids);
    PdrCheckpoint c{rounds_done, std::string(name), std::move(cur)};
    const Status s = options.checkpoint(c);
    cur = std::move(c.mesh);
    PDR_ASSIGN_OR_RETURN(ids, SurfaceIdMap::to_engine(cur.boundary_ids));
    return s;
  };
  const auto account = [&](RoundResult&& r) {
    prof.partition_swap += r.fixups.swap_s;
    prof.boundary_extraction += r.fixups.extraction_s;
    prof.fixup_swaps += r.fixups.swaps;
    prof.fixup_moves += r.fixups.moves;
    prof.fixup_unresolved += r.fixups.unresolved;
    prof.merge += r.merge_s;
    prof.task_busy += r.schedule.busy_s;
    prof.task_cpu += r.cpu_s;
    prof.max_concurrency = std::max(prof.max_concurrency, r.schedule.max_concurrency);
    if (r.failed > 0 && prof.failed_leaves == 0) prof.first_failure = r.first_failure;
    prof.failed_leaves += r.failed;
    prof.rounds.push_back(std::move(r.record));
  };
  /// A round over a new decomposition of `cur` at `box`, sending each leaf
  /// the tets `select` flags (one per tet of `cur`; none: every tet).
  using Selector = std::function<std::vector<char>()>;
  const auto round = [&](std::string_view phase, const Box& box, const LeafKernel& k, bool fix, int round_depth,
                         const Selector& select) -> Status {
    return step(phase, [&]() -> Status {
      const auto td = Clock::now();
      PDR_ASSIGN_OR_RETURN(Decomposition d, decompose_leaves(cur, round_depth, box));
      std::vector<char> selected;
      if (select) selected = select();
      prof.decomposition += seconds_since(td);
      RoundResult r;
      PDR_TRY(run_round(phase, cur, std::move(d), boundary, sizing, k, options, fix, r,
                        {.selected = select ? &selected : nullptr}));
      account(std::move(r));
      return {};
    });
  };
  // The optimization's seeds (is_bad per tet of `cur`): tested once, when the
  // first optimization round runs, then kept up to date by the rounds, which
  // test only the tets their tasks made.
  std::vector<char> bad;
  bool bad_known = false;
  const auto bad_now = [&]() -> std::vector<char>& {
    if (!bad_known) bad = bad_tets(cur, options);
    bad_known = true;
    return bad;
  };
  /// An optimization round: only the `seeds`' tets and their optimize_halo
  /// layers go to tasks, the others stay where they are (selected_round), and
  /// only the tasks' tets get the round's leaves (no later step reads the leaf
  /// of a tet). With `keep`, the tasks keep `seeds` up to date for the next
  /// round (they test only the tets they made).
  const auto optimize_around = [&](std::string_view phase, const Box& box, int round_depth, const LeafKernel& k,
                                   std::vector<char>& seeds, bool keep) -> Status {
    const auto td = Clock::now();
    BufferedRound b = selected_round(cur, box, round_depth, select_around(cur, seeds, options.optimize_halo));
    prof.decomposition += seconds_since(td);
    RoundResult r;
    PDR_TRY(run_round(phase, cur, std::move(b.d), boundary, sizing, k, options, false, r,
                      {.scratch = &scratch, .outside = &b.outside, .bad = keep ? &seeds : nullptr}));
    account(std::move(r));
    return {};
  };
  /// optimize_around the mesh's bad tets, as one checkpointed step.
  const auto selected_step = [&](std::string_view phase, const Box& box, int round_depth, const LeafKernel& k) -> Status {
    return step(phase, [&]() -> Status { return optimize_around(phase, box, round_depth, k, bad_now(), true); });
  };

  const auto refinement = [&]() -> Status {
    auto t0 = Clock::now();
    PDR_ASSIGN_OR_RETURN(Decomposition d1, decompose(cur, depth, box1));  // checks the initial mesh's faces
    prof.decomposition += seconds_since(t0);
    RoundResult r1;
    t0 = Clock::now();
    PDR_TRY(run_round("refinement", cur, std::move(d1), boundary, sizing, kernel, options, fixups, r1));
    prof.leaves = seconds_since(t0) - r1.fixups.swap_s - r1.fixups.extraction_s;
    prof.leaf_count = r1.leaves;
    prof.max_leaf_tets = r1.max_leaf_tets;
    account(std::move(r1));
    return {};
  };
  const bool buffered = options.buffered && !fixups && depth > 0;
  Box last_box = box1;
  if (buffered) {
    // Sweeps of eight rounds, one per colour. A leaf whose box held no tet's
    // barycenter in its round (tets larger than a leaf span it, a thin part
    // say) has had no task: the tets its neighbours split there do now, so
    // the next sweep runs such leaves, until none is left.
    const auto sweeps = [&]() -> Status {
      const Grid grid{box1, depth};
      PDR_TRY(decompose(cur, depth, box1).status());  // checks the initial mesh's faces
      assign_leaves(cur, box1, depth);
      // h at every point, evaluated once here and then by the task that makes the point.
      std::vector<double> sizes(cur.points.size());
      reserve_room(sizes, cur.points.capacity());
      tbb::parallel_for(std::size_t{0}, sizes.size(), [&](std::size_t v) { sizes[v] = sizing.at(cur.points[v]); });
      // The colour rounds of one sweep over `m` (the mesh, or a later sweep's
      // sub-mesh with its boundary faces `fb` and point sizes `sz`); with
      // `allowed`, only those leaves get tasks; `beside`: the mesh's tets not in `m`.
      std::vector<LeafId> done;
      const auto colour_rounds = [&](VolumeMesh& m, const FaceIdTable& fb, std::vector<double>& sz,
                                     const std::vector<LeafId>* allowed, std::size_t beside) -> Status {
        for (int colour = 0; colour < 8; ++colour) {
          // A later sweep's few leaves leave most colours empty: those cost no pass over the mesh.
          if (allowed != nullptr &&
              std::none_of(allowed->begin(), allowed->end(), [&](LeafId l) { return colour_of(l, depth) == colour; }))
            continue;
          auto td = Clock::now();
          BufferedRound b = buffered_round(m, box1, depth, colour, options.buffer_layers, allowed);
          prof.decomposition += seconds_since(td);
          if (b.d.size() == 0) continue;
          done.insert(done.end(), b.d.leaves.begin(), b.d.leaves.end());
          RoundResult r;
          PDR_TRY(run_round("refinement", m, std::move(b.d), fb, sizing, kernel, options, false, r,
                            {.scratch = &scratch,
                             .outside = &b.outside,
                             .cores = &b.cores,
                             .grid = &grid,
                             .sizes = &sz,
                             .leaves_before = prof.leaf_count,
                             .tets_beside = beside}));
          prof.leaf_count += r.leaves;
          prof.max_leaf_tets = std::max(prof.max_leaf_tets, r.max_leaf_tets);
          account(std::move(r));
        }
        return {};
      };
      // A sweep of seed rounds first (PdrPlan::leaf_seeds): the tasks of the
      // leaves that hold seeds insert them and refine nothing, so that every
      // seed is in before any leaf refines, as in an initial mesh that holds
      // them all. Over a grid at least one level coarser, so that a task's
      // seeds outweigh its fixed costs, and with leaves of kSeedLeafSpacings
      // lattice spacings or more: a seed must lie in a tet of its leaf's task
      // (the tets of the coarser rounds' seeds span about two spacings).
      if (!initial.leaf_seeds.empty()) {
        const double spacing = seed_spacing(*plan.tetgen.max_volume);
        int seed_depth = depth - 1;
        while (seed_depth > 0 && (box1.hi[0] - box1.lo[0]) / (1 << seed_depth) < kSeedLeafSpacings * spacing)
          --seed_depth;
        const Grid seed_grid{box1, seed_depth};
        std::vector<std::pair<LeafId, Vec3>> seeds(initial.leaf_seeds.size());
        tbb::parallel_for(std::size_t{0}, seeds.size(), [&](std::size_t i) {
          seeds[i] = {leaf_of_point(box1, seed_grid.depth, initial.leaf_seeds[i]), initial.leaf_seeds[i]};
        });
        initial.leaf_seeds = {};
        std::stable_sort(seeds.begin(), seeds.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
        std::vector<LeafId> seeded;
        for (const auto& s : seeds)
          if (seeded.empty() || seeded.back() != s.first) seeded.push_back(s.first);
        if (seed_grid.depth != depth) assign_leaves(cur, box1, seed_grid.depth);
        for (int colour = 0; colour < 8; ++colour) {
          const auto td = Clock::now();
          BufferedRound b = buffered_round(cur, box1, seed_grid.depth, colour, options.buffer_layers, &seeded);
          prof.decomposition += seconds_since(td);
          if (b.d.size() == 0) continue;
          std::vector<std::vector<Vec3>> task_seeds(b.d.size());
          for (std::size_t l = 0; l < b.d.size(); ++l) {
            auto it = std::lower_bound(seeds.begin(), seeds.end(), b.d.leaves[l],
                                       [](const auto& s, LeafId leaf) { return s.first < leaf; });
            for (; it != seeds.end() && it->first == b.d.leaves[l]; ++it) task_seeds[l].push_back(it->second);
          }
          RoundResult r;
          PDR_TRY(run_round("seeds", cur, std::move(b.d), boundary, sizing, kernel, options, false, r,
                            {.scratch = &scratch,
                             .outside = &b.outside,
                             .cores = &b.cores,
                             .grid = &seed_grid,
                             .sizes = &sizes,
                             .seeds = &task_seeds}));
          account(std::move(r));
        }
        if (seed_grid.depth != depth) assign_leaves(cur, box1, depth);
      }
      PDR_TRY(colour_rounds(cur, boundary, sizes, nullptr, 0));
      for (int sweep = 1; sweep < kMaxSweeps; ++sweep) {
        const std::vector<LeafId> todo = leaves_without(cur, depth, done);
        if (todo.empty()) break;
        // A later sweep's few leaves run on a sub-mesh: their tets and two
        // buffers' layers around them, so its rounds cost what those do.
        const auto td = Clock::now();
        std::vector<char> flag(cur.tets.size());
        tbb::parallel_for(std::size_t{0}, flag.size(), [&](std::size_t t) {
          flag[t] = std::binary_search(todo.begin(), todo.end(), static_cast<LeafId>(cur.tet_regions[t])) ? 1 : 0;
        });
        grow_selection(cur, flag, 2 * options.buffer_layers);
        SubMesh sub = extract_tets(cur, flag);
        flag = {};
        const FaceIdTable sub_boundary(sub.mesh.boundary, sub.mesh.boundary_ids);
        std::vector<double> sub_sizes(sub.global_points.size());
        tbb::parallel_for(std::size_t{0}, sub_sizes.size(), [&](std::size_t i) { sub_sizes[i] = sizes[sub.global_points[i]]; });
        prof.decomposition += seconds_since(td);
        PDR_TRY(colour_rounds(sub.mesh, sub_boundary, sub_sizes, &todo, cur.tets.size() - sub.global_tets.size()));
        const auto tm = Clock::now();
        tbb::parallel_for(std::size_t{0}, sub.global_points.size(), [&](std::size_t i) { sizes[sub.global_points[i]] = sub_sizes[i]; });
        sizes.insert(sizes.end(), sub_sizes.begin() + static_cast<std::ptrdiff_t>(sub.global_points.size()), sub_sizes.end());
        put_back(cur, std::move(sub));
        prof.merge += seconds_since(tm);
      }
      return {};
    };
    const auto t0 = Clock::now();
    PDR_TRY(step("refinement", sweeps));
    prof.leaves = seconds_since(t0);
  } else {
    PDR_TRY(step("refinement", refinement));
  }

  if (!buffered && options.interface_round && depth > 0 && options.interface_rounds > 0) {
    const auto t0 = Clock::now();
    Selector near_interfaces;
    if (options.interface_halo > 0 && !fixups) {
      near_interfaces = [&] { return select_interface_tets(cur, options.interface_halo); };
    }
    const std::size_t before = prof.rounds.size();
    PDR_TRY(round("interface round", box2, kernel, fixups, depth, near_interfaces));
    prof.interface_leaf_count = prof.rounds.size() > before ? prof.rounds.back().n1.size() : 0;
    last_box = box2;
    if (options.interface_rounds > 1) {
      // A quarter-leaf shift: the lines where a first-round interface plane
      // crosses a second-round one (frozen in both rounds) lie inside its leaves.
      Box box3 = box1;
      for (int k = 0; k < 3; ++k) {
        box3.lo[k] += 0.5 * half;
        box3.hi[k] += 0.5 * half;
      }
      PDR_TRY(round("second interface round", box3, kernel, fixups, depth, near_interfaces));
      last_box = box3;
    }
    prof.interface_round = seconds_since(t0);
  }
  prof.fixups = prof.partition_swap + prof.boundary_extraction;

  remove_unused_points(cur);  // nothing to remove when resumed after it
  if (options.optimize_kernel != nullptr || options.optimize) {
    if (!report("optimization", cur.tets.size())) return cancelled("stopped before the optimization");
    const auto t0 = Clock::now();
    const bool select = options.optimize_kernel != nullptr && static_cast<bool>(options.optimize_selects);
    // The final pass's grid (buffered rounds), or 0: one task over the whole
    // selection, which then runs without optimization rounds before it.
    const int final_depth = depth - kFinalCoarsening >= kMinFinalDepth ? depth - kFinalCoarsening : 0;
    const bool one_final_task = select && (!buffered || final_depth == 0);
    const LeafKernel* final_kernel =
        options.final_optimize_kernel != nullptr ? options.final_optimize_kernel : options.optimize_kernel;
    if (options.optimize_kernel != nullptr && !one_final_task) {
      if (select) {
        PDR_TRY(selected_step("optimization", box1, depth, *options.optimize_kernel));
        if (depth > 0) PDR_TRY(selected_step("shifted optimization", box2, depth, *options.optimize_kernel));
      } else {
        PDR_TRY(round("optimization", box1, *options.optimize_kernel, false, depth, {}));
        if (depth > 0) PDR_TRY(round("shifted optimization", box2, *options.optimize_kernel, false, depth, {}));
      }
      last_box = depth > 0 ? box2 : box1;
      prof.optimization_leaves = seconds_since(t0);
    }
    if (select && buffered) {
      // The final pass, in rounds by colour as in the refinement (over a
      // coarser grid: kFinalCoarsening; one leaf, one task, on small meshes):
      // a leaf's task gets the selected tets whose barycenter it holds and
      // optimize_buffer_layers of any tets around them, and may change all
      // but its hull, so what the rounds' frozen hulls kept from them is
      // reached with no task over the whole mesh. The rounds work on the
      // selection and its buffer as a sub-mesh (its hull unchanged), put back
      // into the mesh at the end: their scans cost what the selection does.
      const auto tg = Clock::now();
      // Over more than one leaf, the rounds' cuts can leave a tet with no
      // point on the surface outside the targets where two tasks' buffers
      // met; such tets, if any, and their halo go to one more task with the
      // one-task kernel (no cuts). Only the `swept` tets, the mesh's last ones
      // (put_back), can be such tets: the others were not bad.
      const auto leftovers = [&](std::size_t swept) -> Status {
        const auto surface_points = static_cast<Index>(surface.points.size());
        const std::size_t first = cur.tets.size() - swept;
        std::vector<char> seeds(cur.tets.size(), 0);
        tbb::parallel_for(first, cur.tets.size(), [&](std::size_t t) {
          const Tet& k = cur.tets[t];
          const bool interior = std::all_of(k.begin(), k.end(), [&](Index v) { return v >= surface_points; });
          seeds[t] = interior ? is_bad(cur, k, options) : char{0};
        });
        if (std::find(seeds.begin() + static_cast<std::ptrdiff_t>(first), seeds.end(), char{1}) == seeds.end())
          return {};
        return optimize_around("final optimization", box1, 0, *final_kernel, seeds, false);
      };
      const auto sweep = [&]() -> Status {
        const Grid grid{box1, final_depth};
        auto td = Clock::now();
        // One leaf has no cuts for a buffer to cover.
        const int buffer = final_depth > 0 ? options.optimize_buffer_layers : 0;
        const std::vector<char>& seeds = bad_now();
        SubMesh sub = extract_tets(cur, select_around(cur, seeds, options.optimize_halo + buffer));
        std::vector<char> sub_bad(sub.global_tets.size());
        tbb::parallel_for(std::size_t{0}, sub_bad.size(), [&](std::size_t i) { sub_bad[i] = seeds[sub.global_tets[i]]; });
        assign_leaves(sub.mesh, box1, final_depth);
        const FaceIdTable sub_boundary(sub.mesh.boundary, sub.mesh.boundary_ids);
        prof.decomposition += seconds_since(td);
        // With more than one leaf, a task changes tets of leaves whose round
        // has passed (its buffer): a second sweep gives those a core again,
        // and no seed to the bad tets a task already had in its core.
        const int colours = final_depth > 0 ? 16 : 1;
        std::vector<char> cored(sub.mesh.tets.size(), 0);
        for (int colour = 0; colour < colours; ++colour) {
          td = Clock::now();
          const std::vector<char> selected =
              select_around(sub.mesh, sub_bad, options.optimize_halo, colour >= 8 ? &cored : nullptr);
          BufferedRound b =
              buffered_round(sub.mesh, box1, final_depth, colour % 8, buffer, nullptr, &selected);
          prof.decomposition += seconds_since(td);
          if (b.d.size() == 0) continue;
          RoundResult r;
          PDR_TRY(run_round("final optimization", sub.mesh, std::move(b.d), sub_boundary, sizing,
                            final_depth > 0 ? *options.optimize_kernel : *final_kernel, options, false, r,
                            {.scratch = &scratch,
                             .outside = &b.outside,
                             .cores = &b.cores,
                             .grid = &grid,
                             .tets_beside = cur.tets.size() - sub.global_tets.size(),
                             .cored = &cored,
                             .bad = &sub_bad}));
          account(std::move(r));
        }
        td = Clock::now();
        const std::size_t swept = sub.mesh.tets.size();
        put_back(cur, std::move(sub));
        bad_known = false;  // the tets moved: no later step reads the flags
        prof.merge += seconds_since(td);
        if (final_depth > 0) PDR_TRY(leftovers(swept));
        return {};
      };
      PDR_TRY(step("final optimization", sweep));
      prof.global_optimization = seconds_since(tg);
    } else if (select) {
      // The final pass: one task over the whole mesh's selection (its hull
      // frozen), so what the rounds' frozen hulls kept from them is reached.
      // Its tets are then in the one leaf of a depth-0 grid (from here on the
      // leaf of a tet is bookkeeping no step reads).
      const auto tg = Clock::now();
      PDR_TRY(selected_step("final optimization", box1, 0, *final_kernel));
      prof.global_optimization = seconds_since(tg);
    } else if (options.optimize && !select) {
      // The leaf of each tet is bookkeeping, not a material region: the
      // optimization must see one region, or it would treat every former leaf
      // interface as a constraint (no flip across it, its points fixed) and
      // leave the slivers there. Afterwards each tet gets the leaf of the last
      // round's grid that holds its barycenter.
      const auto tg = Clock::now();
      const auto whole = [&]() -> Status {
        cur.tet_regions.clear();
        PDR_TRY(options.optimize(cur));
        assign_leaves(cur, last_box, depth);
        return {};
      };
      PDR_TRY(step("final optimization", whole));
      prof.global_optimization = seconds_since(tg);
    }
    prof.optimization = seconds_since(t0);
    // The optimization's tasks leave the points they removed in no tet
    // (leaf_optimize_options).
    remove_unused_points(cur);
  }
  prof.interior_points = cur.points.size() - surface.points.size();  // after the optimization's removals
  prof.final_tets = cur.tets.size();
  prof.total = initial_s + seconds_since(t_total);
  ids.to_user(cur.boundary_ids);
  cur.boundary_names = surface.surface_names;  // keyed by the user's ids, as the boundary now is
  return cur;
}

}  // namespace pdrmesh
