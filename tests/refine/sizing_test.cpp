// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the point distribution function (sizing.hpp): definition, clamping,
// the exactness of the growth limit, continuity, determinism, serialisation.
#include "pdrmesh/sizing.hpp"

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <ctime>

#include "pdrmesh/predicates.hpp"
#include "pdrmesh/validate.hpp"
#include "test_fixtures.hpp"

namespace pdrmesh {
namespace {

constexpr double kHuge = 1e6;  // a growth rate that never limits inside these meshes

SizingOptions growth(double g) {
  SizingOptions o;
  o.growth = g;
  return o;
}

SizingField build_ok(const SurfaceMesh& s, const VolumeMesh& m, const SizingOptions& o) {
  auto f = SizingField::build(s, m, o);
  EXPECT_TRUE(f.ok()) << f.status().to_string();
  return std::move(f).value();
}

std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

/// Mean length of the distinct surface edges at each point (0 when unused),
/// computed independently of the library.
std::vector<double> mean_incident_edge(const SurfaceMesh& s) {
  std::set<std::pair<Index, Index>> edges;
  for (const Tri& t : s.triangles)
    for (int i = 0; i < 3; ++i) edges.insert(std::minmax(t[i], t[(i + 1) % 3]));
  std::vector<double> sum(s.points.size(), 0), n(s.points.size(), 0);
  for (const auto& [a, b] : edges) {
    const double l = norm(s.points[a] - s.points[b]);
    sum[a] += l, sum[b] += l, n[a] += 1, n[b] += 1;
  }
  for (std::size_t i = 0; i < sum.size(); ++i) sum[i] = n[i] > 0 ? sum[i] / n[i] : 0;
  return sum;
}

/// min over boundary points of s(p) + (G - 1)|x - p|, by brute force.
double brute_growth(const SurfaceMesh& s, const std::vector<double>& spacing, double g, const Vec3& x) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t p = 0; p < s.points.size(); ++p) {
    if (spacing[p] > 0) best = std::min(best, spacing[p] + (g - 1) * norm(x - s.points[p]));
  }
  return best;
}

std::mt19937_64 seeded_rng(const char* test) {
  const std::uint64_t seed = std::random_device{}();
  std::printf("[ %s ] seed %llu\n", test, static_cast<unsigned long long>(seed));
  return std::mt19937_64(seed);
}

Vec3 random_in(std::mt19937_64& rng, const Box& b) {
  std::uniform_real_distribution<double> u(0, 1);
  Vec3 x;
  for (int k = 0; k < 3; ++k) x[k] = b.lo[k] + u(rng) * (b.hi[k] - b.lo[k]);
  return x;
}

Box unit_box(double pad) { return Box{{-pad, -pad, -pad}, {1 + pad, 1 + pad, 1 + pad}}; }

/// The unit cube split into 12 tets around an interior point 8 at its centre.
VolumeMesh cube_with_centre() {
  VolumeMesh m;
  m.points = fixtures::unit_cube_points();
  m.points.push_back({0.5, 0.5, 0.5});
  const auto s = fixtures::unit_cube_surface();
  for (const Tri& t : s.triangles) m.tets.push_back({t[0], t[2], t[1], 8});
  m.boundary = s.triangles;
  m.boundary_ids = s.surface_ids;
  return m;
}

/// A closed convex(ish) surface coned to its bounding-box centre: a background
/// mesh whose points are the surface points plus one interior point.
bool cone_mesh(const SurfaceMesh& s, VolumeMesh& m) {
  const Box b = s.bounds();
  const Vec3 c = 0.5 * (b.lo + b.hi);
  m.points = s.points;
  m.points.push_back(c);
  const Index ci = static_cast<Index>(s.points.size());
  for (const Tri& t : s.triangles) {
    const int o = exact::orient3d(s.points[t[0]], s.points[t[1]], s.points[t[2]], c);
    if (o == 0) return false;
    m.tets.push_back(o > 0 ? Tet{t[0], t[1], t[2], ci} : Tet{t[0], t[2], t[1], ci});
  }
  return validate_mesh(m).ok();
}

