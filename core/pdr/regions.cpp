// SPDX-License-Identifier: AGPL-3.0-or-later
// Regions from nested shells, and the merge of their meshes (regions.hpp).
#include "pdrmesh/regions.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <utility>

#include "pdrmesh/union_find.hpp"

namespace pdrmesh {
namespace {

/// The connected component of every triangle as the smallest point index of
/// its set, by points: in a meshable surface no two shells share a point
/// (that is a pinched vertex), so this is the check's edge connectivity.
std::vector<Index> triangle_roots(const SurfaceMesh& s) {
  UnionFind uf(s.points.size());
  for (const Tri& t : s.triangles) {
    uf.unite(t[0], t[1]);
    uf.unite(t[0], t[2]);
  }
  std::vector<Index> root(s.triangles.size());
  for (std::size_t i = 0; i < s.triangles.size(); ++i) root[i] = uf.find(s.triangles[i][0]);
  return root;
}

bool valid_indices(const SurfaceMesh& s) {
  return std::all_of(s.triangles.begin(), s.triangles.end(), [&](const Tri& t) {
    return t[0] < s.points.size() && t[1] < s.points.size() && t[2] < s.points.size();
  });
}

bool point_less(const Vec3& a, const Vec3& b) { return a < b; }

}  // namespace

Result<std::vector<SurfaceRegion>> surface_regions(const SurfaceMesh& surface, const SurfaceReport& report) {
  if (!report.meshable()) return require_meshable(report, surface.name);
  if (!valid_indices(surface) || surface.surface_ids.size() != surface.triangles.size())
    return invalid_input(fmt::format("{}: the surface does not match its check report", surface.name));
  const auto& comps = report.components;
  if (std::none_of(comps.begin(), comps.end(), [](const ComponentReport& c) { return c.interface; }))
    return std::vector<SurfaceRegion>{};
  // The report's component of each triangle: its components are ordered by
  // their first triangles, which identify the sets found here.
  const std::vector<Index> root = triangle_roots(surface);
  std::map<Index, Index> comp_of_root;
  for (Index c = 0; c < comps.size(); ++c) {
    const Index t = comps[c].first_triangle;
    if (t >= surface.triangles.size() || !comp_of_root.emplace(root[t], c).second)
      return invalid_input(fmt::format("{}: the surface does not match its check report", surface.name));
  }
  std::vector<Index> comp(surface.triangles.size());
  for (std::size_t i = 0; i < comp.size(); ++i) {
    const auto it = comp_of_root.find(root[i]);
    if (it == comp_of_root.end())
      return invalid_input(fmt::format("{}: the surface does not match its check report", surface.name));
    comp[i] = it->second;
  }

  std::vector<SurfaceRegion> regions;
  for (Index c = 0; c < comps.size(); ++c) {
    if (!(comps[c].volume > 0)) continue;
    SurfaceRegion r;
    r.id = static_cast<int>(regions.size()) + 1;
    SurfaceMesh& d = r.domain;
    d.surface_names = surface.surface_names;
    d.name = fmt::format("{} (region {})", surface.name, r.id);
    std::vector<Index> local(surface.points.size(), kNoIndex);
    std::vector<std::size_t> taken;  // input triangles, in input order
    for (std::size_t i = 0; i < comp.size(); ++i) {
      const Index k = comp[i];
      if (k == c || comps[k].parent == c) taken.push_back(i);
    }
    // Domain points in input order.
    for (std::size_t i : taken)
      for (Index v : surface.triangles[i]) local[v] = 0;
    for (Index v = 0; v < local.size(); ++v) {
      if (local[v] == kNoIndex) continue;
      local[v] = static_cast<Index>(r.input_points.size());
      r.input_points.push_back(v);
      d.points.push_back(surface.points[v]);
    }
    bool one_id = true;
    for (std::size_t i : taken) {
      const Tri& t = surface.triangles[i];
      const bool reverse = comp[i] != c && comps[comp[i]].interface;
      d.triangles.push_back(reverse ? Tri{local[t[0]], local[t[2]], local[t[1]]} : Tri{local[t[0]], local[t[1]], local[t[2]]});
      d.surface_ids.push_back(surface.surface_ids[i]);
      if (comp[i] == c && surface.surface_ids[i] != surface.surface_ids[comps[c].first_triangle]) one_id = false;
    }
    const auto named = surface.surface_names.find(surface.surface_ids[comps[c].first_triangle]);
    r.name = one_id && named != surface.surface_names.end() ? named->second : region_name({}, r.id);
    // Two shells of one name: the later regions keep their numbers.
    if (std::any_of(regions.begin(), regions.end(), [&](const SurfaceRegion& o) { return o.name == r.name; }))
      r.name = region_name({}, r.id);
    regions.push_back(std::move(r));
  }
  return regions;
}

Result<std::vector<SurfaceRegion>> surface_regions(const SurfaceMesh& surface) {
  if (!valid_indices(surface)) return invalid_input(fmt::format("{}: a triangle names a point that does not exist", surface.name));
  const std::vector<Index> root = triangle_roots(surface);
  if (std::all_of(root.begin(), root.end(), [&](Index r) { return r == root.front(); }))
    return std::vector<SurfaceRegion>{};
  CheckOptions options;
  options.self_intersections = false;  // the caller checked them
  return surface_regions(surface, check_surface(surface, options));
}

Result<VolumeMesh> merge_regions(const SurfaceMesh& surface, const std::vector<SurfaceRegion>& regions,
                                 std::vector<VolumeMesh> parts) {
  if (parts.size() != regions.size())
    return invalid_input(fmt::format("{} region meshes for {} regions", parts.size(), regions.size()));
  // Merged indices: the input points the domains use, in input order, first.
  std::vector<Index> global(surface.points.size(), kNoIndex);
  for (const SurfaceRegion& r : regions)
    for (Index v : r.input_points) global[v] = 0;
  VolumeMesh out;
  for (Index v = 0; v < global.size(); ++v) {
    if (global[v] == kNoIndex) continue;
    global[v] = static_cast<Index>(out.points.size());
    out.points.push_back(surface.points[v]);
  }
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const SurfaceRegion& r = regions[k];
    VolumeMesh& part = parts[k];
    // A part point at a domain point's coordinates is that input point.
    std::vector<Index> by_coord(r.domain.points.size());
    for (Index i = 0; i < by_coord.size(); ++i) by_coord[i] = i;
    std::sort(by_coord.begin(), by_coord.end(),
              [&](Index a, Index b) { return point_less(r.domain.points[a], r.domain.points[b]); });
    std::vector<Index> to_out(part.points.size());
    std::size_t matched = 0;
    for (std::size_t i = 0; i < part.points.size(); ++i) {
      const Vec3& p = part.points[i];
      const auto it = std::lower_bound(by_coord.begin(), by_coord.end(), p,
                                       [&](Index a, const Vec3& key) { return point_less(r.domain.points[a], key); });
      if (it != by_coord.end() && r.domain.points[*it] == p) {
        to_out[i] = global[r.input_points[*it]];
        ++matched;
      } else {
        to_out[i] = static_cast<Index>(out.points.size());
        out.points.push_back(p);
      }
    }
    if (matched != r.domain.points.size())
      return invalid_input(fmt::format("the mesh of region {} holds {} of its domain's {} boundary points", r.id,
                                       matched, r.domain.points.size()));
    for (const Tet& t : part.tets) {
      out.tets.push_back({to_out[t[0]], to_out[t[1]], to_out[t[2]], to_out[t[3]]});
      out.tet_regions.push_back(r.id);
    }
    // A part's prism layers (layered_pipeline.hpp) keep their region too.
    for (Prism c : part.prisms) {
      for (Index& v : c) v = to_out[v];
      out.prisms.push_back(c);
      out.prism_regions.push_back(r.id);
    }
    for (Pyramid c : part.pyramids) {
      for (Index& v : c) v = to_out[v];
      out.pyramids.push_back(c);
      out.pyramid_regions.push_back(r.id);
    }
    out.region_names[r.id] = r.name;
    part = VolumeMesh{};
  }
  out.boundary.reserve(surface.triangles.size());
  for (const Tri& t : surface.triangles) out.boundary.push_back({global[t[0]], global[t[1]], global[t[2]]});
  out.boundary_ids = surface.surface_ids;
  out.boundary_names = surface.surface_names;
  return out;
}

}  // namespace pdrmesh
