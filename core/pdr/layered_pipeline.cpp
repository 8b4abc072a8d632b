// SPDX-License-Identifier: AGPL-3.0-or-later
// The pipelines with prism layers (see layered_pipeline.hpp).
#include "pdrmesh/layered_pipeline.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <utility>
#include <vector>

#include "pdrmesh/regions.hpp"

namespace pdrmesh {
namespace {

/// The regions of `surface` (regions.hpp; none: empty) and, per region,
/// whether it grows layers (layers.regions names it, by name or id).
/// invalid_input for a surface of several regions that names none of them,
/// for a name that is no region's, and for names on a surface of one region.
Result<std::vector<SurfaceRegion>> layered_regions(const SurfaceMesh& surface, const LayerOptions& layers,
                                                   std::vector<char>& grows) {
  PDR_ASSIGN_OR_RETURN(std::vector<SurfaceRegion> regions, surface_regions(surface));
  if (regions.empty()) {
    if (!layers.regions.empty())
      return invalid_input(fmt::format("--layers-in names regions, but {} is one region", surface.name));
    return regions;
  }
  std::vector<std::string> known;
  for (const SurfaceRegion& r : regions) known.push_back(fmt::format("{} ({})", r.name, r.id));
  if (layers.regions.empty())
    return invalid_input(fmt::format("{} has {} regions, {}: name those on whose side the walls grow layers "
                                     "(--layers-in)", surface.name, regions.size(), fmt::join(known, ", ")));
  grows.assign(regions.size(), 0);
  for (const std::string& name : layers.regions) {
    const auto it = std::find_if(regions.begin(), regions.end(), [&](const SurfaceRegion& r) {
      return r.name == name || std::to_string(r.id) == name;
    });
    if (it == regions.end())
      return invalid_input(fmt::format("--layers-in: {} names no region of {}; its regions are {}", name, surface.name,
                                       fmt::join(known, ", ")));
    // A region named must have walls to grow them from.
    const std::vector<int>& ids = it->domain.surface_ids;
    if (!layers.walls.empty() && std::none_of(ids.begin(), ids.end(), [&](int id) {
          return std::find(layers.walls.begin(), layers.walls.end(), id) != layers.walls.end();
        }))
      return invalid_input(fmt::format("--layers-in: region {} ({}) of {} has none of the walls that grow layers "
                                       "(--layers-on)", it->name, it->id, surface.name));
    grows[static_cast<std::size_t>(it - regions.begin())] = 1;
  }
  return regions;
}

/// Adds one region's layer figures to a run's (counts and times summed,
/// thickness extremes combined).
void add_layer_figures(LayeredResult& all, const LayeredResult& part) {
  const bool first = all.wall_triangles == 0;
  all.wall_triangles += part.wall_triangles;
  all.wall_points += part.wall_points;
  all.compressed_points += part.compressed_points;
  all.stopped_points += part.stopped_points;
  all.full_faces += part.full_faces;
  all.smooth_faces += part.smooth_faces;
  all.smooth_full_faces += part.smooth_full_faces;
  all.thickness_min = first ? part.thickness_min : std::min(all.thickness_min, part.thickness_min);
  all.thickness_max = std::max(all.thickness_max, part.thickness_max);
  all.shrink_rounds = std::max(all.shrink_rounds, part.shrink_rounds);
  all.seconds_layers += part.seconds_layers;
}

/// The layers of `surface` (one region), their figures into `out`.
Result<LayerMesh> grow_checked(const SurfaceMesh& surface, const LayerOptions& layer_options,
                               LayeredResult& out) {
  const auto t = std::chrono::steady_clock::now();
  PDR_ASSIGN_OR_RETURN(LayerMesh layers, grow_layers(surface, layer_options));
  out.seconds_layers = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  out.wall_triangles = layers.wall_triangles;
  out.wall_points = layers.wall_points;
  out.compressed_points = layers.compressed_points;
  out.stopped_points = layers.stopped_points;
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
  for (const Pyramid& p : layers.pyramids)
    for (Index v : p) mark(v);
  for (const Tet& k : layers.tets)
    for (Index v : k) mark(v);
  for (Index v = 0; v < points.size(); ++v)
    if (renumber[v] != kNoIndex) {
      renumber[v] = static_cast<Index>(mesh.points.size());
      mesh.points.push_back(points[v]);
    }
  // The layers' tets (where stacks stop) first, then the fill's.
  mesh.tets.reserve(layers.tets.size() + fill.tets.size());
  for (const Tet& k : layers.tets) mesh.tets.push_back({renumber[k[0]], renumber[k[1]], renumber[k[2]], renumber[k[3]]});
  for (const Tet& k : fill.tets)
    mesh.tets.push_back({renumber[to_mixed[k[0]]], renumber[to_mixed[k[1]]], renumber[to_mixed[k[2]]],
                         renumber[to_mixed[k[3]]]});
  const auto renumbered = [&](auto cell) {
    for (Index& v : cell) v = renumber[v];
    return cell;
  };
  mesh.prisms.reserve(layers.prisms.size());
  for (const Prism& p : layers.prisms) mesh.prisms.push_back(renumbered(p));
  mesh.pyramids.reserve(layers.pyramids.size());
  for (const Pyramid& p : layers.pyramids) mesh.pyramids.push_back(renumbered(p));
  for (const Tri& f : surface.triangles) {
    if (renumber[f[0]] == kNoIndex || renumber[f[1]] == kNoIndex || renumber[f[2]] == kNoIndex)
      return internal_error("layers: a surface triangle is not a face of the mixed mesh");
    mesh.boundary.push_back({renumber[f[0]], renumber[f[1]], renumber[f[2]]});
  }
  mesh.boundary_ids = surface.surface_ids;
  mesh.boundary_names = surface.surface_names;
  return {};
}

/// mesh_serial_layered of a surface of one region.
Result<LayeredResult> serial_layered_one(const SurfaceMesh& surface, const LayerOptions& layer_options,
                                         const SerialOptions& options, const RefineProgress& progress) {
  LayeredResult out;
  PDR_ASSIGN_OR_RETURN(LayerMesh layers, grow_checked(surface, layer_options, out));
  PDR_ASSIGN_OR_RETURN(out.fill, mesh_serial(layers.fill, options, progress));
  PDR_TRY(merge_layers_and_fill(surface, layers, out.fill.mesh, out.mesh));
  out.fill.mesh = VolumeMesh{};
  return out;
}

/// mesh_parallel_layered of a surface of one region.
Result<LayeredParallelResult> parallel_layered_one(const SurfaceMesh& surface, const LayerOptions& layer_options,
                                                   const ParallelOptions& options, const LeafKernel* kernel,
                                                   const LeafKernel* optimize_kernel,
                                                   const LeafKernel* final_optimize_kernel) {
  LayeredParallelResult out;
  PDR_ASSIGN_OR_RETURN(LayerMesh layers, grow_checked(surface, layer_options, out.layered));
  PDR_ASSIGN_OR_RETURN(out.fill, mesh_parallel(layers.fill, options, kernel, optimize_kernel, final_optimize_kernel));
  PDR_TRY(merge_layers_and_fill(surface, layers, out.fill.mesh, out.layered.mesh));
  out.fill.mesh = VolumeMesh{};
  return out;
}

}  // namespace

Status check_layer_regions(const SurfaceMesh& surface, const LayerOptions& layers) {
  std::vector<char> grows;
  return layered_regions(surface, layers, grows).status();
}

Result<LayeredResult> mesh_serial_layered(const SurfaceMesh& surface, const LayerOptions& layer_options,
                                          const SerialOptions& options, const RefineProgress& progress) {
  std::vector<char> grows;
  PDR_ASSIGN_OR_RETURN(const std::vector<SurfaceRegion> regions, layered_regions(surface, layer_options, grows));
  if (regions.empty()) return serial_layered_one(surface, layer_options, options, progress);
  // Region by region (as mesh_serial), within what is left of the time limit.
  const auto start = std::chrono::steady_clock::now();
  LayeredResult out;
  std::vector<VolumeMesh> parts;
  for (std::size_t k = 0; k < regions.size(); ++k) {
    SerialOptions o = options;
    if (options.time_limit_s > 0) {
      o.time_limit_s = options.time_limit_s - std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (!(o.time_limit_s > 0))
        return deadline_exceeded(fmt::format("the time limit ran out before region {} was meshed", regions[k].id));
    }
    if (grows[k]) {
      PDR_ASSIGN_OR_RETURN(LayeredResult part, serial_layered_one(regions[k].domain, layer_options, o, progress));
      add_layer_figures(out, part);
      add_region(out.fill, part.fill, parts.empty());
      parts.push_back(std::move(part.mesh));
    } else {
      PDR_ASSIGN_OR_RETURN(SerialResult part, mesh_serial(regions[k].domain, o, progress));
      add_region(out.fill, part, parts.empty());
      parts.push_back(std::move(part.mesh));
    }
  }
  PDR_ASSIGN_OR_RETURN(out.mesh, merge_regions(surface, regions, std::move(parts)));
  return out;
}

Result<LayeredParallelResult> mesh_parallel_layered(const SurfaceMesh& surface, const LayerOptions& layer_options,
                                                    const ParallelOptions& options, const LeafKernel* kernel,
                                                    const LeafKernel* optimize_kernel,
                                                    const LeafKernel* final_optimize_kernel) {
  std::vector<char> grows;
  PDR_ASSIGN_OR_RETURN(const std::vector<SurfaceRegion> regions, layered_regions(surface, layer_options, grows));
  if (regions.empty()) return parallel_layered_one(surface, layer_options, options, kernel, optimize_kernel, final_optimize_kernel);
  PDR_ASSIGN_OR_RETURN(const ParallelOptions o, region_by_region(options, surface, regions.size()));
  LayeredParallelResult out;
  std::vector<VolumeMesh> parts;
  for (std::size_t k = 0; k < regions.size(); ++k) {
    if (grows[k]) {
      PDR_ASSIGN_OR_RETURN(LayeredParallelResult part,
                           parallel_layered_one(regions[k].domain, layer_options, o, kernel, optimize_kernel, final_optimize_kernel));
      add_layer_figures(out.layered, part.layered);
      parts.push_back(std::move(part.layered.mesh));
      add_region(out.fill, std::move(part.fill));
    } else {
      PDR_ASSIGN_OR_RETURN(ParallelResult part, mesh_parallel(regions[k].domain, o, kernel, optimize_kernel, final_optimize_kernel));
      parts.push_back(std::move(part.mesh));
      add_region(out.fill, std::move(part));
    }
  }
  PDR_ASSIGN_OR_RETURN(out.layered.mesh, merge_regions(surface, regions, std::move(parts)));
  out.fill.profile.final_tets = out.layered.mesh.tets.size();
  return out;
}

}  // namespace pdrmesh
