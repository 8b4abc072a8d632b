// SPDX-License-Identifier: AGPL-3.0-or-later
// Angle and margin polish: compass searches of free points that raise their stars'
// smallest angle, or their bad tets' margin to the targets, where every tet stays
// positive and within its bounds, so that no extreme of the mesh gets worse.
#include "moves.hpp"

namespace pdrmesh::optimize_detail {

/// Angle polish (optimize.hpp, 6.): the free points of the tets whose
/// smallest dihedral angle is under target_min_dihedral, ascending, each
/// once (polish_point). Returns the points moved.
std::size_t Optimizer::polish_angles() {
  find_fixed();
  std::vector<Index> wanted;
  for (Index t : bad_tets()) {
    const auto p = corners(m_, m_.tet(t));
    if (!(dihedral_range(p[0], p[1], p[2], p[3]).min < o_.target_min_dihedral)) continue;
    for (Index v : m_.tet(t)) wanted.push_back(v);
  }
  sort_unique(wanted);
  std::erase_if(wanted, [this](Index v) { return v < s_.fixed.size() && s_.fixed[v]; });
  const std::size_t moved = move_points(wanted, Attempt::kAngle, [](Optimizer& opt, Index v, Index start) {
    return opt.polish_point(v, start) ? Outcome::kDone : Outcome::kNotBetter;
  });
  st_.points_moved += moved;
  return moved;
}

/// Margin polish (optimize.hpp, 7.): up to kMarginRounds rounds; in each,
/// first the ring (the free points next to a free point of a bad tet with
/// no surface point, not on such a tet themselves), ascending, each moved by
/// margin_point as the ring, then the free points of those bad tets,
/// ascending, each moved by margin_point; each compass search ends at 1/`end` of its first
/// step; with `extremes`, the tets with a surface point may use the mesh's
/// extremes (margin_point). The ring is `layers` deep: with more than one,
/// the free points next to the ring (not on a bad tet) join it, and so on.
/// Returns the moves.
std::size_t Optimizer::polish_margins(double end, bool extremes, int layers) {
  find_fixed();
  std::size_t moved = 0;
  // Per point: 1 wanted (a point of such a bad tet), 2 in the ring; reset
  // after each round, so a round costs what its points and stars do.
  marks_.resize(m_.num_points(), 0);
  for (int round = 0; round < kMarginRounds; ++round) {
    std::vector<Index> wanted;
    for (Index t : bad_tets()) {
      if (tet_class(m_.tet(t)) == TetClass::kSurface) continue;
      for (Index v : m_.tet(t)) wanted.push_back(v);
    }
    if (wanted.empty()) break;  // most meshes: no star walks
    sort_unique(wanted);
    for (Index v : wanted) marks_[v] = 1;
    const AngleRange mesh = angles();  // the extremes as the round begins
    attempt_key(Attempt::kMargin, {end, extremes ? 1.0 : 0.0, mesh.min, mesh.max});
    attempt_key(Attempt::kRing, {end, extremes ? 1.0 : 0.0, mesh.min, mesh.max});
    // The moves of the ring's points, then of the wanted ones (move_points).
    const auto moves = [&](std::span<const Index> points, bool ring) {
      return move_points(points, ring ? Attempt::kRing : Attempt::kMargin,
                         [&](Optimizer& opt, Index v, Index start) {
                           return opt.margin_point(v, start, end, ring, extremes, mesh) ? Outcome::kDone
                                                                                         : Outcome::kNotBetter;
                         });
    };
    // The ring: the free points of the links of the free wanted points that
    // are not wanted themselves; each deeper layer, those of the links of the
    // last layer's points not taken yet. Sets: the walks' order does not matter.
    std::vector<Index> ring, layer, next;
    const auto visit = [&](Index v, std::vector<Index>& out) {
      gather_link(v, any_tet(v));
      for (const Tri& f : link_)
        for (Index u : f)
          if (marks_[u] == 0 && !s_.fixed[u]) {
            marks_[u] = 2;
            out.push_back(u);
          }
    };
    for (Index v : wanted)
      if (!s_.fixed[v]) visit(v, ring);
    layer = ring;
    for (int depth = 1; depth < layers && !layer.empty(); ++depth) {
      next.clear();
      for (Index v : layer) visit(v, next);
      ring.insert(ring.end(), next.begin(), next.end());
      std::swap(layer, next);
    }
    std::sort(ring.begin(), ring.end());
    std::size_t now = moves(ring, /*ring=*/true);
    for (Index v : wanted) marks_[v] = 0;
    std::erase_if(wanted, [this](Index v) { return s_.fixed[v] != 0; });
    now += moves(wanted, /*ring=*/false);
    for (Index v : ring) marks_[v] = 0;
    moved += now;
    if (now == 0) break;
  }
  st_.points_moved += moved;
  st_.margin_moves += moved;
  return moved;
}

/// Angle polish of v (polish_angles): a compass search for the position
/// that raises the smallest dihedral angle of v's star, every tet of it
/// positive (exact) and within its bounds: one with a surface point (its
/// link face on_surface) keeps its largest angle within the larger of
/// kRelaxedCapAngles[1] and the star's old largest; one with none stays
/// within the targets or no worse than it was on either side (the interior
/// bound). True when v moved.
bool Optimizer::polish_point(Index v, Index start) {
  gather_link(v, start);
  const Vec3 old = m_.point(v);
  const AngleRange before = angle_range(&old, {});
  if (!(before.min < o_.target_min_dihedral)) return false;
  const double largest = std::max(kRelaxedCapAngles[1], before.max);
  polish_bounds_.clear();
  for (const Tri& f : link_) {
    if (on_surface(f)) {
      polish_bounds_.push_back({0.0, largest});
      continue;
    }
    const AngleRange r = dihedral_range(m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), old);
    polish_bounds_.push_back(target_bounds(r));
  }
  return move_by_score(v, before.min, [this](std::size_t i, const AngleRange& r) {
    return within(r, polish_bounds_[i]) ? r.min : -kInfinity;
  });
}

