// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of several regions (regions.hpp): a solid sphere (sphere966) inside a
// fluid box, both shells with outward normals, meshed by the serial and the
// parallel pipelines; the interface conforming, per-tet region ids, the
// validator's interface checks, and the round trips through the formats.
#include "pdrmesh/regions.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "pdrmesh/layered_pipeline.hpp"
#include "pdrmesh/mixed_cells.hpp"
#include "pdrmesh/pipeline.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/surface_check.hpp"
#include "pdrmesh/topology.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"
#include "test_fixtures.hpp"

namespace pdrmesh {
namespace {

/// Appends the box [-a, a]^3 with n x n quads per face, outward, surface id `id`.
void add_box(SurfaceMesh& s, double a, int n, int id) {
  std::map<std::array<int, 3>, Index> at;  // grid coordinates -> point
  const auto point = [&](int i, int j, int k) {
    const auto [it, fresh] = at.try_emplace({i, j, k}, static_cast<Index>(s.points.size()));
    if (fresh) s.points.push_back({-a + 2 * a * i / n, -a + 2 * a * j / n, -a + 2 * a * k / n});
    return it->second;
  };
  // Face (axis, side): the grid (u, v) of the other two axes, ordered so that
  // u x v points along the outward normal.
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      const int u_axis = (axis + 1) % 3, v_axis = (axis + 2) % 3;
      for (int u = 0; u < n; ++u) {
        for (int v = 0; v < n; ++v) {
          const auto corner = [&](int du, int dv) {
            std::array<int, 3> g{};
            g[axis] = side * n;
            g[u_axis] = u + du;
            g[v_axis] = v + dv;
            return point(g[0], g[1], g[2]);
          };
          Index q[4] = {corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)};
          if (side == 0) std::swap(q[1], q[3]);
          s.triangles.push_back({q[0], q[1], q[2]});
          s.triangles.push_back({q[0], q[2], q[3]});
          s.surface_ids.push_back(id);
          s.surface_ids.push_back(id);
        }
      }
    }
  }
}

/// sphere966 (radius about 10, id 2 "body") inside the box [-20, 20]^3 (id 1 "fluid").
SurfaceMesh sphere_in_box() {
  SurfaceMesh s;
  add_box(s, 20, 4, 1);
  const SurfaceMesh sphere = fixtures::corpus_surface("sphere966");
  const auto offset = static_cast<Index>(s.points.size());
  s.points.insert(s.points.end(), sphere.points.begin(), sphere.points.end());
  for (const Tri& t : sphere.triangles) {
    s.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
    s.surface_ids.push_back(2);
  }
  s.surface_names = {{1, "fluid"}, {2, "body"}};
  s.name = "sphere_in_box";
  return s;
}

double region_volume(const VolumeMesh& m, int region) {
  double v = 0;
  for (std::size_t t = 0; t < m.tets.size(); ++t)
    if (m.tet_regions[t] == region)
      v += signed_volume(m.points[m.tets[t][0]], m.points[m.tets[t][1]], m.points[m.tets[t][2]], m.points[m.tets[t][3]]);
  return v;
}

