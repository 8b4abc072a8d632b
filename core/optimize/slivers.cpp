// SPDX-License-Identifier: AGPL-3.0-or-later
// Sliver insertion: a sliver and its face neighbours replaced by the star of one new
// point, where every new tet is positive and beats the cavity's worst measure and the
// point keeps its distance from the others; fill_cavity does the replacement.
#include "optimizer.hpp"

namespace pdrmesh::optimize_detail {

/// Point insertion into the slivers left in the mesh (see optimize.hpp).
std::size_t Optimizer::insert_into_slivers() {
  if (sizing_ == nullptr || !o_.insert_points) return 0;
  std::vector<Index> slivers;
  for (Index t : bad_tets())
    if (badness(t) == Badness::kSliver) slivers.push_back(t);
  std::size_t inserted = 0;
  for (Index t : slivers) {
    if (!m_.alive(t) || badness(t) != Badness::kSliver) continue;  // a flip took the slot
    if (failed_before(Attempt::kSliver, t)) continue;
    if (tally(LocalOperation::kInsertion, insert_into(t)) != Outcome::kDone) {
      remember_failure(Attempt::kSliver, t);
      continue;
    }
    ++inserted;
    ++st_.slivers_removed;
    const auto created = m_.last_created();
    reconnect(std::vector<Index>(created.begin(), created.end()));
  }
  st_.points_inserted += inserted;
  return inserted;
}

/// Replaces the tets of `cavity` by the star of a new point x over link_
/// (the new tets take the region of cavity[0] and the outer faces' marks).
void Optimizer::fill_cavity(std::span<const Index> cavity, const Vec3& x) {
  const Index p = m_.add_point(x);
  std::vector<Tet> fresh;
  for (const Tri& f : link_) fresh.push_back({f[0], f[1], f[2], p});
  const std::vector<Index> parent(fresh.size(), 0);
  m_.replace_cavity(cavity, fresh, parent);
  forget_created();
}

/// Replaces the sliver t and its four face neighbours by the star of a new
/// point over the cavity's boundary, when the new tets are all positive, beat
/// the cavity's worst measure, and the point keeps its distance; with a
/// `guard` (the interior repair), also when the guard accepts the new tets
/// (RepairCriterion: each holds its class's floor). kDone, or why not.
Outcome Optimizer::insert_into(Index t, RepairCriterion* guard) {
  if ((m_.flags(t) & TetMesh::kFrozenMask) != 0) return Outcome::kConstrained;
  std::array<Index, 5> cavity{t, 0, 0, 0, 0};
  for (int f = 0; f < 4; ++f) {
    const Index n = m_.neighbour(t, f);
    if (n == kNoIndex || m_.region(face_tet(n)) != m_.region(t)) return Outcome::kConstrained;
    cavity[static_cast<std::size_t>(f + 1)] = face_tet(n);
  }
  double q_old = std::numeric_limits<double>::infinity();
  for (Index u : cavity) q_old = std::min(q_old, measure(corners(m_, m_.tet(u))));
  // The cavity's boundary: the neighbours' faces away from t, less the faces
  // two neighbours share (seen once each way), which must not be frozen.
  link_.clear();
  std::vector<std::pair<Tri, bool>> faces;  // (sorted key, frozen), with link_ in step
  for (int f = 0; f < 4; ++f) {
    const Index n = m_.neighbour(t, f);
    const Index u = face_tet(n);
    for (int g = 0; g < 4; ++g) {
      if (g == face_local(n)) continue;
      const Tri k = topo::face_of(m_.tet(u), g);
      link_.push_back({k[0], k[2], k[1]});  // the new point lies inside: reversed
      faces.push_back({topo::sorted_key(k), m_.frozen(u, g)});
    }
  }
  std::vector<Tri> outer;
  for (std::size_t i = 0; i < link_.size(); ++i) {
    int same = 0;
    for (std::size_t j = 0; j < faces.size(); ++j) same += faces[j].first == faces[i].first ? 1 : 0;
    if (same == 1) {
      outer.push_back(link_[i]);
    } else if (faces[i].second) {
      return Outcome::kConstrained;  // a frozen face inside the cavity
    }
  }
  // Every vertex of the cavity must stay a vertex of the refill: one whose
  // whole star lies inside the cavity (e.g. the point of a 1-4 split whose
  // tets include the sliver) would vanish from the mesh.
  for (Index u : cavity)
    for (Index v : m_.tet(u))
      if (std::none_of(outer.begin(), outer.end(),
                       [v](const Tri& f) { return f[0] == v || f[1] == v || f[2] == v; }))
        return Outcome::kNotApplicable;
  link_ = outer;
  const Tet& k = m_.tet(t);
  const Vec3 centroid =
      0.25 * (m_.point(k[0]) + m_.point(k[1]) + m_.point(k[2]) + m_.point(k[3]));
  Vec3 x;
  const double q_centroid = star_quality(centroid);
  double q = best_position(centroid, q_centroid, x);
  if (!(q > q_centroid)) x = centroid;
  q = std::max(q, q_centroid);
  if (!(q > q_old)) return Outcome::kNotBetter;
  const double h = size_at(x);
  for (Index u : link_points_)
    if (norm(m_.point(u) - x) < kInsertMinDistance * h) return Outcome::kTooClose;
  if (guard != nullptr) {  // the repair: the new tets hold the old ones' floors
    guard->bar(cavity);
    const ClassFloors& floors = guard->floors();
    for (const Tri& f : link_) {
      const TetClass c = tet_class({f[0], f[1], f[2], kNoIndex});  // the new point is free
      if (measure({m_.point(f[0]), m_.point(f[1]), m_.point(f[2]), x}) < floors[c]) return Outcome::kNotBetter;
    }
  }
  fill_cavity(cavity, x);
  return Outcome::kDone;
}

}  // namespace pdrmesh::optimize_detail
