// SPDX-License-Identifier: AGPL-3.0-or-later
#include "local_commands.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/parallel_invoke.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "exit_codes.hpp"
#include "layer_options.hpp"
#include "options.hpp"
#include "progress_display.hpp"
#include "run_options.hpp"
#include "pdrmesh/boundary_names.hpp"
#include "pdrmesh/boundary_names_io.hpp"
#include "pdrmesh/farfield.hpp"
#include "pdrmesh/layered_pipeline.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/mixed_cells.hpp"
#include "pdrmesh/pdr_profile.hpp"
#include "pdrmesh/optimize.hpp"
#include "pdrmesh/pdr.hpp"
#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/foam_quality.hpp"
#include "pdrmesh/quality.hpp"
#include "pdrmesh/refine.hpp"
#include "pdrmesh/regions.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/stopwatch.hpp"
#include "pdrmesh/surface_check.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/tet_mesh.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"

namespace pdrmesh::cli {
namespace {

using Progress = ProgressDisplay;

int fail(const Status& s) {
  fmt::print(stderr, "pdrmesh: error: {}\n", s.to_string());
  return exit_code_for(s);
}

/// A failure of a run with --time-limit: a deadline hit anywhere (TetGen, a
/// step of the pipeline, the engine told to stop) is said as the run's limit.
int fail_run(const Status& s, double time_limit_s, bool stopped_by_us = false) {
  if (time_limit_s > 0 && (stopped_by_us || s.code() == StatusCode::kDeadlineExceeded))
    return fail(deadline_exceeded(
        fmt::format("the time limit (--time-limit {} s) ran out: {}", time_limit_s, s.message())));
  return fail(s);
}

Status write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) return io_error(fmt::format("{}: cannot write the file", path));
  return {};
}

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// Seconds of the steps around the meshing, for `run --profile`.
struct StepTimes {
  double read = 0, check = 0, validation = 0, write = 0, quality = 0;
  double overlapped = 0;  ///< of validation + write + quality: the time they ran side by side
};

/// Puts the names of the --names file `names_path` (empty: none) over the
/// surface's own names.
Status apply_names_file(const std::string& names_path, const std::vector<int>& ids, std::map<int, std::string>& names) {
  if (names_path.empty()) return {};
  PDR_ASSIGN_OR_RETURN(const auto given, read_boundary_names(names_path));
  return merge_boundary_names(names, ids, given, names_path);
}

/// "boundary names: 1 inlet, 2 outlet" for the progress lines; empty without names.
std::string names_line(const std::map<int, std::string>& names) {
  if (names.empty()) return {};
  std::vector<std::string> items;
  for (const auto& [id, name] : names) items.push_back(fmt::format("{} {}", id, name));
  return fmt::format("boundary names: {}", fmt::join(items, ", "));
}

/// ", N regions: NAME, ..." when the surface has interfaces (regions.hpp), else empty.
std::string regions_note(const SurfaceMesh& surface, const SurfaceReport& report) {
  const auto regions = surface_regions(surface, report);
  if (!regions.ok() || regions->empty()) return {};
  std::vector<std::string> names;
  for (const SurfaceRegion& r : *regions) names.push_back(fmt::format("{} {}", r.id, r.name));
  return fmt::format(", {} regions: {}", regions->size(), fmt::join(names, ", "));
}

/// Per region of a mesh (none without tet_regions): id, name, tets.
struct RegionCount {
  int id;
  std::string name;
  std::size_t tets = 0, prisms = 0, pyramids = 0;
};
std::vector<RegionCount> region_counts(const VolumeMesh& mesh) {
  std::map<int, RegionCount> n;
  for (int r : mesh.tet_regions) ++n[r].tets;
  for (int r : mesh.prism_regions) ++n[r].prisms;
  for (int r : mesh.pyramid_regions) ++n[r].pyramids;
  std::vector<RegionCount> out;
  for (auto& [id, count] : n) {
    count.id = id;
    count.name = region_name(mesh.region_names, id);
    out.push_back(count);
  }
  return out;
}

/// quality's line of cells per region ("regions: 1 fluid: 120 tets and 36 prisms, 2 body: 40 tets").
std::string format_region_counts(const std::vector<RegionCount>& regions) {
  if (regions.empty()) return {};
  std::vector<std::string> items;
  for (const RegionCount& r : regions) {
    std::string cells = fmt::format("{} tets", r.tets);
    if (r.prisms > 0) cells += fmt::format(" and {} prisms", r.prisms);
    if (r.pyramids > 0) cells += fmt::format(" and {} pyramids", r.pyramids);
    items.push_back(fmt::format("{} {}: {}", r.id, r.name, cells));
  }
  return fmt::format("regions: {}\n", fmt::join(items, ", "));
}