/// Checks a two-region mesh of sphere_in_box(): valid against the surface,
/// both regions present and filling their shells, every sphere triangle a
/// face of one tet of each region.
void expect_two_regions(const VolumeMesh& m, const SurfaceMesh& s) {
  const ValidationReport v = validate_mesh(m, &s);
  ASSERT_TRUE(v.ok()) << format_validation(v);
  EXPECT_EQ(v.regions, 2u);
  const auto sphere_triangles = static_cast<std::size_t>(std::count(s.surface_ids.begin(), s.surface_ids.end(), 2));
  EXPECT_EQ(v.interface_faces, sphere_triangles);
  EXPECT_EQ(v.boundary_faces, s.triangles.size() - sphere_triangles);
  ASSERT_EQ(m.tet_regions.size(), m.tets.size());
  EXPECT_EQ(m.region_names, (std::map<int, std::string>{{1, "fluid"}, {2, "body"}}));
  // Which regions hold each face, by its sorted points.
  std::map<Tri, std::vector<int>> sides;
  for (std::size_t t = 0; t < m.tets.size(); ++t)
    for (int f = 0; f < 4; ++f) sides[topo::sorted_key(topo::face_of(m.tets[t], f))].push_back(m.tet_regions[t]);
  std::size_t interfaces = 0;
  for (std::size_t f = 0; f < m.boundary.size(); ++f) {
    const std::vector<int>& r = sides[topo::sorted_key(m.boundary[f])];
    if (m.boundary_ids[f] == 2) {
      EXPECT_EQ(r.size(), 2u);
      EXPECT_EQ(std::min(r[0], r[1]), 1);
      EXPECT_EQ(std::max(r[0], r[1]), 2);
      ++interfaces;
    } else {
      EXPECT_EQ(r, std::vector<int>{1});
    }
  }
  EXPECT_EQ(interfaces, sphere_triangles);
  // The solid region fills the sphere, the fluid the rest of the box.
  SurfaceMesh sphere = fixtures::corpus_surface("sphere966");
  const double inner = enclosed_volume(sphere);
  EXPECT_NEAR(region_volume(m, 2), inner, 1e-9 * inner);
  EXPECT_NEAR(region_volume(m, 1), 64000 - inner, 1e-9 * 64000);
}

/// mesh_serial of sphere_in_box(), made once for the tests that read it.
const SerialResult* serial_mesh() {
  static const Result<SerialResult> r = mesh_serial(sphere_in_box(), SerialOptions{});
  if (!r.ok()) ADD_FAILURE() << r.status().to_string();
  return r.ok() ? &*r : nullptr;
}

/// Writes m in each format that holds regions into dir, reads it back and
/// checks the tets' regions and that it validates against s; then
/// check(suffix, back, report) for what a test checks besides.
template <class Check>
void round_trip_region_formats(const VolumeMesh& m, const SurfaceMesh& s, const std::filesystem::path& dir,
                               Check&& check) {
  for (const std::string suffix : {".vtu", ".msh", ".mesh", ".meshb"}) {
    const auto path = dir / ("m" + suffix);
    ASSERT_TRUE(write_volume(m, path.string()).ok()) << suffix;
    Result<VolumeMesh> back = read_volume(path.string());
    ASSERT_TRUE(back.ok()) << suffix << ": " << back.status().to_string();
    EXPECT_EQ(back->tet_regions, m.tet_regions) << suffix;
    const ValidationReport v = validate_mesh(*back, &s);
    EXPECT_TRUE(v.ok()) << suffix << "\n" << format_validation(v);
    check(suffix, *back, v);
  }
}

TEST(Regions, NestedShellsOfOneOrientationAreTwoRegions) {
  const SurfaceMesh s = sphere_in_box();
  const SurfaceReport report = check_surface(s);
  ASSERT_TRUE(report.meshable()) << format_report(report, s.name);
  Result<std::vector<SurfaceRegion>> regions = surface_regions(s, report);
  ASSERT_TRUE(regions.ok()) << regions.status().to_string();
  ASSERT_EQ(regions->size(), 2u);
  const SurfaceRegion& fluid = (*regions)[0];
  const SurfaceRegion& body = (*regions)[1];
  EXPECT_EQ(fluid.id, 1);
  EXPECT_EQ(fluid.name, "fluid");
  EXPECT_EQ(body.id, 2);
  EXPECT_EQ(body.name, "body");
  // The fluid's domain: the box, then the sphere reversed (a cavity of it).
  EXPECT_EQ(fluid.domain.triangles.size(), s.triangles.size());
  EXPECT_EQ(body.domain.triangles.size(), 1848u);  // the sphere alone
  const SurfaceReport fr = check_surface(fluid.domain);
  EXPECT_TRUE(fr.meshable()) << format_report(fr, "fluid domain");
  ASSERT_EQ(fr.components.size(), 2u);
  EXPECT_LT(fr.components[1].volume, 0);  // the sphere, now a cavity
  const SurfaceReport br = check_surface(body.domain);
  EXPECT_TRUE(br.meshable()) << format_report(br, "body domain");
  // The same without a report, and none for one shell or a cavity.
  Result<std::vector<SurfaceRegion>> again = surface_regions(s);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->size(), 2u);
  Result<std::vector<SurfaceRegion>> one = surface_regions(fixtures::corpus_surface("sphere966"));
  ASSERT_TRUE(one.ok());
  EXPECT_TRUE(one->empty());
  SurfaceMesh cavity = fluid.domain;
  Result<std::vector<SurfaceRegion>> none = surface_regions(cavity);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

