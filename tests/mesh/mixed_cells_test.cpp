// SPDX-License-Identifier: AGPL-3.0-or-later
// Prisms and pyramids (mixed_cells.hpp): their cuts into tets and the positivity check.
#include "pdrmesh/mixed_cells.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "pdrmesh/predicates.hpp"

namespace pdrmesh {
namespace {

/// The reference prism of mixed_cells.hpp, its top at height h.
std::vector<Vec3> prism_points(double h = 1) {
  return {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, h}, {1, 0, h}, {0, 1, h}};
}

double volume_of(const std::vector<Vec3>& P, const Tet& t) { return signed_volume(P[t[0]], P[t[1]], P[t[2]], P[t[3]]); }

TEST(MixedCells, PrismCutIsThreePositiveTetsFillingIt) {
  const std::vector<Vec3> P = prism_points();
  // Every labelling that keeps the orientation cuts it into positive tets.
  const Prism labellings[] = {{0, 1, 2, 3, 4, 5}, {1, 2, 0, 4, 5, 3}, {3, 5, 4, 0, 2, 1}, {5, 4, 3, 2, 1, 0}};
  for (const Prism& p : labellings) {
    double v = 0;
    for (const Tet& t : prism_tets(p)) {
      EXPECT_GT(exact::orient3d(P[t[0]], P[t[1]], P[t[2]], P[t[3]]), 0);
      v += volume_of(P, t);
    }
    EXPECT_DOUBLE_EQ(v, 0.5);
    EXPECT_TRUE(prism_positive(P, p));
  }
}

TEST(MixedCells, PrismCutsAgreeOnASharedQuad) {
  // Two prisms side by side: their shared quad (1, 2, 6, 5) is cut the same
  // way by both (whatever their coordinates: the rule looks at indices only).
  const Prism a{0, 1, 2, 4, 5, 6}, b{1, 3, 2, 5, 7, 6};
  std::set<Tri> faces_a, faces_b;
  const auto faces = [](const std::array<Tet, 3>& tets, std::set<Tri>& out) {
    for (const Tet& t : tets)
      for (int skip = 0; skip < 4; ++skip) {
        Tri f{};
        for (int i = 0, j = 0; i < 4; ++i)
          if (i != skip) f[j++] = t[i];
        std::sort(f.begin(), f.end());
        out.insert(f);
      }
  };
  faces(prism_tets(a), faces_a);
  faces(prism_tets(b), faces_b);
  int shared = 0;
  for (const Tri& f : faces_a) {
    const bool on_quad = std::all_of(f.begin(), f.end(), [](Index v) { return v == 1 || v == 2 || v == 5 || v == 6; });
    if (on_quad) shared += faces_b.count(f) > 0 ? 1 : 0;
  }
  EXPECT_EQ(shared, 2);
}

TEST(MixedCells, InvertedOrTwistedPrismIsNotPositive) {
  EXPECT_FALSE(prism_positive(prism_points(-1), {0, 1, 2, 3, 4, 5}));  // top below the bottom
  EXPECT_FALSE(prism_positive(prism_points(), {0, 2, 1, 3, 5, 4}));    // bottom turning the wrong way
  std::vector<Vec3> twisted = prism_points(0.1);
  twisted[3] = {0.9, 0.0, 0.1};  // the top turned far round: its quads fold
  twisted[4] = {0.1, 0.9, 0.1};
  twisted[5] = {0.0, 0.1, 0.1};
  EXPECT_FALSE(prism_positive(twisted, {0, 1, 2, 3, 4, 5}));
}

TEST(MixedCells, PyramidCutIsTwoPositiveTets) {
  const std::vector<Vec3> P = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 1}};
  for (const Pyramid& p : {Pyramid{0, 1, 2, 3, 4}, Pyramid{1, 2, 3, 0, 4}}) {
    double v = 0;
    for (const Tet& t : pyramid_tets(p)) {
      EXPECT_GT(exact::orient3d(P[t[0]], P[t[1]], P[t[2]], P[t[3]]), 0);
      v += volume_of(P, t);
    }
    EXPECT_DOUBLE_EQ(v, 1.0 / 3);
    EXPECT_TRUE(pyramid_positive(P, p));
  }
  EXPECT_FALSE(pyramid_positive(P, {0, 3, 2, 1, 4}));
}

}  // namespace
}  // namespace pdrmesh
