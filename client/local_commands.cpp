// SPDX-License-Identifier: AGPL-3.0-or-later
#include "local_commands.hpp"

#include <fmt/format.h>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/parallel_invoke.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>

#include "exit_codes.hpp"
#include "progress_display.hpp"
#include "run_options.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/pdr_profile.hpp"
#include "pdrmesh/optimize.hpp"
#include "pdrmesh/pdr.hpp"
#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/quality.hpp"
#include "pdrmesh/refine.hpp"
#include "pdrmesh/sizing.hpp"
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

/// Reads and checks a surface; on failure prints why and returns the exit code.
int load_checked_surface(const std::string& path, Progress& progress, SurfaceMesh& out, StepTimes* times = nullptr) {
  auto t = Clock::now();
  auto surface = read_surface(path);
  if (!surface.ok()) return fail(surface.status());
  if (times) times->read = seconds_since(t);
  progress.say("read {}: {} points, {} triangles", path, surface->points.size(), surface->triangles.size());
  t = Clock::now();
  const SurfaceReport report = check_surface(*surface);
  if (times) times->check = seconds_since(t);
  if (Status s = require_meshable(report, path); !s.ok()) return fail(s);
  progress.say("surface check passed: {} component(s)", report.components.size());
  out = std::move(surface).value();
  return kExitOk;
}

/// The end of every meshing command: validate against the surface (a failure
/// is our bug, never the user's), write, and print the quality summary. The
/// validation runs beside the write and the summary (when the thread budget
/// allows): the file is staged and goes in place only once the mesh validated.
int finish(const VolumeMesh& mesh, const SurfaceMesh& surface, const std::string& output, bool validate,
           Progress& progress, bool quiet, StepTimes* times = nullptr) {
  StepTimes local;
  StepTimes& st = times ? *times : local;
  const auto t0 = Clock::now();
  ValidationReport report;
  Result<StagedVolume> staged = StagedVolume{};
  std::string summary;
  tbb::parallel_invoke(
      [&] {
        if (!validate) return;
        const auto t = Clock::now();
        report = validate_mesh(mesh, &surface);
        st.validation = seconds_since(t);
      },
      [&] {
        auto t = Clock::now();
        staged = stage_volume(mesh, output);
        st.write = seconds_since(t);
        if (quiet || !staged.ok()) return;
        t = Clock::now();
        summary = format_quality(measure_quality(mesh));
        st.quality = seconds_since(t);
      });
  st.overlapped = std::max(0.0, st.validation + st.write + st.quality - seconds_since(t0));
  if (validate) {
    if (!report.ok()) {
      fmt::print(stderr, "{}", format_validation(report));
      return fail(internal_error("the generated mesh failed validation; please report this with the input"));
    }
    progress.say("validated: conforming, positive, boundary identical to the input, volume conserved");
  }
  if (!staged.ok()) return fail(staged.status());
  if (Status s = staged->commit(); !s.ok()) return fail(s);
  progress.say("wrote {}", output);
  fmt::print(stderr, "{}", summary);
  return kExitOk;
}

int run_check(const std::string& path, bool json, bool no_self_intersections) {
  auto surface = read_surface(path);
  if (!surface.ok()) return fail(surface.status());
  CheckOptions options;
  options.self_intersections = !no_self_intersections;
  const SurfaceReport report = check_surface(*surface, options);
  if (json) {
    fmt::print("{}\n", report_to_json(report, path));
  } else {
    fmt::print("{}", format_report(report, path));
  }
  return report.meshable() ? kExitOk : kExitBadInput;
}

struct MeshArgs {
  std::string surface;
  std::string output;
  double max_volume = 0;
  double time_limit_s = 600;
  bool quiet = false;
  bool no_validate = false;
  bool no_refine = false;
  bool no_optimize = false;
  SizeArgs size;
};

int run_mesh(const MeshArgs& a) {
  Progress progress(a.quiet);
  if (auto f = volume_format_from_path(a.output); !f.ok()) return fail(f.status());
  SurfaceMesh surface;
  if (int code = load_checked_surface(a.surface, progress, surface); code != kExitOk) return code;
  if (Status s = a.size.check_tet_limit(surface, !a.no_refine); !s.ok()) return fail(s);

  if (a.no_refine) {
    TetgenOptions options;
    if (a.max_volume > 0) options.max_volume = a.max_volume;
    options.time_limit_s = a.time_limit_s;
    auto mesh = tetrahedralize(surface, options);
    if (!mesh.ok()) return fail(mesh.status());
    progress.say("initial mesh (TetGen -{}): {} tets, {} points", tetgen_switches(options), mesh->tets.size(),
                 mesh->points.size());
    return finish(*mesh, surface, a.output, !a.no_validate, progress, a.quiet);
  }

  SerialOptions options;
  options.sizing = a.size.options();
  options.tetgen.time_limit_s = a.time_limit_s;
  if (a.no_optimize) options.optimize.reset();
  auto result = mesh_serial(surface, options, [&progress](const RefinePassStats& p) {
    progress.say("pass {}: {} candidates, {} inserted, {} flips, {} tets", p.pass, p.candidates, p.inserted,
                 p.flips, p.tets);
  });
  if (!result.ok()) return fail(result.status());
  progress.say("refined: {} tets, {} points (initial mesh {:.2f} s, sizing {:.2f} s, refinement {:.2f} s, "
               "optimization {:.2f} s)",
               result->mesh.tets.size(), result->mesh.points.size(), result->seconds_initial,
               result->seconds_sizing, result->seconds_refine, result->seconds_optimize);
  return finish(result->mesh, surface, a.output, !a.no_validate, progress, a.quiet);
}