struct SphereWithBackground {
  SurfaceMesh surface;
  VolumeMesh background;
};

const SphereWithBackground* sphere_with_background() {
  static const SphereWithBackground* s = [] {
    auto* sp = new SphereWithBackground;
    sp->surface = fixtures::corpus_surface("sphere966");
    if (sp->surface.triangles.empty() || !cone_mesh(sp->surface, sp->background)) {
      delete sp;
      return static_cast<SphereWithBackground*>(nullptr);
    }
    return sp;
  }();
  return s;
}

/// An n x n x n Kuhn grid of [0,1]^3 with coordinates graded by t -> t^2 (so the
/// boundary spacing varies by a factor of about 2n), and its boundary surface.
void graded_kuhn(int n, SurfaceMesh& s, VolumeMesh& m) {
  auto id = [n](int i, int j, int k) { return Index(i + (n + 1) * (j + (n + 1) * k)); };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const double u = double(i) / n, v = double(j) / n, w = double(k) / n;
        m.points.push_back({u * u, v * v, w * w});
      }
  const auto cube = fixtures::unit_cube_mesh();
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const Tet& t : cube.tets) {
          Tet g;
          for (int a = 0; a < 4; ++a) g[a] = id(i + int(t[a] & 1), j + int((t[a] >> 1) & 1), k + int((t[a] >> 2) & 1));
          m.tets.push_back(g);
        }
  // Boundary: the faces whose three points lie on one side of the grid, outward
  // (face i is opposite vertex i of a positive tet).
  constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  auto grid_coord = [n](Index p, int axis) {
    return int(axis == 0 ? p % Index(n + 1) : (axis == 1 ? p / Index(n + 1) % Index(n + 1) : p / Index((n + 1) * (n + 1))));
  };
  for (const Tet& t : m.tets)
    for (const auto& f : kFace)
      for (int axis = 0; axis < 3; ++axis) {
        const int c = grid_coord(t[f[0]], axis);
        if ((c == 0 || c == n) && grid_coord(t[f[1]], axis) == c && grid_coord(t[f[2]], axis) == c) {
          m.boundary.push_back({t[f[0]], t[f[1]], t[f[2]]});
        }
      }
  m.boundary_ids.assign(m.boundary.size(), 1);
  s.points = m.points;
  s.triangles = m.boundary;
  s.surface_ids = m.boundary_ids;
  s.name = "graded_kuhn";
}

// ---------------------------------------------------------------- definition

TEST(SizingField, BoundarySpacingIsMeanIncidentEdgeLength) {
  const auto s = fixtures::unit_cube_surface();
  const auto f = build_ok(s, fixtures::unit_cube_mesh(), growth(kHuge));
  const auto expect = mean_incident_edge(s);
  EXPECT_NEAR(expect[0], (3 + 3 * std::sqrt(2.0)) / 6, 1e-15);  // corner 0: 3 sides, 3 diagonals
  EXPECT_NEAR(expect[1], (3 + std::sqrt(2.0)) / 4, 1e-15);      // corner 1: 3 sides, 1 diagonal
  for (Index i = 0; i < 8; ++i) {
    EXPECT_NEAR(f.at_point(i), expect[i], 1e-15 * expect[i]) << "point " << i;
    EXPECT_EQ(bits(f.at(s.points[i])), bits(f.at_point(i))) << "point " << i;
  }
  EXPECT_EQ(f.boundary_points(), 8u);
  EXPECT_TRUE(std::isnan(f.at_point(8)));
}

TEST(SizingField, InteriorPointGetsInverseDistanceMean) {
  const auto s = fixtures::unit_cube_surface();
  const auto f = build_ok(s, cube_with_centre(), growth(kHuge));
  const auto spacing = mean_incident_edge(s);
  double mean = 0;
  for (int i = 0; i < 8; ++i) mean += spacing[std::size_t(i)] / 8;  // all 8 corners equidistant
  EXPECT_NEAR(f.at_point(8), mean, 1e-14);
  EXPECT_EQ(bits(f.at({0.5, 0.5, 0.5})), bits(f.at_point(8)));
}

