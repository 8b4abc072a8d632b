// SPDX-License-Identifier: AGPL-3.0-or-later
// The PDR engine: initial mesh, decomposition, fix-ups, leaf tasks, merge,
// interface round. See pdr.hpp for the numbering and determinism argument.
#include "pdrmesh/pdr.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
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
#include "pdrmesh/byte_codec.hpp"
#include "pdrmesh/digest.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/surface_ids.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/stopwatch.hpp"
#include "pdrmesh/union_find.hpp"

namespace pdrmesh {

namespace {

using Clock = std::chrono::steady_clock;

/// Packed face neighbours (4 * u + g, or kNoIndex) of every tet face.
std::vector<Index> face_neighbours(const VolumeMesh& m) {
  struct Rec {
    Tri key;
    Index packed;
    bool operator<(const Rec& o) const { return std::tie(key, packed) < std::tie(o.key, o.packed); }
  };
  std::vector<Rec> faces;
  faces.reserve(4 * m.tets.size());
  for (Index t = 0; t < m.tets.size(); ++t)
    for (int f = 0; f < 4; ++f) faces.push_back({topo::sorted_key(topo::face_of(m.tets[t], f)), 4 * t + Index(f)});
  tbb::parallel_sort(faces.begin(), faces.end());  // a total order: std::sort's result
  std::vector<Index> nbr(faces.size(), kNoIndex);
  for (std::size_t i = 0; i + 1 < faces.size(); ++i) {
    if (faces[i].key == faces[i + 1].key) {
      nbr[faces[i].packed] = faces[i + 1].packed;
      nbr[faces[i + 1].packed] = faces[i].packed;
    }
  }
  return nbr;
}

/// The working state of the fix-ups: adjacency, vertex stars, leaf membership.
class Fixer {
 public:
  Fixer(const VolumeMesh& m, Decomposition& d) : m_(m), d_(d), nbr_(face_neighbours(m)) {
    start_.assign(m.points.size() + 1, 0);
    for (const Tet& t : m.tets)
      for (Index v : t) ++start_[v + 1];
    std::partial_sum(start_.begin(), start_.end(), start_.begin());
    star_.resize(start_.back());
    pinned_.assign(m.tets.size(), 0);
    std::vector<Index> fill(start_.begin(), start_.end() - 1);
    for (Index t = 0; t < m.tets.size(); ++t)
      for (Index v : m.tets[t]) star_[fill[v]++] = t;
  }

  /// Tets of leaf l that partition swap moves out: every face component of the
  /// leaf that shares a vertex with a larger one (ties: the lower-numbered
  /// component stays), ascending.
  std::vector<Index> loose_tets(Index l) const {
    const std::vector<Index>& tets = d_.leaf_tets[l];
    std::vector<Index> comp(tets.size(), kNoIndex);
    auto pos = [&](Index t) { return static_cast<Index>(std::lower_bound(tets.begin(), tets.end(), t) - tets.begin()); };
    std::vector<Index> size;
    std::vector<Index> queue;
    for (Index i = 0; i < tets.size(); ++i) {
      if (comp[i] != kNoIndex) continue;
      const auto c = static_cast<Index>(size.size());
      size.push_back(0);
      comp[i] = c;
      queue.assign(1, i);
      while (!queue.empty()) {
        const Index j = queue.back();
        queue.pop_back();
        ++size[c];
        for (int f = 0; f < 4; ++f) {
          const Index u = nbr_[4 * tets[j] + Index(f)];
          if (u == kNoIndex || d_.tet_leaf[u / 4] != l) continue;
          const Index k = pos(u / 4);
          if (comp[k] == kNoIndex) {
            comp[k] = c;
            queue.push_back(k);
          }
        }
      }
    }
    if (size.size() < 2) return {};
    // Components sharing a vertex form a group (vertex -> component pairs, sorted).
    std::vector<std::pair<Index, Index>> vc;
    for (Index i = 0; i < tets.size(); ++i)
      for (Index v : m_.tets[tets[i]]) vc.emplace_back(v, comp[i]);
    std::sort(vc.begin(), vc.end());
    UnionFind groups(size.size());
    for (std::size_t i = 1; i < vc.size(); ++i)
      if (vc[i].first == vc[i - 1].first) groups.unite(vc[i].second, vc[i - 1].second);
    std::vector<Index> keep(size.size(), kNoIndex);  // per group root: the kept component
    for (Index c = 0; c < size.size(); ++c) {
      Index& k = keep[groups.find(c)];
      if (k == kNoIndex || size[c] > size[k]) k = c;
    }
    std::vector<Index> out;
    for (Index i = 0; i < tets.size(); ++i)
      if (keep[groups.find(comp[i])] != comp[i]) out.push_back(tets[i]);
    return out;
  }

