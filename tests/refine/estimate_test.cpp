// SPDX-License-Identifier: AGPL-3.0-or-later
// The cost estimate against real meshes of cubes built in code.
#include "pdrmesh/estimate.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>

#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/validate.hpp"
#include "test_fixtures.hpp"

namespace pdrmesh {
namespace {

/// The estimate must be within this factor of the real count (either side).
constexpr double kFactor = 2.0;

/// A cube of side `side` whose faces are split into n x n squares of two
/// triangles each (the unit cube's triangles subdivided n times along each
/// edge): boundary spacing about side / n. Lattice points are integers before
/// the one scaling, so shared edges get identical points.
SurfaceMesh subdivided_cube(double side, int n) {
  const SurfaceMesh unit = fixtures::unit_cube_surface();
  SurfaceMesh s;
  std::map<std::array<long, 3>, Index> index;
  auto point = [&](const std::array<long, 3>& q) {
    auto [it, fresh] = index.emplace(q, static_cast<Index>(s.points.size()));
    if (fresh) {
      s.points.push_back({side * static_cast<double>(q[0]) / n, side * static_cast<double>(q[1]) / n,
                          side * static_cast<double>(q[2]) / n});
    }
    return it->second;
  };
  for (std::size_t t = 0; t < unit.triangles.size(); ++t) {
    std::array<std::array<long, 3>, 3> c{};
    for (int v = 0; v < 3; ++v)
      for (int k = 0; k < 3; ++k) c[v][k] = static_cast<long>(unit.points[unit.triangles[t][v]][k]);
    auto lattice = [&](int i, int j) {
      std::array<long, 3> q{};
      for (int k = 0; k < 3; ++k) q[k] = c[0][k] * (n - i - j) + c[1][k] * i + c[2][k] * j;
      return point(q);
    };
    for (int i = 0; i < n; ++i) {
      for (int j = 0; i + j < n; ++j) {
        s.triangles.push_back({lattice(i, j), lattice(i + 1, j), lattice(i, j + 1)});
        s.surface_ids.push_back(unit.surface_ids[t]);
        if (i + j + 1 < n) {
          s.triangles.push_back({lattice(i + 1, j), lattice(i + 1, j + 1), lattice(i, j + 1)});
          s.surface_ids.push_back(unit.surface_ids[t]);
        }
      }
    }
  }
  s.name = "subdivided_cube";
  return s;
}

/// Meshes `surface` serially, validates the result, and returns its tet count.
double real_tets(const SurfaceMesh& surface, const SizingOptions& sizing) {
  SerialOptions options;
  options.sizing = sizing;
  auto r = mesh_serial(surface, options);
  EXPECT_TRUE(r.ok()) << r.status().to_string();
  if (!r.ok()) return 0;
  const ValidationReport report = validate_mesh(r->mesh, &surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
  return static_cast<double>(r->mesh.tets.size());
}

TEST(Estimate, VolumeIsExactAndUniformSizeScalesAsTheCube) {
  const SurfaceMesh cube = subdivided_cube(3.0, 4);
  SizingOptions o;
  o.size = o.hmax = 0.5;  // hmax: one h everywhere, also next to the 0.75-wide triangles
  auto a = estimate_mesh(cube, o);
  ASSERT_TRUE(a.ok()) << a.status().to_string();
  EXPECT_NEAR(a->volume, 27.0, 1e-12);
  o.size = o.hmax = 0.25;
  auto b = estimate_mesh(cube, o);
  ASSERT_TRUE(b.ok());
  EXPECT_NEAR(b->tets / a->tets, 8.0, 1e-9);  // h halved: eight times the tets
  EXPECT_NEAR(b->mean_h, 0.25, 1e-12);
  EXPECT_GT(b->peak_bytes, a->peak_bytes);
}

/// The estimate of `surface` with `o` is within `factor` of a real mesh's count,
/// and the same when asked again (a function of its inputs only).
void expect_estimate_within_factor(const SurfaceMesh& surface, const SizingOptions& o, double factor = kFactor) {
  auto e = estimate_mesh(surface, o);
  ASSERT_TRUE(e.ok()) << e.status().to_string();
  const double real = real_tets(surface, o);
  ASSERT_GT(real, 0);
  EXPECT_LT(e->tets, factor * real) << "estimate " << e->tets << ", real " << real;
  EXPECT_GT(e->tets, real / factor) << "estimate " << e->tets << ", real " << real;
  auto again = estimate_mesh(surface, o);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->tets, e->tets);
}

TEST(Estimate, UniformSizeWithinFactorOfARealMesh) {
  SizingOptions o;
  o.size = 0.2;
  expect_estimate_within_factor(subdivided_cube(2.0, 4), o);
}

TEST(Estimate, GradedDefaultWithinFactorOfARealMesh) {
  // Default sizing: the boundary spacing 2/10 inside, the growth limit near the faces.
  expect_estimate_within_factor(subdivided_cube(2.0, 10), SizingOptions{});
}

TEST(Estimate, ABodyInAFarFieldWithinFactorOfARealMesh) {
  // A finely split cube (spacing 0.2) in the middle of a coarse one (spacing
  // 8): far from the body h follows the growth limit, not the body's spacing
  // (taking the nearest boundary point's spacing everywhere overestimated
  // such a domain by orders of magnitude).
  SurfaceMesh outer = subdivided_cube(16.0, 2);
  const SurfaceMesh body = subdivided_cube(2.0, 10);
  const Index offset = static_cast<Index>(outer.points.size());
  for (const Vec3& p : body.points) outer.points.push_back(p + Vec3{7, 7, 7});
  for (std::size_t t = 0; t < body.triangles.size(); ++t) {  // reversed: a cavity
    const Tri& k = body.triangles[t];
    outer.triangles.push_back({k[0] + offset, k[2] + offset, k[1] + offset});
    outer.surface_ids.push_back(body.surface_ids[t] + 10);
  }
  expect_estimate_within_factor(outer, SizingOptions{});
}

TEST(Estimate, NineBodiesInAFarFieldWithinFactorFourOfARealMesh) {
  // More components than the estimate blends one by one: nine finely split
  // cubes (spacing 0.2) inside a coarse one (spacing 8). Between the bodies
  // and the far field h still grows; the nearest boundary point of all the
  // components at once gave the bodies' spacing over half the box (about ten
  // times the real count). Blending the spacings of several bodies around a
  // point keeps h lower between them than the background mesh does (two
  // bodies: 2.5 times the real count, four: 3.2), hence a factor 4 here.
  SurfaceMesh outer = subdivided_cube(16.0, 2);
  const SurfaceMesh body = subdivided_cube(1.0, 5);
  for (int i = 0; i < 9; ++i) {
    const Vec3 at{4.0 + 4.0 * (i % 3), 4.0 + 4.0 * (i / 3), 7.5};
    const Index offset = static_cast<Index>(outer.points.size());
    for (const Vec3& p : body.points) outer.points.push_back(p + at);
    for (std::size_t t = 0; t < body.triangles.size(); ++t) {  // reversed: a cavity
      const Tri& k = body.triangles[t];
      outer.triangles.push_back({k[0] + offset, k[2] + offset, k[1] + offset});
      outer.surface_ids.push_back(body.surface_ids[t] + 10);
    }
  }
  expect_estimate_within_factor(outer, SizingOptions{}, 4.0);
}

TEST(Estimate, ASizeRisingNextToWideTrianglesWithinFactorOfARealMesh) {
  // A cube of side 2 in triangles 1 wide at --size 0.1: h rises from 1 at the
  // corners, so the mesh has far fewer tets than one h everywhere would.
  const SurfaceMesh cube = subdivided_cube(2.0, 2);
  SizingOptions o;
  o.size = 0.1;
  expect_estimate_within_factor(cube, o);
  auto graded = estimate_mesh(cube, o);
  o.hmax = o.size;  // one h everywhere
  auto uniform = estimate_mesh(cube, o);
  ASSERT_TRUE(graded.ok() && uniform.ok());
  EXPECT_LT(graded->tets, 0.5 * uniform->tets);
}

TEST(Estimate, HmaxCapsTheGradedSizeAndHminLiftsIt) {
  const SurfaceMesh cube = subdivided_cube(2.0, 10);
  SizingOptions o;
  auto base = estimate_mesh(cube, o);
  o.hmax = 0.1;  // below the boundary spacing 0.2: h = 0.1 everywhere
  auto capped = estimate_mesh(cube, o);
  ASSERT_TRUE(base.ok() && capped.ok());
  EXPECT_GT(capped->tets, 4 * base->tets);
  EXPECT_NEAR(capped->mean_h, 0.1, 1e-12);
  SizingOptions lifted;
  lifted.hmin = 0.4;
  auto up = estimate_mesh(cube, lifted);
  ASSERT_TRUE(up.ok());
  EXPECT_LT(up->tets, base->tets / 4);
}

TEST(Estimate, TinySizeIsRefusedWithTheSmallestSensibleSize) {
  // Triangles 0.1 wide: the size rises next to them, and is 1e-9 in the rest.
  const SurfaceMesh cube = subdivided_cube(2.0, 20);
  SizingOptions o;
  o.size = 1e-9;
  auto e = estimate_mesh(cube, o);
  ASSERT_TRUE(e.ok());
  EXPECT_TRUE(std::isfinite(e->tets));
  EXPECT_GT(e->tets, 1e27);
  const double limit = 1e6;
  const Status s = check_tet_limit(*e, o, limit, "--max-tets");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("--size 1e-09 would make about"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("the limit is 1,000,000 tets (--max-tets)"), std::string::npos) << s.message();
  // The suggested size fits the limit; one a little smaller does not.
  const double h = smallest_size_for(e->volume, limit);
  EXPECT_NE(s.message().find(fmt::format("use --size {:.2g} or larger", h)), std::string::npos) << s.message();
  o.size = o.hmax = h;  // the suggestion is for one h everywhere: a rise only lowers the count
  auto fits = estimate_mesh(cube, o);
  ASSERT_TRUE(fits.ok());
  EXPECT_LE(fits->tets, limit);
  EXPECT_TRUE(check_tet_limit(*fits, o, limit, "--max-tets").ok());
  o.size = o.hmax = 0.9 * h;
  auto over = estimate_mesh(cube, o);
  ASSERT_TRUE(over.ok());
  EXPECT_GT(over->tets, limit);
}

TEST(Estimate, BadOptionsAreRefused) {
  const SurfaceMesh cube = subdivided_cube(1.0, 1);
  SizingOptions o;
  o.growth = 1.0;
  EXPECT_FALSE(estimate_mesh(cube, o).ok());
  EXPECT_GT(default_max_tets(), 0);
}

}  // namespace
}  // namespace pdrmesh
