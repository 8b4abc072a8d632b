// SPDX-License-Identifier: AGPL-3.0-or-later
// One round of leaf tasks (run_round) and the splice of its results; the leaf
// task's input (build_leaf_input, FaceIdTable).
#include "rounds.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <functional>
#include <iterator>
#include <limits>
#include <numeric>
#include <string>
#include <utility>

#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_sort.h>

#include "pdrmesh/atomic_extremum.hpp"
#include "pdrmesh/fixed_chunks.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/stopwatch.hpp"
#include "pdrmesh/validate.hpp"

namespace pdrmesh {

FaceIdTable::FaceIdTable(std::span<const Tri> faces, std::span<const int> ids) {
  sorted_.reserve(faces.size());
  for (std::size_t i = 0; i < faces.size(); ++i) {
    sorted_.emplace_back(topo::sorted_key(faces[i]), i < ids.size() ? ids[i] : 0);
    last_point_ = std::max(last_point_, sorted_.back().first[2]);
  }
  std::sort(sorted_.begin(), sorted_.end());
}

int FaceIdTable::lookup(const Tri& face) const {
  const Tri key = topo::sorted_key(face);
  if (sorted_.empty() || key[2] > last_point_) return 0;  // a point no listed face has: an interior face
  const auto it = std::lower_bound(sorted_.begin(), sorted_.end(), std::pair<Tri, int>{key, std::numeric_limits<int>::min()});
  return it != sorted_.end() && it->first == key ? it->second : 0;
}

namespace {

/// Sorts keys whose low words ascend in their order (and are distinct) by
/// their high words, which are at most `largest`: a stable LSD radix sort of
/// the high word, a byte a pass, so the result is std::sort's. A task's
/// corners are a few tens of thousands: a few linear passes beat the sort.
void sort_by_high_word(std::vector<std::uint64_t>& keys, Index largest) {
  std::vector<std::uint64_t> other(keys.size());
  for (int shift = 32; shift < 64 && (std::uint64_t{largest} >> (shift - 32)) != 0; shift += 8) {
    std::array<std::size_t, 257> at{};
    for (const std::uint64_t k : keys) ++at[((k >> shift) & 0xff) + 1];
    for (std::size_t b = 1; b < at.size(); ++b) at[b] += at[b - 1];
    for (const std::uint64_t k : keys) other[at[(k >> shift) & 0xff]++] = k;
    keys.swap(other);
  }
}

}  // namespace

LeafTaskInput build_leaf_input(std::uint32_t leaf, std::span<const Vec3> points, std::span<const Tet> tets,
                               const FaceIdTable& boundary, std::span<const double> sizes) {
  LeafTaskInput in;
  in.leaf = leaf;
  // Every corner as (global point, corner slot), sorted: one pass then
  // numbers the points in ascending global order and fills in the tets. (The
  // slot takes 32 bits: a task of 2^30 tets would hold 16 GiB of tets alone.)
  std::vector<std::uint64_t> corners(4 * tets.size());
  Index largest = 0;
  for (std::size_t t = 0; t < tets.size(); ++t)
    for (int c = 0; c < 4; ++c) {
      corners[4 * t + c] = (std::uint64_t{tets[t][c]} << 32) | (4 * t + c);
      largest = std::max(largest, tets[t][c]);
    }
  sort_by_high_word(corners, largest);
  std::vector<Index> used;
  in.tets.resize(tets.size());
  for (const std::uint64_t k : corners) {
    const auto g = static_cast<Index>(k >> 32);
    if (used.empty() || used.back() != g) used.push_back(g);
    const auto slot = static_cast<std::size_t>(k & 0xffffffffu);
    in.tets[slot / 4][slot % 4] = static_cast<Index>(used.size() - 1);
  }
  corners = {};
  in.point_ids.assign(used.begin(), used.end());
  in.points.reserve(used.size());
  for (Index g : used) in.points.push_back(points[g]);
  if (!sizes.empty()) {
    in.sizes.reserve(used.size());
    for (Index g : used) in.sizes.push_back(sizes[g]);
  }
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

namespace round_detail {
namespace {

using Clock = std::chrono::steady_clock;

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
  if (d.size() <= 1) return std::vector<Index>(d.size(), 0);  // nothing to order
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

/// The outside tets' flags (RoundExtras::cored and ::bad, when set), which
/// the splice copies.
struct OutsideFlags {
  detail::UninitVector<char> cored, bad;
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
/// moved point's is evaluated again. The flags of x.cored and x.bad follow
/// the tets: the outside tets' from `outside_flags`, the others set here.
void splice(VolumeMesh& cur, const std::vector<LeafId>& leaves, std::vector<TaskResult>& results,
            std::vector<std::vector<Tet>>& kept, detail::UninitVector<Tet>& outside,
            detail::UninitVector<int>& outside_leaf,
            OutsideFlags& outside_flags, const RoundExtras& x, const SizingField& sizing, const PdrOptions& options,
            RoundResult& rr) {
  const Grid* grid = x.grid;
  std::vector<double>* sizes = x.sizes;
  std::vector<char>* cored = x.cored;
  std::vector<char>* bad = x.bad;
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
  detail::resize_prefaulted(cur.tets, tet_at[n]);
  detail::resize_prefaulted(cur.tet_regions, tet_at[n]);
  detail::resize_prefaulted(pts, point_at[n]);
  if (sizes != nullptr) detail::resize_prefaulted(*sizes, point_at[n]);
  detail::parallel_copy(outside.begin(), outside.end(), cur.tets.begin());
  detail::parallel_copy(outside_leaf.begin(), outside_leaf.end(), cur.tet_regions.begin());
  if (cored != nullptr) {
    cored->resize(tet_at[n]);
    detail::parallel_copy(outside_flags.cored.begin(), outside_flags.cored.end(), cored->begin());
  }
  if (bad != nullptr) {
    bad->resize(tet_at[n]);
    detail::parallel_copy(outside_flags.bad.begin(), outside_flags.bad.end(), bad->begin());
  }
  outside.clear();  // the run's scratch keeps its room for the next round
  outside_leaf.clear();
  outside_flags = {};
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
    if (cored != nullptr)
      std::fill(cored->begin() + static_cast<std::ptrdiff_t>(tet_at[l]),
                cored->begin() + static_cast<std::ptrdiff_t>(tet_at[l + 1]), char{0});
    if (grid != nullptr) {
      for (std::size_t t = tet_at[l]; t < tet_at[l] + r.output.tets.size(); ++t) {
        cur.tet_regions[t] = static_cast<int>(leaf_of_point(grid->box, grid->depth, tet_barycenter(cur, static_cast<Index>(t))));
        if (cored != nullptr) (*cored)[t] = cur.tet_regions[t] == static_cast<int>(leaves[l]) ? 1 : 0;
      }
    }
    if (bad != nullptr)
      for (std::size_t t = tet_at[l]; t < tet_at[l + 1]; ++t) (*bad)[t] = is_bad(cur, cur.tets[t], options);
    r = TaskResult{};
    kept[l] = {};
  });
}

}  // namespace

Status run_round(std::string_view phase, VolumeMesh& cur, Decomposition d, const FaceIdTable& boundary,
                 const SizingField& sizing, const LeafKernel& kernel, const PdrOptions& options, bool fixups,
                 RoundResult& rr, RoundExtras extras) {
  if (fixups) rr.fixups = apply_fixups(cur, d, options.max_fixup_sweeps);
  rr.leaves = d.size();
  const std::vector<char>* selected = extras.selected;
  std::vector<std::vector<Tet>> leaf_tets(d.size());
  std::vector<std::vector<Tet>> kept(d.size());
  tbb::parallel_for(Index{0}, static_cast<Index>(d.size()), [&](Index l) {
    for (Index t : d.leaf_tets[l]) (selected == nullptr || (*selected)[t] ? leaf_tets[l] : kept[l]).push_back(cur.tets[t]);
  });
  // The tets of no task, gathered by parallel passes that also first touch
  // their memory (a round on a large mesh leaves most of it outside).
  RoundScratch own;
  RoundScratch& scratch = extras.scratch != nullptr ? *extras.scratch : own;
  detail::UninitVector<Tet>& outside = scratch.outside;
  detail::UninitVector<int>& outside_leaf = scratch.outside_leaf;
  if (extras.outside != nullptr) {
    const bool has_leaf = cur.tet_regions.size() == cur.tets.size();
    outside.resize(extras.outside->size());
    outside_leaf.resize(extras.outside->size());
    tbb::parallel_for(std::size_t{0}, outside.size(), [&](std::size_t i) {
      outside[i] = cur.tets[(*extras.outside)[i]];
      outside_leaf[i] = has_leaf ? cur.tet_regions[(*extras.outside)[i]] : 0;
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
    if (extras.seeds != nullptr) in.seeds = (*extras.seeds)[l];
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
  OutsideFlags outside_flags;
  if (extras.outside != nullptr) {
    const auto gather = [&](const std::vector<char>* all, detail::UninitVector<char>& out) {
      if (all == nullptr) return;
      out.resize(extras.outside->size());
      tbb::parallel_for(std::size_t{0}, out.size(), [&](std::size_t i) { out[i] = (*all)[(*extras.outside)[i]]; });
    };
    gather(extras.cored, outside_flags.cored);
    gather(extras.bad, outside_flags.bad);
  }
  splice(cur, d.leaves, results, kept, outside, outside_leaf, outside_flags, extras, sizing, options, rr);
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

}  // namespace round_detail
}  // namespace pdrmesh
