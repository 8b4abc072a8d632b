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

constexpr double kInvalid = -std::numeric_limits<double>::infinity();
constexpr double kEmpty = std::numeric_limits<double>::infinity();

bool positive(const TetMesh& m, const Tet& k) {
  return exact::orient3d(m.point(k[0]), m.point(k[1]), m.point(k[2]), m.point(k[3])) > 0;
}

/// tet_quality of the alive tet t, through the mesh's cache.
double quality_of(TetMesh& m, Index t) {
  double q = m.cached_quality(t);
  if (std::isnan(q)) {
    q = tet_quality(m, m.tet(t));
    m.set_cached_quality(t, q);
  }
  return q;
}

/// Edge removal (ring size `required`, 0: any). The new tets must all beat the
/// old ones' worst quality, or, when `floor` is not NaN, beat min(floor, that
/// worst) and create no edge as long as the removed one (remove_long_edge).
FlipOutcome remove_edge_of_size(TetMesh& m, Index t, int e, int required,
                                double floor = std::numeric_limits<double>::quiet_NaN()) {
  EdgeRing r;
  if (const FlipOutcome why = removable_edge_ring(m, t, e, required, r); why != FlipOutcome::kDone) return why;
  const int n = r.size;
  double old_quality = kEmpty;
  for (int i = 0; i < n; ++i) old_quality = std::min(old_quality, quality_of(m, r.tets[i]));
  const bool shorten = !std::isnan(floor);
  double edge2 = std::numeric_limits<double>::infinity();
  if (shorten) {
    old_quality = std::min(old_quality, floor);
    const Vec3 d = m.point(r.a) - m.point(r.b);
    edge2 = dot(d, d);
  }
  // A diagonal (ring[i], ring[j]) that is not a side of the ring polygon is a new edge.
  const auto too_long = [&](int i, int j) {
    if (j - i < 2 || (i == 0 && j == n - 1)) return false;
    const Vec3 d = m.point(r.ring[i]) - m.point(r.ring[j]);
    return dot(d, d) >= edge2;
  };
  const auto quality = [&m](const Tet& k) { return positive(m, k) ? tet_quality(m, k) : kInvalid; };
  RingTriangulation best;
  const bool found =
      shorten ? best_ring_triangulation(
                    r, old_quality, quality,
                    [&](int i, int k, int j) { return too_long(i, k) || too_long(k, j) || too_long(i, j); }, best)
              : best_ring_triangulation(r, old_quality, quality, [](int, int, int) { return false; }, best);
  // No candidate survived: some tet was merely not better, or every one inverted.
  if (!found) return best.pruned ? FlipOutcome::kNotBetter : FlipOutcome::kWouldInvert;

  std::array<Index, RingTriangulation::kMaxTets> parent{};
  const auto c = static_cast<std::size_t>(best.count);
  m.replace_cavity(std::span<const Index>(r.tets.data(), static_cast<std::size_t>(n)),
                   std::span<const Tet>(best.tets.data(), c), std::span<const Index>(parent.data(), c));
  for (std::size_t j = 0; j < c; ++j) m.set_cached_quality(m.last_created()[j], best.quality[j]);
  return FlipOutcome::kDone;
}

}  // namespace

std::string_view to_string(FlipOutcome o) {
  switch (o) {
    case FlipOutcome::kDone:
      return "done";
    case FlipOutcome::kNotBetter:
      return "not better";
    case FlipOutcome::kConstrained:
      return "constrained";
    case FlipOutcome::kWouldInvert:
      return "would invert";
    case FlipOutcome::kNotApplicable:
      return "not applicable";
  }
  return "?";
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
  if (t >= mesh.num_slots() || !mesh.alive(t)) return FlipOutcome::kNotApplicable;
  const Index n = mesh.neighbour(t, f);
  if (n == kNoIndex) return FlipOutcome::kNotApplicable;
  if (mesh.frozen(t, f)) return FlipOutcome::kConstrained;
  const Index u = face_tet(n);
  if (mesh.region(t) != mesh.region(u)) return FlipOutcome::kConstrained;
  // Face (a, b, c) is outward from t: its apex d lies below it and u's apex e above.
  const Tet& kt = mesh.tet(t);
  const Index a = kt[topo::kFaceVertex[f][0]];
  const Index b = kt[topo::kFaceVertex[f][1]];
  const Index c = kt[topo::kFaceVertex[f][2]];
  const Index d = kt[f];
  const Index e = mesh.tet(u)[face_local(n)];
  const std::array<Tet, 3> fresh{Tet{a, b, d, e}, Tet{b, c, d, e}, Tet{c, a, d, e}};
  for (const Tet& k : fresh)
    if (!positive(mesh, k)) return FlipOutcome::kWouldInvert;
  const double old_quality = std::min(quality_of(mesh, t), quality_of(mesh, u));
  std::array<double, 3> quality{};
  for (std::size_t j = 0; j < 3; ++j) {
    quality[j] = tet_quality(mesh, fresh[j]);
    if (!(quality[j] > old_quality)) return FlipOutcome::kNotBetter;
  }
  const std::array<Index, 2> old{t, u};
  const std::array<Index, 3> parent{0, 0, 0};
  mesh.replace_cavity(old, fresh, parent);
  for (std::size_t j = 0; j < 3; ++j) mesh.set_cached_quality(mesh.last_created()[j], quality[j]);
  return FlipOutcome::kDone;
}

FlipOutcome flip32(TetMesh& mesh, Index t, int e) { return remove_edge_of_size(mesh, t, e, 3); }

FlipOutcome flip44(TetMesh& mesh, Index t, int e) { return remove_edge_of_size(mesh, t, e, 4); }

FlipOutcome remove_edge(TetMesh& mesh, Index t, int e) {
  return remove_edge_of_size(mesh, t, e, 0);
}

FlipOutcome remove_long_edge(TetMesh& mesh, Index t, int e, double floor) {
  if (std::isnan(floor)) return FlipOutcome::kNotApplicable;
  return remove_edge_of_size(mesh, t, e, 0, floor);
}

}  // namespace pdrmesh
