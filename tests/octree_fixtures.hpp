// SPDX-License-Identifier: AGPL-3.0-or-later
// Structured tet meshes for the decomposition, scheduler and replay tests.
#pragma once

#include <functional>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "pdrmesh/decomposition.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh::fixtures {

/// The box [0, k]^3 cut into k^3 unit cubes, each split into the 6 Kuhn tets
/// around its 0-7 diagonal (corner index x + 2y + 4z). `keep(x, y, z)` selects
/// the cubes meshed (all by default). Only points and tets are filled.
inline VolumeMesh kuhn_grid(int k, const std::function<bool(int, int, int)>& keep = nullptr) {
  static constexpr int kTets[6][4] = {{0, 1, 3, 7}, {0, 5, 1, 7}, {0, 3, 2, 7},
                                      {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 6, 4, 7}};
  VolumeMesh m;
  const int q = k + 1;
  for (int z = 0; z < q; ++z)
    for (int y = 0; y < q; ++y)
      for (int x = 0; x < q; ++x) m.points.push_back({double(x), double(y), double(z)});
  for (int z = 0; z < k; ++z) {
    for (int y = 0; y < k; ++y) {
      for (int x = 0; x < k; ++x) {
        if (keep && !keep(x, y, z)) continue;
        Index corner[8];
        for (int c = 0; c < 8; ++c) {
          corner[c] = static_cast<Index>((x + (c & 1)) + q * ((y + ((c >> 1) & 1)) + q * (z + (c >> 2))));
        }
        for (const auto& t : kTets) m.tets.push_back({corner[t[0]], corner[t[1]], corner[t[2]], corner[t[3]]});
      }
    }
  }
  return m;
}

/// The octree decomposition of depth `depth` of kuhn_grid(k) (a test failure if it fails).
inline Decomposition grid_decomposition(int k, int depth) {
  auto d = decompose(kuhn_grid(k), depth);
  EXPECT_TRUE(d.ok()) << d.status().to_string();
  return std::move(d).value();
}

}  // namespace pdrmesh::fixtures
