// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of topology.hpp's tables and of TetMesh: construction, adjacency,
// frozen faces, ids, edge rings, compaction and the validity check.
#include "pdrmesh/tet_mesh.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "pdrmesh/flips.hpp"
#include "pdrmesh/insert.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/topology.hpp"
#include "octree_fixtures.hpp"
#include "tet_fixtures.hpp"

namespace pdrmesh {
namespace {

using fixtures::build;

const std::array<Vec3, 4> kReference{Vec3{0, 0, 0}, Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}};

TEST(Topology, ReferenceTetIsPositive) {
  EXPECT_GT(exact::orient3d(kReference[0], kReference[1], kReference[2], kReference[3]), 0);
}

TEST(Topology, FacesPointOutOfAPositiveTet) {
  for (int f = 0; f < 4; ++f) {
    const auto& v = topo::kFaceVertex[f];
    EXPECT_LT(exact::orient3d(kReference[v[0]], kReference[v[1]], kReference[v[2]], kReference[f]),
              0)
        << "face " << f;
    // A point pushed out through the face's centroid lies beyond it.
    Vec3 c{0, 0, 0};
    for (int k = 0; k < 3; ++k) c = c + (1.0 / 3.0) * kReference[v[k]];
    const Vec3 out = c + 0.5 * (c - kReference[f]);
    EXPECT_GT(exact::orient3d(kReference[v[0]], kReference[v[1]], kReference[v[2]], out), 0);
  }
}

TEST(Topology, EdgesAndTheirFacesAgree) {
  for (int e = 0; e < 6; ++e) {
    const int i = topo::kEdgeVertex[e][0], j = topo::kEdgeVertex[e][1];
    const int k = topo::kEdgeOther[e][0], l = topo::kEdgeOther[e][1];
    EXPECT_GT(exact::orient3d(kReference[i], kReference[j], kReference[k], kReference[l]), 0);
    for (int s = 0; s < 2; ++s) {  // both faces of the edge hold both its vertices
      const int f = topo::edge_face(e, s);
      int found = 0;
      for (int q = 0; q < 3; ++q)
        found += topo::kFaceVertex[f][q] == i || topo::kFaceVertex[f][q] == j;
      EXPECT_EQ(found, 2) << "edge " << e << " face " << f;
    }
  }
}

TEST(Topology, SortedKeyParityIsThePermutationsParity) {
  // Each of the six orders of three indices: the sorted key, and even exactly
  // for the three rotations of the ascending order.
  std::array<int, 3> p{0, 1, 2};
  int even = 0;
  do {
    const Tri k{static_cast<Index>(10 + 7 * p[0]), static_cast<Index>(10 + 7 * p[1]), static_cast<Index>(10 + 7 * p[2])};
    const auto [sorted, is_even] = topo::sorted_key_parity(k);
    EXPECT_EQ(sorted, (Tri{10, 17, 24}));
    EXPECT_EQ(sorted, topo::sorted_key(k));
    EXPECT_EQ(is_even, topo::is_even_permutation({p[0], p[1], p[2], 3})) << p[0] << p[1] << p[2];
    even += is_even ? 1 : 0;
  } while (std::next_permutation(p.begin(), p.end()));
  EXPECT_EQ(even, 3);
}

TEST(TetMesh, BuildsSymmetricAdjacencyOfCube) {
  const TetMesh m = build(fixtures::cube());
  ASSERT_TRUE(m.check().ok()) << m.check().to_string();
  EXPECT_EQ(m.num_tets(), 6u);
  int hull = 0, frozen = 0, interior = 0;
  for (Index t = 0; t < m.num_slots(); ++t)
    for (int f = 0; f < 4; ++f) {
      const Index n = m.neighbour(t, f);
      hull += n == kNoIndex;
      interior += n != kNoIndex;
      frozen += m.frozen(t, f);
      if (n != kNoIndex) {
        EXPECT_EQ(m.neighbour(face_tet(n), face_local(n)), pack_face(t, f));
      }
    }
  EXPECT_EQ(hull, 12);
  EXPECT_EQ(frozen, 12);    // exactly the boundary
  EXPECT_EQ(interior, 12);  // 6 interior faces, seen from both sides
}

TEST(TetMesh, RoundTripIsIdentical) {
  VolumeMesh v = fixtures::cube();
  v.tet_regions = {3, 3, 4, 4, 5, 5};
  const TetMesh m = build(v);
  const VolumeMesh back = m.to_volume_mesh();
  EXPECT_EQ(back.points, v.points);
  EXPECT_EQ(back.tets, v.tets);
  EXPECT_EQ(back.tet_regions, v.tet_regions);
  EXPECT_EQ(back.boundary, v.boundary);
  EXPECT_EQ(back.boundary_ids, v.boundary_ids);
}

TEST(TetMesh, RejectsInvertedTet) {
  VolumeMesh v = fixtures::cube();
  std::swap(v.tets[2][0], v.tets[2][1]);
  const auto r = TetMesh::from_volume_mesh(v);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(r.status().message().find("tet 2"), std::string::npos) << r.status().message();
}

TEST(TetMesh, RejectsFaceOfThreeTets) {
  VolumeMesh v = fixtures::two_tets({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.2, 0.2, -1}, {0.2, 0.2, 1});
  v.points.push_back({0.3, 0.3, 2});
  v.tets.push_back({0, 1, 2, 5});  // a second tet above face 012
  v.boundary.clear();
  v.boundary_ids.clear();
  const auto r = TetMesh::from_volume_mesh(v);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("shared by 3 tets"), std::string::npos)
      << r.status().message();
}