TEST(Regions, TheSpacingIsTheSameOnBothSidesOfTheInterface) {
  const SurfaceMesh s = sphere_in_box();
  Result<std::vector<SurfaceRegion>> regions = surface_regions(s);
  ASSERT_TRUE(regions.ok() && regions->size() == 2u);
  // h at every domain point, by input point: the sphere's points are in both.
  std::map<Index, std::vector<double>> h;
  for (const SurfaceRegion& r : *regions) {
    Result<std::vector<double>> values = SizingField::surface_values(r.domain, SizingOptions{});
    ASSERT_TRUE(values.ok()) << values.status().to_string();
    for (std::size_t i = 0; i < values->size(); ++i) h[r.input_points[i]].push_back((*values)[i]);
  }
  std::size_t shared = 0;
  for (const auto& [point, values] : h) {
    if (values.size() != 2) continue;
    ++shared;
    EXPECT_EQ(values[0], values[1]) << "input point " << point;
  }
  EXPECT_EQ(shared, 926u);  // every sphere point
}

TEST(Regions, SerialMeshHasAConformingInterface) {
  const SurfaceMesh s = sphere_in_box();
  const SerialResult* r = serial_mesh();
  ASSERT_NE(r, nullptr);
  expect_two_regions(r->mesh, s);

  // The validator sees a broken interface: regions erased, or the interface
  // missing from the listed boundary.
  VolumeMesh one = r->mesh;
  std::fill(one.tet_regions.begin(), one.tet_regions.end(), 1);
  EXPECT_FALSE(validate_mesh(one, &s).ok());
  VolumeMesh unlisted = r->mesh;
  unlisted.boundary.clear();
  unlisted.boundary_ids.clear();
  for (std::size_t f = 0; f < r->mesh.boundary.size(); ++f) {
    if (r->mesh.boundary_ids[f] == 2) continue;
    unlisted.boundary.push_back(r->mesh.boundary[f]);
    unlisted.boundary_ids.push_back(r->mesh.boundary_ids[f]);
  }
  const ValidationReport u = validate_mesh(unlisted, &s);
  EXPECT_FALSE(u.ok());
  EXPECT_NE(format_validation(u).find("between two regions"), std::string::npos) << format_validation(u);
}

TEST(Regions, ParallelMeshIsTheSameForOneAndTwoWorkers) {
  const SurfaceMesh s = sphere_in_box();
  ParallelOptions o;
  o.pdr.depth = 1;  // leaf tasks even at this size
  o.pdr.workers = 1;
  Result<ParallelResult> one = mesh_parallel(s, o);
  ASSERT_TRUE(one.ok()) << one.status().to_string();
  expect_two_regions(one->mesh, s);
  EXPECT_GT(one->profile.leaf_count, 2u);
  o.pdr.workers = 2;
  Result<ParallelResult> two = mesh_parallel(s, o);
  ASSERT_TRUE(two.ok()) << two.status().to_string();
  EXPECT_EQ(one->mesh.points, two->mesh.points);
  EXPECT_EQ(one->mesh.tets, two->mesh.tets);
  EXPECT_EQ(one->mesh.tet_regions, two->mesh.tet_regions);
  EXPECT_EQ(one->mesh.boundary, two->mesh.boundary);
  EXPECT_EQ(one->mesh.boundary_ids, two->mesh.boundary_ids);
  // A checkpointed run cannot resume across regions.
  PdrCheckpoint c;
  o.pdr.resume = &c;
  EXPECT_FALSE(mesh_parallel(s, o).ok());
}

