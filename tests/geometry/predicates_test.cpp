// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/predicates.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>

// libtet's own predicates (initialised by predicates.cpp), to check the
// filtered wrappers against.
double orient3d(double* pa, double* pb, double* pc, double* pd);
double insphere(double* pa, double* pb, double* pc, double* pd, double* pe);

namespace pdrmesh {
namespace {

const Vec3 kO{0, 0, 0}, kX{1, 0, 0}, kY{0, 1, 0}, kZ{0, 0, 1};

TEST(Orient3d, MatchesSignedVolumeConvention) {
  EXPECT_GT(signed_volume(kO, kX, kY, kZ), 0.0);
  EXPECT_EQ(exact::orient3d(kO, kX, kY, kZ), 1);
  EXPECT_EQ(exact::orient3d(kO, kY, kX, kZ), -1);
  EXPECT_EQ(exact::orient3d(kO, kX, kY, Vec3{0.3, 0.7, 0}), 0);
}

TEST(Orient3d, ExactOnNearDegenerateGrid) {
  // Shewchuk's classic: points c near (0.5, 0.5) a few ulps apart, tested
  // against the plane x = y through a, b, d. The exact sign is sign(cx - cy),
  // which a plain double determinant gets wrong on parts of this grid.
  const Vec3 a{12, 12, 0}, b{24, 24, 0}, d{0, 0, 1};
  const double ulp = std::nextafter(0.5, 1.0) - 0.5;
  for (int i = 0; i < 32; ++i) {
    for (int j = 0; j < 32; ++j) {
      const Vec3 c{0.5 + i * ulp, 0.5 + j * ulp, 0};
      EXPECT_EQ(exact::orient3d(a, b, d, c), (i > j) - (i < j)) << "i=" << i << " j=" << j;
    }
  }
}

TEST(Orient2d, ProjectionsAreCyclic) {
  // (O, X, Y) is counterclockwise seen from +z: drop z.
  EXPECT_EQ(exact::orient2d(kO, kX, kY, 2), 1);
  // (O, Y, Z) is counterclockwise seen from +x: drop x.
  EXPECT_EQ(exact::orient2d(kO, kY, kZ, 0), 1);
  // (O, Z, X) is counterclockwise seen from +y: drop y.
  EXPECT_EQ(exact::orient2d(kO, kZ, kX, 1), 1);
}

TEST(Insphere, InsideOnOutsideForPositiveTet) {
  ASSERT_EQ(exact::orient3d(kO, kX, kY, kZ), 1);
  EXPECT_EQ(exact::insphere(kO, kX, kY, kZ, Vec3{0.2, 0.2, 0.2}), 1);
  EXPECT_EQ(exact::insphere(kO, kX, kY, kZ, Vec3{1, 1, 1}), 0);  // cube corner: cospherical
  EXPECT_EQ(exact::insphere(kO, kX, kY, kZ, Vec3{2, 2, 2}), -1);
}

TEST(Collinear, DetectsDegenerateTriangles) {
  EXPECT_TRUE(exact::collinear(kO, kX, Vec3{3, 0, 0}));
  EXPECT_TRUE(exact::collinear(kO, Vec3{1, 1, 1}, Vec3{0.5, 0.5, 0.5}));
  EXPECT_FALSE(exact::collinear(kO, kX, kY));
}

TEST(Predicates, FilterAgreesWithLibtet) {
  // Random points, then the same nudged onto planes and spheres by a few ulps,
  // where the wrappers' inline filter cannot decide and libtet's adaptive
  // stages must: every answer equals the sign libtet gives.
  std::uint64_t state = 0x243F6A8885A308D3ull;
  const auto uniform = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) * 0x1p-53;
  };
  const auto sign = [](double v) { return (v > 0.0) - (v < 0.0); };
  int undecided_o3d = 0, undecided_isp = 0;
  for (int i = 0; i < 20000; ++i) {
    std::array<Vec3, 5> p;
    for (Vec3& q : p) q = {uniform() * 8 - 4, uniform() * 8 - 4, uniform() * 8 - 4};
    if (i % 2 == 1) {
      // d (and e) on the plane of a, b, c (and sphere of a, b, c, d), up to rounding.
      const double s = uniform(), t = uniform();
      p[3] = p[0] + s * (p[1] - p[0]) + t * (p[2] - p[0]);
      p[4] = p[0] + (p[1] - p[0]) + (p[2] - p[0]) - p[3] + p[0];  // on the plane too
    }
    if (i % 4 == 3) p[3] = Vec3{p[0][0], p[0][1], p[0][2] + uniform() * 0x1p-40};
    std::array<Vec3, 5> c = p;  // libtet takes non-const pointers
    const int o3d = -sign(::orient3d(c[0].data(), c[1].data(), c[2].data(), c[3].data()));
    EXPECT_EQ(exact::orient3d(p[0], p[1], p[2], p[3]), o3d) << "case " << i;
    undecided_o3d += o3d == 0 ? 1 : 0;
    c = p;
    const int isp = -sign(::insphere(c[0].data(), c[1].data(), c[2].data(), c[3].data(), c[4].data()));
    EXPECT_EQ(exact::insphere(p[0], p[1], p[2], p[3], p[4]), isp) << "case " << i;
    undecided_isp += isp == 0 ? 1 : 0;
  }
  // The cases above include exact zeros (a degenerate tet, d = e and so on).
  EXPECT_GT(undecided_o3d + undecided_isp, 0);
}

}  // namespace
}  // namespace pdrmesh
