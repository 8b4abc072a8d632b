// SPDX-License-Identifier: AGPL-3.0-or-later
// The PDR engine end to end: both kernels on a cube and on sphere966, results
// validated against the surface, byte-identical for 1, 2 and 4 workers, and
// lying kernels rejected.
#include "pdrmesh/pdr.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <array>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "pdr_fixtures.hpp"
#include "pdrmesh/farfield.hpp"
#include "pdrmesh/leaf_kernels.hpp"
#include "pdrmesh/optimize.hpp"
#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/quality.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"
#include "test_fixtures.hpp"

namespace pdrmesh {
namespace {

using fixtures::barycenter_hook;
using fixtures::uniform_sizing;

struct Sphere {
  SurfaceMesh surface;
  std::optional<SizingField> sizing;
};

/// sphere966 with its surface-derived sizing field (nullptr when unreadable).
const Sphere* sphere() {
  static const std::optional<Sphere> s = []() -> std::optional<Sphere> {
    Result<SurfaceMesh> surface = read_surface(std::string(PDRMESH_CORPUS_DIR) + "/sphere966.mesh");
    if (!surface.ok()) return std::nullopt;
    Result<VolumeMesh> background = tetrahedralize(*surface);
    if (!background.ok()) return std::nullopt;
    Result<SizingField> h = SizingField::build(*surface, *background, {});
    if (!h.ok()) return std::nullopt;
    Sphere sp;
    sp.surface = std::move(*surface);
    sp.sizing.emplace(std::move(*h));
    return sp;
  }();
  return s ? &*s : nullptr;
}

/// fandisk in a box 5 body lengths away (--farfield 5): the domain's surface.
SurfaceMesh fandisk_in_a_box() {
  Result<FarfieldDomain> domain = make_farfield(fixtures::corpus_surface("fandisk"), {5, FarfieldShape::kBox});
  EXPECT_TRUE(domain.ok()) << domain.status().to_string();
  return domain.ok() ? std::move(domain->surface) : SurfaceMesh{};
}

/// Valid against `s`; run_pdr's meshes hold the leaf of every tet, and
/// mesh_parallel's (`pipeline`) none, the surface being one region.
void expect_valid(const VolumeMesh& m, const SurfaceMesh& s, bool pipeline = false) {
  const ValidationReport rep = validate_mesh(m, &s);
  EXPECT_TRUE(rep.ok()) << format_validation(rep);
  EXPECT_EQ(m.tet_regions.size(), pipeline ? 0 : m.tets.size());
}

/// Depth 2 with a lighter initial mesh than the default (about 60 tets per
/// full leaf), to keep the tests fast.
PdrOptions depth2(std::size_t workers = 1) {
  PdrOptions o;
  o.depth = 2;
  o.min_leaf_width = 0;  // the cube's leaves are 2.5 spacings wide: these tests exercise the rounds
  o.workers = workers;
  o.initial_volume_divisor = 60;
  return o;
}

TEST(Pdr, NativeKernelMeshesACube) {
  const SurfaceMesh cube = fixtures::unit_cube_surface();
  const SizingField h = uniform_sizing(0.1);
  const NativeLeafKernel kernel(barycenter_hook(30));
  PdrProfile prof;
  Result<VolumeMesh> m = run_pdr(cube, h, kernel, depth2(), &prof);
  ASSERT_TRUE(m.ok()) << m.status().to_string();
  expect_valid(*m, cube);
  EXPECT_EQ(prof.depth, 2);
  EXPECT_GT(prof.leaf_count, 8u);
  // Seed rounds (the finest seeds, inserted by leaf tasks), then buffered
  // rounds, one per colour of the grid's 2x2x2 parity classes, and no
  // interface round after them.
  EXPECT_GE(prof.rounds.size(), 9u);
  std::size_t seed_rounds = 0;
  for (const RoundRecord& r : prof.rounds) {
    if (r.name == "seeds") {
      EXPECT_EQ(seed_rounds++, static_cast<std::size_t>(&r - prof.rounds.data())) << "the seed rounds come first";
    } else {
      EXPECT_EQ(r.name, "refinement");
    }
  }
  EXPECT_GE(seed_rounds, 1u);
  EXPECT_LE(seed_rounds, 8u);
  EXPECT_EQ(prof.interface_leaf_count, 0u);
  EXPECT_EQ(prof.fixup_swaps + prof.fixup_moves, 0u);  // the native kernel needs no fix-ups
  // Both rounds inserted points: at least 30 per leaf that had a large tet.
  EXPECT_GT(prof.interior_points, prof.initial_tets / 10);
  EXPECT_EQ(prof.final_tets, m->tets.size());
}

TEST(Pdr, TetgenKernelMeshesACube) {
  const SurfaceMesh cube = fixtures::unit_cube_surface();
  const SizingField h = uniform_sizing(0.15);
  const TetgenLeafKernel kernel;
  PdrProfile prof;
  Result<VolumeMesh> m = run_pdr(cube, h, kernel, depth2(), &prof);
  ASSERT_TRUE(m.ok()) << m.status().to_string();
  expect_valid(*m, cube);
  EXPECT_EQ(prof.fixup_unresolved, 0u);
  // Refilled to the sizing: about volume / regular volume tets, give or take.
  const double expected = 1.0 / regular_tet_volume(0.15);
  EXPECT_GT(static_cast<double>(m->tets.size()), 0.5 * expected);
}

TEST(Pdr, BothKernelsMeshSphere966) {
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const NativeLeafKernel native(barycenter_hook(20));
  const TetgenLeafKernel tetgen;
  for (const LeafKernel* k : {static_cast<const LeafKernel*>(&native), static_cast<const LeafKernel*>(&tetgen)}) {
    SCOPED_TRACE(std::string(k->name()));
    PdrProfile prof;
    Result<VolumeMesh> m = run_pdr(sp->surface, *sp->sizing, *k, depth2(2), &prof);
    ASSERT_TRUE(m.ok()) << m.status().to_string();
    expect_valid(*m, sp->surface);
    EXPECT_EQ(prof.fixup_unresolved, 0u);
    EXPECT_GT(prof.interior_points, 0u);
  }
}

VolumeMesh run_native(const Sphere& sp, std::size_t workers, SchedulePolicy policy = SchedulePolicy::kColoured) {
  const NativeLeafKernel kernel(barycenter_hook(20));
  PdrOptions o = depth2(workers);
  o.policy = policy;
  Result<VolumeMesh> m = run_pdr(sp.surface, *sp.sizing, kernel, o, nullptr);
  EXPECT_TRUE(m.ok()) << m.status().to_string();
  return m.ok() ? std::move(*m) : VolumeMesh{};
}

std::string meshb_bytes(const VolumeMesh& m, const std::string& name) {
  const auto path = std::filesystem::temp_directory_path() / (name + ".meshb");
  EXPECT_TRUE(write_volume(m, path).ok());
  std::string bytes;
  if (FILE* f = std::fopen(path.c_str(), "rb")) {
    char buf[65536];
    std::size_t n = 0;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) bytes.append(buf, n);
    std::fclose(f);
  }
  std::filesystem::remove(path);
  return bytes;
}

TEST(Pdr, ByteIdenticalFor1To8WorkersAndBothPolicies) {
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const VolumeMesh one = run_native(*sp, 1);
  expect_valid(one, sp->surface);
  const std::string ref = meshb_bytes(one, "pdr_w1");
  ASSERT_GT(ref.size(), 1000u);
  for (SchedulePolicy policy : {SchedulePolicy::kDynamic, SchedulePolicy::kColoured}) {
    for (std::size_t w : {1u, 2u, 4u, 8u}) {
      if (w == 1 && policy == SchedulePolicy::kDynamic) continue;  // the reference
      const VolumeMesh m = run_native(*sp, w, policy);
      EXPECT_EQ(m.points, one.points) << w;
      EXPECT_EQ(m.tets, one.tets) << w;
      EXPECT_EQ(m.tet_regions, one.tet_regions) << w;
      EXPECT_EQ(meshb_bytes(m, "pdr_w" + std::to_string(w)), ref) << w;
    }
  }
}

// Workers that come and go during a run (the coordinator's remote workers):
// the concurrency the scheduler is told changes at every hand-out, and the
// bytes stay those of one worker.
TEST(Pdr, ByteIdenticalWhenTheConcurrencyChangesDuringTheRun) {
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const std::string ref = meshb_bytes(run_native(*sp, 1, SchedulePolicy::kDynamic), "pdr_c1");
  for (SchedulePolicy policy : {SchedulePolicy::kDynamic, SchedulePolicy::kColoured}) {
    const NativeLeafKernel kernel(barycenter_hook(20));
    PdrOptions o = depth2(1);
    o.policy = policy;
    std::atomic<std::size_t> asked{0};
    o.concurrency = [&asked] { return std::size_t{1} + (asked.fetch_add(1) * 7) % 5; };  // 1, 3, 5, 2, 4, 1, ...
    Result<VolumeMesh> m = run_pdr(sp->surface, *sp->sizing, kernel, o, nullptr);
    ASSERT_TRUE(m.ok()) << m.status().to_string();
    expect_valid(*m, sp->surface);
    // kDynamic asks at every hand-out, kColoured once a round.
    EXPECT_GT(asked.load(), policy == SchedulePolicy::kDynamic ? 20u : 0u);
    EXPECT_EQ(meshb_bytes(*m, "pdr_c"), ref) << (policy == SchedulePolicy::kDynamic ? "dynamic" : "coloured");
  }
}

/// A refinement hook that also moves every interior point a little towards
/// the mean of its first tet's other vertices when that keeps all tets around
/// it positive: a stand-in for smoothing, so that moved points travel.
RefineHook nudging_hook() {
  return [](TetMesh& m, const SizingField& h, const std::optional<Box>&) -> Status {
    PDR_TRY(fixtures::barycenter_hook(10)(m, h, {}));
    std::vector<unsigned char> fixed(m.num_points(), 0);
    std::vector<std::vector<Index>> star(m.num_points());
    for (Index t = 0; t < m.num_slots(); ++t) {
      if (!m.alive(t)) continue;
      for (int f = 0; f < 4; ++f) {
        if (m.neighbour(t, f) == kNoIndex || m.frozen(t, f))
          for (int k = 0; k < 4; ++k)
            if (k != f) fixed[m.tet(t)[k]] = 1;
        star[m.tet(t)[f]].push_back(t);
      }
    }
    for (Index v = 0; v < m.num_points(); ++v) {
      if (fixed[v] != 0 || star[v].empty()) continue;
      const Tet& t0 = m.tet(star[v][0]);
      Vec3 mean{0, 0, 0};
      for (Index u : t0)
        if (u != v) mean = mean + (1.0 / 3.0) * m.point(u);
      const Vec3 old = m.point(v);
      m.set_point(v, old + 0.05 * (mean - old));
      bool ok = true;
      for (Index t : star[v]) {
        const Tet& q = m.tet(t);
        ok = ok && exact::orient3d(m.point(q[0]), m.point(q[1]), m.point(q[2]), m.point(q[3])) > 0;
        m.invalidate_quality(t);
      }
      if (!ok) m.set_point(v, old);
    }
    return m.check();
  };
}

TEST(Pdr, OptimizationRoundsMayMoveInteriorPointsAndStayIdentical) {
  const SurfaceMesh cube = fixtures::unit_cube_surface();
  const SizingField h = uniform_sizing(0.12);
  const NativeLeafKernel kernel(barycenter_hook(20));
  const NativeLeafKernel optimizer(nudging_hook());
  bool saw_regions = true;
  PdrOptions o = depth2(1);
  o.optimize_kernel = &optimizer;
  o.optimize = [&](VolumeMesh& m) {
    saw_regions = !m.tet_regions.empty();  // the global pass must see one region
    return Status{};
  };
  PdrProfile prof;
  Result<VolumeMesh> a = run_pdr(cube, h, kernel, o, &prof);
  ASSERT_TRUE(a.ok()) << a.status().to_string();
  expect_valid(*a, cube);
  EXPECT_FALSE(saw_regions);
  std::vector<std::string> names;
  for (const RoundRecord& r : prof.rounds) names.push_back(r.name);
  ASSERT_GE(names.size(), 10u);
  EXPECT_EQ(std::count(names.begin(), names.end(), "seeds") + std::count(names.begin(), names.end(), "refinement"),
            static_cast<std::ptrdiff_t>(names.size() - 2));
  EXPECT_EQ(std::vector<std::string>(names.end() - 2, names.end()),
            (std::vector<std::string>{"optimization", "shifted optimization"}));
  // The same with 4 workers; and without the optimization rounds the points
  // the refinement made are where they were made: the rounds moved some.
  o.workers = 4;
  Result<VolumeMesh> b = run_pdr(cube, h, kernel, o, nullptr);
  ASSERT_TRUE(b.ok()) << b.status().to_string();
  EXPECT_EQ(a->points, b->points);
  EXPECT_EQ(a->tets, b->tets);
  o.optimize_kernel = nullptr;
  Result<VolumeMesh> c = run_pdr(cube, h, kernel, o, nullptr);
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  std::size_t moved = 0;
  for (std::size_t i = 0; i < std::min(a->points.size(), c->points.size()); ++i) moved += a->points[i] != c->points[i];
  EXPECT_GT(moved, 0u);
}

/// Runs `inner` and records the barycenters of the tets each task receives.
class RecordingKernel final : public LeafKernel {
 public:
  explicit RecordingKernel(RefineHook hook) : inner_(std::move(hook)) {}
  Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& h) const override {
    {
      const std::lock_guard lock(mutex_);
      for (const Tet& t : in.tets)
        received_.push_back(0.25 * (in.points[t[0]] + in.points[t[1]] + in.points[t[2]] + in.points[t[3]]));
    }
    return inner_.run(in, h);
  }
  std::string_view name() const override { return "recording"; }
  std::vector<Vec3> received() const {
    const std::lock_guard lock(mutex_);
    return received_;
  }

