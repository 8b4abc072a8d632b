// SPDX-License-Identifier: AGPL-3.0-or-later
// make_farfield: the domain around a body (farfield.hpp).
#include "pdrmesh/farfield.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "pdrmesh/surface_check.hpp"
#include "test_fixtures.hpp"

namespace pdrmesh {
namespace {

using fixtures::unit_cube_surface;

/// The cube with every face named after its id (1: z=0 ... 6: x=1) removed: all unnamed, one id.
SurfaceMesh one_id_cube() {
  SurfaceMesh s = unit_cube_surface();
  std::fill(s.surface_ids.begin(), s.surface_ids.end(), 1);
  return s;
}

/// The domain passes the whole surface check (with self-intersections): one
/// outward far field at depth 0, the reversed body at depth 1.
void expect_meshable(const FarfieldDomain& d) {
  const SurfaceReport r = check_surface(d.surface);
  EXPECT_TRUE(r.meshable()) << format_report(r, "domain");
  ASSERT_EQ(r.components.size(), 2u);
  EXPECT_EQ(r.components[0].nesting_depth, 1);  // the body's triangles come first
  EXPECT_LT(r.components[0].volume, 0);
  EXPECT_EQ(r.components[1].nesting_depth, 0);
  EXPECT_GT(r.components[1].volume, 0);
}

TEST(Farfield, BoxAroundCubeHasInletOutletSidesAndWall) {
  const SurfaceMesh body = one_id_cube();
  auto d = make_farfield(body, {10, FarfieldShape::kBox});
  ASSERT_TRUE(d.ok()) << d.status().to_string();
  expect_meshable(*d);
  EXPECT_EQ(d->body_length, 1.0);
  EXPECT_DOUBLE_EQ(d->farfield_size, 2.5);
  const std::map<int, std::string> names{{1, "wall"}, {2, "inlet"}, {3, "outlet"}, {4, "sides"}};
  EXPECT_EQ(d->surface.surface_names, names);
  // The body keeps its points and its triangles, reversed.
  const SurfaceMesh& s = d->surface;
  for (std::size_t i = 0; i < body.points.size(); ++i) EXPECT_EQ(s.points[i], body.points[i]);
  for (std::size_t t = 0; t < body.triangles.size(); ++t) {
    const Tri& a = body.triangles[t];
    EXPECT_EQ(s.triangles[t], (Tri{a[0], a[2], a[1]}));
  }
  // The box [-10, 11]^3, 21 / 2.5 -> 9 squares a side, 2 triangles each, on 6 faces.
  EXPECT_EQ(d->farfield_triangles, 6u * 9 * 9 * 2);
  ASSERT_EQ(s.triangles.size(), body.triangles.size() + d->farfield_triangles);
  std::map<int, int> per_id;
  Box far;
  for (std::size_t t = body.triangles.size(); t < s.triangles.size(); ++t) {
    ++per_id[s.surface_ids[t]];
    for (Index p : s.triangles[t]) far.add(s.points[p]);
    const int id = s.surface_ids[t];
    if (id == 2 || id == 3) {  // the inlet at x = -10, the outlet at x = 11
      for (Index p : s.triangles[t]) EXPECT_EQ(s.points[p][0], id == 2 ? -10.0 : 11.0);
    }
  }
  EXPECT_EQ(per_id, (std::map<int, int>{{2, 162}, {3, 162}, {4, 4 * 162}}));
  EXPECT_EQ(far.lo, (Vec3{-10, -10, -10}));
  EXPECT_EQ(far.hi, (Vec3{11, 11, 11}));
}

TEST(Farfield, SphereIsNamedFarfieldAndAtItsRadius) {
  const SurfaceMesh body = fixtures::corpus_surface("sphere966");
  ASSERT_FALSE(body.points.empty());
  auto d = make_farfield(body, {10, FarfieldShape::kSphere});
  ASSERT_TRUE(d.ok()) << d.status().to_string();
  expect_meshable(*d);
  EXPECT_EQ(d->surface.surface_names, (std::map<int, std::string>{{1, "wall"}, {2, "farfield"}}));
  const Box box = body.bounds();
  const Vec3 centre = 0.5 * (box.lo + box.hi);
  const double radius = box.diagonal() / 2 + 10 * d->body_length;
  for (std::size_t i = body.points.size(); i < d->surface.points.size(); ++i)
    EXPECT_NEAR(norm(d->surface.points[i] - centre), radius, 1e-12 * radius);
  // A geodesic icosahedron: 20 n^2 triangles, 10 n^2 + 2 points.
  const std::size_t far_points = d->surface.points.size() - body.points.size();
  const auto n = static_cast<std::size_t>(std::lround(std::sqrt(static_cast<double>(d->farfield_triangles) / 20)));
  EXPECT_EQ(d->farfield_triangles, 20 * n * n);
  EXPECT_EQ(far_points, 10 * n * n + 2);
  EXPECT_GE(n, 4u);
}

TEST(Farfield, IsDeterministic) {
  const SurfaceMesh body = fixtures::corpus_surface("sphere966");
  for (FarfieldShape shape : {FarfieldShape::kBox, FarfieldShape::kSphere}) {
    auto a = make_farfield(body, {7.5, shape});
    auto b = make_farfield(body, {7.5, shape});
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a->surface.points, b->surface.points);
    EXPECT_EQ(a->surface.triangles, b->surface.triangles);
    EXPECT_EQ(a->surface.surface_ids, b->surface.surface_ids);
  }
}

TEST(Farfield, KeepsBodyNamesAndNamesSeveralUnnamedIds) {
  SurfaceMesh body = unit_cube_surface();  // ids 1..6
  body.surface_names = {{1, "floor"}, {4, "roof"}};
  auto d = make_farfield(body, {2, FarfieldShape::kSphere});
  ASSERT_TRUE(d.ok()) << d.status().to_string();
  expect_meshable(*d);
  const std::map<int, std::string> names{{1, "floor"}, {2, "wall_2"}, {3, "wall_3"}, {4, "roof"},
                                         {5, "wall_5"}, {6, "wall_6"}, {7, "farfield"}};
  EXPECT_EQ(d->surface.surface_names, names);
}

TEST(Farfield, RefusesAbsurdDistances) {
  const SurfaceMesh body = one_id_cube();
  for (double bad : {0.5, 0.0, -3.0, 1000.5, std::nan(""), std::numeric_limits<double>::infinity()}) {
    auto d = make_farfield(body, {bad, FarfieldShape::kBox});
    ASSERT_FALSE(d.ok()) << bad;
    EXPECT_EQ(d.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(d.status().message().find("in body lengths, over 0.5 and at most 1000"), std::string::npos)
        << d.status().message();
  }
  EXPECT_TRUE(make_farfield(body, {1000, FarfieldShape::kBox}).ok());
  EXPECT_TRUE(make_farfield(body, {0.51, FarfieldShape::kSphere}).ok());
}

TEST(Farfield, RefusesAnOpenBody) {
  SurfaceMesh body = one_id_cube();
  body.triangles.pop_back();
  body.surface_ids.pop_back();
  auto d = make_farfield(body, {10, FarfieldShape::kBox});
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.status().message().find("--farfield needs a closed, outward body"), std::string::npos)
      << d.status().message();
  EXPECT_NE(d.status().message().find("hole"), std::string::npos) << d.status().message();
}

TEST(Farfield, RefusesAnInwardBody) {
  SurfaceMesh body = one_id_cube();
  for (Tri& t : body.triangles) std::swap(t[1], t[2]);
  auto d = make_farfield(body, {10, FarfieldShape::kBox});
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.status().message().find("inward"), std::string::npos) << d.status().message();
}

