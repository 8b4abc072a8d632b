// SPDX-License-Identifier: AGPL-3.0-or-later
// The serial meshing pipeline (see pipeline.hpp).
#include "pdrmesh/pipeline.hpp"

#include <chrono>
#include <utility>

#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/tet_mesh.hpp"

namespace pdrmesh {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
}  // namespace

Result<SerialResult> mesh_serial(const SurfaceMesh& surface, const SerialOptions& options,
                                 const RefineProgress& progress) {
  PDR_TRY(validate(options.sizing));
  PDR_TRY(validate(options.refine));
  if (options.optimize) PDR_TRY(validate(*options.optimize));
  SerialResult out;
  auto t = Clock::now();
  PDR_ASSIGN_OR_RETURN(VolumeMesh initial, tetrahedralize(surface, options.tetgen));
  out.seconds_initial = seconds_since(t);
  t = Clock::now();
  PDR_ASSIGN_OR_RETURN(SizingField sizing, SizingField::build(surface, initial, options.sizing));
  out.seconds_sizing = seconds_since(t);
  t = Clock::now();
  PDR_ASSIGN_OR_RETURN(TetMesh mesh, TetMesh::from_volume_mesh(initial));
  initial = VolumeMesh{};
  PDR_ASSIGN_OR_RETURN(out.refine, refine(mesh, sizing, options.refine, progress));
  out.seconds_refine = seconds_since(t);
  if (options.optimize) {
    t = Clock::now();
    PDR_ASSIGN_OR_RETURN(out.optimize, pdrmesh::optimize(mesh, &sizing, *options.optimize));
    out.seconds_optimize = seconds_since(t);
  }
  out.mesh = mesh.to_volume_mesh();
  return out;
}

Status optimize_volume(VolumeMesh& mesh, const SizingField& sizing, const OptimizeOptions& options) {
  PDR_ASSIGN_OR_RETURN(TetMesh tets, TetMesh::from_volume_mesh(mesh));
  PDR_TRY(pdrmesh::optimize(tets, &sizing, options).status());
  mesh = tets.to_volume_mesh();
  return {};
}

Result<ParallelResult> mesh_parallel(const SurfaceMesh& surface, const ParallelOptions& options,
                                     const LeafKernel* kernel) {
  PDR_TRY(validate(options.sizing));
  if (options.optimize) PDR_TRY(validate(*options.optimize));
  std::unique_ptr<LeafKernel> native;
  if (kernel == nullptr) {
    PDR_ASSIGN_OR_RETURN(native, make_leaf_kernel("native"));
    kernel = native.get();
  }
  ParallelResult out;
  auto t = Clock::now();
  PDR_ASSIGN_OR_RETURN(const VolumeMesh background, tetrahedralize(surface));
  PDR_ASSIGN_OR_RETURN(const SizingField sizing, SizingField::build(surface, background, options.sizing));
  out.seconds_sizing = seconds_since(t);
  out.boundary_points = sizing.boundary_points();
  PdrOptions pdr = options.pdr;
  pdr.optimize = nullptr;
  pdr.optimize_kernel = nullptr;
  std::optional<NativeLeafKernel> optimizer;
  if (options.optimize) {
    const OptimizeOptions opt = *options.optimize;
    optimizer.emplace([opt](TetMesh& leaf, const SizingField& h) { return pdrmesh::optimize(leaf, &h, opt).status(); });
    pdr.optimize_kernel = &*optimizer;
    pdr.optimize = [&sizing, &options](VolumeMesh& m) { return optimize_volume(m, sizing, *options.optimize); };
  }
  PDR_ASSIGN_OR_RETURN(out.mesh, run_pdr(surface, sizing, *kernel, pdr, &out.profile));
  return out;
}

}  // namespace pdrmesh
