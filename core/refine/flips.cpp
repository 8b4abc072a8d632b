// SPDX-License-Identifier: AGPL-3.0-or-later
// Flips: decide with exact orientation, choose by dihedral angles.
#include "pdrmesh/flips.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "pdrmesh/predicates.hpp"
#include "pdrmesh/topology.hpp"

namespace pdrmesh {
namespace {

/// tet_quality of the alive tet t, through the mesh's cache.
double quality_of(TetMesh& m, Index t) {
  double q = m.cached_quality(t);
  if (std::isnan(q)) {
    q = tet_quality(m, m.tet(t));
    m.set_cached_quality(t, q);
  }
  return q;
}

/// The triangulations of remove_long_edge: every new edge (a diagonal of the
/// ring polygon that is not one of its sides) strictly shorter than the removed one.
struct ShorterEdges {
  const TetMesh& m;
  double edge2;  ///< the removed edge's squared length
  bool too_long(const EdgeRing& r, int i, int j) const {
    if (j - i < 2 || (i == 0 && j == r.size - 1)) return false;
    const Vec3 d = m.point(r.ring[i]) - m.point(r.ring[j]);
    return dot(d, d) >= edge2;
  }
  bool operator()(const EdgeRing& r, int i, int k, int j) const {
    return too_long(r, i, k) || too_long(r, k, j) || too_long(r, i, j);
  }
  /// Whether a triangulation may exist at all: one of a polygon of four or
  /// more sides has two ears, so two diagonals (i - 1, i + 1) must be short.
  bool possible(const EdgeRing& r) const {
    if (r.size < 4) return true;
    int ears = 0;
    for (int i = 0; i < r.size && ears < 2; ++i) {
      const Vec3 d = m.point(r.ring[(i + r.size - 1) % r.size]) - m.point(r.ring[(i + 1) % r.size]);
      ears += dot(d, d) < edge2 ? 1 : 0;
    }
    return ears == 2;
  }
};

}  // namespace

std::string_view to_string(Outcome o) {
  switch (o) {
    case Outcome::kDone:
      return "done";
    case Outcome::kNotBetter:
      return "not better";
    case Outcome::kConstrained:
      return "constrained";
    case Outcome::kWouldInvert:
      return "would invert";
    case Outcome::kNotApplicable:
      return "not applicable";
    case Outcome::kTooClose:
      return "too close";
  }
  return "?";
}

double MaxDihedral::bar(std::span<const Index> old) const {
  double worst = std::numeric_limits<double>::infinity();
  for (Index t : old) worst = std::min(worst, quality_of(mesh_, t));
  return std::min(worst, floor_);
}

void MaxDihedral::done(std::span<const Index> created, std::span<const double> scores) const {
  for (std::size_t j = 0; j < created.size(); ++j) mesh_.set_cached_quality(created[j], scores[j]);
}

double max_dihedral_cosine(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const std::array<const Vec3*, 4> v{&a, &b, &c, &d};
  std::array<Vec3, 4> normal;  // outward, unit
  for (int f = 0; f < 4; ++f) {
    const Vec3& q0 = *v[topo::kFaceVertex[f][0]];
    const Vec3 n = cross(*v[topo::kFaceVertex[f][1]] - q0, *v[topo::kFaceVertex[f][2]] - q0);
    const double l = norm(n);
    normal[f] = l > 0.0 ? (1.0 / l) * n : Vec3{0.0, 0.0, 0.0};
  }
  // The interior angle at edge e is pi minus the angle between the outward
  // normals of the two faces that share it: cos = -n1.n2.
  double lowest = 1.0;
  for (int e = 0; e < 6; ++e)
    lowest = std::min(lowest, -dot(normal[topo::edge_face(e, 0)], normal[topo::edge_face(e, 1)]));
  return lowest;
}

double tet_quality(const TetMesh& mesh, const Tet& k) {
  // Sort the vertex indices; an odd sort flips the orientation, undone by
  // swapping the last two.
  Tet s = k;
  bool odd = false;
  for (int i = 1; i < 4; ++i)
    for (int j = i; j > 0 && s[j - 1] > s[j]; --j) {
      std::swap(s[j - 1], s[j]);
      odd = !odd;
    }
  if (odd) std::swap(s[2], s[3]);
  return max_dihedral_cosine(mesh.point(s[0]), mesh.point(s[1]), mesh.point(s[2]),
                             mesh.point(s[3]));
}

FlipOutcome removable_edge_ring(const TetMesh& m, Index t, int e, int required, EdgeRing& r) {
  if (t >= m.num_slots() || !m.alive(t)) return FlipOutcome::kNotApplicable;
  // Cheap rejections first: t's own faces on the edge, and its hull faces.
  for (int s = 0; s < 2; ++s) {
    const int f = topo::edge_face(e, s);
    if (m.neighbour(t, f) == kNoIndex) return FlipOutcome::kNotApplicable;
    if (m.frozen(t, f)) return FlipOutcome::kConstrained;
  }
  if (!m.edge_ring(t, e, r, required != 0 ? required : kMaxRemovalRing) || !r.closed)
    return FlipOutcome::kNotApplicable;
  const int n = r.size;
  if ((required != 0 && n != required) || n < 3 || n > kMaxRemovalRing) return FlipOutcome::kNotApplicable;
  // Faces on the edge: tets[i] and tets[i+1] share the face opposite ring[i] in tets[i].
  for (int i = 0; i < n; ++i) {
    const Index u = r.tets[i];
    if (m.frozen(u, topo::local_vertex(m.tet(u), r.ring[i]))) return FlipOutcome::kConstrained;
    if (m.region(u) != m.region(r.tets[0])) return FlipOutcome::kConstrained;
  }
  return FlipOutcome::kDone;
}

FlipOutcome flip23(TetMesh& mesh, Index t, int f) {
  MaxDihedral criterion(mesh);
  return flip23(mesh, t, f, criterion);
}

FlipOutcome flip32(TetMesh& mesh, Index t, int e) {
  MaxDihedral criterion(mesh);
  return remove_edge(mesh, t, e, criterion, AnyTriangulation{}, 3);
}

FlipOutcome flip44(TetMesh& mesh, Index t, int e) {
  MaxDihedral criterion(mesh);
  return remove_edge(mesh, t, e, criterion, AnyTriangulation{}, 4);
}

FlipOutcome remove_edge(TetMesh& mesh, Index t, int e) {
  MaxDihedral criterion(mesh);
  return remove_edge(mesh, t, e, criterion);
}

FlipOutcome remove_long_edge(TetMesh& mesh, Index t, int e, double floor) {
  if (std::isnan(floor)) return FlipOutcome::kNotApplicable;
  if (t >= mesh.num_slots() || !mesh.alive(t)) return FlipOutcome::kNotApplicable;
  const Tet& k = mesh.tet(t);
  const Vec3 d = mesh.point(k[topo::kEdgeVertex[e][0]]) - mesh.point(k[topo::kEdgeVertex[e][1]]);
  const ShorterEdges shorter{mesh, dot(d, d)};
  EdgeRing r;
  if (const Outcome why = removable_edge_ring(mesh, t, e, 0, r); why != Outcome::kDone) return why;
  MaxDihedral criterion(mesh, floor);
  if (!shorter.possible(r)) {
    // The ring's qualities go into the cache as the search would have put
    // them: the refiner takes a tet without one for a new tet.
    criterion.bar(std::span<const Index>(r.tets.data(), static_cast<std::size_t>(r.size)));
    return Outcome::kNotBetter;
  }
  return replace_ring(mesh, r, criterion, shorter);
}

}  // namespace pdrmesh
