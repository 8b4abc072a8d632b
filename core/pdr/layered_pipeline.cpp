// SPDX-License-Identifier: AGPL-3.0-or-later
// The pipelines with prism layers (see layered_pipeline.hpp).
#include "pdrmesh/layered_pipeline.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <utility>
#include <vector>

#include "pdrmesh/regions.hpp"

namespace pdrmesh {
namespace {

/// The layers of `surface`, their figures into `out`.
Result<LayerMesh> grow_checked(const SurfaceMesh& surface, const LayerOptions& layer_options,
                               LayeredResult& out) {
  // Regions (regions.hpp) would lose their tet_regions in the merge below.
  PDR_ASSIGN_OR_RETURN(const std::vector<SurfaceRegion> regions, surface_regions(surface));
  if (!regions.empty())
    return invalid_input(fmt::format("{}: prism layers in a surface of {} regions are not supported yet",
                                     surface.name, regions.size()));
  const auto t = std::chrono::steady_clock::now();
  PDR_ASSIGN_OR_RETURN(LayerMesh layers, grow_layers(surface, layer_options));
  out.seconds_layers = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  out.wall_triangles = layers.wall_triangles;
  out.wall_points = layers.wall_points;
  out.compressed_points = layers.compressed_points;
  out.full_faces = layers.full_faces;
  out.smooth_faces = layers.smooth_faces;
  out.smooth_full_faces = layers.smooth_full_faces;
  out.thickness_min = layers.thickness_min;
  out.thickness_max = layers.thickness_max;
  out.shrink_rounds = layers.shrink_rounds;
  return layers;
}

/// The mixed mesh of `layers` and `fill`, a tet mesh of layers.fill, into `mesh`.
Status merge_layers_and_fill(const SurfaceMesh& surface, LayerMesh& layers, const VolumeMesh& fill,
                             VolumeMesh& mesh) {
  // The fill's points: those of its boundary are layer (or surface) points,
  // found by their exact coordinates; the others are new, appended in order.
  std::vector<Index> by_coord(layers.fill.points.size());
  for (Index i = 0; i < by_coord.size(); ++i) by_coord[i] = i;
  const auto& fp = layers.fill.points;
  std::sort(by_coord.begin(), by_coord.end(), [&](Index a, Index b) { return fp[a] < fp[b]; });
  std::vector<Vec3> points = std::move(layers.points);
  std::vector<Index> to_mixed(fill.points.size());
  for (Index i = 0; i < fill.points.size(); ++i) {
    const Vec3& x = fill.points[i];
    const auto it = std::lower_bound(by_coord.begin(), by_coord.end(), x,
                                     [&](Index a, const Vec3& key) { return fp[a] < key; });
    if (it != by_coord.end() && fp[*it] == x) {
      to_mixed[i] = layers.fill_points[*it];
    } else {
      to_mixed[i] = static_cast<Index>(points.size());
      points.push_back(x);
    }
  }

  // Only the points that cells use, in their order (a surface may carry
  // points no triangle uses).
  std::vector<Index> renumber(points.size(), kNoIndex);
  const auto mark = [&](Index v) { renumber[v] = 0; };
  for (const Tet& k : fill.tets)
    for (Index v : k) mark(to_mixed[v]);
  for (const Prism& p : layers.prisms)
    for (Index v : p) mark(v);
  for (Index v = 0; v < points.size(); ++v)
    if (renumber[v] != kNoIndex) {
      renumber[v] = static_cast<Index>(mesh.points.size());
      mesh.points.push_back(points[v]);
    }
  mesh.tets.reserve(fill.tets.size());
  for (const Tet& k : fill.tets)
    mesh.tets.push_back({renumber[to_mixed[k[0]]], renumber[to_mixed[k[1]]], renumber[to_mixed[k[2]]],
                         renumber[to_mixed[k[3]]]});
  mesh.prisms.reserve(layers.prisms.size());
  for (const Prism& p : layers.prisms) {
    Prism q{};
    for (int i = 0; i < 6; ++i) q[i] = renumber[p[i]];
    mesh.prisms.push_back(q);
  }
  for (const Tri& f : surface.triangles) {
    if (renumber[f[0]] == kNoIndex || renumber[f[1]] == kNoIndex || renumber[f[2]] == kNoIndex)
      return internal_error("layers: a surface triangle is not a face of the mixed mesh");
    mesh.boundary.push_back({renumber[f[0]], renumber[f[1]], renumber[f[2]]});
  }
  mesh.boundary_ids = surface.surface_ids;
  mesh.boundary_names = surface.surface_names;
  return {};
}

}  // namespace

Result<LayeredResult> mesh_serial_layered(const SurfaceMesh& surface, const LayerOptions& layer_options,
                                          const SerialOptions& options, const RefineProgress& progress) {
  LayeredResult out;
  PDR_ASSIGN_OR_RETURN(LayerMesh layers, grow_checked(surface, layer_options, out));
  PDR_ASSIGN_OR_RETURN(out.fill, mesh_serial(layers.fill, options, progress));
  PDR_TRY(merge_layers_and_fill(surface, layers, out.fill.mesh, out.mesh));
  out.fill.mesh = VolumeMesh{};
  return out;
}

Result<LayeredParallelResult> mesh_parallel_layered(const SurfaceMesh& surface, const LayerOptions& layer_options,
                                                    const ParallelOptions& options, const LeafKernel* kernel,
                                                    const LeafKernel* optimize_kernel) {
  LayeredParallelResult out;
  PDR_ASSIGN_OR_RETURN(LayerMesh layers, grow_checked(surface, layer_options, out.layered));
  PDR_ASSIGN_OR_RETURN(out.fill, mesh_parallel(layers.fill, options, kernel, optimize_kernel));
  PDR_TRY(merge_layers_and_fill(surface, layers, out.fill.mesh, out.layered.mesh));
  out.fill.mesh = VolumeMesh{};
  return out;
}

}  // namespace pdrmesh
