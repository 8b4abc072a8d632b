// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the PDR octree decomposition: leaf assignment, N1/N2, interface faces.
#include "pdrmesh/decomposition.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <array>
#include <functional>
#include <set>
#include <string>

#include <fmt/format.h>

#include <oneapi/tbb/task_arena.h>

#include "octree_fixtures.hpp"

namespace pdrmesh {
namespace {

using fixtures::kuhn_grid;

Decomposition decompose_ok(const VolumeMesh& m, int depth) {
  auto d = decompose(m, depth);
  EXPECT_TRUE(d.ok()) << d.status().to_string();
  return std::move(d).value();
}

int chebyshev(LeafId a, LeafId b, int depth) {
  const auto ca = leaf_coords(a, depth), cb = leaf_coords(b, depth);
  int r = 0;
  for (int i = 0; i < 3; ++i) r = std::max(r, std::abs(int(ca[i]) - int(cb[i])));
  return r;
}

std::set<Index> lock_set(const Decomposition& d, Index l) {
  std::set<Index> s(d.n1[l].begin(), d.n1[l].end());
  s.insert(l);
  return s;
}

TEST(Decomposition, AssignsEveryTetOnceToTheLeafHoldingItsBarycenter) {
  const VolumeMesh m = kuhn_grid(7);
  for (int depth : {0, 1, 2, 3}) {
    const Decomposition d = decompose_ok(m, depth);
    ASSERT_EQ(d.tet_leaf.size(), m.tets.size());
    ASSERT_EQ(d.leaf_tets.size(), d.leaves.size());
    EXPECT_TRUE(std::is_sorted(d.leaves.begin(), d.leaves.end()));
    EXPECT_EQ(std::adjacent_find(d.leaves.begin(), d.leaves.end()), d.leaves.end());
    std::vector<int> seen(m.tets.size(), 0);
    for (std::size_t l = 0; l < d.size(); ++l) {
      EXPECT_FALSE(d.leaf_tets[l].empty());
      EXPECT_TRUE(std::is_sorted(d.leaf_tets[l].begin(), d.leaf_tets[l].end()));
      for (Index t : d.leaf_tets[l]) {
        ++seen[t];
        EXPECT_EQ(d.tet_leaf[t], l);
      }
    }
    // The root box is a cube holding every point strictly inside.
    const double side = d.box.hi[0] - d.box.lo[0];
    for (int a = 0; a < 3; ++a) {
      EXPECT_DOUBLE_EQ(d.box.hi[a] - d.box.lo[a], side);
      EXPECT_LT(d.box.lo[a], 0.0);
      EXPECT_GT(d.box.hi[a], 7.0);
    }
    for (std::size_t t = 0; t < m.tets.size(); ++t) {
      EXPECT_EQ(seen[t], 1) << "tet " << t;
      const Vec3 b = tet_barycenter(m, static_cast<Index>(t));
      const LeafId id = d.leaves[d.tet_leaf[t]];
      EXPECT_EQ(id, leaf_of_point(d.box, depth, b));
      const Box lb = leaf_box(d.box, depth, id);
      for (int a = 0; a < 3; ++a) {
        EXPECT_LE(lb.lo[a], b[a]) << "tet " << t;
        EXPECT_GE(lb.hi[a], b[a]) << "tet " << t;
      }
    }
  }
}

TEST(Decomposition, LeafOfPointSendsBoundaryPointsUpAndClamps) {
  Box box;
  box.add({0, 0, 0});
  box.add({1, 1, 1});
  EXPECT_EQ(leaf_of_point(box, 2, {0.25, 0.5, 0.75}), 1u + 4u * (2u + 4u * 3u));
  EXPECT_EQ(leaf_of_point(box, 2, {0.2499, 0.0, 0.0}), 0u);
  EXPECT_EQ(leaf_of_point(box, 2, {1.0, 1.0, 1.0}), 63u);  // far faces clamp
  EXPECT_EQ(leaf_of_point(box, 2, {-5.0, 7.0, 0.1}), 0u + 4u * (3u + 4u * 0u));
  EXPECT_EQ(leaf_of_point(box, 0, {0.9, 0.9, 0.9}), 0u);
  const auto c = leaf_coords(1u + 4u * (2u + 4u * 3u), 2);
  EXPECT_EQ(c[0], 1u);
  EXPECT_EQ(c[1], 2u);
  EXPECT_EQ(c[2], 3u);
}

TEST(Decomposition, NeighboursOfAFullGridAreTheChebyshevRings) {
  const Decomposition d = decompose_ok(kuhn_grid(8), 2);  // 4^3 leaves, all non-empty
  ASSERT_EQ(d.size(), 64u);
  for (std::size_t l = 0; l < d.size(); ++l) {
    std::vector<Index> ring1, ring2;
    for (std::size_t m = 0; m < d.size(); ++m) {
      const int c = chebyshev(d.leaves[l], d.leaves[m], d.depth);
      if (c == 1) ring1.push_back(static_cast<Index>(m));
      if (c == 2) ring2.push_back(static_cast<Index>(m));
    }
    EXPECT_EQ(d.n1[l], ring1) << "leaf " << l;
    EXPECT_EQ(d.n2[l], ring2) << "leaf " << l;
  }
  auto idx = [&](LeafId id) {
    return static_cast<std::size_t>(std::lower_bound(d.leaves.begin(), d.leaves.end(), id) -
                                    d.leaves.begin());
  };
  const std::size_t interior = idx(1 + 4 * (1 + 4 * 1)), corner = idx(0);
  const std::size_t edge = idx(1 + 4 * (0 + 4 * 0)), face = idx(1 + 4 * (1 + 4 * 0));
  EXPECT_EQ(d.n1[interior].size(), 26u);
  EXPECT_EQ(d.n1[corner].size(), 7u);
  EXPECT_EQ(d.n1[edge].size(), 11u);
  EXPECT_EQ(d.n1[face].size(), 17u);
  EXPECT_EQ(d.n2[interior].size(), 64u - 27u);  // [0,3]^3 less the 3^3 block
  EXPECT_EQ(d.n2[corner].size(), 27u - 8u);     // [0,2]^3 less [0,1]^3
}

TEST(Decomposition, NeighboursWithEmptyLeavesFollowTheLockSets) {
  // Cubes removed in a fixed pattern leave empty leaves at depth 3 (one cube per leaf).
  const VolumeMesh m = kuhn_grid(8, [](int x, int y, int z) { return (x * 7 + y * 3 + z * 5) % 4 != 0; });
  const Decomposition d = decompose_ok(m, 3);
  ASSERT_LT(d.size(), 512u);
  ASSERT_GT(d.size(), 300u);
  for (std::size_t l = 0; l < d.size(); ++l) {
    const Index li = static_cast<Index>(l);
    const std::set<Index> mine = lock_set(d, li);
    std::vector<Index> expect_n1, expect_n2;
    for (std::size_t o = 0; o < d.size(); ++o) {
      if (o == l) continue;
      const Index oi = static_cast<Index>(o);
      if (chebyshev(d.leaves[l], d.leaves[o], d.depth) == 1) {
        expect_n1.push_back(oi);
        continue;
      }
      const std::set<Index> theirs = lock_set(d, oi);
      const bool overlap = std::any_of(theirs.begin(), theirs.end(), [&](Index x) { return mine.count(x) > 0; });
      if (overlap) expect_n2.push_back(oi);
    }
    EXPECT_EQ(d.n1[l], expect_n1) << "leaf " << l;
    EXPECT_EQ(d.n2[l], expect_n2) << "leaf " << l;
    for (Index x : d.n2[l]) EXPECT_EQ(chebyshev(d.leaves[l], d.leaves[x], d.depth), 2);
  }
}

TEST(Decomposition, InterfaceFacesAreExactlyTheFacesBetweenLeaves) {
  const VolumeMesh m = kuhn_grid(6, [](int x, int y, int z) { return x + y + z != 7; });
  for (int depth : {1, 2, 3}) {
    const Decomposition d = decompose_ok(m, depth);
    // Brute force: every face by its sorted vertex triple.
    std::map<std::array<Index, 3>, std::vector<std::pair<Index, int>>> faces;
    for (std::size_t t = 0; t < m.tets.size(); ++t) {
      for (int f = 0; f < 4; ++f) {
        std::vector<Index> v;
        for (int q = 0; q < 4; ++q) {
          if (q != f) v.push_back(m.tets[t][static_cast<std::size_t>(q)]);
        }
        std::sort(v.begin(), v.end());
        faces[{v[0], v[1], v[2]}].emplace_back(static_cast<Index>(t), f);
      }
    }
    std::vector<std::vector<std::pair<Index, int>>> expect(d.size());
    std::size_t boundary = 0;
    for (const auto& [key, users] : faces) {
      ASSERT_LE(users.size(), 2u);
      if (users.size() == 1) {
        ++boundary;
        continue;
      }
      const Index la = d.tet_leaf[users[0].first], lb = d.tet_leaf[users[1].first];
      if (la == lb) continue;
      expect[la].push_back(users[0]);
      expect[lb].push_back(users[1]);
    }
    EXPECT_GT(boundary, 0u);
    std::size_t total = 0;
    for (std::size_t l = 0; l < d.size(); ++l) {
      std::sort(expect[l].begin(), expect[l].end());
      EXPECT_EQ(d.interface_faces[l], expect[l]) << "depth " << depth << " leaf " << l;
      total += expect[l].size();
    }
    EXPECT_GT(total, 0u);
  }
}

TEST(Decomposition, DepthZeroIsOneLeafWithoutInterfaces) {
  const VolumeMesh m = kuhn_grid(3);
  const Decomposition d = decompose_ok(m, 0);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d.leaves[0], 0u);
  EXPECT_EQ(d.per_side, 1);
  EXPECT_EQ(d.leaf_tets[0].size(), m.tets.size());
  EXPECT_TRUE(d.n1[0].empty());
  EXPECT_TRUE(d.n2[0].empty());
  EXPECT_TRUE(d.interface_faces[0].empty());
}

TEST(Decomposition, EmptyMeshHasNoLeaves) {
  const Decomposition d = decompose_ok(VolumeMesh{}, 3);
  EXPECT_EQ(d.size(), 0u);
}

TEST(Decomposition, RejectsBadDepthBadPointsAndOverSharedFaces) {
  const VolumeMesh m = kuhn_grid(1);
  EXPECT_EQ(decompose(m, -1).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(decompose(m, kMaxDepth + 1).status().code(), StatusCode::kInvalidInput);
  EXPECT_TRUE(decompose(m, kMaxDepth).ok());

  VolumeMesh bad = m;
  bad.tets.push_back({0, 1, 2, 99});
  const auto r = decompose(bad, 1);
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(r.status().message().find("point 99"), std::string::npos) << r.status().message();

  VolumeMesh three = m;
  three.points.push_back({2, 2, 2});
  three.tets.push_back({0, 1, 7, 8});  // face (0, 1, 7) is now shared by three tets
  const auto r3 = decompose(three, 1);
  EXPECT_EQ(r3.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(r3.status().message().find("face (0, 1, 7)"), std::string::npos) << r3.status().message();
}

TEST(Decomposition, DefaultDepthIsTheSmallestThatReachesTheTarget) {
  EXPECT_EQ(default_depth(0, 1000), 0);
  EXPECT_EQ(default_depth(1000, 1000), 0);
  EXPECT_EQ(default_depth(3773233, 1000), 4);  // the paper's horn bulb at depth 4
  EXPECT_EQ(default_depth(std::size_t{1} << 62, 1), kMaxDepth);
  EXPECT_EQ(default_depth(100, 0), default_depth(100, 1));
  for (std::size_t target : {1ul, 7ul, 8ul, 9ul, 4096ul, 100000ul, 5000000ul}) {
    for (std::size_t per : {1ul, 10ul, 1000ul}) {
      const int d = default_depth(target, per);
      EXPECT_GE((std::size_t{1} << (3 * d)) * per, target);
      if (d > 0) {
        EXPECT_LT((std::size_t{1} << (3 * (d - 1))) * per, target);
      }
    }
  }
}

TEST(Decomposition, DefaultDepthCountsTheOccupiedLeaves) {
  // A rod: 2^d of the 8^d leaves occupied, so 100 leaves need depth 7, not 3.
  const auto rod = [](int d) { return std::size_t{1} << d; };
  EXPECT_EQ(default_depth(100000, 1000, rod), 7);
  EXPECT_EQ(default_depth(100000, 1000), 3);
  // Estimates are clamped to [1, 8^d]: none occupied still deepens, more than
  // all does not make a shallower grid than the full count.
  EXPECT_EQ(default_depth(100000, 1000, [](int) { return std::size_t{0}; }), kMaxDepth);
  EXPECT_EQ(default_depth(100000, 1000, [](int) { return std::size_t{1} << 40; }), default_depth(100000, 1000));
}

TEST(Decomposition, OccupiedLeavesOfAThinSlabAndOfAFullCube) {
  // Points on both faces of a 1 x 1 x 0.01 slab. Its root cube is 1 wide and
  // centred on the slab, whose faces straddle the middle plane z = 0.005: at
  // depth 2, 4 x 4 leaves in x and y, 2 in z, out of 64.
  std::vector<Vec3> slab;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 20; ++j)
      for (double z : {0.0, 0.01}) slab.push_back({i / 20.0, j / 20.0, z});
  EXPECT_EQ(occupied_leaves_estimate(slab, 0.01, 0), 1u);
  EXPECT_EQ(occupied_leaves_estimate(slab, 0.01, 1), 8u);
  EXPECT_EQ(occupied_leaves_estimate(slab, 0.01, 2), 32u);
  // A unit cube known by its 8 corners: the volume counts the inner leaves.
  std::vector<Vec3> corners;
  for (int k = 0; k < 8; ++k) corners.push_back({double(k & 1), double((k >> 1) & 1), double((k >> 2) & 1)});
  EXPECT_EQ(occupied_leaves_estimate(corners, 1.0, 2), 64u);
  EXPECT_EQ(occupied_leaves_estimate(corners, 1.0, 3), 512u);
}

}  // namespace
}  // namespace pdrmesh

