// SPDX-License-Identifier: AGPL-3.0-or-later
// pdrmesh_bench_optimize: runs the final optimization (optimize.hpp) on dense
// TetGen meshes of corpus surfaces and prints the dihedral angles before and
// after, over all tets and over tets with no boundary vertex, and the speed.
// Not a test: it asserts nothing.
//   usage: pdrmesh_bench_optimize [CORPUS_DIR] [DIVISOR=20000] [NAME...]
//   (max_volume = enclosed volume / DIVISOR)
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "pdrmesh/optimize.hpp"
#include "pdrmesh/quality.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/tet_mesh.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/validate.hpp"

namespace {

using namespace pdrmesh;

struct Range {
  double all_min = 180, all_max = 0, in_min = 180, in_max = 0;
};

/// Dihedral range over all alive tets, and over those with no boundary vertex.
Range measure(const TetMesh& m, const std::vector<char>& on_boundary) {
  Range r;
  for (Index t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    const Tet& k = m.tet(t);
    const AngleRange a = dihedral_range(m.point(k[0]), m.point(k[1]), m.point(k[2]), m.point(k[3]));
    r.all_min = std::min(r.all_min, a.min);
    r.all_max = std::max(r.all_max, a.max);
    bool inner = true;
    for (Index v : k) inner = inner && !(v < on_boundary.size() && on_boundary[v]);
    if (inner) {
      r.in_min = std::min(r.in_min, a.min);
      r.in_max = std::max(r.in_max, a.max);
    }
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : PDRMESH_DEFAULT_CORPUS;
  const double divisor = argc > 2 ? std::atof(argv[2]) : 20000.0;
  std::vector<std::string> names;
  for (int i = 3; i < argc; ++i) names.emplace_back(argv[i]);
  if (names.empty()) names = {"sphere966", "bunny_npm", "elephant", "fandisk", "knot2"};
  fmt::print("final optimization, max_volume = enclosed / {}, default options\n", divisor);
  fmt::print("{:<12} {:>8} {:>8} | {:>15} {:>15} | {:>15} {:>15} | {:>6} {:>6} {:>6} {:>5} | {:>7} {:>9} {}\n",
             "surface", "tets", "after", "min all", "max all", "min inner", "max inner", "bad",
             "->", "flips", "ins", "s", "tets/s", "valid");
  for (const std::string& name : names) {
    auto surface = read_surface(dir + "/" + name + ".stl");
    if (!surface.ok()) {
      fmt::print("{:<12} {}\n", name, surface.status().to_string());
      continue;
    }
    TetgenOptions to;
    to.max_volume = enclosed_volume(*surface) / divisor;
    auto vm = tetrahedralize(*surface, to);
    if (!vm.ok()) {
      fmt::print("{:<12} {}\n", name, vm.status().to_string());
      continue;
    }
    auto sizing = SizingField::build(*surface, *vm, {});
    auto built = TetMesh::from_volume_mesh(*vm);
    if (!sizing.ok() || !built.ok()) {
      fmt::print("{:<12} setup failed\n", name);
      continue;
    }
    TetMesh m = std::move(built).value();
    std::vector<char> on_boundary(vm->points.size(), 0);
    for (const Tri& f : vm->boundary)
      for (Index v : f) on_boundary[v] = 1;
    const std::size_t tets = m.num_tets();
    const Range before = measure(m, on_boundary);
    auto st = optimize(m, &*sizing, {});
    if (!st.ok()) {
      fmt::print("{:<12} {}\n", name, st.status().to_string());
      continue;
    }
    const Range after = measure(m, on_boundary);
    m.compact();
    const ValidationReport report = validate_mesh(m.to_volume_mesh(), &*surface);
    fmt::print(
        "{:<12} {:>8} {:>8} | {:>6.2f} -> {:>5.2f} {:>6.2f} -> {:>5.2f} | {:>6.2f} -> {:>5.2f} "
        "{:>6.2f} -> {:>5.2f} | {:>6} {:>6} {:>6} {:>5} | {:>7.3f} {:>9.0f} {}\n",
        name, tets, m.num_tets(), before.all_min, after.all_min, before.all_max, after.all_max,
        before.in_min, after.in_min, before.in_max, after.in_max, st->bad_before, st->bad_after,
        st->flips, st->points_inserted, st->seconds, static_cast<double>(tets) / st->seconds,
        report.ok() ? "ok" : "FAILED");
  }
  return 0;
}