/// The angles a tet whose angles are r may reach: the targets, widened on
/// either side to r where r lies outside them (within stays within, outside
/// gets no worse).
AngleRange Optimizer::target_bounds(const AngleRange& r) const {
  return {std::min(o_.target_min_dihedral, r.min), std::max(o_.target_max_dihedral, r.max)};
}

/// How far the dihedral angles of r lie inside the targets, in degrees:
/// negative for a tet outside them (by its worse side).
double Optimizer::margin(const AngleRange& r) const {
  return std::min(r.min - o_.target_min_dihedral, o_.target_max_dihedral - r.max);
}

/// The angles a tet with a surface point may reach from `old` in the margin
/// and size polish: a side within `limits` stays within them, a side already
/// past them may go as far as the mesh's extreme on that side when the round
/// began (`mesh`), so neither extreme of the mesh gets worse, nor the
/// share of tets past the limits. The margin polish's limits are
/// kRelaxedCapAngles (no tet crosses 10 or 165 degrees). Next to needle
/// triangles the tets on the surface are that bad anyway, and letting them
/// move within that range gives the tets off the surface room.
AngleRange Optimizer::surface_bounds(const AngleRange& old, const AngleRange& limits, const AngleRange& mesh) {
  return {old.min < limits.min ? std::min(mesh.min, old.min) : limits.min,
          old.max > limits.max ? std::max(mesh.max, old.max) : limits.max};
}

/// Margin polish of v (polish_margins): a compass search for the position
/// that raises the smallest margin() of v's star's bad tets with no surface
/// point, every tet positive (exact); such a tet within the targets stays
/// within them, and a tet with a surface point keeps its angles within
/// surface_bounds(its old angles, kRelaxedCapAngles), or with `extremes`
/// (the absorption's pass) within the mesh's extremes `mesh`. With `ring`, v is next to a bad tet's
/// point but on none (polish_margins' ring): every tet of its star with no
/// surface point is judged (all within the targets, and they stay within),
/// so that the bad tets' points find room next, and with keep_edge_sizes no
/// edge to a point off the surface is made short (bound_edge_sizes). True
/// when v moved.
bool Optimizer::margin_point(Index v, Index start, double end, bool ring, bool extremes, const AngleRange& mesh) {
  gather_link(v, start);
  const Vec3 old = m_.point(v);
  double worst = kInfinity;
  polish_bounds_.clear();
  margin_kind_.clear();
  for (const Tri& f : link_) {
    const AngleRange r = dihedral_range(m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), old);
    if (on_surface(f)) {
      margin_kind_.push_back(MarginKind::kSurface);
      polish_bounds_.push_back(
          surface_bounds(r, extremes ? mesh : AngleRange{kRelaxedCapAngles[0], kRelaxedCapAngles[1]}, mesh));
      continue;
    }
    const double q = margin(r);
    const bool judged = ring || q < 0;
    margin_kind_.push_back(judged ? MarginKind::kBad : MarginKind::kGood);
    polish_bounds_.push_back(r);
    if (judged) worst = std::min(worst, q);
  }
  if (ring ? worst == kInfinity : !(worst < 0)) return false;  // nothing to judge, or nothing bad
  if (ring) bound_edge_sizes(old);
  return move_by_score(v, worst, [this](std::size_t i, const AngleRange& r) {
    switch (margin_kind_[i]) {
      case MarginKind::kSurface:
        return within(r, polish_bounds_[i]) ? kInfinity : -kInfinity;
      case MarginKind::kGood:
        return margin(r) >= 0 ? kInfinity : -kInfinity;
      case MarginKind::kBad:
        break;
    }
    return margin(r);
  }, end);
}

}  // namespace pdrmesh::optimize_detail