 private:
  NativeLeafKernel inner_;
  mutable std::mutex mutex_;
  mutable std::vector<Vec3> received_;
};

/// The native kernel, checking what each buffered task is given and makes:
/// its tets reach beyond its leaf's box (the buffer), its new points lie
/// inside the box.
class CoreCheckingKernel final : public LeafKernel {
 public:
  Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& h) const override {
    Result<LeafTaskOutput> out = inner_->run(in, h);
    if (!in.core || !out.ok()) return out;
    const Box& b = *in.core;
    const auto inside = [&](const Vec3& p) {
      for (int i = 0; i < 3; ++i)
        if (p[i] < b.lo[i] || p[i] > b.hi[i]) return false;
      return true;
    };
    const std::lock_guard lock(mutex_);
    ++tasks_;
    for (const Vec3& p : in.points) beyond_ += inside(p) ? 0 : 1;
    for (const Vec3& p : out->new_points) stray_ += inside(p) ? 0 : 1;
    added_ += out->new_points.size();
    return out;
  }
  std::string_view name() const override { return "native"; }
  mutable std::size_t tasks_ = 0, beyond_ = 0, stray_ = 0, added_ = 0;  // under mutex_

 private:
  std::unique_ptr<LeafKernel> inner_ = make_leaf_kernel("native").value();
  mutable std::mutex mutex_;
};

