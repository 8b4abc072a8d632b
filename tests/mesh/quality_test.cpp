// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/quality.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>
#include <numbers>

#include "tet_fixtures.hpp"

namespace pdrmesh {
namespace {

const double kRegularDihedral = std::acos(1.0 / 3.0) * 180.0 / std::numbers::pi;  // 70.53

// A regular tetrahedron with unit-ish edges, positively oriented.
const Vec3 kA{1, 1, 1}, kB{1, -1, -1}, kC{-1, -1, 1}, kD{-1, 1, -1};

TEST(DihedralAngles, RegularTetHasAllAnglesEqual) {
  ASSERT_GT(signed_volume(kA, kB, kC, kD), 0);
  for (double x : dihedral_angles(kA, kB, kC, kD)) EXPECT_NEAR(x, kRegularDihedral, 1e-9);
}

TEST(DihedralAngles, CornerTetHasRightAngles) {
  // Corner tet of the unit cube: three right angles at the edges through the origin.
  const auto x = dihedral_angles({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1});
  EXPECT_NEAR(x[0], 90, 1e-9);  // ab
  EXPECT_NEAR(x[1], 90, 1e-9);  // ac
  EXPECT_NEAR(x[2], 90, 1e-9);  // ad
  EXPECT_NEAR(x[3], std::acos(1 / std::sqrt(3.0)) * 180 / std::numbers::pi, 1e-9);
}

TEST(DihedralAngles, SliverHasAnglesNearZeroAndPi) {
  // Four almost coplanar points at the corners of a square.
  const auto r = dihedral_range({0, 0, 0}, {1, 0, 0}, {1, 1, 1e-3}, {0, 1, 0});
  EXPECT_LT(r.min, 1.0);
  EXPECT_GT(r.max, 179.0);
}

/// `count` random tets in [-0.5, 0.5)^3 (a fixed linear congruential
/// sequence from `seed`), then a regular, a flat, one with a degenerate face
/// and one that is a single point.
std::vector<std::array<Vec3, 4>> test_tets(std::uint64_t seed, int count) {
  std::uint64_t state = seed;
  const auto next = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0 - 0.5;
  };
  std::vector<std::array<Vec3, 4>> tets;
  for (int i = 0; i < count; ++i) tets.push_back({Vec3{next(), next(), next()}, Vec3{next(), next(), next()},
                                                  Vec3{next(), next(), next()}, Vec3{next(), next(), next()}});
  tets.push_back({kA, kB, kC, kD});
  tets.push_back({Vec3{0, 0, 0}, Vec3{1, 0, 0}, Vec3{1, 1, 0}, Vec3{0, 1, 0}});  // flat
  tets.push_back({Vec3{0, 0, 0}, Vec3{1, 0, 0}, Vec3{2, 0, 0}, Vec3{0, 1, 1}});  // a degenerate face
  tets.push_back({Vec3{0, 0, 0}, Vec3{0, 0, 0}, Vec3{0, 0, 0}, Vec3{0, 0, 0}});  // a point
  return tets;
}

TEST(DihedralRange, EqualsTheExtremesOfTheSixAngles) {
  // dihedral_range takes two acos instead of six: the same doubles, bit for
  // bit, on positive, inverted, flat and degenerate tets.
  const std::vector<std::array<Vec3, 4>> tets = test_tets(12345, 2000);
  for (const auto& p : tets) {
    const auto a = dihedral_angles(p[0], p[1], p[2], p[3]);
    const AngleRange r = dihedral_range(p[0], p[1], p[2], p[3]);
    EXPECT_EQ(r.min, *std::min_element(a.begin(), a.end()));
    EXPECT_EQ(r.max, *std::max_element(a.begin(), a.end()));
  }
}

TEST(DihedralBounds, DecidesAsDihedralRangeDoes) {
  // The cosine test against [15, 150] degrees (and a few other bounds) on
  // random, flat and degenerate tets: the same decision as dihedral_range's
  // extremes, except where an extreme lies within rounding of a bound.
  const std::vector<std::array<Vec3, 4>> tets = test_tets(777, 5000);
  std::size_t outside = 0, inside = 0;
  for (const auto& [lo, hi] : {std::pair{15.0, 150.0}, std::pair{0.0, 180.0}, std::pair{40.0, 100.0}}) {
    const DihedralBounds bounds(lo, hi);
    for (const auto& p : tets) {
      const AngleRange r = dihedral_range(p[0], p[1], p[2], p[3]);
      if (std::abs(r.min - lo) < 1e-9 || std::abs(r.max - hi) < 1e-9) continue;
      const bool want = r.min < lo || r.max > hi;
      EXPECT_EQ(bounds.outside(p[0], p[1], p[2], p[3]), want) << lo << " " << hi << ": " << r.min << " " << r.max;
      (want ? outside : inside) += 1;
    }
  }
  EXPECT_GT(outside, 1000u);  // both answers are exercised
  EXPECT_GT(inside, 1000u);
}

TEST(VerdictShape, OneForRegularZeroForInverted) {
  EXPECT_NEAR(verdict_shape(kA, kB, kC, kD), 1.0, 1e-12);
  EXPECT_EQ(verdict_shape(kB, kA, kC, kD), 0.0);
  EXPECT_LT(verdict_shape({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}), 1.0);
}

TEST(VerdictRelativeSize, OneAtAverageSmallerAway) {
  const double v = signed_volume(kA, kB, kC, kD);
  EXPECT_NEAR(verdict_relative_size_squared(kA, kB, kC, kD, v), 1.0, 1e-12);
  EXPECT_NEAR(verdict_relative_size_squared(kA, kB, kC, kD, 2 * v), 0.25, 1e-12);
  EXPECT_NEAR(verdict_relative_size_squared(kA, kB, kC, kD, 0.5 * v), 0.25, 1e-12);
}

TEST(MeasureQuality, CountsEveryAngleInTheHistogram) {
  VolumeMesh m;
  m.points = {kA, kB, kC, kD, {0, 0, -3}};
  m.tets = {{0, 1, 2, 3}};
  const auto q = measure_quality(m);
  EXPECT_EQ(q.tets, 1u);
  std::size_t n = 0;
  for (auto c : q.histogram) n += c;
  EXPECT_EQ(n, 6u);
  EXPECT_EQ(q.histogram[7], 6u);  // 70.5 degrees
  EXPECT_DOUBLE_EQ(q.share_below_10, 0.0);
  EXPECT_NEAR(q.mean_shape_and_size, 1.0, 1e-12);
}

TEST(MeasureQuality, BinsAndExtremesAreThoseOfTheSixAngles) {
  // measure_quality bins each angle by its cosine and takes the extremes from
  // the extreme cosines: the same counts and doubles as binning every angle
  // of dihedral_angles, on random, flat and degenerate tets, and on corner
  // tets whose right angles lie on a bin edge.
  std::vector<std::array<Vec3, 4>> tets = test_tets(4242, 3000);
  for (int s = 1; s <= 50; ++s) {
    const double h = 0.1 * s;
    tets.push_back({Vec3{0, 0, 0}, Vec3{h, 0, 0}, Vec3{0, h, 0}, Vec3{0, 0, h}});
    tets.push_back({Vec3{0, 0, 0}, Vec3{h, 0, 0}, Vec3{h, h, 0}, Vec3{h, h, h}});
  }
  VolumeMesh m;
  std::array<std::size_t, 18> histogram{};
  double lo = 180.0, hi = 0.0;
  std::size_t below = 0;
  for (const auto& p : tets) {
    const auto base = static_cast<Index>(m.points.size());
    m.points.insert(m.points.end(), p.begin(), p.end());
    m.tets.push_back({base, base + 1, base + 2, base + 3});
    const auto a = dihedral_angles(p[0], p[1], p[2], p[3]);
    for (double x : a) ++histogram[std::min<std::size_t>(17, static_cast<std::size_t>(std::max(0.0, x) / 10.0))];
    const double tet_lo = std::min(180.0, *std::min_element(a.begin(), a.end()));
    lo = std::min(lo, tet_lo);
    hi = std::max(hi, *std::max_element(a.begin(), a.end()));
    below += tet_lo < 10.0;
  }
  const QualityReport q = measure_quality(m);
  for (std::size_t i = 0; i < histogram.size(); ++i) EXPECT_EQ(q.histogram[i], histogram[i]) << "bin " << i;
  EXPECT_EQ(q.min_dihedral, lo);
  EXPECT_EQ(q.max_dihedral, hi);
  EXPECT_EQ(q.share_below_10, static_cast<double>(below) / static_cast<double>(tets.size()));
  EXPECT_GT(histogram[0], 0u);  // flat tets and slivers are there
  EXPECT_GT(histogram[9], 0u);
}

TEST(MeasureQuality, InteriorTetsAreThoseWithNoHullVertex) {
  // 3 x 3 x 3 unit cubes, each cut into the 6 tets of fixtures::cube(): only
  // the middle cube's 8 corners are off the hull, so its 6 tets are the
  // interior ones (Kuhn tets: dihedral angles of 45, 60 and 90 degrees).
  const VolumeMesh unit = fixtures::cube();
  VolumeMesh m;
  auto point = [&](const Vec3& p) {
    const auto it = std::find(m.points.begin(), m.points.end(), p);
    if (it != m.points.end()) return static_cast<Index>(it - m.points.begin());
    m.points.push_back(p);
    return static_cast<Index>(m.points.size() - 1);
  };
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y)
      for (int z = 0; z < 3; ++z)
        for (const Tet& k : unit.tets) {
          Tet t{};
          for (int i = 0; i < 4; ++i) t[i] = point(unit.points[k[i]] + Vec3{double(x), double(y), double(z)});
          m.tets.push_back(t);
        }
  EXPECT_FALSE(measure_quality(m).interior_measured);
  const auto q = measure_quality(m, /*interior=*/true);
  EXPECT_TRUE(q.interior_measured);
  EXPECT_EQ(q.tets, 27u * 6u);
  EXPECT_EQ(q.interior_tets, 6u);
  EXPECT_NEAR(q.interior_min_dihedral, 45.0, 1e-9);
  EXPECT_NEAR(q.interior_max_dihedral, 90.0, 1e-9);
  // Triangles in the file do not count (TetGen's -g output lists every face).
  m.boundary = {{point({1, 1, 1}), point({2, 1, 1}), point({2, 2, 1})}};
  EXPECT_EQ(measure_quality(m, true).interior_tets, 6u);
  EXPECT_NE(quality_to_json(q).find("\"interior_tets\":6"), std::string::npos);
  VolumeMesh one;
  one.points = {kA, kB, kC, kD};
  one.tets = {{0, 1, 2, 3}};
  const auto none = measure_quality(one, true);
  EXPECT_EQ(none.interior_tets, 0u);
  EXPECT_EQ(none.interior_min_dihedral, 0.0);
}

}  // namespace
}  // namespace pdrmesh
