// SPDX-License-Identifier: AGPL-3.0-or-later
// LayerRequest: the layer options a user gives, checked alone and resolved
// against a surface (names to ids, a y+ to a length).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <set>

#include "pdrmesh/boundary_names.hpp"
#include "pdrmesh/layers.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {
namespace {

/// The id of `surface` that `name` names: a name of surface_names,
/// "surface_<id>", or the id's digits.
std::optional<int> surface_id_named(const SurfaceMesh& surface, const std::set<int>& ids, const std::string& name) {
  for (int id : ids) {
    const auto it = surface.surface_names.find(id);
    int number = 0;
    const auto [end, ec] = std::from_chars(name.data(), name.data() + name.size(), number);
    const bool as_number = ec == std::errc() && end == name.data() + name.size() && number == id;
    if ((it != surface.surface_names.end() && it->second == name) || is_default_boundary_name(id, name) || as_number)
      return id;
  }
  return std::nullopt;
}

/// The options with their values only (walls and a y+ height not yet resolved).
LayerOptions values_of(const LayerRequest& r) {
  LayerOptions o;
  o.layers = r.layers;
  o.first_height = r.first_height;
  o.growth_ratio = r.growth_ratio;
  o.max_thickness = r.max_thickness;
  return o;
}

}  // namespace

Status validate(const LayerRequest& r) {
  PDR_TRY(validate(values_of(r)));
  const auto positive = [](double x) { return std::isfinite(x) && x > 0; };
  if (r.yplus) {
    if (!positive(r.reynolds))
      return invalid_input(fmt::format("--reynolds must be a positive number with a y+ first height, got {}",
                                       r.reynolds));
    if (!(positive(r.reference_length) || r.reference_length == 0))
      return invalid_input(fmt::format("--reference-length must be a positive length, got {}", r.reference_length));
  } else if (r.reynolds != 0 || r.reference_length != 0) {
    return invalid_input("--reynolds and --reference-length: only with a y+ first height (yplus:Y)");
  }
  return {};
}

Result<LayerOptions> resolve_layers(const LayerRequest& r, const SurfaceMesh& surface,
                                    const std::vector<int>& default_walls) {
  PDR_TRY(validate(r));
  LayerOptions o = values_of(r);
  o.regions = r.in;  // resolved against the surface's regions by the layered pipelines
  if (r.on.empty()) o.walls = default_walls;
  const std::set<int> ids(surface.surface_ids.begin(), surface.surface_ids.end());
  for (const std::string& name : r.on) {
    const std::optional<int> id = surface_id_named(surface, ids, name);
    if (!id) {
      std::vector<std::string> known;
      for (int i : ids) known.push_back(fmt::format("{} ({})", boundary_name(surface.surface_names, i), i));
      return invalid_input(fmt::format("--layers-on: {} names no surface of {}; its surfaces are {}", name,
                                       surface.name, fmt::join(known, ", ")));
    }
    o.walls.push_back(*id);
  }
  if (r.yplus) {
    double length = r.reference_length;
    if (!(length > 0)) {
      const std::set<int> walls(o.walls.begin(), o.walls.end());
      Box box;
      for (std::size_t t = 0; t < surface.triangles.size(); ++t)
        if (walls.empty() || walls.count(surface.surface_ids[t]) > 0)
          for (Index v : surface.triangles[t]) box.add(surface.points[v]);
      for (int k = 0; k < 3; ++k) length = std::max(length, box.hi[k] - box.lo[k]);
    }
    PDR_ASSIGN_OR_RETURN(o.first_height, first_height_for_yplus(r.first_height, r.reynolds, length));
  }
  PDR_TRY(validate(o));
  return o;
}

}  // namespace pdrmesh
