// SPDX-License-Identifier: AGPL-3.0-or-later
// A picture of a volume mesh (`pdrmesh view`): a cut through the mesh by a
// plane normal to x, y or z, seen slightly from the side. The tets the plane
// cuts are drawn as their cross-section polygons, coloured by their smallest
// dihedral angle (with a colour bar); behind the plane the boundary triangles
// that face the viewer are shaded (Lambert, painter's order), so the shape of
// the body shows around the cut. SVG, or PNG from a small rasterizer of our
// own (3x3 supersampling) encoded by libpng. The output is deterministic.
#pragma once

#include <cstddef>
#include <optional>
#include <string>

#include "pdrmesh/status.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh::picture {

enum class Format { kSvg, kPng };

struct Options {
  int axis = 2;               ///< the plane's normal: 0 x, 1 y, 2 z
  std::optional<double> at;   ///< where it cuts that axis (default: the bounding box's centre)
  int width = 960, height = 720;
  std::string title;          ///< the first line of the caption (the SVG's; PNG text is plain ASCII)
};

struct Picture {
  std::string bytes;             ///< the SVG text or the PNG file
  double at = 0;                 ///< where the plane cut
  std::size_t cut_tets = 0;      ///< tets the plane cuts
  std::size_t boundary_drawn = 0;  ///< boundary triangles drawn behind the plane
};

/// The picture of `mesh`. invalid_input when the mesh has no tets or the plane
/// misses the mesh's bounding box (the message names the box's extent).
Result<Picture> draw(const VolumeMesh& mesh, const Options& options, Format format);

/// The colour of a smallest dihedral angle (degrees): dark red at 0, through
/// orange and yellow, to green and blue at the regular tet's 70.5.
struct Rgb {
  unsigned char r, g, b;
};
Rgb angle_colour(double degrees);

}  // namespace pdrmesh::picture
