// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the surface check: one fixture per defect class, the negatives,
// components and genus on the corpus, and a randomised comparison of the
// exact self-intersection test with an independent brute force.
#include "pdrmesh/surface_check.hpp"

#include "test_fixtures.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace pdrmesh {
namespace {

// ---------------------------------------------------------------------------
// Fixtures built in code.

// The faces of a box with corners c = x + 2y + 4z (x, y, z in {0, 1}), each a
// quad counterclockwise seen from outside, in the order -x, +x, -y, +y, -z, +z.
constexpr int kBoxQuads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                 {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};

// Appends the two triangles of quad v (diagonal v[0]-v[2]), optionally flipped.
void add_quad(SurfaceMesh& s, const Index (&v)[4], bool outward = true) {
  s.triangles.push_back(outward ? Tri{v[0], v[1], v[2]} : Tri{v[0], v[2], v[1]});
  s.triangles.push_back(outward ? Tri{v[0], v[2], v[3]} : Tri{v[0], v[3], v[2]});
}

// Appends the 12 triangles of the box [lo, hi], normals outward (or inward).
void add_box(SurfaceMesh& s, const Vec3& lo, const Vec3& hi, bool outward = true) {
  const Index base = static_cast<Index>(s.points.size());
  for (int c = 0; c < 8; ++c)
    s.points.push_back({c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]});
  for (const auto& q : kBoxQuads) {
    const Index v[4] = {base + Index(q[0]), base + Index(q[1]), base + Index(q[2]),
                        base + Index(q[3])};
    add_quad(s, v, outward);
  }
}

SurfaceMesh box(const Vec3& lo, const Vec3& hi, bool outward = true) {
  SurfaceMesh s;
  add_box(s, lo, hi, outward);
  return s;
}

SurfaceMesh tetrahedron() {
  SurfaceMesh s;
  s.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  s.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return s;
}

