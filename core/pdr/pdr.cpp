// SPDX-License-Identifier: AGPL-3.0-or-later
// The PDR engine: initial mesh, buffered rounds (or frozen leaves with fix-ups
// and interface rounds), merge, optimization rounds. See pdr.hpp for the
// numbering and determinism argument.
#include "pdrmesh/pdr.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <iterator>
#include <limits>
#include <mutex>
#include <numeric>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>

#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_sort.h>

#include "pdrmesh/atomic_extremum.hpp"
#include "pdrmesh/fixed_chunks.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/surface_ids.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/stopwatch.hpp"

namespace pdrmesh {

namespace {
using Clock = std::chrono::steady_clock;
}  // namespace

FaceIdTable::FaceIdTable(std::span<const Tri> faces, std::span<const int> ids) {
  sorted_.reserve(faces.size());
  for (std::size_t i = 0; i < faces.size(); ++i)
    sorted_.emplace_back(topo::sorted_key(faces[i]), i < ids.size() ? ids[i] : 0);
  std::sort(sorted_.begin(), sorted_.end());
}

int FaceIdTable::lookup(const Tri& face) const {
  const Tri key = topo::sorted_key(face);
  const auto it = std::lower_bound(sorted_.begin(), sorted_.end(), std::pair<Tri, int>{key, std::numeric_limits<int>::min()});
  return it != sorted_.end() && it->first == key ? it->second : 0;
}

LeafTaskInput build_leaf_input(std::uint32_t leaf, std::span<const Vec3> points, std::span<const Tet> tets,
                               const FaceIdTable& boundary, std::span<const double> sizes) {
  LeafTaskInput in;
  in.leaf = leaf;
  std::vector<Index> used;
  used.reserve(4 * tets.size());
  for (const Tet& t : tets) used.insert(used.end(), t.begin(), t.end());
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  auto local = [&](Index g) { return static_cast<Index>(std::lower_bound(used.begin(), used.end(), g) - used.begin()); };
  in.point_ids.assign(used.begin(), used.end());
  in.points.reserve(used.size());
  for (Index g : used) in.points.push_back(points[g]);
  if (!sizes.empty()) {
    in.sizes.reserve(used.size());
    for (Index g : used) in.sizes.push_back(sizes[g]);
  }
  in.tets.reserve(tets.size());
  for (const Tet& t : tets) in.tets.push_back({local(t[0]), local(t[1]), local(t[2]), local(t[3])});
  // The hull: the faces of one tet, in the order of their sorted points.
  const auto faces = detail::faces_by_smallest_point(in.tets, used.size());
  for (std::size_t a = 0; a < used.size(); ++a) {
    detail::for_each_face_group(faces, a, [&](std::span<const detail::FaceRef> group) {
      if (group.size() != 1) return;
      const Tri t = topo::face_of(in.tets[group[0].tet], static_cast<int>(group[0].slot));
      in.frozen_faces.push_back(t);
      in.frozen_ids.push_back(boundary.lookup({used[t[0]], used[t[1]], used[t[2]]}));
    });
  }
  return in;
}

namespace {

struct RoundResult {
  std::size_t leaves = 0;
  std::size_t max_leaf_tets = 0;
  std::size_t failed = 0;      ///< leaves kept unrefined after a kernel error
  std::string first_failure;   ///< the lowest such leaf's error
  double merge_s = 0;          ///< serial: merges and the final splice
  double cpu_s = 0;            ///< process CPU seconds while the schedule ran
  ScheduleStats schedule;
  FixupStats fixups;
  RoundRecord record;
};

struct TaskResult {
  Status status;                  ///< a validation failure, or cancelled
  Status kernel_error;            ///< the kernel failed and the leaf was kept as it was
  std::vector<GlobalId> point_ids;
  LeafTaskOutput output;
};

/// The expected cost of each leaf's task, as ranks (0 = the most expensive
/// starts first): its tet count plus the tets its volume should hold at h
/// (sampled on every 4th tet; h at its barycenter, or the mean of its points'
/// `sizes` when given), or the size of the leaf's selection when the
/// round sends only part of it. A heuristic for the order only; the result
/// does not depend on it.
std::vector<Index> cost_ranks(const VolumeMesh& cur, const Decomposition& d, const SizingField& sizing,
                              const std::vector<std::vector<Tet>>& sent, std::span<const double> sizes) {
  std::vector<double> cost(d.size(), 0.0);
  tbb::parallel_for(std::size_t{0}, d.size(), [&](std::size_t l) {
    const auto& tets = d.leaf_tets[l];
    if (sent[l].size() != tets.size()) {  // a selection: its size is the work
      cost[l] = static_cast<double>(sent[l].size());
      return;
    }
    double c = static_cast<double>(tets.size());
    for (std::size_t i = 0; i < tets.size(); i += 4) {
      const Tet& v = cur.tets[tets[i]];
      const auto& P = cur.points;
      const double vol = signed_volume(P[v[0]], P[v[1]], P[v[2]], P[v[3]]);
      const double h = sizes.empty() ? sizing.at(tet_barycenter(cur, tets[i]))
                                     : 0.25 * (sizes[v[0]] + sizes[v[1]] + sizes[v[2]] + sizes[v[3]]);
      c += 4 * vol / regular_tet_volume(h);
    }
    cost[l] = c;
  });
  std::vector<Index> order(d.size());
  std::iota(order.begin(), order.end(), Index{0});
  std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) { return cost[a] > cost[b]; });
  std::vector<Index> rank(d.size());
  for (Index i = 0; i < order.size(); ++i) rank[order[i]] = i;
  return rank;
}

