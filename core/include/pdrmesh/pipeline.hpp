// SPDX-License-Identifier: AGPL-3.0-or-later
// The serial meshing pipeline: initial boundary-conforming TetGen mesh, point
// distribution function, grid generation passes (refine.hpp). The final
// optimisation (optimize.hpp) is a separate step.
#pragma once

#include <optional>

#include "pdrmesh/optimize.hpp"
#include "pdrmesh/refine.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

struct SerialOptions {
  SizingOptions sizing;
  RefineOptions refine;
  TetgenOptions tetgen;
  /// The final optimization after refinement; unset: none.
  std::optional<OptimizeOptions> optimize = OptimizeOptions{};
};

struct SerialResult {
  VolumeMesh mesh;  ///< boundary = the surface's triangles and ids; tet_regions empty
  RefineStats refine;
  OptimizeStats optimize;  ///< zero when the optimization did not run
  double seconds_initial = 0, seconds_sizing = 0, seconds_refine = 0, seconds_optimize = 0;
};

/// Meshes the volume enclosed by a checked surface (surface_check.hpp) on one
/// core: tetrahedralize -> SizingField::build(surface, initial mesh) ->
/// TetMesh::from_volume_mesh -> refine -> optimize -> to_volume_mesh. The boundary is the
/// input triangulation, frozen throughout.
Result<SerialResult> mesh_serial(const SurfaceMesh& checked_surface, const SerialOptions& options,
                                 const RefineProgress& progress = {});

}  // namespace pdrmesh