TEST(TetMesh, RejectsBoundaryTriangleThatIsNoFace) {
  VolumeMesh v = fixtures::cube();
  v.boundary.push_back({1, 2, 4});  // every face of the 6 tets holds corner 0 or 7
  v.boundary_ids.push_back(9);
  const auto r = TetMesh::from_volume_mesh(v);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("boundary triangle 12"), std::string::npos)
      << r.status().message();
}

TEST(TetMesh, KeepsCallerIdsAndNumbersNewPointsFromTheSeed) {
  const VolumeMesh v = fixtures::cube();
  std::vector<GlobalId> ids;
  for (GlobalId i = 0; i < 8; ++i) ids.push_back(500 + 3 * i);
  auto r = TetMesh::from_volume_mesh(v, ids, 1000);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  TetMesh& m = *r;
  EXPECT_EQ(m.point_ids(), ids);
  const Index p = m.add_point({0.5, 0.5, 0.5});
  const Index q = m.add_point({0.25, 0.5, 0.5});
  EXPECT_EQ(m.point_id(p), 1000u);
  EXPECT_EQ(m.point_id(q), 1001u);
  EXPECT_EQ(m.next_id(), 1002u);
  EXPECT_FALSE(TetMesh::from_volume_mesh(v, {1, 2}, 10).ok());
}

TEST(TetMesh, SetFrozenMarksBothSidesOfAFace) {
  TetMesh m =
      build(fixtures::two_tets({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.2, 0.2, -1}, {0.2, 0.2, 1}));
  const Index n = m.neighbour(0, 3);  // tet 0's face opposite e is the shared face
  ASSERT_NE(n, kNoIndex);
  EXPECT_FALSE(m.frozen(0, 3));
  m.set_frozen(0, 3, true);
  EXPECT_TRUE(m.frozen(face_tet(n), face_local(n)));
  EXPECT_TRUE(m.check().ok());
  m.set_frozen(face_tet(n), face_local(n), false);
  EXPECT_FALSE(m.frozen(0, 3));
}

TEST(TetMesh, EdgeRingOfInteriorEdgeIsClosedAndOrdered) {
  const TetMesh m = build(fixtures::edge_ring({0, 0, -1}, {0, 0, 1}, fixtures::polygon(5, 1.0)));
  for (Index start = 0; start < 5; ++start) {
    const auto [t, e] = std::pair{start, topo::kEdgeIndex[0][1]};  // tets hold a, b at 0, 1
    EdgeRing r;
    ASSERT_TRUE(m.edge_ring(t, e, r));
    EXPECT_TRUE(r.closed);
    ASSERT_EQ(r.size, 5);
    EXPECT_EQ(r.tets[0], start);
    for (int i = 0; i < 5; ++i) {
      const Index p = r.ring[i], q = r.ring[(i + 1) % 5];
      EXPECT_GT(exact::orient3d(m.point(r.a), m.point(r.b), m.point(p), m.point(q)), 0);
      const Tet& k = m.tet(r.tets[i]);
      EXPECT_GE(topo::local_vertex(k, p), 0);
      EXPECT_GE(topo::local_vertex(k, q), 0);
    }
  }
}

