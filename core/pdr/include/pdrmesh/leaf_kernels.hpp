// SPDX-License-Identifier: AGPL-3.0-or-later
// The two PDR leaf kernels (leaf_task.hpp's LeafKernel):
//  * NativeLeafKernel: the leaf as a TetMesh with its hull frozen, refined in
//    place by a refine hook (the native refiner, refine.hpp, plugs in here);
//    every input point is kept.
//  * TetgenLeafKernel: the paper's black-box approach: the leaf's hull (its
//    frozen faces) is handed to TetGen as a closed surface and TetGen fills it
//    anew (interior input points are dropped), with a volume bound from the
//    sizing field. Needs each leaf's hull to be a closed 2-manifold and the leaf
//    face-connected: run_pdr applies the paper's fix-ups for it.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "pdrmesh/leaf_task.hpp"
#include "pdrmesh/optimize.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/tet_mesh.hpp"
#include "pdrmesh/tetgen_adapter.hpp"

namespace pdrmesh {

/// Refines a mesh in place towards h(x) without touching frozen faces, adding
/// points only inside `core` when it is set (LeafTaskInput::core); must be
/// deterministic and thread-safe across distinct meshes.
using RefineHook = std::function<Status(TetMesh&, const SizingField&, const std::optional<Box>& core)>;
/// A RefineHook that also takes h at the mesh's points (`sizes`: one per point
/// as LeafTaskInput::sizes gives them, or empty) and leaves h at every point,
/// new ones included, in it (or leaves it empty), as refine() does.
using SizedRefineHook = std::function<Status(TetMesh&, const SizingField&, const std::optional<Box>& core,
                                             std::vector<double>& sizes)>;

class NativeLeafKernel final : public LeafKernel {
 public:
  /// `name` is what name() answers: the make_leaf_kernel name of this hook.
  explicit NativeLeafKernel(RefineHook refine, std::string name = "native");
  explicit NativeLeafKernel(SizedRefineHook refine, std::string name = "native")
      : refine_(std::move(refine)), name_(std::move(name)) {}
  /// leaf_tet_mesh(in), the hook, then leaf_output_from, with the new points'
  /// sizes when a sized hook gave them. Errors of the hook are returned with
  /// the leaf named.
  Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& sizing) const override;
  std::string_view name() const override { return name_; }
  bool trusted() const override { return true; }

 private:
  SizedRefineHook refine_;
  std::string name_;
};

struct TetgenLeafOptions {
  double time_limit_s = 600;  ///< per leaf (TetGen runs in a child process)
  /// Test seam: TetGen misbehaves this way (tetgen_adapter.hpp) on leaf
  /// `fault_leaf` of every round, to test that a crash stays one leaf's problem.
  TetgenOptions::Fault inject_fault = TetgenOptions::Fault::kNone;
  std::uint32_t fault_leaf = 0;
};

class TetgenLeafKernel final : public LeafKernel {
 public:
  explicit TetgenLeafKernel(TetgenLeafOptions options = {}) : options_(options) {}
  /// The hull points (ascending local index) and frozen faces as a surface,
  /// tetrahedralized with max_volume = h^3 / (6 sqrt 2), h the mean of
  /// sizing.at over all the leaf's input points (a regular tet of edge h).
  Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& sizing) const override;
  std::string_view name() const override { return "tetgen"; }
  bool needs_manifold_hull() const override { return true; }

 private:
  TetgenLeafOptions options_;
};

/// The options of an optimization leaf task: `options` with
/// keep_point_indices, since a leaf's output names its input points by index
/// (NativeLeafKernel drops the removed new points; a removed input point is
/// left out of the output's tets, as the TetGen kernel leaves out the
/// interior ones, and run_pdr drops it after the optimization), and without
/// surface_room and late_caps (OptimizeOptions says why).
OptimizeOptions leaf_optimize_options(OptimizeOptions options = {});

/// The options of the one final optimization task over every bad tet and its
/// halo (PdrOptions::final_optimize_kernel): `options` with
/// keep_point_indices, and the whole mesh's schedule, since that task holds
/// the mesh's angle extremes; its point moves run side by side on the threads
/// the other tasks leave idle (parallel_moves: the same mesh). The leaf tasks
/// of the rounds stay on their thread, so that a task's time is its work.
OptimizeOptions final_optimize_options(OptimizeOptions options = {});

/// A NativeLeafKernel named `name` that runs optimize() with `options` on its
/// leaf (the kernels "optimize" and "optimize-final" with their options).
std::unique_ptr<LeafKernel> optimizing_kernel(const OptimizeOptions& options, std::string name);

/// The kernel a job names: "native" (NativeLeafKernel running refine() with
/// default RefineOptions) or "tetgen" (TetgenLeafKernel with default options),
/// or the kernel of the optimization rounds, "optimize" (NativeLeafKernel
/// running optimize() with leaf_optimize_options(): what mesh_parallel runs
/// there by default), or of the one final optimization task, "optimize-final"
/// (final_optimize_options()); invalid_input naming the choices otherwise. The same name
/// gives the same kernel in every process, which is what makes remote leaf
/// results identical.
Result<std::unique_ptr<LeafKernel>> make_leaf_kernel(std::string_view name);

/// Volume of the regular tetrahedron of edge h: h^3 / (6 sqrt 2).
double regular_tet_volume(double h);

}  // namespace pdrmesh
