// SPDX-License-Identifier: AGPL-3.0-or-later
// A triangulated surface as read from a user's file.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "pdrmesh/types.hpp"

namespace pdrmesh {

/// Triangles are oriented by the right-hand rule; a valid input has normals
/// pointing out of the meshed volume. `surface_ids` has one entry per triangle
/// (1 where the format carries no id) and travels to the volume mesh's
/// boundary faces. `surface_names` names some of those ids (an STL solid, an
/// OBJ group, a `--names` file); an id without an entry is unnamed.
struct SurfaceMesh {
  std::vector<Vec3> points;
  std::vector<Tri> triangles;
  std::vector<int> surface_ids;
  std::map<int, std::string> surface_names;
  std::string name;  ///< where it came from (a file name), for messages

  Box bounds() const {
    Box b;
    for (const Vec3& p : points) b.add(p);
    return b;
  }
};

}  // namespace pdrmesh
