// SPDX-License-Identifier: AGPL-3.0-or-later
// Size polish: edges off the surface brought back within [kShortEdge, kLongEdge] h by
// flips, splits and point moves, each taken only where no new tet leaves its angle
// bounds and no edge is pushed out of the band.
#include "moves.hpp"

namespace pdrmesh::optimize_detail {

/// Size polish (optimize.hpp, 9.): up to kSizeRounds rounds, while one
/// changes something; in each, of the edges between two points off the
/// surface, one of them moved or inserted by the optimization (touched),
/// that are out of [kShortEdge, kLongEdge] times the mean h of their ends
/// (h at the points, measured once each), the long ones are removed
/// (size_flips) or split (size_splits) where that holds, then the free
/// points of all of them and the new points, ascending, are moved by
/// size_point. Returns the moves.
std::size_t Optimizer::polish_sizes(bool room) {
  const auto touched = [this](Index v) { return v >= s_.first_new_point || (v < s_.moved.size() && s_.moved[v] != 0); };
  std::vector<double> h(m_.num_points(), -1.0);
  const auto h_at = [&](Index v) {
    if (h[v] < 0.0) h[v] = size_at(m_.point(v));
    return h[v];
  };
  std::size_t moved = 0;
  SizeBounds bounds;
  bounds.room = room;
  bounds.mesh = angles();
  bounds.limits = {std::max(kRelaxedCapAngles[0], bounds.mesh.min), std::min(kRelaxedCapAngles[1], bounds.mesh.max)};
  attempt_key(Attempt::kSize, {room ? 1.0 : 0.0, bounds.mesh.min, bounds.mesh.max, 0.0});
  for (int round = 0; round < kSizeRounds; ++round) {
    find_fixed();  // also sized for the points the last round's splits added
    h.resize(m_.num_points(), -1.0);
    const Index np = m_.num_points();
    // The tets with an edge to check: those of the touched points off the
    // surface (free points, whose stars the walks find whole), in slot order.
    std::vector<Index> walked;
    for (Index v : s_.moved_list)
      if (s_.surface[v] == 0) walked.push_back(v);
    for (Index v = s_.first_new_point; v < np; ++v)
      if (s_.surface[v] == 0) walked.push_back(v);
    const bool parallel = o_.parallel_moves && walked.size() >= kParallelMovesMin;
    if (parallel) (void)any_tet(walked.front());  // the walks' starts, known before they run
    std::vector<Index> tets = each_chunk(walked, [this](Index v, std::vector<Index>& out) { star_tets(v, out); }, parallel);
    sort_unique(tets, parallel);
    // The edges to check: off the surface, a touched end.
    const auto checked = [&](Index a, Index b) {
      return s_.surface[a] == 0 && s_.surface[b] == 0 && (touched(a) || touched(b));
    };
    if (parallel) {  // h at their ends, once each, first (the same values: at() with or without a hint)
      std::vector<Index> ends = each_chunk(tets, [&](Index t, std::vector<Index>& out) {
        const Tet& k = m_.tet(t);
        for (int e = 0; e < 6; ++e) {
          const Index a = k[topo::kEdgeVertex[e][0]], b = k[topo::kEdgeVertex[e][1]];
          if (!checked(a, b)) continue;
          if (h[a] < 0.0) out.push_back(a);
          if (h[b] < 0.0) out.push_back(b);
        }
      });
      sort_unique(ends, true);
      tbb::parallel_for(std::size_t{0}, ends.size(), [&](std::size_t i) { h[ends[i]] = sizing_->at(m_.point(ends[i])); });
    }
    std::vector<Index> wanted;
    long_edges_.clear();
    for (Index t : tets) {
      const Tet& k = m_.tet(t);
      for (int e = 0; e < 6; ++e) {
        const Index a = k[topo::kEdgeVertex[e][0]], b = k[topo::kEdgeVertex[e][1]];
        if (!checked(a, b)) continue;
        const Vec3 d = m_.point(a) - m_.point(b);
        const double mean = 0.5 * (h_at(a) + h_at(b)), l2 = dot(d, d);
        if (l2 > kLongEdge * kLongEdge * mean * mean) long_edges_.push_back({std::min(a, b), std::max(a, b), t, e});
        if (l2 < kShortEdge * kShortEdge * mean * mean || l2 > kLongEdge * kLongEdge * mean * mean) {
          wanted.push_back(a);
          wanted.push_back(b);
        }
      }
    }
    std::sort(long_edges_.begin(), long_edges_.end());  // each edge once, from its first tet
    long_edges_.erase(std::unique(long_edges_.begin(), long_edges_.end(),
                                  [](const LongEdge& x, const LongEdge& y) { return x.a == y.a && x.b == y.b; }),
                      long_edges_.end());
    const std::size_t flipped = o_.reconnect ? size_flips(bounds) : 0;
    st_.flips += flipped;
    st_.size_flips += flipped;
    const std::size_t split = o_.insert_points ? size_splits(bounds) : 0;
    st_.points_inserted += split;
    st_.size_splits += split;
    find_fixed();
    for (Index v = np; v < m_.num_points(); ++v) wanted.push_back(v);  // new: their edges may be out of the band
    sort_unique(wanted);
    std::erase_if(wanted, [this](Index v) { return s_.fixed[v] != 0; });
    const std::size_t now = move_points(wanted, Attempt::kSize, [&bounds](Optimizer& opt, Index v, Index start) {
      return opt.size_point(v, start, bounds) ? Outcome::kDone : Outcome::kNotBetter;
    });
    moved += now;
    if (now + flipped + split == 0) break;
  }
  st_.points_moved += moved;
  st_.size_moves += moved;
  return moved;
}

/// How far the edges from a point at x to the link points off the surface
/// (size_edges_) lie out of [kShortEdge, kLongEdge] h, h at their midpoints
/// when the search began: how many are out, then the sum of the distances
/// (in units of h) to the band.
std::pair<std::size_t, double> Optimizer::size_excess(const Vec3& x) const {
  std::pair<std::size_t, double> out{0, 0.0};
  for (const SizeEdge& e : size_edges_) {
    const double r = norm(x - m_.point(e.u)) / e.h;
    const double excess = std::max(r - kLongEdge, 0.0) + std::max(kShortEdge - r, 0.0);
    if (excess > 0.0) ++out.first;
    out.second += excess;
  }
  return out;
}

/// Whether the long edge le is still where polish_sizes found it (its tet
/// alive and holding it: the slot may hold another tet now).
bool Optimizer::ring_of(const LongEdge& le) const {
  if (!m_.alive(le.t)) return false;
  const Tet& k = m_.tet(le.t);
  const Index u = k[topo::kEdgeVertex[le.e][0]], w = k[topo::kEdgeVertex[le.e][1]];
  return std::min(u, w) == le.a && std::max(u, w) == le.b;
}

/// The angles a new tet of the size flips and splits must lie within: the
/// targets, or bounds.limits for a tet with a surface point with the room.
AngleRange Optimizer::size_bounds(const Tet& t, const SizeBounds& bounds) const {
  if (bounds.room && tet_class(t) == TetClass::kSurface) return bounds.limits;
  return {o_.target_min_dihedral, o_.target_max_dihedral};
}

/// The size flips' criterion: a new tet scores its measure() when it lies
/// within its size_bounds, else -inf; any such triangulation is taken (no
/// bar: the flip removes an edge out of the band, and the bounds keep the
/// angles).
class Optimizer::SizeCriterion final {
 public:
  SizeCriterion(const Optimizer& o, const SizeBounds& bounds) : o_(o), bounds_(bounds) {}
  double bar(std::span<const Index>) const { return -kInfinity; }
  double score(const Tet& k) const {
    const auto p = corners(o_.m_, k);
    return within(dihedral_range(p[0], p[1], p[2], p[3]), o_.size_bounds(k, bounds_)) ? o_.measure(p) : -kInfinity;
  }
  bool accepts(std::span<const Tet>) const { return true; }
  void done(std::span<const Index>, std::span<const double>) const {}

