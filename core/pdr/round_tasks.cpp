// SPDX-License-Identifier: AGPL-3.0-or-later
// Which tets go to which task in a round: selections (bad tets, interfaces,
// their halos), buffered rounds by colour, selected rounds, and the sub-meshes
// the final optimization works on. All in parallel, each tet or point writing
// only its own entry (or idempotent atomic stores), so deterministic.
#include "rounds.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
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

namespace pdrmesh::round_detail {

void grow_selection(const VolumeMesh& m, std::vector<char>& flag, int layers) {
  if (layers <= 0) return;
  // touched[v]: the layer whose pass first reached point v (the flagged
  // tets' points: 1; 0: not yet). Pass L flags the tets with a point touched
  // before it, and marks their untouched points L + 1. A store races only
  // with stores of the same value and with loads that take 0 and L + 1
  // alike (not before pass L + 1), so the result does not depend on the
  // threads, and each layer costs one pass over the tets instead of two.
  std::vector<std::uint16_t> touched(m.points.size(), 0);
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    if (flag[t])
      for (Index v : m.tets[t]) std::atomic_ref<std::uint16_t>(touched[v]).store(1, std::memory_order_relaxed);
  });
  for (int layer = 1; layer <= layers; ++layer) {
    const auto before = static_cast<std::uint16_t>(std::min(layer, 65534));
    const bool mark = layer < layers;
    tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
      if (flag[t]) return;
      bool near = false;
      for (Index v : m.tets[t]) {
        const std::uint16_t at = std::atomic_ref<std::uint16_t>(touched[v]).load(std::memory_order_relaxed);
        near = near || (at != 0 && at <= before);
      }
      if (!near) return;
      flag[t] = 1;
      if (!mark) return;
      for (Index v : m.tets[t]) {
        std::atomic_ref<std::uint16_t> at(touched[v]);
        if (at.load(std::memory_order_relaxed) == 0) at.store(static_cast<std::uint16_t>(before + 1), std::memory_order_relaxed);
      }
    });
  }
}

std::vector<char> bad_tets(const VolumeMesh& m, const PdrOptions& options) {
  std::vector<char> bad(m.tets.size());
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) { bad[t] = is_bad(m, m.tets[t], options); });
  return bad;
}

std::vector<char> select_around(const VolumeMesh& m, const std::vector<char>& bad, int halo,
                                const std::vector<char>* skip) {
  std::vector<char> flag(m.tets.size());
  tbb::parallel_for(std::size_t{0}, m.tets.size(),
                    [&](std::size_t t) { flag[t] = bad[t] != 0 && (skip == nullptr || !(*skip)[t]) ? 1 : 0; });
  grow_selection(m, flag, halo);
  return flag;
}

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

int colour_of(LeafId l, int depth) {
  const auto c = leaf_coords(l, depth);
  return static_cast<int>((c[0] & 1U) | (c[1] & 1U) << 1 | (c[2] & 1U) << 2);
}

BufferedRound buffered_round(const VolumeMesh& m, const Box& box, int depth, int colour, int layers,
                             const std::vector<LeafId>* allowed, const std::vector<char>* selected) {
  constexpr LeafId kNone = std::numeric_limits<LeafId>::max();
  constexpr LeafId kBlocked = kNone - 1;
  // Per-round arrays as large as the mesh, written whole by parallel passes
  // (no serial zero fill: these rounds run dozens of times on large meshes).
  detail::UninitVector<LeafId> owner(m.tets.size());
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    owner[t] = kNone;
    if (selected != nullptr && !(*selected)[t]) return;
    const auto l = static_cast<LeafId>(m.tet_regions[t]);
    if (colour_of(l, depth) != colour) return;
    if (allowed == nullptr || std::binary_search(allowed->begin(), allowed->end(), l)) owner[t] = l;
  });
  detail::UninitVector<LeafId> lo(m.points.size()), hi(m.points.size());
  for (int layer = 0; layer < layers; ++layer) {
    tbb::parallel_for(std::size_t{0}, m.points.size(), [&](std::size_t v) {
      lo[v] = kNone;
      hi[v] = LeafId{0};
    });
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


BufferedRound selected_round(const VolumeMesh& m, const Box& box, int depth, const std::vector<char>& selected) {
  detail::UninitVector<LeafId> owner(m.tets.size());
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    owner[t] = selected[t] ? leaf_of_point(box, depth, tet_barycenter(m, static_cast<Index>(t)))
                           : std::numeric_limits<LeafId>::max();
  });
  return tasks_of_owners(owner, box, depth);
}

BufferedRound tasks_of_owners(std::span<const LeafId> owner, const Box& box, int depth) {
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
  // Each leaf's tets, ascending, and those of no leaf (key nl).
  const std::size_t nl = r.d.leaves.size();
  const auto groups = detail::group_indices(owner.size(), nl + 1, [&](std::size_t t) {
    return owner[t] < kBlocked ? static_cast<std::size_t>(dense[owner[t]]) : nl;
  });
  const auto group = [&](std::size_t k) {
    return std::pair{groups.items.begin() + static_cast<std::ptrdiff_t>(groups.first[k]),
                     groups.items.begin() + static_cast<std::ptrdiff_t>(groups.first[k + 1])};
  };
  r.d.leaf_tets.resize(nl);
  tbb::parallel_for(std::size_t{0}, nl + 1, [&](std::size_t k) {
    const auto [b, e] = group(k);
    if (k < nl) {
      r.d.leaf_tets[k].assign(b, e);
    } else {
      r.outside.resize(static_cast<std::size_t>(e - b));
      detail::parallel_copy(b, e, r.outside.begin());
    }
  });
  r.d.n1.assign(r.d.size(), {});
  r.d.n2.assign(r.d.size(), {});
  return r;
}

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


std::vector<LeafId> leaves_without(const VolumeMesh& m, int depth, const std::vector<LeafId>& done) {
  std::vector<char> present(std::size_t{1} << (3 * depth), 0);
  tbb::parallel_for(std::size_t{0}, m.tet_regions.size(), [&](std::size_t t) {
    std::atomic_ref<char>(present[static_cast<std::size_t>(m.tet_regions[t])]).store(1, std::memory_order_relaxed);
  });
  for (LeafId l : done) present[l] = 0;
  std::vector<LeafId> out;
  for (std::size_t l = 0; l < present.size(); ++l)
    if (present[l]) out.push_back(static_cast<LeafId>(l));
  return out;
}


void assign_leaves(VolumeMesh& m, const Box& box, int depth) {
  m.tet_regions.resize(m.tets.size());
  tbb::parallel_for(std::size_t{0}, m.tets.size(), [&](std::size_t t) {
    m.tet_regions[t] = static_cast<int>(leaf_of_point(box, depth, tet_barycenter(m, static_cast<Index>(t))));
  });
}


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


}  // namespace pdrmesh::round_detail
