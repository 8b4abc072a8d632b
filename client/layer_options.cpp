// SPDX-License-Identifier: AGPL-3.0-or-later
#include "layer_options.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <charconv>
#include <limits>
#include <set>

#include "options.hpp"
#include "pdrmesh/boundary_names.hpp"
#include "pdrmesh/volume_io.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh::cli {
namespace {

/// `part` as a percentage of `whole` (0 of none).
double share(std::size_t part, std::size_t whole) {
  return whole == 0 ? 0.0 : 100.0 * static_cast<double>(part) / static_cast<double>(whole);
}

inline constexpr Accepts kLayers{"a whole number from 1 to 1000", "N", 1, 1000, false, true};
inline constexpr Accepts kRatio{"a growth ratio from 1 to 10 (1.2: each layer 20% higher than the one below)", "RATIO",
                                1, 10, false};
inline constexpr Accepts kReynolds{"a positive Reynolds number", "RE", 0, std::numeric_limits<double>::infinity(), true};

}  // namespace

std::optional<FirstHeightValue> FirstHeightValue::parse(std::string_view text) {
  FirstHeightValue h;
  constexpr std::string_view kYplus = "yplus:";
  if (text.substr(0, kYplus.size()) == kYplus) {
    h.yplus = true;
    text.remove_prefix(kYplus.size());
  }
  const std::optional<double> v = parse_finite(text);
  if (!v || !(*v > 0)) return std::nullopt;
  h.value = *v;
  return h;
}

void LayerArgs::add_to(CLI::App* cmd) {
  add_number(cmd, "--layers", layers, "prism layers grown from the walls before the tets fill the rest", kLayers);
  cmd->add_option("--first-height", first_height,
                  "with --layers: the height of the first layer, a length or yplus:Y (Y wall units at --reynolds)")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            if (FirstHeightValue::parse(text)) return {};
            return fmt::format("must be a positive length or yplus:Y with Y a positive number of wall units, got '{}'",
                               text);
          },
          ""))
      ->type_name("LENGTH|yplus:Y");
  add_number(cmd, "--reynolds", reynolds,
             "with --first-height yplus:Y: the Reynolds number U L / nu on the reference length", kReynolds);
  add_number(cmd, "--reference-length", reference_length,
             "with --reynolds: its length L (default: the walls' length, the longest side of their bounding box)",
             kLength);
  add_number(cmd, "--growth-ratio", growth_ratio, "with --layers: each layer's height over the one below", kRatio)
      ->capture_default_str();
  add_number(cmd, "--layers-max-thickness", max_thickness,
             "with --layers: the stack of layers is at most this thick (compressed where it would be more)", kLength);
  cmd->add_option("--layers-on", on,
                  "with --layers: the surfaces that grow layers, by boundary name or id, comma-separated "
                  "(default: every surface; with --farfield every surface of the body)")
      ->delimiter(',')
      ->type_name("NAMES");
}

void LayerArgs::check(const CLI::App& cmd, const std::string& output) const {
  if (layers == 0) {
    for (const char* o : {"--first-height", "--growth-ratio", "--layers-max-thickness", "--layers-on", "--reynolds",
                          "--reference-length"})
      if (cmd.count(o) > 0) usage_error(fmt::format("{}: only with --layers", o));
    return;
  }
  if (cmd.count("--first-height") == 0) usage_error("--layers: give the first layer's height with --first-height");
  const bool yplus = FirstHeightValue::parse(first_height).value_or(FirstHeightValue{}).yplus;
  if (yplus && cmd.count("--reynolds") == 0)
    usage_error(fmt::format("--first-height {}: give the Reynolds number with --reynolds", first_height));
  if (!yplus)
    for (const char* o : {"--reynolds", "--reference-length"})
      if (cmd.count(o) > 0) usage_error(fmt::format("{}: only with --first-height yplus:Y", o));
  const auto format = volume_format_from_path(output);
  if (format.ok() && !holds_mixed(*format))
    usage_error(fmt::format("--layers: {} cannot hold prisms; write a mesh with layers as {}", output,
                            mixed_volume_suffixes()));
}

Result<LayerOptions> LayerArgs::resolve(const SurfaceMesh& surface, const std::vector<int>& default_walls) const {
  LayerOptions o;
  o.layers = layers;
  const FirstHeightValue height = FirstHeightValue::parse(first_height).value_or(FirstHeightValue{});
  o.first_height = height.value;
  o.growth_ratio = growth_ratio;
  if (max_thickness > 0) o.max_thickness = max_thickness;
  if (on.empty()) o.walls = default_walls;
  const std::set<int> ids(surface.surface_ids.begin(), surface.surface_ids.end());
  for (const std::string& name : on) {
    int found = 0;
    bool matched = false;
    for (int id : ids) {
      const auto it = surface.surface_names.find(id);
      int number = 0;
      const auto [end, ec] = std::from_chars(name.data(), name.data() + name.size(), number);
      const bool as_number = ec == std::errc() && end == name.data() + name.size() && number == id;
      if ((it != surface.surface_names.end() && it->second == name) || is_default_boundary_name(id, name) || as_number) {
        found = id;
        matched = true;
        break;
      }
    }
    if (!matched) {
      std::vector<std::string> known;
      for (int id : ids) known.push_back(fmt::format("{} ({})", boundary_name(surface.surface_names, id), id));
      return invalid_input(fmt::format("--layers-on: {} names no surface of {}; its surfaces are {}", name, surface.name,
                                       fmt::join(known, ", ")));
    }
    o.walls.push_back(found);
  }
  if (height.yplus) {
    double length = reference_length;
    if (!(length > 0)) {
      const std::set<int> walls(o.walls.begin(), o.walls.end());
      Box box;
      for (std::size_t t = 0; t < surface.triangles.size(); ++t)
        if (walls.empty() || walls.count(surface.surface_ids[t]) > 0)
          for (Index v : surface.triangles[t]) box.add(surface.points[v]);
      for (int k = 0; k < 3; ++k) length = std::max(length, box.hi[k] - box.lo[k]);
    }
    PDR_ASSIGN_OR_RETURN(o.first_height, first_height_for_yplus(height.value, reynolds, length));
  }
  PDR_TRY(validate(o));
  return o;
}

std::string layer_growth_line(int layers, const LayeredResult& r) {
  return fmt::format(
      "layers: {} on {} wall triangles ({} points), stack {:.4g} to {:.4g} thick, {} stacks compressed ({:.2f} s); "
      "all {} layers at full thickness on {:.1f}% of the wall triangles, {:.1f}% of the {} smooth ones",
      layers, r.wall_triangles, r.wall_points, r.thickness_min, r.thickness_max, r.compressed_points,
      r.seconds_layers, layers, share(r.full_faces, r.wall_triangles), share(r.smooth_full_faces, r.smooth_faces),
      r.smooth_faces);
}

std::string layer_growth_json(const LayeredResult& r) {
  const nlohmann::json j = {{"wall_points", r.wall_points},
                            {"compressed_points", r.compressed_points},
                            {"thickness_min", r.thickness_min},
                            {"thickness_max", r.thickness_max},
                            {"full_thickness_faces", r.full_faces},
                            {"smooth_faces", r.smooth_faces},
                            {"smooth_full_thickness_faces", r.smooth_full_faces},
                            {"full_thickness_share", share(r.full_faces, r.wall_triangles)},
                            {"smooth_full_thickness_share", share(r.smooth_full_faces, r.smooth_faces)}};
  return j.dump();
}

}  // namespace pdrmesh::cli