TEST(Pdr, BufferedTasksAddPointsOnlyInsideTheirLeaf) {
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const CoreCheckingKernel kernel;
  PdrOptions o = depth2(2);
  PdrProfile prof;
  Result<VolumeMesh> m = run_pdr(sp->surface, *sp->sizing, kernel, o, &prof);
  ASSERT_TRUE(m.ok()) << m.status().to_string();
  expect_valid(*m, sp->surface);
  std::size_t seed_tasks = 0;  // the seed rounds' tasks (their seeds lie in their leaf too)
  for (const RoundRecord& r : prof.rounds)
    if (r.name == "seeds") seed_tasks += r.leaves.size();
  EXPECT_GT(seed_tasks, 0u);
  EXPECT_EQ(kernel.tasks_, prof.leaf_count + seed_tasks);
  EXPECT_GT(kernel.beyond_, 0u);   // the buffer: points of the neighbours' tets
  EXPECT_GT(kernel.added_, 1000u);
  EXPECT_EQ(kernel.stray_, 0u);
  EXPECT_EQ(prof.interface_leaf_count, 0u);
}

/// The tets whose four points lie beyond x = x0, as sorted coordinate lists.
std::vector<std::array<Vec3, 4>> tets_beyond(const VolumeMesh& m, double x0) {
  std::vector<std::array<Vec3, 4>> out;
  for (const Tet& t : m.tets) {
    std::array<Vec3, 4> c{m.points[t[0]], m.points[t[1]], m.points[t[2]], m.points[t[3]]};
    if (std::all_of(c.begin(), c.end(), [&](const Vec3& p) { return p[0] > x0; })) {
      std::sort(c.begin(), c.end());
      out.push_back(c);
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(Pdr, OptimizationTasksGetOnlyTheSelectedTetsAndTheirHalo) {
  // sphere966 with the real refiner: edges about h long, so a vertex layer is short.
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const std::unique_ptr<LeafKernel> kernel = make_leaf_kernel("native").value();
  PdrOptions o = depth2(2);
  Result<VolumeMesh> plain = run_pdr(sp->surface, *sp->sizing, *kernel, o, nullptr);  // no optimization
  ASSERT_TRUE(plain.ok()) << plain.status().to_string();

  // Nothing selected: no task gets a tet, and the mesh is the unoptimized one.
  const RecordingKernel idle(nudging_hook());
  o.optimize_kernel = &idle;
  o.optimize_selects = [](const Vec3&, const Vec3&, const Vec3&, const Vec3&) { return false; };
  Result<VolumeMesh> none = run_pdr(sp->surface, *sp->sizing, *kernel, o, nullptr);
  ASSERT_TRUE(none.ok()) << none.status().to_string();
  EXPECT_TRUE(idle.received().empty());
  EXPECT_EQ(none->points, plain->points);
  EXPECT_EQ(tets_beyond(*none, -1e9), tets_beyond(*plain, -1e9));

  // The tets with a corner in the first fifth along x, with one vertex layer
  // (and one buffer layer in the final pass): the tasks (three rounds, the
  // last over one leaf, the whole grid at depth 2) get tets near that slab
  // only, and nothing far beyond it changes.
  const Box bb = sp->surface.bounds();
  const double lo = bb.lo[0], w = bb.hi[0] - bb.lo[0];
  const RecordingKernel near(nudging_hook());
  o.optimize_kernel = &near;
  o.optimize_halo = 1;
  o.optimize_buffer_layers = 1;
  o.optimize_selects = [x0 = lo + 0.2 * w](const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
    return std::min({a[0], b[0], c[0], d[0]}) < x0;
  };
  PdrProfile prof;
  Result<VolumeMesh> some = run_pdr(sp->surface, *sp->sizing, *kernel, o, &prof);
  ASSERT_TRUE(some.ok()) << some.status().to_string();
  expect_valid(*some, sp->surface);
  const std::vector<Vec3> got = near.received();
  ASSERT_FALSE(got.empty());
  double farthest = lo;
  for (const Vec3& b : got) farthest = std::max(farthest, b[0]);
  EXPECT_LT(farthest, lo + 0.5 * w);
  EXPECT_EQ(tets_beyond(*some, lo + 0.6 * w), tets_beyond(*plain, lo + 0.6 * w));
  EXPECT_NE(tets_beyond(*some, lo - 1), tets_beyond(*plain, lo - 1));  // the selection did change
  ASSERT_FALSE(prof.rounds.empty());
  EXPECT_EQ(prof.rounds.back().name, "final optimization");
  EXPECT_EQ(prof.rounds.back().leaves.size(), 1u);
}

TEST(Pdr, TheFinalOptimizationRunsAsBufferedTasksOnACoarserGrid) {
  // sphere966 at depth 5 with the real refiner and optimizer: the final pass
  // goes in two sweeps of colour rounds over the depth-3 grid (two levels
  // coarser), each task a leaf's selected tets with a buffer around them, and
  // no task gets the whole mesh's selection (the one task after the rounds,
  // if any, gets only the interior tets they left outside the targets, with
  // their halo); the result is valid and the same for any workers.
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const std::unique_ptr<LeafKernel> kernel = make_leaf_kernel("native").value();
  const std::unique_ptr<LeafKernel> optimizer = make_leaf_kernel("optimize").value();
  PdrOptions o = depth2(1);
  o.depth = 5;
  o.optimize_kernel = optimizer.get();
  o.optimize_selects = [](const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
    const AngleRange r = dihedral_range(a, b, c, d);
    return r.min < 15 || r.max > 150;
  };
  PdrProfile prof;
  Result<VolumeMesh> one = run_pdr(sp->surface, *sp->sizing, *kernel, o, &prof);
  ASSERT_TRUE(one.ok()) << one.status().to_string();
  expect_valid(*one, sp->surface);
  std::size_t final_rounds = 0, final_tasks = 0, final_sent = 0, swept_sent = 0, leftover_rounds = 0,
              leftover_sent = 0;
  for (const RoundRecord& r : prof.rounds) {
    if (r.name != "final optimization") continue;
    if (r.depth == 0) {  // the rounds' leftovers
      ++leftover_rounds;
      leftover_sent = r.tets_sent;
      continue;
    }
    ++final_rounds;
    final_tasks += r.leaves.size();
    final_sent = std::max(final_sent, r.tets_sent);
    swept_sent += r.tets_sent;
    EXPECT_EQ(r.depth, 3);
    EXPECT_LT(r.tets_sent, r.tets) << "a round got every tet of the mesh";
  }
  EXPECT_GT(final_rounds, 8u) << "two sweeps of colour rounds";
  EXPECT_GT(final_tasks, final_rounds) << "several tasks a round";
  EXPECT_GT(final_sent, 0u);
  EXPECT_LE(leftover_rounds, 1u);
  EXPECT_LT(leftover_sent, swept_sent / 4) << "the leftovers' task against the rounds' selections";
  o.workers = 3;
  Result<VolumeMesh> three = run_pdr(sp->surface, *sp->sizing, *kernel, o, nullptr);
  ASSERT_TRUE(three.ok()) << three.status().to_string();
  EXPECT_EQ(one->points, three->points);
  EXPECT_EQ(one->tets, three->tets);
}

TEST(Pdr, InterfaceRoundsGetOnlyTheTetsNearTheLastInterfaces) {
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const std::unique_ptr<LeafKernel> kernel = make_leaf_kernel("native").value();
  PdrOptions o = depth2(2);
  o.buffered = false;    // frozen leaf hulls, then the interface rounds
  o.interface_halo = 0;  // whole leaves
  PdrProfile whole_prof;
  Result<VolumeMesh> whole = run_pdr(sp->surface, *sp->sizing, *kernel, o, &whole_prof);
  ASSERT_TRUE(whole.ok()) << whole.status().to_string();
  o.interface_halo = 1;
  PdrProfile prof;
  Result<VolumeMesh> near = run_pdr(sp->surface, *sp->sizing, *kernel, o, &prof);
  ASSERT_TRUE(near.ok()) << near.status().to_string();
  expect_valid(*near, sp->surface);

  // The refinement round sends every tet; the interface rounds only part.
  ASSERT_EQ(prof.rounds.size(), 3u);
  EXPECT_EQ(prof.rounds[0].tets_sent, prof.rounds[0].tets);
  for (std::size_t r = 0; r < 3; ++r) EXPECT_EQ(whole_prof.rounds[r].tets_sent, whole_prof.rounds[r].tets);
  for (std::size_t r = 1; r < 3; ++r) {
    EXPECT_GT(prof.rounds[r].tets_sent, 0u) << prof.rounds[r].name;
    EXPECT_LT(prof.rounds[r].tets_sent, prof.rounds[r].tets) << prof.rounds[r].name;
  }
  // What the interface rounds are for is kept: the density and the worst angle.
  const double ratio = static_cast<double>(near->tets.size()) / static_cast<double>(whole->tets.size());
  EXPECT_NEAR(ratio, 1.0, 0.03);
  EXPECT_GT(measure_quality(*near).min_dihedral, measure_quality(*whole).min_dihedral - 1.0);
}

TEST(Pdr, ATetgenCrashOnALeafKeepsThatLeafUnrefined) {
  const SurfaceMesh cube = fixtures::unit_cube_surface();
  const SizingField h = uniform_sizing(0.15);
  TetgenLeafOptions crash;
  crash.inject_fault = TetgenOptions::Fault::kCrash;
  crash.fault_leaf = 3;
  const TetgenLeafKernel kernel(crash);
  PdrOptions o = depth2(2);
  o.interface_round = false;
  PdrProfile prof;
  Result<VolumeMesh> m = run_pdr(cube, h, kernel, o, &prof);
  ASSERT_TRUE(m.ok()) << m.status().to_string();
  expect_valid(*m, cube);
  EXPECT_EQ(prof.failed_leaves, 1u);
  EXPECT_NE(prof.first_failure.find("leaf 3"), std::string::npos) << prof.first_failure;
  EXPECT_NE(prof.first_failure.find("crashed"), std::string::npos) << prof.first_failure;
  const TetgenLeafKernel honest;
  PdrProfile p2;
  Result<VolumeMesh> ok = run_pdr(cube, h, honest, o, &p2);
  ASSERT_TRUE(ok.ok());
  EXPECT_EQ(p2.failed_leaves, 0u);
  o.keep_failed_leaves = false;
  Result<VolumeMesh> fails = run_pdr(cube, h, kernel, o, nullptr);
  ASSERT_FALSE(fails.ok());
  EXPECT_NE(fails.status().message().find("leaf 3"), std::string::npos) << fails.status().to_string();
}

/// Fails one leaf with a given status, as a dispatcher would when no worker
/// could run it; refines the others with the native kernel.
class FailingLeafKernel final : public LeafKernel {
 public:
  FailingLeafKernel(std::uint32_t leaf, Status status) : leaf_(leaf), status_(std::move(status)) {}
  Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& sizing) const override {
    if (in.leaf == leaf_) return status_;
    return native_.run(in, sizing);
  }
  std::string_view name() const override { return "failing"; }

 private:
  std::uint32_t leaf_;
  Status status_;
  NativeLeafKernel native_{barycenter_hook(5)};
};

TEST(Pdr, ATaskThatCouldNotRunFailsTheRunInsteadOfKeepingTheLeaf) {
  // Keeping a leaf unrefined is for a kernel that gave up on it (the same
  // anywhere); a dispatcher's failure must fail the run, or the output would
  // depend on faults.
  const SurfaceMesh cube = fixtures::unit_cube_surface();
  const SizingField h = uniform_sizing(0.15);
  for (const Status& s : {io_error("no valid result after 4 attempts"), resource_exhausted("task too large"),
                          invalid_input("worker refused the task")}) {
    Result<VolumeMesh> m = run_pdr(cube, h, FailingLeafKernel(3, s), depth2(2), nullptr);
    ASSERT_FALSE(m.ok()) << s.to_string();
    EXPECT_EQ(m.status().code(), s.code());
  }
  PdrProfile prof;
  Result<VolumeMesh> kept = run_pdr(cube, h, FailingLeafKernel(3, internal_error("kernel crashed")), depth2(2), &prof);
  ASSERT_TRUE(kept.ok()) << kept.status().to_string();
  expect_valid(*kept, cube);
  EXPECT_GE(prof.failed_leaves, 1u);
}

TEST(Pdr, TetgenKernelByteIdenticalFor1And4Workers) {
  const SurfaceMesh cube = fixtures::unit_cube_surface();
  const SizingField h = uniform_sizing(0.2);
  const TetgenLeafKernel kernel;
  PdrOptions o = depth2(1);
  o.interface_round = false;
  Result<VolumeMesh> a = run_pdr(cube, h, kernel, o, nullptr);
  o.workers = 4;
  Result<VolumeMesh> b = run_pdr(cube, h, kernel, o, nullptr);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->points, b->points);
  EXPECT_EQ(a->tets, b->tets);
}

/// Returns the honest result minus its last tet (a frozen face goes missing).
class DroppingKernel final : public LeafKernel {
 public:
  Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& h) const override {
    Result<LeafTaskOutput> r = inner_.run(in, h);
    if (r.ok() && in.leaf == 3 && !r->tets.empty()) r->tets.pop_back();
    return r;
  }
  std::string_view name() const override { return "dropping"; }

 private:
  NativeLeafKernel inner_{barycenter_hook(5)};
};