TEST(TetMesh, EdgeRingOfHullEdgeIsOpen) {
  const TetMesh m = build(fixtures::cube());
  // The cube's diagonal 0-7 is in all 6 tets (closed); the edge 0-1 lies on the hull.
  const auto [t7, e7] = fixtures::find_edge(m, 0, 7);
  EdgeRing r;
  ASSERT_TRUE(m.edge_ring(t7, e7, r));
  EXPECT_TRUE(r.closed);
  EXPECT_EQ(r.size, 6);
  const auto [t1, e1] = fixtures::find_edge(m, 0, 1);
  ASSERT_TRUE(m.edge_ring(t1, e1, r));
  EXPECT_FALSE(r.closed);
  ASSERT_EQ(r.size, 2);  // the tets along paths 0-1-3-7 and 0-1-5-7
  // Both ends of an open ring are hull faces on the edge: the first tet's face
  // (a, b, ring[0]) and the last tet's face (a, b, ring[size]).
  const Index first = r.tets[0], last = r.tets[1];
  EXPECT_EQ(m.neighbour(first, topo::local_vertex(m.tet(first), r.ring[1])), kNoIndex);
  EXPECT_EQ(m.neighbour(last, topo::local_vertex(m.tet(last), r.ring[1])), kNoIndex);
  EXPECT_NE(m.neighbour(first, topo::local_vertex(m.tet(first), r.ring[0])), kNoIndex);
}

TEST(TetMesh, CompactRenumbersAliveTetsInOrder) {
  // A 3-2 flip on a ring walked from tet 1 reuses slots 1 and 2 and frees slot 0.
  TetMesh m = build(fixtures::edge_ring({0, 0, -2}, {0, 0, 2}, fixtures::polygon(3, 1.0)));
  ASSERT_EQ(flip32(m, 1, topo::kEdgeIndex[0][1]), FlipOutcome::kDone);
  ASSERT_EQ(m.num_slots(), 3u);
  ASSERT_EQ(m.num_tets(), 2u);
  ASSERT_FALSE(m.alive(0));
  std::vector<Tet> before;
  std::vector<std::array<Index, 4>> neighbours;
  for (Index t = 0; t < 3; ++t) {
    before.push_back(m.tet(t));
    neighbours.push_back(
        {m.neighbour(t, 0), m.neighbour(t, 1), m.neighbour(t, 2), m.neighbour(t, 3)});
  }
  const std::vector<Index> map = m.compact();
  ASSERT_EQ(map, (std::vector<Index>{kNoIndex, 0, 1}));
  EXPECT_EQ(m.num_slots(), 2u);
  EXPECT_TRUE(m.check().ok()) << m.check().to_string();
  for (Index t = 1; t < 3; ++t) {
    EXPECT_EQ(m.tet(map[t]), before[t]);
    for (int f = 0; f < 4; ++f) {
      const Index old = neighbours[t][f];
      const Index expect =
          old == kNoIndex ? kNoIndex : pack_face(map[face_tet(old)], face_local(old));
      EXPECT_EQ(m.neighbour(map[t], f), expect);
    }
  }
}

TEST(TetMesh, ReorderPutsAliveTetsInTheGivenOrder) {
  TetMesh m = build(fixtures::edge_ring({0, 0, -2}, {0, 0, 2}, fixtures::polygon(3, 1.0)));
  ASSERT_EQ(flip32(m, 1, topo::kEdgeIndex[0][1]), FlipOutcome::kDone);
  ASSERT_FALSE(m.alive(0));
  const Tet t1 = m.tet(1), t2 = m.tet(2);
  const Index n2 = m.neighbour(2, 0);
  const std::vector<Index> order{2, 1};
  const std::vector<Index> map = m.reorder(order);
  ASSERT_EQ(map, (std::vector<Index>{kNoIndex, 1, 0}));
  EXPECT_EQ(m.num_slots(), 2u);
  EXPECT_TRUE(m.check().ok()) << m.check().to_string();
  EXPECT_EQ(m.tet(0), t2);
  EXPECT_EQ(m.tet(1), t1);
  EXPECT_EQ(m.neighbour(0, 0), n2 == kNoIndex ? kNoIndex : pack_face(map[face_tet(n2)], face_local(n2)));
}

