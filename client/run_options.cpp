// SPDX-License-Identifier: AGPL-3.0-or-later
// The mesh options: flags, their checks, and their translations.
#include "run_options.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "pdrmesh/estimate.hpp"
#include "pdrmesh/surface_io.hpp"

namespace pdrmesh::cli {

void SizeArgs::add_to(CLI::App* cmd) {
  cmd->add_option("--size", size,
                  "target edge length, or a percentage of the surface's bounding-box diagonal such as 1% "
                  "(with --farfield: of the body's; default: the surface's own spacing); next to surface "
                  "triangles wider than it the length starts at theirs (--hmax caps it)")
      ->check(size_check())
      ->type_name("LENGTH|PCT%");
  add_number(cmd, "--hmin", hmin, "smallest target edge length", kLength);
  add_number(cmd, "--hmax", hmax, "largest target edge length", kLength);
  add_number(cmd, "--growth", growth, "how fast the spacing may grow away from the boundary (> 1)", kGrowth)
      ->capture_default_str();
  add_number(cmd, "--max-tets", max_tets,
             "refuse before meshing when the estimated tet count is over this (default: what this machine's "
             "available memory holds)",
             kTets);
}

Status SizeArgs::check_tet_limit(const SurfaceMesh& surface, const SizingOptions& options,
                                 bool machine_default) const {
  if (max_tets <= 0 && !machine_default) return {};
  PDR_ASSIGN_OR_RETURN(const MeshEstimate e, estimate_mesh(surface, options));
  if (max_tets > 0) return pdrmesh::check_tet_limit(e, options, max_tets, "--max-tets");
  return pdrmesh::check_tet_limit(e, options, default_max_tets(), "--max-tets, from this machine's memory");
}

Result<SizingOptions> SizeArgs::job_sizing(const std::filesystem::path& path, std::string& line,
                                           const std::optional<FarfieldOptions>& farfield) const {
  SizingOptions sizing = options(0);
  line = "size: from the surface (the coordinator derives it)";
  const std::optional<SizeValue> s = size_value();
  if ((s && s->percent) || max_tets > 0) {
    PDR_ASSIGN_OR_RETURN(SurfaceMesh surface, read_surface(path));
    double body_diagonal = 0;
    if (farfield) {
      body_diagonal = surface.bounds().diagonal();
      PDR_ASSIGN_OR_RETURN(FarfieldDomain domain, make_farfield(surface, *farfield));
      surface = std::move(domain.surface);
    }
    if (s && s->percent) sizing = resolve(surface, line, /*surface_h=*/false, body_diagonal);
    PDR_TRY(check_tet_limit(surface, sizing, false));
  }
  if (s && !s->percent) line = fmt::format("size: {:.6g} (--size)", *sizing.size);
  return sizing;
}

void SizeArgs::check() const {
  if (hmin > 0 && hmax > 0 && hmin > hmax)
    usage_error(fmt::format("--hmin {} is larger than --hmax {}: the smallest length must not exceed the largest",
                            hmin, hmax));
}

SizingOptions SizeArgs::options(double diagonal) const {
  SizingOptions o;
  if (auto s = size_value()) o.size = s->length(diagonal);
  if (hmin > 0) o.hmin = hmin;
  if (hmax > 0) o.hmax = hmax;
  o.growth = growth;
  return o;
}

SizingOptions SizeArgs::resolve(const SurfaceMesh& surface, std::string& line, bool surface_h,
                                double body_diagonal) const {
  const double diagonal = body_diagonal > 0 ? body_diagonal : surface.bounds().diagonal();
  const SizingOptions o = options(diagonal);
  const std::optional<SizeValue> s = size_value();
  if (s && s->percent) {
    line = fmt::format("size: {:.6g} ({:g}% of the {}bounding-box diagonal {:.6g})", *o.size, s->value,
                       body_diagonal > 0 ? "body's " : "", diagonal);
  } else if (s) {
    line = fmt::format("size: {:.6g} (--size)", *o.size);
  }
  if (s && surface_h) {
    // Next to triangles wider than the size, h starts at their spacing (sizing.hpp).
    if (auto h = SizingField::surface_values(surface, o); h.ok()) {
      double hi = 0;
      for (double v : *h)
        if (std::isfinite(v)) hi = std::max(hi, v);
      if (hi > *o.size)
        line += fmt::format("; up to {:.6g} next to surface triangles wider than it (--hmax {:.6g} keeps it there too)",
                            hi, *o.size);
    }
  } else if (!s) {
    line = "size: from the surface";
    if (surface_h) {
      // h at the surface points: one pass over the surface, no background mesh.
      if (auto h = SizingField::surface_values(surface, o); h.ok()) {
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (double v : *h)
          if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
        if (lo <= hi) line += fmt::format(" (h from {:.6g} to {:.6g})", lo, hi);
      }
    }
  }
  return o;
}

CLI::Option* add_time_limit(CLI::App* cmd, double& seconds, const std::string& default_text) {
  return add_number(cmd, "--time-limit", seconds,
                    "seconds the whole run may take; past it the run stops, exit 75 (default: " + default_text + ")",
                    kSeconds);
}

void FarfieldArgs::add_to(CLI::App* cmd) {
  constexpr Accepts kBodyLengths{"a distance in body lengths over 0.5 and at most 1000 (10 to 20 is usual)",
                                 "LENGTHS", kMinFarfieldDistance, kMaxFarfieldDistance, true};
  CLI::Option* far = add_number(cmd, "--farfield", distance,
                                "external flow: mesh the space between the surface (the body) and a far field this "
                                "many body lengths away, patches inlet (-x), outlet (+x) and sides, or farfield",
                                kBodyLengths);
  cmd->add_option("--farfield-shape", shape, "the far field's shape: box (inlet, outlet, sides) or sphere (farfield)")
      ->check(CLI::IsMember({"box", "sphere"}))
      ->needs(far)
      ->capture_default_str();
}

std::optional<FarfieldOptions> FarfieldArgs::options() const {
  if (!(distance > 0)) return std::nullopt;
  FarfieldOptions o;
  o.distance = distance;
  o.shape = parse_farfield_shape(shape).value_or(FarfieldShape::kBox);
  return o;
}

void RunOptionArgs::add_to(CLI::App* cmd) {
  add_number(cmd, "--depth", depth,
             fmt::format("octree depth (2^d leaves a side); default: chosen from the target size and the leaves the "
                         "body occupies; at most the depth whose leaves are {:g} times the surface's spacing wide",
                         PdrOptions{}.min_leaf_width),
             kDepth);
  cmd->add_option("--kernel", kernel, "leaf kernel")->check(CLI::IsMember({"native", "tetgen"}))->capture_default_str();
  cmd->add_flag("--no-interface-round", no_interface_round, "with --kernel tetgen (leaf hulls frozen): skip the interface rounds over the grids shifted by half and a quarter leaf");
  cmd->add_flag("--no-optimize", no_optimize, "skip the final optimization");
  size.add_to(cmd);
  add_names_option(cmd, names);
  farfield.add_to(cmd);
}

ParallelOptions RunOptionArgs::parallel_options(const SizingOptions& sizing) const {
  ParallelOptions o;
  o.sizing = sizing;
  o.pdr.depth = depth;
  o.pdr.interface_round = !no_interface_round;
  if (no_optimize) o.optimize.reset();
  return o;
}

v1::MeshOptions RunOptionArgs::mesh_options(const SizingOptions& s) const {
  v1::MeshOptions o;
  if (s.size) o.set_size(*s.size);
  if (s.hmin) o.set_hmin(*s.hmin);
  if (s.hmax) o.set_hmax(*s.hmax);
  o.set_growth(s.growth);
  if (depth >= 0) o.set_depth(depth);
  o.set_kernel(kernel);
  o.set_interface_round(!no_interface_round);
  o.set_optimize(!no_optimize);
  if (const auto f = farfield.options()) {
    o.set_farfield(f->distance);
    o.set_farfield_shape(std::string(to_string(f->shape)));
  }
  return o;
}

}  // namespace pdrmesh::cli
