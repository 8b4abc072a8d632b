// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the grid generation passes (refine.hpp) and the serial pipeline.
#include "pdrmesh/refine.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <vector>

#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/predicates.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/validate.hpp"
#include "test_fixtures.hpp"
#include "tet_fixtures.hpp"

namespace pdrmesh {
namespace {

SizingField uniform_field(const SurfaceMesh& surface, const VolumeMesh& background, double h) {
  SizingOptions o;
  o.size = h;
  o.hmax = h;  // h everywhere, also next to boundary triangles wider than h
  auto r = SizingField::build(surface, background, o);
  EXPECT_TRUE(r.ok()) << r.status().to_string();
  return std::move(r).value();
}

/// The surface made of a mesh's hull faces (all its points kept).
SurfaceMesh hull_surface(const VolumeMesh& m) {
  SurfaceMesh s;
  s.points = m.points;
  s.triangles = fixtures::hull_faces(m);
  s.surface_ids.assign(s.triangles.size(), 1);
  s.name = "hull";
  return s;
}

/// Sorted keys of the hull faces.
std::vector<Tri> hull_keys(const VolumeMesh& m) {
  std::vector<Tri> k;
  for (const Tri& t : fixtures::hull_faces(m)) k.push_back(topo::sorted_key(t));
  std::sort(k.begin(), k.end());
  return k;
}

/// Share of the edges with no endpoint in `fixed` whose length lies in [0.6, 1.5] h.
double interior_edge_share(const VolumeMesh& m, const std::vector<bool>& fixed, double h,
                           std::size_t* count) {
  std::set<std::pair<Index, Index>> edges;
  for (const Tet& k : m.tets)
    for (int e = 0; e < 6; ++e) {
      Index a = k[topo::kEdgeVertex[e][0]], b = k[topo::kEdgeVertex[e][1]];
      if (fixed[a] || fixed[b]) continue;
      edges.insert({std::min(a, b), std::max(a, b)});
    }
  std::size_t good = 0;
  for (const auto& [a, b] : edges) {
    const double l = norm(m.points[a] - m.points[b]);
    if (l >= 0.6 * h && l <= 1.5 * h) ++good;
  }
  *count = edges.size();
  return edges.empty() ? 0.0 : double(good) / double(edges.size());
}

std::vector<bool> boundary_points(const VolumeMesh& m) {
  std::vector<bool> b(m.points.size(), false);
  for (const Tri& t : fixtures::hull_faces(m))
    for (Index v : t) b[v] = true;
  return b;
}

/// Checks that every interior face is locally Delaunay (the apex across it
/// is not strictly inside the tet's circumsphere); returns the faces checked.
std::size_t expect_locally_delaunay(const TetMesh& m) {
  std::size_t faces = 0;
  for (Index t = 0; t < m.num_slots(); ++t) {
    if (!m.alive(t)) continue;
    const Tet& k = m.tet(t);
    for (int f = 0; f < 4; ++f) {
      const Index n = m.neighbour(t, f);
      if (n == kNoIndex) continue;
      ++faces;
      const Vec3& e = m.point(m.tet(face_tet(n))[face_local(n)]);
      EXPECT_LE(exact::insphere(m.point(k[0]), m.point(k[1]), m.point(k[2]), m.point(k[3]), e), 0)
          << "tet " << t << " face " << f;
    }
  }
  return faces;
}

TetMesh refined_cube(double h, RefineStats* stats = nullptr, const RefineOptions& options = {}) {
  const SurfaceMesh surface = fixtures::unit_cube_surface();
  const VolumeMesh initial = fixtures::unit_cube_mesh();
  const SizingField field = uniform_field(surface, initial, h);
  TetMesh mesh = fixtures::build(initial);
  auto r = refine(mesh, field, options);
  EXPECT_TRUE(r.ok()) << r.status().to_string();
  if (stats != nullptr && r.ok()) *stats = *r;
  return mesh;
}

TEST(Refine, CubeToUniformSize) {
  const double h = 0.2;
  RefineStats stats;
  TetMesh mesh = refined_cube(h, &stats);
  ASSERT_TRUE(mesh.check().ok()) << mesh.check().to_string();
  EXPECT_GT(stats.points_added, 20u);
  EXPECT_FALSE(stats.passes.empty());
  const VolumeMesh out = mesh.to_volume_mesh();
  const SurfaceMesh surface = fixtures::unit_cube_surface();
  const ValidationReport report = validate_mesh(out, &surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
  // The frozen boundary is untouched: same hull, the 8 corners at their places,
  // and every new point strictly inside the cube.
  EXPECT_EQ(hull_keys(out), hull_keys(fixtures::unit_cube_mesh()));
  for (Index v = 0; v < 8; ++v) EXPECT_EQ(out.points[v], surface.points[v]);
  for (std::size_t v = 8; v < out.points.size(); ++v)
    for (int k = 0; k < 3; ++k) {
      EXPECT_GT(out.points[v][k], 0.0);
      EXPECT_LT(out.points[v][k], 1.0);
    }
  std::size_t edges = 0;
  const double share = interior_edge_share(out, boundary_points(out), h, &edges);
  EXPECT_GT(edges, 20u);
  EXPECT_GE(share, 0.9) << edges << " interior edges";
}

TEST(Refine, IsDeterministic) {
  const VolumeMesh a = refined_cube(0.25).to_volume_mesh();
  const VolumeMesh b = refined_cube(0.25).to_volume_mesh();
  ASSERT_EQ(a.points.size(), b.points.size());
  ASSERT_EQ(a.tets, b.tets);
  EXPECT_EQ(std::memcmp(a.points.data(), b.points.data(), a.points.size() * sizeof(Vec3)), 0);
}

TEST(Refine, SpatialOrderValidatesAndIsDeterministic) {
  // Fine enough that the mesh passes a renumbering threshold of 4096 tets
  // (the default threshold would need a far larger mesh).
  RefineOptions o;
  o.spatial_order_min_tets = 4096;
  RefineStats stats;
  const VolumeMesh a = refined_cube(0.07, &stats, o).to_volume_mesh();
  ASSERT_GT(a.tets.size(), 8192u);
  const SurfaceMesh surface = fixtures::unit_cube_surface();
  const ValidationReport report = validate_mesh(a, &surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
  std::size_t edges = 0;
  EXPECT_GE(interior_edge_share(a, boundary_points(a), 0.07, &edges), 0.9) << edges << " interior edges";
  const VolumeMesh b = refined_cube(0.07, nullptr, o).to_volume_mesh();
  ASSERT_EQ(a.points.size(), b.points.size());
  ASSERT_EQ(a.tets, b.tets);
  EXPECT_EQ(std::memcmp(a.points.data(), b.points.data(), a.points.size() * sizeof(Vec3)), 0);
  // The order differs from an unrenumbered run's: the renumbering took effect.
  RefineOptions plain;
  plain.spatial_order = false;
  EXPECT_NE(a.tets, refined_cube(0.07, nullptr, plain).to_volume_mesh().tets);
}

TEST(Refine, CavityInsertionKeepsTheMeshDelaunay) {
  // With the Delaunay step alone (no min-max, no long-edge flips), Bowyer-Watson
  // insertion into the Delaunay initial cube leaves every interior face locally
  // Delaunay: the apex across it is not strictly inside the tet's circumsphere.
  const SurfaceMesh surface = fixtures::unit_cube_surface();
  const VolumeMesh initial = fixtures::unit_cube_mesh();
  const SizingField field = uniform_field(surface, initial, 0.2);
  TetMesh m = fixtures::build(initial);
  RefineOptions o;
  o.min_max = false;
  o.long_edge_ratio = 0;
  auto r = refine(m, field, o);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_GT(r->points_added, 50u);
  ASSERT_TRUE(m.check().ok()) << m.check().to_string();
  EXPECT_GT(expect_locally_delaunay(m), 100u);
  const ValidationReport report = validate_mesh(m.to_volume_mesh(), &surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
}

TEST(InsertPoints, IsADelaunayInsertionWhateverTheOrder) {
  // A jittered lattice inside the cube, plus a point on a vertex, one outside
  // and one not finite: every lattice point goes in, the three are declined,
  // the mesh stays valid and locally Delaunay (the cube's initial mesh is), and
  // the order the points come in changes their numbers, not the tets.
  const SurfaceMesh surface = fixtures::unit_cube_surface();
  const VolumeMesh initial = fixtures::unit_cube_mesh();
  std::vector<Vec3> points;
  for (int i = 1; i < 8; ++i)
    for (int j = 1; j < 8; ++j)
      for (int k = 1; k < 8; ++k)
        points.push_back({i / 8.0 + 0.01 * std::sin(i * j + k), j / 8.0 + 0.01 * std::cos(i + j * k),
                          k / 8.0 + 0.01 * std::sin(i * k - j)});
  const std::size_t lattice = points.size();
  points.push_back(initial.points[0]);
  points.push_back({2.0, 0.5, 0.5});
  points.push_back({std::nan(""), 0.5, 0.5});
  VolumeMesh results[2];
  for (int reversed = 0; reversed < 2; ++reversed) {
    TetMesh m = fixtures::build(initial);
    if (reversed) std::reverse(points.begin(), points.end());
    Result<InsertPointsStats> r = insert_points(m, points);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    EXPECT_EQ(r->inserted, lattice);
    EXPECT_EQ(r->declined, 3u);
    ASSERT_EQ(m.num_points(), initial.points.size() + lattice);
    ASSERT_TRUE(m.check().ok()) << m.check().to_string();
    expect_locally_delaunay(m);
    results[reversed] = m.to_volume_mesh();
    const ValidationReport report = validate_mesh(results[reversed], &surface);
    EXPECT_TRUE(report.ok()) << format_validation(report);
  }
  // Each tet as its sorted corners.
  const auto shapes = [](const VolumeMesh& v) {
    std::vector<std::array<Vec3, 4>> out;
    for (const Tet& k : v.tets) {
      std::array<Vec3, 4> c{v.points[k[0]], v.points[k[1]], v.points[k[2]], v.points[k[3]]};
      std::sort(c.begin(), c.end());
      out.push_back(c);
    }
    std::sort(out.begin(), out.end());
    return out;
  };
  EXPECT_EQ(shapes(results[0]), shapes(results[1]));
}

TEST(Refine, InteriorFillsInFewPassesFromACoarseBoundary) {
  // The cube's boundary triangles are ten times h: advancing one layer per
  // pass from them takes many passes; the longest-edge midpoints of interior
  // tets with no front face fill the inside at once.
  const SurfaceMesh surface = fixtures::unit_cube_surface();
  const VolumeMesh initial = fixtures::unit_cube_mesh();
  const SizingField field = uniform_field(surface, initial, 0.1);
  std::size_t passes[2] = {0, 0};
  for (bool fill : {false, true}) {
    TetMesh m = fixtures::build(initial);
    RefineOptions o;
    o.void_midpoints = fill;
    auto r = refine(m, field, o);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    ASSERT_TRUE(m.check().ok()) << m.check().to_string();
    passes[fill ? 1 : 0] = r->passes.size();
    std::size_t edges = 0;
    const VolumeMesh out = m.to_volume_mesh();
    EXPECT_GE(interior_edge_share(out, boundary_points(out), 0.1, &edges), 0.9) << fill;
  }
  EXPECT_LT(2 * passes[1], passes[0]) << passes[1] << " passes with the interior midpoints, "
                                      << passes[0] << " without";
}

/// Two unit cubes side by side along x, each cut like the Kuhn cube (their
/// common face x = 1 gets the same diagonal from both).
VolumeMesh two_boxes() {
  const VolumeMesh cube = fixtures::unit_cube_mesh();
  VolumeMesh m;
  std::map<Vec3, Index> index;
  const auto add = [&](Vec3 p) {
    auto [it, fresh] = index.emplace(p, static_cast<Index>(m.points.size()));
    if (fresh) m.points.push_back(p);
    return it->second;
  };
  for (double shift : {0.0, 1.0})
    for (const Tet& k : cube.tets) {
      Tet t;
      for (int i = 0; i < 4; ++i) t[i] = add(cube.points[k[i]] + Vec3{shift, 0.0, 0.0});
      m.tets.push_back(t);
    }
  return fixtures::with_hull_boundary(m);
}

TEST(Refine, FrozenInteriorPlaneStaysIntact) {
  const VolumeMesh initial = two_boxes();
  const SurfaceMesh surface = hull_surface(initial);
  TetMesh mesh = fixtures::build(initial);
  const auto on_plane = [](const VolumeMesh& m, const Tri& t) {
    return m.points[t[0]][0] == 1.0 && m.points[t[1]][0] == 1.0 && m.points[t[2]][0] == 1.0;
  };
  std::set<Tri> plane_before;
  for (Index t = 0; t < mesh.num_slots(); ++t)
    for (int f = 0; f < 4; ++f) {
      const Tri face = topo::face_of(mesh.tet(t), f);
      if (mesh.neighbour(t, f) != kNoIndex && on_plane(initial, face)) {
        mesh.set_frozen(t, f, true);
        plane_before.insert(topo::sorted_key(face));
      }
    }
  ASSERT_EQ(plane_before.size(), 2u);
  const SizingField field = uniform_field(surface, initial, 0.25);
  auto r = refine(mesh, field);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_TRUE(mesh.check().ok()) << mesh.check().to_string();
  EXPECT_GT(r->points_added, 20u);
  const VolumeMesh out = mesh.to_volume_mesh();
  const ValidationReport report = validate_mesh(out, &surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
  std::set<Tri> plane_after;
  for (const Tet& k : out.tets)
    for (int f = 0; f < 4; ++f)
      if (on_plane(out, topo::face_of(k, f))) plane_after.insert(topo::sorted_key(topo::face_of(k, f)));
  EXPECT_EQ(plane_after, plane_before);
  for (std::size_t v = initial.points.size(); v < out.points.size(); ++v)
    EXPECT_NE(out.points[v][0], 1.0) << "point " << v;
  // Points were added on both sides.
  std::size_t left = 0, right = 0;
  for (std::size_t v = initial.points.size(); v < out.points.size(); ++v)
    (out.points[v][0] < 1.0 ? left : right) += 1;
  EXPECT_GT(left, 5u);
  EXPECT_GT(right, 5u);
}

/// The tets of `whole` whose barycenter has x < cut, points renumbered, every
/// hull face (the cut ones included) a boundary face, hence frozen.
VolumeMesh cut_below(const VolumeMesh& whole, double cut) {
  VolumeMesh sub;
  std::vector<Index> to_sub(whole.points.size(), kNoIndex);
  for (const Tet& k : whole.tets) {
    double x = 0;
    for (Index v : k) x += whole.points[v][0] / 4.0;
    if (!(x < cut)) continue;
    Tet t;
    for (int i = 0; i < 4; ++i) {
      if (to_sub[k[i]] == kNoIndex) {
        to_sub[k[i]] = static_cast<Index>(sub.points.size());
        sub.points.push_back(whole.points[k[i]]);
      }
      t[i] = to_sub[k[i]];
    }
    sub.tets.push_back(t);
  }
  return fixtures::with_hull_boundary(sub);
}

/// cut_below(whole, cut) for the first cut in the list whose piece has a
/// manifold boundary.
VolumeMesh valid_piece(const VolumeMesh& whole) {
  VolumeMesh sub;
  for (double cut : {0.5, 0.45, 0.55, 0.4, 0.6}) {
    sub = cut_below(whole, cut);
    if (validate_mesh(sub).ok()) break;
  }
  return sub;
}

TEST(Refine, SubMeshKeepsItsCutFaces) {
  const VolumeMesh whole = refined_cube(0.3).to_volume_mesh();
  const VolumeMesh sub = valid_piece(whole);
  ASSERT_TRUE(validate_mesh(sub).ok());
  ASSERT_GT(sub.tets.size(), 10u);
  ASSERT_LT(sub.tets.size(), whole.tets.size());
  const SurfaceMesh surface = hull_surface(sub);
  TetMesh mesh = fixtures::build(sub);
  const SizingField field = uniform_field(surface, sub, 0.15);
  auto r = refine(mesh, field);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_TRUE(mesh.check().ok()) << mesh.check().to_string();
  EXPECT_GT(r->points_added, 5u);
  const VolumeMesh out = mesh.to_volume_mesh();
  const ValidationReport report = validate_mesh(out, &surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
  EXPECT_EQ(hull_keys(out), hull_keys(sub));
  for (std::size_t v = 0; v < sub.points.size(); ++v) EXPECT_EQ(out.points[v], sub.points[v]);
}

TEST(Refine, InsertsOnlyInsideItsBoxAndTreatsCutFacesAsOpen) {
  VolumeMesh sub = valid_piece(refined_cube(0.3).to_volume_mesh());
  ASSERT_TRUE(validate_mesh(sub).ok());
  // The piece's faces on the cut (x well above 0) are a PDR task's cut
  // through the volume (boundary id 0); the cube's own faces keep id 1.
  sub.boundary = fixtures::hull_faces(sub);
  sub.boundary_ids.clear();
  for (const Tri& f : sub.boundary) {
    bool on_cube = false;  // all three points on one side of the unit cube
    for (int i = 0; i < 3; ++i)
      for (double side : {0.0, 1.0})
        on_cube = on_cube || (sub.points[f[0]][i] == side && sub.points[f[1]][i] == side && sub.points[f[2]][i] == side);
    sub.boundary_ids.push_back(on_cube ? 1 : 0);
  }
  const SurfaceMesh surface = hull_surface(sub);
  const SizingField field = uniform_field(surface, sub, 0.1);
  const Box core{{0, 0, 0}, {0.25, 1, 1}};
  RefineOptions o;
  o.insert_within = core;
  TetMesh mesh = fixtures::build(sub);
  auto r = refine(mesh, field, o);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  ASSERT_TRUE(mesh.check().ok()) << mesh.check().to_string();
  EXPECT_GT(r->points_added, 20u);
  const VolumeMesh out = mesh.to_volume_mesh();
  EXPECT_EQ(hull_keys(out), hull_keys(sub));
  for (std::size_t v = sub.points.size(); v < out.points.size(); ++v) {
    for (int i = 0; i < 3; ++i) {
      EXPECT_GE(out.points[v][i], core.lo[i]);
      EXPECT_LE(out.points[v][i], core.hi[i]);
    }
  }
  // Without the box the same task refines the whole piece.
  TetMesh free_mesh = fixtures::build(sub);
  auto all = refine(free_mesh, field);
  ASSERT_TRUE(all.ok()) << all.status().to_string();
  EXPECT_GT(all->points_added, r->points_added);
  // With the whole piece as its box, the task places points up to the cut
  // faces, which are open to the task beyond: more than when they are walls.
  o.insert_within = Box{{0, 0, 0}, {1, 1, 1}};
  TetMesh open_cut = fixtures::build(sub);
  auto open_stats = refine(open_cut, field, o);
  ASSERT_TRUE(open_stats.ok()) << open_stats.status().to_string();
  VolumeMesh walled = sub;
  walled.boundary_ids.assign(walled.boundary.size(), 1);
  TetMesh walled_mesh = fixtures::build(walled);
  auto walled_stats = refine(walled_mesh, field, o);
  ASSERT_TRUE(walled_stats.ok()) << walled_stats.status().to_string();
  EXPECT_GT(open_stats->points_added, walled_stats->points_added);
}

/// The cross-section of the L-prism below, in (x, z), counter-clockwise: a
/// 10 x 10 square without its upper right quarter.
constexpr std::array<std::array<double, 2>, 6> kLSection{{{0, 0}, {10, 0}, {10, 5}, {5, 5}, {5, 10}, {0, 10}}};
constexpr double kLLength = 20;

/// The L-section extruded along y over [0, kLLength], every face outward:
/// caps of four triangles, each side a rectangle of two 20-long triangles.
SurfaceMesh l_prism_surface() {
  SurfaceMesh s;
  for (double y : {0.0, kLLength})
    for (const auto& [x, z] : kLSection) s.points.push_back({x, y, z});
  const Index n = kLSection.size();
  // The section is counter-clockwise seen with x right and z up, so at y = 0
  // this order faces -y; the far cap takes the reverse.
  for (const Tri& t : {Tri{0, 1, 2}, Tri{0, 2, 3}, Tri{0, 3, 5}, Tri{3, 4, 5}}) {
    s.triangles.push_back(t);
    s.triangles.push_back({t[0] + n, t[2] + n, t[1] + n});
  }
  for (Index i = 0; i < n; ++i) {
    const Index j = (i + 1) % n;
    s.triangles.push_back({i, j + n, j});
    s.triangles.push_back({i, i + n, j + n});
  }
  s.surface_ids.assign(s.triangles.size(), 1);
  s.name = "l-prism";
  return s;
}

/// Distance from p to the L-prism's boundary, for p inside it.
double l_prism_depth(const Vec3& p) {
  double d = std::min(p[1], kLLength - p[1]);
  for (std::size_t i = 0; i < kLSection.size(); ++i) {
    const auto& a = kLSection[i];
    const auto& b = kLSection[(i + 1) % kLSection.size()];
    const double ex = b[0] - a[0], ez = b[1] - a[1];
    const double t = std::clamp(((p[0] - a[0]) * ex + (p[2] - a[1]) * ez) / (ex * ex + ez * ez), 0.0, 1.0);
    d = std::min(d, std::hypot(p[0] - a[0] - t * ex, p[2] - a[1] - t * ez));
  }
  return d;
}

TEST(Refine, BoundaryRejectKeepsPointsOffTheFacesNotOffTheirPlanes) {
  // The notch's floor (z = 5, x >= 5) is two triangles 20 long; its plane runs
  // through the L's left arm (x < 5), where a point just above or below it is
  // a unit or more from the floor itself. The refiner keeps its points
  // boundary_reject_distance * h from every hull face, measured to the face
  // (closest_on_triangle): none lies closer to the boundary than that, and
  // points fill the arm across the floor's plane. (A bound by the floor's
  // plane would also pass here: the proximity walk seldom reaches the floor's
  // tets from the arm once the tets are small; on hinge it does, through the
  // long tets over its needle triangles.)
  const SurfaceMesh surface = l_prism_surface();
  auto initial = tetrahedralize(surface);
  ASSERT_TRUE(initial.ok()) << initial.status().to_string();
  const double h = 1.0;
  const SizingField field = uniform_field(surface, *initial, h);
  TetMesh mesh = fixtures::build(*initial);
  const RefineOptions options;
  auto r = refine(mesh, field, options);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  const VolumeMesh out = mesh.to_volume_mesh();
  const ValidationReport report = validate_mesh(out, &surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
  std::size_t across = 0;
  for (std::size_t v = initial->points.size(); v < out.points.size(); ++v) {
    const Vec3& p = out.points[v];
    EXPECT_GE(l_prism_depth(p), options.boundary_reject_distance * h * (1 - 1e-9)) << "point " << v;
    if (p[0] < 4.0 && std::fabs(p[2] - 5.0) < 0.4 && p[1] > 1.0 && p[1] < kLLength - 1.0) ++across;
  }
  EXPECT_GE(across, 5u);
}

TEST(Refine, RejectsBadOptions) {
  TetMesh mesh = fixtures::build(fixtures::unit_cube_mesh());
  const SizingField field =
      uniform_field(fixtures::unit_cube_surface(), fixtures::unit_cube_mesh(), 0.5);
  RefineOptions o;
  o.reject_distance = -1;
  auto r = refine(mesh, field, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(r.status().message().find("reject_distance"), std::string::npos);
  EXPECT_EQ(mesh.num_points(), 8u);
}

TEST(Refine, ReportsEveryPassToProgress) {
  TetMesh mesh = fixtures::build(fixtures::unit_cube_mesh());
  const SizingField field =
      uniform_field(fixtures::unit_cube_surface(), fixtures::unit_cube_mesh(), 0.3);
  std::vector<RefinePassStats> seen;
  auto r = refine(mesh, field, {}, [&](const RefinePassStats& p) { seen.push_back(p); });
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(seen.size(), r->passes.size());
  std::size_t added = 0;
  for (std::size_t i = 0; i < seen.size(); ++i) {
    EXPECT_EQ(seen[i].pass, static_cast<int>(i) + 1);
    EXPECT_LE(seen[i].inserted, seen[i].accepted);
    EXPECT_LE(seen[i].accepted, seen[i].candidates);
    added += seen[i].inserted;
  }
  EXPECT_EQ(added, r->points_added);
  EXPECT_EQ(mesh.num_points(), 8u + added);
  EXPECT_EQ(seen.back().tets, mesh.num_tets());
}

void expect_corpus_meshes(const char* name) {
  auto surface = read_surface(std::string(PDRMESH_CORPUS_DIR) + "/" + name + ".stl");
  ASSERT_TRUE(surface.ok()) << surface.status().to_string();
  SerialOptions o;
  o.sizing.size = surface->bounds().diagonal() / 12.0;  // coarse: keeps the test fast
  auto r = mesh_serial(*surface, o);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_GT(r->refine.points_added, 0u);
  const ValidationReport report = validate_mesh(r->mesh, &*surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
}

TEST(Pipeline, Sphere966Validates) { expect_corpus_meshes("sphere966"); }
TEST(Pipeline, ElephantValidates) { expect_corpus_meshes("elephant"); }

}  // namespace
}  // namespace pdrmesh