/// Adds to `flag` (one per tet of `m`) every tet within `layers` vertex
/// layers of a flagged one (a layer: the tets sharing a point with a flagged tet).
/// In parallel: a tet writes only its own flag, and marks its points with
/// atomic stores of the same value, so the result does not depend on the threads.
void grow_selection(const VolumeMesh& m, std::vector<char>& flag, int layers) {
  std::vector<char> touched(m.points.size());
  for (int layer = 0; layer < layers; ++layer) {
    std::fill(touched.begin(), touched.end(), 0);
    tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
      if (flag[t])
        for (Index v : m.tets[t]) std::atomic_ref<char>(touched[v]).store(1, std::memory_order_relaxed);
    });
    tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
      if (!flag[t])
        for (Index v : m.tets[t]) flag[t] = static_cast<char>(flag[t] | touched[v]);
    });
  }
}

/// The optimization rounds' selection: the tets options.optimize_selects
/// picks and their optimize_halo layers.
/// With `skip`, the tets it flags are no seeds (they may join a halo).
std::vector<char> select_bad_tets(const VolumeMesh& m, const PdrOptions& options, int halo,
                                  const std::vector<char>* skip = nullptr) {
  const auto& needs = options.optimize_selects;
  const std::vector<Vec3>& P = m.points;
  std::vector<char> flag(m.tets.size(), 0);
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    const Tet& k = m.tets[t];
    flag[t] = (skip == nullptr || !(*skip)[t]) && needs(P[k[0]], P[k[1]], P[k[2]], P[k[3]]) ? 1 : 0;
  });
  grow_selection(m, flag, halo);
  return flag;
}
std::vector<char> select_bad_tets(const VolumeMesh& m, const PdrOptions& options) {
  return select_bad_tets(m, options, options.optimize_halo);
}

/// The interface rounds' selection: the tets with a point on a face between
/// two of the last round's leaves (`m.tet_regions`: the leaf of each tet),
/// which that round kept frozen, and their `halo` layers. Everywhere else the
/// last round's kernel already ran to the end with nothing frozen nearby.
std::vector<char> select_interface_tets(const VolumeMesh& m, int halo) {
  // A point is shared by two leaves when the smallest and the largest leaf of
  // its tets differ (atomic min and max: the same whatever the threads).
  std::vector<int> lo(m.points.size(), std::numeric_limits<int>::max());
  std::vector<int> hi(m.points.size(), std::numeric_limits<int>::min());
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    const int r = m.tet_regions[t];
    for (Index v : m.tets[t]) {
      std::atomic_ref<int> a(lo[v]), b(hi[v]);
      detail::atomic_lower(a, r);
      detail::atomic_raise(b, r);
    }
  });
  std::vector<char> flag(m.tets.size(), 0);
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    for (Index v : m.tets[t]) flag[t] = static_cast<char>(flag[t] | (lo[v] != hi[v] ? 1 : 0));
  });
  grow_selection(m, flag, halo);
  return flag;
}

/// A grid of leaves: the depth-`depth` octree over `box`.
struct Grid {
  Box box;
  int depth = 0;
};

