// SPDX-License-Identifier: AGPL-3.0-or-later
// Several regions in one mesh (a solid inside a fluid, for conjugate heat
// transfer). Nested closed shells define them: every shell with outward
// normals bounds one region, the space between it and the shells directly
// inside it. A shell with outward normals directly inside another is the
// interface between two regions (surface_check.hpp: ComponentReport::interface);
// one with inward normals is a cavity, as in a one-region mesh.
//
// Each region is meshed as a closed domain of its own (its outer shell, its
// cavities, and its interface shells reversed) by the unchanged pipelines;
// merge_regions joins the parts. The boundary of a pdrmesh mesh is exactly its
// input triangulation, so both sides of an interface hold the same triangles
// on the same input points, and the merged mesh conforms across it by
// construction. The sizing of each side is built from its own domain, which
// holds the interface: at an interface point both sides get the same spacing
// (the mean length of its surface edges, which the interface shell alone
// gives), so the size field does not jump across it.
#pragma once

#include <string>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/surface_check.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

struct SurfaceRegion {
  int id = 0;        ///< 1, 2, ... in the order of the outer shells' first triangles
  std::string name;  ///< the outer shell's surface name (all its triangles of one named id), else region_<id>
  /// Closed and outward: the outer shell, then the shells directly inside it
  /// (cavities as they are, interface shells reversed), in input triangle
  /// order, with their surface ids and the surface's names.
  SurfaceMesh domain;
  std::vector<Index> input_points;  ///< domain point -> surface point
};

/// The regions of a meshable surface, from its check report; empty when no
/// shell is an interface (the surface is one region, meshed as it always was).
Result<std::vector<SurfaceRegion>> surface_regions(const SurfaceMesh& surface, const SurfaceReport& report);

/// The same for a surface already checked: when it has more than one
/// connected component, runs check_surface on it (without the
/// self-intersection test) for the nesting.
Result<std::vector<SurfaceRegion>> surface_regions(const SurfaceMesh& checked_surface);

/// Joins `parts` (parts[i] a mesh of regions[i].domain whose boundary is that
/// domain's triangulation) into one mesh of `surface`: the surface's points
/// that the parts use, in input order, then each part's other points in part
/// order; the parts' tets in region order, tet_regions their region ids,
/// region_names their names (prisms and pyramids likewise, with
/// prism_regions and pyramid_regions); the boundary the surface's triangles and ids in
/// input order (an interface once, oriented as in the input). invalid_input
/// when a part's boundary point is not a point of its domain.
Result<VolumeMesh> merge_regions(const SurfaceMesh& surface, const std::vector<SurfaceRegion>& regions,
                                 std::vector<VolumeMesh> parts);

}  // namespace pdrmesh
