// SPDX-License-Identifier: AGPL-3.0-or-later
// Reconnection: flips (2-3, 3-2, edge removal) around the bad tets, taken where they
// raise the worst measure, and the interior repair's flips judged by the full
// measure. Every flip keeps the mesh valid and its frozen and kept faces.
#include "optimizer.hpp"

namespace pdrmesh::optimize_detail {

/// Runs the reconnection queue from `seeds` (processed in the given order).
std::size_t Optimizer::reconnect(std::vector<Index> seeds) {
  queue_ = std::move(seeds);
  std::size_t done = 0;
  if (!o_.reconnect) return 0;
  for (std::size_t head = 0; head < queue_.size(); ++head) {
    if (flips_this_sweep_ >= flip_budget_) break;
    const Index t = queue_[head];
    if (!m_.alive(t)) continue;
    const Badness b = badness(t);
    if (b == Badness::kGood) continue;
    if (try_flips(t)) {
      ++done;
      ++flips_this_sweep_;
      if (b == Badness::kSliver) ++st_.slivers_removed;
    }
  }
  st_.flips += done;
  return done;
}

/// Interior repair flips (see optimize.hpp): for each bad tet with no fixed
/// point in `seeds` (slot order), one edge removal or 2-3 flip judged by
/// measure() (min-max over the tets replaced) on its edges, its faces, then
/// its face neighbours' other edges; created bad tets with no fixed point
/// join the queue. Returns the flips done.
std::size_t Optimizer::repair_flips(std::vector<Index> seeds) {
  std::size_t done = 0;
  for (std::size_t head = 0; head < seeds.size(); ++head) {
    if (flips_this_sweep_ >= flip_budget_) break;
    const Index t = seeds[head];
    if (!m_.alive(t) || badness(t) == Badness::kGood || !free_tet(t)) continue;
    if (!repair_tet(t)) continue;
    ++done;
    ++flips_this_sweep_;
    for (Index c : m_.last_created())
      if (badness(c) != Badness::kGood && free_tet(c)) seeds.push_back(c);
    if (m_.alive(t)) seeds.push_back(t);
  }
  st_.flips += done;
  st_.repair_flips += done;
  return done;
}

/// One flip that improves the neighbourhood of the bad tet t, or none.
bool Optimizer::try_flips(Index t) {
  const auto p = corners(m_, m_.tet(t));
  const auto angles = dihedral_angles(p[0], p[1], p[2], p[3]);
  std::array<int, 6> edges{0, 1, 2, 3, 4, 5};
  std::stable_sort(edges.begin(), edges.end(),
                   [&](int a, int b) { return angles[a] > angles[b]; });
  for (int e : edges)
    if (remove_edge(m_, t, e) == FlipOutcome::kDone) return push_created();
  for (int f = 0; f < 4; ++f)
    if (flip23(m_, t, f) == FlipOutcome::kDone) return push_created();
  // The neighbourhood: edges of the face neighbours that t does not hold.
  for (int f = 0; f < 4; ++f) {
    const Index n = m_.neighbour(t, f);
    if (n == kNoIndex) continue;
    const Index u = face_tet(n);
    const int apex = face_local(n);
    for (int j = 0; j < 4; ++j) {
      if (j == apex) continue;
      if (remove_edge(m_, u, topo::kEdgeIndex[apex][j]) == FlipOutcome::kDone) {
        push_created();
        queue_.push_back(t);
        return true;
      }
    }
  }
  return false;
}

}  // namespace pdrmesh::optimize_detail
