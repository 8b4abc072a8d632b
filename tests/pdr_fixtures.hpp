// SPDX-License-Identifier: AGPL-3.0-or-later
// Shared fixtures of the PDR engine tests: a uniform sizing field and a simple
// refine hook for the native leaf kernel.
#pragma once

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "pdrmesh/insert.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/sizing.hpp"
#include "test_fixtures.hpp"

namespace pdrmesh::fixtures {

/// h everywhere on the unit cube (whose triangles are wider than any h the tests use).
inline SizingField uniform_sizing(double h) {
  SizingOptions o;
  o.size = h;
  o.hmax = h;  // h everywhere, also next to boundary triangles wider than h
  Result<SizingField> s = SizingField::build(fixtures::unit_cube_surface(), fixtures::unit_cube_mesh(), o);
  EXPECT_TRUE(s.ok()) << s.status().to_string();
  return std::move(s).value();
}

/// A simple but real refinement: splits, at their barycenter, the tets whose
/// volume exceeds twice the regular volume at h, up to `cap` insertions.
inline RefineHook barycenter_hook(std::size_t cap) {
  return [cap](TetMesh& m, const SizingField& sizing, const std::optional<Box>& = {}) -> Status {
    std::size_t done = 0;
    for (Index t = 0; t < m.num_slots() && done < cap; ++t) {
      if (!m.alive(t)) continue;
      const Tet& v = m.tet(t);
      const Vec3 c = 0.25 * ((m.point(v[0]) + m.point(v[1])) + (m.point(v[2]) + m.point(v[3])));
      const double vol = signed_volume(m.point(v[0]), m.point(v[1]), m.point(v[2]), m.point(v[3]));
      if (vol <= 2 * regular_tet_volume(sizing.at(c))) continue;
      const InsertResult r = insert_point(m, t, c);
      if (r.outcome != InsertOutcome::kDone) return internal_error(fmt::format("insertion: {}", to_string(r.outcome)));
      ++done;
    }
    return m.check();
  };
}

}  // namespace pdrmesh::fixtures