// The boundary of a union of unit voxels, points welded, normals outward.
SurfaceMesh voxels(const std::vector<std::array<int, 3>>& cells) {
  std::set<std::array<int, 3>> in(cells.begin(), cells.end());
  std::map<std::array<int, 3>, Index> ids;
  SurfaceMesh s;
  auto point = [&](std::array<int, 3> p) {
    auto [it, fresh] = ids.emplace(p, static_cast<Index>(s.points.size()));
    if (fresh) s.points.push_back({double(p[0]), double(p[1]), double(p[2])});
    return it->second;
  };
  const int normal[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
  for (const auto& c : cells) {
    for (int f = 0; f < 6; ++f) {
      if (in.count({c[0] + normal[f][0], c[1] + normal[f][1], c[2] + normal[f][2]})) continue;
      Index v[4];
      for (int k = 0; k < 4; ++k) {
        const int q = kBoxQuads[f][k];
        v[k] = point({c[0] + (q & 1), c[1] + (q >> 1 & 1), c[2] + (q >> 2 & 1)});
      }
      add_quad(s, v);
    }
  }
  return s;
}

// A surface of loose triangles, each given by its three corners (no welding).
SurfaceMesh soup(const std::vector<std::array<Vec3, 3>>& tris) {
  SurfaceMesh s;
  for (const auto& t : tris) {
    const Index b = static_cast<Index>(s.points.size());
    for (const Vec3& p : t) s.points.push_back(p);
    s.triangles.push_back({b, b + 1, b + 2});
  }
  return s;
}

std::size_t count(const SurfaceReport& r, DefectKind k) { return r.count(k); }

std::vector<const Defect*> defects_of(const SurfaceReport& r, DefectKind k) {
  std::vector<const Defect*> out;
  for (const Defect& d : r.defects)
    if (d.kind == k) out.push_back(&d);
  return out;
}

// Only the given kind occurs, `n` times.
void expect_only(const SurfaceReport& r, DefectKind k, std::size_t n) {
  EXPECT_EQ(r.count(k), n) << format_report(r, "fixture");
  EXPECT_EQ(r.total_defects(), n) << format_report(r, "fixture");
}

// ---------------------------------------------------------------------------
// Clean surfaces.

TEST(SurfaceCheck, TetrahedronIsMeshableGenusZero) {
  const SurfaceMesh s = tetrahedron();
  const SurfaceReport r = check_surface(s);
  EXPECT_TRUE(r.meshable()) << format_report(r, "tet");
  ASSERT_EQ(r.components.size(), 1u);
  const ComponentReport& c = r.components[0];
  EXPECT_TRUE(c.closed && c.manifold && c.consistently_oriented && c.outward);
  EXPECT_EQ(c.euler, 2);
  EXPECT_EQ(c.genus, 0);
  EXPECT_EQ(c.points, 4u);
  EXPECT_DOUBLE_EQ(c.volume, signed_volume(s.points[0], s.points[1], s.points[2], s.points[3]));
  EXPECT_TRUE(require_meshable(r, "tet").ok());
}

TEST(SurfaceCheck, CubeVolumeAndEuler) {
  const SurfaceReport r = check_surface(box({1, 2, 3}, {3, 5, 7}));
  EXPECT_TRUE(r.meshable()) << format_report(r, "cube");
  ASSERT_EQ(r.components.size(), 1u);
  EXPECT_DOUBLE_EQ(r.components[0].volume, 2.0 * 3.0 * 4.0);
  EXPECT_EQ(r.components[0].genus, 0);
  EXPECT_EQ(r.components[0].nesting_depth, 0);
}

TEST(SurfaceCheck, TwoCubesAreTwoComponentsAtDepthZero) {
  SurfaceMesh s = box({0, 0, 0}, {1, 1, 1});
  add_box(s, {2, 0, 0}, {3, 1, 1});
  const SurfaceReport r = check_surface(s);
  EXPECT_TRUE(r.meshable()) << format_report(r, "two cubes");
  ASSERT_EQ(r.components.size(), 2u);
  for (const auto& c : r.components) {
    EXPECT_EQ(c.triangles, 12u);
    EXPECT_EQ(c.nesting_depth, 0);
    EXPECT_TRUE(c.outward);
  }
  EXPECT_EQ(r.components[1].first_triangle, 12u);
}

TEST(SurfaceCheck, InwardCavityInsideCubeIsMeshable) {
  SurfaceMesh s = box({0, 0, 0}, {3, 3, 3});
  add_box(s, {1, 1, 1}, {2, 2, 2}, /*outward=*/false);
  const SurfaceReport r = check_surface(s);
  EXPECT_TRUE(r.meshable()) << format_report(r, "cavity");
  ASSERT_EQ(r.components.size(), 2u);
  EXPECT_EQ(r.components[0].nesting_depth, 0);
  EXPECT_EQ(r.components[1].nesting_depth, 1);
  EXPECT_DOUBLE_EQ(r.components[0].volume, 27.0);
  EXPECT_DOUBLE_EQ(r.components[1].volume, -1.0);
  EXPECT_TRUE(r.components[1].outward);
}

TEST(SurfaceCheck, OutwardShellInsideIsAnInterface) {
  SurfaceMesh s = box({0, 0, 0}, {3, 3, 3});
  add_box(s, {1, 1, 1}, {2, 2, 2}, /*outward=*/true);
  const SurfaceReport r = check_surface(s);
  EXPECT_TRUE(r.meshable()) << format_report(r, "two regions");
  ASSERT_EQ(r.components.size(), 2u);
  EXPECT_EQ(r.components[1].nesting_depth, 1);
  EXPECT_EQ(r.components[1].parent, 0u);
  EXPECT_TRUE(r.components[1].interface);
  EXPECT_TRUE(r.components[1].outward);
  EXPECT_FALSE(r.components[0].interface);
  EXPECT_EQ(r.components[0].parent, kNoIndex);
}

TEST(SurfaceCheck, InwardShellInsideACavityIsInward) {
  SurfaceMesh s = box({0, 0, 0}, {7, 7, 7});
  add_box(s, {1, 1, 1}, {6, 6, 6}, false);
  add_box(s, {2, 2, 2}, {5, 5, 5}, false);
  const SurfaceReport r = check_surface(s);
  expect_only(r, DefectKind::kInwardOrientation, 1);
  ASSERT_EQ(r.components.size(), 3u);
  EXPECT_EQ(r.components[2].parent, 1u);
  EXPECT_FALSE(r.components[2].outward);
  EXPECT_TRUE(r.components[1].outward);
  const auto d = defects_of(r, DefectKind::kInwardOrientation);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0]->triangles, std::vector<Index>{24});
  EXPECT_NE(d[0]->message.find("cavity of component 1"), std::string::npos) << d[0]->message;
}

TEST(SurfaceCheck, NestingThreeDeepAlternates) {
  SurfaceMesh s = box({0, 0, 0}, {7, 7, 7});
  add_box(s, {1, 1, 1}, {6, 6, 6}, false);
  add_box(s, {2, 2, 2}, {5, 5, 5}, true);
  add_box(s, {3, 3, 3}, {4, 4, 4}, false);
  const SurfaceReport r = check_surface(s);
  EXPECT_TRUE(r.meshable()) << format_report(r, "nested");
  ASSERT_EQ(r.components.size(), 4u);
  for (int c = 0; c < 4; ++c) EXPECT_EQ(r.components[c].nesting_depth, c);
  for (Index c = 1; c < 4; ++c) EXPECT_EQ(r.components[c].parent, c - 1);
  for (int c = 0; c < 4; ++c) EXPECT_FALSE(r.components[c].interface);
}

TEST(SurfaceCheck, TorusBlockHasGenusOne) {
  std::vector<std::array<int, 3>> cells;
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y)
      if (x != 1 || y != 1) cells.push_back({x, y, 0});
  const SurfaceReport r = check_surface(voxels(cells));
  EXPECT_TRUE(r.meshable()) << format_report(r, "torus block");
  ASSERT_EQ(r.components.size(), 1u);
  EXPECT_EQ(r.components[0].euler, 0);
  EXPECT_EQ(r.components[0].genus, 1);
  EXPECT_DOUBLE_EQ(r.components[0].volume, 8.0);
}

