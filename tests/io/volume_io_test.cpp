// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of volume mesh output and input: exact round trips in every format,
// malformed files per reader, suffix detection.
#include "pdrmesh/volume_io.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "pdrmesh/quality.hpp"

namespace pdrmesh {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------- fixtures

/// An n x n x n grid of unit-cube cells, each split into 6 Kuhn tets turned
/// positive, with the outward boundary triangles (ids 1..6 by cube face:
/// x=0, x=n, y=0, y=n, z=0, z=n) sorted by id, regions alternating 1, 2.
VolumeMesh grid_mesh(int n) {
  VolumeMesh m;
  const auto id = [n](int i, int j, int k) { return static_cast<Index>(i + (n + 1) * (j + (n + 1) * k)); };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) m.points.push_back({double(i), double(j), double(k)});
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  std::vector<std::pair<int, Tri>> faces;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const auto& perm : perms) {
          int c[3] = {i, j, k};
          Tet t{};
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[perm[s]];
            t[static_cast<std::size_t>(s) + 1] = id(c[0], c[1], c[2]);
          }
          const auto& p = m.points;
          if (signed_volume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]) < 0) std::swap(t[2], t[3]);
          m.tets.push_back(t);
          for (int opp = 0; opp < 4; ++opp) {
            Tri f{};
            int w = 0;
            for (int v = 0; v < 4; ++v)
              if (v != opp) f[static_cast<std::size_t>(w++)] = t[static_cast<std::size_t>(v)];
            for (int axis = 0; axis < 3; ++axis)
              for (int side = 0; side < 2; ++side) {
                const double plane = side == 0 ? 0.0 : double(n);
                if (p[f[0]][axis] == plane && p[f[1]][axis] == plane && p[f[2]][axis] == plane) {
                  // Outward: the opposite vertex lies below the face.
                  if (signed_volume(p[f[0]], p[f[1]], p[f[2]], p[t[static_cast<std::size_t>(opp)]]) > 0)
                    std::swap(f[1], f[2]);
                  faces.push_back({1 + 2 * axis + side, f});
                }
              }
          }
        }
  std::stable_sort(faces.begin(), faces.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [fid, f] : faces) {
    m.boundary.push_back(f);
    m.boundary_ids.push_back(fid);
  }
  for (std::size_t t = 0; t < m.tets.size(); ++t) m.tet_regions.push_back(1 + static_cast<int>(t % 2));
  return m;
}

/// Coordinates that shortest-round-trip printing and binary must keep exactly.
VolumeMesh awkward_mesh() {
  VolumeMesh m;
  m.points = {{1e-300, -0.0, 0.1},
              {1.0 / 3.0, 1e300, -2.5e-310},
              {0.30000000000000004, -1e300, 123456789.123456789},
              {5e-324, 1.0 / 7.0, -0.0},
              {-1.7976931348623157e308, 2.2250738585072014e-308, 1e-5},
              {3, 4, 5}};
  m.tets = {{0, 1, 2, 3}, {1, 2, 3, 4}, {2, 3, 4, 5}};
  m.boundary = {{0, 1, 2}, {3, 4, 5}, {1, 2, 5}};
  m.boundary_ids = {-3, 0, 2147483647};
  m.tet_regions = {5, -1, 5};
  return m;
}

struct FormatCase {
  const char* suffix;
  bool holds_regions;
};
constexpr FormatCase kFormats[] = {{".mesh", true},  {".meshb", true},     {".vtu", true},
                                   {".ugrid", false}, {".lb8.ugrid", false}, {".b8.ugrid", false},
                                   {".msh", true},   {".su2", false}};

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

void expect_same_mesh(const VolumeMesh& want, const VolumeMesh& got, bool regions) {
  ASSERT_EQ(want.points.size(), got.points.size());
  for (std::size_t i = 0; i < want.points.size(); ++i)
    for (int k = 0; k < 3; ++k)
      ASSERT_TRUE(same_bits(want.points[i][k], got.points[i][k]))
          << "point " << i << " coordinate " << k << ": " << fmt::format("{} vs {}", want.points[i][k], got.points[i][k]);
  EXPECT_EQ(want.tets, got.tets);
  EXPECT_EQ(want.boundary, got.boundary);
  EXPECT_EQ(want.boundary_ids, got.boundary_ids);
  if (regions) {
    EXPECT_EQ(want.tet_regions, got.tet_regions);
  } else {
    EXPECT_TRUE(got.tet_regions.empty());
  }
}

class VolumeIo : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / fmt::format("pdrmesh_volio_{}_{}", info->name(), getpid());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path path(const std::string& name) const { return dir_ / name; }
  fs::path write_text(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
    return path(name);
  }
  std::string slurp(const fs::path& p) const {
    std::ifstream f(p, std::ios::binary);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  }
  /// Reads `text` saved as `name`; expects `code` and every part of `where` in the message.
  void expect_error(const std::string& name, const std::string& text, StatusCode code,
                    std::initializer_list<std::string_view> where) {
    const auto r = read_volume(write_text(name, text));
    ASSERT_FALSE(r.ok()) << name << " was accepted";
    EXPECT_EQ(r.status().code(), code) << r.status().to_string();
    for (std::string_view w : where)
      EXPECT_NE(r.status().message().find(w), std::string::npos) << "'" << w << "' not in: " << r.status().to_string();
  }

  fs::path dir_;
};

// ---------------------------------------------------------------- round trips

TEST_F(VolumeIo, CubeFixtureIsValid) {
  const VolumeMesh m = grid_mesh(1);
  ASSERT_EQ(m.tets.size(), 6u);
  ASSERT_EQ(m.boundary.size(), 12u);
  for (const Tet& t : m.tets) EXPECT_GT(signed_volume(m.points[t[0]], m.points[t[1]], m.points[t[2]], m.points[t[3]]), 0);
  // Outward: every boundary normal points away from the cube centre.
  const Vec3 centre{0.5, 0.5, 0.5};
  for (const Tri& f : m.boundary)
    EXPECT_LT(signed_volume(m.points[f[0]], m.points[f[1]], m.points[f[2]], centre), 0);
  for (int id = 1; id <= 6; ++id) EXPECT_EQ(std::count(m.boundary_ids.begin(), m.boundary_ids.end(), id), 2);
}