  /// Boundary extraction's move for leaf l: at the first hull edge, then hull
  /// vertex, where the leaf's tets form several sectors, the smallest sector of
  /// other leaves' tets that holds no pinned tet goes into l; failing that, the
  /// smallest sector of l goes to the lowest leaf holding a face neighbour of it
  /// there. Empty when the hull is manifold; `stuck` counts bad elements with
  /// no move.
  struct Move {
    std::vector<Index> tets;
    Index to = kNoIndex;
    bool stuck = false;
  };
  Move extraction(Index l) const {
    Move move;
    std::vector<std::array<Index, 2>> elements;  // edges (a < b), then vertices (v, kNoIndex)
    std::vector<std::array<Index, 2>> vertices;
    for (Index t : d_.leaf_tets[l]) {
      for (int f = 0; f < 4; ++f) {
        const Index u = nbr_[4 * t + Index(f)];
        if (u != kNoIndex && d_.tet_leaf[u / 4] == l) continue;
        const Tri tri = topo::face_of(m_.tets[t], f);
        for (int k = 0; k < 3; ++k) {
          elements.push_back({std::min(tri[k], tri[(k + 1) % 3]), std::max(tri[k], tri[(k + 1) % 3])});
          vertices.push_back({tri[k], kNoIndex});
        }
      }
    }
    std::sort(elements.begin(), elements.end());
    elements.erase(std::unique(elements.begin(), elements.end()), elements.end());
    std::sort(vertices.begin(), vertices.end());
    vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
    elements.insert(elements.end(), vertices.begin(), vertices.end());
    for (const auto& x : elements) {
      std::vector<Index> star;
      for (Index i = start_[x[0]]; i < start_[x[0] + 1]; ++i) {
        const Index t = star_[i];
        if (x[1] == kNoIndex || topo::local_vertex(m_.tets[t], x[1]) >= 0) star.push_back(t);
      }
      // Sectors: star tets joined across faces that contain x, on the same side.
      UnionFind uf(star.size());
      auto pos = [&](Index t) { return static_cast<Index>(std::lower_bound(star.begin(), star.end(), t) - star.begin()); };
      for (Index i = 0; i < star.size(); ++i) {
        const Tet& v = m_.tets[star[i]];
        const bool in_l = d_.tet_leaf[star[i]] == l;
        for (int f = 0; f < 4; ++f) {
          if (v[f] == x[0] || v[f] == x[1]) continue;  // face f lacks the opposite vertex v[f]
          const Index u = nbr_[4 * star[i] + Index(f)];
          if (u == kNoIndex || (d_.tet_leaf[u / 4] == l) != in_l) continue;
          uf.unite(i, pos(u / 4));
        }
      }
      std::size_t l_sectors = 0;
      Index best_in = kNoIndex, best_out = kNoIndex;  // roots of the smallest movable sectors
      std::vector<Index> count(star.size(), 0);
      std::vector<unsigned char> pinned(star.size(), 0);
      for (Index i = 0; i < star.size(); ++i) {
        ++count[uf.find(i)];
        pinned[uf.find(i)] |= pinned_[star[i]];
      }
      for (Index i = 0; i < star.size(); ++i) {
        if (uf.find(i) != i) continue;
        Index& best = d_.tet_leaf[star[i]] == l ? best_out : best_in;
        l_sectors += d_.tet_leaf[star[i]] == l ? 1 : 0;
        if (best == kNoIndex || count[i] < count[best]) best = i;
      }
      if (l_sectors < 2) continue;
      if (best_in != kNoIndex && pinned[best_in] != 0) {
        // Prefer any unpinned outside sector; else move the smallest own sector out.
        best_in = kNoIndex;
        for (Index i = 0; i < star.size(); ++i)
          if (uf.find(i) == i && d_.tet_leaf[star[i]] != l && pinned[i] == 0 &&
              (best_in == kNoIndex || count[i] < count[best_in]))
            best_in = i;
      }
      const Index root = best_in != kNoIndex ? best_in : best_out;
      for (Index i = 0; i < star.size(); ++i)
        if (uf.find(i) == root) move.tets.push_back(star[i]);
      if (root == best_in) {
        move.to = l;
        return move;
      }
      for (Index t : move.tets) {
        for (int f = 0; f < 4; ++f) {
          const Index u = nbr_[4 * t + Index(f)];
          if (u != kNoIndex && d_.tet_leaf[u / 4] != l) move.to = std::min(move.to, d_.tet_leaf[u / 4]);
        }
      }
      if (move.to != kNoIndex) return move;
      move.tets.clear();
      move.stuck = true;
    }
    return move;
  }