TEST(SizingField, UniformSizeIsConstantAndClamped) {
  // The cube's boundary spacing is 1 to 1.2: a size at or above it, or one
  // that hmax holds below it, is one value everywhere.
  const auto s = fixtures::unit_cube_surface();
  const auto m = fixtures::unit_cube_mesh();
  auto rng = seeded_rng("UniformSizeIsConstantAndClamped");
  for (auto [size, hmin, hmax, want] : {std::tuple{2.0, 0.0, 0.0, 2.0}, std::tuple{0.3, 1.5, 0.0, 1.5},
                                        std::tuple{2.0, 0.0, 1.0, 1.0}, std::tuple{0.3, 0.1, 0.25, 0.25}}) {
    SizingOptions o;
    o.size = size;
    if (hmin > 0) o.hmin = hmin;
    if (hmax > 0) o.hmax = hmax;
    const auto f = build_ok(s, m, o);
    EXPECT_TRUE(f.uniform()) << size << " " << hmin << " " << hmax;
    for (int q = 0; q < 100; ++q) EXPECT_EQ(f.at(random_in(rng, unit_box(0.5))), want);
    EXPECT_EQ(f.at_point(7), want);
  }
}

/// max(size, max_p s(p) - |x - p|), clamped to hmax, by brute force.
double brute_graded(const SurfaceMesh& s, const std::vector<double>& spacing, double size, double hmax,
                    const Vec3& x) {
  double best = size;
  for (Index p = 0; p < s.points.size(); ++p)
    if (spacing[p] > 0) best = std::max(best, spacing[p] - std::sqrt(dot(x - s.points[p], x - s.points[p])));
  return std::min(best, hmax);
}

TEST(SizingField, SizeIsRaisedNextToACoarserBoundary) {
  // sphere966's triangles are about four times --size 0.1 wide: h is their
  // spacing at the boundary, falls by one per unit of distance, and is the
  // size deep inside; the same bits as a brute-force loop, after a round trip
  // through encode(), and 1-Lipschitz.
  const SphereWithBackground* sp = sphere_with_background();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable or not star-shaped";
  const auto spacing = mean_incident_edge(sp->surface);
  const double hi = *std::max_element(spacing.begin(), spacing.end());
  for (const double hmax : {kHuge, 0.5 * hi}) {
    SizingOptions o;
    o.size = 0.1 * hi;
    if (hmax < kHuge) o.hmax = hmax;
    const auto f = build_ok(sp->surface, sp->background, o);
    EXPECT_FALSE(f.uniform());
    const auto d = SizingField::decode(f.encode());
    ASSERT_TRUE(d.ok()) << d.status().message();
    EXPECT_EQ(bits(f.at({0, 0, 0})), bits(*o.size)) << "the centre is far from every boundary point";
    for (Index p = 0; p < sp->surface.points.size(); ++p) {
      if (spacing[p] == 0) continue;
      EXPECT_GE(f.at(sp->surface.points[p]), std::min(spacing[p], hmax)) << "point " << p;
    }
    auto rng = seeded_rng("SizeIsRaisedNextToACoarserBoundary");
    const Box b = sp->surface.bounds();
    SizingHint hint;
    int raised = 0;
    for (int q = 0; q < 2000; ++q) {
      const Vec3 x = random_in(rng, b), y = x + Vec3{0.01 * hi, -0.02 * hi, 0.005 * hi};
      const double h = f.at(x);
      ASSERT_EQ(bits(h), bits(brute_graded(sp->surface, spacing, *o.size, hmax, x))) << q;
      ASSERT_EQ(bits(d->at(x)), bits(h)) << q;
      ASSERT_EQ(bits(f.at(x, hint)), bits(h)) << q;
      EXPECT_LE(std::fabs(f.at(y) - h), norm(y - x) * (1 + 1e-12)) << q;
      raised += h > *o.size;
    }
    EXPECT_GT(raised, 100) << "the raise should reach into the volume";
    EXPECT_TRUE(std::isnan(f.at_point(0))) << "a graded field keeps no background points";
  }
}