/// Puts a round's results into `cur` as if leaf by leaf in ascending order,
/// after the tets of no leaf (`outside`, which keep their leaf): leaf l's tets
/// (task output, then its kept tets) follow those of the leaves before it, and
/// new point k of leaf l gets the next id after the new points of the leaves
/// before it. Point moves go first, in leaf order (the leaves of a round move
/// disjoint points: nothing moves a hull point); the rest is copied in
/// parallel into slots fixed by prefix sums, so the result does not depend on
/// the threads. Frees the results as it goes. With `grid` set, each tet a
/// task made is given the grid leaf that holds its barycenter instead of the
/// task's leaf. With `sizes` (h per point of `cur`), the new points' sizes
/// are appended (a task's new_sizes, or sizing.at where it gave none) and a
/// moved point's is evaluated again.
void splice(VolumeMesh& cur, const std::vector<LeafId>& leaves, std::vector<TaskResult>& results,
            std::vector<std::vector<Tet>>& kept, std::vector<Tet>& outside, std::vector<int>& outside_leaf,
            const Grid* grid, std::vector<double>* sizes, const SizingField& sizing, RoundResult& rr,
            std::vector<char>* cored = nullptr, const std::vector<char>& outside_cored = {}) {
  const std::size_t n = results.size();
  std::vector<Vec3>& pts = cur.points;
  std::vector<std::size_t> tet_at(n + 1, outside.size()), point_at(n + 1, pts.size());
  for (std::size_t l = 0; l < n; ++l) {
    TaskResult& r = results[l];
    if (!r.kernel_error.ok() && rr.failed++ == 0) rr.first_failure = r.kernel_error.message();
    for (std::size_t i = 0; i < r.output.moved.size(); ++i) {
      const GlobalId g = r.point_ids[r.output.moved[i]];
      pts[g] = r.output.moved_to[i];
      if (sizes != nullptr) (*sizes)[g] = sizing.at(pts[g]);
    }
    tet_at[l + 1] = tet_at[l] + r.output.tets.size() + kept[l].size();
    point_at[l + 1] = point_at[l] + r.output.new_points.size();
  }
  cur.tets.resize(tet_at[n]);
  cur.tet_regions.resize(tet_at[n]);
  pts.resize(point_at[n]);
  if (sizes != nullptr) sizes->resize(point_at[n]);
  detail::parallel_copy(outside.begin(), outside.end(), cur.tets.begin());
  detail::parallel_copy(outside_leaf.begin(), outside_leaf.end(), cur.tet_regions.begin());
  if (cored != nullptr) {
    cored->assign(tet_at[n], 0);
    detail::parallel_copy(outside_cored.begin(), outside_cored.end(), cored->begin());
  }
  outside = {};
  outside_leaf = {};
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t l) {
    TaskResult& r = results[l];
    const auto ni = static_cast<Index>(r.point_ids.size());
    const auto base = static_cast<Index>(point_at[l]);
    std::copy(r.output.new_points.begin(), r.output.new_points.end(), pts.begin() + static_cast<std::ptrdiff_t>(base));
    if (sizes != nullptr) {
      const auto to = sizes->begin() + static_cast<std::ptrdiff_t>(base);
      if (r.output.new_sizes.size() == r.output.new_points.size()) {
        std::copy(r.output.new_sizes.begin(), r.output.new_sizes.end(), to);
      } else {
        std::transform(r.output.new_points.begin(), r.output.new_points.end(), to,
                       [&](const Vec3& p) { return sizing.at(p); });
      }
    }
    auto out = cur.tets.begin() + static_cast<std::ptrdiff_t>(tet_at[l]);
    for (const Tet& t : r.output.tets) {
      Tet g;
      for (int i = 0; i < 4; ++i) g[i] = t[i] < ni ? static_cast<Index>(r.point_ids[t[i]]) : base + (t[i] - ni);
      *out++ = g;
    }
    std::copy(kept[l].begin(), kept[l].end(), out);
    std::fill(cur.tet_regions.begin() + static_cast<std::ptrdiff_t>(tet_at[l]),
              cur.tet_regions.begin() + static_cast<std::ptrdiff_t>(tet_at[l + 1]), static_cast<int>(leaves[l]));
    if (grid != nullptr) {
      for (std::size_t t = tet_at[l]; t < tet_at[l] + r.output.tets.size(); ++t) {
        cur.tet_regions[t] = static_cast<int>(leaf_of_point(grid->box, grid->depth, tet_barycenter(cur, static_cast<Index>(t))));
        if (cored != nullptr) (*cored)[t] = cur.tet_regions[t] == static_cast<int>(leaves[l]) ? 1 : 0;
      }
    }
    r = TaskResult{};
    kept[l] = {};
  });
}

