// SPDX-License-Identifier: AGPL-3.0-or-later
// Fuzz target for the coordinator's acceptance of a worker's leaf result:
// LeafTaskOutput::decode of untrusted bytes, then validate_leaf_output against
// one fixed, valid leaf (the unit cube as 6 Kuhn tets, its 12 hull faces
// frozen). A decoded result re-encodes to the same bytes; an accepted result
// has every reference in range, every tet positively oriented (exact) and every
// point inside the leaf's cube: positive tets whose hull is exactly the cube's
// surface cannot reach outside it, so a point outside means a result that
// should have been refused was merged. The same bytes also go through
// LeafTaskInput::decode (what a worker does with a task).
#include <string>

#include "../octree_fixtures.hpp"
#include "fuzz_common.hpp"
#include "pdrmesh/leaf_task.hpp"
#include "pdrmesh/pdr.hpp"
#include "pdrmesh/predicates.hpp"

using namespace pdrmesh;

namespace {

const LeafTaskInput& cube_leaf() {
  static const LeafTaskInput in = [] {
    const VolumeMesh g = fixtures::kuhn_grid(1);
    return build_leaf_input(3, g.points, g.tets, FaceIdTable());
  }();
  return in;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes = fuzz::bytes_of(data, size);
  if (Result<LeafTaskInput> task = LeafTaskInput::decode(bytes); task.ok()) {
    FUZZ_REQUIRE(task->encode() == bytes);
  }
  Result<LeafTaskOutput> out = LeafTaskOutput::decode(bytes);
  if (!out.ok()) return 0;
  FUZZ_REQUIRE(out->encode() == bytes);
  const LeafTaskInput& in = cube_leaf();
  if (!validate_leaf_output(in, *out).ok()) return 0;
  std::vector<Vec3> points = in.points;
  points.insert(points.end(), out->new_points.begin(), out->new_points.end());
  FUZZ_REQUIRE(fuzz::indices_below(out->tets, points.size()));
  for (const Tet& t : out->tets) {
    FUZZ_REQUIRE(exact::orient3d(points[t[0]], points[t[1]], points[t[2]], points[t[3]]) > 0);
    for (Index v : t)
      for (double c : points[v]) FUZZ_REQUIRE(c >= 0 && c <= 1);
  }
  return 0;
}
