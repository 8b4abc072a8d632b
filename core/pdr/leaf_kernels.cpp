// SPDX-License-Identifier: AGPL-3.0-or-later
// The native (TetMesh + refine hook) and TetGen (refill the frozen hull) leaf kernels.
#include "pdrmesh/leaf_kernels.hpp"

#include <fmt/format.h>

#include <cmath>

#include "pdrmesh/optimize.hpp"
#include "pdrmesh/refine.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/tetgen_adapter.hpp"

namespace pdrmesh {

double regular_tet_volume(double h) { return h * h * h / (6.0 * std::sqrt(2.0)); }

OptimizeOptions leaf_optimize_options(OptimizeOptions options) {
  options.schedule = OptimizeOptions::Schedule::kLeafTask;
  options.keep_point_indices = true;
  options.surface_room = false;  // a sub-mesh's extremes are not the mesh's
  options.late_caps = false;     // OptimizeOptions::late_caps says why
  return options;
}

OptimizeOptions final_optimize_options(OptimizeOptions options) {
  options.schedule = OptimizeOptions::Schedule::kWholeMesh;
  options.keep_point_indices = true;
  options.parallel_moves = true;
  return options;
}

std::unique_ptr<LeafKernel> optimizing_kernel(const OptimizeOptions& options, std::string name) {
  return std::make_unique<NativeLeafKernel>(
      [options](TetMesh& leaf, const SizingField& h, const std::optional<Box>&) {
        return optimize(leaf, &h, options).status();
      },
      std::move(name));
}

Result<std::unique_ptr<LeafKernel>> make_leaf_kernel(std::string_view name) {
  if (name == "native") {
    return std::unique_ptr<LeafKernel>(std::make_unique<NativeLeafKernel>(
        SizedRefineHook([](TetMesh& leaf, const SizingField& h, const std::optional<Box>& core,
                           std::vector<double>& sizes) {
          RefineOptions options;
          options.insert_within = core;
          return refine(leaf, h, options, {}, &sizes).status();
        })));
  }
  if (name == "tetgen") return std::unique_ptr<LeafKernel>(std::make_unique<TetgenLeafKernel>());
  if (name == "optimize") return optimizing_kernel(leaf_optimize_options(), "optimize");
  if (name == "optimize-final") return optimizing_kernel(final_optimize_options(), "optimize-final");
  return invalid_input(fmt::format("unknown leaf kernel '{}' (native, tetgen, optimize or optimize-final)", name));
}

NativeLeafKernel::NativeLeafKernel(RefineHook refine, std::string name)
    : refine_([hook = std::move(refine)](TetMesh& mesh, const SizingField& sizing, const std::optional<Box>& core,
                                         std::vector<double>& sizes) {
        sizes.clear();  // the hook does not keep them
        return hook ? hook(mesh, sizing, core) : Status();
      }),
      name_(std::move(name)) {}

Result<LeafTaskOutput> NativeLeafKernel::run(const LeafTaskInput& in, const SizingField& sizing) const {
  Result<TetMesh> mesh = leaf_tet_mesh(in);
  if (!mesh.ok()) {
    return Status(mesh.status().code(), fmt::format("leaf {}: {}", in.leaf, mesh.status().message()));
  }
  std::vector<double> sizes = in.sizes;
  if (!in.seeds.empty()) {  // a seed round's task: the seeds go in, nothing else
    const Index before = mesh->num_points();
    const Result<InsertPointsStats> seeded = insert_points(*mesh, in.seeds);
    if (!seeded.ok())
      return Status(seeded.status().code(), fmt::format("leaf {}: seeds: {}", in.leaf, seeded.status().message()));
    if (sizes.size() == before) {
      SizingHint hint;  // the seeds went in in Morton order
      for (Index v = before; v < mesh->num_points(); ++v) sizes.push_back(sizing.at(mesh->point(v), hint));
    }
  } else if (refine_) {
    const Status s = refine_(*mesh, sizing, in.core, sizes);
    if (!s.ok()) return Status(s.code(), fmt::format("leaf {}: refinement: {}", in.leaf, s.message()));
  }
  // The output names the input points by their index (leaf_output_from): a
  // hook that dropped one (optimize() without keep_point_indices) shifted the
  // rest. Ids keep their order, so the last input point's id tells. New
  // points that the hook removed again go here.
  const auto n = static_cast<Index>(in.points.size());
  mesh->remove_unused_points(n);
  if (mesh->num_points() < n || (n > 0 && mesh->point_id(n - 1) != n - 1))
    return internal_error(
        fmt::format("leaf {}: the {} hook dropped input points (a leaf keeps them all)", in.leaf, name_));
  LeafTaskOutput out = leaf_output_from(in, *mesh);
  if (sizes.size() == mesh->num_points()) out.new_sizes.assign(sizes.begin() + n, sizes.end());
  return out;
}

Result<LeafTaskOutput> TetgenLeafKernel::run(const LeafTaskInput& in, const SizingField& sizing) const {
  LeafTaskOutput out;
  out.leaf = in.leaf;
  out.input_points = static_cast<std::uint32_t>(in.points.size());
  if (in.tets.empty()) return out;

  // The hull surface: its points in ascending local index.
  std::vector<Index> to_hull(in.points.size(), kNoIndex);
  for (const Tri& f : in.frozen_faces)
    for (Index v : f) to_hull[v] = 0;
  SurfaceMesh surface;
  surface.name = fmt::format("leaf {} hull", in.leaf);
  std::vector<Index> from_hull;
  for (Index v = 0; v < in.points.size(); ++v) {
    if (to_hull[v] == kNoIndex) continue;
    to_hull[v] = static_cast<Index>(from_hull.size());
    from_hull.push_back(v);
    surface.points.push_back(in.points[v]);
  }
  for (const Tri& f : in.frozen_faces) surface.triangles.push_back({to_hull[f[0]], to_hull[f[1]], to_hull[f[2]]});
  surface.surface_ids.assign(surface.triangles.size(), 1);

  double sum_h = 0;
  for (const Vec3& p : in.points) sum_h += sizing.at(p);
  TetgenOptions options;
  options.max_volume = regular_tet_volume(sum_h / static_cast<double>(in.points.size()));
  options.time_limit_s = options_.time_limit_s;
  if (in.leaf == options_.fault_leaf) options.inject_fault = options_.inject_fault;
  Result<VolumeMesh> filled = tetrahedralize(surface, options);
  if (!filled.ok()) {
    return Status(filled.status().code(), fmt::format("leaf {}: TetGen on its hull ({} faces): {}", in.leaf,
                                                      surface.triangles.size(), filled.status().message()));
  }
  const std::size_t nh = from_hull.size();
  const auto ni = static_cast<Index>(in.points.size());
  out.new_points.assign(filled->points.begin() + static_cast<std::ptrdiff_t>(nh), filled->points.end());
  out.tets.reserve(filled->tets.size());
  for (const Tet& t : filled->tets) {
    Tet r;
    for (int i = 0; i < 4; ++i) r[i] = t[i] < nh ? from_hull[t[i]] : ni + (t[i] - static_cast<Index>(nh));
    out.tets.push_back(r);
  }
  return out;
}

}  // namespace pdrmesh