TEST_F(VolumeIo, RoundTripsCubeInEveryFormat) {
  const VolumeMesh cube = grid_mesh(1);
  for (const FormatCase& f : kFormats) {
    SCOPED_TRACE(f.suffix);
    const fs::path p = path(std::string("cube") + f.suffix);
    ASSERT_TRUE(write_volume(cube, p).ok());
    const auto r = read_volume(p);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    expect_same_mesh(cube, *r, f.holds_regions);
  }
}

TEST_F(VolumeIo, RoundTripsAwkwardCoordinatesBitExact) {
  const VolumeMesh m = awkward_mesh();
  for (const FormatCase& f : kFormats) {
    SCOPED_TRACE(f.suffix);
    const fs::path p = path(std::string("awkward") + f.suffix);
    const Status s = write_volume(m, p);
    ASSERT_TRUE(s.ok()) << s.to_string();
    const auto r = read_volume(p);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    expect_same_mesh(m, *r, f.holds_regions);
  }
}

TEST_F(VolumeIo, RoundTripsGridWithInterleavedRegionsAndNoRegions) {
  VolumeMesh m = grid_mesh(4);
  for (const FormatCase& f : kFormats) {
    SCOPED_TRACE(f.suffix);
    const fs::path p = path(std::string("grid") + f.suffix);
    ASSERT_TRUE(write_volume(m, p).ok());
    const auto r = read_volume(p);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    expect_same_mesh(m, *r, f.holds_regions);
  }
  m.tet_regions.clear();
  for (const FormatCase& f : kFormats) {
    SCOPED_TRACE(std::string("no regions ") + f.suffix);
    const fs::path p = path(std::string("plain") + f.suffix);
    ASSERT_TRUE(write_volume(m, p).ok());
    const auto r = read_volume(p);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    expect_same_mesh(m, *r, true);  // empty stays empty everywhere
  }
}

TEST_F(VolumeIo, RoundTripsPrismsAndPyramidsInEveryFormat) {
  // Cell arrays only (a format keeps what it is given; validate_mesh judges
  // conformity): the cube's tets and boundary, and cells on its corners whose
  // vertices are all different, so that a permuted vertex order shows.
  VolumeMesh m = grid_mesh(1);
  m.tet_regions.clear();
  m.prisms = {{0, 1, 2, 4, 5, 6}, {7, 3, 1, 6, 2, 0}};
  m.pyramids = {{0, 1, 3, 2, 4}, {5, 7, 6, 4, 3}};
  for (const FormatCase& f : kFormats) {
    SCOPED_TRACE(f.suffix);
    const fs::path p = path(std::string("mixed") + f.suffix);
    ASSERT_TRUE(write_volume(m, p).ok());
    const auto r = read_volume(p);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    expect_same_mesh(m, *r, false);
    EXPECT_EQ(r->prisms, m.prisms);
    EXPECT_EQ(r->pyramids, m.pyramids);
  }
}

TEST_F(VolumeIo, RegionsOfPrismsAndPyramidsRoundTripEvenWithoutTets) {
  VolumeMesh m = grid_mesh(1);
  m.tet_regions.assign(m.tets.size(), 2);
  m.tet_regions[0] = 5;
  m.prisms = {{0, 1, 2, 4, 5, 6}, {7, 3, 1, 6, 2, 0}};
  m.prism_regions = {5, 7};
  m.pyramids = {{0, 1, 3, 2, 4}};
  m.pyramid_regions = {2};
  VolumeMesh no_tets = m;  // regions on the prisms and pyramids alone
  no_tets.tets.clear();
  no_tets.tet_regions.clear();
  for (const VolumeMesh* mesh : {&m, &no_tets}) {
    for (const char* suffix : {".mesh", ".meshb", ".vtu", ".msh"}) {
      SCOPED_TRACE(std::string(suffix) + (mesh == &m ? " with tets" : " without tets"));
      const fs::path p = path(std::string("regions") + suffix);
      ASSERT_TRUE(write_volume(*mesh, p).ok());
      const auto r = read_volume(p);
      ASSERT_TRUE(r.ok()) << r.status().to_string();
      EXPECT_EQ(r->tet_regions, mesh->tet_regions);
      EXPECT_EQ(r->prism_regions, mesh->prism_regions);
      EXPECT_EQ(r->pyramid_regions, mesh->pyramid_regions);
    }
  }
  // Regions on some kinds of cell and not on others cannot be written.
  VolumeMesh half = m;
  half.prism_regions.clear();
  const Status s = write_volume(half, path("half.meshb"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("but 6, 0 and 1 regions"), std::string::npos) << s.message();
}

TEST_F(VolumeIo, GmshRestoresElementOrderAcrossEntityBlocks) {
  // Boundary ids interleaved: Gmsh groups them by entity, element tags restore the order.
  VolumeMesh m = grid_mesh(1);
  std::reverse(m.boundary.begin(), m.boundary.end());
  for (std::size_t i = 0; i < m.boundary_ids.size(); ++i) m.boundary_ids[i] = 1 + static_cast<int>(i % 3);
  ASSERT_TRUE(write_volume(m, path("m.msh")).ok());
  const auto r = read_volume(path("m.msh"));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  expect_same_mesh(m, *r, true);
}

TEST_F(VolumeIo, Su2GroupsBoundaryByMarkerInIdOrder) {
  VolumeMesh m = grid_mesh(1);
  for (std::size_t i = 0; i < m.boundary_ids.size(); ++i) m.boundary_ids[i] = static_cast<int>(i % 2 == 0 ? 9 : 4);
  ASSERT_TRUE(write_volume(m, path("m.su2")).ok());
  const auto r = read_volume(path("m.su2"));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  std::vector<std::size_t> order(m.boundary.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](auto a, auto b) { return m.boundary_ids[a] < m.boundary_ids[b]; });
  ASSERT_EQ(r->boundary.size(), m.boundary.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    EXPECT_EQ(r->boundary[i], m.boundary[order[i]]);
    EXPECT_EQ(r->boundary_ids[i], m.boundary_ids[order[i]]);
  }
}

