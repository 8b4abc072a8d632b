// SPDX-License-Identifier: AGPL-3.0-or-later
// Cap repair: flat tets lying on the surface (two or three kept faces, or four surface
// points) replaced by the star of a new point over a cavity grown around them, where the
// new tets beat the old by their angles and keep their floors and spacing.
#include "optimizer.hpp"

namespace pdrmesh::optimize_detail {

/// Cap repair (optimize.hpp, 5.): one point inserted into a cavity around
/// each cap (is_cap), worst first (insert_cap). With `relaxed` (the second
/// pass) also around each free-apex cap (cap_kind) and each bad tet of four
/// surface points (whatever its surface triangles), and a star is judged by
/// kRelaxedCapAngles (cap_angles_rise). Returns the points inserted.
std::size_t Optimizer::repair_caps(bool relaxed) {
  if (sizing_ == nullptr || !o_.insert_points) return 0;
  // The surface triangles (TetMesh::boundary() with a non-zero id, or all
  // when there are no ids; not a leaf's interface), as sorted keys.
  if (!s_.surface_keys_known) {
    s_.surface_keys_known = true;
    for (std::size_t i = 0; i < m_.boundary().size(); ++i)
      if (surface_triangle(i)) s_.surface_keys.push_back(topo::sorted_key(m_.boundary()[i]));
    std::sort(s_.surface_keys.begin(), s_.surface_keys.end());
  }
  const std::vector<Tri>& surface = s_.surface_keys;
  find_fixed();
  // Worst first (the smaller of the smallest dihedral angle and 180 - the
  // largest; ties in slot order): a cavity may swallow a worse cap next to
  // its own that a repair of that cap would fix better.
  // A slot may hold a newer tet by the time it is tried: asked again then.
  const auto eligible = [&](Index t) {
    if (!m_.alive(t) || badness(t) == Badness::kGood) return false;
    const CapKind kind = cap_kind(t, surface);
    return kind == CapKind::kCap ||
           (relaxed && (kind == CapKind::kFreeApex || all_on_surface(t)));
  };
  std::vector<std::pair<double, Index>> caps;
  for (Index t : bad_tets()) {
    if (!eligible(t)) continue;
    const auto p = corners(m_, m_.tet(t));
    const AngleRange r = dihedral_range(p[0], p[1], p[2], p[3]);
    caps.push_back({std::min(r.min, 180.0 - r.max), t});
  }
  if (caps.empty()) return 0;
  std::sort(caps.begin(), caps.end());
  const CapRule rule{.relaxed = relaxed, .max_angle = angles().max};
  std::size_t done = 0;
  for (const auto& [worst, t] : caps)
    if (eligible(t) && tally(LocalOperation::kInsertion, insert_cap(t, rule)) == Outcome::kDone) ++done;
  st_.points_inserted += done;
  st_.caps_repaired += done;
  return done;
}

/// The new tets over link_ with the free point x and no surface point
/// (kInterior, kFrozen) meet their class's floor (repair_floors of the tets
/// they replace): a cap repair may not trade the cap for a bad tet away from
/// the surface.
bool Optimizer::off_surface_floors_hold(const Vec3& x, const ClassFloors& floors) const {
  for (const Tri& f : link_) {
    const TetClass c = tet_class({f[0], f[1], f[2], kNoIndex});  // x: not yet a point, free
    if (c == TetClass::kSurface) continue;
    if (measure({m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), x}) < floors[c]) return false;
  }
  return true;
}