 private:
  const Optimizer& o_;
  const SizeBounds& bounds_;
};

/// Size flips (before each round's moves): each long edge of long_edges_
/// (in the order of its ends, from the first tet in slot order that held it
/// when the round began, if that tet still does) is removed where a triangulation of its
/// ring exists whose new tets are positive (exact), those with no surface
/// point within the targets and those with one within bounds.limits, and
/// whose new edges are all shorter than the removed one and, between two
/// points off the surface, within [kShortEdge, kLongEdge] h at their
/// midpoint: one edge fewer out of the band, none added. The triangulation
/// with the best smallest measure wins. Returns the flips.
std::size_t Optimizer::size_flips(const SizeBounds& bounds) {
  std::size_t flips = 0;
  SizeCriterion criterion(*this, bounds);
  for (const LongEdge& le : long_edges_) {
    if (!ring_of(le)) continue;
    const Vec3 d = m_.point(le.a) - m_.point(le.b);
    const double removed2 = dot(d, d);
    // A diagonal (ring[i], ring[j]) that is not a side of the ring polygon is a new edge.
    const auto refused = [&](const EdgeRing& r, int i, int j) {
      if (j - i < 2 || (i == 0 && j == r.size - 1)) return false;
      const Vec3 &x = m_.point(r.ring[i]), &y = m_.point(r.ring[j]);
      const double l2 = dot(x - y, x - y);
      if (l2 >= removed2) return true;
      if (!off_surface(r.ring[i]) || !off_surface(r.ring[j])) return false;
      const double h = size_at(0.5 * (x + y));
      return l2 < kShortEdge * kShortEdge * h * h || l2 > kLongEdge * kLongEdge * h * h;
    };
    const auto excluded = [&](const EdgeRing& r, int i, int m, int j) {
      return refused(r, i, m) || refused(r, m, j) || refused(r, i, j);
    };
    if (tally(LocalOperation::kFlip, remove_edge(m_, le.t, le.e, criterion, excluded)) != Outcome::kDone) continue;
    forget_created();
    ++flips;
  }
  return flips;
}

/// Size splits (after the size flips): each long edge of long_edges_ still
/// in the mesh gets a new point x on it, its ring's tets each split in two
/// (a and b in turn replaced by x), where every new tet is positive (exact)
/// and within the bounds of size_flips, and at most one new edge to a point
/// off the surface lies out of [kShortEdge, kLongEdge] h (x moves next, with
/// the polish's moves). x is tried at kSplitAt along the edge, the first
/// that holds taken. Returns the points added.
std::size_t Optimizer::size_splits(const SizeBounds& bounds) {
  std::size_t splits = 0;
  for (const LongEdge& le : long_edges_) {
    EdgeRing r;
    if (!ring_of(le) || removable_edge_ring(m_, le.t, le.e, 0, r) != Outcome::kDone) continue;
    // Whether a split at x holds: its new tets within their bounds (fresh_
    // gets them, with kNoIndex for the new point) and at most one of x's
    // edges out of the size band.
    const auto holds = [&](const Vec3& x) {
      const auto out_of_band = [&](Index v) {
        if (!off_surface(v)) return 0;
        const Vec3& y = m_.point(v);
        const double l = norm(x - y), hm = size_at(0.5 * (x + y));
        return l < kShortEdge * hm || l > kLongEdge * hm ? 1 : 0;
      };
      fresh_.clear();
      for (int i = 0; i < r.size; ++i) {
        const Tet& t = m_.tet(r.tets[i]);
        const AngleRange limits = size_bounds(t, bounds);  // the two halves hold t's points
        for (const Index replaced : {r.a, r.b}) {
          Tet n = t;
          std::array<Vec3, 4> p = corners(m_, t);
          for (int j = 0; j < 4; ++j)
            if (n[j] == replaced) {
              p[j] = x;
              n[j] = kNoIndex;
            }
          if (exact::orient3d(p[0], p[1], p[2], p[3]) <= 0 || !within(dihedral_range(p[0], p[1], p[2], p[3]), limits))
            return false;
          fresh_.push_back(n);
        }
      }
      // Then at most one edge to x out of the band, asked of the sizing
      // field only for candidates whose new tets hold (the cheaper test,
      // which declines most of them).
      int out = out_of_band(r.a) + out_of_band(r.b);
      for (int i = 0; i < r.size && out <= 1; ++i) out += out_of_band(r.ring[i]);
      return out <= 1;
    };
    const Vec3 &pa = m_.point(r.a), &pb = m_.point(r.b);
    bool found = false;
    Vec3 x{};
    for (std::size_t c = 0; c < kSplitAt.size() && !found; ++c) {
      x = pa + kSplitAt[c] * (pb - pa);
      found = holds(x);
    }
    if (!found) continue;
    replace_with_point(std::span<const Index>(r.tets.data(), static_cast<std::size_t>(r.size)), x);
    ++splits;
  }
  return splits;
}

/// Size polish of v (polish_sizes): a compass search for the position
/// that lowers size_excess (fewer edges out of the band, then less far out),
/// every tet of the star positive (exact); one with no surface point within
/// the targets or, where it was outside, no worse on either side than it
/// was; one with a surface point within surface_bounds(its old angles,
/// bounds.limits, bounds.mesh). True when v moved.
bool Optimizer::size_point(Index v, Index start, const SizeBounds& bounds) {
  gather_link(v, start);
  gather_link_points();
  const Vec3 old = m_.point(v);
  size_edges_.clear();
  for (Index u : link_points_)
    if (u >= s_.surface.size() || s_.surface[u] == 0)
      size_edges_.push_back({u, size_at(0.5 * (old + m_.point(u)))});
  std::pair<std::size_t, double> best = size_excess(old);
  if (best.first == 0) return false;
  polish_bounds_.clear();
  for (const Tri& f : link_) {
    const AngleRange r = dihedral_range(m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), old);
    const bool room = bounds.room && on_surface(f);
    polish_bounds_.push_back(room ? surface_bounds(r, bounds.limits, bounds.mesh) : target_bounds(r));
  }
  const Vec3 to = compass_search(old, [&](const Vec3& y) {
    const std::pair<std::size_t, double> excess = size_excess(y);
    if (!(excess < best)) return false;
    for (std::size_t i = 0; i < link_.size(); ++i) {
      const Vec3 &a = m_.point(link_[i][0]), &b = m_.point(link_[i][1]), &c = m_.point(link_[i][2]);
      if (exact::orient3d(a, b, c, y) <= 0 || !within(dihedral_range(a, b, c, y), polish_bounds_[i])) return false;
    }
    best = excess;
    return true;
  });
  if (to == old) return false;
  move_point(v, to);
  return true;
}

}  // namespace pdrmesh::optimize_detail