TEST_F(VolumeIo, VtuCarriesMinDihedralPerTetAndTheirTetsForTriangles) {
  const VolumeMesh m = grid_mesh(1);
  ASSERT_TRUE(write_volume(m, path("m.vtu"), {VtuEncoding::kAscii}).ok());
  const std::string text = slurp(path("m.vtu"));
  const std::size_t at = text.find("Name=\"min_dihedral\"");
  ASSERT_NE(at, std::string::npos);
  std::istringstream values(text.substr(text.find('>', at) + 1));
  const std::vector<double> want = min_dihedral_per_tet(m);
  for (double w : want) {
    double v = -1;
    values >> v;
    EXPECT_EQ(v, w);
  }
  // A boundary triangle: the value of the tet that has all three of its points.
  for (const Tri& f : m.boundary) {
    double v = -1;
    values >> v;
    std::size_t owners = 0;
    for (std::size_t t = 0; t < m.tets.size(); ++t) {
      const Tet& k = m.tets[t];
      if (std::all_of(f.begin(), f.end(), [&](Index p) { return std::find(k.begin(), k.end(), p) != k.end(); })) {
        EXPECT_EQ(v, want[t]);
        ++owners;
      }
    }
    EXPECT_EQ(owners, 1u);
  }
  EXPECT_NE(text.find("Name=\"region\""), std::string::npos);
}

TEST_F(VolumeIo, BinaryUgridByteOrderFollowsSuffix) {
  const VolumeMesh m = grid_mesh(1);
  ASSERT_TRUE(write_volume(m, path("m.lb8.ugrid")).ok());
  ASSERT_TRUE(write_volume(m, path("m.b8.ugrid")).ok());
  const std::string little = slurp(path("m.lb8.ugrid")), big = slurp(path("m.b8.ugrid"));
  ASSERT_EQ(little.size(), big.size());
  // 8 points, 12 triangles, 6 tets: 7*4 + 8*24 + 12*16 + 6*16 bytes.
  EXPECT_EQ(little.size(), 28u + 8 * 24 + 12 * 16 + 6 * 16);
  EXPECT_EQ(little.substr(0, 4), std::string("\x08\x00\x00\x00", 4));
  EXPECT_EQ(big.substr(0, 4), std::string("\x00\x00\x00\x08", 4));
  // A big-endian file read as little-endian is refused, not misread.
  fs::copy_file(path("m.b8.ugrid"), path("swapped.lb8.ugrid"));
  const auto r = read_volume(path("swapped.lb8.ugrid"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput);
}

/// An independent encoder of libMeshb version 3 (64-bit positions), from the
/// format description, to check that version-3 files are read too.
std::string meshb_v3(const VolumeMesh& m) {
  std::string out;
  auto i32 = [&](std::int32_t v) { out.append(reinterpret_cast<const char*>(&v), 4); };
  auto i64 = [&](std::int64_t v) { out.append(reinterpret_cast<const char*>(&v), 8); };
  auto f64 = [&](double v) { out.append(reinterpret_cast<const char*>(&v), 8); };
  auto kw = [&](std::int32_t code, std::size_t body) {
    i32(code);
    i64(code == 54 ? 0 : static_cast<std::int64_t>(out.size() + 8 + body));
  };
  i32(1);
  i32(3);
  kw(3, 4);
  i32(3);
  kw(4, 4 + m.points.size() * 28);
  i32(static_cast<std::int32_t>(m.points.size()));
  for (const Vec3& p : m.points) {
    for (double x : p) f64(x);
    i32(0);
  }
  kw(8, 4 + m.tets.size() * 20);
  i32(static_cast<std::int32_t>(m.tets.size()));
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    for (Index v : m.tets[t]) i32(static_cast<std::int32_t>(v + 1));
    i32(m.tet_regions[t]);
  }
  kw(6, 4 + m.boundary.size() * 16);  // after the tets: order of keywords is free
  i32(static_cast<std::int32_t>(m.boundary.size()));
  for (std::size_t t = 0; t < m.boundary.size(); ++t) {
    for (Index v : m.boundary[t]) i32(static_cast<std::int32_t>(v + 1));
    i32(m.boundary_ids[t]);
  }
  kw(54, 0);
  return out;
}

TEST_F(VolumeIo, MeshbReadsVersion3AndMatchesOurVersion2Layout) {
  const VolumeMesh m = grid_mesh(1);
  const auto r = read_volume(write_text("v3.meshb", meshb_v3(m)));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  expect_same_mesh(m, *r, true);
  // Our own file: version 2, Dimension 3 first, End last with a zero pointer.
  ASSERT_TRUE(write_volume(m, path("v2.meshb")).ok());
  const std::string b = slurp(path("v2.meshb"));
  std::int32_t w[5];
  std::memcpy(w, b.data(), sizeof w);
  EXPECT_EQ(w[0], 1);
  EXPECT_EQ(w[1], 2);
  EXPECT_EQ(w[2], 3);   // Dimension keyword
  EXPECT_EQ(w[3], 20);  // next keyword right after the dimension value
  EXPECT_EQ(w[4], 3);
  std::int32_t end[2];
  std::memcpy(end, b.data() + b.size() - 8, sizeof end);
  EXPECT_EQ(end[0], 54);
  EXPECT_EQ(end[1], 0);
}

