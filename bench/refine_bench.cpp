// SPDX-License-Identifier: AGPL-3.0-or-later
// pdrmesh_bench_refine: runs the serial pipeline's steps (TetGen initial mesh,
// sizing field, refinement, optimization) on corpus surfaces at the default
// spacing and at size = bounding-box diagonal / 100, validates each mesh and
// prints a table: tets, refinement and optimization CPU seconds (one thread;
// CPU time rather than wall time because the bench machine is shared), their
// wall time together, tets per CPU second of refinement + optimization, the share of interior edges (no boundary
// endpoint) with length in [0.6, 1.5] h(midpoint) (and the shares below/above),
// dihedral extremes over all tets and over interior tets (no boundary vertex),
// the share of interior tets with every dihedral angle in [15, 150] and the
// number outside it (i_out), and the share of all tets with a dihedral angle
// under 10 degrees.
// Not a test: it asserts nothing.
//   usage: pdrmesh_bench_refine [CORPUS_DIR [NAME...]]
//   environment: PDRMESH_BENCH_SIZES=dflt|d100 (one size only), PDRMESH_BENCH_VERBOSE
//   (per-pass lines), PDRMESH_BENCH_NO_OPTIMIZE, PDRMESH_BENCH_NO_MIN_MAX,
//   PDRMESH_BENCH_EACH_INSERTION (min-max step after each insertion), PDRMESH_BENCH_MIN_MAX_ANGLE=A,
//   PDRMESH_BENCH_SWEEPS=N (optimization sweeps), PDRMESH_BENCH_NO_REPAIR (no interior repair),
//   PDRMESH_BENCH_NO_POLISH (no angle polish), PDRMESH_BENCH_NO_MARGIN (no margin polish),
//   PDRMESH_BENCH_REPAIR_CYCLES=N (OptimizeOptions::repair_cycles), PDRMESH_BENCH_NO_SIZE_POLISH (no size polish),
//   PDRMESH_BENCH_NO_ABSORB (no absorption), PDRMESH_BENCH_NO_LATE_CAPS (no late cap pass),
//   PDRMESH_BENCH_DIVISOR=N (the fine size is diagonal / N, not / 100),
//   PDRMESH_BENCH_LONG_EDGE_RATIO=R,
//   PDRMESH_BENCH_NO_VOID_MIDPOINTS, PDRMESH_BENCH_NO_SPATIAL_ORDER (RefineOptions::spatial_order off),
//   PDRMESH_BENCH_SPATIAL_ORDER_MIN_TETS=N (RefineOptions::spatial_order_min_tets),
//   PDRMESH_BENCH_REJECT=D, PDRMESH_BENCH_BOUNDARY_REJECT=D (RefineOptions' reject distances),
//   PDRMESH_BENCH_NO_SMOOTH, PDRMESH_BENCH_NO_INSERT, PDRMESH_BENCH_NO_CAPS,
//   PDRMESH_BENCH_NO_KEEP_SIZES, PDRMESH_BENCH_NO_REMOVE (OptimizeOptions::smooth,
//   insert_points, repair_caps, keep_edge_sizes, remove_points off),
//   PDRMESH_BENCH_WRITE=DIR (each mesh to DIR/NAME-SIZE.mesh),
//   PDRMESH_BENCH_DUMP_BAD (stderr: the 40 worst interior tets outside
//   [15, 150] with their edge lengths over h and their vertices' stars)
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "pdrmesh/optimize.hpp"
#include "pdrmesh/quality.hpp"
#include "pdrmesh/refine.hpp"
#include "pdrmesh/size_band.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/tet_mesh.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"

