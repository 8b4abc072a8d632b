// SPDX-License-Identifier: AGPL-3.0-or-later
// The mesh options of `pdrmesh run` and `pdrmesh submit`, declared once: the
// same flags become ParallelOptions for a local run and v1::MeshOptions for a
// job, so a job with the same flags gives the same bytes as the local run.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/v1/pdrmesh.pb.h"

namespace pdrmesh::cli {

/// Size options shared by the commands that refine (the point distribution function).
struct SizeArgs {
  double size = 0, hmin = 0, hmax = 0, growth = 1.2;
  double max_tets = 0;  ///< --max-tets; 0: from this machine's memory (default_max_tets)

  void add_to(CLI::App* cmd);
  SizingOptions options() const;
  /// Estimates the mesh of `surface` with these options (estimate.hpp) and
  /// refuses (invalid_input, with the estimate and the smallest sensible
  /// --size) when it is over --max-tets, or over this machine's memory when
  /// --max-tets is not given and `machine_default` is set.
  Status check_tet_limit(const SurfaceMesh& surface, bool machine_default) const;
};

/// --depth --kernel --no-interface-round --no-optimize and the size options.
struct RunOptionArgs {
  SizeArgs size;
  int depth = -1;
  std::string kernel = "native";
  bool no_interface_round = false;
  bool no_optimize = false;

  void add_to(CLI::App* cmd);
  /// For mesh_parallel (workers 1, no progress hook: the caller sets them).
  ParallelOptions parallel_options() const;
  /// For a job (time limit unset: the caller sets it).
  v1::MeshOptions mesh_options() const;
};

}  // namespace pdrmesh::cli