// ---------------------------------------------------------------------------
// One fixture per defect class.

TEST(SurfaceCheck, ReportsNonFiniteCoordinateWithoutCrashing) {
  SurfaceMesh s = box({0, 0, 0}, {1, 1, 1});
  s.points[5][1] = std::numeric_limits<double>::quiet_NaN();
  s.points[6][2] = std::numeric_limits<double>::infinity();
  const SurfaceReport r = check_surface(s);
  EXPECT_EQ(count(r, DefectKind::kNonFiniteCoordinate), 2u);
  const auto d = defects_of(r, DefectKind::kNonFiniteCoordinate);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0]->points, std::vector<Index>{5});
  EXPECT_EQ(d[1]->points, std::vector<Index>{6});
  EXPECT_GT(count(r, DefectKind::kOpenEdge), 0u);  // triangles at 5 and 6 are skipped
  EXPECT_FALSE(r.meshable());
  EXPECT_NE(report_to_json(r, "nan").find("non_finite_coordinate"), std::string::npos);
}

TEST(SurfaceCheck, ReportsIndexOutOfRange) {
  SurfaceMesh s = box({0, 0, 0}, {1, 1, 1});
  s.triangles.push_back({0, 1, 99});
  const SurfaceReport r = check_surface(s);
  expect_only(r, DefectKind::kIndexOutOfRange, 1);
  const auto d = defects_of(r, DefectKind::kIndexOutOfRange);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0]->triangles, std::vector<Index>{12});
  EXPECT_NE(d[0]->message.find("triangle 12"), std::string::npos);
}

TEST(SurfaceCheck, ReportsCollinearTriangle) {
  SurfaceMesh s = tetrahedron();
  s.points.push_back({5, 5, 5});
  s.points.push_back({6, 7, 8});
  s.points.push_back({7, 9, 11});  // on the line through the two before
  s.triangles.push_back({4, 5, 6});
  const SurfaceReport r = check_surface(s);
  EXPECT_EQ(count(r, DefectKind::kDegenerateTriangle), 1u);
  const auto d = defects_of(r, DefectKind::kDegenerateTriangle);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0]->triangles, std::vector<Index>{4});
  EXPECT_NE(d[0]->message.find("collinear"), std::string::npos);
  EXPECT_EQ(count(r, DefectKind::kSelfIntersection), 0u);
}

TEST(SurfaceCheck, ReportsRepeatedIndexAsDegenerate) {
  SurfaceMesh s = tetrahedron();
  s.triangles.push_back({1, 3, 1});
  const SurfaceReport r = check_surface(s);
  expect_only(r, DefectKind::kDegenerateTriangle, 1);
  EXPECT_EQ(defects_of(r, DefectKind::kDegenerateTriangle)[0]->triangles, std::vector<Index>{4});
}

TEST(SurfaceCheck, ReportsDuplicateTriangleInAnyOrder) {
  SurfaceMesh s = box({0, 0, 0}, {1, 1, 1});
  const Tri t = s.triangles[3];
  s.triangles.push_back({t[2], t[1], t[0]});
  const SurfaceReport r = check_surface(s);
  expect_only(r, DefectKind::kDuplicateTriangle, 1);
  EXPECT_EQ(defects_of(r, DefectKind::kDuplicateTriangle)[0]->triangles,
            (std::vector<Index>{3, 12}));
}

TEST(SurfaceCheck, ReportsOpenEdges) {
  SurfaceMesh s = box({0, 0, 0}, {1, 1, 1});
  s.triangles.erase(s.triangles.begin() + 7);
  const SurfaceReport r = check_surface(s);
  expect_only(r, DefectKind::kOpenEdge, 3);
  ASSERT_EQ(r.components.size(), 1u);
  EXPECT_FALSE(r.components[0].closed);
  EXPECT_EQ(r.components[0].genus, -1);
  for (const Defect* d : defects_of(r, DefectKind::kOpenEdge)) {
    EXPECT_EQ(d->triangles.size(), 1u);
    EXPECT_EQ(d->points.size(), 2u);
  }
}

TEST(SurfaceCheck, ReportsNonManifoldEdge) {
  // Two voxels sharing only an edge: four triangles at it.
  const SurfaceReport r = check_surface(voxels({{0, 0, 0}, {1, 1, 0}}));
  expect_only(r, DefectKind::kNonManifoldEdge, 1);
  const auto d = defects_of(r, DefectKind::kNonManifoldEdge);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0]->triangles.size(), 4u);
  EXPECT_EQ(d[0]->where, (Vec3{1, 1, 0.5}));
  ASSERT_EQ(r.components.size(), 1u);
  EXPECT_FALSE(r.components[0].manifold);
}