/// One round over decomposition d of `cur`: every leaf's tets go through
/// `kernel` (its hull frozen), and `cur` gets the results, leaf by leaf in
/// ascending order, new points appended in that order. Task inputs depend only
/// on the leaf's own tets and the points present before the round (nothing
/// moves a hull point, and new points get their ids only after the round), so
/// the result is the same for any worker count, completion order or policy.
/// With `selected` (one flag per tet of `cur`), a leaf's task gets only its
/// selected tets and the others are kept as they are, after the task's tets.
/// A buffered round (BufferedRound) gives tets to no leaf (kept as they are,
/// before all others) and a core box to each task.
struct RoundExtras {
  const std::vector<char>* selected = nullptr;
  const std::vector<Index>* outside = nullptr;  ///< ascending
  const std::vector<Box>* cores = nullptr;      ///< per leaf
  const Grid* grid = nullptr;                   ///< see splice
  std::vector<double>* sizes = nullptr;         ///< h per point of `cur`, kept up to date (see splice)
  std::size_t leaves_before = 0;                ///< leaves merged in this phase's earlier rounds (progress)
  std::size_t tets_beside = 0;                  ///< tets of the whole mesh when `cur` is a part of it (progress)
  /// Per tet of `cur`, kept up to date (with `grid` and `outside`): 1 when the
  /// last task that had it made it in its own leaf (its core), else 0.
  std::vector<char>* cored = nullptr;
};
Status run_round(std::string_view phase, VolumeMesh& cur, Decomposition d, const FaceIdTable& boundary,
                 const SizingField& sizing, const LeafKernel& kernel, const PdrOptions& options, bool fixups,
                 RoundResult& rr, RoundExtras extras = {}) {
  if (fixups) rr.fixups = apply_fixups(cur, d, options.max_fixup_sweeps);
  rr.leaves = d.size();
  const std::vector<char>* selected = extras.selected;
  std::vector<std::vector<Tet>> leaf_tets(d.size());
  std::vector<std::vector<Tet>> kept(d.size());
  tbb::parallel_for(Index{0}, static_cast<Index>(d.size()), [&](Index l) {
    for (Index t : d.leaf_tets[l]) (selected == nullptr || (*selected)[t] ? leaf_tets[l] : kept[l]).push_back(cur.tets[t]);
  });
  std::vector<Tet> outside;
  std::vector<int> outside_leaf;
  if (extras.outside != nullptr) {
    const bool has_leaf = cur.tet_regions.size() == cur.tets.size();
    outside.resize(extras.outside->size());
    outside_leaf.resize(extras.outside->size(), 0);
    tbb::parallel_for(std::size_t{0}, outside.size(), [&](std::size_t i) {
      outside[i] = cur.tets[(*extras.outside)[i]];
      if (has_leaf) outside_leaf[i] = cur.tet_regions[(*extras.outside)[i]];
    });
  }
  for (const std::vector<Tet>& sent : leaf_tets) {
    rr.max_leaf_tets = std::max(rr.max_leaf_tets, sent.size());
    rr.record.tets_sent += sent.size();
  }
  rr.record.tets = extras.tets_beside + cur.tets.size();
  const std::span<const double> sizes =
      extras.sizes != nullptr ? std::span<const double>(*extras.sizes) : std::span<const double>();
  const std::vector<Index> rank = cost_ranks(cur, d, sizing, leaf_tets, sizes);
  const std::vector<Vec3>& points = cur.points;  // read-only during the round
  Status error;
  std::atomic<bool> stop{false};
  std::size_t merged = 0;
  std::size_t tet_count = extras.tets_beside + cur.tets.size();
  const std::size_t before = extras.leaves_before;
  if (options.progress && !options.progress({phase, before, before + d.size(), tet_count})) {
    return cancelled(fmt::format("stopped before the {}", phase));
  }
  std::vector<TaskResult> results(d.size());
  // One kernel on one input (a remote kernel sends its bytes to a worker; the
  // codec is lossless, so a local one runs on the input itself) and the checks
  // of its result (size limit, validate_leaf_output), which a trusted kernel's
  // results skip (the latter runs in debug builds).
  const auto run_kernel = [&](const LeafKernel& k, const LeafTaskInput& in, Index l) -> Result<LeafTaskOutput> {
    Result<LeafTaskOutput> out = run_leaf_kernel(k, in, sizing);
    if (!out.ok()) return Status(out.status().code(), fmt::format("leaf {}: {}", l, out.status().message()));
    const std::uint64_t bytes = out->encoded_size();
    if (const std::uint64_t limit = k.trusted() ? bytes : leaf_output_byte_limit(in, sizing); bytes > limit) {
      return invalid_input(
          fmt::format("leaf {} result rejected: {} bytes, over the {} its leaf can hold", l, bytes, limit));
    }
    if (kDebugChecks || !k.trusted()) PDR_TRY(validate_leaf_output(in, *out));
    return out;
  };
  // A kernel that gave up on a leaf (TetGen crashing on a hull, say) leaves it
  // as it was, which conforms to its neighbours by construction.
  const auto kept_on_failure = [&](const Status& s) { return options.keep_failed_leaves && is_kernel_failure(s); };
  std::function<TaskResult(Index)> task = [&](Index l) -> TaskResult {
    TaskResult r;
    if (stop.load()) {
      r.status = cancelled("stopped");
      return r;
    }
    LeafTaskInput in = build_leaf_input(l, points, leaf_tets[l], boundary, sizes);
    if (extras.cores != nullptr) in.core = (*extras.cores)[l];
    r.output.leaf = l;
    r.output.input_points = static_cast<std::uint32_t>(in.points.size());
    if (in.tets.empty()) return r;
    Result<LeafTaskOutput> out = run_kernel(kernel, in, l);
    if (!out.ok() && kept_on_failure(out.status())) {
      r.kernel_error = out.status();
      r.output.tets = std::move(in.tets);
      r.point_ids = std::move(in.point_ids);
      return r;
    }
    if (!out.ok()) {
      r.status = out.status();
      return r;
    }
    r.output = std::move(*out);
    r.point_ids = std::move(in.point_ids);
    return r;
  };
  std::function<void(Index, TaskResult&&)> merge = [&](Index l, TaskResult&& r) {
    if (!error.ok()) return;
    const auto t0 = Clock::now();
    if (!r.status.ok()) {
      error = r.status;
      stop = true;
      return;
    }
    tet_count = tet_count - leaf_tets[l].size() + r.output.tets.size();
    results[l] = std::move(r);
    rr.merge_s += seconds_since(t0);
    ++merged;
    if (options.progress && !options.progress({phase, before + merged, before + d.size(), tet_count})) {
      error = cancelled(fmt::format("stopped after {} of {} leaves ({})", merged, d.size(), phase));
      stop = true;
    }
  };
  const double cpu0 = process_cpu_seconds();
  rr.schedule = run_leaves<TaskResult>(d, std::max<std::size_t>(options.workers, 1), task, merge, options.policy, rank,
                                       options.concurrency);
  rr.cpu_s = process_cpu_seconds() - cpu0;
  PDR_TRY(error);

  const auto t0 = Clock::now();
  std::vector<char> outside_cored;
  if (extras.cored != nullptr && extras.outside != nullptr) {
    outside_cored.resize(extras.outside->size());
    for (std::size_t i = 0; i < outside_cored.size(); ++i) outside_cored[i] = (*extras.cored)[(*extras.outside)[i]];
  }
  splice(cur, d.leaves, results, kept, outside, outside_leaf, extras.grid, extras.sizes, sizing, rr, extras.cored,
         outside_cored);
  rr.merge_s += seconds_since(t0);
  rr.record.name = std::string(phase);
  rr.record.depth = d.depth;
  rr.record.leaves = d.leaves;
  rr.record.task_s = rr.schedule.task_s;
  rr.record.wall_s = rr.schedule.wall_s;
  rr.record.rank = rank;
  rr.record.n1 = std::move(d.n1);
  return {};
}