nlohmann::json region_counts_json(const std::vector<RegionCount>& regions) {
  nlohmann::json a = nlohmann::json::array();
  for (const RegionCount& r : regions)
    a.push_back({{"id", r.id}, {"name", r.name}, {"tets", r.tets}, {"prisms", r.prisms}, {"pyramids", r.pyramids}});
  return a;
}

/// Reads and checks a surface, with the names of a --names file (`names_path`,
/// empty: none), and with `farfield` the domain around it (farfield.hpp) in its
/// place, `body_diagonal` then the body's bounding-box diagonal (0 without)
/// and `body_ids` (when given) the body's surface ids; on failure prints why
/// and returns the exit code.
int load_checked_surface(const std::string& path, const std::string& names_path,
                         const std::optional<FarfieldOptions>& farfield, Progress& progress, SurfaceMesh& out,
                         double& body_diagonal, StepTimes* times = nullptr, std::vector<int>* body_ids = nullptr) {
  body_diagonal = 0;
  auto t = Clock::now();
  auto surface = read_surface(path);
  if (!surface.ok()) return fail(surface.status());
  if (Status s = apply_names_file(names_path, surface->surface_ids, surface->surface_names); !s.ok()) return fail(s);
  if (times) times->read = seconds_since(t);
  progress.say("read {}: {} points, {} triangles", path, surface->points.size(), surface->triangles.size());
  if (farfield) {
    body_diagonal = surface->bounds().diagonal();
    auto domain = make_farfield(*surface, *farfield);
    if (!domain.ok()) return fail(domain.status());
    progress.say("far field: a {} {:g} body lengths (L = {:.6g}) from the body, {} triangles of about {:.6g}",
                 to_string(farfield->shape), farfield->distance, domain->body_length, domain->farfield_triangles,
                 domain->farfield_size);
    if (body_ids) *body_ids = domain->body_ids();
    *surface = std::move(domain->surface);
  }
  if (!surface->surface_names.empty()) progress.say("{}", names_line(surface->surface_names));
  t = Clock::now();
  const SurfaceReport report = check_surface(*surface);
  if (times) times->check = seconds_since(t);
  if (Status s = require_meshable(report, path); !s.ok()) return fail(s);
  progress.say("surface check passed: {} component(s){}", report.components.size(), regions_note(*surface, report));
  out = std::move(surface).value();
  return kExitOk;
}

/// What a meshing command reports at its end besides the file.
struct Outcome {
  const std::string* output = nullptr;
  const std::string* surface = nullptr;
  std::string size_line;  ///< "size: ..." (SizeArgs::resolve)
  std::optional<double> size;
  bool json = false;  ///< print the result as one JSON object on stdout
  nlohmann::json layer_growth;  ///< with --layers: layer_growth_json, added to the result's "layers"
};

/// The --json result of mesh and run: the files, the size used, the counts and the quality.
void print_result_json(const Outcome& o, const VolumeMesh& mesh, const QualityReport& q) {
  nlohmann::json j = {{"surface", *o.surface},
                      {"output", *o.output},
                      {"size", o.size ? nlohmann::json(*o.size) : nlohmann::json(nullptr)},
                      {"size_text", o.size_line},
                      {"tets", mesh.tets.size()},
                      {"points", mesh.points.size()},
                      {"quality", nlohmann::json::parse(quality_to_json(q))}};
  if (mesh.mixed()) j["layers"] = nlohmann::json::parse(layers_to_json(measure_layers(mesh)));
  if (o.layer_growth.is_object()) j["layers"].update(o.layer_growth);
  fmt::print("{}\n", j.dump());
}

/// The end of every meshing command: validate against the surface (a failure
/// is our bug, never the user's), write, and print the quality summary (and
/// with --json the result on stdout). The validation runs beside the write and
/// the summary (when the thread budget allows): the file is staged and goes in
/// place only once the mesh validated.
int finish(const VolumeMesh& mesh, const SurfaceMesh& surface, const Outcome& o, bool validate,
           Progress& progress, bool quiet, StepTimes* times = nullptr) {
  StepTimes local;
  StepTimes& st = times ? *times : local;
  const auto t0 = Clock::now();
  ValidationReport report;
  Result<StagedVolume> staged = StagedVolume{};
  QualityReport quality;
  tbb::parallel_invoke(
      [&] {
        if (!validate) return;
        const auto t = Clock::now();
        report = validate_mesh(mesh, &surface);
        st.validation = seconds_since(t);
      },
      [&] {
        auto t = Clock::now();
        staged = stage_volume(mesh, *o.output);
        st.write = seconds_since(t);
        if ((quiet && !o.json) || !staged.ok()) return;
        t = Clock::now();
        quality = measure_quality(mesh);
        st.quality = seconds_since(t);
      });
  st.overlapped = std::max(0.0, st.validation + st.write + st.quality - seconds_since(t0));
  if (validate) {
    if (!report.ok()) {
      fmt::print(stderr, "{}", format_validation(report));
      return fail(internal_error("the generated mesh failed validation; please report this with the input"));
    }
    progress.say("validated: conforming, positive, boundary identical to the input, volume conserved{}",
                 report.regions > 0 ? fmt::format("; {} regions, {} interface faces shared by the regions they separate",
                                                  report.regions, report.interface_faces)
                                    : std::string());
  }
  if (!staged.ok()) return fail(staged.status());
  if (Status s = staged->commit(); !s.ok()) return fail(s);
  progress.say("wrote {}", *o.output);
  if (!quiet) fmt::print(stderr, "{}{}", format_quality(quality), format_layers(measure_layers(mesh)));
  if (o.json) print_result_json(o, mesh, quality);
  return kExitOk;
}

