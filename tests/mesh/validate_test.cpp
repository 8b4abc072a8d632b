// SPDX-License-Identifier: AGPL-3.0-or-later
#include "pdrmesh/validate.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <limits>
#include <string>
#include <vector>
#include <utility>

#include <oneapi/tbb/task_arena.h>

#include "pdrmesh/predicates.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "octree_fixtures.hpp"
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

TEST(Validate, FindsTwoTetsOnTheSameSideOfAFace) {
  // Two positive tets on face (0, 1, 2) with their apexes on the same side:
  // the face is shared by two tets, as in a conforming mesh, but with the
  // same orientation, so the tets overlap.
  VolumeMesh mesh;
  mesh.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.2, 0.2, 2}};
  mesh.tets = {{0, 1, 2, 3}, {1, 2, 0, 4}};
  for (const Tet& t : mesh.tets)
    ASSERT_GT(exact::orient3d(mesh.points[t[0]], mesh.points[t[1]], mesh.points[t[2]], mesh.points[t[3]]), 0);
  const auto r = validate_mesh(mesh);
  EXPECT_TRUE(has_error(r, "conformity")) << format_validation(r);
  EXPECT_NE(format_validation(r).find("overlap across face (0, 1, 2)"), std::string::npos) << format_validation(r);
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

/// validate_mesh inside an arena of `threads` threads.
ValidationReport validate_in_arena(int threads, const VolumeMesh& mesh, const SurfaceMesh* surface,
                                   const ValidationOptions& options = {}) {
  tbb::task_arena arena(threads);
  return arena.execute([&] { return validate_mesh(mesh, surface, options); });
}

/// Every field equal, the volume to the bit, and the same text.
void expect_same_report(const ValidationReport& a, const ValidationReport& b) {
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.points, b.points);
  EXPECT_EQ(a.boundary_faces, b.boundary_faces);
  EXPECT_EQ(a.volume, b.volume);
  EXPECT_EQ(a.enclosed_volume, b.enclosed_volume);
  EXPECT_EQ(a.euler_volume, b.euler_volume);
  EXPECT_EQ(a.euler_boundary, b.euler_boundary);
  EXPECT_EQ(a.error_count, b.error_count);
  EXPECT_EQ(a.errors, b.errors);
  EXPECT_EQ(format_validation(a), format_validation(b));
}

/// hinge's TetGen mesh with a seed lattice: about 60,000 tets, many chunks of
/// every parallel pass.
VolumeMesh hinge_mesh(const SurfaceMesh& surface) {
  TetgenOptions o;
  o.max_volume = enclosed_volume(surface) / 30000;
  o.seeds_only = true;
  auto m = tetrahedralize(surface, o);
  EXPECT_TRUE(m.ok()) << m.status().to_string();
  return m.ok() ? std::move(m).value() : VolumeMesh{};
}

TEST(Validate, SameReportOnOneAndFourThreads) {
  const SurfaceMesh surface = fixtures::corpus_surface("hinge");
  const VolumeMesh mesh = hinge_mesh(surface);
  ASSERT_GT(mesh.tets.size(), 40000u);
  const ValidationReport one = validate_in_arena(1, mesh, &surface);
  EXPECT_TRUE(one.ok()) << format_validation(one);
  expect_same_report(one, validate_in_arena(4, mesh, &surface));
  // A structured grid with more points than the point passes' chunks hold.
  const VolumeMesh grid = fixtures::kuhn_grid(28);
  const ValidationReport g1 = validate_in_arena(1, grid, nullptr);
  EXPECT_TRUE(g1.ok()) << format_validation(g1);
  EXPECT_EQ(g1.tets, 6u * 28 * 28 * 28);
  expect_same_report(g1, validate_in_arena(4, grid, nullptr));
}

TEST(Validate, SameErrorsInTheSameOrderOnOneAndFourThreads) {
  SurfaceMesh surface = fixtures::corpus_surface("hinge");
  VolumeMesh mesh = hinge_mesh(surface);
  const std::size_t nt = mesh.tets.size();
  ASSERT_GT(nt, 40000u);
  // Inverted tets spread over the whole tet range (orientation, conformity,
  // volume), tets removed (holes: boundary, surface, Euler), a duplicate and an
  // unused point, a wrong surface id and a flipped input triangle.
  for (std::size_t t = 3; t < nt; t += nt / 23) std::swap(mesh.tets[t][0], mesh.tets[t][1]);
  for (std::size_t k = 0; k < 6; ++k) mesh.tets.erase(mesh.tets.begin() + static_cast<std::ptrdiff_t>(nt - 5 - k * (nt / 7)));
  mesh.points.push_back(mesh.points[mesh.tets[nt / 2][0]]);
  mesh.points.push_back({1e6, 1e6, 1e6});
  ASSERT_EQ(mesh.boundary_ids.size(), mesh.boundary.size());
  ASSERT_EQ(surface.surface_ids.size(), surface.triangles.size());
  mesh.boundary_ids[mesh.boundary.size() / 2] += 1;
  std::swap(surface.triangles.back()[0], surface.triangles.back()[1]);
  for (const std::size_t cap : {std::size_t{10}, std::size_t{100000}}) {
    ValidationOptions options;
    options.max_messages_per_check = cap;
    const ValidationReport one = validate_in_arena(1, mesh, &surface, options);
    for (const char* check : {"orientation", "conformity", "points", "boundary", "surface", "volume"}) {
      EXPECT_TRUE(has_error(one, check)) << check << "\n" << format_validation(one);
    }
    EXPECT_GT(one.error_count, 50u);
    if (cap > one.error_count) {  // every inverted tet listed, in tet order (the serial order)
      std::vector<std::size_t> inverted;
      for (const std::string& e : one.errors) {
        if (e.rfind("orientation: tet ", 0) == 0) inverted.push_back(std::stoul(e.substr(17)));
      }
      std::size_t expected = 0;
      for (const Tet& k : mesh.tets) {
        expected += exact::orient3d(mesh.points[k[0]], mesh.points[k[1]], mesh.points[k[2]], mesh.points[k[3]]) <= 0;
      }
      EXPECT_GT(expected, 20u);
      EXPECT_EQ(inverted.size(), expected);
      EXPECT_TRUE(std::is_sorted(inverted.begin(), inverted.end()));
    }
    expect_same_report(one, validate_in_arena(4, mesh, &surface, options));
    // The face check in slices of points (as for a large mesh) finds the same.
    for (const std::size_t slices : {std::size_t{2}, std::size_t{5}}) {
      options.face_slices = slices;
      expect_same_report(one, validate_in_arena(4, mesh, &surface, options));
    }
  }
  // Index errors over many chunks stop the validator early, the same way.
  VolumeMesh bad = fixtures::kuhn_grid(20);
  for (std::size_t t = 7; t < bad.tets.size(); t += 3001) bad.tets[t][t % 4] = static_cast<Index>(bad.points.size() + t);
  bad.points[5][1] = std::numeric_limits<double>::quiet_NaN();
  const ValidationReport b1 = validate_in_arena(1, bad, nullptr);
  EXPECT_TRUE(has_error(b1, "index") && has_error(b1, "coordinates")) << format_validation(b1);
  expect_same_report(b1, validate_in_arena(4, bad, nullptr));
}

}  // namespace
}  // namespace pdrmesh