/// Sweeps of buffered rounds at most (PdrOptions::buffered).
constexpr int kMaxSweeps = 3;
/// The final optimization's grid is this many levels coarser than the
/// refinement's: its tasks' selections (bad tets and their halo) and buffers
/// reach several tets beyond a leaf, and in a grid as fine as the
/// refinement's two buffers of one round would meet and block each other.
/// Below depth 2 that grid would hold one leaf per colour (its tasks one
/// after another, twice): one task over the selection is cheaper.
constexpr int kFinalCoarsening = 3;

/// The tasks of one buffered round (PdrOptions::buffered): the leaves of one
/// colour (the parities of the grid coordinates, i&1 | (j&1)<<1 | (k&1)<<2),
/// each with the tets whose barycenter it holds (its core) and those within
/// `layers` vertex layers of them (its buffer). A tet that two leaves' layers
/// reach at once goes to neither, nor does any layer grow across it, so the
/// tasks' tets are disjoint; they may share hull points, which no task moves.
/// In parallel and deterministic: per point the least and greatest leaf of
/// its tets by atomic min and max, each tet writing only its own owner.
struct BufferedRound {
  Decomposition d;             ///< leaves, leaf_tets (core and buffer); no lock sets (none conflict), no tet_leaf
  std::vector<Index> outside;  ///< the tets of no task, ascending
  std::vector<Box> cores;      ///< per leaf: its box
};
/// The colour of leaf l of the depth-`depth` grid: the parities of its grid
/// coordinates, i&1 | (j&1)<<1 | (k&1)<<2.
int colour_of(LeafId l, int depth) {
  const auto c = leaf_coords(l, depth);
  return static_cast<int>((c[0] & 1U) | (c[1] & 1U) << 1 | (c[2] & 1U) << 2);
}

/// The tasks of a round from each tet's leaf (`owner`; at least kBlocked:
/// none): leaves ascending, each one's tets ascending, the others `outside`;
/// no cores, no lock sets, no tet_leaf (only the fix-ups read it).
BufferedRound tasks_of_owners(const std::vector<LeafId>& owner, const Box& box, int depth);

/// m.tet_regions must hold the leaf of each tet's barycenter.
/// Only leaves in `allowed` (ascending; null: all) get a task. With `selected`
/// (one flag per tet), a leaf's core is its selected tets only; its buffer
/// may take any tet.
BufferedRound buffered_round(const VolumeMesh& m, const Box& box, int depth, int colour, int layers,
                             const std::vector<LeafId>* allowed, const std::vector<char>* selected = nullptr) {
  constexpr LeafId kNone = std::numeric_limits<LeafId>::max();
  constexpr LeafId kBlocked = kNone - 1;
  std::vector<LeafId> owner(m.tets.size(), kNone);
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    if (selected != nullptr && !(*selected)[t]) return;
    const auto l = static_cast<LeafId>(m.tet_regions[t]);
    if (colour_of(l, depth) != colour) return;
    if (allowed == nullptr || std::binary_search(allowed->begin(), allowed->end(), l)) owner[t] = l;
  });
  std::vector<LeafId> lo(m.points.size()), hi(m.points.size());
  for (int layer = 0; layer < layers; ++layer) {
    std::fill(lo.begin(), lo.end(), kNone);
    std::fill(hi.begin(), hi.end(), LeafId{0});
    tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
      if (owner[t] >= kBlocked) return;
      for (Index v : m.tets[t]) {
        std::atomic_ref<LeafId> a(lo[v]), b(hi[v]);
        detail::atomic_lower(a, owner[t]);
        detail::atomic_raise(b, owner[t]);
      }
    });
    tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
      if (owner[t] != kNone) return;
      LeafId claim = kNone;
      for (Index v : m.tets[t]) {
        if (lo[v] == kNone) continue;
        if (lo[v] != hi[v] || (claim != kNone && claim != lo[v])) {
          owner[t] = kBlocked;
          return;
        }
        claim = lo[v];
      }
      owner[t] = claim;
    });
  }
  BufferedRound r = tasks_of_owners(owner, box, depth);
  for (LeafId l : r.d.leaves) r.cores.push_back(leaf_box(box, depth, l));
  return r;
}

/// The tasks of a round that sends each leaf only its selected tets (one flag
/// per tet of m): a selected tet goes to the leaf of the depth-`depth` grid
/// over `box` that holds its barycenter, the others to no task (kept where
/// they are). Only the selection is bucketed, and the tasks, whose tets are
/// disjoint and whose hulls are frozen, need no lock sets.
BufferedRound selected_round(const VolumeMesh& m, const Box& box, int depth, const std::vector<char>& selected) {
  std::vector<LeafId> owner(m.tets.size(), std::numeric_limits<LeafId>::max());
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    if (selected[t]) owner[t] = leaf_of_point(box, depth, tet_barycenter(m, static_cast<Index>(t)));
  });
  return tasks_of_owners(owner, box, depth);
}