/// The tets of `cavity` grown until every outer face is seen from x (the
/// new tet over it positive by exact::orient3d): a tet across a face that is
/// not seen joins, unless the face is kept (then false). The outer faces,
/// turned into the cavity, go to link_. False too when the cavity would
/// pass kCapMaxCavity tets, leave a region, hold a frozen face inside, or
/// lose a vertex (one with no outer face, see insert_into).
bool Optimizer::grow_cavity(std::vector<Index>& cavity, const Vec3& x) {
  const auto inside = [&cavity](Index u) { return std::find(cavity.begin(), cavity.end(), u) != cavity.end(); };
  for (bool grown = true; grown;) {
    grown = false;
    link_.clear();
    for (std::size_t i = 0; i < cavity.size() && !grown; ++i) {
      const Index u = cavity[i];
      for (int g = 0; g < 4 && !grown; ++g) {
        const Index n = m_.neighbour(u, g);
        if (n != kNoIndex && inside(face_tet(n))) {
          if (m_.frozen(u, g)) return false;
          continue;
        }
        const Tri k = topo::face_of(m_.tet(u), g);
        if (exact::orient3d(m_.point(k[0]), m_.point(k[2]), m_.point(k[1]), x) > 0) {
          link_.push_back({k[0], k[2], k[1]});
          continue;
        }
        if (kept_face(u, g) || cavity.size() >= kCapMaxCavity) return false;
        cavity.push_back(face_tet(n));
        grown = true;
      }
    }
  }
  for (Index u : cavity)
    for (Index v : m_.tet(u))
      if (std::none_of(link_.begin(), link_.end(),
                       [v](const Tri& f) { return f[0] == v || f[1] == v || f[2] == v; }))
        return false;
  return true;
}

/// What the cap repair makes of the bad tet t: kCap as is_cap says; kFreeApex
/// for one kept face, a surface triangle that is not a needle, under a free
/// fourth point (the relaxed pass takes it: insert_over_fans); else kNone.
CapKind Optimizer::cap_kind(Index t, const std::vector<Tri>& surface) const {
  int kept = 0, on_surface = 0, kept_face_index = 0;
  for (int f = 0; f < 4; ++f) {
    if (!kept_face(t, f)) continue;
    ++kept;
    kept_face_index = f;
    on_surface += std::binary_search(surface.begin(), surface.end(),
                                     topo::sorted_key(topo::face_of(m_.tet(t), f)))
                      ? 1
                      : 0;
  }
  if (kept == 1) {
    const Tri k = topo::face_of(m_.tet(t), kept_face_index);
    if (on_surface != 1 || smallest_angle(m_.point(k[0]), m_.point(k[1]), m_.point(k[2])) < kCapMinTriangleAngle)
      return CapKind::kNone;
    return free_point(t) ? CapKind::kFreeApex : CapKind::kCap;
  }
  return kept < 4 && on_surface >= 2 ? CapKind::kCap : CapKind::kNone;
}

/// The tets the cavity of cap t starts from: with two kept faces the ring
/// of the edge that t's two other faces share (t and its neighbours alone
/// are not star-shaped from any point inside: that edge is reflex); with
/// one, three or none (the relaxed pass), t and its neighbours across the
/// faces that are not kept. Empty when the ring is open or too large, or a
/// tet is in another region.
std::vector<Index> Optimizer::cap_seed(Index t) const {
  std::array<int, 4> open{};  // the faces of t that are not kept
  int n_open = 0;
  for (int f = 0; f < 4; ++f)
    if (!kept_face(t, f)) open[static_cast<std::size_t>(n_open++)] = f;
  std::vector<Index> seed{t};
  if (n_open == 2) {
    // The faces opposite local vertices open[0], open[1] share the edge of
    // the other two vertices.
    std::array<int, 2> ends{};
    int m = 0;
    for (int v = 0; v < 4; ++v)
      if (v != open[0] && v != open[1]) ends[static_cast<std::size_t>(m++)] = v;
    EdgeRing r;
    if (!m_.edge_ring(t, topo::kEdgeIndex[ends[0]][ends[1]], r, static_cast<int>(kCapMaxCavity)) || !r.closed)
      return {};
    seed.assign(r.tets.begin(), r.tets.begin() + r.size);
  } else {
    for (int i = 0; i < n_open; ++i) seed.push_back(face_tet(m_.neighbour(t, open[static_cast<std::size_t>(i)])));
  }
  for (Index u : seed)
    if (m_.region(u) != m_.region(t)) return {};
  return seed;
}

