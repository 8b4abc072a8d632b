// SPDX-License-Identifier: AGPL-3.0-or-later
// The pipelines with prism boundary layers: grow_layers (layers.hpp), then
// mesh_serial or mesh_parallel (pipeline.hpp) of what the layers leave (their
// top and the walls without layers), then one mixed mesh of both.
#pragma once

#include "pdrmesh/layers.hpp"
#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

struct LayeredResult {
  VolumeMesh mesh;  ///< tets, prisms and pyramids; boundary = the surface's triangles, ids and names
  SerialResult fill;  ///< the tet fill's figures (its mesh moved into `mesh`)
  std::size_t wall_triangles = 0, wall_points = 0, compressed_points = 0, stopped_points = 0;
  std::size_t full_faces = 0, smooth_faces = 0, smooth_full_faces = 0;  ///< as LayerMesh's
  double thickness_min = 0, thickness_max = 0;
  int shrink_rounds = 0;
  double seconds_layers = 0;
};

/// Meshes the volume enclosed by a checked surface with `layers` prism layers
/// on its walls and tets elsewhere. The tet fill's spacing at the layers' top
/// is that of the top's own triangles and grows by options.sizing.growth (the
/// caller sets it to continue the layers' growth). The mixed mesh's points are
/// the surface's used points first, in their order, then the layer points, then
/// the fill's inner points. A surface of several regions (regions.hpp) is
/// meshed region by region: the regions that layers.regions names with layers
/// on their walls, the others with tets only (mesh_serial), merged by
/// merge_regions (prism_regions the regions of the prisms); the layer figures
/// are those of all its regions together. invalid_input when layers.regions
/// names no region of a surface of several, an unknown one, or one that holds
/// none of layers.walls (check_layer_regions).
Result<LayeredResult> mesh_serial_layered(const SurfaceMesh& checked_surface, const LayerOptions& layers,
                                          const SerialOptions& options, const RefineProgress& progress = {});

/// Whether layers.regions fits `surface`: it names regions of a surface of
/// several (by name or id), each holding one of layers.walls, and is empty
/// for a surface of one; invalid_input naming the regions otherwise. The
/// pipelines here check it first; a caller that refuses before meshing (a
/// service at submission) calls it itself.
Status check_layer_regions(const SurfaceMesh& checked_surface, const LayerOptions& layers);

struct LayeredParallelResult {
  LayeredResult layered;  ///< the mixed mesh and the layer figures (its `fill` unused)
  ParallelResult fill;    ///< the tet fill's figures and profile (its mesh moved into layered.mesh)
};

/// mesh_serial_layered with the tet fill through mesh_parallel (`kernel`,
/// `optimize_kernel` and `final_optimize_kernel` as there): the same layers,
/// made serially, so the prisms and the points under them are the serial
/// path's, byte for byte.
Result<LayeredParallelResult> mesh_parallel_layered(const SurfaceMesh& checked_surface, const LayerOptions& layers,
                                                    const ParallelOptions& options, const LeafKernel* kernel = nullptr,
                                                    const LeafKernel* optimize_kernel = nullptr,
                                                    const LeafKernel* final_optimize_kernel = nullptr);

}  // namespace pdrmesh
