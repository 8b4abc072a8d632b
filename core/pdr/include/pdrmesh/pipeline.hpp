// SPDX-License-Identifier: AGPL-3.0-or-later
// The meshing pipelines. Serial: initial boundary-conforming TetGen mesh, point
// distribution function, grid generation passes (refine.hpp), final
// optimisation (optimize.hpp). Parallel: the same point distribution function,
// then the PDR engine (pdr.hpp) with a leaf kernel, then the same final
// optimisation over the merged mesh. `pdrmesh run` and the coordinator both
// call mesh_parallel, so a job's result is byte-identical to a local run with
// the same options.
#pragma once

#include <optional>

#include "pdrmesh/optimize.hpp"
#include "pdrmesh/pdr.hpp"
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
  /// Seconds the whole of mesh_serial may take; 0: no limit. TetGen gets what
  /// is left (at most tetgen.time_limit_s), refinement stops soon after it
  /// (RefineOptions::deadline), and no step starts past it: deadline_exceeded.
  double time_limit_s = 0;
};

struct SerialResult {
  VolumeMesh mesh;  ///< boundary = the surface's triangles, ids and names; tet_regions empty or the regions
  RefineStats refine;
  OptimizeStats optimize;  ///< zero when the optimization did not run
  double seconds_initial = 0, seconds_sizing = 0, seconds_refine = 0, seconds_optimize = 0;
};

/// Meshes the volume enclosed by a checked surface (surface_check.hpp) on one
/// core: tetrahedralize -> SizingField::build(surface, initial mesh) ->
/// TetMesh::from_volume_mesh -> refine -> optimize -> to_volume_mesh. The boundary is the
/// input triangulation, frozen throughout, with the surface's ids (any int: surface_ids.hpp).
/// A surface of several regions (regions.hpp) is meshed region by region and
/// merged: tet_regions the region ids, the interfaces in the boundary.
Result<SerialResult> mesh_serial(const SurfaceMesh& checked_surface, const SerialOptions& options,
                                 const RefineProgress& progress = {});

/// Adds one region's figures to those of a run that meshes a surface region
/// by region (its mesh aside): times and counts summed, the refinement passes
/// in region order, the optimization's extremes combined over the first
/// region's summary (`first`: `part` is the first region).
void add_region(SerialResult& all, const SerialResult& part, bool first);

struct ParallelOptions {
  SizingOptions sizing;
  /// Depth, workers, policy, interface round, progress. Its `optimize` hook is
  /// ignored: mesh_parallel sets it from `optimize` below.
  PdrOptions pdr;
  /// The final optimization over the merged mesh; unset: none.
  std::optional<OptimizeOptions> optimize = OptimizeOptions{};
};

struct ParallelResult {
  VolumeMesh mesh;  ///< validates against the surface; tet_regions: empty, or the regions (regions.hpp)
  PdrProfile profile;
  std::size_t boundary_points = 0;  ///< points of the point distribution function
  double seconds_sizing = 0;        ///< background mesh and point distribution function
};

/// The same for a parallel run: profiles added (times and counts summed, the
/// rounds in region order), sizing figures summed.
void add_region(ParallelResult& all, ParallelResult&& part);

/// `options` for meshing a surface of `regions` regions region by region: no
/// checkpoint, as one holds one engine run's state; invalid_input when the
/// options resume from one.
Result<ParallelOptions> region_by_region(const ParallelOptions& options, const SurfaceMesh& surface,
                                         std::size_t regions);

/// Meshes the volume enclosed by a checked surface with the PDR engine:
/// background TetGen mesh -> SizingField::build -> run_pdr(kernel) -> optimize.
/// `kernel` null: make_leaf_kernel("native"). `optimize_kernel` runs the
/// optimization's leaf tasks (PdrOptions::optimize_kernel; only with
/// options.optimize) and `final_optimize_kernel` its one final task
/// (PdrOptions::final_optimize_kernel); each null: a NativeLeafKernel running
/// optimize() with leaf_optimize_options(*options.optimize), or
/// final_optimize_options(*options.optimize), in this process. Those given
/// must compute the same, as make_leaf_kernel("optimize") and
/// ("optimize-final") do for the default OptimizeOptions, whether they run
/// the task here or on a remote worker (the coordinator's dispatch).
/// Several regions: each through the method in turn, merged as by mesh_serial
/// (no checkpoint is written, and options.pdr.resume is refused).
Result<ParallelResult> mesh_parallel(const SurfaceMesh& checked_surface, const ParallelOptions& options,
                                     const LeafKernel* kernel = nullptr, const LeafKernel* optimize_kernel = nullptr,
                                     const LeafKernel* final_optimize_kernel = nullptr);

/// The final optimization of a merged mesh (boundary frozen, sizing-aware).
Status optimize_volume(VolumeMesh& mesh, const SizingField& sizing, const OptimizeOptions& options = {});

}  // namespace pdrmesh