BufferedRound tasks_of_owners(const std::vector<LeafId>& owner, const Box& box, int depth) {
  constexpr LeafId kBlocked = std::numeric_limits<LeafId>::max() - 1;
  BufferedRound r;
  r.d.box = box;
  r.d.depth = depth;
  r.d.per_side = 1 << depth;
  // The leaves with a tet, ascending, and each one's index among them.
  const std::size_t grid_leaves = std::size_t{1} << (3 * depth);
  std::vector<Index> dense(grid_leaves, kNoIndex);
  tbb::parallel_for(std::size_t{0}, owner.size(), [&](std::size_t t) {
    if (owner[t] < kBlocked) std::atomic_ref<Index>(dense[owner[t]]).store(0, std::memory_order_relaxed);
  });
  for (std::size_t l = 0; l < grid_leaves; ++l) {
    if (dense[l] == kNoIndex) continue;
    dense[l] = static_cast<Index>(r.d.leaves.size());
    r.d.leaves.push_back(static_cast<LeafId>(l));
  }
  // Each leaf's tets, ascending, and those of no leaf.
  const std::size_t nl = r.d.leaves.size();
  constexpr std::size_t kGrain = 65536;
  r.outside = detail::filter_indices(owner.size(), kGrain, [&](std::size_t t) { return owner[t] >= kBlocked; });
  auto buckets = detail::bucket_items<Index>(owner.size(), nl, kGrain, [&](std::size_t t, auto&& emit) {
    if (owner[t] < kBlocked) emit(dense[owner[t]], static_cast<Index>(t));
  });
  detail::sort_buckets(buckets, std::less<Index>());
  r.d.leaf_tets.resize(nl);
  tbb::parallel_for(std::size_t{0}, nl, [&](std::size_t k) {
    r.d.leaf_tets[k].assign(buckets.items.begin() + static_cast<std::ptrdiff_t>(buckets.first[k]),
                            buckets.items.begin() + static_cast<std::ptrdiff_t>(buckets.first[k + 1]));
  });
  r.d.n1.assign(r.d.size(), {});
  r.d.n2.assign(r.d.size(), {});
  return r;
}

/// Some tets of a mesh as a mesh of their own, for rounds that work on a small
/// part of a large mesh: their scans and copies then cost what the part does.
/// Points are renumbered in ascending global order; tet_regions and the
/// boundary faces among the points come along.
struct SubMesh {
  VolumeMesh mesh;
  std::vector<Index> global_points;  ///< global index of each of mesh.points
  std::vector<Index> global_tets;    ///< global index of each of mesh.tets, ascending
};

SubMesh extract_tets(const VolumeMesh& m, const std::vector<char>& flag) {
  constexpr std::size_t kGrain = 65536;
  SubMesh sub;
  sub.global_tets = detail::filter_indices(m.tets.size(), kGrain, [&](std::size_t t) { return flag[t] != 0; });
  std::vector<Index> local(m.points.size(), kNoIndex);
  tbb::parallel_for(std::size_t{0}, sub.global_tets.size(), [&](std::size_t i) {
    for (Index v : m.tets[sub.global_tets[i]]) std::atomic_ref<Index>(local[v]).store(0, std::memory_order_relaxed);
  });
  sub.global_points =
      detail::filter_indices(m.points.size(), kGrain, [&](std::size_t v) { return local[v] != kNoIndex; });
  VolumeMesh& s = sub.mesh;
  s.points.resize(sub.global_points.size());
  tbb::parallel_for(std::size_t{0}, sub.global_points.size(), [&](std::size_t i) {
    local[sub.global_points[i]] = static_cast<Index>(i);
    s.points[i] = m.points[sub.global_points[i]];
  });
  s.tets.resize(sub.global_tets.size());
  s.tet_regions.resize(sub.global_tets.size());
  tbb::parallel_for(std::size_t{0}, sub.global_tets.size(), [&](std::size_t i) {
    const Index t = sub.global_tets[i];
    for (int k = 0; k < 4; ++k) s.tets[i][k] = local[m.tets[t][k]];
    s.tet_regions[i] = m.tet_regions[t];
  });
  for (std::size_t f = 0; f < m.boundary.size(); ++f) {
    const Tri& tri = m.boundary[f];
    if (local[tri[0]] == kNoIndex || local[tri[1]] == kNoIndex || local[tri[2]] == kNoIndex) continue;
    s.boundary.push_back({local[tri[0]], local[tri[1]], local[tri[2]]});
    s.boundary_ids.push_back(m.boundary_ids[f]);
  }
  return sub;
}

/// Replaces the tets `sub` was extracted from by sub.mesh's: the other tets
/// keep their order, sub.mesh's follow them; sub.mesh's points go back to
/// their global indices, and its new points are appended in order.
void put_back(VolumeMesh& m, SubMesh&& sub) {
  const std::size_t n_old = sub.global_points.size();
  const auto n_global = static_cast<Index>(m.points.size());
  tbb::parallel_for(std::size_t{0}, n_old, [&](std::size_t i) { m.points[sub.global_points[i]] = sub.mesh.points[i]; });
  m.points.insert(m.points.end(), sub.mesh.points.begin() + static_cast<std::ptrdiff_t>(n_old), sub.mesh.points.end());
  // Compacts the tets that stay in place (serial, in one pass over memory
  // already held: the mesh is never copied whole).
  std::size_t w = 0, next = 0;
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    if (next < sub.global_tets.size() && sub.global_tets[next] == t) {
      ++next;
      continue;
    }
    m.tets[w] = m.tets[t];
    m.tet_regions[w] = m.tet_regions[t];
    ++w;
  }
  m.tets.resize(w + sub.mesh.tets.size());
  m.tet_regions.resize(m.tets.size());
  tbb::parallel_for(std::size_t{0}, sub.mesh.tets.size(), [&](std::size_t i) {
    Tet g;
    for (int k = 0; k < 4; ++k) {
      const Index v = sub.mesh.tets[i][k];
      g[k] = v < n_old ? sub.global_points[v] : n_global + (v - static_cast<Index>(n_old));
    }
    m.tets[w + i] = g;
    m.tet_regions[w + i] = sub.mesh.tet_regions[i];
  });
}