TEST_F(VolumeIo, MeditSkipsUnknownSectionsAndComments) {
  const std::string text =
      "MeshVersionFormatted 1\n# a comment\nDimension\n3\nVertices\n4\n0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n"
      "Corners\n2\n1 2\nRidges 0\nTriangles\n1\n1 3 2 7\nTetrahedra\n1\n1 2 3 4 0\nEnd\n";
  const auto r = read_volume(write_text("m.mesh", text));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points.size(), 4u);
  EXPECT_EQ(r->boundary, (std::vector<Tri>{{0, 2, 1}}));
  EXPECT_EQ(r->boundary_ids, std::vector<int>{7});
  EXPECT_EQ(r->tets, (std::vector<Tet>{{0, 1, 2, 3}}));
  EXPECT_TRUE(r->tet_regions.empty());
}

TEST_F(VolumeIo, GmshReadsSimpleVariants) {
  // No $PhysicalNames or $Entities, a $Comments section, nodes in two blocks
  // with sparse tags out of order, a point element block to skip.
  const std::string text =
      "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Comments\nhello world\n$EndComments\n"
      "$Nodes\n2 4 10 40\n0 1 0 2\n40\n10\n0 0 1\n0 0 0\n3 1 0 2\n20\n30\n1 0 0\n0 1 0\n$EndNodes\n"
      "$Elements\n3 3 1 3\n0 1 15 1\n3 10\n3 1 4 1\n2 10 20 30 40\n2 5 2 1\n1 10 30 20\n$EndElements\n";
  const auto r = read_volume(write_text("v.msh", text));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  // Points in ascending tag order: 10, 20, 30, 40.
  EXPECT_EQ(r->points, (std::vector<Vec3>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}));
  EXPECT_EQ(r->tets, (std::vector<Tet>{{0, 1, 2, 3}}));
  EXPECT_EQ(r->boundary, (std::vector<Tri>{{0, 2, 1}}));
  EXPECT_EQ(r->boundary_ids, std::vector<int>{5});  // the entity tag, without physical groups
  EXPECT_TRUE(r->tet_regions.empty());
}

TEST_F(VolumeIo, VtuReadsVtkWriterAsciiLayout) {
  // As vtkXMLUnstructuredGridWriter writes in ascii mode: a compressor
  // attribute, CellData before Points, <InformationKey> inside a DataArray.
  const std::string text =
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\" "
      "header_type=\"UInt32\" compressor=\"vtkZLibDataCompressor\">\n  <UnstructuredGrid>\n"
      "    <Piece NumberOfPoints=\"4\" NumberOfCells=\"2\">\n      <PointData>\n      </PointData>\n"
      "      <CellData Scalars=\"surface_id\">\n"
      "        <DataArray type=\"Int32\" Name=\"surface_id\" format=\"ascii\" RangeMin=\"0\" RangeMax=\"4\">\n"
      "          0 4\n        </DataArray>\n      </CellData>\n      <Points>\n"
      "        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"ascii\">\n"
      "          0 0 0 1 0 0\n          0 1 0 0 0 1\n"
      "          <InformationKey name=\"L2_NORM_RANGE\" location=\"vtkDataArray\" length=\"2\">\n"
      "            <Value index=\"0\">\n              0\n            </Value>\n          </InformationKey>\n"
      "        </DataArray>\n      </Points>\n      <Cells>\n"
      "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n          0 1 2 3 0 1 3\n"
      "        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n          4 7\n"
      "        </DataArray>\n        <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n          10 5\n"
      "        </DataArray>\n      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
  const auto r = read_volume(write_text("paraview.vtu", text));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points, (std::vector<Vec3>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}));
  EXPECT_EQ(r->tets, (std::vector<Tet>{{0, 1, 2, 3}}));
  EXPECT_EQ(r->boundary, (std::vector<Tri>{{0, 1, 3}}));
  EXPECT_EQ(r->boundary_ids, std::vector<int>{4});
  EXPECT_TRUE(r->tet_regions.empty());
}

TEST_F(VolumeIo, Su2MapsMarkerTagsToIds) {
  const std::string text =
      "NDIME=3\nNELEM= 1\n10 0 1 2 3\nNPOIN= 4 4\n0 0 0\n1 0 0 1\n0 1 0 2\n0 0 1 3\nNMARK= 3\n"
      "MARKER_TAG= wall\nMARKER_ELEMS= 1\n5 0 2 1\nMARKER_TAG = surface_1\nMARKER_ELEMS= 1\n5 0 1 3\n"
      "MARKER_TAG= farfield % far away\nMARKER_ELEMS= 1\n5 0 3 2\n";
  const auto r = read_volume(write_text("m.su2", text));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->boundary_ids, (std::vector<int>{2, 1, 3}));  // surface_1 keeps 1; others the next unused
  EXPECT_EQ(r->tets, (std::vector<Tet>{{0, 1, 2, 3}}));
}

// ---------------------------------------------------------------- boundary names

/// The cube with names on some of its ids (1..6 by face).
VolumeMesh named_cube() {
  VolumeMesh m = grid_mesh(1);
  m.boundary_names = {{1, "inlet"}, {2, "outlet"}, {4, "sides"}};
  return m;
}

