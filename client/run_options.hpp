// SPDX-License-Identifier: AGPL-3.0-or-later
// The mesh options of `pdrmesh mesh`, `run` and `submit`, declared once: the
// same flags become SerialOptions, ParallelOptions for a local run and
// v1::MeshOptions for a job, so a job with the same flags gives the same bytes
// as the local run.
#pragma once

#include <CLI/CLI.hpp>

#include <filesystem>
#include <optional>
#include <string>

#include "options.hpp"
#include "pdrmesh/farfield.hpp"
#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/v1/pdrmesh.pb.h"

namespace pdrmesh::cli {

/// Size options shared by the commands that refine (the point distribution function).
struct SizeArgs {
  std::string size;  ///< a length or a percentage ("1%"); empty: from the surface
  double hmin = 0, hmax = 0, growth = 1.2;
  double max_tets = 0;  ///< --max-tets; 0: from this machine's memory (default_max_tets)

  void add_to(CLI::App* cmd);
  /// The checks across options (hmin <= hmax); a usage error otherwise.
  void check() const;
  std::optional<SizeValue> size_value() const { return size.empty() ? std::nullopt : SizeValue::parse(size); }
  /// The options for a surface whose bounding-box diagonal is `diagonal` (used by a percentage only).
  SizingOptions options(double diagonal) const;
  /// The sizing options for `surface`, and the line that says which spacing
  /// they give ("size: 0.59 (1% of the bounding-box diagonal 59.16)"); with
  /// `surface_h`, the default's range at the surface points is worked out too.
  SizingOptions resolve(const SurfaceMesh& surface, std::string& line, bool surface_h = true) const;
  /// Estimates the mesh of `surface` with `options` (estimate.hpp) and refuses
  /// (with the estimate and the smallest sensible --size) when it is over
  /// --max-tets, or over this machine's memory when --max-tets is not given
  /// and `machine_default` is set.
  Status check_tet_limit(const SurfaceMesh& surface, const SizingOptions& options, bool machine_default) const;
  /// The sizing options of a job on the surface file `path`: a percentage
  /// becomes a length from the surface's bounding box (the coordinator takes
  /// lengths) and --max-tets is checked against the estimate (the coordinator
  /// checks its own limits in any case); the file is read only for those.
  /// `line` says which size the job asks for. With `farfield`, the surface is
  /// the domain around the file's body, as the coordinator makes it.
  Result<SizingOptions> job_sizing(const std::filesystem::path& path, std::string& line,
                                   const std::optional<FarfieldOptions>& farfield) const;
};

/// --farfield DISTANCE and --farfield-shape box|sphere: mesh the space around
/// the surface, out to a far field that many body lengths away (farfield.hpp).
struct FarfieldArgs {
  double distance = 0;  ///< body lengths; 0: no far field
  std::string shape = "box";

  void add_to(CLI::App* cmd);
  /// The far field asked for; nullopt without --farfield.
  std::optional<FarfieldOptions> options() const;
};

/// Adds --time-limit: seconds the whole run may take (a deadline, exit 75 past it).
CLI::Option* add_time_limit(CLI::App* cmd, double& seconds, const std::string& default_text);

/// --depth --kernel --no-interface-round --no-optimize --names and the size options.
struct RunOptionArgs {
  SizeArgs size;
  FarfieldArgs farfield;
  std::string names;  ///< --names FILE; empty: none (read by the command, not by mesh_options)
  int depth = -1;
  std::string kernel = "native";
  bool no_interface_round = false;
  bool no_optimize = false;

  void add_to(CLI::App* cmd);
  /// For mesh_parallel (workers 1, no progress hook: the caller sets them).
  ParallelOptions parallel_options(const SizingOptions& sizing) const;
  /// For a job (time limit unset: the caller sets it).
  v1::MeshOptions mesh_options(const SizingOptions& sizing) const;
};

}  // namespace pdrmesh::cli