TEST(SurfaceCheck, ReportsPinchedVertex) {
  // Two voxels sharing only a corner: two fans there, two components.
  const SurfaceReport r = check_surface(voxels({{0, 0, 0}, {1, 1, 1}}));
  expect_only(r, DefectKind::kNonManifoldVertex, 1);
  const auto d = defects_of(r, DefectKind::kNonManifoldVertex);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0]->where, (Vec3{1, 1, 1}));
  EXPECT_EQ(d[0]->triangles.size(), 12u);  // both diagonals of three faces of each voxel
  EXPECT_EQ(r.components.size(), 2u);
  for (const auto& c : r.components) EXPECT_TRUE(c.manifold);  // each alone is fine
}

TEST(SurfaceCheck, PinchedVertexInsideOneComponentMakesItNonManifold) {
  // Voxels (0,0,0) and (1,1,1) share only a corner, and a path of voxels joins
  // them the long way round: one component, pinched at (1, 1, 1).
  const std::vector<std::array<int, 3>> cells = {{1, 1, 1},  {1, 2, 1},  {1, 3, 1},  {0, 3, 1},
                                                 {-1, 3, 1}, {-2, 3, 1}, {-2, 2, 1}, {-2, 1, 1},
                                                 {-2, 0, 1}, {-2, 0, 0}, {-1, 0, 0}, {0, 0, 0}};
  const SurfaceReport r = check_surface(voxels(cells));
  expect_only(r, DefectKind::kNonManifoldVertex, 1);
  EXPECT_EQ(defects_of(r, DefectKind::kNonManifoldVertex).at(0)->where, (Vec3{1, 1, 1}));
  ASSERT_EQ(r.components.size(), 1u);
  EXPECT_FALSE(r.components[0].manifold);
  EXPECT_EQ(r.components[0].genus, -1);
}

TEST(SurfaceCheck, ReportsFlippedTriangle) {
  SurfaceMesh s = box({0, 0, 0}, {1, 1, 1});
  std::swap(s.triangles[4][0], s.triangles[4][1]);
  const SurfaceReport r = check_surface(s);
  expect_only(r, DefectKind::kInconsistentOrientation, 3);
  for (const Defect* d : defects_of(r, DefectKind::kInconsistentOrientation)) {
    ASSERT_EQ(d->triangles.size(), 2u);
    EXPECT_TRUE(d->triangles[0] == 4 || d->triangles[1] == 4);
  }
  EXPECT_FALSE(r.components[0].consistently_oriented);
  EXPECT_EQ(r.components[0].genus, -1);
}

TEST(SurfaceCheck, ReportsInwardSurface) {
  const SurfaceReport r = check_surface(box({0, 0, 0}, {1, 1, 1}, /*outward=*/false));
  expect_only(r, DefectKind::kInwardOrientation, 1);
  EXPECT_LT(r.components[0].volume, 0);
  EXPECT_FALSE(r.components[0].outward);
  const Status st = require_meshable(r, "inside-out.stl");
  EXPECT_FALSE(st.ok());
  EXPECT_EQ(st.code(), StatusCode::kInvalidInput);
  EXPECT_NE(st.message().find("inside-out.stl"), std::string::npos);
  EXPECT_NE(st.message().find("inward orientation"), std::string::npos);
}

// ---------------------------------------------------------------------------
// Self-intersections.

std::set<std::pair<Index, Index>> intersecting_pairs(const SurfaceReport& r) {
  std::set<std::pair<Index, Index>> out;
  for (const Defect* d : defects_of(r, DefectKind::kSelfIntersection))
    out.emplace(d->triangles.at(0), d->triangles.at(1));
  return out;
}

TEST(SelfIntersection, CrossingCubes) {
  SurfaceMesh s = box({0, 0, 0}, {2, 2, 2});
  add_box(s, {1, 1, 1}, {3, 3, 3});
  CheckOptions o;
  o.max_defects_per_kind = 1000;
  const SurfaceReport r = check_surface(s, o);
  EXPECT_GT(count(r, DefectKind::kSelfIntersection), 0u);
  EXPECT_EQ(intersecting_pairs(r).size(), count(r, DefectKind::kSelfIntersection));
  for (const auto& [a, b] : intersecting_pairs(r)) {
    EXPECT_LT(a, 12u);  // always one triangle of each cube
    EXPECT_GE(b, 12u);
  }
  // Each cube has three faces crossing the other: at least 3 x 3 face pairs meet.
  EXPECT_GE(count(r, DefectKind::kSelfIntersection), 9u);
  // Sorted by pair.
  const auto d = defects_of(r, DefectKind::kSelfIntersection);
  for (std::size_t i = 1; i < d.size(); ++i) EXPECT_LT(d[i - 1]->triangles, d[i]->triangles);
  // The test can be switched off.
  o.self_intersections = false;
  EXPECT_EQ(count(check_surface(s, o), DefectKind::kSelfIntersection), 0u);
}