TEST(SizingField, HminHmaxClampTheField) {
  const auto s = fixtures::unit_cube_surface();
  const auto m = fixtures::unit_cube_mesh();
  SizingOptions o = growth(1.2);
  const auto free = build_ok(s, m, o);
  o.hmin = 1.12;
  o.hmax = 1.16;
  const auto clamped = build_ok(s, m, o);
  auto rng = seeded_rng("HminHmaxClampTheField");
  int below = 0, above = 0;
  for (int q = 0; q < 2000; ++q) {
    const Vec3 x = random_in(rng, unit_box(0.2));
    const double h = free.at(x);
    below += h < 1.12;
    above += h > 1.16;
    EXPECT_EQ(bits(clamped.at(x)), bits(std::clamp(h, 1.12, 1.16)));
  }
  EXPECT_GT(below, 0);
  EXPECT_GT(above, 0);
}

// ---------------------------------------------------------------- growth limit

/// h_G(x) == min(h_inf(x), brute-force growth bound) at random points inside,
/// where h_inf is the same field without an effective growth limit.
void check_growth(const SurfaceMesh& s, const VolumeMesh& m, double g, const Box& box,
                  bool (*inside)(const Vec3&), const char* name) {
  const auto limited = build_ok(s, m, growth(g));
  const auto free = build_ok(s, m, growth(kHuge));
  const auto spacing = mean_incident_edge(s);
  auto rng = seeded_rng(name);
  int active = 0, tried = 0;
  while (tried < 2000) {
    const Vec3 x = random_in(rng, box);
    if (!inside(x)) continue;
    ++tried;
    const double bound = brute_growth(s, spacing, g, x);
    const double h = limited.at(x);
    EXPECT_LE(h, bound * (1 + 1e-12)) << "at " << x[0] << " " << x[1] << " " << x[2];
    EXPECT_NEAR(h, std::min(free.at(x), bound), 1e-12 * h) << "at " << x[0] << " " << x[1] << " " << x[2];
    active += bound < free.at(x);
  }
  EXPECT_GT(active, 100) << "the growth limit should bind somewhere";
}

TEST(SizingField, GrowthLimitMatchesBruteForceOnCube) {
  check_growth(fixtures::unit_cube_surface(), fixtures::unit_cube_mesh(), 1.01, unit_box(0),
               [](const Vec3&) { return true; }, "GrowthLimitMatchesBruteForceOnCube");
}

TEST(SizingField, GrowthLimitMatchesBruteForceOnGradedGrid) {
  SurfaceMesh s;
  VolumeMesh m;
  graded_kuhn(6, s, m);
  const auto report = validate_mesh(m, &s);
  ASSERT_TRUE(report.ok()) << format_validation(report);
  check_growth(s, m, 1.1, unit_box(0), [](const Vec3&) { return true; },
               "GrowthLimitMatchesBruteForceOnGradedGrid");
}

TEST(SizingField, GrowthLimitMatchesBruteForceOnSphere966) {
  const SphereWithBackground* sp = sphere_with_background();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable or not star-shaped";
  const Box b = sp->surface.bounds();
  check_growth(sp->surface, sp->background, 1.002, b,
               [](const Vec3& x) { return norm(x) < 9.0; },  // the sphere has radius ~10 about 0
               "GrowthLimitMatchesBruteForceOnSphere966");
}

TEST(SizingField, SphereBoundarySpacingAndCentre) {
  const SphereWithBackground* sp = sphere_with_background();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable or not star-shaped";
  const auto f = build_ok(sp->surface, sp->background, growth(kHuge));
  const auto spacing = mean_incident_edge(sp->surface);
  double lo = 1e300, hi = 0;
  for (Index i = 0; i < sp->surface.points.size(); ++i) {
    if (spacing[i] == 0) continue;
    lo = std::min(lo, spacing[i]);
    hi = std::max(hi, spacing[i]);
    EXPECT_NEAR(f.at_point(i), spacing[i], 1e-14 * spacing[i]) << "point " << i;
    EXPECT_EQ(bits(f.at(sp->surface.points[i])), bits(f.at_point(i))) << "point " << i;
  }
  const Index centre = static_cast<Index>(sp->surface.points.size());
  EXPECT_GE(f.at_point(centre), lo);
  EXPECT_LE(f.at_point(centre), hi);
}