TEST_F(VolumeIo, Su2MarkerTagsAreTheNamesAndComeBackAsNames) {
  const VolumeMesh m = named_cube();
  ASSERT_TRUE(write_volume(m, path("m.su2")).ok());
  const std::string text = slurp(path("m.su2"));
  for (const char* tag : {"inlet", "outlet", "surface_3", "sides", "surface_5", "surface_6"})
    EXPECT_NE(text.find(fmt::format("MARKER_TAG= {}\n", tag)), std::string::npos) << tag;
  const auto r = read_volume(path("m.su2"));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  // The unnamed keep their ids; the named take the next unused ids in file (= id) order: here their own.
  expect_same_mesh(m, *r, false);
  EXPECT_EQ(r->boundary_names, m.boundary_names);

  // Markers of one tag share an id; a tag that is no boundary name is made one.
  const std::string two =
      "NDIME=3\nNELEM= 1\n10 0 1 2 3\nNPOIN= 4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nNMARK= 3\n"
      "MARKER_TAG= wall\nMARKER_ELEMS= 1\n5 0 2 1\nMARKER_TAG= Body:1\nMARKER_ELEMS= 1\n5 0 1 3\n"
      "MARKER_TAG= wall\nMARKER_ELEMS= 2\n5 0 3 2\n5 1 2 3\n";
  const auto w = read_volume(write_text("two.su2", two));
  ASSERT_TRUE(w.ok()) << w.status().to_string();
  EXPECT_EQ(w->boundary_ids, (std::vector<int>{1, 2, 1, 1}));
  EXPECT_EQ(w->boundary_names, (std::map<int, std::string>{{1, "wall"}, {2, "Body_1"}}));
}

TEST_F(VolumeIo, UgridWritesItsNamesIntoAMapbcBesideAndReadsThemBack) {
  const VolumeMesh m = named_cube();
  for (const char* suffix : {".ugrid", ".lb8.ugrid", ".b8.ugrid"}) {
    SCOPED_TRACE(suffix);
    const fs::path grid = path(std::string("wing") + suffix);
    ASSERT_TRUE(write_volume(m, grid).ok());
    EXPECT_EQ(slurp(path("wing.mapbc")),
              "6\n1 3000 inlet\n2 3000 outlet\n3 3000 surface_3\n4 3000 sides\n5 3000 surface_5\n"
              "6 3000 surface_6\n");
    const auto r = read_volume(grid);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    expect_same_mesh(m, *r, false);
    EXPECT_EQ(r->boundary_names, m.boundary_names);
    fs::remove(path("wing.mapbc"));
    const auto bare = read_volume(grid);  // no .mapbc: no names, ids as before
    ASSERT_TRUE(bare.ok()) << bare.status().to_string();
    EXPECT_TRUE(bare->boundary_names.empty());
    EXPECT_EQ(bare->boundary_ids, m.boundary_ids);
  }
  EXPECT_EQ(mapbc_path("runs/Wing.LB8.UGRID"), fs::path("runs/Wing.mapbc"));
  EXPECT_EQ(mapbc_path("wing.b8.ugrid"), fs::path("wing.mapbc"));
  EXPECT_EQ(mapbc_path("a.ugrid"), fs::path("a.mapbc"));

  // Medit holds no names, and writes no file beside.
  ASSERT_TRUE(write_volume(m, path("m.mesh")).ok());
  EXPECT_FALSE(fs::exists(path("m.mapbc")));
  EXPECT_TRUE(read_volume(path("m.mesh"))->boundary_names.empty());
}

TEST_F(VolumeIo, MapbcFromOtherToolsIsReadAndABadOneIsAnErrorNamingIt) {
  ASSERT_TRUE(write_volume(grid_mesh(1), path("g.ugrid")).ok());
  // FUN3D's own: other bc codes, a name with a character we do not take, a line without a name.
  write_text("g.mapbc", "6\n1 5000 farfield\n2 4000 wing/upper\n3 3000\n4 3000 surface_4\n5 3000 a\n6 3000 b\n");
  const auto r = read_volume(path("g.ugrid"));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->boundary_names,
            (std::map<int, std::string>{{1, "farfield"}, {2, "wing_upper"}, {5, "a"}, {6, "b"}}));

  write_text("g.mapbc", "2\n1 3000 a\n7 3000 b\n");
  const auto unknown = read_volume(path("g.ugrid"));
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.status().message().find("g.mapbc"), std::string::npos) << unknown.status().to_string();
  EXPECT_NE(unknown.status().message().find("id 7"), std::string::npos) << unknown.status().to_string();
  write_text("g.mapbc", "2\n1 3000 a\n2 wall b\n");
  const auto malformed = read_volume(path("g.ugrid"));
  ASSERT_FALSE(malformed.ok());
  EXPECT_NE(malformed.status().message().find("g.mapbc:3:"), std::string::npos) << malformed.status().to_string();
  write_text("g.mapbc", "2\n1 3000 a\n2 3000 a\n");
  const auto twice = read_volume(path("g.ugrid"));
  ASSERT_FALSE(twice.ok());
  EXPECT_NE(twice.status().message().find("ids 1 and 2 are both named 'a'"), std::string::npos)
      << twice.status().to_string();
}

TEST_F(VolumeIo, AStagedUgridHoldsItsMapbcTooUntilCommitted) {
  const auto entries = [&] {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  };
  {
    auto staged = stage_volume(named_cube(), path("w.ugrid"));
    ASSERT_TRUE(staged.ok()) << staged.status().to_string();
    EXPECT_EQ(entries().size(), 2u);
    for (const std::string& n : entries()) EXPECT_TRUE(n.ends_with(".partial")) << n;
  }
  EXPECT_TRUE(entries().empty());  // discarded: both gone
  auto staged = stage_volume(named_cube(), path("w.ugrid"));
  ASSERT_TRUE(staged.ok());
  ASSERT_TRUE(staged->commit().ok());
  EXPECT_EQ(entries(), (std::vector<std::string>{"w.mapbc", "w.ugrid"}));
}

// ---------------------------------------------------------------- suffixes and writer checks