TEST(SelfIntersection, VertexTouchingFace) {
  // Apex (1.5, 0.5, 2) lies inside top triangle 10 = (4, 5, 7) of the cube [0,2]^3.
  SurfaceMesh s = box({0, 0, 0}, {2, 2, 2});
  const Index b = static_cast<Index>(s.points.size());
  s.points.push_back({1.5, 0.5, 2});
  s.points.push_back({1, 0, 3});
  s.points.push_back({2, 1, 3});
  s.points.push_back({1, 1, 3});
  for (Tri t : tetrahedron().triangles) s.triangles.push_back({b + t[0], b + t[1], b + t[2]});
  const SurfaceReport r = check_surface(s);
  ASSERT_EQ(s.triangles[10], (Tri{4, 5, 7}));
  EXPECT_EQ(count(r, DefectKind::kSelfIntersection), 3u) << format_report(r, "touch");
  for (const auto& [x, y] : intersecting_pairs(r)) EXPECT_EQ(x, 10u);
  const auto d = defects_of(r, DefectKind::kSelfIntersection);
  ASSERT_FALSE(d.empty());
  EXPECT_EQ(d[0]->where, (Vec3{1.5, 0.5, 2}));

  // One ulp higher it does not touch.
  s.points[b][2] = std::nextafter(2.0, 3.0);
  EXPECT_TRUE(check_surface(s).meshable()) << format_report(check_surface(s), "near miss");
}

TEST(SelfIntersection, CoplanarOverlapSharingAnEdge) {
  SurfaceMesh s;
  s.points = {{0, 0, 0}, {2, 0, 0}, {1, 2, 0}, {1, 1, 0}};
  s.triangles = {{0, 1, 2}, {1, 0, 3}};  // 3 lies inside, same side of edge 0-1
  EXPECT_EQ(count(check_surface(s), DefectKind::kSelfIntersection), 1u);
  s.points[3] = {1, -1, 0};  // other side: flat neighbours
  EXPECT_EQ(count(check_surface(s), DefectKind::kSelfIntersection), 0u);
  s.points[3] = {1, 1, 1};  // folded
  EXPECT_EQ(count(check_surface(s), DefectKind::kSelfIntersection), 0u);
}

TEST(SelfIntersection, CoplanarOverlapSharingAVertex) {
  SurfaceMesh s;
  s.points = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {2, 1, 0}, {3, 3, 0}};
  s.triangles = {{0, 1, 2}, {0, 3, 4}};  // sectors overlap at 0
  EXPECT_EQ(count(check_surface(s), DefectKind::kSelfIntersection), 1u);
  s.points[3] = {2, 0, 0};  // touching along the ray 0 -> (1, 0, 0), another index
  s.points[4] = {0, -2, 0};
  EXPECT_EQ(count(check_surface(s), DefectKind::kSelfIntersection), 1u);
  s.points[3] = {-1, -1, 0};  // sectors apart
  s.points[4] = {0, -2, 0};
  EXPECT_EQ(count(check_surface(s), DefectKind::kSelfIntersection), 0u);
}

TEST(SelfIntersection, NonCoplanarSharingAVertex) {
  SurfaceMesh s;
  s.points = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {1, 1, -1}, {1, 1, 1}};
  s.triangles = {{0, 1, 2}, {0, 3, 4}};  // the second pierces the first
  EXPECT_EQ(count(check_surface(s), DefectKind::kSelfIntersection), 1u);
  s.points[3] = {-1, -1, -1};  // the second only meets the first at 0
  s.points[4] = {-1, -1, 1};
  EXPECT_EQ(count(check_surface(s), DefectKind::kSelfIntersection), 0u);
}

TEST(SelfIntersection, EdgeTouchingEdge) {
  // The edge y = 1, z = 0 of the first and the edge x = 1, y = 1 of the second
  // cross at (1, 1, 0).
  const double y = 1.0;
  SurfaceMesh s = soup({{Vec3{0, 1, 0}, Vec3{2, 1, 0}, Vec3{0, 3, 0}},
                        {Vec3{1, y, -1}, Vec3{1, y, 1}, Vec3{1, 0, 0}}});
  SurfaceReport r = check_surface(s);
  EXPECT_EQ(count(r, DefectKind::kSelfIntersection), 1u);
  EXPECT_EQ(defects_of(r, DefectKind::kSelfIntersection)[0]->where, (Vec3{1, 1, 0}));
  // One ulp away from the first triangle: apart.
  s.points[3][1] = s.points[4][1] = std::nextafter(1.0, 0.0);
  EXPECT_EQ(count(check_surface(s), DefectKind::kSelfIntersection), 0u);
  // One ulp towards it: the edge pierces the first triangle.
  s.points[3][1] = s.points[4][1] = std::nextafter(1.0, 2.0);
  EXPECT_EQ(count(check_surface(s), DefectKind::kSelfIntersection), 1u);
}

TEST(SelfIntersection, AdjacentTrianglesAreNotIntersections) {
  for (const SurfaceMesh& s : {tetrahedron(), box({0, 0, 0}, {1, 1, 1}),
                               voxels({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {2, 1, 0}, {2, 1, 1}})}) {
    const SurfaceReport r = check_surface(s);
    EXPECT_EQ(count(r, DefectKind::kSelfIntersection), 0u) << format_report(r, "adjacent");
    EXPECT_TRUE(r.meshable());
  }
}

// ---------------------------------------------------------------------------
// Randomised: the exact test against an independent brute force.