TEST(Pdr, RejectsALyingKernel) {
  const DroppingKernel kernel;
  Result<VolumeMesh> m = run_pdr(fixtures::unit_cube_surface(), uniform_sizing(0.2), kernel, depth2(2), nullptr);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.status().message().find("leaf 3 result rejected"), std::string::npos) << m.status().to_string();
}

/// Adds `extra` unused new points to every result (an inflated answer).
class InflatingKernel final : public LeafKernel {
 public:
  explicit InflatingKernel(std::size_t extra) : extra_(extra) {}
  Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& h) const override {
    Result<LeafTaskOutput> r = inner_.run(in, h);
    if (r.ok()) r->new_points.resize(r->new_points.size() + extra_, in.points.front());
    return r;
  }
  std::string_view name() const override { return "inflating"; }

 private:
  std::size_t extra_;
  NativeLeafKernel inner_{barycenter_hook(5)};
};

TEST(Pdr, RejectsAResultLargerThanItsLeafCanHold) {
  // h = 0.25 over a depth-2 cube: a leaf's limit is a few tens of kilobytes.
  const InflatingKernel kernel(100000);
  Result<VolumeMesh> m = run_pdr(fixtures::unit_cube_surface(), uniform_sizing(0.25), kernel, depth2(), nullptr);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(m.status().message().find("its leaf can hold"), std::string::npos) << m.status().to_string();
}

/// The native kernel, recording the largest result size / leaf_output_byte_limit.
class MeasuringKernel final : public LeafKernel {
 public:
  Result<LeafTaskOutput> run(const LeafTaskInput& in, const SizingField& h) const override {
    Result<LeafTaskOutput> r = inner_->run(in, h);
    if (r.ok()) {
      const double ratio =
          static_cast<double>(r->encode().size()) / static_cast<double>(leaf_output_byte_limit(in, h));
      const std::lock_guard lock(mutex_);
      worst_ = std::max(worst_, ratio);
    }
    return r;
  }
  std::string_view name() const override { return "native"; }
  double worst() const { return worst_; }

