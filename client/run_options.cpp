// SPDX-License-Identifier: AGPL-3.0-or-later
// The run/submit mesh options: flags, and their two translations.
#include "run_options.hpp"

#include "pdrmesh/estimate.hpp"

namespace pdrmesh::cli {

void SizeArgs::add_to(CLI::App* cmd) {
  cmd->add_option("--size", size, "uniform target edge length (default: the surface's own spacing)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--hmin", hmin, "smallest target edge length")->check(CLI::PositiveNumber);
  cmd->add_option("--hmax", hmax, "largest target edge length")->check(CLI::PositiveNumber);
  cmd->add_option("--growth", growth, "how fast the spacing may grow away from the boundary (> 1)")
      ->capture_default_str();
  cmd->add_option("--max-tets", max_tets,
                  "refuse before meshing when the estimated tet count is over this "
                  "(default: what this machine's available memory holds)")
      ->check(CLI::PositiveNumber);
}

Status SizeArgs::check_tet_limit(const SurfaceMesh& surface, bool machine_default) const {
  if (max_tets <= 0 && !machine_default) return {};
  const SizingOptions o = options();
  PDR_ASSIGN_OR_RETURN(const MeshEstimate e, estimate_mesh(surface, o));
  if (max_tets > 0) return pdrmesh::check_tet_limit(e, o, max_tets, "--max-tets");
  return pdrmesh::check_tet_limit(e, o, default_max_tets(), "--max-tets, from this machine's memory");
}

SizingOptions SizeArgs::options() const {
  SizingOptions o;
  if (size > 0) o.size = size;
  if (hmin > 0) o.hmin = hmin;
  if (hmax > 0) o.hmax = hmax;
  o.growth = growth;
  return o;
}

void RunOptionArgs::add_to(CLI::App* cmd) {
  cmd->add_option("--depth", depth, "octree depth (2^d leaves a side); default: chosen from the target size and the leaves the body occupies")
      ->check(CLI::Range(0, 10));
  cmd->add_option("--kernel", kernel, "leaf kernel")->check(CLI::IsMember({"native", "tetgen"}))->capture_default_str();
  cmd->add_flag("--no-interface-round", no_interface_round, "skip the interface rounds (decompositions shifted by half and a quarter leaf, over the first round's interfaces)");
  cmd->add_flag("--no-optimize", no_optimize, "skip the final optimization");
  size.add_to(cmd);
}

ParallelOptions RunOptionArgs::parallel_options() const {
  ParallelOptions o;
  o.sizing = size.options();
  o.pdr.depth = depth;
  o.pdr.interface_round = !no_interface_round;
  if (no_optimize) o.optimize.reset();
  return o;
}

v1::MeshOptions RunOptionArgs::mesh_options() const {
  v1::MeshOptions o;
  const SizingOptions s = size.options();
  if (s.size) o.set_size(*s.size);
  if (s.hmin) o.set_hmin(*s.hmin);
  if (s.hmax) o.set_hmax(*s.hmax);
  o.set_growth(s.growth);
  if (depth >= 0) o.set_depth(depth);
  o.set_kernel(kernel);
  o.set_interface_round(!no_interface_round);
  o.set_optimize(!no_optimize);
  return o;
}

}  // namespace pdrmesh::cli