TEST(Farfield, RefusesABodyNameOfTheFarfield) {
  SurfaceMesh body = one_id_cube();
  body.surface_names = {{1, "inlet"}};
  auto d = make_farfield(body, {10, FarfieldShape::kBox});
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.status().message().find("is named 'inlet', a name of the far field"), std::string::npos)
      << d.status().message();
  body.surface_names = {{1, "farfield"}};
  EXPECT_TRUE(make_farfield(body, {10, FarfieldShape::kBox}).ok());  // not a box's name
  EXPECT_FALSE(make_farfield(body, {10, FarfieldShape::kSphere}).ok());
}

TEST(Farfield, WrapsSeveralBodies) {
  SurfaceMesh body = one_id_cube();
  const std::size_t n = body.points.size(), m = body.triangles.size();
  for (std::size_t i = 0; i < n; ++i) body.points.push_back(body.points[i] + Vec3{3, 0, 0});
  for (std::size_t t = 0; t < m; ++t) {
    const Tri& a = body.triangles[t];
    body.triangles.push_back({a[0] + Index(n), a[1] + Index(n), a[2] + Index(n)});
    body.surface_ids.push_back(1);
  }
  auto d = make_farfield(body, {5, FarfieldShape::kBox});
  ASSERT_TRUE(d.ok()) << d.status().to_string();
  EXPECT_EQ(d->body_length, 4.0);
  const SurfaceReport r = check_surface(d->surface);
  EXPECT_TRUE(r.meshable()) << format_report(r, "domain");
  EXPECT_EQ(r.components.size(), 3u);
}

}  // namespace
}  // namespace pdrmesh
