// SPDX-License-Identifier: AGPL-3.0-or-later
// Reconnection: flips (2-3, 3-2, edge removal) around the bad tets, judged by the
// flips' min-max criterion (MaxDihedral, flips.hpp): taken where they lower the worst
// largest dihedral angle. Every flip keeps the mesh valid and its frozen and kept faces.
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
    if (b == Badness::kGood || failed_before(Attempt::kFlips, t)) continue;
    if (try_flips(t) != Outcome::kDone) {
      remember_failure(Attempt::kFlips, t);
      continue;
    }
    ++done;
    ++flips_this_sweep_;
    if (b == Badness::kSliver) ++st_.slivers_removed;
  }
  st_.flips += done;
  return done;
}

/// One flip that improves the neighbourhood of the bad tet t (kDone), or
/// none (kNotBetter; each flip tried is counted by its own outcome).
Outcome Optimizer::try_flips(Index t) {
  MaxDihedral criterion(m_);
  const auto p = corners(m_, m_.tet(t));
  const auto angles = dihedral_angles(p[0], p[1], p[2], p[3]);
  std::array<int, 6> edges{0, 1, 2, 3, 4, 5};
  std::stable_sort(edges.begin(), edges.end(),
                   [&](int a, int b) { return angles[a] > angles[b]; });
  const auto done = [&] {
    push_created();
    return Outcome::kDone;
  };
  // An edge removal that failed fails again while the tets around the edge
  // and their points stay as they were, which holds while one of the edge's
  // ends has no later stamp (whatever changes those tets stamps both ends):
  // it is counted with the outcome it had (searched from another tet of the
  // ring a decline may be named differently, never a removal found).
  const auto removal = [&](Index u, int e) {
    const Tet& k = m_.tet(u);
    const Index a = k[topo::kEdgeVertex[e][0]], b = k[topo::kEdgeVertex[e][1]];
    const std::uint64_t key = a < b ? (std::uint64_t{a} << 32) | b : (std::uint64_t{b} << 32) | a;
    const auto later = [&](Index v, std::uint64_t c) { return v < s_.stamp.size() && s_.stamp[v] > c; };
    if (const auto it = s_.failed_removals.find(key);
        it != s_.failed_removals.end() && !(later(a, it->second.clock) && later(b, it->second.clock))) {
      return tally(LocalOperation::kFlip, it->second.outcome);
    }
    const Outcome o = tally(LocalOperation::kFlip, remove_edge(m_, u, e, criterion));
    if (o != Outcome::kDone) s_.failed_removals[key] = {o, s_.clock};
    return o;
  };
  for (int e : edges)
    if (removal(t, e) == Outcome::kDone) return done();
  for (int f = 0; f < 4; ++f)
    if (tally(LocalOperation::kFlip, flip23(m_, t, f, criterion)) == Outcome::kDone) return done();
  // The neighbourhood: edges of the face neighbours that t does not hold.
  for (int f = 0; f < 4; ++f) {
    const Index n = m_.neighbour(t, f);
    if (n == kNoIndex) continue;
    const Index u = face_tet(n);
    const int apex = face_local(n);
    for (int j = 0; j < 4; ++j) {
      if (j == apex) continue;
      if (removal(u, topo::kEdgeIndex[apex][j]) == Outcome::kDone) {
        push_created();
        queue_.push_back(t);
        return Outcome::kDone;
      }
    }
  }
  return Outcome::kNotBetter;
}

}  // namespace pdrmesh::optimize_detail
