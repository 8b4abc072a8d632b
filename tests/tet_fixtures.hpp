// SPDX-License-Identifier: AGPL-3.0-or-later
// Tiny named tet meshes built in code, shared by the TetMesh, flip and insert tests.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <vector>

#include "pdrmesh/quality.hpp"
#include "pdrmesh/tet_mesh.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh::fixtures {

/// Faces of the tets that no other tet shares, outward.
inline std::vector<Tri> hull_faces(const VolumeMesh& m) {
  std::vector<std::pair<Tri, Tri>> keyed;  // (sorted key, outward face)
  for (const Tet& k : m.tets)
    for (int f = 0; f < 4; ++f)
      keyed.push_back({topo::sorted_key(topo::face_of(k, f)), topo::face_of(k, f)});
  std::sort(keyed.begin(), keyed.end());
  std::vector<Tri> hull;
  for (std::size_t i = 0; i < keyed.size();) {
    std::size_t j = i + 1;
    while (j < keyed.size() && keyed[j].first == keyed[i].first) ++j;
    if (j - i == 1) hull.push_back(keyed[i].second);
    i = j;
  }
  return hull;
}

/// Declares every hull face a boundary face (id 1), so that it is frozen.
inline VolumeMesh with_hull_boundary(VolumeMesh m) {
  m.boundary = hull_faces(m);
  m.boundary_ids.assign(m.boundary.size(), 1);
  return m;
}

/// Two tets sharing the face (a, b, c): d below it (against its right-hand
/// normal), e above. Points 0..4 = a, b, c, d, e; tet 0 holds e, tet 1 holds d.
inline VolumeMesh two_tets(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                           const Vec3& e) {
  VolumeMesh m;
  m.points = {a, b, c, d, e};
  m.tets = {{0, 1, 2, 4}, {0, 2, 1, 3}};
  return with_hull_boundary(m);
}

/// The tets (a, b, ring[i], ring[i+1]) around the edge ab, closed. Points:
/// 0 = a, 1 = b, 2.. = ring. The ring turns counterclockwise seen from b.
inline VolumeMesh edge_ring(const Vec3& a, const Vec3& b, const std::vector<Vec3>& ring) {
  VolumeMesh m;
  m.points = {a, b};
  m.points.insert(m.points.end(), ring.begin(), ring.end());
  const auto n = static_cast<Index>(ring.size());
  for (Index i = 0; i < n; ++i) m.tets.push_back({0, 1, 2 + i, 2 + (i + 1) % n});
  return with_hull_boundary(m);
}

/// A regular n-gon of radius r in the plane z = 0, counterclockwise from above.
inline std::vector<Vec3> polygon(int n, double r) {
  std::vector<Vec3> p;
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * 3.14159265358979323846 * i / n;
    p.push_back({r * std::cos(t), r * std::sin(t), 0.0});
  }
  return p;
}

/// The unit cube cut into 6 tets around its diagonal (0,0,0)-(1,1,1). Point i
/// is (i & 1, (i >> 1) & 1, i >> 2). Boundary ids: 1 + 2 * axis + (side == 1).
inline VolumeMesh cube() {
  VolumeMesh m;
  for (int i = 0; i < 8; ++i)
    m.points.push_back({double(i & 1), double((i >> 1) & 1), double(i >> 2)});
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& ax : perms) {
    const Index v1 = 1u << ax[0], v2 = v1 | (1u << ax[1]);
    Tet k{0, v1, v2, 7};
    const auto& p = m.points;
    if (signed_volume(p[k[0]], p[k[1]], p[k[2]], p[k[3]]) < 0) std::swap(k[2], k[3]);
    m.tets.push_back(k);
  }
  m.boundary = hull_faces(m);
  for (const Tri& f : m.boundary) {
    for (int axis = 0; axis < 3; ++axis) {
      const double c = m.points[f[0]][axis];
      if (m.points[f[1]][axis] == c && m.points[f[2]][axis] == c) {
        m.boundary_ids.push_back(1 + 2 * axis + (c == 1.0 ? 1 : 0));
        break;
      }
    }
  }
  return m;
}

inline TetMesh build(const VolumeMesh& v) {
  auto r = TetMesh::from_volume_mesh(v);
  EXPECT_TRUE(r.ok()) << r.status().to_string();
  return r.ok() ? std::move(r).value() : TetMesh{};
}

inline double total_volume(const TetMesh& m) {
  double v = 0;
  for (Index t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    const Tet& k = m.tet(t);
    v += signed_volume(m.point(k[0]), m.point(k[1]), m.point(k[2]), m.point(k[3]));
  }
  return v;
}

/// Largest dihedral angle (degrees) over the alive tets, by quality.hpp.
inline double max_dihedral(const TetMesh& m) {
  double worst = 0;
  for (Index t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    const Tet& k = m.tet(t);
    worst = std::max(
        worst, dihedral_range(m.point(k[0]), m.point(k[1]), m.point(k[2]), m.point(k[3])).max);
  }
  return worst;
}

/// Finds the alive tet holding local edge (a, b); returns (tet, edge) or (kNoIndex, -1).
inline std::pair<Index, int> find_edge(const TetMesh& m, Index a, Index b) {
  for (Index t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    const int la = topo::local_vertex(m.tet(t), a), lb = topo::local_vertex(m.tet(t), b);
    if (la >= 0 && lb >= 0) return {t, topo::kEdgeIndex[la][lb]};
  }
  return {kNoIndex, -1};
}

}  // namespace pdrmesh::fixtures
