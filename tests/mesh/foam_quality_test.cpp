// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of cell_faces (OpenFOAM's face order) and of the checkMesh figures on
// fixtures whose values follow by hand.
#include "pdrmesh/foam_quality.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "pdrmesh/cell_faces.hpp"
#include "tet_fixtures.hpp"

namespace pdrmesh {
namespace {

constexpr double kDegrees = 180.0 / std::numbers::pi;

TEST(CellFaces, CubeFacesAreUpperTriangularAndOutOfTheirOwner) {
  const VolumeMesh m = fixtures::cube();
  const auto cf = cell_faces(m.tets, m.points.size());
  ASSERT_TRUE(cf.ok()) << cf.status().to_string();
  EXPECT_EQ(cf->internal(), 6U) << "6 tets around the diagonal share 6 faces";
  EXPECT_EQ(cf->faces.size(), 18U);
  for (std::size_t f = 0; f < cf->faces.size(); ++f) {
    const Tri& t = cf->faces[f];
    const Tet& own = m.tets[cf->owner[f]];
    // The owner's fourth point lies behind the face.
    Index apex = 0;
    for (Index v : own)
      if (std::find(t.begin(), t.end(), v) == t.end()) apex = v;
    EXPECT_LT(signed_volume(m.points[t[0]], m.points[t[1]], m.points[t[2]], m.points[apex]), 0) << "face " << f;
    if (f < cf->internal()) {
      EXPECT_LT(cf->owner[f], cf->neighbour[f]);
      if (f > 0) {
        EXPECT_LT(std::make_pair(cf->owner[f - 1], cf->neighbour[f - 1]), std::make_pair(cf->owner[f], cf->neighbour[f]));
      }
    } else if (f > cf->internal()) {
      EXPECT_LE(cf->owner[f - 1], cf->owner[f]) << "hull faces by owner";
    }
  }
}

TEST(FoamQuality, NonOrthogonalityOfTwoTetsFollowsFromTheirCentroids) {
  // Face abc in z = 0; tet 0 = (a, b, c, e) above with centroid (1/4, 1/4, 1/4),
  // tet 1 = (a, c, b, d) below. With d = (1, 1, -1) tet 1's centroid is
  // (1/2, 1/2, -1/4): the centre line (1/4, 1/4, -1/2) leans from the face
  // normal (0, 0, -1) by atan(|(1/4, 1/4)| / (1/2)) = atan(1 / sqrt 2).
  const VolumeMesh m = fixtures::two_tets({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, -1}, {0, 0, 1});
  const auto q = measure_foam_quality(m);
  ASSERT_TRUE(q.ok()) << q.status().to_string();
  EXPECT_EQ(q->internal_faces, 1U);
  EXPECT_EQ(q->boundary_faces, 6U);
  const double want = std::atan(1 / std::sqrt(2.0)) * kDegrees;  // 35.26 degrees
  EXPECT_NEAR(q->max_non_orthogonality, want, 1e-9);
  EXPECT_NEAR(q->mean_non_orthogonality, want, 1e-9);
  EXPECT_EQ(q->faces_over_70, 0U);

  // d = (3, 3, -1/4): centroid (1, 1, -1/16), centre line (3/4, 3/4, -5/16):
  // atan(3 sqrt 2 / 4 / (5/16)) = 73.6 degrees, a face over 70.
  const VolumeMesh lean = fixtures::two_tets({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {3, 3, -0.25}, {0, 0, 1});
  const auto l = measure_foam_quality(lean);
  ASSERT_TRUE(l.ok());
  EXPECT_NEAR(l->max_non_orthogonality, std::atan(0.75 * std::sqrt(2.0) / 0.3125) * kDegrees, 1e-9);
  EXPECT_EQ(l->faces_over_70, 1U);
  EXPECT_EQ(l->faces_over_90, 0U);
  const auto j = nlohmann::json::parse(foam_quality_to_json(*l));
  EXPECT_EQ(j["faces_over_70"], 1);
  EXPECT_NE(format_foam_quality(*l).find("1 of 1 internal faces over 70"), std::string::npos) << format_foam_quality(*l);
}

TEST(FoamQuality, SkewnessOfCornerTetIsAQuarter) {
  // The tet (0,0,0), (1,0,0), (0,1,0), (0,0,1) has its centroid c = (1/4, 1/4, 1/4).
  // On the face x = 0 (centroid (0, 1/3, 1/3)) c projects to (0, 1/4, 1/4): an
  // offset of sqrt 2 / 12 towards the corner (0,0,0), which lies sqrt 2 / 3
  // from the face centroid in that direction (more than 0.4 x 1/4): skewness
  // 1/4, and the same on y = 0 and z = 0; the slanted face's is 0.
  VolumeMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.tets = {{0, 1, 2, 3}};
  const auto q = measure_foam_quality(m);
  ASSERT_TRUE(q.ok());
  EXPECT_NEAR(q->max_skewness, 0.25, 1e-12);
  EXPECT_EQ(q->internal_faces, 0U);
  EXPECT_EQ(q->max_non_orthogonality, 0.0) << "no internal face";
}

TEST(FoamQuality, FaceOfThreeTetsIsAnError) {
  VolumeMesh m = fixtures::two_tets({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1});
  m.tets.push_back(m.tets[1]);
  const auto q = measure_foam_quality(m);
  ASSERT_FALSE(q.ok());
  EXPECT_EQ(q.status().code(), StatusCode::kInvalidInput);
}

}  // namespace
}  // namespace pdrmesh