/// Five layers, the first 0.05 high, on the sphere (id 2) on the fluid's side.
LayerOptions fluid_layers() {
  LayerOptions o;
  o.layers = 5;
  o.first_height = 0.05;
  o.walls = {2};
  o.regions = {"fluid"};
  return o;
}

/// The volume of region `region`'s tets and prisms.
double cells_volume(const VolumeMesh& m, int region) {
  double v = region_volume(m, region);
  for (std::size_t c = 0; c < m.prisms.size(); ++c)
    if (m.prism_regions[c] == region)
      for (const Tet& t : prism_tets(m.prisms[c]))
        v += signed_volume(m.points[t[0]], m.points[t[1]], m.points[t[2]], m.points[t[3]]);
  return v;
}

TEST(Regions, LayersGrowOnTheSideOfTheRegionsNamedAndTheMeshValidates) {
  const SurfaceMesh s = sphere_in_box();
  SerialOptions so;
  so.sizing.growth = 1.2;
  Result<LayeredResult> r = mesh_serial_layered(s, fluid_layers(), so);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  const VolumeMesh& m = r->mesh;
  const ValidationReport v = validate_mesh(m, &s);
  ASSERT_TRUE(v.ok()) << format_validation(v);
  EXPECT_EQ(v.regions, 2u);
  EXPECT_EQ(v.interface_faces, 1848u);
  ASSERT_EQ(m.prisms.size(), 5u * 1848u);
  ASSERT_EQ(m.prism_regions.size(), m.prisms.size());
  EXPECT_TRUE(std::all_of(m.prism_regions.begin(), m.prism_regions.end(), [](int id) { return id == 1; }));
  EXPECT_EQ(r->full_faces, 1848u);
  // Into the fluid: every layer point lies outside the sphere.
  const SurfaceMesh sphere = fixtures::corpus_surface("sphere966");
  double radius = 0;
  for (const Vec3& x : sphere.points) radius = std::max(radius, norm(x));
  for (const Prism& p : m.prisms)
    for (int i = 3; i < 6; ++i) EXPECT_GT(norm(m.points[p[i]]), radius);
  // Each region fills its shells: the body its tets, the fluid tets and prisms.
  const double inner = enclosed_volume(sphere);
  EXPECT_NEAR(cells_volume(m, 2), inner, 1e-9 * inner);
  EXPECT_NEAR(cells_volume(m, 1), 64000 - inner, 1e-9 * 64000);
  // The formats that hold regions keep the prisms' too.
  const auto dir = std::filesystem::temp_directory_path() / ("pdrmesh_layer_regions_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  round_trip_region_formats(m, s, dir, [&](const std::string& suffix, const VolumeMesh& back, const ValidationReport&) {
    EXPECT_EQ(back.prisms, m.prisms) << suffix;
    EXPECT_EQ(back.prism_regions, m.prism_regions) << suffix;
  });
  std::filesystem::remove_all(dir);
}

