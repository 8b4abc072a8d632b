// SPDX-License-Identifier: AGPL-3.0-or-later
// The rounds' selections (core/pdr/rounds.hpp, internal to the engine).
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <vector>

#include <oneapi/tbb/task_arena.h>

#include "octree_fixtures.hpp"
#include "rounds.hpp"

namespace pdrmesh::round_detail {
namespace {

/// grow_selection by its definition: each layer adds the tets that share a
/// point with a tet flagged before it.
std::vector<char> grown_by_definition(const VolumeMesh& m, std::vector<char> flag, int layers) {
  for (int layer = 0; layer < layers; ++layer) {
    std::set<Index> points;
    for (std::size_t t = 0; t < m.tets.size(); ++t)
      if (flag[t]) points.insert(m.tets[t].begin(), m.tets[t].end());
    std::vector<char> next = flag;
    for (std::size_t t = 0; t < m.tets.size(); ++t)
      for (Index v : m.tets[t]) next[t] = static_cast<char>(next[t] | (points.count(v) ? 1 : 0));
    flag = std::move(next);
  }
  return flag;
}

TEST(RoundTasks, GrowSelectionAddsOneLayerOfTetsAroundTheFlaggedOnesPerLayer) {
  const VolumeMesh m = fixtures::kuhn_grid(6);
  std::vector<char> seeds(m.tets.size(), 0);
  seeds[0] = 1;                      // a corner tet
  seeds[m.tets.size() / 2 + 3] = 1;  // and one inside
  std::size_t previous = 2;
  for (int layers = 0; layers <= 4; ++layers) {
    std::vector<char> flag = seeds;
    grow_selection(m, flag, layers);
    EXPECT_EQ(flag, grown_by_definition(m, seeds, layers)) << layers << " layers";
    const auto count = static_cast<std::size_t>(std::count(flag.begin(), flag.end(), 1));
    if (layers > 0) {
      EXPECT_GT(count, previous) << layers << " layers";
    }
    previous = count;
    // One thread gives the same flags as all of them.
    std::vector<char> alone = seeds;
    tbb::task_arena(1).execute([&] { grow_selection(m, alone, layers); });
    EXPECT_EQ(alone, flag) << layers << " layers";
  }
}

}  // namespace
}  // namespace pdrmesh::round_detail
