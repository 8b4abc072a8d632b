// SPDX-License-Identifier: AGPL-3.0-or-later
// Local topology of one tetrahedron: the numbering of its vertices, faces and
// edges, drawn once. Every module that walks a tet's faces or edges uses these
// tables; no other file restates them.
//
// Orientation (predicates.hpp): a tet (v0, v1, v2, v3) is positive when
// exact::orient3d(p0, p1, p2, p3) > 0, i.e. seen from v3 the base v0 -> v1 -> v2
// turns counterclockwise. Every alive tet of a mesh is positive.
//
//                 3                 reference tet (edge 1-3 not drawn):
//                 |`.                 0 = (0,0,0)   1 = (1,0,0)
//                 |  `.               2 = (0,1,0)   3 = (0,0,1)
//                 |    `.
//                 |      `.         face i is opposite vertex i:
//                 |        `.         face 0 = (1, 2, 3)
//                 0 - - - - -2        face 1 = (0, 3, 2)
//                  `.       .'        face 2 = (0, 1, 3)
//                    `.   .'          face 3 = (0, 2, 1)
//                      `1'          each listed so that its right-hand normal
//                                   points OUT of a positive tet:
//   edges: 0 = (0,1)  1 = (0,2)       orient3d(face verts, v_i) < 0 and
//          2 = (0,3)  3 = (1,2)       orient3d(face verts, x) > 0 <=> x lies
//          4 = (1,3)  5 = (2,3)       beyond face i.
//
// Edge e = (i, j) is shared by the two faces opposite the two other vertices
// (k, l) = kEdgeOther[e]. (k, l) is ordered so that (i, j, k, l) is an even
// permutation of (0, 1, 2, 3): then orient3d(vi, vj, vk, vl) > 0 as well, which
// fixes the direction in which the ring of tets around an edge is walked.
// Edge 5 - e is the edge opposite edge e.
#pragma once

#include <algorithm>
#include <array>
#include <utility>

#include "pdrmesh/types.hpp"

namespace pdrmesh::topo {

/// Vertices of face f (opposite vertex f), outward for a positive tet.
inline constexpr int kFaceVertex[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/// The two vertices of edge e, lower local index first.
inline constexpr int kEdgeVertex[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

/// The two vertices not on edge e, ordered so that (kEdgeVertex[e], kEdgeOther[e])
/// is an even permutation. They also name the two faces that share edge e.
inline constexpr int kEdgeOther[6][2] = {{2, 3}, {3, 1}, {1, 2}, {0, 3}, {2, 0}, {0, 1}};

/// Edge index of the local vertex pair (i, j), either order; -1 when i == j.
inline constexpr int kEdgeIndex[4][4] = {
    {-1, 0, 1, 2}, {0, -1, 3, 4}, {1, 3, -1, 5}, {2, 4, 5, -1}};

/// The two faces sharing edge e (s = 0 or 1).
constexpr int edge_face(int e, int s) { return kEdgeOther[e][s]; }

/// The edge opposite edge e (no common vertex).
constexpr int opposite_edge(int e) { return 5 - e; }

/// True when (p[0], p[1], p[2], p[3]) is an even permutation of (0, 1, 2, 3).
constexpr bool is_even_permutation(std::array<int, 4> p) {
  int inversions = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) inversions += p[i] > p[j] ? 1 : 0;
  return inversions % 2 == 0;
}

/// Local index (0..3) of global vertex v in tet t, or -1.
constexpr int local_vertex(const Tet& t, Index v) {
  for (int i = 0; i < 4; ++i)
    if (t[i] == v) return i;
  return -1;
}

/// Global vertices of face f of tet t, outward for a positive tet.
constexpr Tri face_of(const Tet& t, int f) {
  return {t[kFaceVertex[f][0]], t[kFaceVertex[f][1]], t[kFaceVertex[f][2]]};
}

/// The three indices of a triangle in ascending order: the key of a face.
constexpr Tri sorted_key(Tri k) {
  if (k[0] > k[1]) std::swap(k[0], k[1]);
  if (k[1] > k[2]) std::swap(k[1], k[2]);
  if (k[0] > k[1]) std::swap(k[0], k[1]);
  return k;
}

/// sorted_key(k), and whether k is an even permutation of it (three distinct indices).
constexpr std::pair<Tri, bool> sorted_key_parity(Tri k) {
  bool even = true;
  if (k[0] > k[1]) std::swap(k[0], k[1]), even = !even;
  if (k[1] > k[2]) std::swap(k[1], k[2]), even = !even;
  if (k[0] > k[1]) std::swap(k[0], k[1]), even = !even;
  return {k, even};
}

// The tables agree with one another and with the orientation convention.
namespace detail {
constexpr bool tables_consistent() {
  for (int f = 0; f < 4; ++f) {
    // (face vertices, f) is odd: f lies on the inner side of the outward face.
    if (is_even_permutation({kFaceVertex[f][0], kFaceVertex[f][1], kFaceVertex[f][2], f}))
      return false;
    for (int k = 0; k < 3; ++k)
      if (kFaceVertex[f][k] == f) return false;
  }
  for (int e = 0; e < 6; ++e) {
    const int i = kEdgeVertex[e][0], j = kEdgeVertex[e][1];
    if (!is_even_permutation({i, j, kEdgeOther[e][0], kEdgeOther[e][1]})) return false;
    if (kEdgeIndex[i][j] != e || kEdgeIndex[j][i] != e) return false;
    if (kEdgeVertex[opposite_edge(e)][0] != std::min(kEdgeOther[e][0], kEdgeOther[e][1]))
      return false;
  }
  return true;
}
}  // namespace detail
static_assert(detail::tables_consistent(), "topology tables disagree with the convention");

}  // namespace pdrmesh::topo