TEST_F(VolumeIo, DetectsFormatFromSuffix) {
  const std::pair<const char*, VolumeFormat> cases[] = {
      {"a.mesh", VolumeFormat::kMedit},          {"a.meshb", VolumeFormat::kMeditBinary},
      {"a.vtu", VolumeFormat::kVtu},             {"a.ugrid", VolumeFormat::kUgridAscii},
      {"a.lb8.ugrid", VolumeFormat::kUgridLittle}, {"a.b8.ugrid", VolumeFormat::kUgridBig},
      {"dir.b8/a.ugrid", VolumeFormat::kUgridAscii}, {"A.LB8.UGRID", VolumeFormat::kUgridLittle},
      {"a.msh", VolumeFormat::kGmsh},            {"a.su2", VolumeFormat::kSu2},
      {"x.tar.MESH", VolumeFormat::kMedit}};
  for (const auto& [name, format] : cases) {
    const auto r = volume_format_from_path(name);
    ASSERT_TRUE(r.ok()) << name << ": " << r.status().to_string();
    EXPECT_EQ(*r, format) << name;
  }
  for (const char* name : {"a.stl", "a.r8.ugrid", "mesh", "a.vtk", "a.lb4.ugrid"}) {
    const auto r = volume_format_from_path(name);
    ASSERT_FALSE(r.ok()) << name;
    EXPECT_EQ(r.status().code(), StatusCode::kUnsupported);
    EXPECT_NE(r.status().message().find(".lb8.ugrid"), std::string::npos) << r.status().to_string();
  }
  EXPECT_EQ(volume_format_suffixes(), ".mesh .meshb .vtu .ugrid .lb8.ugrid .b8.ugrid .msh .su2 .cgns polyMesh");
}