/// The deadline of --time-limit (0: none), from now.
std::optional<Clock::time_point> deadline_after(double seconds) {
  if (!(seconds > 0)) return std::nullopt;
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

int run_check(const std::string& path, bool json, bool no_self_intersections) {
  auto surface = read_surface(path);
  if (!surface.ok()) return fail(surface.status());
  CheckOptions options;
  options.self_intersections = !no_self_intersections;
  const SurfaceReport report = check_surface(*surface, options);
  const Result<std::vector<SurfaceRegion>> regions =
      report.meshable() ? surface_regions(*surface, report) : Result<std::vector<SurfaceRegion>>(std::vector<SurfaceRegion>{});
  if (json) {
    auto j = nlohmann::json::parse(report_to_json(report, path));
    j["regions"] = nlohmann::json::array();
    if (regions.ok())
      for (const SurfaceRegion& r : *regions)
        j["regions"].push_back({{"id", r.id}, {"name", r.name}, {"triangles", r.domain.triangles.size()}});
    fmt::print("{}\n", j.dump());
  } else {
    fmt::print("{}", format_report(report, path));
    if (regions.ok() && !regions->empty()) {
      fmt::print("  {} regions (shells inside shells of the same orientation are interfaces):\n", regions->size());
      for (const SurfaceRegion& r : *regions)
        fmt::print("    region {} {}: {} triangles with its interfaces and cavities\n", r.id, r.name,
                   r.domain.triangles.size());
    }
  }
  return report.meshable() ? kExitOk : kExitBadInput;
}

struct MeshArgs {
  std::string surface;
  std::string output;
  double max_volume = 0;
  double time_limit_s = 0;  ///< 0: none
  bool quiet = false;
  bool json = false;
  bool no_validate = false;
  bool no_refine = false;
  bool no_optimize = false;
  SizeArgs size;
  std::string names;  ///< --names FILE; empty: none
  LayerArgs layers;
  bool growth_given = false;  ///< --growth on the command line (else the layers' ratio continues)
  FarfieldArgs farfield;
};

/// `mesh --layers`: prisms on the walls (by default every surface but the far
/// field's: `body_ids` with --farfield), the serial pipeline for the rest.
int run_mesh_layered(const MeshArgs& a, const SurfaceMesh& surface, const std::vector<int>& body_ids,
                     SerialOptions options, Outcome& outcome, Progress& progress) {
  auto layers = a.layers.resolve(surface, body_ids);
  if (!layers.ok()) return fail(layers.status());
  if (!a.growth_given && layers->growth_ratio > 1) options.sizing.growth = layers->growth_ratio;
  auto result = mesh_serial_layered(surface, *layers, options, [&progress](const RefinePassStats& p) {
    progress.say("pass {}: {} candidates, {} inserted, {} flips, {} tets", p.pass, p.candidates, p.inserted,
                 p.flips, p.tets);
  });
  if (!result.ok()) return fail_run(result.status(), a.time_limit_s);
  progress.say("{}", layer_growth_line(layers->layers, *result));
  outcome.layer_growth = nlohmann::json::parse(layer_growth_json(*result));
  progress.say("mixed mesh: {} prisms, {} tets, {} points", result->mesh.prisms.size(), result->mesh.tets.size(),
               result->mesh.points.size());
  return finish(result->mesh, surface, outcome, !a.no_validate, progress, a.quiet);
}

int run_mesh(const MeshArgs& a) {
  Progress progress(a.quiet);
  const auto start = Clock::now();
  SurfaceMesh surface;
  double body_diagonal = 0;
  std::vector<int> body_ids;
  if (int code = load_checked_surface(a.surface, a.names, a.farfield.options(), progress, surface, body_diagonal,
                                      nullptr, &body_ids);
      code != kExitOk)
    return code;
  // The time limit counts from the start: what reading and checking took is gone.
  const double left_s = a.time_limit_s > 0 ? a.time_limit_s - seconds_since(start) : 0;
  if (a.time_limit_s > 0 && !(left_s > 0))
    return fail_run(deadline_exceeded("it ran out while the surface was read and checked"), a.time_limit_s);
  Outcome outcome{&a.output, &a.surface, {}, std::nullopt, a.json, {}};

  if (a.no_refine) {
    TetgenOptions options;
    if (a.max_volume > 0) options.max_volume = a.max_volume;
    if (left_s > 0) options.time_limit_s = std::min(options.time_limit_s, left_s);
    auto mesh = tetrahedralize(surface, options);
    if (!mesh.ok()) return fail_run(mesh.status(), a.time_limit_s);
    progress.say("initial mesh (TetGen -{}): {} tets, {} points", tetgen_switches(options), mesh->tets.size(),
                 mesh->points.size());
    return finish(*mesh, surface, outcome, !a.no_validate, progress, a.quiet);
  }

  SerialOptions options;
  options.sizing = a.size.resolve(surface, outcome.size_line, true, body_diagonal);
  outcome.size = options.sizing.size;
  progress.say("{}", outcome.size_line);
  if (Status s = a.size.check_tet_limit(surface, options.sizing, true); !s.ok()) return fail(s);
  options.time_limit_s = left_s;
  if (a.no_optimize) options.optimize.reset();
  if (a.layers.layers > 0) return run_mesh_layered(a, surface, body_ids, options, outcome, progress);
  auto result = mesh_serial(surface, options, [&progress](const RefinePassStats& p) {
    progress.say("pass {}: {} candidates, {} inserted, {} flips, {} tets", p.pass, p.candidates, p.inserted,
                 p.flips, p.tets);
  });
  if (!result.ok()) return fail_run(result.status(), a.time_limit_s);
  progress.say("refined: {} tets, {} points (initial mesh {:.2f} s, sizing {:.2f} s, refinement {:.2f} s, "
               "optimization {:.2f} s)",
               result->mesh.tets.size(), result->mesh.points.size(), result->seconds_initial,
               result->seconds_sizing, result->seconds_refine, result->seconds_optimize);
  if (options.optimize) progress.say("optimization: {}", outcome_summary(result->optimize));
  return finish(result->mesh, surface, outcome, !a.no_validate, progress, a.quiet);
}

struct RunArgs {
  std::string surface;
  std::string output;
  std::size_t workers = 1;
  bool profile = false;
  std::string profile_json;
  double time_limit_s = 0;  ///< 0: none
  bool quiet = false;
  bool json = false;
  RunOptionArgs mesh;
  LayerArgs layers;
  bool growth_given = false;  ///< --growth on the command line (else the layers' ratio continues)
};

/// The whole run's profile: every step from reading the surface to the
/// quality summary, each with its share of the wall time.
void print_profile(const PdrProfile& p) {
  const double wall = p.wall > 0 ? p.wall : (p.total > 0 ? p.total : 1);
  fmt::print(stderr, "profile: depth {}, {} leaves (+{} in the interface round), {} initial tets, {} final tets, "
                     "max concurrency {}\n",
             p.depth, p.leaf_count, p.interface_leaf_count, p.initial_tets, p.final_tets, p.max_concurrency);
  const std::pair<const char*, double> phases[] = {
      {"read", p.read},
      {"surface check", p.surface_check},
      {"TetGen mesh", p.background},
      {"sizing", p.sizing},
      {"seeds", p.initial},
      {"decomposition", p.decomposition},
      {"fix-ups", p.fixups},
      {"leaf refinement", p.leaves},
      {"merge", p.merge},
      {"interface round", p.interface_round},
      {"optimization", p.optimization},
      {" leaf rounds", p.optimization_leaves},
      {" global pass", p.global_optimization},
      {"validation", p.validation},
      {"write", p.write},
      {"quality", p.quality}};
  for (const auto& [name, s] : phases)
    fmt::print(stderr, "  {:<16} {:9.3f} s {:6.1f}%\n", name, s, 100 * s / wall);
  if (p.overlapped > 0) {
    fmt::print(stderr, "  {:<16} {:9.3f} s {:6.1f}% (steps run side by side: validation beside the write)\n",
               "overlapped", -p.overlapped, -100 * p.overlapped / wall);
  }
  fmt::print(stderr, "  {:<16} {:9.3f} s; engine {:.3f} s; fix-ups moved {} tets by partition swap, {} by "
                     "boundary extraction\n",
             "wall", wall, p.total, p.fixup_swaps, p.fixup_moves);
  fmt::print(stderr, "  leaf tasks {:.3f} s in all rounds; serial (outside the leaf schedules) {:.1f}%\n",
             p.task_busy, 100 * serial_seconds(p) / wall);
}

int run_run(const RunArgs& a) {
  const auto t_wall = Clock::now();
  const double cpu0 = process_cpu_seconds();
  const std::optional<Clock::time_point> deadline = deadline_after(a.time_limit_s);
  // --workers N is the whole run's thread budget: the leaf schedules and every
  // parallel step around them (surface check, sizing, sorts, validation).
  const tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::max<std::size_t>(a.workers, 1));
  Progress progress(a.quiet);
  SurfaceMesh surface;
  StepTimes times;
  double body_diagonal = 0;
  std::vector<int> body_ids;
  const int loaded = load_checked_surface(a.surface, a.mesh.names, a.mesh.farfield.options(), progress, surface,
                                          body_diagonal, &times, &body_ids);
  if (loaded != kExitOk) return loaded;
  std::optional<LayerOptions> layers;
  if (a.layers.layers > 0) {
    auto resolved = a.layers.resolve(surface, body_ids);
    if (!resolved.ok()) return fail(resolved.status());
    layers = *resolved;
  }

  auto kernel = make_leaf_kernel(a.mesh.kernel);
  if (!kernel.ok()) return fail(kernel.status());
  Outcome outcome{&a.output, &a.surface, {}, std::nullopt, a.json, {}};
  ParallelOptions options = a.mesh.parallel_options(a.mesh.size.resolve(surface, outcome.size_line, true, body_diagonal));
  outcome.size = options.sizing.size;
  progress.say("{}", outcome.size_line);
  if (Status s = a.mesh.size.check_tet_limit(surface, options.sizing, true); !s.ok()) return fail(s);
  if (layers && !a.growth_given && layers->growth_ratio > 1) options.sizing.growth = layers->growth_ratio;
  options.pdr.workers = a.workers;
  if (a.time_limit_s > 0) options.pdr.tetgen_time_limit_s = std::min(options.pdr.tetgen_time_limit_s, a.time_limit_s);
  progress.update({"sizing"});
  // The progress hook is where the engine asks whether to go on: past the
  // deadline it says no, and the run stops at its next phase or merged leaf.
  bool timed_out = false;
  options.pdr.progress = [&progress, &deadline, &timed_out](const PdrProgress& p) {
    if (deadline && Clock::now() >= *deadline) {
      timed_out = true;
      return false;
    }
    progress.update({std::string(p.phase), p.leaves_done, p.leaves_total, p.tets});
    return true;
  };
  // With layers: the layers made serially as `mesh` makes them, the tets that
  // fill the rest by the parallel method.
  std::optional<LayeredParallelResult> layered;
  Result<ParallelResult> result = ParallelResult{};
  if (layers) {
    auto r = mesh_parallel_layered(surface, *layers, options, kernel->get());
    if (r.ok()) {
      layered = std::move(r).value();
      result = std::move(layered->fill);
    } else {
      result = r.status();
    }
  } else {
    result = mesh_parallel(surface, options, kernel->get());
  }
  progress.finish();
  if (!result.ok()) return fail_run(result.status(), a.time_limit_s, timed_out);
  if (deadline && Clock::now() >= *deadline)
    return fail_run(deadline_exceeded("it ran out before the mesh was done"), a.time_limit_s);
  if (layered) {
    const LayeredResult& l = layered->layered;
    progress.say("{}", layer_growth_line(layers->layers, l));
    outcome.layer_growth = nlohmann::json::parse(layer_growth_json(l));
    result->mesh = std::move(layered->layered.mesh);
  }
  const VolumeMesh& mesh = result->mesh;
  PdrProfile& profile = result->profile;
  progress.say("point distribution function built from {} boundary points", result->boundary_points);
  progress.say("parallel refinement ({} kernel, {} worker(s), depth {}): {} tets, {} points", (*kernel)->name(),
               a.workers, profile.depth, mesh.tets.size(), mesh.points.size());
  if (profile.requested_depth > profile.depth)
    progress.say("note: depth {} would make leaves narrower than {} times the surface's spacing, where the parallel "
                 "mesh drifts from the serial one; meshed at depth {}",
                 profile.requested_depth, options.pdr.min_leaf_width, profile.depth);

  if (profile.failed_leaves > 0) {
    progress.say("warning: {} leaf task(s) failed and were kept unrefined (first: {})", profile.failed_leaves,
                 profile.first_failure);
  }
  if (int code = finish(mesh, surface, outcome, true, progress, a.quiet, &times); code != kExitOk) return code;
  profile.read = times.read;
  profile.surface_check = times.check;
  profile.validation = times.validation;
  profile.write = times.write;
  profile.quality = times.quality;
  profile.overlapped += times.overlapped;
  profile.wall = seconds_since(t_wall);
  profile.cpu = process_cpu_seconds() - cpu0;
  if (a.profile) print_profile(profile);
  if (!a.profile_json.empty()) {
    if (Status s = write_text(a.profile_json, profile_to_json(profile, a.workers)); !s.ok()) return fail(s);
  }
  return kExitOk;
}

