// SPDX-License-Identifier: AGPL-3.0-or-later
// The paper's fix-ups for a kernel that refills each leaf's hull (TetGen):
// partition swap and boundary extraction (pdr.hpp's apply_fixups).
#include <algorithm>
#include <array>
#include <chrono>
#include <numeric>
#include <tuple>
#include <vector>

#include <oneapi/tbb/parallel_sort.h>

#include "pdrmesh/pdr.hpp"
#include "pdrmesh/stopwatch.hpp"
#include "pdrmesh/topology.hpp"
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


}  // namespace pdrmesh
