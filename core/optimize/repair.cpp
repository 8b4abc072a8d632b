// SPDX-License-Identifier: AGPL-3.0-or-later
// Interior repair: the bad tets with no fixed point mended by flips, point removal,
// edge collapse and insertion, each judged by the criterion the pass hands over:
// RepairCriterion (the full measure; tets next to the surface give way only down to the
// repair floor) or AbsorbCriterion (the absorption hands them to the surface).
#include <type_traits>

#include "optimizer.hpp"

namespace pdrmesh::optimize_detail {

/// The interior repair's floor for tets with a surface point, now:
/// kRepairFloor, or kRepairFloorMargin times the measure that the mesh's
/// smallest dihedral angle (now) has on the acute side when that is lower.
/// Next to needle triangles, where the tets on the surface are that bad
/// anyway, the tets off it then get room to reach the targets, while no
/// repair makes a tet near the mesh's worst. The margin leaves the cap
/// repair and angle polish after it room too (at the worst measure itself
/// the mesh's smallest angle falls).
double Optimizer::repair_floor() {
  const double smallest = angles().min * (3.14159265358979323846 / 180.0);
  return std::min(kRepairFloor, kRepairFloorMargin * std::sin(smallest) * acute_);
}

/// Interior repair flips (see optimize.hpp): for each bad tet with no fixed
/// point in `seeds` (slot order), one operation of repair_tet judged by
/// `criterion`; created bad tets with no fixed point join the queue.
/// Returns the operations done.
template <class Criterion>
std::size_t Optimizer::repair_flips(std::vector<Index> seeds, Criterion& criterion, RepairMoves moves) {
  std::size_t done = 0;
  const Attempt kind = std::is_same_v<Criterion, AbsorbCriterion> ? Attempt::kAbsorb : Attempt::kRepair;
  AttemptKey key = criterion.key();
  key[2] = moves.insert ? 1.0 : 0.0;
  key[3] = moves.collapse ? 1.0 : 0.0;
  attempt_key(kind, key);
  for (std::size_t head = 0; head < seeds.size(); ++head) {
    if (flips_this_sweep_ >= flip_budget_) break;
    const Index t = seeds[head];
    if (!m_.alive(t) || badness(t) == Badness::kGood || !free_tet(t) || failed_before(kind, t)) continue;
    if (repair_tet(t, criterion, moves) != Outcome::kDone) {
      remember_failure(kind, t);
      continue;
    }
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

/// Absorption (optimize.hpp, 10.): repair_flips over `seeds` judged by
/// AbsorbCriterion against the mesh's extremes now, no point inserted into
/// a cavity and an edge collapse (collapse_edge) tried last. Returns the
/// operations.
std::size_t Optimizer::absorb(std::vector<Index> seeds) {
  find_fixed();
  AbsorbCriterion criterion(*this, angles());
  const std::size_t done = repair_flips(std::move(seeds), criterion, {.insert = false, .collapse = true});
  st_.absorbed += done;
  return done;
}

/// measure() of tet k, or -inf when k is not positive (exact).
double Optimizer::measured(const Tet& k) const {
  const auto p = corners(m_, k);
  if (exact::orient3d(p[0], p[1], p[2], p[3]) <= 0) return -std::numeric_limits<double>::infinity();
  return measure(p);
}

/// The class of tet k (TetClass) by s_.surface and s_.fixed (kNoIndex, a point
/// not made yet, counts as free).
TetClass Optimizer::tet_class(const Tet& k) const {
  TetClass c = TetClass::kInterior;
  for (Index v : k) {
    if (v < s_.surface.size() && s_.surface[v] != 0) return TetClass::kSurface;
    if (v < s_.fixed.size() && s_.fixed[v] != 0) c = TetClass::kFrozen;
  }
  return c;
}

/// The floors of a repair operation replacing `tets`, per TetClass: the
/// worst measure of the class, capped at 1 (at `surface_floor` for
/// kSurface). With `worst`, also the worst measure over all of them,
/// uncapped (each tet is measured once).
ClassFloors Optimizer::repair_floors(std::span<const Index> tets, double surface_floor, double* worst) const {
  ClassFloors q{{1.0, surface_floor, 1.0}};
  double lowest = std::numeric_limits<double>::infinity();
  for (Index t : tets) {
    const double m = measure(corners(m_, m_.tet(t)));
    double& f = q[tet_class(m_.tet(t))];
    f = std::min(f, m);
    lowest = std::min(lowest, m);
  }
  if (worst != nullptr) *worst = lowest;
  return q;
}

/// One repair operation around the bad tet t (repair_flips), judged by
/// `criterion`: an edge removal or 2-3 flip on its edges (most extreme angle
/// first), its faces, then its face neighbours' other edges; else (with
/// moves.insert) a point into its cavity, else one of its points removed,
/// else (with moves.collapse) an edge collapsed. kDone, or kNotBetter.
template <class Criterion>
Outcome Optimizer::repair_tet(Index t, Criterion& criterion, RepairMoves moves) {
  const auto flipped = [&](Outcome o) {
    if (tally(LocalOperation::kFlip, o) != Outcome::kDone) return false;
    forget_created();
    return true;
  };
  const auto p = corners(m_, m_.tet(t));
  const auto angles = dihedral_angles(p[0], p[1], p[2], p[3]);
  std::array<int, 6> edges{0, 1, 2, 3, 4, 5};
  std::stable_sort(edges.begin(), edges.end(), [&](int a, int b) {
    return std::abs(angles[a] - 90.0) > std::abs(angles[b] - 90.0);  // most extreme first
  });
  for (int e : edges)
    if (flipped(remove_edge(m_, t, e, criterion))) return Outcome::kDone;
  for (int f = 0; f < 4; ++f)
    if (flipped(flip23(m_, t, f, criterion))) return Outcome::kDone;
  for (int f = 0; f < 4; ++f) {
    const Index n = m_.neighbour(t, f);
    if (n == kNoIndex) continue;
    const Index u = face_tet(n);
    const int apex = face_local(n);
    for (int j = 0; j < 4; ++j)
      if (j != apex && flipped(remove_edge(m_, u, topo::kEdgeIndex[apex][j], criterion))) return Outcome::kDone;
  }
  // No flip: a point in the cavity of t and its face neighbours (as for
  // slivers, held to the repair's floors).
  if constexpr (std::is_same_v<Criterion, RepairCriterion>) {
    if (moves.insert && sizing_ != nullptr && o_.insert_points &&
        tally(LocalOperation::kInsertion, insert_into(t, &criterion)) == Outcome::kDone) {
      ++st_.points_inserted;
      return Outcome::kDone;
    }
  }
  // Nor a point: one of t's points removed.
  if (o_.remove_points && tally(LocalOperation::kRemoval, remove_point(t, criterion)) == Outcome::kDone) {
    ++st_.points_removed;
    return Outcome::kDone;
  }
  // Last: two of t's points replaced by one.
  if (moves.collapse && o_.remove_points && tally(LocalOperation::kCollapse, collapse_edge(t, criterion)) == Outcome::kDone) {
    ++st_.edges_collapsed;
    return Outcome::kDone;
  }
  return Outcome::kNotBetter;
}

/// Point removal (remove_points, optimize.hpp 4.): a free point v of the bad
/// tet t is contracted onto a point w of its link: v's star becomes the cone
/// from w over the link faces that do not hold w (the tets around the edge
/// (v, w) go). Of v's link points, the w whose cone has the best worst tet,
/// ascending index on ties; done when every tet of the cone is positive
/// (exact), beats the criterion's bar over the star and is accepted by it.
/// Positive tets over the whole link tile the star (it is star-shaped from
/// w), so the mesh stays a conforming tetrahedralization of the same region;
/// v is left in no tet (optimize() drops such points at the end).
/// kDone; kConstrained when every point of t is fixed (or its star too
/// large); else kNotBetter.
template <class Criterion>
Outcome Optimizer::remove_point(Index t, Criterion& criterion) {
  const Tet k = m_.tet(t);
  Outcome why = Outcome::kConstrained;
  for (Index v : k) {
    if ((v < s_.fixed.size() && s_.fixed[v] != 0) || !gather_star(v, t, kRemovalMaxStar)) continue;
    why = Outcome::kNotBetter;
    removal_star_.clear();
    for (const auto& [s, lv] : star_) removal_star_.push_back(s);
    removal_targets_.clear();
    for (const auto& [s, lv] : star_)
      for (Index u : m_.tet(s))
        if (u != v) removal_targets_.push_back(u);
    sort_unique(removal_targets_);
    Index best = kNoIndex;
    double best_q = criterion.bar(removal_star_);
    for (Index w : removal_targets_) {
      const double q = cone_quality(w, best_q, criterion);
      if (q > best_q) {
        best_q = q;
        best = w;
      }
    }
    if (best == kNoIndex) continue;
    fresh_.clear();
    for (const auto& [s, lv] : star_)
      if (const std::optional<Tet> n = cone_tet(s, lv, best)) fresh_.push_back(*n);
    if (!criterion.accepts(fresh_)) continue;
    parent_.assign(fresh_.size(), 0);
    m_.replace_cavity(removal_star_, fresh_, parent_);
    forget_created();
    return Outcome::kDone;
  }
  return why;
}

/// Edge collapse: the free points v and w of an edge of the bad tet t are
/// replaced by one new point x: the tets of both stars become the star of x
/// over their outer faces (the tets holding both go), x placed by a compass
/// search from the edge's midpoint for the best worst score of `criterion`;
/// done when every new tet is positive (exact) and that worst beats the
/// criterion's bar over both stars. v and w are left in no tet (optimize()
/// drops them). kDone; kConstrained when no edge of t has two free points
/// (or their stars are too large); else kNotBetter.
template <class Criterion>
Outcome Optimizer::collapse_edge(Index t, Criterion& criterion) {
  const Tet k = m_.tet(t);
  Outcome why = Outcome::kConstrained;
  for (int e = 0; e < 6; ++e) {
    const Index v = k[topo::kEdgeVertex[e][0]], w = k[topo::kEdgeVertex[e][1]];
    if ((v < s_.fixed.size() && s_.fixed[v] != 0) || (w < s_.fixed.size() && s_.fixed[w] != 0)) continue;
    if (!gather_star(v, t, kRemovalMaxStar)) continue;
    removal_star_.clear();
    fresh_.clear();
    for (const auto& [s, lv] : star_) {
      removal_star_.push_back(s);
      const Tet& ks = m_.tet(s);
      if (std::find(ks.begin(), ks.end(), w) != ks.end()) continue;
      Tet n = ks;
      n[static_cast<std::size_t>(lv)] = kNoIndex;
      fresh_.push_back(n);
    }
    if (!gather_star(w, t, kRemovalMaxStar)) continue;
    for (const auto& [s, lw] : star_) {
      const Tet& ks = m_.tet(s);
      if (std::find(ks.begin(), ks.end(), v) != ks.end()) continue;
      removal_star_.push_back(s);
      Tet n = ks;
      n[static_cast<std::size_t>(lw)] = kNoIndex;
      fresh_.push_back(n);
    }
    why = Outcome::kNotBetter;
    const double floor = criterion.bar(removal_star_);
    const auto score = [&](const Vec3& x) {
      double q = kInfinity;
      for (const Tet& n : fresh_) {
        std::array<Vec3, 4> p{};
        for (int j = 0; j < 4; ++j) p[j] = n[j] == kNoIndex ? x : m_.point(n[j]);
        if (exact::orient3d(p[0], p[1], p[2], p[3]) <= 0) return -kInfinity;
        bool surface = false;
        for (Index u : n) surface = surface || (u != kNoIndex && !off_surface(u));
        q = std::min(q, criterion.score(p, surface));
        if (q == -kInfinity) return q;
      }
      return q;
    };
    link_points_.clear();
    for (const Tet& n : fresh_)
      for (Index u : n)
        if (u != kNoIndex) link_points_.push_back(u);
    sort_unique(link_points_);
    const Vec3 mid = 0.5 * (m_.point(v) + m_.point(w));
    double best = score(mid);
    const Vec3 x = compass_search(mid, [&](const Vec3& y) {
      const double q = score(y);
      if (!(q > best)) return false;
      best = q;
      return true;
    });
    if (!(best > floor)) continue;
    replace_with_point(removal_star_, x);
    return Outcome::kDone;
  }
  return why;
}

/// Replaces the tets `old` by fresh_, in which kNoIndex stands for a new
/// point at x (collapse_edge, size_splits).
void Optimizer::replace_with_point(std::span<const Index> old, const Vec3& x) {
  const Index np = m_.add_point(x);
  for (Tet& n : fresh_)
    for (Index& u : n)
      if (u == kNoIndex) u = np;
  parent_.assign(fresh_.size(), 0);
  m_.replace_cavity(old, fresh_, parent_);
  forget_created();
}

/// The tet of the cone from w that replaces star tet s (whose point lv is
/// the removed one): s with w in that place; none when s holds w (it goes).
std::optional<Tet> Optimizer::cone_tet(Index s, int lv, Index w) const {
  Tet n = m_.tet(s);
  if (std::find(n.begin(), n.end(), w) != n.end()) return std::nullopt;
  n[static_cast<std::size_t>(lv)] = w;
  return n;
}

/// The worst score (`criterion`) of the cone from w over the link faces of
/// star_'s point that do not hold w, -inf when one is not positive; it stops
/// early, with a value <= `beat`, once the worst is no better than `beat`.
template <class Criterion>
double Optimizer::cone_quality(Index w, double beat, Criterion& criterion) const {
  double q = std::numeric_limits<double>::infinity();
  for (const auto& [s, lv] : star_) {
    const std::optional<Tet> n = cone_tet(s, lv, w);
    if (!n) continue;
    const auto p = corners(m_, *n);
    q = std::min(q, exact::orient3d(p[0], p[1], p[2], p[3]) <= 0 ? -kInfinity : criterion.score(*n));
    if (!(q > beat)) break;
  }
  return q;
}

// The two criteria the passes hand to the repair (optimize.cpp, absorb).
template std::size_t Optimizer::repair_flips(std::vector<Index>, RepairCriterion&, RepairMoves);
template std::size_t Optimizer::repair_flips(std::vector<Index>, AbsorbCriterion&, RepairMoves);

}  // namespace pdrmesh::optimize_detail
