// SPDX-License-Identifier: AGPL-3.0-or-later
// External flow: the domain between a body and a far-field boundary around it.
//
// make_farfield turns a closed, outward body surface (one or several
// components) into the surface of the space around it: the body's triangles
// reversed (their normals point into the body, which becomes a cavity of the
// domain) and a far-field boundary made by pdrmesh, a given number of body
// lengths away. The body length L is the largest extent of the body's
// bounding box; the flow runs along +x.
//
//  - box: the body's bounding box grown by distance * L on every side, each
//    face a grid of right triangles of about the far-field size, with the
//    surface ids (and names) inlet (the -x face), outlet (+x) and sides.
//  - sphere: centred on the body's bounding box, radius half its diagonal plus
//    distance * L, a geodesic subdivision of an icosahedron projected on the
//    sphere, surface id (and name) farfield.
//
// The far-field size is distance * L / 4, so a face gets about eight triangle
// edges a side whatever the distance, and the default point distribution
// function (sizing.hpp) grades the spacing from the body's own to it. The
// body's surface ids and names are kept; an unnamed body id is named wall
// (wall_<id> when several are unnamed); the far field's ids follow the
// largest body id. The result is deterministic: the same body and options give
// the same points and triangles, bit for bit.
#pragma once

#include <cstddef>
#include <optional>
#include <string_view>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"

namespace pdrmesh {

enum class FarfieldShape { kBox, kSphere };

/// "box" or "sphere".
std::string_view to_string(FarfieldShape shape);
/// The shape named `name` ("box", "sphere"), or nullopt.
std::optional<FarfieldShape> parse_farfield_shape(std::string_view name);

/// The distances make_farfield takes, in body lengths: over kMinFarfieldDistance
/// (closer, the far field would crowd the body) and at most kMaxFarfieldDistance.
inline constexpr double kMinFarfieldDistance = 0.5;
inline constexpr double kMaxFarfieldDistance = 1000;

struct FarfieldOptions {
  double distance = 10;  ///< body lengths between the body's bounding box and the far field
  FarfieldShape shape = FarfieldShape::kBox;
};

/// OK, or invalid_input saying what distance is accepted (`what` names the
/// option in the message, e.g. "--farfield").
Status check_farfield_distance(double distance, std::string_view what);

struct FarfieldDomain {
  SurfaceMesh surface;                ///< the body reversed, then the far field
  double body_length = 0;             ///< L
  double farfield_size = 0;           ///< the far field's triangle edge length (about)
  std::size_t farfield_triangles = 0;  ///< the last ones of surface.triangles

  /// The body's surface ids, ascending (those of every triangle before the far field's).
  std::vector<int> body_ids() const;
};

/// The domain around `body` (see the top of this file). invalid_input when the
/// distance is refused (check_farfield_distance), when the body is not a
/// closed, manifold, consistently and outward oriented surface (the surface
/// check's first defects), or when a body name is one of the far field's.
Result<FarfieldDomain> make_farfield(const SurfaceMesh& body, const FarfieldOptions& options);

}  // namespace pdrmesh