__extension__ typedef __int128 Int;

Int gcd(Int a, Int b) {
  if (a < 0) a = -a;
  if (b < 0) b = -b;
  while (b != 0) {
    const Int t = a % b;
    a = b;
    b = t;
  }
  return a;
}

// A reduced rational with a positive denominator.
struct Rat {
  Int n = 0, d = 1;
  Rat() = default;
  Rat(Int num, Int den = 1) : n(num), d(den) {  // NOLINT: implicit from integers
    if (d < 0) n = -n, d = -d;
    const Int g = gcd(n, d);
    if (g > 1) n /= g, d /= g;
  }
  friend Rat operator+(Rat a, Rat b) { return {a.n * b.d + b.n * a.d, a.d * b.d}; }
  friend Rat operator-(Rat a, Rat b) { return {a.n * b.d - b.n * a.d, a.d * b.d}; }
  friend Rat operator*(Rat a, Rat b) { return {a.n * b.n, a.d * b.d}; }
  friend Rat operator/(Rat a, Rat b) { return {a.n * b.d, a.d * b.n}; }
  friend bool operator==(Rat a, Rat b) { return a.n == b.n && a.d == b.d; }
  int sign() const { return (n > 0) - (n < 0); }
};
using RPoint = std::array<Rat, 3>;