  /// Moves tet t to leaf `to`; `pin`: boundary extraction moved it there, and
  /// no other leaf's extraction may take it back (which could cycle forever).
  void move(Index t, Index to, bool pin = false) {
    pinned_[t] = pin ? 1 : 0;
    auto& from = d_.leaf_tets[d_.tet_leaf[t]];
    from.erase(std::lower_bound(from.begin(), from.end(), t));
    auto& dst = d_.leaf_tets[to];
    dst.insert(std::lower_bound(dst.begin(), dst.end(), t), t);
    d_.tet_leaf[t] = to;
  }

  /// Lowest leaf other than tet t's own that holds a face neighbour of t.
  Index neighbour_leaf(Index t) const {
    Index best = kNoIndex;
    for (int f = 0; f < 4; ++f) {
      const Index u = nbr_[4 * t + Index(f)];
      if (u != kNoIndex && d_.tet_leaf[u / 4] != d_.tet_leaf[t]) best = std::min(best, d_.tet_leaf[u / 4]);
    }
    return best;
  }

 private:
  const VolumeMesh& m_;
  Decomposition& d_;
  std::vector<Index> nbr_;
  std::vector<Index> start_, star_;  // vertex -> tets (CSR)
  std::vector<unsigned char> pinned_;
};

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
                               const FaceIdTable& boundary) {
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
  in.tets.reserve(tets.size());
  struct Face {
    Tri key;
    Tri tri;
    bool operator<(const Face& o) const { return std::tie(key, tri) < std::tie(o.key, o.tri); }
  };
  std::vector<Face> faces;
  faces.reserve(4 * tets.size());
  for (const Tet& t : tets) {
    const Tet lt = {local(t[0]), local(t[1]), local(t[2]), local(t[3])};
    in.tets.push_back(lt);
    for (int f = 0; f < 4; ++f) {
      const Tri tri = topo::face_of(lt, f);
      faces.push_back({topo::sorted_key(tri), tri});
    }
  }
  std::sort(faces.begin(), faces.end());
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i == 1) {
      const Tri& t = faces[i].tri;
      in.frozen_faces.push_back(t);
      in.frozen_ids.push_back(boundary.lookup({used[t[0]], used[t[1]], used[t[2]]}));
    }
    i = j;
  }
  return in;
}

