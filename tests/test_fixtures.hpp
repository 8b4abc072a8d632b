// SPDX-License-Identifier: AGPL-3.0-or-later
// Named mesh fixtures shared by the tests.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "pdrmesh/surface.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh::fixtures {

/// Points of the unit cube, index = x + 2y + 4z.
inline std::vector<Vec3> unit_cube_points() {
  std::vector<Vec3> p;
  for (int i = 0; i < 8; ++i) p.push_back({double(i & 1), double((i >> 1) & 1), double((i >> 2) & 1)});
  return p;
}

/// The unit cube's surface: 12 outward triangles, split along the face
/// diagonals through corner 0 or corner 7 (those of the Kuhn triangulation).
/// Surface id = cube face (1: z=0, 2: y=0, 3: x=0, 4: z=1, 5: y=1, 6: x=1).
inline SurfaceMesh unit_cube_surface() {
  SurfaceMesh s;
  s.points = unit_cube_points();
  s.triangles = {{0, 3, 1}, {0, 2, 3}, {0, 1, 5}, {0, 5, 4}, {0, 6, 2}, {0, 4, 6},
                 {4, 5, 7}, {4, 7, 6}, {2, 7, 3}, {2, 6, 7}, {1, 3, 7}, {1, 7, 5}};
  s.surface_ids = {1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6};
  s.name = "unit_cube";
  return s;
}

/// The Kuhn triangulation of the unit cube: 6 positive tets around the
/// diagonal 0-7, with the cube's surface as boundary.
inline VolumeMesh unit_cube_mesh() {
  VolumeMesh m;
  m.points = unit_cube_points();
  m.tets = {{0, 1, 3, 7}, {0, 5, 1, 7}, {0, 3, 2, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 6, 4, 7}};
  const SurfaceMesh s = unit_cube_surface();
  m.boundary = s.triangles;
  m.boundary_ids = s.surface_ids;
  return m;
}

/// A test surface (NAME.mesh of tests/data, copied into the build tree), read
/// with the project's reader; an empty surface, and a test failure, when it
/// cannot be read.
inline SurfaceMesh corpus_surface(const std::string& name) {
  auto s = read_surface(std::string(PDRMESH_CORPUS_DIR) + "/" + name + ".mesh");
  if (!s.ok()) {
    ADD_FAILURE() << s.status().to_string();
    return {};
  }
  return std::move(s).value();
}

}  // namespace pdrmesh::fixtures