namespace pdrmesh {
namespace {

TEST(Decomposition, LeavesOnlyMatchesTheFullDecompositionWithoutInterfaces) {
  const VolumeMesh g = fixtures::kuhn_grid(6);
  Result<Decomposition> full = decompose(g, 2);
  ASSERT_TRUE(full.ok());
  Result<Decomposition> lean = decompose_leaves(g, 2, full->box);
  ASSERT_TRUE(lean.ok());
  EXPECT_EQ(lean->leaves, full->leaves);
  EXPECT_EQ(lean->leaf_tets, full->leaf_tets);
  EXPECT_EQ(lean->tet_leaf, full->tet_leaf);
  EXPECT_EQ(lean->n1, full->n1);
  EXPECT_EQ(lean->n2, full->n2);
  EXPECT_EQ(lean->interface_faces.size(), full->size());
  for (const auto& f : lean->interface_faces) EXPECT_TRUE(f.empty());
  EXPECT_FALSE(decompose_leaves(g, kMaxDepth + 1, full->box).ok());
}

/// `make()` inside an arena of `threads` threads.
Result<Decomposition> in_arena(int threads, const std::function<Result<Decomposition>()>& make) {
  tbb::task_arena arena(threads);
  return arena.execute(make);
}

void expect_same_decomposition(const Result<Decomposition>& a, const Result<Decomposition>& b) {
  ASSERT_EQ(a.ok(), b.ok());
  if (!a.ok()) {
    EXPECT_EQ(a.status().to_string(), b.status().to_string());
    return;
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(a->box.lo[k], b->box.lo[k]);
    EXPECT_EQ(a->box.hi[k], b->box.hi[k]);
  }
  EXPECT_EQ(a->depth, b->depth);
  EXPECT_EQ(a->per_side, b->per_side);
  EXPECT_EQ(a->leaves, b->leaves);
  EXPECT_EQ(a->leaf_tets, b->leaf_tets);
  EXPECT_EQ(a->tet_leaf, b->tet_leaf);
  EXPECT_EQ(a->n1, b->n1);
  EXPECT_EQ(a->n2, b->n2);
  EXPECT_EQ(a->interface_faces, b->interface_faces);
}

TEST(Decomposition, SameOnOneAndFourThreads) {
  // 166,374 tets and 24,389 points: many chunks of every parallel pass. The
  // grid is shuffled so that leaves' tets and faces' points are scattered.
  VolumeMesh g = kuhn_grid(28);
  for (std::size_t t = 0; t < g.tets.size(); ++t) std::swap(g.tets[t], g.tets[(t * 7919) % g.tets.size()]);
  for (int depth : {0, 3, 5}) {
    const auto full = in_arena(1, [&] { return decompose(g, depth); });
    ASSERT_TRUE(full.ok()) << full.status().to_string();
    expect_same_decomposition(full, in_arena(4, [&] { return decompose(g, depth); }));
    // Every tet is listed once, in its leaf, ascending (the serial order).
    std::size_t listed = 0;
    for (std::size_t l = 0; l < full->size(); ++l) {
      EXPECT_TRUE(std::is_sorted(full->leaf_tets[l].begin(), full->leaf_tets[l].end()));
      for (Index t : full->leaf_tets[l]) EXPECT_EQ(full->tet_leaf[t], l);
      listed += full->leaf_tets[l].size();
    }
    EXPECT_EQ(listed, g.tets.size());
    if (depth > 0) {
      EXPECT_FALSE(full->interface_faces[0].empty());
    }
    Box shifted = full->box;
    for (int k = 0; k < 3; ++k) shifted.lo[k] += 0.7, shifted.hi[k] += 0.7;
    expect_same_decomposition(in_arena(1, [&] { return decompose_leaves(g, depth, shifted); }),
                              in_arena(4, [&] { return decompose_leaves(g, depth, shifted); }));
  }
}

TEST(Decomposition, SameErrorOnOneAndFourThreads) {
  // Several over-shared faces and several bad points: the first in the
  // serial order is reported, whatever the threads.
  VolumeMesh three = kuhn_grid(24);
  const std::size_t nt = three.tets.size();
  for (std::size_t k = 0; k < 4; ++k) three.tets.push_back(three.tets[nt - 1 - k * (nt / 5)]);
  std::map<std::array<Index, 3>, int> uses;  // the oracle: the smallest face of more than two tets
  for (const Tet& t : three.tets) {
    for (int f = 0; f < 4; ++f) {
      std::array<Index, 3> key{t[(f + 1) % 4], t[(f + 2) % 4], t[(f + 3) % 4]};
      std::sort(key.begin(), key.end());
      ++uses[key];
    }
  }
  const auto over = std::find_if(uses.begin(), uses.end(), [](const auto& u) { return u.second > 2; });
  ASSERT_NE(over, uses.end());
  const auto r3 = in_arena(1, [&] { return decompose(three, 2); });
  EXPECT_EQ(r3.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(r3.status().message().find(fmt::format("face ({}, {}, {}) is shared by 3 tets", over->first[0],
                                                   over->first[1], over->first[2])),
            std::string::npos)
      << r3.status().message();
  expect_same_decomposition(r3, in_arena(4, [&] { return decompose(three, 2); }));

  VolumeMesh bad = kuhn_grid(24);
  for (std::size_t k = 0; k < 5; ++k) {
    const std::size_t t = nt - 1 - k * (nt / 6);
    bad.tets[t][2] = static_cast<Index>(bad.points.size() + t);
  }
  const Box cube = root_cube(Box{{0, 0, 0}, {24, 24, 24}});
  const auto rb = in_arena(1, [&] { return decompose_leaves(bad, 2, cube); });
  EXPECT_EQ(rb.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(rb.status().message().find(fmt::format("tet {} refers", nt - 1 - 4 * (nt / 6))), std::string::npos)
      << rb.status().message();
  expect_same_decomposition(rb, in_arena(4, [&] { return decompose_leaves(bad, 2, cube); }));
}

}  // namespace
}  // namespace pdrmesh