FixupStats apply_fixups(const VolumeMesh& mesh, Decomposition& d, std::size_t max_sweeps) {
  FixupStats stats;
  Fixer fixer(mesh, d);
  for (; stats.sweeps < max_sweeps; ++stats.sweeps) {
    bool changed = false;
    auto t0 = Clock::now();
    for (Index l = 0; l < d.size(); ++l) {
      for (Index t : fixer.loose_tets(l)) {
        const Index to = fixer.neighbour_leaf(t);
        if (to == kNoIndex) continue;
        fixer.move(t, to);
        ++stats.swaps;
        changed = true;
      }
    }
    stats.swap_s += seconds_since(t0);
    t0 = Clock::now();
    for (Index l = 0; l < d.size(); ++l) {
      // Bounded: a tet moved in or out is pinned where it goes, so it never
      // comes back into l by l's own extraction.
      for (std::size_t pass = 0; pass < 2 * mesh.tets.size(); ++pass) {
        const Fixer::Move move = fixer.extraction(l);
        if (move.tets.empty()) break;
        for (Index t : move.tets) fixer.move(t, move.to, true);
        stats.moves += move.tets.size();
        changed = true;
      }
    }
    stats.extraction_s += seconds_since(t0);
    if (!changed) break;
  }
  stats.unresolved = leaves_needing_fixups(mesh, d).size();
  return stats;
}

std::vector<Index> leaves_needing_fixups(const VolumeMesh& mesh, const Decomposition& d) {
  Decomposition copy = d;  // Fixer takes a mutable decomposition; nothing is moved here
  const Fixer fixer(mesh, copy);
  std::vector<Index> out;
  for (Index l = 0; l < d.size(); ++l) {
    const Fixer::Move move = fixer.extraction(l);
    if (!fixer.loose_tets(l).empty() || !move.tets.empty() || move.stuck) out.push_back(l);
  }
  return out;
}