// A point that no tet uses any more (a 1-4 split undone) is dropped; the
// points after it move down with their global ids, and the tets follow.
TEST(TetMesh, RemoveUnusedPointsKeepsTheOthersAndTheirIds) {
  VolumeMesh one;
  one.points.assign(kReference.begin(), kReference.end());
  one.tets = {Tet{0, 1, 2, 3}};
  TetMesh m = build(fixtures::with_hull_boundary(one));
  ASSERT_EQ(insert_point(m, 0, {0.2, 0.2, 0.2}).outcome, InsertOutcome::kDone);  // point 4, id 4
  std::vector<Index> split;
  for (Index t = 0; t < m.num_slots(); ++t)
    if (m.alive(t)) split.push_back(t);
  ASSERT_EQ(split.size(), 4u);
  const std::array<Tet, 1> whole{Tet{0, 1, 2, 3}};
  const std::array<Index, 1> parent{0};
  m.replace_cavity(split, whole, parent);
  ASSERT_EQ(insert_point(m, m.last_created()[0], {0.1, 0.3, 0.2}).outcome, InsertOutcome::kDone);  // point 5, id 5
  const std::vector<Tri> boundary = m.boundary();
  TetMesh below = m;  // from index 5 on only: point 4 stays, in no tet
  EXPECT_EQ(below.remove_unused_points(5), (std::vector<Index>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(below.num_points(), 6u);

  const std::vector<Index> map = m.remove_unused_points();
  EXPECT_EQ(map, (std::vector<Index>{0, 1, 2, 3, kNoIndex, 4}));
  ASSERT_EQ(m.num_points(), 5u);
  EXPECT_EQ(m.point_ids(), (std::vector<GlobalId>{0, 1, 2, 3, 5}));
  EXPECT_EQ(m.point(4), (Vec3{0.1, 0.3, 0.2}));
  EXPECT_EQ(m.next_id(), 6u);
  EXPECT_EQ(m.boundary(), boundary);  // its points come before the dropped one
  EXPECT_EQ(m.num_tets(), 4u);
  for (Index t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    EXPECT_NE(std::find(m.tet(t).begin(), m.tet(t).end(), 4u), m.tet(t).end());  // the split's point
  }
  EXPECT_TRUE(m.check().ok()) << m.check().to_string();
  EXPECT_EQ(m.remove_unused_points(), (std::vector<Index>{0, 1, 2, 3, 4}));  // nothing left to drop
}

TEST(TetMesh, ReplaceStarIsReplaceCavityOfTheStar) {
  // The ball of the grid's centre point (24 Kuhn tets, one link face frozen)
  // re-tiled from a new point beside it: replace_star and replace_cavity of
  // the same tets leave the same slots, adjacency, marks and created list.
  VolumeMesh grid = fixtures::with_hull_boundary(fixtures::kuhn_grid(4));
  grid.tet_regions.assign(grid.tets.size(), 7);
  TetMesh m = build(grid);
  const Index centre = 2 + 5 * (2 + 5 * 2);
  ASSERT_EQ(m.point(centre), (Vec3{2, 2, 2}));
  std::vector<Index> ball;
  for (Index t = 0; t < m.num_slots(); ++t)
    if (m.alive(t) && topo::local_vertex(m.tet(t), centre) >= 0) ball.push_back(t);
  ASSERT_EQ(ball.size(), 24u);
  m.set_frozen(ball[5], topo::local_vertex(m.tet(ball[5]), centre), true);
  const Index apex = m.add_point({2.1, 1.95, 2.05});
  TetMesh other = m;
  std::vector<TetMesh::StarFace> star;
  std::vector<Tet> tets;
  std::vector<Index> parent;
  for (std::size_t i = 0; i < ball.size(); ++i) {
    const int f = topo::local_vertex(m.tet(ball[i]), centre);
    const Tri p = topo::face_of(m.tet(ball[i]), f);
    star.push_back({p, m.neighbour(ball[i], f), static_cast<Index>(i), m.frozen(ball[i], f)});
    tets.push_back({p[0], p[2], p[1], apex});
    parent.push_back(static_cast<Index>(i));
  }
  m.replace_star(ball, apex, star);
  other.replace_cavity(ball, tets, parent);
  ASSERT_TRUE(m.check().ok()) << m.check().to_string();
  EXPECT_TRUE(std::equal(m.last_created().begin(), m.last_created().end(), other.last_created().begin(),
                         other.last_created().end()));
  ASSERT_EQ(m.num_slots(), other.num_slots());
  for (Index t = 0; t < m.num_slots(); ++t) {
    ASSERT_EQ(m.alive(t), other.alive(t)) << t;
    if (!m.alive(t)) continue;
    EXPECT_EQ(m.tet(t), other.tet(t)) << t;
    EXPECT_EQ(m.region(t), other.region(t)) << t;
    EXPECT_EQ(m.active(t), other.active(t)) << t;
    for (int f = 0; f < 4; ++f) {
      EXPECT_EQ(m.neighbour(t, f), other.neighbour(t, f)) << t << " face " << f;
      EXPECT_EQ(m.frozen(t, f), other.frozen(t, f)) << t << " face " << f;
    }
  }
  int frozen = 0;
  for (const Index t : m.last_created())
    for (int f = 0; f < 4; ++f) frozen += m.frozen(t, f) ? 1 : 0;
  EXPECT_EQ(frozen, 1) << "the new tet over the frozen link face";
}

TEST(TetMesh, CheckReportsAnInvertedTet) {
  TetMesh m = build(fixtures::cube());
  Tet mirrored = m.tet(2);
  std::swap(mirrored[0], mirrored[1]);  // same faces, opposite orientation
  const std::array<Index, 1> old{2};
  const std::array<Index, 1> parent{0};
  m.replace_cavity(old, std::array<Tet, 1>{mirrored}, parent);
  const Status s = m.check();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("not positively oriented"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace pdrmesh