 private:
  std::unique_ptr<LeafKernel> inner_ = make_leaf_kernel("native").value();
  mutable std::mutex mutex_;
  mutable double worst_ = 0;
};

TEST(Pdr, HonestResultsStayFarBelowTheirLeafsByteLimit) {
  // The limit is a bound an honest kernel never nears: on sphere966's graded
  // field, every round's results stay under a tenth of it.
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const MeasuringKernel kernel;
  PdrOptions o = depth2(2);
  o.initial_volume_divisor = PdrOptions{}.initial_volume_divisor;
  Result<VolumeMesh> m = run_pdr(sp->surface, *sp->sizing, kernel, o, nullptr);
  ASSERT_TRUE(m.ok()) << m.status().to_string();
  expect_valid(*m, sp->surface);
  EXPECT_GT(kernel.worst(), 0);
  EXPECT_LT(kernel.worst(), 0.1);
}

TEST(Pdr, InterfaceRoundRefinesMore) {
  const SurfaceMesh cube = fixtures::unit_cube_surface();
  const SizingField h = uniform_sizing(0.1);
  const NativeLeafKernel kernel(barycenter_hook(30));
  PdrOptions frozen = depth2();
  frozen.buffered = false;  // frozen leaf hulls, then the interface rounds
  PdrOptions once = frozen;
  once.interface_round = false;
  PdrProfile p1, p2;
  Result<VolumeMesh> a = run_pdr(cube, h, kernel, once, &p1);
  Result<VolumeMesh> b = run_pdr(cube, h, kernel, frozen, &p2);
  ASSERT_TRUE(a.ok() && b.ok());
  expect_valid(*a, cube);
  EXPECT_EQ(p1.interface_leaf_count, 0u);
  EXPECT_GT(b->points.size(), a->points.size());
}

TEST(Pdr, RejectsBadOptions) {
  const NativeLeafKernel kernel(barycenter_hook(1));
  PdrOptions o;
  o.depth = kMaxDepth + 1;
  EXPECT_EQ(run_pdr(fixtures::unit_cube_surface(), uniform_sizing(0.5), kernel, o, nullptr).status().code(),
            StatusCode::kInvalidInput);
  o = PdrOptions{};
  o.initial_volume_divisor = 0;
  EXPECT_EQ(run_pdr(fixtures::unit_cube_surface(), uniform_sizing(0.5), kernel, o, nullptr).status().code(),
            StatusCode::kInvalidInput);
}

TEST(Pdr, DefaultDepthFollowsTheSizing) {
  const NativeLeafKernel kernel(barycenter_hook(1));
  PdrOptions o;
  PdrProfile prof;
  // h = 0.2: about 1 / regular_tet_volume(0.2) = 1060 tets expected, too few
  // to be worth leaf tasks: depth 0, the serial path.
  Result<VolumeMesh> m = run_pdr(fixtures::unit_cube_surface(), uniform_sizing(0.2), kernel, o, &prof);
  ASSERT_TRUE(m.ok()) << m.status().to_string();
  EXPECT_EQ(prof.depth, 0);
  o.min_parallel_tets = 0;
  o.final_tets_per_leaf = 1000;  // so depth 1
  o.min_leaf_width = 0;          // (its leaves 2.5 spacings wide)
  m = run_pdr(fixtures::unit_cube_surface(), uniform_sizing(0.2), kernel, o, &prof);
  ASSERT_TRUE(m.ok()) << m.status().to_string();
  EXPECT_EQ(prof.depth, 1);
  EXPECT_EQ(prof.depth, default_depth(static_cast<std::size_t>(1.0 / regular_tet_volume(0.2)), 1000));
}

TEST(Pdr, ProgressCountsEveryMergedLeaf) {
  const SurfaceMesh cube = fixtures::unit_cube_surface();
  const SizingField h = uniform_sizing(0.1);
  const NativeLeafKernel kernel(barycenter_hook(5));
  PdrOptions o = depth2(2);
  std::vector<std::string> phases;
  std::size_t merged_refinement = 0, last_tets = 0;
  o.progress = [&](const PdrProgress& p) {
    if (phases.empty() || phases.back() != p.phase) phases.emplace_back(p.phase);
    if (p.phase == "refinement" && p.leaves_done != merged_refinement) {  // (a round's start repeats the count)
      EXPECT_EQ(p.leaves_done, merged_refinement + 1);  // one call per merged leaf, in order
      merged_refinement = p.leaves_done;
    }
    last_tets = p.tets;
    return true;
  };
  PdrProfile prof;
  Result<VolumeMesh> m = run_pdr(cube, h, kernel, o, &prof);
  ASSERT_TRUE(m.ok()) << m.status().to_string();
  expect_valid(*m, cube);
  // Leaves counted over all the refinement's rounds; the seed rounds report as seeds.
  EXPECT_EQ(phases, (std::vector<std::string>{"initial mesh", "seeds", "refinement"}));
  EXPECT_EQ(merged_refinement, prof.leaf_count);
  EXPECT_EQ(last_tets, m->tets.size());  // the last merge's count is the final one (no optimization)
}

TEST(Pdr, ProgressCanStopTheRun) {
  const NativeLeafKernel kernel(barycenter_hook(5));
  PdrOptions o = depth2(2);
  std::size_t calls_after_stop = 0;
  bool stopped = false;
  o.progress = [&](const PdrProgress& p) {
    if (stopped) ++calls_after_stop;
    stopped = stopped || (p.phase == "refinement" && p.leaves_done == 3);
    return !stopped;
  };
  Result<VolumeMesh> m = run_pdr(fixtures::unit_cube_surface(), uniform_sizing(0.1), kernel, o, nullptr);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().code(), StatusCode::kCancelled) << m.status().to_string();
  EXPECT_EQ(calls_after_stop, 0u);
}

TEST(Pdr, ACallerMadeInitialMeshGivesRunPdrsResult) {
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const NativeLeafKernel kernel(barycenter_hook(20));
  const PdrOptions o = depth2(2);
  Result<VolumeMesh> whole = run_pdr(sp->surface, *sp->sizing, kernel, o, nullptr);
  ASSERT_TRUE(whole.ok()) << whole.status().to_string();
  Result<PdrPlan> plan = plan_pdr(sp->surface, surface_spacing(sp->surface, *sp->sizing), o, kernel);
  ASSERT_TRUE(plan.ok()) << plan.status().to_string();
  EXPECT_EQ(plan->depth, 2);
  Result<InitialMesh> initial = initial_mesh(sp->surface, *plan);
  ASSERT_TRUE(initial.ok()) << initial.status().to_string();
  PdrProfile profile;
  Result<VolumeMesh> split = run_pdr(sp->surface, *sp->sizing, kernel, o, &profile, *plan, std::move(*initial), 1.5);
  ASSERT_TRUE(split.ok()) << split.status().to_string();
  EXPECT_EQ(split->points, whole->points);
  EXPECT_EQ(split->tets, whole->tets);
  EXPECT_EQ(split->tet_regions, whole->tet_regions);
  EXPECT_EQ(profile.initial, 1.5);
  EXPECT_GE(profile.total, 1.5);
}

TEST(Pdr, DepthZeroStartsFromTheSerialInitialMesh) {
  // One leaf needs no seeds to balance: at depth 0 the native kernel starts
  // from the boundary-conforming mesh that mesh_serial refines (seeds there
  // only moved the count: sphere966 0.963 times the serial tets with them),
  // while at depth 1 the seed lattice fills the leaves.
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const NativeLeafKernel kernel(barycenter_hook(20));
  const double h = surface_spacing(sp->surface, *sp->sizing);
  PdrOptions o;
  o.depth = 0;
  Result<PdrPlan> plan = plan_pdr(sp->surface, h, o, kernel);
  ASSERT_TRUE(plan.ok()) << plan.status().to_string();
  EXPECT_FALSE(plan->tetgen.max_volume.has_value());  // no seed lattice
  EXPECT_EQ(tetgen_switches(plan->tetgen), tetgen_switches(TetgenOptions{}));
  o.depth = 1;
  plan = plan_pdr(sp->surface, h, o, kernel);
  ASSERT_TRUE(plan.ok()) << plan.status().to_string();
  EXPECT_TRUE(plan->tetgen.max_volume.has_value());
  EXPECT_TRUE(plan->tetgen.seeds_only);
}

