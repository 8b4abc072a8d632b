// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the final optimization (reconnection, sliver removal, smoothing).
#include "pdrmesh/optimize.hpp"


#include <gtest/gtest.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <map>
#include <optional>
#include <vector>

#include "pdrmesh/insert.hpp"
#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/quality.hpp"
#include "pdrmesh/refine.hpp"
#include "pdrmesh/size_band.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/validate.hpp"
#include "tet_fixtures.hpp"

namespace pdrmesh {
namespace {

using fixtures::max_dihedral;

/// n x n x n unit cubes, each cut into the 6 Kuhn tets of fixtures::cube();
/// point (x, y, z) has index x + (n+1) (y + (n+1) z). The hull is the frozen boundary.
VolumeMesh kuhn_grid_with_hull(int n) {
  VolumeMesh m;
  const auto id = [n](int x, int y, int z) { return static_cast<Index>(x + (n + 1) * (y + (n + 1) * z)); };
  for (int z = 0; z <= n; ++z)
    for (int y = 0; y <= n; ++y)
      for (int x = 0; x <= n; ++x) m.points.push_back({double(x), double(y), double(z)});
  const VolumeMesh cube = fixtures::cube();
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        for (const Tet& k : cube.tets) {
          Tet g{};
          for (int i = 0; i < 4; ++i) {
            const Index c = k[i];
            g[i] = id(x + int(c & 1), y + int((c >> 1) & 1), z + int(c >> 2));
          }
          m.tets.push_back(g);
        }
  return fixtures::with_hull_boundary(m);
}

std::vector<char> hull_points(const VolumeMesh& m) {
  std::vector<char> on(m.points.size(), 0);
  for (const Tri& f : m.boundary)
    for (Index v : f) on[v] = 1;
  return on;
}

/// Every hull point of the input `v` is still there and where it was. By
/// global id (point i of `v` has id i): the optimizer may drop interior points
/// and renumber the others.
void expect_hull_points_kept(const TetMesh& m, const VolumeMesh& v) {
  const auto on_hull = hull_points(v);
  std::size_t found = 0;
  for (Index j = 0; j < m.num_points(); ++j) {
    const GlobalId i = m.point_id(j);
    if (i >= v.points.size() || !on_hull[i]) continue;
    ++found;
    EXPECT_EQ(m.point(j), v.points[i]) << "boundary point " << i << " moved";
  }
  EXPECT_EQ(found, static_cast<std::size_t>(std::count(on_hull.begin(), on_hull.end(), 1)));
}

bool all_positive(const VolumeMesh& m) {
  for (const Tet& k : m.tets)
    if (exact::orient3d(m.points[k[0]], m.points[k[1]], m.points[k[2]], m.points[k[3]]) <= 0)
      return false;
  return true;
}

/// The Kuhn grid with every interior point moved by a deterministic pseudo-random
/// offset of up to `amount` per axis (halved until every tet stays positive).
VolumeMesh jittered_grid(int n, double amount) {
  VolumeMesh m = kuhn_grid_with_hull(n);
  const auto on_hull = hull_points(m);
  std::uint64_t state = 0x2545F4914F6CDD1Dull;
  const auto next = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0 * 2.0 - 1.0;
  };
  for (Index v = 0; v < m.points.size(); ++v) {
    if (on_hull[v]) continue;
    const Vec3 old = m.points[v];
    const Vec3 d{next() * amount, next() * amount, next() * amount};
    double s = 1.0;
    for (int tries = 0; tries < 8; ++tries, s *= 0.5) {
      m.points[v] = old + s * d;
      if (all_positive(m)) break;
      m.points[v] = old;
    }
  }
  return m;
}

SurfaceMesh surface_of(const VolumeMesh& m) {
  SurfaceMesh s;
  s.points = m.points;
  s.triangles = m.boundary;
  s.surface_ids = m.boundary_ids;
  s.name = "fixture";
  return s;
}

SizingField uniform_sizing(const VolumeMesh& m, double h) {
  SizingOptions o;
  o.size = h;
  o.hmax = h;  // h everywhere, also next to boundary triangles wider than h
  auto f = SizingField::build(surface_of(m), m, o);
  EXPECT_TRUE(f.ok()) << f.status().to_string();
  return std::move(f).value();
}

/// Smallest dihedral angle over tets with no vertex in `fixed` (or over all).
double min_dihedral(const TetMesh& m, const std::vector<char>* fixed = nullptr) {
  double lo = 180;
  for (Index t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    const Tet& k = m.tet(t);
    bool skip = false;
    for (Index v : k) skip = skip || (fixed != nullptr && v < fixed->size() && (*fixed)[v]);
    if (skip) continue;
    lo = std::min(lo, dihedral_range(m.point(k[0]), m.point(k[1]), m.point(k[2]), m.point(k[3])).min);
  }
  return lo;
}

/// Sorted keys of the frozen faces with their coordinates.
std::vector<std::array<Vec3, 3>> frozen_faces(const TetMesh& m) {
  std::vector<std::array<Vec3, 3>> out;
  for (Index t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    for (int f = 0; f < 4; ++f) {
      if (!m.frozen(t, f)) continue;
      const Tri k = topo::face_of(m.tet(t), f);
      std::array<Vec3, 3> c{m.point(k[0]), m.point(k[1]), m.point(k[2])};
      std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());  // keep orientation
      out.push_back(c);
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

void expect_valid(const TetMesh& m, const SurfaceMesh* surface = nullptr) {
  ASSERT_TRUE(m.check().ok()) << m.check().to_string();
  TetMesh copy = m;
  copy.compact();
  const ValidationReport r = validate_mesh(copy.to_volume_mesh(), surface);
  EXPECT_TRUE(r.ok()) << format_validation(r);
}

/// A sliver (four nearly coplanar points at the corners of a square, two raised,
/// two lowered by e) with a near-regular cap tet on each face; the hull is frozen.
VolumeMesh capped_sliver(double e) {
  VolumeMesh m;
  m.points = {{1, 0, e}, {-1, 0, e}, {0, 1, -e}, {0, -1, -e}};
  Tet s{0, 1, 2, 3};
  if (signed_volume(m.points[0], m.points[1], m.points[2], m.points[3]) < 0) std::swap(s[2], s[3]);
  m.tets.push_back(s);
  for (int f = 0; f < 4; ++f) {
    const Tri k = topo::face_of(s, f);
    const Vec3 &a = m.points[k[0]], &b = m.points[k[1]], &c = m.points[k[2]];
    const Vec3 n = cross(b - a, c - a);
    const double edge = (norm(b - a) + norm(c - b) + norm(a - c)) / 3.0;
    const Vec3 apex = (1.0 / 3.0) * (a + b + c) + (std::sqrt(2.0 / 3.0) * edge / norm(n)) * n;
    m.points.push_back(apex);
    m.tets.push_back({k[0], k[1], k[2], static_cast<Index>(m.points.size() - 1)});
  }
  return fixtures::with_hull_boundary(m);
}

TEST(Optimize, RejectsBadOptions) {
  TetMesh m = fixtures::build(kuhn_grid_with_hull(1));
  OptimizeOptions o;
  o.target_max_dihedral = 10;
  EXPECT_FALSE(optimize(m, nullptr, o).ok());
  o = {};
  o.sweeps = -1;
  EXPECT_FALSE(optimize(m, nullptr, o).ok());
  o = {};
  o.repair_cycles = -1;
  EXPECT_FALSE(optimize(m, nullptr, o).ok());
  EXPECT_TRUE(optimize(m, nullptr, {}).ok());
}

TEST(Optimize, GoodMeshIsLeftAlone) {
  const VolumeMesh v = kuhn_grid_with_hull(2);  // Kuhn tets: dihedral angles 45..90 degrees
  TetMesh m = fixtures::build(v);
  auto st = optimize(m, nullptr, {});
  ASSERT_TRUE(st.ok());
  EXPECT_EQ(st->bad_before, 0u);
  EXPECT_EQ(st->flips + st->points_moved, 0u);
  EXPECT_EQ(m.points(), v.points);
}

/// The Kuhn grid with interior point (2, 2, 2) moved to (2.95, 2.3, 2.6): close
/// to the face x = 3 of its cube, where the Kuhn tet (v, v+x, v+x+y, v+1)
/// becomes a sliver (its four points nearly coplanar, forming a convex
/// quadrilateral), and its neighbour (v, v+x, v+x+z, v+1) a flat cap. Every tet
/// stays positive: v stays inside the convex star of the Kuhn vertex.
VolumeMesh grid_with_planted_sliver(double gap) {
  VolumeMesh v = kuhn_grid_with_hull(4);
  v.points[2 + 5 * (2 + 5 * 2)] = {3.0 - gap, 2.3, 2.6};
  return v;
}

TEST(Optimize, PlantedSliverIsRemoved) {
  const VolumeMesh v = grid_with_planted_sliver(0.05);
  ASSERT_TRUE(all_positive(v));
  TetMesh m = fixtures::build(v);
  const double volume = fixtures::total_volume(m);
  auto st = optimize(m, nullptr, {});
  ASSERT_TRUE(st.ok());
  EXPECT_LT(st->min_dihedral_before, 5.0);  // the planted sliver
  EXPECT_GT(st->max_dihedral_before, 170.0);
  EXPECT_GE(st->slivers_removed, 1u);
  EXPECT_EQ(st->bad_after, 0u);
  // Above the 15-degree target: every tet's angles lie in [15, 150] degrees.
  EXPECT_GT(min_dihedral(m), 15.0);
  EXPECT_GT(st->min_dihedral_after, 15.0);
  EXPECT_LT(st->max_dihedral_after, 150.0);
  EXPECT_NEAR(fixtures::total_volume(m), volume, 1e-12 * volume);
  expect_valid(m, nullptr);
}

TEST(Optimize, SliverBetweenHullEdgesStaysWhenNothingImproves) {
  // Its edges are on the hull and any point inserted in the cavity lies within
  // e of two of them: no operation improves it, and none may make it worse.
  const VolumeMesh v = capped_sliver(0.02);
  TetMesh m = fixtures::build(v);
  const SizingField h = uniform_sizing(v, 1.5);
  auto st = optimize(m, &h, {});
  ASSERT_TRUE(st.ok()) << st.status().to_string();
  EXPECT_EQ(st->slivers_removed, 0u);
  EXPECT_EQ(st->points_inserted, 0u);
  EXPECT_EQ(st->min_dihedral_after, st->min_dihedral_before);
  EXPECT_EQ(m.points(), v.points);
  expect_valid(m, nullptr);
}

TEST(Optimize, SmoothingRepairsMisplacedPoint) {
  VolumeMesh v = kuhn_grid_with_hull(3);
  const Index p = 1 + 4 * (1 + 4 * 1);  // interior point (1, 1, 1); (2, 2, 2) is a neighbour
  v.points[p] = {1.95, 1.92, 1.96};
  ASSERT_TRUE(all_positive(v));
  TetMesh m = fixtures::build(v);
  const double before = min_dihedral(m);
  ASSERT_LT(before, 5.0);
  OptimizeOptions o;
  o.reconnect = false;  // smoothing alone
  auto st = optimize(m, nullptr, o);
  ASSERT_TRUE(st.ok());
  EXPECT_GE(st->points_moved, 1u);
  EXPECT_NE(m.point(p), v.points[p]);
  EXPECT_EQ(st->flips, 0u);
  EXPECT_GT(min_dihedral(m), 30.0);
  EXPECT_NEAR(fixtures::total_volume(m), 27.0, 1e-12);
  expect_valid(m, nullptr);
}

TEST(Optimize, SmoothingAimsAtTheTargetAngles) {
  // Kuhn tets have dihedral angles of 45, 60 and 90 degrees. With targets
  // [30, 100] a point pushed towards a neighbour makes obtuse tets (over 100
  // degrees) whose smallest angles stay well above 30: smoothing must aim at
  // the large angles (the plain smallest sine of a dihedral angle, which the
  // measure replaced, ranks a 105-degree angle as better than a 45-degree one).
  VolumeMesh v = kuhn_grid_with_hull(3);
  const Index p = 1 + 4 * (1 + 4 * 1);
  v.points[p] = {1.2, 1.2, 1.2};  // 35.3 to 105.8 degrees around it
  ASSERT_TRUE(all_positive(v));
  TetMesh m = fixtures::build(v);
  OptimizeOptions o;
  o.target_min_dihedral = 30;
  o.target_max_dihedral = 100;
  o.reconnect = false;  // smoothing alone
  ASSERT_GT(max_dihedral(m), 100.0);
  ASSERT_GT(min_dihedral(m), 30.0);
  auto st = optimize(m, nullptr, o);
  ASSERT_TRUE(st.ok());
  EXPECT_GT(st->bad_before, 0u);
  EXPECT_EQ(st->bad_after, 0u);
  EXPECT_GE(st->points_moved, 1u);
  EXPECT_LE(max_dihedral(m), 100.0);
  EXPECT_GE(min_dihedral(m), 30.0);
  EXPECT_NEAR(fixtures::total_volume(m), 27.0, 1e-12);
  expect_valid(m, nullptr);
}

TEST(Optimize, SmoothingNeverLowersAStarsWorstTet) {
  // Every accepted move raises its star's clipped profile lexicographically,
  // so the worst tet over all stays at least as good: with reconnection off
  // the smallest measure (here, the smallest dihedral angle over tets of the
  // jittered grid's interior points) never falls, and the boundary stays.
  const VolumeMesh v = jittered_grid(4, 0.45);
  TetMesh m = fixtures::build(v);
  OptimizeOptions o;
  o.reconnect = false;
  o.insert_points = false;
  auto st = optimize(m, nullptr, o);
  ASSERT_TRUE(st.ok());
  EXPECT_GT(st->points_moved, 0u);
  EXPECT_GE(st->min_dihedral_after, st->min_dihedral_before);
  EXPECT_LT(st->bad_after, st->bad_before);
  expect_hull_points_kept(m, v);
  expect_valid(m, nullptr);
}

/// Tets with no hull point (by global id, as in expect_hull_points_kept) and a
/// dihedral angle outside [lo, hi] degrees.
std::size_t interior_bad(const TetMesh& m, const std::vector<char>& on_hull, double lo, double hi) {
  std::size_t n = 0;
  for (Index t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    const Tet& k = m.tet(t);
    bool hull = false;
    for (Index v : k) hull = hull || (m.point_id(v) < on_hull.size() && on_hull[m.point_id(v)]);
    const AngleRange a = dihedral_range(m.point(k[0]), m.point(k[1]), m.point(k[2]), m.point(k[3]));
    if (!hull && (a.min < lo || a.max > hi)) ++n;
  }
  return n;
}

TEST(Optimize, PolishingRoundsWorkOnTheInteriorAlone) {
  // One sweep towards strict targets leaves work: the polishing rounds
  // follow, touch no hull point, and leave fewer interior bad tets.
  const VolumeMesh v = jittered_grid(5, 0.45);
  const auto on_hull = hull_points(v);
  TetMesh m = fixtures::build(v);
  OptimizeOptions o;
  o.sweeps = 1;
  o.target_min_dihedral = 35;
  o.target_max_dihedral = 110;
  const std::size_t before = interior_bad(m, on_hull, 35, 110);
  const double volume = fixtures::total_volume(m);
  auto st = optimize(m, nullptr, o);
  ASSERT_TRUE(st.ok());
  EXPECT_GE(st->polish_rounds, 1);
  EXPECT_GT(before, 0u);
  EXPECT_LT(interior_bad(m, on_hull, 35, 110), before);
  expect_hull_points_kept(m, v);
  EXPECT_NEAR(fixtures::total_volume(m), volume, 1e-12 * volume);
  expect_valid(m, nullptr);
}

TEST(Optimize, MarginPolishRaisesInteriorTetsToTheTargetsAndLosesNoOther) {
  // The margin polish alone (no sweeps, no angle polish): only points move,
  // so the tets keep their slots and each can be compared with itself.
  const VolumeMesh v = jittered_grid(5, 0.45);
  const auto on_hull = hull_points(v);
  TetMesh m = fixtures::build(v);
  OptimizeOptions o;
  o.sweeps = 0;
  o.polish_angles = false;
  o.target_min_dihedral = 35;
  o.target_max_dihedral = 110;
  const auto ranges = [](const TetMesh& mesh) {
    std::vector<AngleRange> r(mesh.num_slots());
    for (Index t = 0; t < mesh.num_slots(); ++t) {
      const Tet& k = mesh.tet(t);
      if (mesh.alive(t)) r[t] = dihedral_range(mesh.point(k[0]), mesh.point(k[1]), mesh.point(k[2]), mesh.point(k[3]));
    }
    return r;
  };
  const std::vector<AngleRange> before = ranges(m);
  AngleRange extremes{180.0, 0.0};
  for (Index t = 0; t < m.num_slots(); ++t)
    if (m.alive(t)) extremes = {std::min(extremes.min, before[t].min), std::max(extremes.max, before[t].max)};
  const std::size_t bad_before = interior_bad(m, on_hull, 35, 110);
  const double volume = fixtures::total_volume(m);
  auto st = optimize(m, nullptr, o);
  ASSERT_TRUE(st.ok());
  EXPECT_GT(st->margin_moves, 0u);
  EXPECT_EQ(st->margin_moves, st->points_moved);
  EXPECT_EQ(st->flips, 0u);
  EXPECT_GT(bad_before, 0u);
  EXPECT_LT(interior_bad(m, on_hull, 35, 110), bad_before);
  const std::vector<AngleRange> after = ranges(m);
  ASSERT_EQ(after.size(), before.size());
  for (Index t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    bool hull = false;
    for (Index u : m.tet(t)) hull = hull || on_hull[m.point_id(u)] != 0;
    if (hull) {  // a tet with a surface point: a side within [10, 165] stays, one past it stays within the extremes
      EXPECT_GE(after[t].min, before[t].min < 10.0 ? extremes.min : 10.0) << "tet " << t;
      EXPECT_LE(after[t].max, before[t].max > 165.0 ? extremes.max : 165.0) << "tet " << t;
    } else if (before[t].min >= 35 && before[t].max <= 110) {  // within the targets: stays
      EXPECT_GE(after[t].min, 35.0) << "tet " << t;
      EXPECT_LE(after[t].max, 110.0) << "tet " << t;
    }
  }
  // Off, nothing moves.
  TetMesh still = fixtures::build(v);
  o.polish_margins = false;
  auto none = optimize(still, nullptr, o);
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->points_moved, 0u);
  EXPECT_EQ(interior_bad(still, on_hull, 35, 110), bad_before);
  expect_hull_points_kept(m, v);
  EXPECT_NEAR(fixtures::total_volume(m), volume, 1e-12 * volume);
  expect_valid(m, nullptr);
}

/// Targets [40, 100]: strict enough that the steps before the repair cycles
/// leave bad tets with no hull point on jittered_grid(5, 0.45).
OptimizeOptions strict_targets() {
  OptimizeOptions o;
  o.target_min_dihedral = 40;
  o.target_max_dihedral = 100;
  return o;
}

/// optimize() of jittered_grid(5, 0.45) with `o` and no sizing field: its
/// stats and the number of tets with no hull point it leaves outside o's
/// targets. The hull points, the volume and the mesh's validity are checked.
std::pair<OptimizeStats, std::size_t> optimize_jittered_grid(const OptimizeOptions& o) {
  const VolumeMesh v = jittered_grid(5, 0.45);
  TetMesh m = fixtures::build(v);
  const double volume = fixtures::total_volume(m);
  auto st = optimize(m, nullptr, o);
  EXPECT_TRUE(st.ok());
  expect_hull_points_kept(m, v);
  EXPECT_NEAR(fixtures::total_volume(m), volume, 1e-12 * volume);
  expect_valid(m, nullptr);
  return {st.ok() ? *st : OptimizeStats{},
          interior_bad(m, hull_points(v), o.target_min_dihedral, o.target_max_dihedral)};
}

TEST(Optimize, RepairCyclesLeaveFewerInteriorTetsOutsideTheTargets) {
  // Strict targets leave bad interior tets after the margin polish; the
  // cycles of repair rounds and margin polish that follow leave fewer, and
  // none runs when turned off. (The absorption after them, off here, leaves
  // none: see AbsorptionLeavesFewerInteriorTetsOutsideTheTargets.)
  OptimizeOptions o = strict_targets();
  o.absorb = false;
  o.repair_cycles = 0;
  const auto [without, left] = optimize_jittered_grid(o);
  EXPECT_EQ(without.repair_cycles, 0);
  ASSERT_GT(left, 0u);
  o.repair_cycles = 4;
  const auto [with, now] = optimize_jittered_grid(o);
  EXPECT_GE(with.repair_cycles, 1);
  EXPECT_LE(with.repair_cycles, 4);
  EXPECT_GT(with.repair_rounds, without.repair_rounds);
  EXPECT_LT(now, left);
}

TEST(Optimize, PointMovesSideBySideMakeTheMeshOfOneThread) {
  // parallel_moves runs the smoothing and polish moves side by side
  // (moves.hpp): the mesh, bit for bit, and every count of the stats are
  // those of the moves in turn, on one thread or two.
  const VolumeMesh v = jittered_grid(8, 0.45);
  const SizingField h = uniform_sizing(v, 1.0);
  struct Run {
    VolumeMesh mesh;
    OptimizeStats stats;
  };
  const auto run = [&](bool parallel, int threads) {
    TetMesh m = fixtures::build(v);
    OptimizeOptions o;
    o.parallel_moves = parallel;
    Result<OptimizeStats> st = invalid_input("not run");
    tbb::task_arena(threads).execute([&] { st = optimize(m, &h, o); });
    EXPECT_TRUE(st.ok()) << st.status().to_string();
    expect_hull_points_kept(m, v);
    expect_valid(m, nullptr);
    return Run{m.to_volume_mesh(), st.ok() ? *st : OptimizeStats{}};
  };
  const Run in_turn = run(false, 2), alone = run(true, 1), side_by_side = run(true, 2);
  EXPECT_EQ(in_turn.stats.move_windows, 0u);
  EXPECT_EQ(alone.stats.move_windows, 0u);
  EXPECT_GT(side_by_side.stats.move_windows, 0u);
  ASSERT_GT(in_turn.stats.points_moved, 300u);
  for (const Run* r : {&alone, &side_by_side}) {
    EXPECT_EQ(r->mesh.points, in_turn.mesh.points);
    EXPECT_EQ(r->mesh.tets, in_turn.mesh.tets);
    EXPECT_EQ(r->stats.tried, in_turn.stats.tried);
    EXPECT_EQ(r->stats.points_moved, in_turn.stats.points_moved);
    EXPECT_EQ(r->stats.margin_moves, in_turn.stats.margin_moves);
    EXPECT_EQ(r->stats.size_moves, in_turn.stats.size_moves);
    EXPECT_EQ(r->stats.flips, in_turn.stats.flips);
  }
}

TEST(Optimize, AbsorptionLeavesFewerInteriorTetsOutsideTheTargets) {
  // With strict targets the repair cycles leave bad tets with no hull point;
  // the absorption (optimize.hpp, 10.) hands them to the tets on the hull
  // (flips and point removals judged by the tets off it, those on it only
  // kept positive and within the mesh's extremes): fewer are left, and it
  // runs only when turned on and given the room (surface_room).
  OptimizeOptions o = strict_targets();
  o.absorb = false;
  const auto [without, left] = optimize_jittered_grid(o);
  EXPECT_EQ(without.absorb_cycles, 0);
  ASSERT_GT(left, 0u);
  o.absorb = true;
  o.surface_room = false;
  EXPECT_EQ(optimize_jittered_grid(o).first.absorb_cycles, 0);
  o.surface_room = true;
  const auto [with, now] = optimize_jittered_grid(o);
  EXPECT_GE(with.absorb_cycles, 1);
  EXPECT_GT(with.absorbed, 0u);
  EXPECT_GT(with.edges_collapsed, 0u);
  EXPECT_LT(now, left);
}

/// `on` is `off` after the size polish (moves, edge removals, splits). A tet of
/// `off` still in `on` with no hull point that was within the targets stays
/// within them, one that was outside gets no worse on either side; one with a
/// hull point may give way within the limits [max(10, mesh min), min(165,
/// mesh max)] (with `room`; else as the others), a side past them going no
/// further than the mesh's extreme, so neither extreme of the mesh gets worse.
/// A new tet (an edge removal's or a split's) lies within the targets, or,
/// with a hull point and `room`, within the limits. Returns how many tets with
/// a hull point got worse than the interior's rule allows (the room the
/// polish used).
std::size_t expect_size_polish_bounds(const VolumeMesh& off, const VolumeMesh& on, bool room = true) {
  EXPECT_GE(on.points.size(), off.points.size());  // splits add points
  const OptimizeOptions targets;
  const auto range = [](const VolumeMesh& m, const Tet& k) {
    return dihedral_range(m.points[k[0]], m.points[k[1]], m.points[k[2]], m.points[k[3]]);
  };
  AngleRange mesh{180.0, 0.0};
  std::map<Tet, Tet> old;  // sorted vertices -> the tet of `off`
  for (const Tet& k : off.tets) {
    mesh.min = std::min(mesh.min, range(off, k).min);
    mesh.max = std::max(mesh.max, range(off, k).max);
    Tet key = k;
    std::sort(key.begin(), key.end());
    old.emplace(key, k);
  }
  const AngleRange limits{std::max(10.0, mesh.min), std::min(165.0, mesh.max)};
  const AngleRange within_targets{targets.target_min_dihedral, targets.target_max_dihedral};
  const auto on_hull = hull_points(on);
  std::size_t gave_way = 0;
  for (const Tet& k : on.tets) {
    const AngleRange now = range(on, k);
    const bool hull = on_hull[k[0]] || on_hull[k[1]] || on_hull[k[2]] || on_hull[k[3]];
    Tet key = k;
    std::sort(key.begin(), key.end());
    const auto it = old.find(key);
    if (it == old.end()) {  // new
      const AngleRange bounds = hull && room ? limits : within_targets;
      EXPECT_GE(now.min, bounds.min);
      EXPECT_LE(now.max, bounds.max);
      continue;
    }
    const AngleRange was = range(off, it->second);
    if (hull && room) {
      EXPECT_GE(now.min, was.min < limits.min ? mesh.min : limits.min);
      EXPECT_LE(now.max, was.max > limits.max ? mesh.max : limits.max);
      if (now.min < std::min(was.min, targets.target_min_dihedral) ||
          now.max > std::max(was.max, targets.target_max_dihedral))
        ++gave_way;
      continue;
    }
    EXPECT_GE(now.min, std::min(was.min, targets.target_min_dihedral));
    EXPECT_LE(now.max, std::max(was.max, targets.target_max_dihedral));
  }
  return gave_way;
}

TEST(Optimize, SizePolishBringsEdgesIntoTheBandAndKeepsTheAngleBounds) {
  // The jittered grid's long diagonals (1.73 at h = 1) lie out of [0.6, 1.5] h.
  // The size polish, the last step, removes, splits and moves so that fewer
  // edges off the hull lie out of the band, and keeps the angle bounds above.
  const VolumeMesh v = jittered_grid(5, 0.45);
  const SizingField h = uniform_sizing(v, 1.0);
  std::array<VolumeMesh, 2> out;
  std::array<OptimizeStats, 2> stats;
  for (int polish = 0; polish < 2; ++polish) {
    TetMesh m = fixtures::build(v);
    const double volume = fixtures::total_volume(m);
    OptimizeOptions o;
    o.polish_sizes = polish == 1;
    auto st = optimize(m, &h, o);
    ASSERT_TRUE(st.ok()) << st.status().to_string();
    stats[polish] = *st;
    expect_hull_points_kept(m, v);
    EXPECT_NEAR(fixtures::total_volume(m), volume, 1e-12 * volume);
    expect_valid(m, nullptr);
    out[polish] = m.to_volume_mesh();
  }
  EXPECT_EQ(stats[0].size_moves, 0u);
  EXPECT_GT(stats[1].size_moves, 0u);
  const SizeBand before = measure_size_band(out[0], h), after = measure_size_band(out[1], h);
  EXPECT_GT(before.shorter + before.longer, 0u);
  EXPECT_LT(after.shorter + after.longer, before.shorter + before.longer);
  expect_size_polish_bounds(out[0], out[1]);
}

// hinge at the default spacing is a thin part (no point lies deeper than
// about 0.85 h): its interior points form one sheet, which the smoothing
// lets zig-zag between the two faces, stretching the sheet's edges. Moving
// points only and holding every tet to the interior's bounds, the size
// polish took the share of interior edges within [0.6, 1.5] h from 62.8% to
// 64.0%; with the room above for the tets on the surface to 83.0%, with its
// edge removals to 85.0% and with its splits to 90.4% (`pdrmesh_bench_refine`). Without the room (a leaf task's) it
// keeps every tet on the surface as the interior ones are kept.
TEST(Optimize, SizePolishUsesTheSurfaceTetsRoomOnAThinPart) {
  auto surface = read_surface(PDRMESH_CORPUS_DIR "/hinge.stl");
  ASSERT_TRUE(surface.ok()) << surface.status().to_string();
  SerialOptions options;
  auto background = tetrahedralize(*surface);
  ASSERT_TRUE(background.ok()) << background.status().to_string();
  auto h = SizingField::build(*surface, *background, options.sizing);
  ASSERT_TRUE(h.ok()) << h.status().to_string();
  std::array<VolumeMesh, 3> out;  // no size polish, with it, with it but no room
  std::array<double, 3> share{};
  for (int run = 0; run < 3; ++run) {
    options.optimize->polish_sizes = run > 0;
    options.optimize->surface_room = run == 1;
    auto r = mesh_serial(*surface, options);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    EXPECT_EQ(r->optimize.size_moves > 0, run > 0);
    if (run == 1) {
      EXPECT_GT(r->optimize.size_flips, 0u);
      EXPECT_GT(r->optimize.size_splits, 0u);
    }
    const ValidationReport report = validate_mesh(r->mesh, &*surface);
    EXPECT_TRUE(report.ok()) << format_validation(report);
    const SizeBand band = measure_size_band(r->mesh, *h);
    ASSERT_GT(band.edges, 100u);
    share[run] = static_cast<double>(band.within) / static_cast<double>(band.edges);
    out[run] = std::move(r->mesh);
  }
  EXPECT_GT(share[1], share[0] + 0.1) << share[0] << " -> " << share[1];
  EXPECT_GE(share[1], 0.9);  // the size goal: 90% of interior edges in band
  EXPECT_GT(share[1], share[2]) << share[2] << " without the room";
  EXPECT_GT(expect_size_polish_bounds(out[0], out[1]), 0u);
  EXPECT_EQ(expect_size_polish_bounds(out[0], out[2], false), 0u);
}

/// `pdrmesh mesh` of corpus surface `name` at the default spacing: every
/// dihedral angle within [lo, hi] (as `pdrmesh quality` reports), and valid.
void expect_serial_angles_within(const char* name, double lo, double hi) {
  auto surface = read_surface(std::string(PDRMESH_CORPUS_DIR) + "/" + name + ".stl");
  ASSERT_TRUE(surface.ok()) << surface.status().to_string();
  auto r = mesh_serial(*surface, SerialOptions{});
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  const VolumeMesh& out = r->mesh;
  const auto q = measure_quality(out);
  EXPECT_GE(q.min_dihedral, lo) << name;
  EXPECT_LE(q.max_dihedral, hi) << name;
  const ValidationReport report = validate_mesh(out, &*surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
}

/// The serial pipeline at the default spacing (or `diagonal_over` > 0: --size
/// = bounding-box diagonal / diagonal_over): every tet with no boundary vertex
/// has its dihedral angles within the default targets [15, 150]. (Not asserted
/// on sphere966, whose interior minimum moved between 11.7 and 15.5 degrees
/// with small changes of the optimization: see README.)
void expect_interior_within_targets(const char* name, double diagonal_over = 0, std::size_t min_interior = 1000) {
  auto surface = read_surface(std::string(PDRMESH_CORPUS_DIR) + "/" + name + ".stl");
  ASSERT_TRUE(surface.ok()) << surface.status().to_string();
  SerialOptions options;
  if (diagonal_over > 0) {
    const Box b = surface->bounds();
    options.sizing.size = norm(b.hi - b.lo) / diagonal_over;
  }
  auto r = mesh_serial(*surface, options);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  const VolumeMesh& out = r->mesh;
  const auto on_boundary = hull_points(out);
  std::size_t interior = 0;
  for (const Tet& k : out.tets) {
    if (on_boundary[k[0]] || on_boundary[k[1]] || on_boundary[k[2]] || on_boundary[k[3]]) continue;
    ++interior;
    const AngleRange a = dihedral_range(out.points[k[0]], out.points[k[1]], out.points[k[2]], out.points[k[3]]);
    EXPECT_GE(a.min, 15.0) << name << ": interior tet " << k[0] << " " << k[1] << " " << k[2] << " " << k[3];
    EXPECT_LE(a.max, 150.0) << name << ": interior tet " << k[0] << " " << k[1] << " " << k[2] << " " << k[3];
  }
  EXPECT_GT(interior, min_interior);
  const ValidationReport report = validate_mesh(out, &*surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
}

/// A corpus surface at the default spacing: the surface, TetGen's initial
/// mesh, its sizing field and the refined mesh (no optimization); none, with a
/// test failure, when a step fails.
struct RefinedCorpus {
  SurfaceMesh surface;
  VolumeMesh initial;
  SizingField h;
  TetMesh refined;
};
std::optional<RefinedCorpus> refine_corpus(const char* name) {
  auto surface = read_surface(std::string(PDRMESH_CORPUS_DIR) + "/" + name + ".stl");
  auto vm = surface.ok() ? tetrahedralize(*surface) : Result<VolumeMesh>(surface.status());
  auto h = vm.ok() ? SizingField::build(*surface, *vm, {}) : Result<SizingField>(vm.status());
  auto built = h.ok() ? TetMesh::from_volume_mesh(*vm) : Result<TetMesh>(h.status());
  Status s = built.ok() ? refine(*built, *h).status() : built.status();
  if (!s.ok()) {
    ADD_FAILURE() << name << ": " << s.to_string();
    return std::nullopt;
  }
  return RefinedCorpus{*std::move(surface), *std::move(vm), *std::move(h), *std::move(built)};
}

TEST(Optimize, PolishingPinsTetsWithAFixedPoint) {
  // hinge's needle triangles leave hopeless tets next to the boundary. With
  // those pinned (polish_pins_fixed, the default) the polishing rounds leave
  // fewer bad tets with no boundary point than when they lead the comparison,
  // and the mesh stays valid with its boundary points in place.
  const std::optional<RefinedCorpus> hinge = refine_corpus("hinge");
  ASSERT_TRUE(hinge.has_value());
  const auto on_hull = hull_points(hinge->initial);
  std::array<std::size_t, 2> bad{};
  std::array<int, 2> rounds{};
  for (int pin = 0; pin < 2; ++pin) {
    TetMesh m = hinge->refined;
    OptimizeOptions o;
    o.polish_pins_fixed = pin == 1;
    o.interior_repair = false;  // the polishing rounds alone
    auto st = optimize(m, &hinge->h, o);
    ASSERT_TRUE(st.ok());
    rounds[pin] = st->polish_rounds;
    bad[pin] = interior_bad(m, on_hull, o.target_min_dihedral, o.target_max_dihedral);
    expect_hull_points_kept(m, hinge->initial);
    expect_valid(m, &hinge->surface);
  }
  EXPECT_GE(rounds[1], 1);
  EXPECT_LT(bad[1], bad[0]);
}

TEST(Optimize, PointRemovalKeepsTheMeshValidAndTheIdsInOrder) {
  // Next to hinge's needle triangles the interior repair removes points
  // (optimize.hpp, 4.): optimize() drops them, the others keep their order,
  // global ids and (on the surface) places, the counts add up, and the mesh
  // validates (the validator refuses a point that no tet uses).
  const std::optional<RefinedCorpus> hinge = refine_corpus("hinge");
  ASSERT_TRUE(hinge.has_value());
  const auto on_hull = hull_points(hinge->initial);
  std::array<std::size_t, 2> bad{};
  for (int remove = 0; remove < 2; ++remove) {
    SCOPED_TRACE(remove == 1 ? "with point removal" : "without");
    TetMesh m = hinge->refined;
    OptimizeOptions o;
    o.remove_points = remove == 1;
    auto st = optimize(m, &hinge->h, o);
    ASSERT_TRUE(st.ok()) << st.status().to_string();
    if (remove == 1) {
      EXPECT_GT(st->points_removed, 0u);
    } else {
      EXPECT_EQ(st->points_removed, 0u);
    }
    EXPECT_EQ(m.num_points(), hinge->refined.num_points() + st->points_inserted - st->points_removed);
    const std::vector<GlobalId>& ids = m.point_ids();
    EXPECT_EQ(std::adjacent_find(ids.begin(), ids.end(), std::greater_equal<>()), ids.end());  // ascending
    bad[remove] = interior_bad(m, on_hull, o.target_min_dihedral, o.target_max_dihedral);
    expect_hull_points_kept(m, hinge->initial);
    expect_valid(m, &hinge->surface);
  }
  EXPECT_LE(bad[1], bad[0]);
}

TEST(Optimize, InteriorRepairFixesInteriorTetsTheSweepsLeave) {
  // With strict targets the sweeps and polishing rounds leave bad tets with no
  // hull point in the jittered grid; the interior repair (flips judged by the
  // full measure, smoothing where tets with a hull point may give way down to
  // the repair floor) leaves fewer, moves no hull point, keeps the volume, and
  // never lowers the smallest dihedral angle over the interior tets. (The
  // margin polish after it is off: alone it leaves this grid's interior within
  // the targets.)
  const VolumeMesh v = jittered_grid(5, 0.45);
  const auto on_hull = hull_points(v);
  const SizingField h = uniform_sizing(v, 1.0);
  std::array<std::size_t, 2> bad{};
  std::array<double, 2> inner_min{};
  for (int repair = 0; repair < 2; ++repair) {
    TetMesh m = fixtures::build(v);
    const double volume = fixtures::total_volume(m);
    OptimizeOptions o;
    o.target_min_dihedral = 35;
    o.target_max_dihedral = 110;
    o.polish_margins = false;
    o.interior_repair = repair == 1;
    auto st = optimize(m, &h, o);
    ASSERT_TRUE(st.ok()) << st.status().to_string();
    EXPECT_EQ(st->repair_rounds > 0, repair == 1);
    bad[repair] = interior_bad(m, on_hull, 35, 110);
    inner_min[repair] = min_dihedral(m, &on_hull);
    expect_hull_points_kept(m, v);
    EXPECT_NEAR(fixtures::total_volume(m), volume, 1e-12 * volume);
    expect_valid(m, nullptr);
  }
  EXPECT_GT(bad[0], 0u);
  EXPECT_LT(bad[1], bad[0]);
  EXPECT_GE(inner_min[1], inner_min[0]);
}

TEST(Optimize, InteriorRepairLeavesTetsThatNeedAHullPointToMove) {
  // A slab 0.1 thick: every tet is flat, the interior ones (whose points lie
  // between the two hull planes) too, and making them good would need the
  // hull points to move. The repair must leave the hull points and every tet
  // with a hull point as they are (those are below its floor already, so they
  // may not get worse) and keep the mesh valid, whatever it does inside.
  VolumeMesh v = kuhn_grid_with_hull(3);
  for (Vec3& p : v.points) p[2] *= 0.1;
  ASSERT_TRUE(all_positive(v));
  const auto on_hull = hull_points(v);
  TetMesh m = fixtures::build(v);
  const SizingField h = uniform_sizing(v, 1.0);
  const std::size_t before = interior_bad(m, on_hull, 15, 150);
  const double volume = fixtures::total_volume(m);
  auto st = optimize(m, &h, {});
  ASSERT_TRUE(st.ok()) << st.status().to_string();
  EXPECT_GT(before, 0u);
  EXPECT_GE(st->repair_rounds, 1);
  EXPECT_EQ(interior_bad(m, on_hull, 15, 150), before);
  expect_hull_points_kept(m, v);
  EXPECT_NEAR(fixtures::total_volume(m), volume, 1e-12 * volume);
  EXPECT_GE(st->min_dihedral_after, st->min_dihedral_before);
  expect_valid(m, nullptr);
}

/// A 2x2x2 Kuhn grid with a flat cap on its top: the corners A = (0, 0, 2)
/// and C = (1, 1, 2) of one top square are lowered by `dip`, and the tet
/// (A, B, C, D) over the square (B = (1, 0, 2), D = (0, 1, 2)) fills the dent:
/// two faces on the surface (A B D, B C D, split along B D), two inside (on the
/// grid's old top triangles A B C, A C D), all four points on the surface.
VolumeMesh grid_with_cap(double dip) {
  VolumeMesh v = kuhn_grid_with_hull(2);
  const auto id = [](int x, int y, int z) { return static_cast<Index>(x + 3 * (y + 3 * z)); };
  const Index a = id(0, 0, 2), b = id(1, 0, 2), c = id(1, 1, 2), d = id(0, 1, 2);
  v.points[a][2] -= dip;
  v.points[c][2] -= dip;
  Tet cap{a, b, c, d};
  if (signed_volume(v.points[a], v.points[b], v.points[c], v.points[d]) < 0) std::swap(cap[1], cap[3]);
  v.tets.push_back(cap);
  return fixtures::with_hull_boundary(v);
}

TEST(Optimize, CapRepairReplacesAFlatTetOnTheSurface) {
  const VolumeMesh v = grid_with_cap(0.04);
  ASSERT_TRUE(all_positive(v));
  const SurfaceMesh surface = surface_of(v);
  const SizingField h = uniform_sizing(v, 1.0);
  OptimizeOptions o;
  o.reconnect = false;  // a 3-2 flip of the edge A C would do here; the caps of the engine have no such flip
  {
    TetMesh m = fixtures::build(v);  // without the cap repair nothing can touch it: all its points are fixed
    o.repair_caps = false;
    auto st = optimize(m, &h, o);
    ASSERT_TRUE(st.ok()) << st.status().to_string();
    EXPECT_LT(st->min_dihedral_after, 10.0);
    EXPECT_EQ(st->caps_repaired, 0u);
  }
  TetMesh m = fixtures::build(v);
  const auto frozen = frozen_faces(m);
  const double volume = fixtures::total_volume(m);
  o.repair_caps = true;
  auto st = optimize(m, &h, o);
  ASSERT_TRUE(st.ok()) << st.status().to_string();
  EXPECT_LT(st->min_dihedral_before, 10.0);
  EXPECT_GT(st->max_dihedral_before, 160.0);
  EXPECT_EQ(st->caps_repaired, 1u);
  EXPECT_EQ(m.num_points(), v.points.size() + 1);
  EXPECT_GT(st->min_dihedral_after, 20.0);
  EXPECT_LT(st->max_dihedral_after, st->max_dihedral_before);
  expect_hull_points_kept(m, v);
  EXPECT_EQ(frozen_faces(m), frozen);  // the surface triangles, exactly
  EXPECT_NEAR(fixtures::total_volume(m), volume, 1e-12 * volume);
  expect_valid(m, &surface);
}

/// The star of armadillo's worst free point in its parallel mesh at the default
/// depth (main at 499b5b3, 8.42 degrees; point 1 here, coordinates rounded to
/// 1e-4), cut out with its link as hull: the point alone covers the surface
/// fans of two surface points, one curved, so no position of it makes their
/// tets good.
VolumeMesh armadillo_covered_fans() {
  VolumeMesh v;
  v.points = {
      {45.3728, 50.6451, -17.8553},
      {45.2369, 50.4632, -16.5291},
      {45.5143, 51.6945, -17.4879},
      {44.7240, 51.6087, -17.0959},
      {46.8330, 49.6886, -16.2591},
      {46.7461, 50.8059, -15.7368},
      {45.6655, 49.8290, -15.5003},
      {47.2166, 49.7726, -16.6877},
      {46.1399, 51.1235, -16.5252},
      {44.4388, 50.0589, -15.8393},
      {45.2523, 50.8891, -15.6447},
      {43.9427, 50.6505, -16.4855},
      {45.1463, 50.2294, -17.0270},
      {44.4485, 50.7452, -17.4406},
      {45.3250, 50.0542, -16.2577},
      {44.5387, 51.2163, -15.2616},
      {45.1527, 52.0654, -15.7516},
      {44.4348, 52.2337, -16.7565},
      {43.8934, 51.5393, -15.8188},
      {45.2832, 52.2896, -16.5346},
  };
  v.tets = {
      {0, 1, 2, 3}, {1, 4, 5, 6}, {1, 4, 7, 8}, {6, 1, 9, 10},
      {1, 7, 0, 8}, {11, 12, 13, 1}, {13, 1, 0, 3}, {11, 14, 12, 1},
      {9, 14, 11, 1}, {7, 1, 0, 12}, {6, 1, 12, 14}, {4, 1, 7, 12},
      {4, 1, 5, 8}, {13, 11, 1, 3}, {2, 1, 0, 8}, {13, 12, 0, 1},
      {1, 6, 9, 14}, {9, 10, 1, 15}, {16, 8, 10, 1}, {10, 1, 5, 6},
      {1, 10, 5, 8}, {17, 1, 11, 3}, {1, 18, 11, 15}, {1, 11, 9, 15},
      {18, 15, 1, 16}, {1, 15, 10, 16}, {1, 16, 8, 19}, {2, 3, 1, 19},
      {2, 1, 8, 19}, {16, 19, 1, 17}, {3, 1, 19, 17}, {18, 16, 1, 17},
      {1, 17, 11, 18}, {6, 1, 4, 12},
  };
  return fixtures::with_hull_boundary(v);
}

// The relaxed cap pass puts a point over a fan that a free apex alone covers
// (optimize.hpp, 5.); without it this cut reached 12.12 degrees.
TEST(Optimize, RelaxedCapPassSplitsFansAFreeApexCovers) {
  const VolumeMesh v = armadillo_covered_fans();
  ASSERT_TRUE(all_positive(v));
  const SurfaceMesh surface = surface_of(v);
  const SizingField h = uniform_sizing(v, 1.2);
  TetMesh m = fixtures::build(v);
  const auto frozen = frozen_faces(m);
  const double volume = fixtures::total_volume(m);
  auto st = optimize(m, &h, {});
  ASSERT_TRUE(st.ok()) << st.status().to_string();
  EXPECT_LT(st->min_dihedral_before, 9.0);
  EXPECT_GE(st->caps_repaired, 1u);
  EXPECT_GT(st->min_dihedral_after, 14.0);
  EXPECT_LT(st->max_dihedral_after, 165.0);
  expect_hull_points_kept(m, v);
  EXPECT_EQ(frozen_faces(m), frozen);
  EXPECT_NEAR(fixtures::total_volume(m), volume, 1e-12 * volume);
  expect_valid(m, &surface);
}

// sphere966's worst tets at the default spacing were 14 flat tets (4.10
// degrees) with four surface points and one surface face, which the cap repair
// took only with two or three kept faces (Gmsh HXT gets 5.85 on this surface);
// then 6.16 / 171.02 degrees, points whose smoothing targets all made their
// star worse, until the compass search (optimize.hpp, 3.); then 6.93 / 165.98,
// free points whose stars the measure judged at a local best, until the angle
// polish (optimize.hpp, 6.): 8.66 / 165.51. Since smoothing keeps interior
// edges from getting short (keep_edge_sizes), 9.5 / 171.8: the largest angle is
// that of four tets of two surface triangles each, over a surface edge whose
// fold is 171.8 degrees, which the cap repair left until its late pass (5.:
// 9.9 / 167.9).
TEST(Optimize, Sphere966WorstTetsAreRepaired) { expect_serial_angles_within("sphere966", 8.5, 172.0); }

// The relaxed cap pass once more after the absorption (late_caps,
// optimize.hpp 5.): the polish and the repair cycles change the cavities
// around the caps the first passes left, and some then fit a star within [10,
// 165] degrees. On sphere966 at the default spacing it repairs more caps, the
// mesh's extreme angles get no worse and its share of tets under 10 degrees
// falls (9.7 / 171.8 degrees and 0.027% under 10 without it, 9.9
// / 167.9 and 0.020% with it).
TEST(Optimize, LateCapPassTakesTheCapsTheLaterStepsLeave) {
  auto surface = read_surface(PDRMESH_CORPUS_DIR "/sphere966.stl");
  ASSERT_TRUE(surface.ok()) << surface.status().to_string();
  SerialOptions options;
  std::array<std::size_t, 2> caps{};
  std::array<QualityReport, 2> quality{};
  for (int run = 0; run < 2; ++run) {
    options.optimize->late_caps = run == 1;
    auto r = mesh_serial(*surface, options);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    caps[run] = r->optimize.caps_repaired;
    quality[run] = measure_quality(r->mesh);
    const ValidationReport report = validate_mesh(r->mesh, &*surface);
    EXPECT_TRUE(report.ok()) << format_validation(report);
  }
  EXPECT_GT(caps[1], caps[0]);
  EXPECT_GE(quality[1].min_dihedral, quality[0].min_dihedral);
  EXPECT_LE(quality[1].max_dihedral, quality[0].max_dihedral);
  EXPECT_LT(quality[1].share_below_10, quality[0].share_below_10);
}

// bunny_npm's worst tets at the default spacing (12.29 degrees) were caps whose
// best stars raise the largest angle past the cavity's, which the first cap
// pass refuses; the relaxed pass takes them when every new tet lies within
// [10, 165] degrees (optimize.hpp, 5.).
TEST(Optimize, BunnyRelaxedCapPassReachesTheTarget) { expect_serial_angles_within("bunny_npm", 15.0, 165.0); }

TEST(Optimize, ElephantInteriorWithinTargets) { expect_interior_within_targets("elephant"); }

// Next to needle triangles: the interior reached 14.9 / 150.6 degrees before
// the angle polish kept its tets with no surface point within the targets.
TEST(Optimize, CouplingdownInteriorWithinTargets) { expect_interior_within_targets("couplingdown"); }

// hinge's needle triangles (0.33 degrees) at the default spacing: its interior
// (170 tets, one or two layers off the surface) reached 10.0 / 160.9 degrees
// while the interior repair held the tets with a surface point at 10 degrees;
// with the floor following the mesh's worst tet (optimize.hpp, 4.) it is
// within the targets.
TEST(Optimize, HingeInteriorWithinTargets) { expect_interior_within_targets("hinge", 0, 100); }

// hinge at --size = diagonal / 50 (33,000 tets): next to its triangles 35 h
// long, the repair cycles leave 4 tets with no surface point outside [15,
// 150] (14.0 / 150.8 degrees); the absorption (optimize.hpp, 10.) hands them
// to the tets on the surface and none is left
// (`PDRMESH_BENCH_DIVISOR=50 pdrmesh_bench_refine`). Its flips and removals
// keep every tet with a surface point within the mesh's extremes, and its
// repair rounds hold their floors (4.): the mesh's smallest angle stays, and
// the share of tets under 10 degrees grows by a few tets at most.
TEST(Optimize, AbsorptionHandsHingesLastInteriorTetsToTheSurface) {
  auto surface = read_surface(PDRMESH_CORPUS_DIR "/hinge.stl");
  ASSERT_TRUE(surface.ok()) << surface.status().to_string();
  SerialOptions options;
  options.sizing.size = surface->bounds().diagonal() / 50.0;
  options.sizing.hmax = options.sizing.size;  // h next to the wide triangles too (the raise alone spares them)
  std::array<std::size_t, 2> outside{};
  std::array<QualityReport, 2> quality{};
  for (int run = 0; run < 2; ++run) {
    options.optimize->absorb = run == 1;
    auto r = mesh_serial(*surface, options);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    EXPECT_EQ(r->optimize.absorbed > 0, run == 1);
    EXPECT_EQ(r->optimize.absorb_cycles > 0, run == 1);
    const VolumeMesh& out = r->mesh;
    const auto on_boundary = hull_points(out);
    for (const Tet& k : out.tets) {
      if (on_boundary[k[0]] || on_boundary[k[1]] || on_boundary[k[2]] || on_boundary[k[3]]) continue;
      const AngleRange a = dihedral_range(out.points[k[0]], out.points[k[1]], out.points[k[2]], out.points[k[3]]);
      if (a.min < 15.0 || a.max > 150.0) ++outside[run];
    }
    quality[run] = measure_quality(out);
    const ValidationReport report = validate_mesh(out, &*surface);
    EXPECT_TRUE(report.ok()) << format_validation(report);
  }
  EXPECT_GT(outside[0], 0u);  // what the absorption is for
  EXPECT_EQ(outside[1], 0u);
  EXPECT_GE(quality[1].min_dihedral, quality[0].min_dihedral);
  EXPECT_LE(quality[1].share_below_10, quality[0].share_below_10 + 0.001);
}

// Next to needle triangles, smoothing judged by angles alone pulled interior
// points together: 87.8% of couplingdown's interior edges within [0.6, 1.5] h
// at its midpoint, against the goal of 90%. keep_edge_sizes keeps
// them off the short side, without losing the interior's angle bounds. (The
// size polish also brings the unguarded smoothing's edges
// back into the band: the guard is compared without it.)
TEST(Optimize, SmoothingKeepsCouplingdownsInteriorEdgesInTheSizeBand) {
  auto surface = read_surface(PDRMESH_CORPUS_DIR "/couplingdown.stl");
  ASSERT_TRUE(surface.ok()) << surface.status().to_string();
  const SerialOptions options;
  auto background = tetrahedralize(*surface);
  ASSERT_TRUE(background.ok()) << background.status().to_string();
  auto h = SizingField::build(*surface, *background, options.sizing);
  ASSERT_TRUE(h.ok()) << h.status().to_string();
  // The share of the edges with no surface point whose length lies within
  // [0.6, 1.5] h at the midpoint (measure_size_band, as pdrmesh_bench_refine
  // prints it).
  const auto in_band = [&](const VolumeMesh& m) {
    const SizeBand band = measure_size_band(m, *h);
    EXPECT_GT(band.edges, 1000u);
    return static_cast<double>(band.within) / static_cast<double>(std::max<std::size_t>(1, band.edges));
  };
  auto full = mesh_serial(*surface, options);
  ASSERT_TRUE(full.ok()) << full.status().to_string();
  EXPECT_GE(in_band(full->mesh), 0.9);
  SerialOptions guarded = options;
  guarded.optimize->polish_sizes = false;
  auto kept = mesh_serial(*surface, guarded);
  ASSERT_TRUE(kept.ok()) << kept.status().to_string();
  SerialOptions angles_only = guarded;
  angles_only.optimize->keep_edge_sizes = false;
  auto free = mesh_serial(*surface, angles_only);
  ASSERT_TRUE(free.ok()) << free.status().to_string();
  const double share = in_band(kept->mesh);
  EXPECT_GE(share, 0.9);
  EXPECT_GT(share, in_band(free->mesh));
  for (const VolumeMesh* m : {&full->mesh, &kept->mesh, &free->mesh}) {
    const ValidationReport report = validate_mesh(*m, &*surface);
    EXPECT_TRUE(report.ok()) << format_validation(report);
  }
}

// A coarse spacing on a CAD body: the cap repair once traded flat surface tets
// for interior tets of 9.6 / 166.6 degrees here (it must meet the interior floors).
TEST(Optimize, Primitives13CoarseInteriorWithinTargets) { expect_interior_within_targets("primitives13", 100, 500); }

TEST(Optimize, BoundaryAndFrozenFacesStayAndVolumeIsKept) {
  const VolumeMesh v = jittered_grid(4, 0.45);
  TetMesh m = fixtures::build(v);
  const auto on_hull = hull_points(v);
  const auto frozen = frozen_faces(m);
  const double volume = fixtures::total_volume(m);
  const SizingField h = uniform_sizing(v, 1.0);
  auto st = optimize(m, &h, {});
  ASSERT_TRUE(st.ok());
  EXPECT_GT(st->bad_before, 0u);
  EXPECT_LT(st->bad_after, st->bad_before);
  EXPECT_GT(st->flips, 0u);
  EXPECT_GT(st->points_moved, 0u);
  EXPECT_GT(st->min_dihedral_after, st->min_dihedral_before);
  EXPECT_LT(st->max_dihedral_after, st->max_dihedral_before);
  expect_hull_points_kept(m, v);
  EXPECT_EQ(frozen_faces(m), frozen);
  EXPECT_NEAR(fixtures::total_volume(m), volume, 1e-12 * volume);
  expect_valid(m, nullptr);
}

TEST(Optimize, Deterministic) {
  const VolumeMesh v = jittered_grid(4, 0.45);
  const SizingField h = uniform_sizing(v, 1.0);
  std::vector<VolumeMesh> out;
  for (int run = 0; run < 2; ++run) {
    TetMesh m = fixtures::build(v);
    ASSERT_TRUE(optimize(m, &h, {}).ok());
    m.compact();
    out.push_back(m.to_volume_mesh());
  }
  ASSERT_EQ(out[0].points.size(), out[1].points.size());
  EXPECT_EQ(std::memcmp(out[0].points.data(), out[1].points.data(),
                        out[0].points.size() * sizeof(Vec3)),
            0);
  EXPECT_EQ(out[0].tets, out[1].tets);
}

TEST(Optimize, ImprovesTetgenSphereInterior) {
  auto surface = read_surface(PDRMESH_CORPUS_DIR "/sphere966.stl");
  ASSERT_TRUE(surface.ok()) << surface.status().to_string();
  TetgenOptions to;
  to.max_volume = enclosed_volume(*surface) / 2000;
  auto vm = tetrahedralize(*surface, to);
  ASSERT_TRUE(vm.ok()) << vm.status().to_string();
  auto built = TetMesh::from_volume_mesh(*vm);
  ASSERT_TRUE(built.ok()) << built.status().to_string();
  TetMesh m = std::move(built).value();
  const auto on_hull = hull_points(*vm);
  const double before = min_dihedral(m, &on_hull);
  auto h = SizingField::build(*surface, *vm, {});
  ASSERT_TRUE(h.ok()) << h.status().to_string();
  auto st = optimize(m, &*h, {});
  ASSERT_TRUE(st.ok());
  const double after = min_dihedral(m, &on_hull);
  EXPECT_GT(after, before);
  EXPECT_LE(st->bad_after, st->bad_before);
  expect_valid(m, &*surface);
}

// Per pass, on the named fixtures above: the outcome each local operation
// reports (OptimizeStats::tried), and a valid mesh.

TEST(Reconnect, DeclinesEveryFlipAroundASliverBetweenHullEdges) {
  // Every edge of the sliver is a hull edge and every face of it borders a
  // cap: no flip applies, or it would remove a frozen face.
  const VolumeMesh v = capped_sliver(0.02);
  TetMesh m = fixtures::build(v);
  OptimizeOptions o;
  o.smooth = false;
  auto st = optimize(m, nullptr, o);
  ASSERT_TRUE(st.ok()) << st.status().to_string();
  EXPECT_EQ(st->count(LocalOperation::kFlip, Outcome::kDone), 0u);
  EXPECT_GT(st->count(LocalOperation::kFlip, Outcome::kNotApplicable) +
                st->count(LocalOperation::kFlip, Outcome::kConstrained),
            0u);
  EXPECT_EQ(m.points(), v.points);
  expect_valid(m, nullptr);
}

TEST(Reconnect, FlipsThePlantedSliverAway) {
  const VolumeMesh v = grid_with_planted_sliver(0.05);
  TetMesh m = fixtures::build(v);
  OptimizeOptions o;
  o.smooth = false;
  auto st = optimize(m, nullptr, o);
  ASSERT_TRUE(st.ok()) << st.status().to_string();
  EXPECT_EQ(st->count(LocalOperation::kFlip, Outcome::kDone), st->flips);
  EXPECT_GE(st->flips, 1u);
  EXPECT_GT(st->min_dihedral_after, st->min_dihedral_before);
  expect_valid(m, nullptr);
}

TEST(SliverInsertion, DeclinesAPointTooCloseToTheHullEdges) {
  // Any point in the capped sliver's cavity lies within e of two of its hull
  // edges: with a spacing of half of h = 1.5 every insertion is too close.
  const VolumeMesh v = capped_sliver(0.02);
  TetMesh m = fixtures::build(v);
  const SizingField h = uniform_sizing(v, 1.5);
  OptimizeOptions o;
  o.smooth = false;
  o.repair_caps = false;
  auto st = optimize(m, &h, o);
  ASSERT_TRUE(st.ok()) << st.status().to_string();
  EXPECT_EQ(st->count(LocalOperation::kInsertion, Outcome::kDone), 0u);
  EXPECT_GT(st->count(LocalOperation::kInsertion, Outcome::kTooClose) +
                st->count(LocalOperation::kInsertion, Outcome::kNotBetter),
            0u);
  EXPECT_EQ(m.points(), v.points);
  expect_valid(m, nullptr);
}

TEST(Smoothing, MovesTheMisplacedPointAndCountsTheMove) {
  VolumeMesh v = kuhn_grid_with_hull(3);
  v.points[1 + 4 * (1 + 4 * 1)] = {1.95, 1.92, 1.96};
  TetMesh m = fixtures::build(v);
  OptimizeOptions o;
  o.reconnect = false;
  auto st = optimize(m, nullptr, o);
  ASSERT_TRUE(st.ok()) << st.status().to_string();
  EXPECT_EQ(st->count(LocalOperation::kMove, Outcome::kDone), st->points_moved);
  EXPECT_GE(st->points_moved, 1u);
  expect_valid(m, nullptr);
}

TEST(Smoothing, DeclinesWhenTheStarsWorstTetCannotBeHelped) {
  // A 2 x 2 x 2 Kuhn grid has one free point, the centre; with a smallest-angle
  // target above 45 degrees every tet is bad, and the worst angles of its star
  // lie at edges on the frozen hull, which no move of the centre changes for
  // the better.
  const VolumeMesh v = kuhn_grid_with_hull(2);
  TetMesh m = fixtures::build(v);
  OptimizeOptions o;
  o.target_min_dihedral = 50;
  o.reconnect = false;
  auto st = optimize(m, nullptr, o);
  ASSERT_TRUE(st.ok()) << st.status().to_string();
  EXPECT_GT(st->bad_before, 0u);
  EXPECT_EQ(st->count(LocalOperation::kMove, Outcome::kDone), 0u);
  EXPECT_GT(st->count(LocalOperation::kMove, Outcome::kNotBetter), 0u);
  EXPECT_GE(st->min_dihedral_after, st->min_dihedral_before);
  EXPECT_EQ(m.points(), v.points);
  expect_valid(m, nullptr);
}

TEST(CapRepair, ReplacesAFlatCapOverAPlaneAndCountsTheInsertion) {
  const VolumeMesh v = grid_with_cap(0.04);
  const SurfaceMesh surface = surface_of(v);
  const SizingField h = uniform_sizing(v, 1.0);
  TetMesh m = fixtures::build(v);
  OptimizeOptions o;
  o.reconnect = false;
  auto st = optimize(m, &h, o);
  ASSERT_TRUE(st.ok()) << st.status().to_string();
  EXPECT_EQ(st->caps_repaired, 1u);
  EXPECT_EQ(st->count(LocalOperation::kInsertion, Outcome::kDone), st->points_inserted);
  expect_valid(m, &surface);
}

TEST(OptimizeStats, OutcomeSummaryNamesTheReasons) {
  OptimizeStats st;
  EXPECT_EQ(outcome_summary(st), "no operations tried");
  st.tried[static_cast<std::size_t>(LocalOperation::kFlip)][static_cast<std::size_t>(Outcome::kDone)] = 3;
  st.tried[static_cast<std::size_t>(LocalOperation::kFlip)][static_cast<std::size_t>(Outcome::kNotBetter)] = 5;
  st.tried[static_cast<std::size_t>(LocalOperation::kInsertion)][static_cast<std::size_t>(Outcome::kTooClose)] = 2;
  EXPECT_EQ(outcome_summary(st), "flips 3 done, 5 not better; insertions 0 done, 2 too close");
}

TEST(Schedule, LeafTaskScheduleDropsWhatALeafsSwitchesTurnOff) {
  // The leaf-task schedule (no absorption, no late caps, no room in the size
  // polish) gives the mesh that the whole-mesh schedule gives with those
  // switches off, bit for bit.
  const VolumeMesh v = jittered_grid(4, 0.45);
  const SizingField h = uniform_sizing(v, 1.0);
  OptimizeOptions off;
  off.surface_room = false;
  off.late_caps = false;
  OptimizeOptions leaf;
  leaf.schedule = OptimizeOptions::Schedule::kLeafTask;
  TetMesh a = fixtures::build(v), b = fixtures::build(v);
  auto sa = optimize(a, &h, off);
  auto sb = optimize(b, &h, leaf);
  ASSERT_TRUE(sa.ok() && sb.ok());
  EXPECT_GT(sa->points_moved, 0u);
  EXPECT_EQ(sb->absorb_cycles, 0);
  EXPECT_EQ(a.points(), b.points());
  EXPECT_EQ(a.to_volume_mesh().tets, b.to_volume_mesh().tets);
  expect_valid(b, nullptr);
}

}  // namespace
}  // namespace pdrmesh
