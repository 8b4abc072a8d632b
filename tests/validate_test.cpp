// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/validate.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "test_fixtures.hpp"

namespace pdrmesh {
namespace {

bool has_error(const ValidationReport& r, std::string_view check) {
  return std::any_of(r.errors.begin(), r.errors.end(),
                     [&](const std::string& e) { return e.rfind(std::string(check) + ":", 0) == 0; });
}

TEST(Validate, KuhnCubeIsValid) {
  const auto mesh = fixtures::unit_cube_mesh();
  const auto surface = fixtures::unit_cube_surface();
  const auto r = validate_mesh(mesh, &surface);
  EXPECT_TRUE(r.ok()) << format_validation(r);
  EXPECT_EQ(r.boundary_faces, 12u);
  EXPECT_EQ(r.euler_volume, 1);
  EXPECT_EQ(r.euler_boundary, 2);
  EXPECT_NEAR(r.volume, 1.0, 1e-15);
  EXPECT_NEAR(r.enclosed_volume, 1.0, 1e-15);
}

TEST(Validate, FindsInvertedTet) {
  auto mesh = fixtures::unit_cube_mesh();
  std::swap(mesh.tets[2][0], mesh.tets[2][1]);
  const auto r = validate_mesh(mesh);
  EXPECT_TRUE(has_error(r, "orientation")) << format_validation(r);
}

TEST(Validate, FindsMissingTetAgainstSurface) {
  auto mesh = fixtures::unit_cube_mesh();
  mesh.tets.pop_back();
  const auto surface = fixtures::unit_cube_surface();
  const auto r = validate_mesh(mesh, &surface);
  EXPECT_TRUE(has_error(r, "surface")) << format_validation(r);
  EXPECT_TRUE(has_error(r, "volume")) << format_validation(r);
}

TEST(Validate, FindsOverlappingTets) {
  auto mesh = fixtures::unit_cube_mesh();
  mesh.tets.push_back(mesh.tets[0]);
  const auto r = validate_mesh(mesh);
  EXPECT_TRUE(has_error(r, "conformity")) << format_validation(r);
}

TEST(Validate, FindsDuplicateAndUnusedPoints) {
  auto mesh = fixtures::unit_cube_mesh();
  mesh.points.push_back(mesh.points[3]);  // a second point at corner 3, unused
  const auto r = validate_mesh(mesh);
  EXPECT_TRUE(has_error(r, "points")) << format_validation(r);
  EXPECT_GE(r.error_count, 2u);  // duplicate and unused
}

TEST(Validate, FindsNonConformingSplitPoint) {
  // Split tet 0 at the midpoint of its face (0, 1, 3) without splitting the
  // neighbour across that face: the face is then a hole in the mesh.
  auto mesh = fixtures::unit_cube_mesh();
  mesh.points.push_back({0.5, 0.25, 0});
  const Index m = 8;
  const Tet t = mesh.tets[0];  // (0, 1, 3, 7): face (0, 1, 3) lies on z = 0
  mesh.tets[0] = {t[0], t[1], m, t[3]};
  mesh.tets.push_back({t[1], t[2], m, t[3]});
  mesh.tets.push_back({t[2], t[0], m, t[3]});
  const auto surface = fixtures::unit_cube_surface();
  const auto r = validate_mesh(mesh, &surface);
  EXPECT_FALSE(r.ok()) << format_validation(r);
  EXPECT_TRUE(has_error(r, "surface")) << format_validation(r);
}

TEST(Validate, FindsFlippedSurfaceTriangle) {
  const auto mesh = fixtures::unit_cube_mesh();
  auto surface = fixtures::unit_cube_surface();
  std::swap(surface.triangles[4][1], surface.triangles[4][2]);
  const auto r = validate_mesh(mesh, &surface);
  EXPECT_TRUE(has_error(r, "surface")) << format_validation(r);
}

TEST(Validate, FindsWrongSurfaceId) {
  auto mesh = fixtures::unit_cube_mesh();
  mesh.boundary_ids[7] = 42;
  const auto surface = fixtures::unit_cube_surface();
  const auto r = validate_mesh(mesh, &surface);
  EXPECT_TRUE(has_error(r, "surface")) << format_validation(r);
}

TEST(Validate, FindsBoundaryListThatDisagreesWithTets) {
  auto mesh = fixtures::unit_cube_mesh();
  mesh.boundary.pop_back();
  mesh.boundary_ids.pop_back();
  const auto r = validate_mesh(mesh);
  EXPECT_TRUE(has_error(r, "boundary")) << format_validation(r);
}

TEST(Validate, FindsPinchedVertexAndEulerMismatch) {
  // Two tets touching at one vertex only: the boundary is pinched there.
  VolumeMesh m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}};
  m.tets = {{0, 1, 2, 3}, {0, 4, 6, 5}};
  const auto r = validate_mesh(m);
  EXPECT_TRUE(has_error(r, "boundary")) << format_validation(r);
  EXPECT_TRUE(has_error(r, "topology")) << format_validation(r);
}

TEST(Validate, StopsSafelyOnOutOfRangeIndex) {
  auto mesh = fixtures::unit_cube_mesh();
  mesh.tets[1][2] = 99;
  const auto r = validate_mesh(mesh);
  EXPECT_TRUE(has_error(r, "index")) << format_validation(r);
}

}  // namespace
}  // namespace pdrmesh