TEST(Pdr, ADepthWhoseLeavesWouldBeNarrowerThanMinLeafWidthRunsShallower) {
  // The unit cube at h = 0.1 with leaves at least 3 h wide: depth 1 (0.5
  // wide) is the deepest; depth 2 leaves would be 2.5 h wide.
  const SurfaceMesh cube = fixtures::unit_cube_surface();
  const NativeLeafKernel kernel(barycenter_hook(1));
  PdrOptions o;
  o.depth = 4;
  Result<PdrPlan> plan = plan_pdr(cube, 0.1, o, kernel);
  ASSERT_TRUE(plan.ok()) << plan.status().to_string();
  EXPECT_EQ(plan->depth, 1);
  EXPECT_EQ(plan->requested_depth, 4);
  o.depth = 1;  // wide enough: as asked
  plan = plan_pdr(cube, 0.1, o, kernel);
  ASSERT_TRUE(plan.ok()) << plan.status().to_string();
  EXPECT_EQ(plan->depth, 1);
  EXPECT_EQ(plan->requested_depth, -1);
  o.depth = 4;
  o.min_leaf_width = 0;  // any depth
  plan = plan_pdr(cube, 0.1, o, kernel);
  ASSERT_TRUE(plan.ok()) << plan.status().to_string();
  EXPECT_EQ(plan->depth, 4);
  o.min_leaf_width = -1;
  EXPECT_EQ(plan_pdr(cube, 0.1, o, kernel).status().code(), StatusCode::kInvalidInput);
  // The run says what was asked, and meshes at the depth it ran.
  o.min_leaf_width = 3;
  PdrProfile prof;
  Result<VolumeMesh> m = run_pdr(cube, uniform_sizing(0.1), kernel, o, &prof);
  ASSERT_TRUE(m.ok()) << m.status().to_string();
  expect_valid(*m, cube, false);
  EXPECT_EQ(prof.depth, 1);
  EXPECT_EQ(prof.requested_depth, 4);
}

TEST(Pdr, ASurfaceTooSmallForLeafTasksGetsTheSerialMesh) {
  // sphere966 at its own spacing: about 15,000 tets, under min_parallel_tets,
  // so depth 0, where mesh_parallel is the serial mesher.
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  ParallelOptions o;
  o.pdr.workers = 2;
  Result<ParallelResult> run = mesh_parallel(sp->surface, o);
  ASSERT_TRUE(run.ok()) << run.status().to_string();
  expect_valid(run->mesh, sp->surface, true);
  EXPECT_EQ(run->profile.depth, 0);
  EXPECT_EQ(run->profile.leaf_count, 1u);
  EXPECT_TRUE(run->mesh.tet_regions.empty());  // one region: none
  Result<SerialResult> serial = mesh_serial(sp->surface, SerialOptions{});
  ASSERT_TRUE(serial.ok()) << serial.status().to_string();
  EXPECT_EQ(run->mesh.points, serial->mesh.points);
  EXPECT_EQ(run->mesh.tets, serial->mesh.tets);
  // Asked for leaves, it makes them.
  o.pdr.depth = 1;
  Result<ParallelResult> leaves = mesh_parallel(sp->surface, o);
  ASSERT_TRUE(leaves.ok()) << leaves.status().to_string();
  EXPECT_EQ(leaves->profile.depth, 1);
  EXPECT_GT(leaves->profile.leaf_count, 1u);
}

TEST(Pdr, ASizeThatRisesOverMostOfThePartGetsTheSerialMesh) {
  // The unit cube in 12 triangles at --size 0.025: one h everywhere would be
  // about 500,000 tets, but h rises from the triangles' spacing over the whole
  // cube, and the plan's estimate says so: depth 0, the serial mesh.
  const SurfaceMesh cube = fixtures::unit_cube_surface();
  ParallelOptions o;
  o.sizing.size = 0.025;
  o.pdr.workers = 2;
  Result<ParallelResult> run = mesh_parallel(cube, o);
  ASSERT_TRUE(run.ok()) << run.status().to_string();
  expect_valid(run->mesh, cube, true);
  EXPECT_EQ(run->profile.depth, 0);
  SerialOptions serial_options;
  serial_options.sizing = o.sizing;
  Result<SerialResult> serial = mesh_serial(cube, serial_options);
  ASSERT_TRUE(serial.ok()) << serial.status().to_string();
  EXPECT_EQ(run->mesh.points, serial->mesh.points);
  EXPECT_EQ(run->mesh.tets, serial->mesh.tets);
}

TEST(Pdr, AFarFieldsGradedSpacingPlansByTheEstimate) {
  // sphere966 in a box 10 body lengths away, at the default graded spacing:
  // about 83,000 tets, most of the box's volume in a few coarse ones. The
  // volume over a tet of the surface's mean spacing would count the box as
  // refined as the body (several leaves of seeds over it, and more tets than
  // the serial mesh); the plan's estimate of the graded field says depth 0,
  // the serial mesh.
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  Result<FarfieldDomain> domain = make_farfield(sp->surface, {10, FarfieldShape::kBox});
  ASSERT_TRUE(domain.ok()) << domain.status().to_string();
  ParallelOptions o;
  o.pdr.workers = 2;
  Result<ParallelResult> run = mesh_parallel(domain->surface, o);
  ASSERT_TRUE(run.ok()) << run.status().to_string();
  expect_valid(run->mesh, domain->surface, true);
  EXPECT_EQ(run->profile.depth, 0);
  Result<SerialResult> serial = mesh_serial(domain->surface, SerialOptions{});
  ASSERT_TRUE(serial.ok()) << serial.status().to_string();
  EXPECT_EQ(run->mesh.tets, serial->mesh.tets);
}

TEST(Pdr, AFarFieldOneDepthDeeperKeepsTheSerialTetCount) {
  // elephant in a box 2 body lengths away, at the default graded spacing and
  // one depth below the default: the seed lattice spaced for the smaller
  // leaves is finer than the field's spacing over most of the box, and
  // without its thinning (PdrPlan::seed_min_tets) the mesh had an eighth more
  // tets than the serial one.
  const SurfaceMesh elephant = fixtures::corpus_surface("elephant");
  Result<FarfieldDomain> domain = make_farfield(elephant, {2, FarfieldShape::kBox});
  ASSERT_TRUE(domain.ok()) << domain.status().to_string();
  SerialOptions so;
  so.optimize.reset();
  Result<SerialResult> serial = mesh_serial(domain->surface, so);
  ASSERT_TRUE(serial.ok()) << serial.status().to_string();
  ParallelOptions o;
  o.pdr.workers = 2;
  o.optimize.reset();
  Result<ParallelResult> planned = mesh_parallel(domain->surface, o);
  ASSERT_TRUE(planned.ok()) << planned.status().to_string();
  o.pdr.depth = planned->profile.depth + 1;
  Result<ParallelResult> deeper = mesh_parallel(domain->surface, o);
  ASSERT_TRUE(deeper.ok()) << deeper.status().to_string();
  expect_valid(deeper->mesh, domain->surface, true);
  const double ratio = static_cast<double>(deeper->mesh.tets.size()) / static_cast<double>(serial->mesh.tets.size());
  EXPECT_NEAR(ratio, 1.0, 0.03) << deeper->mesh.tets.size() << " tets at depth " << o.pdr.depth << " against "
                                << serial->mesh.tets.size() << " serial";
}