// ---------------------------------------------------------------- continuity, outside

TEST(SizingField, ContinuousAcrossSharedFace) {
  // Kuhn tets 0 {0,1,3,7} and 1 {0,5,1,7} share face {0,1,7}.
  const auto m = fixtures::unit_cube_mesh();
  const auto f = build_ok(fixtures::unit_cube_surface(), m, growth(1.2));
  const Vec3 &p0 = m.points[0], &p1 = m.points[1], &p7 = m.points[7], &p3 = m.points[3], &p5 = m.points[5];
  const Vec3 n = cross(p1 - p0, p7 - p0);  // normal of the shared face
  auto rng = seeded_rng("ContinuousAcrossSharedFace");
  std::uniform_real_distribution<double> u(0.05, 1);
  for (int q = 0; q < 500; ++q) {
    double a = u(rng), b = u(rng), c = u(rng);
    const double t = a + b + c;
    const Vec3 x = (a / t) * p0 + (b / t) * p1 + (c / t) * p7;
    const Vec3 xa = x + 1e-12 * n, xb = x - 1e-12 * n;
    // One side is strictly inside tet 0 (towards 3), the other strictly inside tet 1 (towards 5).
    const bool a_in_0 = exact::orient3d(p0, p1, p7, xa) == exact::orient3d(p0, p1, p7, p3);
    const Vec3& in0 = a_in_0 ? xa : xb;
    const Vec3& in1 = a_in_0 ? xb : xa;
    ASSERT_EQ(exact::orient3d(p0, p1, p7, in1), exact::orient3d(p0, p1, p7, p5));
    const double h0 = f.at(in0), h1 = f.at(in1), hx = f.at(x);
    EXPECT_NEAR(h0, h1, 1e-12 * h0);
    EXPECT_NEAR(hx, h0, 1e-12 * h0);
  }
}

TEST(SizingField, OutsidePointTakesValueAtClosestPoint) {
  const auto f = build_ok(fixtures::unit_cube_surface(), fixtures::unit_cube_mesh(), growth(1.2));
  auto rng = seeded_rng("OutsidePointTakesValueAtClosestPoint");
  std::uniform_real_distribution<double> u(0, 1), off(1e-9, 2);
  for (int q = 0; q < 500; ++q) {
    const Vec3 y{u(rng), u(rng), 0};  // on face z = 0
    const double h = f.at({y[0], y[1], -off(rng)});
    EXPECT_NEAR(h, f.at(y), 1e-12 * h);
  }
  EXPECT_EQ(bits(f.at({10, 20, 30})), bits(f.at_point(7)));
  EXPECT_EQ(bits(f.at({-5, -1e-3, -7})), bits(f.at_point(0)));
}

// ---------------------------------------------------------------- determinism

void check_roundtrip(const SurfaceMesh& s, const VolumeMesh& m, const SizingOptions& o, const char* name) {
  const auto f = build_ok(s, m, o);
  const std::string bytes = f.encode();
  EXPECT_EQ(build_ok(s, m, o).encode(), bytes) << "two builds differ";
  auto d = SizingField::decode(bytes);
  ASSERT_TRUE(d.ok()) << d.status().to_string();
  EXPECT_EQ(d->encode(), bytes);
  Box b = s.bounds();
  const Vec3 pad = 0.1 * (b.hi - b.lo);
  b = Box{b.lo - pad, b.hi + pad};
  auto rng = seeded_rng(name);
  for (int q = 0; q < 10000; ++q) {
    const Vec3 x = random_in(rng, b);
    ASSERT_EQ(bits(f.at(x)), bits(d->at(x))) << "at " << x[0] << " " << x[1] << " " << x[2];
  }
  for (Index i = 0; i < m.points.size(); ++i) ASSERT_EQ(bits(f.at_point(i)), bits(d->at_point(i)));
}

