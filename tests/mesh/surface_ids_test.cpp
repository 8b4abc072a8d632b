// SPDX-License-Identifier: AGPL-3.0-or-later
// Surface ids: the map between the user's ids and the engines' (>= 1; 0 marks
// a leaf interface), and surfaces whose ids are all 0 through the serial and
// the parallel pipeline: valid, the user's ids back, and meshed exactly as the
// same surface with ids 1 (so the surface-only optimizer steps ran on them;
// without the map they did not, and these meshes differed).
#include "pdrmesh/surface_ids.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/validate.hpp"
#include "test_fixtures.hpp"

namespace pdrmesh {
namespace {

TEST(SurfaceIds, EngineIdsAreOrderedRanksFromOne) {
  const std::vector<int> user{0, -3, 7, 0, std::numeric_limits<int>::min(), std::numeric_limits<int>::max(), 7, 1};
  std::vector<int> ids = user;
  Result<SurfaceIdMap> map = SurfaceIdMap::to_engine(ids);
  ASSERT_TRUE(map.ok()) << map.status().to_string();
  EXPECT_FALSE(map->identity());
  ASSERT_EQ(ids.size(), user.size());
  int top = 0;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    EXPECT_GE(ids[i], 1) << i;
    top = std::max(top, ids[i]);
    for (std::size_t j = 0; j < ids.size(); ++j) {
      EXPECT_EQ(ids[i] < ids[j], user[i] < user[j]) << i << " " << j;
      EXPECT_EQ(ids[i] == ids[j], user[i] == user[j]) << i << " " << j;
    }
  }
  EXPECT_EQ(top, 6);  // six distinct ids
  map->to_user(ids);
  EXPECT_EQ(ids, user);
}

TEST(SurfaceIds, PositiveIdsAreLeftAsTheyAre) {
  std::vector<int> ids{3, 1, 9, 3};
  Result<SurfaceIdMap> map = SurfaceIdMap::to_engine(ids);
  ASSERT_TRUE(map.ok());
  EXPECT_TRUE(map->identity());
  EXPECT_EQ(ids, (std::vector<int>{3, 1, 9, 3}));
  std::vector<int> out{9, 0, 12};
  map->to_user(out);
  EXPECT_EQ(out, (std::vector<int>{9, 0, 12}));
  std::vector<int> none;
  ASSERT_TRUE(SurfaceIdMap::to_engine(none).ok());
}

/// Corpus surface `name` with every surface id set to `id`.
SurfaceMesh with_ids(const char* name, int id) {
  SurfaceMesh s = fixtures::corpus_surface(name);
  s.surface_ids.assign(s.triangles.size(), id);
  return s;
}

void expect_user_ids(const VolumeMesh& m, const SurfaceMesh& s, int id) {
  const ValidationReport rep = validate_mesh(m, &s);  // checks the ids against the surface's too
  EXPECT_TRUE(rep.ok()) << format_validation(rep);
  EXPECT_EQ(m.boundary.size(), s.triangles.size());
  ASSERT_EQ(m.boundary_ids.size(), m.boundary.size());
  for (int b : m.boundary_ids) ASSERT_EQ(b, id);
}

void expect_same_mesh(const VolumeMesh& a, const VolumeMesh& b) {
  ASSERT_EQ(a.points.size(), b.points.size());
  EXPECT_EQ(std::memcmp(a.points.data(), b.points.data(), a.points.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.boundary, b.boundary);
}

TEST(SurfaceIds, ZeroIdsMeshSeriallyAsIdsOne) {
  const SurfaceMesh zero = with_ids("sphere966", 0), one = with_ids("sphere966", 1);
  ASSERT_FALSE(zero.triangles.empty());
  const SerialOptions o;
  Result<SerialResult> a = mesh_serial(zero, o);
  ASSERT_TRUE(a.ok()) << a.status().to_string();
  Result<SerialResult> b = mesh_serial(one, o);
  ASSERT_TRUE(b.ok()) << b.status().to_string();
  expect_user_ids(a->mesh, zero, 0);
  expect_user_ids(b->mesh, one, 1);
  expect_same_mesh(a->mesh, b->mesh);
  // The surface-only steps ran alike (with ids 0 taken for interfaces, as
  // before surface_ids.hpp, the cap repair did not run: 0 caps against 10).
  EXPECT_EQ(a->optimize.caps_repaired, b->optimize.caps_repaired);
  EXPECT_EQ(a->optimize.repair_flips, b->optimize.repair_flips);
  EXPECT_EQ(a->optimize.points_moved, b->optimize.points_moved);
}

/// mesh_parallel at `depth` (one worker, a light initial mesh as pdr_test's
/// depth2()) of `user` and of `plain`, the same surface with the engine ids
/// that `user`'s map to: the same mesh, each with its own ids. On hinge the
/// leaf tasks' surface-only optimizer steps change the mesh: with ids 0 taken
/// for interfaces (before surface_ids.hpp) it differed at depths 1 and 2.
void expect_parallel_alike(const SurfaceMesh& user, const SurfaceMesh& plain, int depth) {
  ParallelOptions o;
  o.pdr.depth = depth;
  o.pdr.workers = 1;
  o.pdr.initial_volume_divisor = 60;
  Result<ParallelResult> a = mesh_parallel(user, o);
  ASSERT_TRUE(a.ok()) << a.status().to_string();
  Result<ParallelResult> b = mesh_parallel(plain, o);
  ASSERT_TRUE(b.ok()) << b.status().to_string();
  const ValidationReport rep = validate_mesh(a->mesh, &user);  // the user's ids, face by face
  EXPECT_TRUE(rep.ok()) << depth << ": " << format_validation(rep);
  expect_same_mesh(a->mesh, b->mesh);
  ASSERT_EQ(a->mesh.boundary_ids.size(), a->mesh.boundary.size());
}

TEST(SurfaceIds, ZeroIdsMeshInParallelAsIdsOne) {
  const SurfaceMesh zero = with_ids("hinge", 0), one = with_ids("hinge", 1);
  ASSERT_FALSE(zero.triangles.empty());
  expect_parallel_alike(zero, one, 1);
}

TEST(SurfaceIds, NegativeAndZeroIdsMeshInParallelAsOneAndTwo) {
  // -5 and 0 on the two halves of the triangles (by index), against 1 and 2.
  SurfaceMesh user = with_ids("hinge", 0), plain = with_ids("hinge", 2);
  ASSERT_FALSE(user.triangles.empty());
  for (std::size_t i = 0; i < user.triangles.size() / 2; ++i) {
    user.surface_ids[i] = -5;
    plain.surface_ids[i] = 1;
  }
  expect_parallel_alike(user, plain, 2);
}

}  // namespace
}  // namespace pdrmesh
