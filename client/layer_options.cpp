// SPDX-License-Identifier: AGPL-3.0-or-later
#include "layer_options.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <limits>

#include "options.hpp"
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
  cmd->add_option("--layers-in", in,
                  "with --layers, for a surface of several regions (nested shells): the regions on whose side "
                  "the walls grow layers, by name or id, comma-separated (the others get tets only)")
      ->delimiter(',')
      ->type_name("REGIONS");
}

void LayerArgs::check(const CLI::App& cmd) const {
  if (layers == 0) {
    for (const char* o : {"--first-height", "--growth-ratio", "--layers-max-thickness", "--layers-on", "--layers-in",
                          "--reynolds", "--reference-length"})
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
}

LayerRequest LayerArgs::request() const {
  LayerRequest r;
  r.layers = layers;
  const FirstHeightValue height = FirstHeightValue::parse(first_height).value_or(FirstHeightValue{});
  r.first_height = height.value;
  r.yplus = height.yplus;
  r.reynolds = reynolds;
  r.reference_length = reference_length;
  r.growth_ratio = growth_ratio;
  if (max_thickness > 0) r.max_thickness = max_thickness;
  r.on = on;
  r.in = in;
  return r;
}

Result<LayerOptions> LayerArgs::resolve(const SurfaceMesh& surface, const std::vector<int>& default_walls) const {
  return resolve_layers(request(), surface, default_walls);
}

std::string layer_growth_line(int layers, const LayeredResult& r) {
  return fmt::format(
      "layers: {} on {} wall triangles ({} points), stack {:.4g} to {:.4g} thick, {} stacks thinner, {} of them "
      "with fewer layers ({:.2f} s); all {} layers at full thickness on {:.1f}% of the wall triangles, {:.1f}% of "
      "the {} smooth ones",
      layers, r.wall_triangles, r.wall_points, r.thickness_min, r.thickness_max, r.compressed_points,
      r.stopped_points, r.seconds_layers, layers, share(r.full_faces, r.wall_triangles), share(r.smooth_full_faces, r.smooth_faces),
      r.smooth_faces);
}

std::string layer_growth_json(const LayeredResult& r) {
  const nlohmann::json j = {{"wall_points", r.wall_points},
                            {"compressed_points", r.compressed_points},
                            {"stopped_points", r.stopped_points},
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