namespace {

struct RoundResult {
  std::size_t leaves = 0;
  std::size_t max_leaf_tets = 0;
  std::size_t failed = 0;      ///< leaves kept unrefined after a kernel error
  std::string first_failure;   ///< the lowest such leaf's error
  double merge_s = 0;          ///< serial: merges and the final splice
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
/// (sampled on every 4th tet), or the size of the leaf's selection when the
/// round sends only part of it. A heuristic for the order only; the result
/// does not depend on it.
std::vector<Index> cost_ranks(const VolumeMesh& cur, const Decomposition& d, const SizingField& sizing,
                              const std::vector<std::vector<Tet>>& sent) {
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
      c += 4 * vol / regular_tet_volume(sizing.at(tet_barycenter(cur, tets[i])));
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
std::vector<char> select_bad_tets(const VolumeMesh& m, const PdrOptions& options) {
  const auto& needs = options.optimize_selects;
  const std::vector<Vec3>& P = m.points;
  std::vector<char> flag(m.tets.size(), 0);
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    const Tet& k = m.tets[t];
    flag[t] = needs(P[k[0]], P[k[1]], P[k[2]], P[k[3]]) ? 1 : 0;
  });
  grow_selection(m, flag, options.optimize_halo);
  return flag;
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

/// Puts a round's results into `cur` as if leaf by leaf in ascending order:
/// leaf l's tets (task output, then its kept tets) follow those of the leaves
/// before it, and new point k of leaf l gets the next id after the new points
/// of the leaves before it. Point moves go first, in leaf order (the leaves of
/// a round move disjoint points: nothing moves a hull point); the rest is
/// copied in parallel into slots fixed by prefix sums, so the result does not
/// depend on the threads. Frees the results as it goes.
void splice(VolumeMesh& cur, const std::vector<LeafId>& leaves, std::vector<TaskResult>& results,
            std::vector<std::vector<Tet>>& kept, RoundResult& rr) {
  const std::size_t n = results.size();
  std::vector<Vec3>& pts = cur.points;
  std::vector<std::size_t> tet_at(n + 1, 0), point_at(n + 1, pts.size());
  for (std::size_t l = 0; l < n; ++l) {
    TaskResult& r = results[l];
    if (!r.kernel_error.ok() && rr.failed++ == 0) rr.first_failure = r.kernel_error.message();
    for (std::size_t i = 0; i < r.output.moved.size(); ++i) pts[r.point_ids[r.output.moved[i]]] = r.output.moved_to[i];
    tet_at[l + 1] = tet_at[l] + r.output.tets.size() + kept[l].size();
    point_at[l + 1] = point_at[l] + r.output.new_points.size();
  }
  cur.tets.resize(tet_at[n]);
  cur.tet_regions.resize(tet_at[n]);
  pts.resize(point_at[n]);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t l) {
    TaskResult& r = results[l];
    const auto ni = static_cast<Index>(r.point_ids.size());
    const auto base = static_cast<Index>(point_at[l]);
    std::copy(r.output.new_points.begin(), r.output.new_points.end(), pts.begin() + static_cast<std::ptrdiff_t>(base));
    auto out = cur.tets.begin() + static_cast<std::ptrdiff_t>(tet_at[l]);
    for (const Tet& t : r.output.tets) {
      Tet g;
      for (int i = 0; i < 4; ++i) g[i] = t[i] < ni ? static_cast<Index>(r.point_ids[t[i]]) : base + (t[i] - ni);
      *out++ = g;
    }
    std::copy(kept[l].begin(), kept[l].end(), out);
    std::fill(cur.tet_regions.begin() + static_cast<std::ptrdiff_t>(tet_at[l]),
              cur.tet_regions.begin() + static_cast<std::ptrdiff_t>(tet_at[l + 1]), static_cast<int>(leaves[l]));
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
Status run_round(std::string_view phase, VolumeMesh& cur, Decomposition d, const FaceIdTable& boundary,
                 const SizingField& sizing, const LeafKernel& kernel, const PdrOptions& options, bool fixups,
                 RoundResult& rr, const std::vector<char>* selected = nullptr) {
  if (fixups) rr.fixups = apply_fixups(cur, d, options.max_fixup_sweeps);
  rr.leaves = d.size();
  std::vector<std::vector<Tet>> leaf_tets(d.size());
  std::vector<std::vector<Tet>> kept(d.size());
  tbb::parallel_for(Index{0}, static_cast<Index>(d.size()), [&](Index l) {
    for (Index t : d.leaf_tets[l]) (selected == nullptr || (*selected)[t] ? leaf_tets[l] : kept[l]).push_back(cur.tets[t]);
  });
  for (const std::vector<Tet>& sent : leaf_tets) {
    rr.max_leaf_tets = std::max(rr.max_leaf_tets, sent.size());
    rr.record.tets_sent += sent.size();
  }
  rr.record.tets = cur.tets.size();
  const std::vector<Index> rank = cost_ranks(cur, d, sizing, leaf_tets);
  const std::vector<Vec3>& points = cur.points;  // read-only during the round
  Status error;
  std::atomic<bool> stop{false};
  std::size_t merged = 0;
  std::size_t tet_count = cur.tets.size();
  if (options.progress && !options.progress({phase, 0, d.size(), tet_count})) {
    return cancelled(fmt::format("stopped before the {}", phase));
  }
  std::vector<TaskResult> results(d.size());
  std::function<TaskResult(Index)> task = [&](Index l) -> TaskResult {
    TaskResult r;
    if (stop.load()) {
      r.status = cancelled("stopped");
      return r;
    }
    LeafTaskInput in = build_leaf_input(l, points, leaf_tets[l], boundary);
    r.output.leaf = l;
    r.output.input_points = static_cast<std::uint32_t>(in.points.size());
    if (in.tets.empty()) return r;
    Result<std::string> bytes = run_leaf_task(kernel, in.encode(), sizing);
    Result<LeafTaskOutput> out = bytes.ok() ? LeafTaskOutput::decode(*bytes) : Result<LeafTaskOutput>(bytes.status());
    if (!bytes.ok() && options.keep_failed_leaves && is_kernel_failure(bytes.status())) {
      // The kernel gave up on this leaf (TetGen crashing on a hull, say): keep
      // the leaf as it was, which conforms to its neighbours by construction.
      r.kernel_error = Status(bytes.status().code(), fmt::format("leaf {}: {}", l, bytes.status().message()));
      r.output.tets = std::move(in.tets);
      r.point_ids = std::move(in.point_ids);
      return r;
    }
    if (!out.ok()) {
      r.status = Status(out.status().code(), fmt::format("leaf {}: {}", l, out.status().message()));
      return r;
    }
    if (const std::uint64_t limit = leaf_output_byte_limit(in, sizing); bytes->size() > limit) {
      r.status = invalid_input(
          fmt::format("leaf {} result rejected: {} bytes, over the {} its leaf can hold", l, bytes->size(), limit));
      return r;
    }
    r.status = validate_leaf_output(in, *out);
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
    if (options.progress && !options.progress({phase, merged, d.size(), tet_count})) {
      error = cancelled(fmt::format("stopped after {} of {} leaves ({})", merged, d.size(), phase));
      stop = true;
    }
  };
  rr.schedule = run_leaves<TaskResult>(d, std::max<std::size_t>(options.workers, 1), task, merge, options.policy, rank,
                                       options.concurrency);
  PDR_TRY(error);

  const auto t0 = Clock::now();
  splice(cur, d.leaves, results, kept, rr);
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
  if (plan.depth < 0) {
    const double volume = enclosed_volume(surface);
    const double estimate = volume / regular_tet_volume(surface_h);
    const double capped = std::isfinite(estimate) ? std::clamp(estimate, 0.0, 1e15) : 0.0;
    plan.depth = default_depth(static_cast<std::size_t>(capped), options.final_tets_per_leaf,
                               [&](int d) { return occupied_leaves_estimate(surface.points, volume, d); });
  }
  TetgenOptions& tg = plan.tetgen;
  const double leaf_side = side / static_cast<double>(1 << plan.depth);
  tg.max_volume = std::max(leaf_side * leaf_side * leaf_side / options.initial_volume_divisor,
                           options.initial_min_volume_factor * regular_tet_volume(surface_h));
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

namespace {

constexpr char kCheckpointMagic[8] = {'P', 'D', 'R', 'C', 'K', 'P', 'T', '\0'};
constexpr std::uint32_t kCheckpointVersion = 1;

Status checkpoint_error(std::string_view what) {
  return invalid_input(fmt::format("PDR checkpoint: {}", what));
}

}  // namespace

std::string PdrCheckpoint::encode() const {
  codec::Writer w;
  w.bytes(kCheckpointMagic, sizeof kCheckpointMagic);
  w.u32(kCheckpointVersion);
  w.u32(static_cast<std::uint32_t>(rounds_done));
  w.u64(round.size());
  w.bytes(round.data(), round.size());
  w.u64(mesh.points.size());
  for (const Vec3& p : mesh.points)
    for (double c : p) w.f64(c);
  w.u64(mesh.tets.size());
  for (const Tet& t : mesh.tets)
    for (Index v : t) w.u32(v);
  w.u64(mesh.boundary.size());
  for (const Tri& f : mesh.boundary)
    for (Index v : f) w.u32(v);
  w.u64(mesh.boundary_ids.size());
  for (int id : mesh.boundary_ids) w.u32(static_cast<std::uint32_t>(id));
  w.u64(mesh.tet_regions.size());
  for (int r : mesh.tet_regions) w.u32(static_cast<std::uint32_t>(r));
  std::string bytes = w.take();
  codec::Writer tail;
  tail.u64(content_digest(bytes));
  bytes += tail.take();  // appended: no second copy of a large mesh's bytes
  return bytes;
}

Result<PdrCheckpoint> PdrCheckpoint::decode(std::string_view bytes) {
  // The digest at the end first: a file cut short or damaged is refused whole.
  std::uint64_t digest = 0;
  if (bytes.size() < 8 || !codec::Reader(bytes.substr(bytes.size() - 8)).u64(digest) ||
      digest != content_digest(bytes.substr(0, bytes.size() - 8))) {
    return checkpoint_error("the bytes do not match their digest (cut short or damaged)");
  }
  bytes.remove_suffix(8);
  codec::Reader r(bytes);
  char magic[8];
  std::uint32_t version = 0, rounds = 0;
  if (!r.bytes(magic, 8) || std::memcmp(magic, kCheckpointMagic, 8) != 0 || !r.u32(version) ||
      version != kCheckpointVersion) {
    return checkpoint_error("bad magic or version");
  }
  PdrCheckpoint c;
  std::size_t n = 0;
  if (!r.u32(rounds) || rounds > 64 || !r.count(1, n)) return checkpoint_error("truncated header");
  c.rounds_done = static_cast<int>(rounds);
  c.round.resize(n);
  if (!r.bytes(c.round.data(), n)) return checkpoint_error("truncated round name");
  if (!r.count(24, n)) return checkpoint_error("bad point count");
  c.mesh.points.resize(n);
  for (Vec3& p : c.mesh.points)
    for (double& x : p) r.f64(x);
  const auto indices = [&](auto& items, const char* what) -> Status {
    constexpr std::size_t k = std::tuple_size_v<typename std::decay_t<decltype(items)>::value_type>;
    if (!r.count(4 * k, n)) return checkpoint_error(fmt::format("bad {} count", what));
    items.resize(n);
    for (auto& item : items) {
      for (Index& v : item) {
        r.u32(v);
        if (v >= c.mesh.points.size()) return checkpoint_error(fmt::format("{} index {} out of range", what, v));
      }
    }
    return {};
  };
  const auto ints = [&](std::vector<int>& items, std::size_t expected, const char* what) -> Status {
    if (!r.count(4, n) || n != expected) {
      return checkpoint_error(fmt::format("bad {} count", what));
    }
    items.resize(n);
    for (int& x : items) {
      std::uint32_t u = 0;
      r.u32(u);
      x = static_cast<int>(u);
    }
    return {};
  };
  PDR_TRY(indices(c.mesh.tets, "tet"));
  PDR_TRY(indices(c.mesh.boundary, "boundary face"));
  PDR_TRY(ints(c.mesh.boundary_ids, c.mesh.boundary.size(), "boundary id"));
  PDR_TRY(ints(c.mesh.tet_regions, c.mesh.tets.size(), "tet region"));
  if (r.left() != 0) return checkpoint_error(fmt::format("{} bytes after the end", r.left()));
  return c;
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
      prof.decomposition += seconds_since(td);
      std::vector<char> selected;
      if (select) selected = select();
      RoundResult r;
      PDR_TRY(run_round(phase, cur, std::move(d), boundary, sizing, k, options, fix, r, select ? &selected : nullptr));
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
  PDR_TRY(step("refinement", refinement));

  Box last_box = box1;
  if (options.interface_round && depth > 0 && options.interface_rounds > 0) {
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
      PDR_TRY(round("optimization", box1, *options.optimize_kernel, false, depth, bad));
      if (depth > 0) PDR_TRY(round("shifted optimization", box2, *options.optimize_kernel, false, depth, bad));
      last_box = depth > 0 ? box2 : box1;
      prof.optimization_leaves = seconds_since(t0);
    }
    if (select) {
      // The final pass: one task over the whole mesh's selection (its hull
      // frozen), so what the rounds' frozen hulls kept from them is reached.
      // Its tets are then in the one leaf of a depth-0 grid; afterwards each
      // gets the leaf of the last round's grid that holds its barycenter.
      const auto tg = Clock::now();
      PDR_TRY(round("final optimization", box1, *options.optimize_kernel, false, 0, bad));
      assign_leaves(cur, last_box, depth);  // the same again when resumed after it
      prof.global_optimization = seconds_since(tg);
    } else if (options.optimize) {
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
  return cur;
}

}  // namespace pdrmesh