/// Whether the star of x over link_ beats the cavity's tets by their
/// dihedral angles (the cap repair's criterion): the smallest rises, and in
/// the relaxed pass every new tet lies within kRelaxedCapAngles; otherwise,
/// with two or three kept faces the largest does not rise. With one (a flat
/// tet on the surface, whose best star may need a larger angle than the
/// cavity had), the smaller of the smallest and 180 - the largest rises, and
/// the largest stays within kCapMaxAngleSlack of rule.max_angle.
bool Optimizer::cap_angles_rise(const Vec3& x, std::span<const Index> cavity, int kept, const CapRule& rule) const {
  const AngleRange old_range = angle_range(nullptr, cavity);
  const AngleRange new_range = angle_range(&x, {});
  if (!(new_range.min > old_range.min)) return false;
  if (rule.relaxed) return new_range.min >= kRelaxedCapAngles[0] && new_range.max <= kRelaxedCapAngles[1];
  if (kept == 1)
    return std::min(new_range.min, 180.0 - new_range.max) > std::min(old_range.min, 180.0 - old_range.max) &&
           new_range.max <= rule.max_angle + kCapMaxAngleSlack;
  return new_range.max <= old_range.max;
}

/// Whether x lies at least kCapMinSpacing times h(x) from every point of
/// link_ that is not on the surface (s_.surface; new points are not).
bool Optimizer::cap_spaced(const Vec3& x) const {
  const double reach = kCapMinSpacing * size_at(x);
  for (const Tri& f : link_)
    for (Index v : f)
      if ((v >= s_.surface.size() || s_.surface[v] == 0) && norm(m_.point(v) - x) < reach) return false;
  return true;
}

/// Replaces the cap t (is_cap, or in the relaxed pass a free-apex cap or a
/// tet of four surface points) and the tets around it by the star of one
/// new point x over the cavity's boundary, the kept faces included (each
/// becomes a face of a new tet). A free-apex cap first tries a point over
/// a fan its apex covers (insert_over_fans). Otherwise the cavity starts
/// from cap_seed, and x above the mean centroid of the kept faces, along
/// their mean inward normal, at kCapHeights times h there (with no kept
/// face: at t's centroid and beside each of its faces); insert_star does
/// the rest. kDone; kConstrained when t has four kept faces or its cavity
/// cannot start; else kNotBetter.
Outcome Optimizer::insert_cap(Index t, const CapRule& rule) {
  const Tet kt = m_.tet(t);
  Vec3 mid{0, 0, 0}, inward{0, 0, 0};
  int kept = 0, kf = 0;  // kf: a kept face (the only one when kept == 1)
  for (int f = 0; f < 4; ++f) {
    if (!kept_face(t, f)) continue;
    Vec3 n;
    if (!kept_face_normal(t, f, n)) return Outcome::kNotApplicable;
    const Tri k = topo::face_of(kt, f);
    mid = mid + (1.0 / 3.0) * (m_.point(k[0]) + m_.point(k[2]) + m_.point(k[1]));
    inward = inward + n;
    kf = f;
    ++kept;
  }
  if (kept == 4) return Outcome::kConstrained;
  if (kept == 1 && free_point(t) && insert_over_fans(t, kf, rule)) return Outcome::kDone;
  const std::vector<Index> seed = cap_seed(t);
  if (seed.empty()) return Outcome::kConstrained;
  std::vector<Vec3> starts;
  if (kept == 0) {
    // Four surface points and no kept face: from the centroid, and off each
    // face into the neighbour across it (the tet is flat: its best point
    // lies beside it), at a quarter and half the height of a regular tet
    // over that face.
    const auto p = corners(m_, kt);
    starts.push_back(0.25 * (p[0] + p[1] + p[2] + p[3]));
    for (int f = 0; f < 4; ++f) {
      const Tri k = topo::face_of(kt, f);  // outward: the apex lies out of t
      for (double fraction : {0.25, 0.5})
        starts.push_back(regular_apex(m_.point(k[0]), m_.point(k[1]), m_.point(k[2]), fraction));
    }
  } else {
    mid = (1.0 / static_cast<double>(kept)) * mid;
    const double ln = norm(inward);
    if (!(ln > 0.0)) return Outcome::kNotApplicable;
    inward = (1.0 / ln) * inward;
    const double h = size_at(mid);
    for (double height : kCapHeights) starts.push_back(mid + (height * h) * inward);
  }
  return insert_star(seed, starts, kept, rule) ? Outcome::kDone : Outcome::kNotBetter;
}