namespace {

using namespace pdrmesh;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The fine size's divisor of the bounding-box diagonal: 100, or PDRMESH_BENCH_DIVISOR.
double divisor() {
  const char* d = std::getenv("PDRMESH_BENCH_DIVISOR");
  return d != nullptr ? std::atof(d) : 100.0;
}

// The fine size's name: d100 (file names) or d/100 (the table), after divisor().
std::string fine_name(bool slash) { return fmt::format("d{}{:g}", slash ? "/" : "", divisor()); }

void run(const std::string& dir, const std::string& name, bool fine) {
  auto surface = read_surface(dir + "/" + name + ".stl");
  if (!surface.ok()) {
    fmt::print("{:<13} read failed: {}\n", name, surface.status().to_string());
    return;
  }
  auto initial = tetrahedralize(*surface);
  if (!initial.ok()) {
    fmt::print("{:<13} tetgen failed: {}\n", name, initial.status().to_string());
    return;
  }
  SizingOptions so;
  if (fine) so.size = surface->bounds().diagonal() / divisor();
  auto field = SizingField::build(*surface, *initial, so);
  auto mesh = TetMesh::from_volume_mesh(*initial);
  if (!field.ok() || !mesh.ok()) {
    fmt::print("{:<13} setup failed\n", name);
    return;
  }
  const auto t0 = Clock::now();
  const std::clock_t c0 = std::clock();
  const bool verbose = std::getenv("PDRMESH_BENCH_VERBOSE") != nullptr;
  RefineOptions ro;
  if (const char* v = std::getenv("PDRMESH_BENCH_MIN_MAX_ANGLE")) ro.min_max_angle = std::atof(v);
  if (std::getenv("PDRMESH_BENCH_NO_MIN_MAX") != nullptr) ro.min_max = false;
  if (std::getenv("PDRMESH_BENCH_EACH_INSERTION") != nullptr) ro.defer_min_max = false;
  if (const char* v = std::getenv("PDRMESH_BENCH_LONG_EDGE_RATIO")) ro.long_edge_ratio = std::atof(v);
  if (std::getenv("PDRMESH_BENCH_NO_VOID_MIDPOINTS") != nullptr) ro.void_midpoints = false;
  if (const char* v = std::getenv("PDRMESH_BENCH_BOUNDARY_REJECT")) ro.boundary_reject_distance = std::atof(v);
  if (const char* v = std::getenv("PDRMESH_BENCH_REJECT")) ro.reject_distance = std::atof(v);
  if (std::getenv("PDRMESH_BENCH_NO_SPATIAL_ORDER") != nullptr) ro.spatial_order = false;
  if (const char* v = std::getenv("PDRMESH_BENCH_SPATIAL_ORDER_MIN_TETS"))
    ro.spatial_order_min_tets = static_cast<Index>(std::atol(v));
  auto stats = refine(*mesh, *field, ro, [&](const RefinePassStats& p) {
    if (verbose)
      fmt::print(stderr, "  pass {:>3}: {:>8} candidates {:>8} accepted {:>8} inserted {:>8} flips {:>9} tets {:.3f}s\n",
                 p.pass, p.candidates, p.accepted, p.inserted, p.flips, p.tets, p.seconds);
  });
  const double refine_cpu = double(std::clock() - c0) / CLOCKS_PER_SEC;
  if (!stats.ok()) {
    fmt::print("{:<13} refine failed: {}\n", name, stats.status().to_string());
    return;
  }
  const std::clock_t c1 = std::clock();
  if (std::getenv("PDRMESH_BENCH_NO_OPTIMIZE") == nullptr) {
    OptimizeOptions oo;
    if (const char* v = std::getenv("PDRMESH_BENCH_SWEEPS")) oo.sweeps = std::atoi(v);
    if (std::getenv("PDRMESH_BENCH_NO_REPAIR") != nullptr) oo.interior_repair = false;
    if (std::getenv("PDRMESH_BENCH_NO_SMOOTH") != nullptr) oo.smooth = false;
    if (std::getenv("PDRMESH_BENCH_NO_KEEP_SIZES") != nullptr) oo.keep_edge_sizes = false;
    if (std::getenv("PDRMESH_BENCH_NO_INSERT") != nullptr) oo.insert_points = false;
    if (std::getenv("PDRMESH_BENCH_NO_CAPS") != nullptr) oo.repair_caps = false;
    if (std::getenv("PDRMESH_BENCH_NO_POLISH") != nullptr) oo.polish_angles = false;
    if (std::getenv("PDRMESH_BENCH_NO_MARGIN") != nullptr) oo.polish_margins = false;
    if (std::getenv("PDRMESH_BENCH_NO_SIZE_POLISH") != nullptr) oo.polish_sizes = false;
    if (std::getenv("PDRMESH_BENCH_NO_ABSORB") != nullptr) oo.absorb = false;
    if (std::getenv("PDRMESH_BENCH_NO_LATE_CAPS") != nullptr) oo.late_caps = false;
    if (std::getenv("PDRMESH_BENCH_NO_REMOVE") != nullptr) oo.remove_points = false;
    if (const char* v = std::getenv("PDRMESH_BENCH_REPAIR_CYCLES")) oo.repair_cycles = std::atoi(v);
    auto ostats = optimize(*mesh, &*field, oo);
    if (verbose && ostats.ok())
      fmt::print(stderr,
                 "  optimize: {} sweeps, bad {} -> {}, {} flips, {} slivers removed, {} points inserted, {} removed, "
                 "{} moved, {} repair cycles\n",
                 ostats->sweeps_run, ostats->bad_before, ostats->bad_after, ostats->flips, ostats->slivers_removed,
                 ostats->points_inserted, ostats->points_removed, ostats->points_moved, ostats->repair_cycles);
    if (!ostats.ok()) {
      fmt::print("{:<13} optimize failed: {}\n", name, ostats.status().to_string());
      return;
    }
  }
  const double optimize_cpu = double(std::clock() - c1) / CLOCKS_PER_SEC;
  const double seconds = seconds_since(t0);
  const VolumeMesh out = mesh->to_volume_mesh();
  const ValidationReport report = validate_mesh(out, &*surface);
  if (const char* out_dir = std::getenv("PDRMESH_BENCH_WRITE")) {
    const std::string path = fmt::format("{}/{}-{}.mesh", out_dir, name, fine ? fine_name(false) : "dflt");
    if (Status s = write_volume(out, path); !s.ok()) fmt::print(stderr, "{}\n", s.to_string());
  }

  std::vector<bool> on_boundary(out.points.size(), false);
  for (const Tri& t : out.boundary)
    for (Index v : t) on_boundary[v] = true;
  const SizeBand band = measure_size_band(out, *field);
  AngleRange all{180, 0}, inner{180, 0};
  std::size_t inner_tets = 0, inner_good = 0, under10 = 0;
  for (const Tet& k : out.tets) {
    const auto r = dihedral_range(out.points[k[0]], out.points[k[1]], out.points[k[2]], out.points[k[3]]);
    all.min = std::min(all.min, r.min);
    all.max = std::max(all.max, r.max);
    if (r.min < 10) ++under10;
    if (on_boundary[k[0]] || on_boundary[k[1]] || on_boundary[k[2]] || on_boundary[k[3]]) continue;
    ++inner_tets;
    if (r.min >= 15 && r.max <= 150) ++inner_good;
    inner.min = std::min(inner.min, r.min);
    inner.max = std::max(inner.max, r.max);
  }
  if (std::getenv("PDRMESH_BENCH_DUMP_BAD") != nullptr) {
    std::vector<std::vector<Index>> vt(out.points.size());
    for (Index t = 0; t < out.tets.size(); ++t)
      for (Index v : out.tets[t]) vt[v].push_back(t);
    // The 40 worst (smallest of min and 180 - max first).
    std::vector<std::pair<double, Index>> worst;
    for (Index t = 0; t < out.tets.size(); ++t) {
      const Tet& k = out.tets[t];
      if (on_boundary[k[0]] || on_boundary[k[1]] || on_boundary[k[2]] || on_boundary[k[3]]) continue;
      const auto r = dihedral_range(out.points[k[0]], out.points[k[1]], out.points[k[2]], out.points[k[3]]);
      if (r.min >= 15 && r.max <= 150) continue;
      worst.push_back({std::min(r.min, 180.0 - r.max), t});
    }
    std::sort(worst.begin(), worst.end());
    if (worst.size() > 40) worst.resize(40);
    for (const auto& [score, t] : worst) {
      const Tet& k = out.tets[t];
      const auto r = dihedral_range(out.points[k[0]], out.points[k[1]], out.points[k[2]], out.points[k[3]]);
      const Vec3 c = 0.25 * (out.points[k[0]] + out.points[k[1]] + out.points[k[2]] + out.points[k[3]]);
      const double h = field->at(c);
      std::string el;
      for (int e = 0; e < 6; ++e)
        el += fmt::format(" {:.2f}", norm(out.points[k[topo::kEdgeVertex[e][0]]] - out.points[k[topo::kEdgeVertex[e][1]]]) / h);
      std::string st;
      for (Index v : k) {
        double wmin = 180, wmax = 0; int bnd = 0, bad = 0; double hv = field->at(out.points[v]);
        for (Index u : vt[v]) {
          const Tet& q = out.tets[u];
          const auto rr = dihedral_range(out.points[q[0]], out.points[q[1]], out.points[q[2]], out.points[q[3]]);
          wmin = std::min(wmin, rr.min); wmax = std::max(wmax, rr.max);
          if (on_boundary[q[0]] || on_boundary[q[1]] || on_boundary[q[2]] || on_boundary[q[3]]) ++bnd;
          if (rr.min < 15 || rr.max > 150) ++bad;
        }
        st += fmt::format(" [v{} h{:.3g} star {} bnd {} bad {} worst {:.1f}/{:.1f}]", v, hv/h, vt[v].size(), bnd, bad, wmin, wmax);
      }
      fmt::print(stderr, "  bad {} {:.1f}/{:.1f} h={:.4g} L/h:{} {}\n", t, r.min, r.max, h, el, st);
    }
  }
  const double n = band.edges == 0 ? 1.0 : double(band.edges);
  const double cpu = refine_cpu + optimize_cpu;
  fmt::print("{:<13} {:>5} {:>9} {:>4} {:>6.2f} {:>6.2f} {:>6.2f} {:>9.0f} {:>6.1f}% {:>5.1f}% {:>5.1f}% {:>6.1f} {:>6.1f} {:>6.1f} {:>6.1f} {:>6.1f}% {:>6} {:>6.3f}% {}\n",
             name, fine ? fine_name(true) : "dflt", out.tets.size(), stats->passes.size(), refine_cpu, optimize_cpu,
             seconds, double(out.tets.size()) / cpu, 100.0 * double(band.within) / n, 100.0 * double(band.shorter) / n,
             100.0 * double(band.longer) / n, all.min, all.max, inner.min, inner.max,
             inner_tets ? 100.0 * double(inner_good) / double(inner_tets) : 0.0,
             inner_tets - inner_good,
             out.tets.empty() ? 0.0 : 100.0 * double(under10) / double(out.tets.size()),
             report.ok() ? "valid" : "INVALID: " + (report.errors.empty() ? std::string() : report.errors[0]));
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : PDRMESH_DEFAULT_CORPUS;
  std::vector<std::string> names;
  for (int i = 2; i < argc; ++i) names.emplace_back(argv[i]);
  if (names.empty())
    names = {"sphere966", "bunny_npm", "hinge", "elephant", "couplingdown",
             "knot2", "fandisk", "primitives13", "armadillo", "frame"};
  fmt::print("{:<13} {:>5} {:>9} {:>4} {:>6} {:>6} {:>6} {:>9} {:>7} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>7} {:>6} {:>7} {}\n", "surface",
             "size", "tets", "pass", "ref_s", "opt_s", "wall_s", "tets/cpu_s", "in[.6,1.5]", "<.6", ">1.5", "dmin", "dmax", "idmin",
             "idmax", "i[15,150]", "i_out", "<10deg", "validate");
  const char* sizes = std::getenv("PDRMESH_BENCH_SIZES");  // "dflt", "d100" or both (unset)
  for (const std::string& name : names)
    for (bool fine : {false, true})
      if (sizes == nullptr || std::string(sizes) == (fine ? "d100" : "dflt")) run(dir, name, fine);
  return 0;
}