TEST_F(VolumeIo, WriteRefusesUnknownSuffixAndInconsistentMeshes) {
  const VolumeMesh cube = grid_mesh(1);
  EXPECT_EQ(write_volume(cube, path("a.stl")).code(), StatusCode::kUnsupported);
  EXPECT_FALSE(fs::exists(path("a.stl")));
  VolumeMesh bad = cube;
  bad.boundary_ids.pop_back();
  EXPECT_EQ(write_volume(bad, path("a.mesh")).code(), StatusCode::kInvalidInput);
  bad = cube;
  bad.tets[2][1] = 8;
  const Status s = write_volume(bad, path("a.mesh"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("tet 2"), std::string::npos) << s.to_string();
  bad = cube;
  bad.points[3][1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(write_volume(bad, path("a.vtu")).code(), StatusCode::kInvalidInput);
  bad = cube;
  bad.tet_regions.resize(2);
  EXPECT_EQ(write_volume(bad, path("a.msh")).code(), StatusCode::kInvalidInput);
  EXPECT_EQ(read_volume(path("missing.mesh")).status().code(), StatusCode::kNotFound);
}

TEST_F(VolumeIo, WritesAtomicallyThroughAStagedFile) {
  const VolumeMesh one = grid_mesh(1), two = grid_mesh(2);
  const fs::path out = path("out.mesh");
  ASSERT_TRUE(write_volume(one, out).ok());
  const std::string first = slurp(out);
  const auto entries = [&] {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  };
  {
    auto staged = stage_volume(two, out);
    ASSERT_TRUE(staged.ok()) << staged.status().to_string();
    EXPECT_EQ(slurp(out), first);  // not in place before commit
    const auto names = entries();
    ASSERT_EQ(names.size(), 2u);
    EXPECT_TRUE(names[0].starts_with(".out.mesh.") && names[0].ends_with(".partial")) << names[0];
  }
  EXPECT_EQ(entries(), std::vector<std::string>{"out.mesh"});  // discarded uncommitted
  EXPECT_EQ(slurp(out), first);

  auto staged = stage_volume(two, out);
  ASSERT_TRUE(staged.ok());
  ASSERT_TRUE(staged->commit().ok());
  EXPECT_EQ(entries(), std::vector<std::string>{"out.mesh"});
  const auto r = read_volume(out);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  expect_same_mesh(two, *r, true);

  // A destination that cannot take the file: named in the error, nothing left behind.
  const Status missing = write_volume(one, path("no/such/dir/a.vtu"));
  EXPECT_EQ(missing.code(), StatusCode::kIoError) << missing.to_string();
  EXPECT_NE(missing.message().find("no/such/dir/a.vtu"), std::string::npos) << missing.to_string();
  fs::create_directory(path("taken.mesh"));
  const Status taken = write_volume(one, path("taken.mesh"));
  EXPECT_EQ(taken.code(), StatusCode::kIoError) << taken.to_string();
  EXPECT_NE(taken.message().find("taken.mesh"), std::string::npos) << taken.to_string();
  EXPECT_TRUE(fs::is_directory(path("taken.mesh")));
  EXPECT_EQ(entries(), (std::vector<std::string>{"out.mesh", "taken.mesh"}));
}

// ---------------------------------------------------------------- malformed files

TEST_F(VolumeIo, MeditRejectsMalformedFiles) {
  const std::string head = "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n";
  ASSERT_TRUE(read_volume(write_text("ok.mesh", head + "Tetrahedra\n1\n1 2 3 4 0\nEnd\n")).ok());
  // Truncation is caught by the count check (no room left) or at the end of the data.
  expect_error("short.mesh", head + "Tetrahedra\n1\n1 2 3", StatusCode::kInvalidInput,
               {"short.mesh:10:", "more than the rest of the file"});
  expect_error("trunc.mesh", "Dimension 3\nVertices\n2\n0.5 0.25 0.125 0\n0.5", StatusCode::kInvalidInput,
               {"trunc.mesh:5:", "end of file", "vertex y"});
  expect_error("count.mesh", head + "Triangles\n2\n1 2 3 4\nTetrahedra\n1\n1 2 3 4 0\nEnd\n",
               StatusCode::kInvalidInput, {"count.mesh:12:", "'Tetrahedra'"});
  expect_error("garbage.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 zero 0 0\n",
               StatusCode::kInvalidInput, {"garbage.mesh:5:", "'zero'"});
  expect_error("nan.mesh", "Dimension 3\nVertices\n1\n0 nan 0 0\n", StatusCode::kInvalidInput,
               {"nan.mesh:4:", "not a finite"});
  expect_error("range.mesh", head + "Triangles\n1\n1 2 5 1\nEnd\n", StatusCode::kInvalidInput,
               {"range.mesh:11:", "5 is out of range"});
  expect_error("huge.mesh", "Dimension 3\nVertices\n99999999999\n0 0 0 0\n", StatusCode::kInvalidInput,
               {"huge.mesh:3:", "more than the rest of the file"});
  expect_error("hex.mesh", head + "Hexahedra\n1\n1 2 3 4 1 2 3 4 0\nEnd\n", StatusCode::kUnsupported, {"Hexahedra"});
  expect_error("dim.mesh", "Dimension 2\n", StatusCode::kUnsupported, {"Dimension 2"});
}

TEST_F(VolumeIo, MeshbRejectsMalformedFiles) {
  const VolumeMesh m = grid_mesh(1);
  ASSERT_TRUE(write_volume(m, path("good.meshb")).ok());
  const std::string good = slurp(path("good.meshb"));
  // Layout of our version-2 file: header 8, Dimension 12, then Vertices.
  const std::size_t vertices = 20, first_x = vertices + 12;
  const std::size_t triangles = vertices + 12 + m.points.size() * 28, first_tri = triangles + 12;
  ASSERT_EQ(good.substr(triangles, 4), std::string("\x06\x00\x00\x00", 4));

  expect_error("trunc.meshb", good.substr(0, good.size() / 2), StatusCode::kInvalidInput, {"trunc.meshb: byte offset"});
  std::string count = good;
  const std::int32_t many = 1000;
  std::memcpy(count.data() + vertices + 8, &many, 4);
  expect_error("count.meshb", count, StatusCode::kInvalidInput, {"byte offset", "vertex count 1000"});
  expect_error("garbage.meshb", "this is not a mesh file", StatusCode::kInvalidInput, {"not a meshb file"});
  std::string nan = good;
  const double q = std::numeric_limits<double>::quiet_NaN();
  std::memcpy(nan.data() + first_x + 8, &q, 8);
  expect_error("nan.meshb", nan, StatusCode::kInvalidInput, {fmt::format("byte offset {}", first_x + 8), "not a finite"});
  std::string range = good;
  const std::int32_t nine = 9;
  std::memcpy(range.data() + first_tri + 4, &nine, 4);
  expect_error("range.meshb", range, StatusCode::kInvalidInput, {fmt::format("byte offset {}", first_tri + 4), "9 is out of range"});
  std::string loop = good;
  const std::int32_t back = 8;
  std::memcpy(loop.data() + vertices + 4, &back, 4);
  expect_error("loop.meshb", loop, StatusCode::kInvalidInput, {"next keyword"});
}

TEST_F(VolumeIo, VtuRejectsMalformedFiles) {
  const VolumeMesh m = grid_mesh(1);
  ASSERT_TRUE(write_volume(m, path("good.vtu"), {VtuEncoding::kAscii}).ok());
  const std::string good = slurp(path("good.vtu"));
  auto replace = [&](std::string_view from, std::string_view to) {
    std::string s = good;
    const std::size_t at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return s.replace(at, from.size(), to);
  };
  expect_error("trunc.vtu", good.substr(0, good.size() / 2), StatusCode::kInvalidInput, {"trunc.vtu:"});
  expect_error("count.vtu", replace("NumberOfPoints=\"8\"", "NumberOfPoints=\"9\""), StatusCode::kInvalidInput,
               {"count.vtu:"});
  expect_error("garbage.vtu", replace("Name=\"connectivity\" format=\"ascii\">\n", "Name=\"connectivity\" format=\"ascii\">\nx"),
               StatusCode::kInvalidInput, {"garbage.vtu:14:", "'x0'"});
  expect_error("nan.vtu", replace("format=\"ascii\">\n0 0 0", "format=\"ascii\">\n0 NaN 0"), StatusCode::kInvalidInput,
               {"nan.vtu:7:", "not a finite"});
  expect_error("range.vtu", replace("Name=\"connectivity\" format=\"ascii\">\n0 ", "Name=\"connectivity\" format=\"ascii\">\n8 "),
               StatusCode::kInvalidInput, {"range.vtu:13:", "is 8, out of range"});
  expect_error("format.vtu", replace("Name=\"types\" format=\"ascii\"", "Name=\"types\" format=\"hex\""),
               StatusCode::kUnsupported, {"ascii, binary and appended"});
  expect_error("notvtk.vtu", "<html></html>", StatusCode::kInvalidInput, {"no <VTKFile>"});
}

TEST_F(VolumeIo, UgridAsciiRejectsMalformedFiles) {
  const std::string head = "4 1 0 1 0 0 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
  ASSERT_TRUE(read_volume(write_text("ok.ugrid", head + "1 3 2\n7\n1 2 3 4\n")).ok());
  expect_error("short.ugrid", head + "1 3 2\n7\n1 2", StatusCode::kInvalidInput, {"short.ugrid:1:", "more than the rest"});
  expect_error("trunc.ugrid", "2 0 0 0 0 0 0\n0.5 0.25 0.125\n0.5 0.25\n", StatusCode::kInvalidInput,
               {"trunc.ugrid:3:", "end of file", "node z"});
  expect_error("count.ugrid", "4 1 0 2 0 0 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 3 2\n7\n1 2 3 4\n", StatusCode::kInvalidInput,
               {"count.ugrid:"});
  expect_error("garbage.ugrid", head + "1 3 two\n7\n1 2 3 4\n", StatusCode::kInvalidInput, {"garbage.ugrid:6:", "'two'"});
  expect_error("nan.ugrid", "2 0 0 0 0 0 0\n0 0 0\n1 0 -inf\n", StatusCode::kInvalidInput, {"nan.ugrid:3:", "not a finite"});
  expect_error("range.ugrid", head + "1 3 2\n7\n1 2 3 0\n", StatusCode::kInvalidInput, {"range.ugrid:8:", "0 is out of range"});
  expect_error("huge.ugrid", "2000000000 0 0 0 0 0 0\n0 0 0\n", StatusCode::kInvalidInput, {"more than the rest"});
  expect_error("hex.ugrid", "8 0 0 0 0 0 1\n", StatusCode::kUnsupported, {"1 hexes"});
}

TEST_F(VolumeIo, UgridBinaryRejectsMalformedFiles) {
  const VolumeMesh m = grid_mesh(1);
  ASSERT_TRUE(write_volume(m, path("good.lb8.ugrid")).ok());
  const std::string good = slurp(path("good.lb8.ugrid"));
  expect_error("trunc.lb8.ugrid", good.substr(0, good.size() - 3), StatusCode::kInvalidInput,
               {"trunc.lb8.ugrid: byte offset", "the file has"});
  std::string count = good;
  const std::int32_t huge = 1 << 30;
  std::memcpy(count.data() + 12, &huge, 4);  // ntet
  expect_error("count.lb8.ugrid", count, StatusCode::kInvalidInput, {"1073741824 tets"});
  expect_error("garbage.lb8.ugrid", "garbage!", StatusCode::kInvalidInput, {"byte offset 8"});
  std::string nan = good;
  const double q = std::numeric_limits<double>::infinity();
  std::memcpy(nan.data() + 28 + 24 + 16, &q, 8);  // node 1, z
  expect_error("nan.lb8.ugrid", nan, StatusCode::kInvalidInput, {"byte offset 68", "not a finite"});
  std::string range = good;
  const std::int32_t zero = 0;
  const std::size_t first_tet = 28 + 8 * 24 + 12 * 16;
  std::memcpy(range.data() + first_tet, &zero, 4);
  expect_error("range.lb8.ugrid", range, StatusCode::kInvalidInput, {fmt::format("byte offset {}", first_tet), "out of range"});
}

TEST_F(VolumeIo, GmshRejectsMalformedFiles) {
  const VolumeMesh m = grid_mesh(1);
  ASSERT_TRUE(write_volume(m, path("good.msh")).ok());
  const std::string good = slurp(path("good.msh"));
  auto replace = [&](std::string_view from, std::string_view to) {
    std::string s = good;
    const std::size_t at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return s.replace(at, from.size(), to);
  };
  expect_error("trunc.msh", good.substr(0, good.size() - 30), StatusCode::kInvalidInput, {"trunc.msh:", "more than the rest"});
  expect_error("nopend.msh", good.substr(0, good.size() - 13), StatusCode::kInvalidInput, {"nopend.msh:", "end of file"});
  expect_error("count.msh", replace("$Nodes\n1 8 1 8\n", "$Nodes\n1 9 1 9\n"), StatusCode::kInvalidInput,
               {"count.msh:", "announced 9"});
  expect_error("garbage.msh", replace("$Elements\n", "$Elements\nfoo "), StatusCode::kInvalidInput, {"'foo'"});
  expect_error("nan.msh", replace("\n0 0 0\n", "\n0 0 nan\n"), StatusCode::kInvalidInput, {"nan.msh:", "not a finite"});
  expect_error("range.msh", replace("3 1 4 3\n1 1 ", "3 1 4 3\n1 99 "), StatusCode::kInvalidInput, {"node tag 99"});
  expect_error("old.msh", "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", StatusCode::kUnsupported, {"4.1 and 2.2"});
  expect_error("hex.msh", "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n0 0 0 0\n$EndNodes\n$Elements\n1 1 1 1\n3 1 5 1\n",
               StatusCode::kUnsupported, {"type 5"});
}

TEST_F(VolumeIo, Su2RejectsMalformedFiles) {
  const std::string good = "NDIME= 3\nNELEM= 1\n10 0 1 2 3 0\nNPOIN= 4\n0 0 0 0\n1 0 0 1\n0 1 0 2\n0 0 1 3\nNMARK= 0\n";
  ASSERT_TRUE(read_volume(write_text("ok.su2", good)).ok());
  expect_error("short.su2", good.substr(0, 60), StatusCode::kInvalidInput, {"short.su2:4:", "more than the rest"});
  expect_error("trunc.su2", "NDIME= 3\nNELEM= 0\nNPOIN= 2\n0.5 0.25 0.125 0\n0.5\n", StatusCode::kInvalidInput,
               {"trunc.su2:5:", "end of file"});
  expect_error("count.su2", "NDIME= 3\nNELEM= 2\n10 0 1 2 3 0\nNPOIN= 4\n0 0 0 0\n1 0 0 1\n0 1 0 2\n0 0 1 3\n",
               StatusCode::kInvalidInput, {"count.su2:4:"});
  expect_error("garbage.su2", "NDIME= 3\nNELEM= 1\n10 0 1 x 3 0\n", StatusCode::kInvalidInput, {"garbage.su2:3:", "'x'"});
  expect_error("nan.su2", "NDIME= 3\nNELEM= 0\nNPOIN= 1\n0 NAN 0 0\n", StatusCode::kInvalidInput, {"nan.su2:4:", "not a finite"});
  expect_error("range.su2", "NDIME= 3\nNELEM= 1\n10 0 1 2 4 0\nNPOIN= 4\n0 0 0 0\n1 0 0 1\n0 1 0 2\n0 0 1 3\nNMARK= 0\n",
               StatusCode::kInvalidInput, {"range.su2:3:", "4 is out of range"});
  expect_error("hex.su2", "NDIME= 3\nNELEM= 1\n12 0 1 2 3 4 5 6 7 0\n", StatusCode::kUnsupported, {"type 12"});
}

}  // namespace
}  // namespace pdrmesh