TEST(SizingField, EncodeDecodeIsBitIdenticalOnCube) {
  check_roundtrip(fixtures::unit_cube_surface(), cube_with_centre(), growth(1.1), "EncodeDecodeIsBitIdenticalOnCube");
  SizingOptions o;
  o.size = 0.25;
  o.hmax = 0.2;
  check_roundtrip(fixtures::unit_cube_surface(), fixtures::unit_cube_mesh(), o, "EncodeDecodeUniform");
}

TEST(SizingField, EncodeDecodeIsBitIdenticalOnSphere966) {
  const SphereWithBackground* sp = sphere_with_background();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable or not star-shaped";
  SizingOptions o = growth(1.01);
  o.hmin = 0.9;
  check_roundtrip(sp->surface, sp->background, o, "EncodeDecodeIsBitIdenticalOnSphere966");
}

TEST(SizingField, ParallelQueriesMatchSerial) {
  SurfaceMesh s;
  VolumeMesh m;
  graded_kuhn(8, s, m);
  const auto f = build_ok(s, m, growth(1.1));
  auto rng = seeded_rng("ParallelQueriesMatchSerial");
  std::vector<Vec3> xs(20000);
  for (Vec3& x : xs) x = random_in(rng, unit_box(0.05));
  std::vector<double> serial(xs.size()), parallel(xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i) serial[i] = f.at(xs[i]);
  tbb::parallel_for(std::size_t(0), xs.size(), [&](std::size_t i) { parallel[i] = f.at(xs[i]); });
  for (std::size_t i = 0; i < xs.size(); ++i) ASSERT_EQ(bits(serial[i]), bits(parallel[i])) << i;
}

/// at(x, hint) == at(x) bit for bit along a path of small steps with jumps,
/// through background vertices, face centroids (walks that end on a face) and
/// points outside the mesh, with one hint carried all the way.
void check_hinted(const SurfaceMesh& s, const VolumeMesh& m, const SizingOptions& o, const Box& box,
                  const char* name) {
  const auto f = build_ok(s, m, o);
  const auto decoded = SizingField::decode(f.encode());
  ASSERT_TRUE(decoded.ok()) << decoded.status().message();
  auto rng = seeded_rng(name);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Vec3 extent = box.hi - box.lo;
  SizingHint hint, decoded_hint;
  Vec3 x = 0.5 * (box.lo + box.hi);
  for (int i = 0; i < 6000; ++i) {
    const double r = unit(rng);
    if (r < 0.05) {
      x = random_in(rng, box);  // a jump
    } else if (r < 0.08) {
      x = m.points[static_cast<std::size_t>(unit(rng) * static_cast<double>(m.points.size())) % m.points.size()];
    } else if (r < 0.11) {
      const Tet& t = m.tets[static_cast<std::size_t>(unit(rng) * static_cast<double>(m.tets.size())) % m.tets.size()];
      x = (1.0 / 3.0) * (m.points[t[0]] + m.points[t[1]] + m.points[t[2]]);
    } else if (r < 0.13) {
      x = box.hi + Vec3{0.3 * extent[0], unit(rng) * extent[1], 0.0};  // outside
    } else {
      for (int a = 0; a < 3; ++a) x[a] += 0.02 * extent[a] * (unit(rng) - 0.5);
    }
    ASSERT_EQ(bits(f.at(x, hint)), bits(f.at(x))) << name << " query " << i;
    ASSERT_EQ(bits(decoded->at(x, decoded_hint)), bits(f.at(x))) << name << " decoded, query " << i;
  }
}

TEST(SizingField, HintedQueriesMatchUnhinted) {
  SurfaceMesh s;
  VolumeMesh m;
  graded_kuhn(6, s, m);
  check_hinted(s, m, growth(1.1), unit_box(0.1), "HintedQueriesMatchUnhinted/graded");
  const SphereWithBackground* sp = sphere_with_background();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable or not star-shaped";
  check_hinted(sp->surface, sp->background, growth(1.2), sp->surface.bounds(), "HintedQueriesMatchUnhinted/sphere");
}

// ---------------------------------------------------------------- surface values

