// SPDX-License-Identifier: AGPL-3.0-or-later
// Interior repair: the bad tets with no fixed point mended by flips, point removal,
// edge collapse and insertion, judged by the full measure so that tets next to the
// surface give way only down to the repair floor; absorption hands them to the surface.
#include "optimizer.hpp"

namespace pdrmesh::optimize_detail {

/// Sets the interior repair's floor for tets with a surface point:
/// kRepairFloor, or kRepairFloorMargin times the measure that the mesh's
/// smallest dihedral angle (now) has on the acute side when that is lower.
/// Next to needle triangles, where the tets on the surface are that bad
/// anyway, the tets off it then get room to reach the targets, while no
/// repair makes a tet near the mesh's worst. The margin leaves the cap
/// repair and angle polish after it room too (at the worst measure itself
/// the mesh's smallest angle falls).
void Optimizer::start_repair() {
  const double smallest = angles().min * (3.14159265358979323846 / 180.0);
  repair_floor_ = std::min(kRepairFloor, kRepairFloorMargin * std::sin(smallest) * acute_);
}

/// Absorption (optimize.hpp, 10.): repair_flips over `seeds` with the
/// operations judged by judged()'s absorption rule, against the mesh's
/// extremes now, no point inserted into a cavity (insert_into) and an edge
/// collapse (collapse_edge) tried last. Returns the operations.
std::size_t Optimizer::absorb(std::vector<Index> seeds) {
  find_fixed();
  mesh_angles_ = angles();
  judge_ = Judge::kAbsorb;
  const std::size_t done = repair_flips(std::move(seeds));
  judge_ = Judge::kRepair;
  st_.absorbed += done;
  return done;
}

/// measure() of tet k, or -inf when k is not positive (exact).
double Optimizer::measured(const Tet& k) const {
  const auto p = corners(m_, k);
  if (exact::orient3d(p[0], p[1], p[2], p[3]) <= 0) return -std::numeric_limits<double>::infinity();
  return measure(p);
}

/// Whether the tets of fresh_ hold the floors of the tets they replace
/// (repair_floors): a repair flip must not trade an interior tet for a worse
/// one, nor make a tet with a fixed point worse than the repair floor where
/// the old ones with a fixed point were not.
bool Optimizer::fresh_holds(const std::array<double, 3>& floors) const {
  if (judge_ == Judge::kAbsorb) return true;  // judged() held the absorption's bounds
  for (const Tet& k : fresh_)
    if (measure(corners(m_, k)) < floors[repair_class(k)]) return false;
  return true;
}

/// The repair's class of tet k: 0 no fixed point, 1 a point on the surface
/// (surface_), 2 fixed points elsewhere only (a leaf's interface, which is
/// inside the final mesh: such tets are held like those with no fixed point).
int Optimizer::repair_class(const Tet& k) const {
  int c = 0;
  for (Index v : k) {
    if (v < surface_.size() && surface_[v] != 0) return 1;
    if (v < fixed_.size() && fixed_[v] != 0) c = 2;
  }
  return c;
}

/// The floors of a repair operation replacing `tets`, per repair_class: the
/// worst measure of the class, capped at 1 (at repair_floor() for class 1).
/// With `worst`, also the worst measure over all of them, uncapped (each
/// tet is measured once).
std::array<double, 3> Optimizer::repair_floors(std::span<const Index> tets, double* worst) const {
  std::array<double, 3> q{1.0, repair_floor_, 1.0};
  double lowest = std::numeric_limits<double>::infinity();
  for (Index t : tets) {
    const double m = measure(corners(m_, m_.tet(t)));
    double& f = q[static_cast<std::size_t>(repair_class(m_.tet(t)))];
    f = std::min(f, m);
    lowest = std::min(lowest, m);
  }
  if (worst != nullptr) *worst = lowest;
  return q;
}

/// The objective of the repair's operations: measured(); in the absorption
/// (judge_), measured() for a tet with no surface point only, while one
/// with a surface point scores +inf when it is positive (exact) and within
/// the mesh's extremes (mesh_angles_), else -inf: the operation is judged
/// by the tets off the surface, and no extreme of the mesh gets worse.
double Optimizer::judged(const Tet& k) const {
  const double q = measured(k);
  return q == -kInfinity ? q : judged(corners(m_, k), repair_class(k) == 1, q);
}

/// judged() of a positive tet with corners p, a surface point or not, and
/// measure q.
double Optimizer::judged(const std::array<Vec3, 4>& p, bool surface, double q) const {
  if (judge_ == Judge::kRepair || !surface) return q;
  return within(dihedral_range(p[0], p[1], p[2], p[3]), mesh_angles_) ? kInfinity : -kInfinity;
}

/// What the new tets of an operation replacing `tets` must beat: the worst
/// measure among them (`worst`, from repair_floors) or, in the absorption,
/// the worst among those with no surface point (+inf when there are none).
double Optimizer::beat(std::span<const Index> tets, double worst) const {
  if (judge_ == Judge::kRepair) return worst;
  double q = kInfinity;
  for (Index t : tets)
    if (repair_class(m_.tet(t)) != 1) q = std::min(q, measure(corners(m_, m_.tet(t))));
  return q;
}

/// One repair flip around the bad tet t (repair_flips).
bool Optimizer::repair_tet(Index t) {
  const auto p = corners(m_, m_.tet(t));
  const auto angles = dihedral_angles(p[0], p[1], p[2], p[3]);
  std::array<int, 6> edges{0, 1, 2, 3, 4, 5};
  std::stable_sort(edges.begin(), edges.end(), [&](int a, int b) {
    return std::abs(angles[a] - 90.0) > std::abs(angles[b] - 90.0);  // most extreme first
  });
  for (int e : edges)
    if (remove_edge_measured(t, e)) return true;
  for (int f = 0; f < 4; ++f)
    if (flip23_measured(t, f)) return true;
  for (int f = 0; f < 4; ++f) {
    const Index n = m_.neighbour(t, f);
    if (n == kNoIndex) continue;
    const Index u = face_tet(n);
    const int apex = face_local(n);
    for (int j = 0; j < 4; ++j)
      if (j != apex && remove_edge_measured(u, topo::kEdgeIndex[apex][j])) return true;
  }
  // No flip: a point in the cavity of t and its face neighbours (as for
  // slivers; judged by the measure, so not in the absorption).
  if (judge_ == Judge::kRepair && sizing_ != nullptr && o_.insert_points && insert_into(t, /*guard_free=*/true)) {
    ++st_.points_inserted;
    return true;
  }
  // Nor a point: one of t's points removed.
  if (o_.remove_points && remove_point(t)) {
    ++st_.points_removed;
    return true;
  }
  // In the absorption, last: two of t's points replaced by one.
  if (judge_ == Judge::kAbsorb && o_.remove_points && collapse_edge(t)) {
    ++st_.edges_collapsed;
    return true;
  }
  return false;
}

/// Edge removal as flips.hpp's remove_edge (the same ring and search,
/// best_ring_triangulation), but maximising the smallest measure() of the new
/// tets, and done only when it beats the old tets' smallest and holds their
/// repair floors.
bool Optimizer::remove_edge_measured(Index t, int e) {
  EdgeRing r;
  if (removable_edge_ring(m_, t, e, 0, r) != FlipOutcome::kDone) return false;
  const auto old = std::span<const Index>(r.tets.data(), static_cast<std::size_t>(r.size));
  double old_q = 0.0;
  const std::array<double, 3> floors = repair_floors(old, &old_q);
  RingTriangulation best;
  if (!best_ring_triangulation(
          r, beat(old, old_q), [this](const Tet& k) { return judged(k); }, [](int, int, int) { return false; }, best))
    return false;
  fresh_.assign(best.tets.begin(), best.tets.begin() + best.count);
  if (!fresh_holds(floors)) return false;
  parent_.assign(fresh_.size(), 0);
  m_.replace_cavity(old, fresh_, parent_);
  forget_created();
  return true;
}

/// Point removal (remove_points, optimize.hpp 4.): a free point v of the bad
/// tet t is contracted onto a point w of its link: v's star becomes the cone
/// from w over the link faces that do not hold w (the tets around the edge
/// (v, w) go). Of v's link points, the w whose cone has the best worst tet,
/// ascending index on ties; done when every tet of the cone is positive
/// (exact), beats the worst tet of the star and holds its repair floors.
/// Positive tets over the whole link tile the star (it is star-shaped from
/// w), so the mesh stays a conforming tetrahedralization of the same region;
/// v is left in no tet (optimize() drops such points at the end).
bool Optimizer::remove_point(Index t) {
  const Tet k = m_.tet(t);
  for (Index v : k) {
    if ((v < fixed_.size() && fixed_[v] != 0) || !gather_star(v, t, kRemovalMaxStar)) continue;
    removal_star_.clear();
    for (const auto& [s, lv] : star_) removal_star_.push_back(s);
    double old_q = 0.0;
    const std::array<double, 3> floors = repair_floors(removal_star_, &old_q);
    removal_targets_.clear();
    for (const auto& [s, lv] : star_)
      for (Index u : m_.tet(s))
        if (u != v) removal_targets_.push_back(u);
    std::sort(removal_targets_.begin(), removal_targets_.end());
    removal_targets_.erase(std::unique(removal_targets_.begin(), removal_targets_.end()),
                           removal_targets_.end());
    Index best = kNoIndex;
    double best_q = beat(removal_star_, old_q);
    for (Index w : removal_targets_) {
      const double q = cone_quality(w, best_q);
      if (q > best_q) {
        best_q = q;
        best = w;
      }
    }
    if (best == kNoIndex) continue;
    fresh_.clear();
    for (const auto& [s, lv] : star_)
      if (const std::optional<Tet> n = cone_tet(s, lv, best)) fresh_.push_back(*n);
    if (!fresh_holds(floors)) continue;
    parent_.assign(fresh_.size(), 0);
    m_.replace_cavity(removal_star_, fresh_, parent_);
    forget_created();
    return true;
  }
  return false;
}

/// Edge collapse: the free points v and w of an edge of the bad tet t are
/// replaced by one new point x: the tets of both stars become the star of x
/// over their outer faces (the tets holding both go), x placed by a compass
/// search from the edge's midpoint for the best worst judged() tet; done
/// when every new tet is positive (exact) and that worst beats the stars'
/// (beat). v and w are left in no tet (optimize() drops them).
bool Optimizer::collapse_edge(Index t) {
  const Tet k = m_.tet(t);
  for (int e = 0; e < 6; ++e) {
    const Index v = k[topo::kEdgeVertex[e][0]], w = k[topo::kEdgeVertex[e][1]];
    if ((v < fixed_.size() && fixed_[v] != 0) || (w < fixed_.size() && fixed_[w] != 0)) continue;
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
    double old_q = 0.0;
    repair_floors(removal_star_, &old_q);
    const double floor = beat(removal_star_, old_q);
    const auto score = [&](const Vec3& x) {
      double q = kInfinity;
      for (const Tet& n : fresh_) {
        std::array<Vec3, 4> p{};
        for (int j = 0; j < 4; ++j) p[j] = n[j] == kNoIndex ? x : m_.point(n[j]);
        if (exact::orient3d(p[0], p[1], p[2], p[3]) <= 0) return -kInfinity;
        bool surface = false;
        for (Index u : n) surface = surface || (u != kNoIndex && !off_surface(u));
        q = std::min(q, judged(p, surface, measure(p)));
        if (q == -kInfinity) return q;
      }
      return q;
    };
    link_points_.clear();
    for (const Tet& n : fresh_)
      for (Index u : n)
        if (u != kNoIndex) link_points_.push_back(u);
    std::sort(link_points_.begin(), link_points_.end());
    link_points_.erase(std::unique(link_points_.begin(), link_points_.end()), link_points_.end());
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
    return true;
  }
  return false;
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

/// The worst measure of the cone from w over the link faces of star_'s
/// point that do not hold w, -inf when one is not positive; it stops early,
/// with a value <= `beat`, once the worst is no better than `beat`.
double Optimizer::cone_quality(Index w, double beat) const {
  double q = std::numeric_limits<double>::infinity();
  for (const auto& [s, lv] : star_) {
    const std::optional<Tet> n = cone_tet(s, lv, w);
    if (!n) continue;
    q = std::min(q, judged(*n));
    if (!(q > beat)) break;
  }
  return q;
}

/// 2-3 flip of face f of t as flips.hpp's flip23, judged by measure().
bool Optimizer::flip23_measured(Index t, int f) {
  const Index n = m_.neighbour(t, f);
  if (n == kNoIndex || m_.frozen(t, f)) return false;
  const Index u = face_tet(n);
  if (m_.region(t) != m_.region(u)) return false;
  const Tet& kt = m_.tet(t);
  const Index a = kt[topo::kFaceVertex[f][0]], b = kt[topo::kFaceVertex[f][1]];
  const Index c = kt[topo::kFaceVertex[f][2]], d = kt[f];
  const Index e = m_.tet(u)[face_local(n)];
  const std::array<Index, 2> old{t, u};
  double old_q = 0.0;
  const std::array<double, 3> floors = repair_floors(old, &old_q);
  fresh_.assign({Tet{a, b, d, e}, Tet{b, c, d, e}, Tet{c, a, d, e}});
  const double floor = beat(old, old_q);
  for (const Tet& k : fresh_)
    if (!(judged(k) > floor)) return false;
  if (!fresh_holds(floors)) return false;
  parent_.assign(3, 0);
  m_.replace_cavity(old, fresh_, parent_);
  forget_created();
  return true;
}

}  // namespace pdrmesh::optimize_detail