int run_quality(const std::string& path, bool json, const std::string& svg) {
  auto mesh = read_volume(path);
  if (!mesh.ok()) return fail(mesh.status());
  if (mesh->mixed()) {
    // The tet measures below cover the tets alone; the prisms get the layer figures.
    const LayerReport layers = measure_layers(*mesh);
    const QualityReport q = measure_quality(*mesh, /*interior=*/true);
    const std::vector<RegionCount> regions = region_counts(*mesh);
    if (json) {
      auto j = nlohmann::json::parse(quality_to_json(q));
      j["layers"] = nlohmann::json::parse(layers_to_json(layers));
      j["openfoam"] = {{"error", "not measured on a mesh with prisms or pyramids"}};
      j["regions"] = region_counts_json(regions);
      fmt::print("{}\n", j.dump());
    } else {
      fmt::print("{}{}{}", format_quality(q), format_region_counts(regions), format_layers(layers));
      fmt::print("OpenFOAM (checkMesh) figures not measured: the mesh has prisms or pyramids\n");
    }
    if (!svg.empty()) {
      if (Status s = write_text(svg, quality_histogram_svg(q, path)); !s.ok()) return fail(s);
    }
    return kExitOk;
  }
  const QualityReport q = measure_quality(*mesh, /*interior=*/true);
  // checkMesh's figures need every face in one or two tets; on a mesh where
  // that fails the rest of the report still prints, with the reason.
  const auto foam = measure_foam_quality(*mesh);
  const std::vector<RegionCount> regions = region_counts(*mesh);
  if (json) {
    auto j = nlohmann::json::parse(quality_to_json(q));
    j["openfoam"] = foam.ok() ? nlohmann::json::parse(foam_quality_to_json(*foam))
                              : nlohmann::json{{"error", foam.status().message()}};
    j["regions"] = region_counts_json(regions);
    fmt::print("{}\n", j.dump());
  } else {
    fmt::print("{}{}", format_quality(q), format_region_counts(regions));
    fmt::print("{}", foam.ok() ? format_foam_quality(*foam)
                               : fmt::format("OpenFOAM (checkMesh) figures not measured: {}\n", foam.status().message()));
  }
  if (!svg.empty()) {
    if (Status s = write_text(svg, quality_histogram_svg(q, path)); !s.ok()) return fail(s);
  }
  return kExitOk;
}