/// For a free-apex cap t (cap_kind) with kept face kf: for each point s of
/// that face whose tets all hold t's free point a over a kept face (a alone
/// covers the surface fan of s: over a curved fan its tets are as bad as the
/// fan is curved, and no move of a helps them all), in
/// order, a new point over that fan (insert_star from the tets of s,
/// starting above s along the fan's mean inward normal at kCapHeights times
/// h(s)), until one is inserted. Frees a to move for the tets left
/// (polish_angles).
bool Optimizer::insert_over_fans(Index t, int kf, const CapRule& rule) {
  const Tet kt = m_.tet(t);
  const Index apex = kt[static_cast<std::size_t>(kf)];
  std::vector<Index> star;
  std::vector<Vec3> starts;
  for (Index s : topo::face_of(kt, kf)) {
    // The tets around s, from t across the faces through s that are not kept.
    if (!gather_star</*kCrossKept=*/false>(s, t, kCapMaxCavity)) continue;
    star.clear();
    for (const auto& e : star_) star.push_back(e.first);
    Vec3 inward{0, 0, 0};
    bool covered = true;
    for (Index u : star) {
      const Tet& k = m_.tet(u);
      const int la = topo::local_vertex(k, apex);
      if (la < 0 || !kept_face(u, la)) {
        covered = false;
        break;
      }
      Vec3 n;
      if (kept_face_normal(u, la, n)) inward = inward + n;
    }
    const double ln = norm(inward);
    if (!covered || !(ln > 0.0)) continue;
    const Vec3& x = m_.point(s);
    const double h = size_at(x);
    starts.clear();
    for (double height : kCapHeights) starts.push_back(x + (height * h / ln) * inward);
    if (insert_star(star, starts, 1, rule)) return true;
  }
  return false;
}

/// The search of insert_cap: from each start point x, the cavity grows from
/// `seed` (grow_cavity) and x moves as in best_position; the best x by the
/// worst measure of its star is taken when that beats the cavity's worst
/// measure, the new tets off the surface hold their floors, the angles rise
/// (cap_angles_rise with `kept` kept faces and `rule`) and x is spaced (cap_spaced).
bool Optimizer::insert_star(const std::vector<Index>& seed, const std::vector<Vec3>& starts, int kept,
                            const CapRule& rule) {
  // The best candidate: its point, cavity and worst new measure.
  double best_q = -std::numeric_limits<double>::infinity();
  Vec3 best_x{0, 0, 0};
  std::vector<Index> best_cavity, cavity;
  for (Vec3 x : starts) {
    cavity = seed;
    if (!grow_cavity(cavity, x)) continue;
    double q = star_quality(x);
    Vec3 moved;
    const double q_moved = best_position(x, q, moved);
    if (q_moved > q) {
      x = moved;
      q = q_moved;
    }
    if (!(q > best_q)) continue;
    double q_old = std::numeric_limits<double>::infinity();
    for (Index u : cavity) q_old = std::min(q_old, measure(corners(m_, m_.tet(u))));
    if (!(q > q_old)) continue;
    if (!off_surface_floors_hold(x, repair_floors(cavity, kRepairFloor))) continue;
    if (!cap_angles_rise(x, cavity, kept, rule) || !cap_spaced(x)) continue;
    best_q = q;
    best_x = x;
    best_cavity = cavity;
  }
  if (best_cavity.empty()) return false;
  cavity = best_cavity;
  if (!grow_cavity(cavity, best_x) || cavity.size() != best_cavity.size()) return false;  // link_ for best_x
  fill_cavity(cavity, best_x);
  return true;
}

}  // namespace pdrmesh::optimize_detail