TEST(SizingField, SurfaceValuesMatchTheBuiltFieldBitForBit) {
  const SphereWithBackground* sp = sphere_with_background();
  ASSERT_NE(sp, nullptr) << "sphere966.mesh not readable or not star-shaped";
  SizingOptions clamped;
  clamped.hmin = 0.9;
  clamped.hmax = 1.1;
  SizingOptions uniform;
  uniform.size = 0.7;
  for (const SizingOptions& o : {growth(1.2), growth(1.02), clamped, uniform}) {
    const SizingField f = build_ok(sp->surface, sp->background, o);
    const Result<std::vector<double>> h = SizingField::surface_values(sp->surface, o);
    ASSERT_TRUE(h.ok()) << h.status().to_string();
    ASSERT_EQ(h->size(), sp->surface.points.size());
    for (Index i = 0; i < sp->surface.points.size(); ++i)
      EXPECT_EQ(bits((*h)[i]), bits(f.at(sp->surface.points[i]))) << "point " << i;
  }
  SurfaceMesh extra = sp->surface;  // a point no triangle uses gets NaN
  extra.points.push_back({100, 100, 100});
  const Result<std::vector<double>> h = SizingField::surface_values(extra, {});
  ASSERT_TRUE(h.ok());
  EXPECT_TRUE(std::isnan(h->back()));
  EXPECT_FALSE(std::isnan(h->front()));
}

// ---------------------------------------------------------------- errors