int run_validate(const std::string& path, const std::string& surface_path, bool json) {
  auto mesh = read_volume(path);
  if (!mesh.ok()) return fail(mesh.status());
  SurfaceMesh surface;
  if (!surface_path.empty()) {
    auto s = read_surface(surface_path);
    if (!s.ok()) return fail(s.status());
    surface = std::move(s).value();
  }
  const ValidationReport report = validate_mesh(*mesh, surface_path.empty() ? nullptr : &surface);
  if (json) {
    const nlohmann::json j = {{"mesh", path},
                              {"surface", surface_path.empty() ? nlohmann::json(nullptr) : nlohmann::json(surface_path)},
                              {"valid", report.ok()},
                              {"tets", report.tets},
                              {"points", report.points},
                              {"boundary_faces", report.boundary_faces},
                              {"regions", report.regions},
                              {"interface_faces", report.interface_faces},
                              {"volume", report.volume},
                              {"enclosed_volume", report.enclosed_volume},
                              {"error_count", report.error_count},
                              {"errors", report.errors}};
    fmt::print("{}\n", j.dump());
  } else {
    fmt::print("{}", format_validation(report));
  }
  return report.ok() ? kExitOk : kExitBadInput;
}

int run_convert(const std::string& in, const std::string& out, const std::string& vtu, const std::string& names) {
  auto mesh = read_volume(in);
  if (!mesh.ok()) return fail(mesh.status());
  if (Status s = apply_names_file(names, mesh->boundary_ids, mesh->boundary_names); !s.ok()) return fail(s);
  VolumeWriteOptions options;
  options.vtu = vtu == "ascii" ? VtuEncoding::kAscii : vtu == "zlib" ? VtuEncoding::kCompressed : VtuEncoding::kBinary;
  if (Status s = write_volume(*mesh, out, options); !s.ok()) return fail(s);
  return kExitOk;
}

}  // namespace