/// The leaves of m.tet_regions not in `done` (ascending), ascending.
std::vector<LeafId> leaves_without(const VolumeMesh& m, const std::vector<LeafId>& done) {
  std::vector<LeafId> present(m.tet_regions.begin(), m.tet_regions.end());
  tbb::parallel_sort(present.begin(), present.end());
  present.erase(std::unique(present.begin(), present.end()), present.end());
  std::vector<LeafId> out;
  std::set_difference(present.begin(), present.end(), done.begin(), done.end(), std::back_inserter(out));
  return out;
}

/// tet_regions = the leaf of the depth-`depth` grid over `box` that holds each
/// tet's barycenter (in parallel: each tet writes its own entry).
void assign_leaves(VolumeMesh& m, const Box& box, int depth) {
  m.tet_regions.resize(m.tets.size());
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    m.tet_regions[t] = static_cast<int>(leaf_of_point(box, depth, tet_barycenter(m, static_cast<Index>(t))));
  });
}

/// Drops points no tet uses, keeping the order of the others. The marks and
/// the renumbering of the tets run in parallel (idempotent stores, own slots).
void remove_unused_points(VolumeMesh& m) {
  std::vector<Index> map(m.points.size(), kNoIndex);
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    for (Index v : m.tets[t]) std::atomic_ref<Index>(map[v]).store(0, std::memory_order_relaxed);
  });
  Index next = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    if (map[i] == kNoIndex) continue;
    map[i] = next;
    m.points[next++] = m.points[i];
  }
  m.points.resize(next);
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    for (Index& v : m.tets[t]) v = map[v];
  });
  for (Tri& f : m.boundary)
    for (Index& v : f) v = map[v];
}

}  // namespace

double surface_spacing(const SurfaceMesh& surface, const SizingField& sizing) {
  double sum_h = 0;
  for (const Vec3& p : surface.points) sum_h += sizing.at(p);
  return sum_h / static_cast<double>(surface.points.size());
}

