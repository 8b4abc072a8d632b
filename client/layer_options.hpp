// SPDX-License-Identifier: AGPL-3.0-or-later
// The prism-layer options of `pdrmesh mesh` (--layers, --first-height,
// --growth-ratio, --layers-max-thickness, --layers-on, --layers-in) and their checks.
#pragma once

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pdrmesh/layered_pipeline.hpp"
#include "pdrmesh/layers.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"

namespace pdrmesh::cli {

/// --first-height: a length, or "yplus:Y", a wall distance of Y wall units
/// turned into a length by first_height_for_yplus (layers.hpp) with --reynolds.
struct FirstHeightValue {
  double value = 0;  ///< the length, or Y
  bool yplus = false;

  /// nullopt unless `text` is a positive finite length or yplus:Y with Y positive and finite.
  static std::optional<FirstHeightValue> parse(std::string_view text);
};

struct LayerArgs {
  int layers = 0;  ///< 0: no layers
  std::string first_height;  ///< FirstHeightValue's text
  double reynolds = 0;          ///< with yplus:Y
  double reference_length = 0;  ///< of --reynolds; 0: the walls' length
  double growth_ratio = 1.2;
  double max_thickness = 0;  ///< 0: no cap
  std::vector<std::string> on;  ///< boundary names or ids; empty: every surface
  std::vector<std::string> in;  ///< region names or ids (LayerOptions::regions)

  void add_to(CLI::App* cmd);
  /// Usage errors across options, after parsing: --first-height needed with
  /// --layers, the other layer options only with it.
  void check(const CLI::App& cmd) const;
  /// The options as given (names and a y+ unresolved): what a job carries.
  LayerRequest request() const;
  /// resolve_layers (layers.hpp) of request() on `surface`; without
  /// --layers-on the walls are `default_walls` (empty: every surface; with
  /// --farfield the body's ids, so that the far-field patches grow none).
  Result<LayerOptions> resolve(const SurfaceMesh& surface, const std::vector<int>& default_walls = {}) const;
};

/// The report line of grown layers: stacks, thickness, compression and the
/// layers reached (wall triangles whose stacks kept all N layers at their
/// full thickness, of all and of the smooth ones).
std::string layer_growth_line(int layers, const LayeredResult& r);
/// The same figures as a JSON object (wall_points, compressed_points, stopped_points,
/// thickness_min/max, full_thickness_faces, smooth_faces,
/// smooth_full_thickness_faces, full_thickness_share, smooth_full_thickness_share).
std::string layer_growth_json(const LayeredResult& r);

}  // namespace pdrmesh::cli