void add_local_commands(CLI::App& app, int& exit_code) {
  const std::string volume_formats = fmt::format("({})", volume_format_suffixes());
  const std::string surface_formats = "surface file (.stl .obj .off .ply .mesh .surf)";
  const std::string json_help = "print the result as one JSON object on stdout";

  {
    auto* cmd = app.add_subcommand("check", "Check a surface triangulation: topology, orientation, "
                                            "self-intersections. Exit 0 when it can be meshed, 65 otherwise.");
    auto path = std::make_shared<std::string>();
    auto json = std::make_shared<bool>(false);
    auto fast = std::make_shared<bool>(false);
    cmd->add_option("SURFACE", *path, surface_formats)->required()->check(surface_input_check());
    cmd->add_flag("--json", *json, "print the report as JSON");
    cmd->add_flag("--no-self-intersections", *fast, "skip the self-intersection test");
    cmd->footer(help_footer({{"pdrmesh check part.stl", "is part.stl closed, manifold, oriented, without self-intersections?"},
                             {"pdrmesh check part.stl --json", "the same report as JSON (holes, defects, components)"}}));
    cmd->callback([&exit_code, path, json, fast] { exit_code = run_check(*path, *json, *fast); });
  }
  {
    auto* cmd = app.add_subcommand("mesh", "Mesh the volume inside a surface on one core: check, "
                                           "boundary-conforming initial mesh, advancing-front refinement, "
                                           "final optimization, validation, quality summary.");
    auto a = std::make_shared<MeshArgs>();
    cmd->add_option("SURFACE", a->surface, surface_formats)->required()->check(surface_input_check());
    cmd->add_option("-o,--output", a->output, "output volume mesh " + volume_formats)
        ->required()
        ->check(output_check(OutputKind::kVolumeMesh));
    add_number(cmd, "--max-volume", a->max_volume, "with --no-refine: maximum tetrahedron volume (TetGen -a)", kVolume);
    cmd->add_flag("--no-refine", a->no_refine, "write the boundary-conforming initial mesh (TetGen) unrefined");
    cmd->add_flag("--no-optimize", a->no_optimize, "skip the final optimization");
    a->size.add_to(cmd);
    add_names_option(cmd, a->names);
    a->farfield.add_to(cmd);
    add_time_limit(cmd, a->time_limit_s, "none");
    cmd->add_flag("-q,--quiet", a->quiet, "no progress or summary on stderr");
    cmd->add_flag("--json", a->json, json_help);
    cmd->add_flag("--no-validate", a->no_validate, "skip validating the result before writing it");
    a->layers.add_to(cmd);
    cmd->footer(help_footer({{"pdrmesh mesh part.stl -o part.vtu", "mesh with the spacing the surface's triangles give"},
                             {"pdrmesh mesh duct.stl -o duct.su2 --layers 10 --first-height 1e-4 --growth-ratio 1.2",
                              "ten prism layers on the walls, then tets"},
                             {"pdrmesh mesh part.stl -o part.msh --size 1% --time-limit 600",
                              "edges about 1% of the bounding-box diagonal; stop after 10 minutes"},
                             {"pdrmesh mesh part.ply -o part.su2 --names names.txt",
                              "SU2 markers named by names.txt (lines like '1 inlet')"},
                             {"pdrmesh mesh wing.stl -o case/constant/polyMesh --farfield 10",
                              "external flow: the space between the wing and a box 10 wing lengths away"}}));
    cmd->callback([&exit_code, a, cmd] {
      a->size.check();
      refuse_together(*cmd, "--no-refine", {"--size", "--hmin", "--hmax", "--growth", "--no-optimize"},
                      "the initial mesh is not refined");
      if (cmd->count("--max-volume") > 0 && !a->no_refine)
        usage_error("--max-volume: only with --no-refine (the refined mesh follows --size)");
      if (a->layers.layers > 0 && a->no_refine) usage_error("--layers: not with --no-refine");
      a->layers.check(*cmd);
      a->growth_given = cmd->count("--growth") > 0;
      exit_code = run_mesh(*a);
    });
  }
  {
    auto* cmd = app.add_subcommand("run", "Mesh a surface with the parallel method (PDR) in this process: "
                                          "octree decomposition, leaf tasks in eight buffered rounds (each leaf refined with its "
                                          "neighbours' tets around it), merge, final optimization.");
    auto a = std::make_shared<RunArgs>();
    cmd->add_option("SURFACE", a->surface, surface_formats)->required()->check(surface_input_check());
    cmd->add_option("-o,--output", a->output, "output volume mesh " + volume_formats)
        ->required()
        ->check(output_check(OutputKind::kVolumeMesh));
    add_number(cmd, "--workers", a->workers, "leaf tasks run at once", kWorkers)->capture_default_str();
    cmd->add_flag("--profile", a->profile, "print the time of each phase and its share");
    cmd->add_option("--profile-json", a->profile_json,
                    "write the phase times and every round's leaf task times as JSON (for pdrmesh_bench_replay)")
        ->check(output_check(OutputKind::kFile));
    add_time_limit(cmd, a->time_limit_s, "none");
    cmd->add_flag("-q,--quiet", a->quiet, "no progress or summary on stderr");
    cmd->add_flag("--json", a->json, json_help);
    a->mesh.add_to(cmd);
    a->layers.add_to(cmd);
    cmd->footer(help_footer({{"pdrmesh run part.stl -o part.meshb --workers 8", "the parallel method on 8 threads"},
                             {"pdrmesh run part.stl -o part.vtu --size 0.5% --depth 2 --profile",
                              "a finer mesh over a 4x4x4 octree, with the time of each phase"}}));
    cmd->callback([&exit_code, a, cmd] {
      a->mesh.size.check();
      a->layers.check(*cmd);
      a->growth_given = cmd->count("--growth") > 0;
      exit_code = run_run(*a);
    });
  }
  {
    auto* cmd = app.add_subcommand("quality", "Quality statistics of a volume mesh, with the figures OpenFOAM's "
                                              "checkMesh reports (face non-orthogonality and skewness).");
    auto path = std::make_shared<std::string>();
    auto json = std::make_shared<bool>(false);
    auto svg = std::make_shared<std::string>();
    cmd->add_option("MESH", *path, "volume mesh " + volume_formats)->required();
    cmd->add_flag("--json", *json, "print the statistics as JSON");
    cmd->add_option("--svg", *svg, "also draw the dihedral-angle histogram into this SVG file")
        ->check(output_check(OutputKind::kFile));
    cmd->footer(help_footer({{"pdrmesh quality part.vtu",
                              "dihedral angles, shape measures, checkMesh's non-orthogonality and skewness"},
                             {"pdrmesh quality part.vtu --json --svg angles.svg", "as JSON, and the angle histogram"}}));
    cmd->callback([&exit_code, path, json, svg] { exit_code = run_quality(*path, *json, *svg); });
  }
  {
    auto* cmd = app.add_subcommand("validate", "Validate a volume mesh, optionally against its input surface. "
                                               "Exit 0 when valid, 65 otherwise.");
    auto path = std::make_shared<std::string>();
    auto surface = std::make_shared<std::string>();
    auto json = std::make_shared<bool>(false);
    cmd->add_option("MESH", *path, "volume mesh " + volume_formats)->required();
    cmd->add_option("--surface", *surface, "the input surface the mesh's boundary must equal")
        ->check(surface_input_check());
    cmd->add_flag("--json", *json, "print the report as JSON");
    cmd->footer(help_footer({{"pdrmesh validate part.vtu", "conforming, positive volumes, a closed boundary"},
                             {"pdrmesh validate part.vtu --surface part.stl",
                              "also: the boundary is the surface's triangles, the volume the enclosed one"}}));
    cmd->callback([&exit_code, path, surface, json] { exit_code = run_validate(*path, *surface, *json); });
  }
  {
    auto* cmd = app.add_subcommand("convert", "Convert a volume mesh between formats (by suffix).");
    auto in = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    auto vtu = std::make_shared<std::string>("binary");
    auto names = std::make_shared<std::string>();
    cmd->add_option("IN", *in, "input volume mesh " + volume_formats)->required();
    cmd->add_option("OUT", *out, "output volume mesh " + volume_formats)
        ->required()
        ->check(output_check(OutputKind::kVolumeMesh));
    cmd->add_option("--vtu", *vtu, "how a .vtu output stores its data: raw binary, zlib-compressed binary, or ascii")
        ->check(CLI::IsMember({"binary", "zlib", "ascii"}))
        ->capture_default_str();
    add_names_option(cmd, *names);
    cmd->footer(help_footer({{"pdrmesh convert part.meshb part.vtu", "for ParaView"},
                             {"pdrmesh convert part.vtu small.vtu --vtu zlib", "a compressed VTU"},
                             {"pdrmesh convert part.meshb part.su2", "for SU2"},
                             {"pdrmesh convert part.meshb case/constant/polyMesh", "for OpenFOAM (checkMesh -case case)"},
                             {"pdrmesh convert part.mesh part.ugrid --names names.txt",
                              "for FUN3D, with part.mapbc naming the surface ids"}}));
    cmd->callback([&exit_code, in, out, vtu, names] { exit_code = run_convert(*in, *out, *vtu, *names); });
  }
}

}  // namespace pdrmesh::cli
