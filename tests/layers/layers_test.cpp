// SPDX-License-Identifier: AGPL-3.0-or-later
// Prism layers (layers.hpp) and the layered serial pipeline (layered_pipeline.hpp):
// layer counts, validity by exact predicates, conserved volume, output and read-back.
#include "pdrmesh/layers.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "pdrmesh/farfield.hpp"
#include "pdrmesh/layered_pipeline.hpp"
#include "pdrmesh/mixed_cells.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"
#include "test_fixtures.hpp"

namespace pdrmesh {
namespace {

using Voxel = std::array<int, 3>;

/// The surface of a union of unit voxels scaled by `scale` and moved by
/// `offset`, each voxel face cut into m x m squares of two triangles,
/// outward (or inward: the walls of a cavity), all with surface id `id`.
SurfaceMesh voxel_surface(const std::vector<Voxel>& voxels, int m, int id, double scale = 1,
                          const Vec3& offset = {0, 0, 0}, bool inward = false) {
  const std::set<Voxel> in(voxels.begin(), voxels.end());
  SurfaceMesh s;
  s.name = "voxels";
  std::map<Voxel, Index> index;  // grid point in units of 1/m -> point
  const auto point = [&](const Voxel& g) {
    const auto [it, added] = index.emplace(g, static_cast<Index>(s.points.size()));
    if (added)
      s.points.push_back({offset[0] + scale * g[0] / m, offset[1] + scale * g[1] / m, offset[2] + scale * g[2] / m});
    return it->second;
  };
  for (const Voxel& v : voxels)
    for (int a = 0; a < 3; ++a)
      for (const int side : {-1, 1}) {
        Voxel n = v;
        n[a] += side;
        if (in.count(n) > 0) continue;
        const int u = (a + 1) % 3, w = (a + 2) % 3;
        for (int i = 0; i < m; ++i)
          for (int j = 0; j < m; ++j) {
            const auto corner = [&](int di, int dj) {
              Voxel g{v[0] * m, v[1] * m, v[2] * m};
              g[a] += side > 0 ? m : 0;
              g[u] += i + di;
              g[w] += j + dj;
              return point(g);
            };
            const Index p00 = corner(0, 0), p10 = corner(1, 0), p11 = corner(1, 1), p01 = corner(0, 1);
            // (u, w, a) is right-handed: (p00, p10, p11) turns about +a.
            Tri t1{p00, p10, p11}, t2{p00, p11, p01};
            if ((side < 0) != inward) {
              std::swap(t1[1], t1[2]);
              std::swap(t2[1], t2[2]);
            }
            s.triangles.push_back(t1);
            s.triangles.push_back(t2);
            s.surface_ids.push_back(id);
            s.surface_ids.push_back(id);
          }
      }
  return s;
}

/// `a` with `b`'s points and triangles appended.
SurfaceMesh joined(SurfaceMesh a, const SurfaceMesh& b) {
  const auto base = static_cast<Index>(a.points.size());
  a.points.insert(a.points.end(), b.points.begin(), b.points.end());
  for (const Tri& t : b.triangles) a.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  a.surface_ids.insert(a.surface_ids.end(), b.surface_ids.begin(), b.surface_ids.end());
  return a;
}

LayerOptions five_layers(double first_height) {
  LayerOptions o;
  o.layers = 5;
  o.first_height = first_height;
  o.growth_ratio = 1.2;
  return o;
}

/// The layered mesh of `surface`, validated against it; a failure is reported.
LayeredResult mesh_layered(const SurfaceMesh& surface, const LayerOptions& layers) {
  SerialOptions options;
  options.sizing.growth = layers.growth_ratio > 1 ? layers.growth_ratio : 1.2;
  auto r = mesh_serial_layered(surface, layers, options);
  if (!r.ok()) {
    ADD_FAILURE() << r.status().to_string();
    return {};
  }
  const ValidationReport report = validate_mesh(r->mesh, &surface);
  EXPECT_TRUE(report.ok()) << format_validation(report);
  EXPECT_NEAR(report.volume, enclosed_volume(surface), 1e-9 * std::abs(enclosed_volume(surface)));
  return std::move(r).value();
}

std::size_t triangles_with_id(const SurfaceMesh& s, int id) {
  return static_cast<std::size_t>(std::count(s.surface_ids.begin(), s.surface_ids.end(), id));
}

std::filesystem::path temp_path(const std::string& name) {
  return std::filesystem::temp_directory_path() / fmt::format("pdrmesh_layers_{}_{}", ::getpid(), name);
}

/// Writes `mesh` in every format that reads a mixed mesh back, and checks
/// that each gives the same cells and validates against `surface`.
void expect_read_back(const VolumeMesh& mesh, const SurfaceMesh& surface) {
  for (const char* suffix : {".mesh", ".meshb", ".vtu", ".msh", ".su2", ".ugrid", ".lb8.ugrid", ".b8.ugrid"}) {
    const auto path = temp_path(std::string("out") + suffix);
    ASSERT_TRUE(write_volume(mesh, path).ok()) << suffix;
    auto back = read_volume(path);
    std::filesystem::remove(path);
    std::filesystem::remove(mapbc_path(path));
    ASSERT_TRUE(back.ok()) << suffix << ": " << back.status().to_string();
    EXPECT_EQ(back->points, mesh.points) << suffix;
    EXPECT_EQ(back->tets, mesh.tets) << suffix;
    EXPECT_EQ(back->prisms, mesh.prisms) << suffix;
    EXPECT_EQ(back->pyramids, mesh.pyramids) << suffix;
    EXPECT_EQ(back->boundary, mesh.boundary) << suffix;
    EXPECT_TRUE(validate_mesh(*back, &surface).ok()) << suffix;
  }
}

/// The sphere's layered mesh, made once for the tests that read it.
const LayeredResult& sphere_layers() {
  static const LayeredResult r = mesh_layered(fixtures::corpus_surface("sphere966"), five_layers(0.05));
  return r;
}

TEST(Layers, SphereGrowsFiveLayersOnEveryTriangle) {
  const SurfaceMesh sphere = fixtures::corpus_surface("sphere966");
  const LayeredResult& r = sphere_layers();
  EXPECT_EQ(r.mesh.prisms.size(), 5 * sphere.triangles.size());
  EXPECT_GT(r.mesh.tets.size(), 0u);
  EXPECT_EQ(r.compressed_points, 0u);  // a smooth sphere needs no compression
  EXPECT_EQ(r.full_faces, sphere.triangles.size());
  EXPECT_EQ(r.smooth_faces, sphere.triangles.size());
  EXPECT_EQ(r.smooth_full_faces, sphere.triangles.size());
  const LayerReport layers = measure_layers(r.mesh);
  EXPECT_EQ(layers.stacks, sphere.triangles.size());
  EXPECT_EQ(layers.min_layers, 5u);
  EXPECT_EQ(layers.max_layers, 5u);
  EXPECT_NEAR(layers.ratio_min, 1.2, 0.05);
  EXPECT_NEAR(layers.ratio_max, 1.2, 0.05);
}

TEST(Layers, MixedMeshIsWrittenInEveryFormatAndReadBackValid) {
  const SurfaceMesh sphere = fixtures::corpus_surface("sphere966");
  const LayeredResult& r = sphere_layers();
  {  // CGNS is written, not read
    const auto path = temp_path("out.cgns");
    EXPECT_TRUE(write_volume(r.mesh, path).ok());
    EXPECT_GT(std::filesystem::file_size(path), 0u);
    std::filesystem::remove(path);
  }
  expect_read_back(r.mesh, sphere);
}

TEST(Layers, FarfieldBodyGrowsLayersIntoTheFluidAndTheFarFieldNone) {
  const SurfaceMesh sphere = fixtures::corpus_surface("sphere966");
  FarfieldOptions far;
  far.distance = 5;
  auto domain = make_farfield(sphere, far);
  ASSERT_TRUE(domain.ok()) << domain.status().to_string();
  // The body's triangles come first in the domain, the far field's last.
  const std::size_t n = sphere.triangles.size();
  ASSERT_EQ(domain->surface.triangles.size(), n + domain->farfield_triangles);
  LayerOptions o = five_layers(0.05);
  const auto& ids = domain->surface.surface_ids;
  const std::set<int> body_ids(ids.begin(), ids.begin() + static_cast<std::ptrdiff_t>(n));
  o.walls.assign(body_ids.begin(), body_ids.end());
  const LayeredResult r = mesh_layered(domain->surface, o);
  ASSERT_EQ(r.mesh.prisms.size(), 5 * n);
  // Every first-layer prism stands on a body triangle: the reversed body's
  // triangles are the bottoms, none of the far field's.
  std::set<Tri> body, bottoms;
  for (std::size_t t = 0; t < n; ++t) body.insert(topo::sorted_key(domain->surface.triangles[t]));
  for (const Prism& p : r.mesh.prisms) bottoms.insert(topo::sorted_key(Tri{p[0], p[1], p[2]}));
  std::size_t on_body = 0;
  for (const Tri& t : bottoms) on_body += body.count(t);
  EXPECT_EQ(on_body, n) << "each body triangle carries a stack";
  for (std::size_t t = n; t < domain->surface.triangles.size(); ++t)
    EXPECT_EQ(bottoms.count(topo::sorted_key(domain->surface.triangles[t])), 0u) << "far-field triangle " << t;
  const LayerReport layers = measure_layers(r.mesh);
  EXPECT_EQ(layers.stacks, n);
  EXPECT_EQ(layers.min_layers, 5u);
  // Into the fluid: every layer point lies farther from the sphere's centre
  // than any of the sphere's own points.
  const Box box = sphere.bounds();
  const Vec3 c = 0.5 * (box.lo + box.hi);
  double radius = 0;
  for (const Vec3& x : sphere.points) radius = std::max(radius, norm(x - c));
  for (const Prism& p : r.mesh.prisms)
    for (int i = 3; i < 6; ++i) EXPECT_GT(norm(r.mesh.points[p[i]] - c), radius);
}

/// A cell's vertex centroid.
template <class Cell>
Vec3 centroid(const std::vector<Vec3>& points, const Cell& c) {
  Vec3 x{0, 0, 0};
  for (Index v : c) x = x + points[v];
  return (1.0 / static_cast<double>(c.size())) * x;
}

TEST(Layers, PolyMeshFacesOfTheMixedMeshAreTrianglesAndQuadsOutOfTheirOwners) {
  const SurfaceMesh sphere = fixtures::corpus_surface("sphere966");
  const VolumeMesh& mesh = sphere_layers().mesh;
  auto cf = mixed_cell_faces(mesh);
  ASSERT_TRUE(cf.ok()) << cf.status().to_string();
  std::vector<Vec3> centre;
  for (const Tet& t : mesh.tets) centre.push_back(centroid(mesh.points, t));
  for (const Prism& p : mesh.prisms) centre.push_back(centroid(mesh.points, p));
  std::vector<int> faces_of(centre.size(), 0);
  std::size_t quads = 0;
  for (std::size_t f = 0; f < cf->faces.size(); ++f) {
    const auto& q = cf->faces[f];
    const int k = q[3] == kNoIndex ? 3 : 4;
    quads += k == 4 ? 1 : 0;
    Vec3 normal{0, 0, 0}, mid{0, 0, 0};  // Newell's normal of the polygon
    for (int i = 0; i < k; ++i) {
      normal = normal + cross(mesh.points[q[i]], mesh.points[q[(i + 1) % k]]);
      mid = mid + (1.0 / k) * mesh.points[q[i]];
    }
    EXPECT_GT(dot(normal, mid - centre[cf->owner[f]]), 0) << "face " << f << " points out of its owner";
    ++faces_of[cf->owner[f]];
    if (f < cf->internal()) {
      EXPECT_LT(cf->owner[f], cf->neighbour[f]);
      if (f > 0) {
        EXPECT_LT(std::make_pair(cf->owner[f - 1], cf->neighbour[f - 1]),
                  std::make_pair(cf->owner[f], cf->neighbour[f]));
      }
      EXPECT_GT(dot(normal, centre[cf->neighbour[f]] - mid), 0) << "face " << f << " points into its neighbour";
      ++faces_of[cf->neighbour[f]];
    } else {
      EXPECT_EQ(k, 3) << "hull face " << f << ": the hull is the sphere's triangles";
    }
  }
  for (std::size_t c = 0; c < faces_of.size(); ++c) EXPECT_EQ(faces_of[c], c < mesh.tets.size() ? 4 : 5) << c;
  EXPECT_EQ(quads, 3 * mesh.prisms.size() / 2) << "every prism side is shared with the next stack";
  EXPECT_EQ(cf->faces.size() - cf->internal(), sphere.triangles.size());

  const auto dir = temp_path("case") / "constant" / "polyMesh";
  ASSERT_TRUE(write_volume(mesh, dir).ok());
  std::ifstream in(dir / "faces");
  std::string line;
  std::size_t quad_lines = 0, triangle_lines = 0;
  while (std::getline(in, line)) {
    quad_lines += line.rfind("4(", 0) == 0 ? 1 : 0;
    triangle_lines += line.rfind("3(", 0) == 0 ? 1 : 0;
  }
  std::filesystem::remove_all(temp_path("case"));
  EXPECT_EQ(quad_lines, quads);
  EXPECT_EQ(triangle_lines + quad_lines, cf->faces.size());
}

TEST(Layers, BoxGrowsFiveLayersAcrossItsEdgesAndCorners) {
  const SurfaceMesh box = voxel_surface({{0, 0, 0}}, 4, 1);
  const LayeredResult r = mesh_layered(box, five_layers(0.01));
  EXPECT_EQ(r.mesh.prisms.size(), 5 * box.triangles.size());
  // The corners stretch their directions so the layers keep their height.
  EXPECT_GT(r.thickness_max, r.thickness_min * 1.3);
  // Nothing compressed on a convex box; smooth are the 2 x 2 inner squares of
  // each face's 4 x 4 (a triangle with a point on an edge of the box is not).
  EXPECT_EQ(r.full_faces, box.triangles.size());
  EXPECT_EQ(r.smooth_faces, 6u * 8u);
  EXPECT_EQ(r.smooth_full_faces, 6u * 8u);
}

TEST(Layers, LShapedDuctStopsItsStacksWhereLayersMeet) {
  // Thick layers inside an L: they meet at the concave edges and corners and
  // fan out at the re-entrant edge. Stacks there are compressed, and where
  // half their thickness is too much they stop: pyramids and tets close the
  // layers above them, every cell positive and conforming (validated).
  const SurfaceMesh l = voxel_surface({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, 3, 1);
  LayerOptions o = five_layers(0.06);
  o.layers = 6;
  const LayeredResult r = mesh_layered(l, o);
  EXPECT_GT(r.compressed_points, r.stopped_points);
  EXPECT_GT(r.stopped_points, 0u);
  EXPECT_LT(r.full_faces, l.triangles.size());
  EXPECT_LE(r.smooth_full_faces, r.smooth_faces);
  EXPECT_LT(r.mesh.prisms.size(), 6 * l.triangles.size());
  EXPECT_GT(r.mesh.pyramids.size(), 0u);
  for (const Prism& p : r.mesh.prisms) ASSERT_TRUE(prism_positive(r.mesh.points, p));
  for (const Pyramid& p : r.mesh.pyramids) ASSERT_TRUE(pyramid_positive(r.mesh.points, p));
  const LayerReport layers = measure_layers(r.mesh);
  EXPECT_EQ(layers.stacks, l.triangles.size());
  EXPECT_LT(layers.min_layers, 6u);
  EXPECT_EQ(layers.max_layers, 6u);
  // A stopped stack keeps the first height of a stack compressed to half.
  EXPECT_GE(layers.first_height_min, 0.5 * 0.06 * (1 - 1e-9));
  // Every format holds the pyramids, and the parallel path grows the same layers.
  expect_read_back(r.mesh, l);
  ParallelOptions parallel;
  parallel.sizing.growth = 1.2;
  parallel.pdr.workers = 2;
  Result<LayeredParallelResult> p = mesh_parallel_layered(l, o, parallel);
  ASSERT_TRUE(p.ok()) << p.status().to_string();
  EXPECT_TRUE(validate_mesh(p->layered.mesh, &l).ok());
  EXPECT_EQ(p->layered.mesh.prisms, r.mesh.prisms);
  EXPECT_EQ(p->layered.mesh.pyramids, r.mesh.pyramids);
  EXPECT_EQ(p->layered.stopped_points, r.stopped_points);
}

TEST(Layers, CavityWallsGrowIntoTheVolumeAroundThem) {
  // An L-shaped body inside a box: the body is a cavity (inward triangles,
  // id 2) and alone grows layers, outward from the body into the volume.
  const SurfaceMesh outer = voxel_surface({{0, 0, 0}}, 2, 1, 6.0, {-2, -2, -2.5});
  const SurfaceMesh body = voxel_surface({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, 2, 2, 1.0, {0, 0, 0}, true);
  const SurfaceMesh s = joined(outer, body);
  LayerOptions o = five_layers(0.02);
  o.walls = {2};
  const LayeredResult r = mesh_layered(s, o);
  EXPECT_EQ(r.mesh.prisms.size(), 5 * triangles_with_id(s, 2));
  const LayerReport layers = measure_layers(r.mesh);
  EXPECT_EQ(layers.stacks, triangles_with_id(s, 2));
  EXPECT_EQ(layers.min_layers, 5u);
}

TEST(Layers, ThicknessCapCompressesTheStacksThenStopsThem) {
  const SurfaceMesh box = voxel_surface({{0, 0, 0}}, 2, 1);
  LayerOptions o = five_layers(0.05);  // 0.372 in all
  // Two thirds of the stack: compressed, all five layers, the first lower.
  o.max_thickness = 0.25;
  const LayeredResult compressed = mesh_layered(box, o);
  EXPECT_LE(compressed.thickness_max, 0.25 * 2 + 1e-12);  // along a stretched corner direction at most twice
  EXPECT_EQ(compressed.stopped_points, 0u);
  LayerReport layers = measure_layers(compressed.mesh);
  EXPECT_EQ(layers.min_layers, 5u);
  EXPECT_LT(layers.first_height_min, 0.05);
  // Less than half of it: the heights of half the stack, as many layers as fit.
  o.max_thickness = 0.1;
  const LayeredResult stopped = mesh_layered(box, o);
  EXPECT_LE(stopped.thickness_max, 0.1 * 2 + 1e-12);
  EXPECT_EQ(stopped.stopped_points, stopped.wall_points);
  layers = measure_layers(stopped.mesh);
  EXPECT_EQ(layers.min_layers, 3u);  // 0.025, 0.055, 0.091 of 0.1
  EXPECT_EQ(layers.max_layers, 3u);
  EXPECT_NEAR(layers.ratio_min, 1.2, 1e-6);
  EXPECT_GE(layers.first_height_min, 0.025 * (1 - 1e-9));
}

TEST(Layers, RefusesWallsThatMeetTrianglesWithoutLayers) {
  const SurfaceMesh cube = fixtures::unit_cube_surface();  // one id per face
  LayerOptions o = five_layers(0.01);
  o.walls = {1};
  const auto r = grow_layers(cube, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(r.status().message().find("surface id 1 (with layers) meets surface id"), std::string::npos)
      << r.status().message();
}

TEST(Layers, RefusesASurfaceOfSeveralRegionsWithoutTheRegionsThatGrowThem) {
  // A small box inside a big one, both outward: two regions (regions.hpp).
  const SurfaceMesh two =
      joined(voxel_surface({{0, 0, 0}}, 2, 1, 4), voxel_surface({{0, 0, 0}}, 2, 2, 1, {1.5, 1.5, 1.5}));
  auto r = mesh_serial_layered(two, five_layers(0.05), SerialOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(r.status().message().find("2 regions"), std::string::npos) << r.status().message();
  EXPECT_NE(r.status().message().find("--layers-in"), std::string::npos) << r.status().message();
}

TEST(Layers, RefusesBadOptions) {
  LayerOptions o = five_layers(0.01);
  o.layers = 0;
  EXPECT_FALSE(validate(o).ok());
  o = five_layers(-1);
  EXPECT_NE(validate(o).message().find("--first-height"), std::string::npos);
  o = five_layers(0.01);
  o.growth_ratio = 0.5;
  EXPECT_NE(validate(o).message().find("--growth-ratio"), std::string::npos);
}

TEST(Layers, RequestResolvesWallNamesAndAYplusOnTheSurface) {
  SurfaceMesh two = joined(voxel_surface({{0, 0, 0}}, 2, 1, 4), voxel_surface({{0, 0, 0}}, 2, 2, 1, {1.5, 1.5, 1.5}));
  LayerRequest r;
  r.layers = 3;
  r.first_height = 0.01;
  auto o = resolve_layers(r, two, {2});
  ASSERT_TRUE(o.ok()) << o.status().to_string();
  EXPECT_EQ(o->walls, std::vector<int>{2}) << "no names: the default walls";
  two.surface_names[1] = "hull";
  r.on = {"hull", "surface_2", "2"};
  o = resolve_layers(r, two);
  ASSERT_TRUE(o.ok()) << o.status().to_string();
  EXPECT_EQ(o->walls, (std::vector<int>{1, 2, 2})) << "a name, a default name and an id";
  r.on = {"wing"};
  o = resolve_layers(r, two);
  ASSERT_FALSE(o.ok());
  EXPECT_EQ(o.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(o.status().message().find("wing names no surface"), std::string::npos) << o.status().message();
  EXPECT_NE(o.status().message().find("hull (1)"), std::string::npos) << o.status().message();

  // A y+ on the walls' length, the longest side of their bounding box; or on a reference length.
  r.on = {"hull"};
  r.yplus = true;
  r.first_height = 1;
  r.reynolds = 1e6;
  o = resolve_layers(r, two);
  ASSERT_TRUE(o.ok()) << o.status().to_string();
  double longest = 0;
  Box box;
  for (std::size_t t = 0; t < two.triangles.size(); ++t)
    if (two.surface_ids[t] == 1)
      for (Index v : two.triangles[t]) box.add(two.points[v]);
  for (int k = 0; k < 3; ++k) longest = std::max(longest, box.hi[k] - box.lo[k]);
  EXPECT_DOUBLE_EQ(o->first_height, *first_height_for_yplus(1, 1e6, longest));
  r.reference_length = 10;
  EXPECT_DOUBLE_EQ(resolve_layers(r, two)->first_height, *first_height_for_yplus(1, 1e6, 10));

  // The values alone, named.
  LayerRequest bad = r;
  bad.reynolds = 0;
  EXPECT_NE(validate(bad).message().find("--reynolds"), std::string::npos) << validate(bad).message();
  bad = r;
  bad.yplus = false;
  EXPECT_NE(validate(bad).message().find("only with a y+"), std::string::npos) << validate(bad).message();
  bad = r;
  bad.layers = 1001;
  EXPECT_NE(validate(bad).message().find("--layers"), std::string::npos) << validate(bad).message();
}

TEST(Layers, FirstHeightFromYplusFollowsTheFlatPlateSkinFriction) {
  // Re 1e6 on a length of 1: Cf = 0.026 / 1e6^(1/7) = 3.6126e-3, so a y+ of 1
  // is 1 / (1e6 sqrt(Cf / 2)) = 2.3529e-5.
  const Result<double> h = first_height_for_yplus(1, 1e6, 1);
  ASSERT_TRUE(h.ok()) << h.status().to_string();
  EXPECT_NEAR(*h, 2.3529e-5, 1e-9);
  EXPECT_NEAR(*first_height_for_yplus(30, 1e6, 1), 30 * *h, 1e-12);   // linear in y+
  EXPECT_NEAR(*first_height_for_yplus(1, 1e6, 20), 20 * *h, 1e-12);   // and in the length
  EXPECT_LT(*first_height_for_yplus(1, 1e7, 1), *h / 5);               // thinner at a higher Re
  for (const auto& [yplus, re, length, named] :
       std::vector<std::tuple<double, double, double, std::string>>{{0, 1e6, 1, "yplus"},
                                                                    {1, -1, 1, "--reynolds"},
                                                                    {1, std::nan(""), 1, "--reynolds"},
                                                                    {1, 1e6, 0, "length"}}) {
    const Result<double> bad = first_height_for_yplus(yplus, re, length);
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(bad.status().message().find(named), std::string::npos) << bad.status().message();
  }
}

TEST(Layers, ValidatorCatchesAnInvertedPrism) {
  const SurfaceMesh box = voxel_surface({{0, 0, 0}}, 2, 1);
  LayeredResult r = mesh_layered(box, five_layers(0.01));
  ASSERT_FALSE(r.mesh.prisms.empty());
  Prism& p = r.mesh.prisms.front();
  std::swap(p[1], p[2]);  // bottom and top both reversed: the prism turns inside out
  std::swap(p[4], p[5]);
  const ValidationReport report = validate_mesh(r.mesh, &box);
  EXPECT_FALSE(report.ok());
  EXPECT_NE(format_validation(report).find("prism 0 is inverted"), std::string::npos) << format_validation(report);
}

}  // namespace
}  // namespace pdrmesh
