// SPDX-License-Identifier: AGPL-3.0-or-later
// The serial pipeline with prism boundary layers: grow_layers (layers.hpp),
// then mesh_serial (pipeline.hpp) of what the layers leave (their top and the
// walls without layers), then one mixed mesh of both.
#pragma once

#include "pdrmesh/layers.hpp"
#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

struct LayeredResult {
  VolumeMesh mesh;  ///< tets and prisms; boundary = the surface's triangles, ids and names
  SerialResult fill;  ///< the tet fill's figures (its mesh moved into `mesh`)
  std::size_t wall_triangles = 0, wall_points = 0, compressed_points = 0;
  double thickness_min = 0, thickness_max = 0;
  int shrink_rounds = 0;
  double seconds_layers = 0;
};

/// Meshes the volume enclosed by a checked surface with `layers` prism layers
/// on its walls and tets elsewhere. The tet fill's spacing at the layers' top
/// is that of the top's own triangles and grows by options.sizing.growth (the
/// caller sets it to continue the layers' growth). The mixed mesh's points are
/// the surface's used points first, in their order, then the layer points, then
/// the fill's inner points.
Result<LayeredResult> mesh_serial_layered(const SurfaceMesh& checked_surface, const LayerOptions& layers,
                                          const SerialOptions& options, const RefineProgress& progress = {});

}  // namespace pdrmesh