TEST(Regions, ParallelLayersAreTheSerialOnesAndTheFillIsTheSameForAnyWorkers) {
  const SurfaceMesh s = sphere_in_box();
  SerialOptions so;
  so.sizing.growth = 1.2;
  Result<LayeredResult> serial = mesh_serial_layered(s, fluid_layers(), so);
  ASSERT_TRUE(serial.ok()) << serial.status().to_string();
  ParallelOptions o;
  o.sizing.growth = 1.2;
  o.pdr.depth = 1;
  o.pdr.workers = 1;
  Result<LayeredParallelResult> one = mesh_parallel_layered(s, fluid_layers(), o);
  ASSERT_TRUE(one.ok()) << one.status().to_string();
  const VolumeMesh& m = one->layered.mesh;
  const ValidationReport v = validate_mesh(m, &s);
  ASSERT_TRUE(v.ok()) << format_validation(v);
  EXPECT_EQ(v.regions, 2u);
  // Byte-identical layers: the same prisms on the same points.
  ASSERT_EQ(m.prisms, serial->mesh.prisms);
  EXPECT_EQ(m.prism_regions, serial->mesh.prism_regions);
  for (const Prism& p : m.prisms)
    for (Index i : p) ASSERT_EQ(m.points[i], serial->mesh.points[i]);
  o.pdr.workers = 2;
  Result<LayeredParallelResult> two = mesh_parallel_layered(s, fluid_layers(), o);
  ASSERT_TRUE(two.ok()) << two.status().to_string();
  EXPECT_EQ(two->layered.mesh.points, m.points);
  EXPECT_EQ(two->layered.mesh.tets, m.tets);
  EXPECT_EQ(two->layered.mesh.tet_regions, m.tet_regions);
  // As mesh_parallel, it cannot resume a surface of several regions from a checkpoint.
  PdrCheckpoint c;
  o.pdr.resume = &c;
  EXPECT_FALSE(mesh_parallel_layered(s, fluid_layers(), o).ok());
}

TEST(Regions, LayersRefuseToGuessTheSideOfAnInterface) {
  const SurfaceMesh s = sphere_in_box();
  LayerOptions o = fluid_layers();
  o.regions = {};
  auto r = mesh_serial_layered(s, o, SerialOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(r.status().message().find("2 regions, fluid (1), body (2)"), std::string::npos) << r.status().message();
  EXPECT_NE(r.status().message().find("--layers-in"), std::string::npos) << r.status().message();
  o.regions = {"air"};
  r = mesh_serial_layered(s, o, SerialOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("air names no region"), std::string::npos) << r.status().message();
  o.regions = {"body"};  // the body's side of the sphere is its outer shell, but the walls are the box's
  o.walls = {1};
  r = mesh_serial_layered(s, o, SerialOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("region body (2) of sphere_in_box has none of the walls"), std::string::npos)
      << r.status().message();
  o.walls = {2};
  o.regions = {"2", "3"};  // ids: the body's, then none
  r = mesh_serial_layered(s, o, SerialOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("3 names no region"), std::string::npos) << r.status().message();
  // A surface of one region takes no region names.
  o = fluid_layers();
  r = mesh_serial_layered(fixtures::corpus_surface("sphere966"), o, SerialOptions{});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("one region"), std::string::npos) << r.status().message();
}

TEST(Regions, FormatsKeepTheRegions) {
  const SurfaceMesh s = sphere_in_box();
  const SerialResult* r = serial_mesh();
  ASSERT_NE(r, nullptr);
  const VolumeMesh& m = r->mesh;
  const auto dir = std::filesystem::temp_directory_path() / ("pdrmesh_regions_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  round_trip_region_formats(m, s, dir, [&](const std::string& suffix, const VolumeMesh& back, const ValidationReport& v) {
    if (suffix == ".vtu" || suffix == ".msh") {
      EXPECT_EQ(back.region_names, m.region_names) << suffix;
    }
    EXPECT_EQ(v.interface_faces, 1848u) << suffix;
  });
  // OpenFOAM: the sphere is internal faces, the regions cellZones by name.
  const auto foam = dir / "case" / "constant" / "polyMesh";
  ASSERT_TRUE(write_volume(m, foam.string()).ok());
  std::ifstream zones(foam / "cellZones");
  std::stringstream text;
  text << zones.rdbuf();
  EXPECT_NE(text.str().find("    fluid\n"), std::string::npos);
  EXPECT_NE(text.str().find("    body\n"), std::string::npos);
  std::ifstream boundary(foam / "boundary");
  std::stringstream patches;
  patches << boundary.rdbuf();
  EXPECT_NE(patches.str().find("fluid"), std::string::npos);
  EXPECT_EQ(patches.str().find("body"), std::string::npos) << "the interface is no patch";
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace pdrmesh