Result<PdrPlan> plan_pdr(const SurfaceMesh& surface, double surface_h, const PdrOptions& options,
                         const LeafKernel& kernel) {
  if (options.depth > kMaxDepth) {
    return invalid_input(fmt::format("octree depth {} is outside [0, {}] (or -1)", options.depth, kMaxDepth));
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
  if (plan.depth < 0) {
    const double volume = enclosed_volume(surface);
    const double estimate = volume / regular_tet_volume(surface_h);
    const double capped = std::isfinite(estimate) ? std::clamp(estimate, 0.0, 1e15) : 0.0;
    const std::size_t per_leaf =
        options.final_tets_per_leaf > 0 ? options.final_tets_per_leaf : buffered ? 5000 : 20000;
    plan.depth = capped < static_cast<double>(options.min_parallel_tets)
                     ? 0
                     : default_depth(static_cast<std::size_t>(capped), per_leaf,
                                     [&](int d) { return occupied_leaves_estimate(surface.points, volume, d); });
  }
  TetgenOptions& tg = plan.tetgen;
  const double leaf_side = side / static_cast<double>(1 << plan.depth);
  tg.max_volume = std::max(leaf_side * leaf_side * leaf_side / options.initial_volume_divisor,
                           options.initial_min_volume_factor.value_or(buffered ? 16 : 2) * regular_tet_volume(surface_h));
  tg.time_limit_s = options.tetgen_time_limit_s;
  tg.radius_edge = options.initial_radius_edge;
  tg.seeds_only = options.initial_seeds_only.value_or(!kernel.needs_manifold_hull());
  if (!(*tg.max_volume > 0) || !std::isfinite(*tg.max_volume)) tg.max_volume.reset();
  // One leaf needs no seeds to balance: start from the boundary-conforming
  // mesh that the serial pipeline refines (with seeds sphere966, depth 0 by
  // default, made 0.963 times the serial tets).
  if (plan.depth == 0 && tg.seeds_only) tg.max_volume.reset();
  return plan;
}

Result<VolumeMesh> run_pdr(const SurfaceMesh& surface, const SizingField& sizing, const LeafKernel& kernel,
                           const PdrOptions& options, PdrProfile* profile) {
  const auto t0 = Clock::now();
  if (surface.points.empty() || surface.triangles.empty()) {
    return invalid_input(fmt::format("{}: the surface is empty", surface.name));
  }
  PDR_ASSIGN_OR_RETURN(const PdrPlan plan, plan_pdr(surface, surface_spacing(surface, sizing), options, kernel));
  if (options.resume != nullptr) {
    return run_pdr(surface, sizing, kernel, options, profile, plan, std::move(options.resume->mesh), 0);
  }
  if (options.progress && !options.progress({"initial mesh", 0, 0, 0})) {
    return cancelled("stopped before the initial mesh");
  }
  Result<VolumeMesh> initial = tetrahedralize(surface, plan.tetgen);
  if (!initial.ok()) return initial.status();
  return run_pdr(surface, sizing, kernel, options, profile, plan, std::move(*initial), seconds_since(t0));
}

Result<VolumeMesh> run_pdr(const SurfaceMesh& surface, const SizingField& sizing, const LeafKernel& kernel,
                           const PdrOptions& options, PdrProfile* profile, const PdrPlan& plan, VolumeMesh initial,
                           double initial_s) {
  const auto t_total = Clock::now();
  PdrProfile local;
  PdrProfile& prof = profile ? *profile : local;
  prof = PdrProfile{};
  const int depth = plan.depth;
  prof.depth = depth;
  prof.threads = static_cast<std::size_t>(tbb::this_task_arena::max_concurrency());
  const auto report = [&](std::string_view phase, std::size_t tets) {
    return !options.progress || options.progress({phase, 0, 0, tets});
  };
  prof.initial = initial_s;
  prof.initial_tets = initial.tets.size();
  VolumeMesh cur = std::move(initial);
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
  std::vector<RoundResult> rounds;
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
  /// An optimization round: only the tets `select` flags go to tasks, the
  /// others stay where they are (selected_round), and only the tasks' tets get
  /// the round's leaves (no later step reads the leaf of a tet).
  const auto selected_step = [&](std::string_view phase, const Box& box, int round_depth,
                                 const Selector& select) -> Status {
    return step(phase, [&]() -> Status {
      const auto td = Clock::now();
      BufferedRound b = selected_round(cur, box, round_depth, select());
      prof.decomposition += seconds_since(td);
      RoundResult r;
      PDR_TRY(run_round(phase, cur, std::move(b.d), boundary, sizing, *options.optimize_kernel, options, false, r,
                        {.outside = &b.outside}));
      account(std::move(r));
      return {};
    });
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
      tbb::parallel_for(std::size_t{0}, sizes.size(), [&](std::size_t v) { sizes[v] = sizing.at(cur.points[v]); });
      std::vector<LeafId> done, todo;
      for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
        for (int colour = 0; colour < 8; ++colour) {
          // A later sweep's few leaves leave most colours empty: those cost no pass over the mesh.
          if (sweep > 0 && std::none_of(todo.begin(), todo.end(), [&](LeafId l) { return colour_of(l, depth) == colour; }))
            continue;
          auto td = Clock::now();
          BufferedRound b = buffered_round(cur, box1, depth, colour, options.buffer_layers, sweep > 0 ? &todo : nullptr);
          prof.decomposition += seconds_since(td);
          if (b.d.size() == 0) continue;
          done.insert(done.end(), b.d.leaves.begin(), b.d.leaves.end());
          RoundResult r;
          PDR_TRY(run_round("refinement", cur, std::move(b.d), boundary, sizing, kernel, options, false, r,
                            {.outside = &b.outside,
                             .cores = &b.cores,
                             .grid = &grid,
                             .sizes = &sizes,
                             .leaves_before = prof.leaf_count}));
          prof.leaf_count += r.leaves;
          prof.max_leaf_tets = std::max(prof.max_leaf_tets, r.max_leaf_tets);
          account(std::move(r));
        }
        std::sort(done.begin(), done.end());
        todo = leaves_without(cur, done);
        if (todo.empty()) break;
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
    Selector bad;
    if (select) bad = [&] { return select_bad_tets(cur, options); };
    if (options.optimize_kernel != nullptr) {
      if (select) {
        PDR_TRY(selected_step("optimization", box1, depth, bad));
        if (depth > 0) PDR_TRY(selected_step("shifted optimization", box2, depth, bad));
      } else {
        PDR_TRY(round("optimization", box1, *options.optimize_kernel, false, depth, bad));
        if (depth > 0) PDR_TRY(round("shifted optimization", box2, *options.optimize_kernel, false, depth, bad));
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
      const int final_depth = depth - kFinalCoarsening >= 2 ? depth - kFinalCoarsening : 0;
      const auto sweep = [&]() -> Status {
        const Grid grid{box1, final_depth};
        auto td = Clock::now();
        // One leaf has no cuts for a buffer to cover.
        const int buffer = final_depth > 0 ? options.optimize_buffer_layers : 0;
        SubMesh sub = extract_tets(cur, select_bad_tets(cur, options, options.optimize_halo + buffer));
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
              select_bad_tets(sub.mesh, options, options.optimize_halo, colour >= 8 ? &cored : nullptr);
          BufferedRound b =
              buffered_round(sub.mesh, box1, final_depth, colour % 8, buffer, nullptr, &selected);
          prof.decomposition += seconds_since(td);
          if (b.d.size() == 0) continue;
          RoundResult r;
          PDR_TRY(run_round("final optimization", sub.mesh, std::move(b.d), sub_boundary, sizing,
                            *options.optimize_kernel, options, false, r,
                            {.outside = &b.outside,
                             .cores = &b.cores,
                             .grid = &grid,
                             .tets_beside = cur.tets.size() - sub.global_tets.size(),
                             .cored = &cored}));
          account(std::move(r));
        }
        td = Clock::now();
        put_back(cur, std::move(sub));
        prof.merge += seconds_since(td);
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
      PDR_TRY(selected_step("final optimization", box1, 0, bad));
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