struct RunArgs {
  std::string surface;
  std::string output;
  std::size_t workers = 1;
  bool profile = false;
  std::string profile_json;
  bool quiet = false;
  RunOptionArgs mesh;
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
      {"background mesh", p.background},
      {"sizing", p.sizing},
      {"initial mesh", p.initial},
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
    fmt::print(stderr, "  {:<16} {:9.3f} s {:6.1f}% (steps run side by side: background mesh and sizing beside the initial mesh, validation beside the write)\n",
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
  // --workers N is the whole run's thread budget: the leaf schedules and every
  // parallel step around them (surface check, sizing, sorts, validation).
  const tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::max<std::size_t>(a.workers, 1));
  Progress progress(a.quiet);
  if (auto f = volume_format_from_path(a.output); !f.ok()) return fail(f.status());
  SurfaceMesh surface;
  StepTimes times;
  if (int code = load_checked_surface(a.surface, progress, surface, &times); code != kExitOk) return code;
  if (Status s = a.mesh.size.check_tet_limit(surface, true); !s.ok()) return fail(s);

  auto kernel = make_leaf_kernel(a.mesh.kernel);
  if (!kernel.ok()) return fail(kernel.status());
  ParallelOptions options = a.mesh.parallel_options();
  options.pdr.workers = a.workers;
  progress.update({"sizing"});
  options.pdr.progress = [&progress](const PdrProgress& p) {
    progress.update({std::string(p.phase), p.leaves_done, p.leaves_total, p.tets});
    return true;
  };
  auto result = mesh_parallel(surface, options, kernel->get());
  progress.finish();
  if (!result.ok()) return fail(result.status());
  const VolumeMesh& mesh = result->mesh;
  PdrProfile& profile = result->profile;
  progress.say("point distribution function built from {} boundary points", result->boundary_points);
  progress.say("parallel refinement ({} kernel, {} worker(s), depth {}): {} tets, {} points", (*kernel)->name(),
               a.workers, profile.depth, mesh.tets.size(), mesh.points.size());

  if (profile.failed_leaves > 0) {
    progress.say("warning: {} leaf task(s) failed and were kept unrefined (first: {})", profile.failed_leaves,
                 profile.first_failure);
  }
  if (int code = finish(mesh, surface, a.output, true, progress, a.quiet, &times); code != kExitOk) return code;
  profile.read = times.read;
  profile.surface_check = times.check;
  profile.validation = times.validation;
  profile.write = times.write;
  profile.quality = times.quality;
  profile.overlapped += times.overlapped;
  profile.wall = seconds_since(t_wall);
  if (a.profile) print_profile(profile);
  if (!a.profile_json.empty()) {
    if (Status s = write_text(a.profile_json, profile_to_json(profile, a.workers)); !s.ok()) return fail(s);
  }
  return kExitOk;
}

int run_quality(const std::string& path, bool json, const std::string& svg) {
  auto mesh = read_volume(path);
  if (!mesh.ok()) return fail(mesh.status());
  const QualityReport q = measure_quality(*mesh, /*interior=*/true);
  if (json) {
    fmt::print("{}\n", quality_to_json(q));
  } else {
    fmt::print("{}", format_quality(q));
  }
  if (!svg.empty()) {
    if (Status s = write_text(svg, quality_histogram_svg(q, path)); !s.ok()) return fail(s);
  }
  return kExitOk;
}

int run_validate(const std::string& path, const std::string& surface_path) {
  auto mesh = read_volume(path);
  if (!mesh.ok()) return fail(mesh.status());
  SurfaceMesh surface;
  if (!surface_path.empty()) {
    auto s = read_surface(surface_path);
    if (!s.ok()) return fail(s.status());
    surface = std::move(s).value();
  }
  const ValidationReport report = validate_mesh(*mesh, surface_path.empty() ? nullptr : &surface);
  fmt::print("{}", format_validation(report));
  return report.ok() ? kExitOk : kExitBadInput;
}

int run_convert(const std::string& in, const std::string& out) {
  if (auto f = volume_format_from_path(out); !f.ok()) return fail(f.status());
  auto mesh = read_volume(in);
  if (!mesh.ok()) return fail(mesh.status());
  if (Status s = write_volume(*mesh, out); !s.ok()) return fail(s);
  return kExitOk;
}

}  // namespace