TEST(Pdr, TheOptimizationRoundsLeaveNoInteriorTetOutsideTheTargets) {
  // fandisk in a box 5 body lengths away at depth 5: the final optimization
  // runs in rounds over a grid two levels up, each task's hull frozen, and
  // left one tet with no point on the surface outside [15, 150] degrees
  // (6.3 / 169.8) where two tasks' buffers met, until the rounds' leftovers
  // got one more task without cuts.
  const SurfaceMesh domain = fandisk_in_a_box();
  ASSERT_FALSE(domain.triangles.empty());
  ParallelOptions o;
  o.pdr.workers = 2;
  o.pdr.depth = 5;
  Result<ParallelResult> run = mesh_parallel(domain, o);
  ASSERT_TRUE(run.ok()) << run.status().to_string();
  expect_valid(run->mesh, domain, true);
  int final_rounds = 0;
  for (const RoundRecord& r : run->profile.rounds)
    if (r.name == "final optimization" && r.depth > 0) ++final_rounds;
  EXPECT_GT(final_rounds, 1) << "the final optimization ran as one task";
  const VolumeMesh& m = run->mesh;
  const auto surface_points = static_cast<Index>(domain.points.size());
  const DihedralBounds targets(15.0, 150.0);
  std::size_t interior = 0, outside = 0;
  for (const Tet& k : m.tets) {
    if (std::any_of(k.begin(), k.end(), [&](Index v) { return v < surface_points; })) continue;
    ++interior;
    if (targets.outside(m.points[k[0]], m.points[k[1]], m.points[k[2]], m.points[k[3]])) ++outside;
  }
  EXPECT_GT(interior, 10000u);
  EXPECT_EQ(outside, 0u) << "of " << interior << " interior tets";
}

TEST(Pdr, DeepGridsKeepTheSeedsTheirRoundsInsert) {
  // sphere966 at 4% of its diagonal: at depth 4 the seed lattice is wider
  // than a leaf one level up, so the seed rounds' leaves must be coarser
  // still, or seeds would lie in no tet of their task and be lost (the
  // refinement then made under half the tets of depth 2).
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  ParallelOptions o;
  o.pdr.workers = 2;
  o.optimize.reset();
  o.sizing.size = 0.04 * sp->surface.bounds().diagonal();
  std::size_t tets[2] = {};
  for (int i = 0; i < 2; ++i) {
    o.pdr.depth = i == 0 ? 2 : 4;
    Result<ParallelResult> r = mesh_parallel(sp->surface, o);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    expect_valid(r->mesh, sp->surface, true);
    tets[i] = r->mesh.tets.size();
    int seed_depth = -1;
    for (const RoundRecord& round : r->profile.rounds)
      if (round.name == "seeds") seed_depth = round.depth;
    EXPECT_GE(seed_depth, 0) << "depth " << o.pdr.depth << ": seed rounds";
    EXPECT_LT(seed_depth, o.pdr.depth);
  }
  EXPECT_GT(static_cast<double>(tets[1]), 0.8 * static_cast<double>(tets[0])) << tets[1] << " against " << tets[0];
}

TEST(Pdr, MeshParallelIsByteIdenticalWithThePlanBesideTetGen) {
  // 1 worker: TetGen's boundary mesh, then the plan; 2 and 4: the plan from
  // SizingField::surface_values beside TetGen. The bytes must not change.
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const NativeLeafKernel kernel(barycenter_hook(20));
  ParallelOptions o;
  o.pdr = depth2();
  o.optimize.reset();
  std::string ref;
  for (std::size_t w : {1u, 2u, 4u}) {
    o.pdr.workers = w;
    Result<ParallelResult> r = mesh_parallel(sp->surface, o, &kernel);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    if (w == 1) {
      expect_valid(r->mesh, sp->surface, true);
      ref = meshb_bytes(r->mesh, "pdr_mp1");
      continue;
    }
    EXPECT_GT(r->profile.background, 0.0) << w;
    EXPECT_EQ(meshb_bytes(r->mesh, "pdr_mp" + std::to_string(w)), ref) << w;
  }
}

TEST(Pdr, TheOptimizeKernelsAreMeshParallelsOwnOptimization) {
  // A coordinator sends the optimization's leaf tasks to its workers as
  // make_leaf_kernel("optimize") (the rounds, from depth 5) and
  // ("optimize-final") (the one final task, below it): those kernels must
  // give the bytes of the optimizers mesh_parallel runs in its own process.
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  const std::unique_ptr<LeafKernel> optimizer = make_leaf_kernel("optimize").value();
  const std::unique_ptr<LeafKernel> last = make_leaf_kernel("optimize-final").value();
  EXPECT_EQ(optimizer->name(), "optimize");
  EXPECT_EQ(last->name(), "optimize-final");
  for (const int depth : {2, 5}) {
    ParallelOptions o;
    o.pdr = depth2(2);
    o.pdr.depth = depth;
    Result<ParallelResult> own = mesh_parallel(sp->surface, o);
    ASSERT_TRUE(own.ok()) << own.status().to_string();
    const std::vector<RoundRecord>& done = own->profile.rounds;
    const bool rounds = std::any_of(done.begin(), done.end(),
                                    [](const RoundRecord& r) { return r.name == "optimization"; });
    EXPECT_EQ(rounds, depth == 5) << "optimization rounds only where the final pass is not one task";
    Result<ParallelResult> given = mesh_parallel(sp->surface, o, nullptr, optimizer.get(), last.get());
    ASSERT_TRUE(given.ok()) << given.status().to_string();
    expect_valid(given->mesh, sp->surface, true);
    EXPECT_EQ(meshb_bytes(given->mesh, "pdr_opt_given"), meshb_bytes(own->mesh, "pdr_opt_own")) << depth;
    // Given the rounds' kernel alone, the final task runs here, as its own.
    Result<ParallelResult> rounds_only = mesh_parallel(sp->surface, o, nullptr, optimizer.get());
    ASSERT_TRUE(rounds_only.ok()) << rounds_only.status().to_string();
    EXPECT_EQ(meshb_bytes(rounds_only->mesh, "pdr_opt_rounds"), meshb_bytes(own->mesh, "pdr_opt_own")) << depth;
    // The optimization did change the mesh, so the comparison says something.
    o.optimize.reset();
    Result<ParallelResult> none = mesh_parallel(sp->surface, o);
    ASSERT_TRUE(none.ok()) << none.status().to_string();
    EXPECT_NE(meshb_bytes(none->mesh, "pdr_opt_none"), meshb_bytes(own->mesh, "pdr_opt_own")) << depth;
  }
}