RPoint sub(const RPoint& a, const RPoint& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Rat rdot(const RPoint& a, const RPoint& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
RPoint rcross(const RPoint& a, const RPoint& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
RPoint rat(const Vec3& p) {
  return {Rat(static_cast<Int>(p[0])), Rat(static_cast<Int>(p[1])), Rat(static_cast<Int>(p[2]))};
}

// Clips a convex polygon (a boundary walk; a point or a segment allowed) to
// {x : dot(m, x - o) >= 0}, exactly (Sutherland-Hodgman).
std::vector<RPoint> clip(const std::vector<RPoint>& poly, const RPoint& m, const RPoint& o) {
  std::vector<RPoint> out;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const RPoint& a = poly[i];
    const RPoint& b = poly[(i + 1) % poly.size()];
    const Rat fa = rdot(m, sub(a, o)), fb = rdot(m, sub(b, o));
    if (fa.sign() >= 0) out.push_back(a);
    if (fa.sign() * fb.sign() < 0) {
      const Rat t = fa / (fa - fb);
      const RPoint d = sub(b, a);
      out.push_back({a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]});
    }
  }
  std::vector<RPoint> unique;
  for (const RPoint& p : out)
    if (std::find(unique.begin(), unique.end(), p) == unique.end()) unique.push_back(p);
  return unique;
}

// Brute force: build the intersection of the two closed triangles as a convex
// polygon, exactly, and ask whether one of its corners lies outside what the
// triangles share by index (nothing, a vertex, or an edge).
bool brute_force_improper(const SurfaceMesh& s, const Tri& ta, const Tri& tb) {
  std::vector<RPoint> poly;
  for (Index v : ta) poly.push_back(rat(s.points[v]));
  const RPoint b0 = rat(s.points[tb[0]]), b1 = rat(s.points[tb[1]]), b2 = rat(s.points[tb[2]]);
  const RPoint n = rcross(sub(b1, b0), sub(b2, b0));
  poly = clip(poly, n, b0);
  poly = clip(poly, {Rat(0) - n[0], Rat(0) - n[1], Rat(0) - n[2]}, b0);
  const RPoint bs[3] = {b0, b1, b2};
  for (int i = 0; i < 3 && !poly.empty(); ++i)
    poly = clip(poly, rcross(n, sub(bs[(i + 1) % 3], bs[i])), bs[i]);
  std::vector<RPoint> shared;
  for (Index v : ta)
    if (v == tb[0] || v == tb[1] || v == tb[2]) shared.push_back(rat(s.points[v]));
  for (const RPoint& x : poly) {
    if (shared.empty()) return true;
    if (shared.size() == 1 && !(x == shared[0])) return true;
    if (shared.size() == 2) {
      const RPoint e = sub(shared[1], shared[0]), d = sub(x, shared[0]);
      const RPoint c = rcross(e, d);
      const Rat t = rdot(d, e);
      const bool on = c[0].sign() == 0 && c[1].sign() == 0 && c[2].sign() == 0 && t.sign() >= 0 &&
                      (rdot(e, e) - t).sign() >= 0;
      if (!on) return true;
    }
  }
  return false;
}

bool collinear_int(const std::array<Vec3, 3>& t) {
  const RPoint c = rcross(sub(rat(t[1]), rat(t[0])), sub(rat(t[2]), rat(t[0])));
  return c[0].sign() == 0 && c[1].sign() == 0 && c[2].sign() == 0;
}

TEST(SelfIntersection, RandomPairsAgreeWithBruteForceAndAreSymmetric) {
  unsigned seed = 20240611;
  if (const char* env = std::getenv("PDRMESH_TEST_SEED"))
    seed = static_cast<unsigned>(std::stoul(env));
  std::printf("SelfIntersection random seed: %u (set PDRMESH_TEST_SEED to change)\n", seed);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> coord(0, 2), coin(0, 1), pick(0, 2), perm(0, 5);

  constexpr int kPairs = 3000;
  constexpr double kSpacing = 10.0;  // pairs far apart: only the two of a pair can meet
  // Triangles as corners; variant 0: (a, b), 1: (b, a) with permuted corners.
  std::vector<std::array<Vec3, 3>> ta, tb;
  std::vector<bool> weld;
  while (ta.size() < kPairs) {
    std::array<Vec3, 3> a, b;
    for (auto& p : a) p = {double(coord(rng)), double(coord(rng)), double(coord(rng))};
    for (auto& p : b)
      p = coin(rng) ? a[pick(rng)]
                    : Vec3{double(coord(rng)), double(coord(rng)), double(coord(rng))};
    if (collinear_int(a) || collinear_int(b)) continue;
    std::set<Vec3> sa(a.begin(), a.end()), sb(b.begin(), b.end());
    if (sa == sb) continue;  // a duplicate, not an intersection
    ta.push_back(a);
    tb.push_back(b);
    weld.push_back(coin(rng) || coin(rng));
  }

  auto permute = [](std::array<Vec3, 3> t, int p) {
    if (p & 1) std::swap(t[1], t[2]);
    std::rotate(t.begin(), t.begin() + p / 2, t.end());
    return t;
  };
  std::vector<int> perms(2 * kPairs);
  for (int& p : perms) p = perm(rng);

  std::size_t positives = 0, shared_any = 0;
  std::vector<bool> first;
  for (int variant = 0; variant < 2; ++variant) {
    SurfaceMesh s;
    std::vector<std::pair<Index, Index>> pair_tris;
    for (int i = 0; i < kPairs; ++i) {
      const Vec3 off{kSpacing * (i % 60), kSpacing * (i / 60), 0};
      std::array<Vec3, 3> x = ta[i], y = tb[i];
      if (variant == 1) {
        std::swap(x, y);
        x = permute(x, perms[2 * i]);
        y = permute(y, perms[2 * i + 1]);
      }
      std::map<Vec3, Index> ids;
      auto add = [&](const Vec3& p) {
        if (weld[i]) {
          auto it = ids.find(p);
          if (it != ids.end()) return it->second;
        }
        const Index id = static_cast<Index>(s.points.size());
        s.points.push_back(p + off);
        ids[p] = id;
        return id;
      };
      Tri t1, t2;
      for (int k = 0; k < 3; ++k) t1[k] = add(x[k]);
      for (int k = 0; k < 3; ++k) t2[k] = add(y[k]);
      pair_tris.emplace_back(static_cast<Index>(s.triangles.size()),
                             static_cast<Index>(s.triangles.size() + 1));
      s.triangles.push_back(t1);
      s.triangles.push_back(t2);
    }
    CheckOptions o;
    o.max_defects_per_kind = 4 * kPairs;
    const SurfaceReport r = check_surface(s, o);
    const auto found = intersecting_pairs(r);
    ASSERT_EQ(found.size(), count(r, DefectKind::kSelfIntersection));
    for (const auto& [a, b] : found) ASSERT_EQ(b, a + 1) << "pairs far apart cannot meet";
    for (int i = 0; i < kPairs; ++i) {
      const auto [a, b] = pair_tris[i];
      const bool fast = found.count({a, b}) > 0;
      const bool brute = brute_force_improper(s, s.triangles[a], s.triangles[b]);
      const bool brute_swapped = brute_force_improper(s, s.triangles[b], s.triangles[a]);
      ASSERT_EQ(brute, brute_swapped) << "brute force asymmetric, pair " << i;
      ASSERT_EQ(fast, brute) << "pair " << i << " variant " << variant << " seed " << seed;
      if (variant == 0) {
        first.push_back(fast);
        positives += fast;
        const Tri& x = s.triangles[a];
        const Tri& y = s.triangles[b];
        for (Index v : x) shared_any += (v == y[0] || v == y[1] || v == y[2]);
      } else {
        ASSERT_EQ(fast, first[i]) << "asymmetric: pair " << i << " seed " << seed;
      }
    }
  }
  // The sample covers both answers and shared vertices.
  std::printf("%zu of %d pairs intersect; %zu shared vertices\n", positives, kPairs, shared_any);
  EXPECT_GT(positives, kPairs / 10u);
  EXPECT_LT(positives, kPairs * 9u / 10u);
  EXPECT_GT(shared_any, std::size_t{kPairs / 2});
}

// ---------------------------------------------------------------------------
// Reports.

TEST(SurfaceCheck, CapsDefectsPerKindButCountsAll) {
  SurfaceMesh s;
  for (int i = 0; i < 30; ++i) add_box(s, {3.0 * i, 0, 0}, {3.0 * i + 1, 1, 1}, false);
  CheckOptions o;
  o.max_defects_per_kind = 5;
  const SurfaceReport r = check_surface(s, o);
  EXPECT_EQ(count(r, DefectKind::kInwardOrientation), 30u);
  EXPECT_EQ(defects_of(r, DefectKind::kInwardOrientation).size(), 5u);
  const std::string text = format_report(r, "boxes");
  EXPECT_NE(text.find("30 inward orientation"), std::string::npos) << text;
  EXPECT_NE(text.find("and 25 more"), std::string::npos) << text;
}

TEST(SurfaceCheck, JsonAndTextNameDefects) {
  SurfaceMesh s = box({0, 0, 0}, {1, 1, 1});
  s.triangles.pop_back();
  const SurfaceReport r = check_surface(s);
  const auto j = nlohmann::json::parse(report_to_json(r, "open.mesh"));
  EXPECT_EQ(j["name"], "open.mesh");
  EXPECT_EQ(j["meshable"], false);
  EXPECT_EQ(j["defect_counts"]["open_edge"], 3);
  ASSERT_EQ(j["defects"].size(), 3u);
  EXPECT_EQ(j["defects"][0]["kind"], "open_edge");
  EXPECT_EQ(j["defects"][0]["triangles"].size(), 1u);
  EXPECT_EQ(j["components"][0]["closed"], false);
  const std::string text = format_report(r, "open.mesh");
  EXPECT_NE(text.find("NOT meshable"), std::string::npos);
  EXPECT_NE(text.find("NOT meshable: 1 hole (3 open edges)"), std::string::npos) << text;
  EXPECT_NE(text.find("hole 1 (3 open edges): edge"), std::string::npos) << text;
  EXPECT_EQ(j["hole_count"], 1);
  EXPECT_EQ(j["holes"][0]["open_edges"], 3);
  const Status st = require_meshable(r, "open.mesh");
  EXPECT_NE(st.message().find("1 hole (3 open edges)"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("triangle"), std::string::npos) << st.message();
}

TEST(SurfaceCheck, OpenEdgesAreGroupedIntoHoles) {
  // Three boxes apart, each with one triangle missing: three holes of three open edges.
  SurfaceMesh s;
  for (int k = 0; k < 3; ++k) {
    add_box(s, {3.0 * k, 0, 0}, {3.0 * k + 1, 1, 1});
    s.triangles.pop_back();
  }
  const SurfaceReport r = check_surface(s);
  EXPECT_EQ(r.count(DefectKind::kOpenEdge), 9u);
  EXPECT_EQ(r.hole_count, 3u);
  ASSERT_EQ(r.holes.size(), 3u);
  for (const HoleReport& h : r.holes) EXPECT_EQ(h.open_edges, 3u);
  const std::string text = format_report(r, "three.off");
  EXPECT_NE(text.find("NOT meshable: 3 holes (9 open edges)"), std::string::npos) << text;
  EXPECT_NE(text.find("hole 3 (3 open edges): edge"), std::string::npos) << text;
}

TEST(SurfaceCheck, EmptySurfaceDoesNotCrash) {
  const SurfaceReport r = check_surface(SurfaceMesh{});
  EXPECT_TRUE(r.components.empty());
  EXPECT_TRUE(r.meshable());
}

void expect_genus(const std::string& name, std::vector<int> genus) {
  const SurfaceMesh s = fixtures::corpus_surface(name);
  ASSERT_FALSE(s.triangles.empty()) << name;
  const SurfaceReport r = check_surface(s);
  EXPECT_TRUE(r.meshable()) << format_report(r, name);
  std::vector<int> got;
  Index triangles = 0;
  for (const auto& c : r.components) {
    got.push_back(c.genus);
    triangles += c.triangles;
    EXPECT_TRUE(c.outward);
    EXPECT_EQ(c.nesting_depth, 0);
  }
  EXPECT_EQ(triangles, s.triangles.size());
  std::sort(got.begin(), got.end());
  std::sort(genus.begin(), genus.end());
  EXPECT_EQ(got, genus) << format_report(r, name);
}

TEST(SurfaceCheckCorpus, Sphere966GenusZero) { expect_genus("sphere966", {0}); }
TEST(SurfaceCheckCorpus, ElephantGenusThree) { expect_genus("elephant", {3}); }
TEST(SurfaceCheckCorpus, CouplingdownGenusNine) { expect_genus("couplingdown", {9}); }
TEST(SurfaceCheckCorpus, Knot2TwoTori) { expect_genus("knot2", {1, 1}); }
TEST(SurfaceCheckCorpus, Primitives13ThirteenBodies) {
  std::vector<int> genus(12, 0);
  genus.push_back(1);
  expect_genus("primitives13", genus);
}

TEST(SurfaceCheckCorpus, ElephantWithOneFlippedTriangleIsRejected) {
  SurfaceMesh s = fixtures::corpus_surface("elephant");
  ASSERT_FALSE(s.triangles.empty());
  std::swap(s.triangles[100][1], s.triangles[100][2]);
  const SurfaceReport r = check_surface(s);
  EXPECT_EQ(count(r, DefectKind::kInconsistentOrientation), 3u);
  EXPECT_FALSE(require_meshable(r, "elephant").ok());
}

}  // namespace
}  // namespace pdrmesh