void add_local_commands(CLI::App& app, int& exit_code) {
  const std::string volume_formats = fmt::format("({})", volume_format_suffixes());

  {
    auto* cmd = app.add_subcommand("check", "Check a surface triangulation: topology, orientation, "
                                            "self-intersections. Exit 0 when it can be meshed, 65 otherwise.");
    auto path = std::make_shared<std::string>();
    auto json = std::make_shared<bool>(false);
    auto fast = std::make_shared<bool>(false);
    cmd->add_option("SURFACE", *path, "surface file (.stl .obj .off .ply .mesh .surf)")->required();
    cmd->add_flag("--json", *json, "print the report as JSON");
    cmd->add_flag("--no-self-intersections", *fast, "skip the self-intersection test");
    cmd->callback([&exit_code, path, json, fast] { exit_code = run_check(*path, *json, *fast); });
  }
  {
    auto* cmd = app.add_subcommand("mesh", "Mesh the volume inside a surface on one core: check, "
                                           "boundary-conforming initial mesh, advancing-front refinement, "
                                           "final optimization, validation, quality summary.");
    auto a = std::make_shared<MeshArgs>();
    cmd->add_option("SURFACE", a->surface, "surface file (.stl .obj .off .ply .mesh .surf)")->required();
    cmd->add_option("-o,--output", a->output, "output volume mesh " + volume_formats)->required();
    cmd->add_option("--max-volume", a->max_volume, "with --no-refine: maximum tetrahedron volume (TetGen -a)")
        ->check(CLI::PositiveNumber);
    cmd->add_flag("--no-refine", a->no_refine, "write the boundary-conforming initial mesh (TetGen) unrefined");
    cmd->add_flag("--no-optimize", a->no_optimize, "skip the final optimization");
    a->size.add_to(cmd);
    cmd->add_option("--time-limit", a->time_limit_s, "seconds TetGen may run before it is stopped")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    cmd->add_flag("-q,--quiet", a->quiet, "no progress or summary on stderr");
    cmd->add_flag("--no-validate", a->no_validate, "skip validating the result before writing it");
    cmd->callback([&exit_code, a] { exit_code = run_mesh(*a); });
  }
  {
    auto* cmd = app.add_subcommand("run", "Mesh a surface with the parallel method (PDR) in this process: "
                                          "octree decomposition, leaf refinement under the lock table, merge, "
                                          "interface round, final optimization.");
    auto a = std::make_shared<RunArgs>();
    cmd->add_option("SURFACE", a->surface, "surface file (.stl .obj .off .ply .mesh .surf)")->required();
    cmd->add_option("-o,--output", a->output, "output volume mesh " + volume_formats)->required();
    cmd->add_option("--workers", a->workers, "leaf tasks run at once")->check(CLI::PositiveNumber)->capture_default_str();
    cmd->add_flag("--profile", a->profile, "print the time of each phase and its share");
    cmd->add_option("--profile-json", a->profile_json,
                    "write the phase times and every round's leaf task times as JSON (for pdrmesh_bench_replay)");
    cmd->add_flag("-q,--quiet", a->quiet, "no progress or summary on stderr");
    a->mesh.add_to(cmd);
    cmd->callback([&exit_code, a] { exit_code = run_run(*a); });
  }
  {
    auto* cmd = app.add_subcommand("quality", "Quality statistics of a volume mesh.");
    auto path = std::make_shared<std::string>();
    auto json = std::make_shared<bool>(false);
    auto svg = std::make_shared<std::string>();
    cmd->add_option("MESH", *path, "volume mesh " + volume_formats)->required();
    cmd->add_flag("--json", *json, "print the statistics as JSON");
    cmd->add_option("--svg", *svg, "also draw the dihedral-angle histogram into this SVG file");
    cmd->callback([&exit_code, path, json, svg] { exit_code = run_quality(*path, *json, *svg); });
  }
  {
    auto* cmd = app.add_subcommand("validate", "Validate a volume mesh, optionally against its input surface. "
                                               "Exit 0 when valid, 65 otherwise.");
    auto path = std::make_shared<std::string>();
    auto surface = std::make_shared<std::string>();
    cmd->add_option("MESH", *path, "volume mesh " + volume_formats)->required();
    cmd->add_option("--surface", *surface, "the input surface the mesh's boundary must equal");
    cmd->callback([&exit_code, path, surface] { exit_code = run_validate(*path, *surface); });
  }
  {
    auto* cmd = app.add_subcommand("convert", "Convert a volume mesh between formats (by suffix).");
    auto in = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    cmd->add_option("IN", *in, "input volume mesh " + volume_formats)->required();
    cmd->add_option("OUT", *out, "output volume mesh " + volume_formats)->required();
    cmd->callback([&exit_code, in, out] { exit_code = run_convert(*in, *out); });
  }
}

}  // namespace pdrmesh::cli
