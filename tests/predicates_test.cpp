// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/predicates.hpp"

#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace
}  // namespace pdrmesh