// Next to hinge's needle triangles the optimization's task removes points
// too (final_optimize_options: every point keeps its index, a removed one is
// left in no tet and run_pdr drops it), and the mesh validates; a hook whose
// optimize() renumbered the points instead is refused, and its leaf stays as
// it came.
TEST(Pdr, OptimizationLeafTasksRemovePointsAndKeepTheIndices) {
  const SurfaceMesh hinge = fixtures::corpus_surface("hinge");
  ParallelOptions o;
  o.pdr = depth2(2);
  o.pdr.depth = 1;  // a depth whose optimization tasks meet removable points
  std::atomic<std::size_t> removed{0};
  const NativeLeafKernel counting(
      [&](TetMesh& leaf, const SizingField& h, const std::optional<Box>&) {
        Result<OptimizeStats> st = optimize(leaf, &h, final_optimize_options());
        if (st.ok()) removed += st->points_removed;
        return st.status();
      },
      "optimize-final");
  Result<ParallelResult> kept = mesh_parallel(hinge, o, nullptr, &counting, &counting);
  ASSERT_TRUE(kept.ok()) << kept.status().to_string();
  EXPECT_GT(removed.load(), 0u);
  EXPECT_EQ(kept->profile.failed_leaves, 0u) << kept->profile.first_failure;
  expect_valid(kept->mesh, hinge, true);
  // The profile counts the points of the result, after the removals.
  EXPECT_EQ(kept->profile.interior_points, kept->mesh.points.size() - hinge.points.size());
  Result<ParallelResult> own = mesh_parallel(hinge, o);
  ASSERT_TRUE(own.ok()) << own.status().to_string();
  EXPECT_EQ(meshb_bytes(own->mesh, "pdr_removal_own"), meshb_bytes(kept->mesh, "pdr_removal_counted"));

  const NativeLeafKernel renumbering([](TetMesh& leaf, const SizingField& h, const std::optional<Box>&) { return optimize(leaf, &h).status(); },
                                     "optimize");
  Result<ParallelResult> refused = mesh_parallel(hinge, o, nullptr, &renumbering, &renumbering);
  ASSERT_TRUE(refused.ok()) << refused.status().to_string();
  EXPECT_GE(refused->profile.failed_leaves, 1u);
  EXPECT_NE(refused->profile.first_failure.find("dropped input points"), std::string::npos)
      << refused->profile.first_failure;
  expect_valid(refused->mesh, hinge, true);
}

TEST(Pdr, ResumingFromEachRoundsCheckpointGivesTheSameBytes) {
  // A coordinator that restarts goes on from the last round's checkpoint: the
  // result must be the uninterrupted run's, from every round.
  const Sphere* sp = sphere();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable";
  ParallelOptions o;
  o.pdr = depth2(2);
  o.pdr.depth = 5;  // deep enough for optimization rounds before the final pass
  std::vector<std::string> saved;
  std::vector<std::string> names;
  o.pdr.checkpoint = [&](const PdrCheckpoint& c) {
    EXPECT_EQ(c.rounds_done, static_cast<int>(saved.size()) + 1);
    EXPECT_EQ(c.mesh.tet_regions.size(), c.mesh.tets.size());
    names.push_back(c.round);
    saved.push_back(c.encode());
    return Status{};
  };
  Result<ParallelResult> whole = mesh_parallel(sp->surface, o);
  ASSERT_TRUE(whole.ok()) << whole.status().to_string();
  expect_valid(whole->mesh, sp->surface, true);
  const std::string want = meshb_bytes(whole->mesh, "pdr_resume_whole");
  EXPECT_EQ(names, (std::vector<std::string>{"refinement", "optimization", "shifted optimization",
                                             "final optimization"}));
  o.pdr.checkpoint = nullptr;
  for (std::size_t k = 0; k < saved.size(); ++k) {
    Result<PdrCheckpoint> c = PdrCheckpoint::decode(saved[k]);
    ASSERT_TRUE(c.ok()) << c.status().to_string();
    EXPECT_EQ(c->rounds_done, static_cast<int>(k) + 1);
    EXPECT_EQ(c->encode(), saved[k]);
    o.pdr.resume = &*c;
    Result<ParallelResult> resumed = mesh_parallel(sp->surface, o);
    ASSERT_TRUE(resumed.ok()) << names[k] << ": " << resumed.status().to_string();
    EXPECT_TRUE(c->mesh.tets.empty()) << "the run took the checkpoint's mesh";
    std::vector<std::string> steps;  // the resumed run's rounds, one name per step
    for (const RoundRecord& r : resumed->profile.rounds)
      if (steps.empty() || steps.back() != r.name) steps.push_back(r.name);
    EXPECT_EQ(steps, std::vector<std::string>(names.begin() + static_cast<std::ptrdiff_t>(k) + 1, names.end()))
        << names[k];
    EXPECT_EQ(meshb_bytes(resumed->mesh, "pdr_resume_" + std::to_string(k)), want) << "resumed after " << names[k];
  }
}

TEST(Pdr, AResumedFarFieldJobKeepsItsPlannedGrid) {
  // A default depth planned from the estimate (fandisk 5 body lengths inside
  // a box: depth 2, where the volume over a tet of the surface's spacing says
  // 4): a run resumed from its first checkpoint goes on over the same grid.
  const SurfaceMesh domain = fandisk_in_a_box();
  ASSERT_FALSE(domain.triangles.empty());
  ParallelOptions o;
  o.pdr.workers = 2;
  std::optional<std::string> first;
  o.pdr.checkpoint = [&](const PdrCheckpoint& c) {
    if (!first) first = c.encode();
    return Status{};
  };
  Result<ParallelResult> whole = mesh_parallel(domain, o);
  ASSERT_TRUE(whole.ok()) << whole.status().to_string();
  expect_valid(whole->mesh, domain, true);
  EXPECT_EQ(whole->profile.depth, 2);
  ASSERT_TRUE(first.has_value());
  Result<PdrCheckpoint> c = PdrCheckpoint::decode(*first);
  ASSERT_TRUE(c.ok()) << c.status().to_string();
  o.pdr.checkpoint = nullptr;
  o.pdr.resume = &*c;
  Result<ParallelResult> resumed = mesh_parallel(domain, o);
  ASSERT_TRUE(resumed.ok()) << resumed.status().to_string();
  EXPECT_EQ(resumed->profile.depth, 2);
  EXPECT_EQ(meshb_bytes(resumed->mesh, "pdr_resume_farfield"), meshb_bytes(whole->mesh, "pdr_whole_farfield"));
}

TEST(Pdr, ACheckpointThatDoesNotDecodeIsRefused) {
  PdrCheckpoint c;
  c.rounds_done = 2;
  c.round = "interface round";
  c.mesh.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  c.mesh.tets = {{0, 1, 2, 3}};
  c.mesh.boundary = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  c.mesh.boundary_ids = {-1, 0, 7, 7};
  c.mesh.tet_regions = {5};
  const std::string bytes = c.encode();
  Result<PdrCheckpoint> back = PdrCheckpoint::decode(bytes);
  ASSERT_TRUE(back.ok()) << back.status().to_string();
  EXPECT_EQ(back->round, c.round);
  EXPECT_EQ(back->mesh.points, c.mesh.points);
  EXPECT_EQ(back->mesh.tets, c.mesh.tets);
  EXPECT_EQ(back->mesh.boundary_ids, c.mesh.boundary_ids);
  EXPECT_EQ(back->mesh.tet_regions, c.mesh.tet_regions);
  for (std::size_t cut : {std::size_t{0}, std::size_t{5}, bytes.size() / 2, bytes.size() - 1}) {
    EXPECT_EQ(PdrCheckpoint::decode(bytes.substr(0, cut)).status().code(), StatusCode::kInvalidInput) << cut;
  }
  EXPECT_EQ(PdrCheckpoint::decode(bytes + "x").status().code(), StatusCode::kInvalidInput);
  std::string damaged = bytes;
  damaged[damaged.size() / 2] ^= 1;  // one bit of a coordinate: the counts still read
  const Status refused = PdrCheckpoint::decode(damaged).status();
  EXPECT_EQ(refused.code(), StatusCode::kInvalidInput);
  EXPECT_NE(refused.message().find("digest"), std::string::npos) << refused.message();
  PdrCheckpoint bad = c;
  bad.mesh.tets[0][3] = 4;  // no such point
  EXPECT_EQ(PdrCheckpoint::decode(bad.encode()).status().code(), StatusCode::kInvalidInput);
  bad = c;
  bad.mesh.tet_regions.clear();  // a leaf for each tet is part of the state
  EXPECT_EQ(PdrCheckpoint::decode(bad.encode()).status().code(), StatusCode::kInvalidInput);
}

}  // namespace
}  // namespace pdrmesh
