// SPDX-License-Identifier: AGPL-3.0-or-later
// The serial meshing pipeline (see pipeline.hpp).
#include "pdrmesh/pipeline.hpp"

#include <chrono>
#include <utility>

#include "pdrmesh/tet_mesh.hpp"

namespace pdrmesh {

Result<SerialResult> mesh_serial(const SurfaceMesh& surface, const SerialOptions& options,
                                 const RefineProgress& progress) {
  using Clock = std::chrono::steady_clock;
  const auto since = [](Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
  };
  PDR_TRY(validate(options.sizing));
  PDR_TRY(validate(options.refine));
  if (options.optimize) PDR_TRY(validate(*options.optimize));
  SerialResult out;
  auto t = Clock::now();
  PDR_ASSIGN_OR_RETURN(VolumeMesh initial, tetrahedralize(surface, options.tetgen));
  out.seconds_initial = since(t);
  t = Clock::now();
  PDR_ASSIGN_OR_RETURN(SizingField sizing, SizingField::build(surface, initial, options.sizing));
  out.seconds_sizing = since(t);
  t = Clock::now();
  PDR_ASSIGN_OR_RETURN(TetMesh mesh, TetMesh::from_volume_mesh(initial));
  initial = VolumeMesh{};
  PDR_ASSIGN_OR_RETURN(out.refine, refine(mesh, sizing, options.refine, progress));
  out.seconds_refine = since(t);
  if (options.optimize) {
    t = Clock::now();
    PDR_ASSIGN_OR_RETURN(out.optimize, pdrmesh::optimize(mesh, &sizing, *options.optimize));
    out.seconds_optimize = since(t);
  }
  out.mesh = mesh.to_volume_mesh();
  return out;
}

}  // namespace pdrmesh