TEST(SizingField, RejectsInvalidOptions) {
  const auto s = fixtures::unit_cube_surface();
  const auto m = fixtures::unit_cube_mesh();
  auto expect_bad = [&](SizingOptions o, const char* option) {
    auto f = SizingField::build(s, m, o);
    ASSERT_FALSE(f.ok()) << option;
    EXPECT_EQ(f.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(f.status().message().find(option), std::string::npos) << f.status().message();
  };
  for (double g : {1.0, 0.5, -2.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    expect_bad(growth(g), "--growth");
  }
  for (double v : {0.0, -1.0, std::nan("")}) {
    SizingOptions o;
    o.size = v;
    expect_bad(o, "--size");
    o = {};
    o.hmin = v;
    expect_bad(o, "--hmin");
    o = {};
    o.hmax = v;
    expect_bad(o, "--hmax");
  }
  SizingOptions o;
  o.hmin = 2;
  o.hmax = 1;
  expect_bad(o, "--hmin");
  o.size = 1.5;  // also with a uniform size
  expect_bad(o, "--hmax");
}

TEST(SizingField, RejectsBadSurfaceOrBackground) {
  const auto s = fixtures::unit_cube_surface();
  const auto m = fixtures::unit_cube_mesh();
  auto expect_bad = [](const SurfaceMesh& ss, const VolumeMesh& mm, const char* what) {
    auto f = SizingField::build(ss, mm, {});
    ASSERT_FALSE(f.ok()) << what;
    EXPECT_EQ(f.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(f.status().message().find(what), std::string::npos) << f.status().message();
  };
  VolumeMesh moved = m;
  moved.points[5][0] += 1e-12;
  expect_bad(s, moved, "point 5 at (1, 0, 1) is not a point of the background mesh");
  VolumeMesh inverted = m;
  std::swap(inverted.tets[3][0], inverted.tets[3][1]);
  expect_bad(s, inverted, "tet 3 (points 2, 0, 6, 7) is not positively oriented");
  SurfaceMesh bad = s;
  bad.triangles[4][1] = 99;
  expect_bad(bad, m, "triangle 4 (points 0, 99, 2)");
  VolumeMesh empty = m;
  empty.tets.clear();
  expect_bad(s, empty, "no tetrahedra");
}

TEST(SizingField, DecodeRejectsCorruptBuffers) {
  const auto f = build_ok(fixtures::unit_cube_surface(), fixtures::unit_cube_mesh(), {});
  const std::string good = f.encode();
  auto expect_bad = [](const std::string& bytes, const char* what) {
    auto d = SizingField::decode(bytes);
    ASSERT_FALSE(d.ok()) << what;
    EXPECT_EQ(d.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(d.status().message().find(what), std::string::npos) << d.status().message();
  };
  expect_bad("", "bad magic");
  expect_bad(good.substr(0, good.size() - 1), "boundary point count exceeds the buffer");
  expect_bad(good.substr(0, 60), "point count exceeds the buffer");
  expect_bad(good + "x", "trailing bytes");
  std::string wrong_version = good;
  wrong_version[8] = 7;
  expect_bad(wrong_version, "unsupported version 7");
  // Layout: magic 8, version 4, mode 4, 3 doubles, n, 8 points, 8 values, m, tets.
  const std::size_t values_at = 8 + 4 + 4 + 24 + 8 + 8 * 24;
  std::string negative = good;
  negative[values_at + 7] = static_cast<char>(negative[values_at + 7] | 0x80);  // sign bit of value 0
  expect_bad(negative, "value -");
  const std::size_t tets_at = values_at + 8 * 8 + 8;
  std::string flipped = good;
  std::swap_ranges(flipped.begin() + long(tets_at), flipped.begin() + long(tets_at + 4),
                   flipped.begin() + long(tets_at + 4));  // swap two indices of tet 0
  expect_bad(flipped, "tet 0 (points 1, 0, 3, 7) is not positively oriented");
}

TEST(SizingField, QueriesStayWithinBoundarySpacingRange) {
  // With the growth limit and no clamp, h never leaves [min, max] of the
  // boundary spacings, whatever the query point (here: random, in a box).
  SurfaceMesh s;
  VolumeMesh m;
  graded_kuhn(12, s, m);
  const auto f = build_ok(s, m, growth(1.2));
  auto rng = seeded_rng("QueriesStayWithinBoundarySpacingRange");
  const auto spacing = mean_incident_edge(s);
  double smin = 1e300, smax = 0;
  for (double v : spacing)
    if (v > 0) smin = std::min(smin, v), smax = std::max(smax, v);
  for (int i = 0; i < 20000; ++i) {
    const double h = f.at(random_in(rng, unit_box(0)));
    ASSERT_GE(h, smin);
    ASSERT_LE(h, smax);
  }
}

TEST(SizingField, LowerBoundHoldsOverItsBoxAndFollowsTheField) {
  // lower_bound(box) <= h(x) for every x of the box inside the mesh, and it is
  // local: small near the fine corner of a graded grid, large near the coarse one.
  SurfaceMesh s;
  VolumeMesh m;
  graded_kuhn(8, s, m);
  for (const double g : {1.05, 1.3}) {
    const auto f = build_ok(s, m, growth(g));
    std::mt19937_64 rng(20261121);
    std::uniform_real_distribution<double> u(0, 1);
    for (int b = 0; b < 40; ++b) {
      Box box;
      box.add(random_in(rng, unit_box(0)));
      box.add(random_in(rng, Box{box.lo - Vec3{0.2, 0.2, 0.2}, box.lo + Vec3{0.2, 0.2, 0.2}}));
      for (int a = 0; a < 3; ++a) box.lo[a] = std::max(box.lo[a], 0.0), box.hi[a] = std::min(box.hi[a], 1.0);
      const double lo = f.lower_bound(box);
      ASSERT_GT(lo, 0);
      for (int i = 0; i < 200; ++i) ASSERT_LE(lo, f.at(random_in(rng, box))) << "box " << b << " growth " << g;
      for (const Vec3& corner : {box.lo, box.hi}) ASSERT_LE(lo, f.at(corner));
    }
    const double fine = f.lower_bound(Box{{0, 0, 0}, {0.1, 0.1, 0.1}});
    const double coarse = f.lower_bound(Box{{0.9, 0.9, 0.9}, {1, 1, 1}});
    EXPECT_GT(coarse, 4 * fine) << "growth " << g;
    EXPECT_LE(f.lower_bound(unit_box(0)), fine);
  }
  SizingOptions o;
  o.size = 0.25;
  const auto uniform = build_ok(s, m, o);
  EXPECT_LE(uniform.lower_bound(unit_box(0)), 0.25);
  EXPECT_GT(uniform.lower_bound(unit_box(0)), 0.25 * (1 - 1e-6));
  EXPECT_TRUE(std::isnan(uniform.lower_bound(Box{})));
}

}  // namespace
}  // namespace pdrmesh
