// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the written-only volume formats: OpenFOAM polyMesh directories
// (face order, orientation, patches, zones, replacing a directory) and CGNS
// (read back with libcgns: zone, sections, boundary conditions).
#include <cgnslib.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <sstream>
#include <thread>

#include "pdrmesh/volume_io.hpp"
#include "tet_fixtures.hpp"

namespace pdrmesh {
namespace {

namespace fs = std::filesystem;

class WrittenFormats : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("pdrmesh_foam_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The numbers of a FoamFile list after its header: "N ( ... )" with every
/// parenthesis dropped, so faces "3(a b c)" come as 3, a, b, c.
std::vector<double> foam_list(const fs::path& p) {
  std::string text = slurp(p);
  const std::size_t header_end = text.find("}\n");
  EXPECT_NE(header_end, std::string::npos) << p;
  text = text.substr(header_end + 2);
  for (char& c : text)
    if (c == '(' || c == ')') c = ' ';
  std::istringstream in(text);
  std::vector<double> v;
  double x = 0;
  while (in >> x) v.push_back(x);
  EXPECT_FALSE(v.empty()) << p;
  if (!v.empty()) v.erase(v.begin());  // the count
  return v;
}

struct PolyMesh {
  std::vector<Vec3> points;
  std::vector<Tri> faces;
  std::vector<Index> owner, neighbour;
  struct Patch {
    std::string name, type;
    std::size_t faces, start;
  };
  std::vector<Patch> patches;
};

PolyMesh read_poly_mesh(const fs::path& dir) {
  PolyMesh m;
  const auto pts = foam_list(dir / "points");
  for (std::size_t i = 0; i + 2 < pts.size(); i += 3) m.points.push_back({pts[i], pts[i + 1], pts[i + 2]});
  const auto faces = foam_list(dir / "faces");
  for (std::size_t i = 0; i + 3 < faces.size(); i += 4) {
    EXPECT_EQ(faces[i], 3.0) << "face " << i / 4 << " is a triangle";
    m.faces.push_back({Index(faces[i + 1]), Index(faces[i + 2]), Index(faces[i + 3])});
  }
  for (double x : foam_list(dir / "owner")) m.owner.push_back(Index(x));
  for (double x : foam_list(dir / "neighbour")) m.neighbour.push_back(Index(x));
  const std::string boundary = slurp(dir / "boundary");
  const std::regex patch(R"(\n    (\S+)\n    \{\n        type +(\w+);\n        nFaces +(\d+);\n        startFace +(\d+);)");
  for (auto it = std::sregex_iterator(boundary.begin(), boundary.end(), patch); it != std::sregex_iterator(); ++it)
    m.patches.push_back({(*it)[1], (*it)[2], std::stoul((*it)[3]), std::stoul((*it)[4])});
  return m;
}

Vec3 centroid(const VolumeMesh& m, Index t) {
  Vec3 c{0, 0, 0};
  for (Index v : m.tets[t]) c = c + m.points[v];
  return 0.25 * c;
}

/// OpenFOAM's rules, checked on the files: upper-triangular internal faces,
/// every face's normal out of its owner (into the neighbour), each cell with
/// four faces, the patches tiling the hull faces in order.
void expect_valid_poly_mesh(const VolumeMesh& mesh, const PolyMesh& p) {
  ASSERT_EQ(p.points.size(), mesh.points.size());
  EXPECT_EQ(p.points, mesh.points);
  ASSERT_EQ(p.owner.size(), p.faces.size());
  for (std::size_t f = 0; f < p.neighbour.size(); ++f) {
    EXPECT_LT(p.owner[f], p.neighbour[f]) << "face " << f;
    if (f > 0) {
      EXPECT_LT(std::make_pair(p.owner[f - 1], p.neighbour[f - 1]), std::make_pair(p.owner[f], p.neighbour[f]))
          << "upper-triangular order at face " << f;
    }
  }
  std::vector<int> faces_of(mesh.tets.size(), 0);
  for (std::size_t f = 0; f < p.faces.size(); ++f) {
    const Tri& t = p.faces[f];
    const Vec3 n = cross(p.points[t[1]] - p.points[t[0]], p.points[t[2]] - p.points[t[0]]);
    const Vec3 fc = (1.0 / 3.0) * (p.points[t[0]] + p.points[t[1]] + p.points[t[2]]);
    EXPECT_GT(dot(n, fc - centroid(mesh, p.owner[f])), 0) << "face " << f << " points out of its owner";
    ++faces_of[p.owner[f]];
    if (f < p.neighbour.size()) {
      EXPECT_GT(dot(n, centroid(mesh, p.neighbour[f]) - fc), 0) << "face " << f << " points into its neighbour";
      ++faces_of[p.neighbour[f]];
    }
  }
  for (std::size_t t = 0; t < faces_of.size(); ++t) EXPECT_EQ(faces_of[t], 4) << "cell " << t;
  std::size_t start = p.neighbour.size();
  for (const auto& patch : p.patches) {
    EXPECT_EQ(patch.start, start) << patch.name;
    start += patch.faces;
  }
  EXPECT_EQ(start, p.faces.size()) << "the patches hold every hull face";
}

TEST_F(WrittenFormats, PolyMeshOfTwoTetsOrdersAndOrientsFaces) {
  // Tet 0 = (a, b, c, e) above the face abc, tet 1 = (a, c, b, d) below it.
  VolumeMesh m = fixtures::two_tets({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.2, 0.3, -1}, {0.1, 0.2, 1});
  // Tet 1's three hull faces get id 2 ("wall"), tet 0's id 1 (unnamed), listed id 2 first.
  m.boundary_ids.clear();
  for (const Tri& f : m.boundary) m.boundary_ids.push_back(std::find(f.begin(), f.end(), Index{3}) != f.end() ? 2 : 1);
  m.boundary_names = {{2, "wall"}};
  const fs::path out = dir_ / "case" / "constant" / "polyMesh";
  ASSERT_TRUE(write_volume(m, out).ok());
  const PolyMesh p = read_poly_mesh(out);
  ASSERT_EQ(p.faces.size(), 7U);
  EXPECT_EQ(p.neighbour, std::vector<Index>{1});
  EXPECT_EQ(p.owner, (std::vector<Index>{0, 0, 0, 0, 1, 1, 1})) << "internal, then surface_1 (tet 0), then wall";
  // The shared face, seen from tet 0, is (a, c, b): its normal points down into tet 1.
  EXPECT_EQ(topo::sorted_key(p.faces[0]), (Tri{0, 1, 2}));
  const Vec3 n = cross(p.points[p.faces[0][1]] - p.points[p.faces[0][0]], p.points[p.faces[0][2]] - p.points[p.faces[0][0]]);
  EXPECT_LT(n[2], 0) << "from owner 0 (above) to neighbour 1 (below)";
  ASSERT_EQ(p.patches.size(), 2U);
  EXPECT_EQ(p.patches[0].name, "surface_1");
  EXPECT_EQ(p.patches[1].name, "wall");
  EXPECT_EQ(p.patches[0].type, "patch");
  EXPECT_EQ(p.patches[1].faces, 3U);
  expect_valid_poly_mesh(m, p);
  EXPECT_NE(slurp(out / "owner").find("nPoints:5  nCells:2  nFaces:7  nInternalFaces:1"), std::string::npos);
  EXPECT_FALSE(fs::exists(out / "cellZones")) << "no regions, no zones";
}

TEST_F(WrittenFormats, PolyMeshOfCubeHasPatchesZonesAndReplacesOldDirectory) {
  VolumeMesh m = fixtures::cube();
  m.boundary_names = {{1, "inlet"}, {2, "out let;{}"}, {3, "7up"}, {4, "inlet"}};
  m.tet_regions = {1, 1, 2, 2, 1, 3};
  const fs::path out = dir_ / "polyMesh";
  fs::create_directories(out);
  { std::ofstream(out / "stale") << "from an earlier mesh"; }
  ASSERT_TRUE(write_volume(m, out.string() + "/").ok()) << "a trailing slash names the same directory";
  EXPECT_FALSE(fs::exists(out / "stale")) << "the old directory is replaced, not merged";
  const PolyMesh p = read_poly_mesh(out);
  expect_valid_poly_mesh(m, p);
  std::vector<std::string> names;
  for (const auto& patch : p.patches) names.push_back(patch.name);
  EXPECT_EQ(names, (std::vector<std::string>{"inlet", "out_let___", "patch_7up", "inlet_4", "surface_5", "surface_6"}));
  for (const auto& patch : p.patches) EXPECT_EQ(patch.faces, 2U) << patch.name;
  const std::string zones = slurp(out / "cellZones");
  EXPECT_NE(zones.find("region_1\n    {\n        type cellZone;\n        cellLabels List<label> 3\n(\n0\n1\n4\n)"),
            std::string::npos)
      << zones;
  EXPECT_NE(zones.find("region_3"), std::string::npos);
  // No staged directory left beside it.
  for (const auto& e : fs::directory_iterator(dir_)) EXPECT_EQ(e.path().filename(), "polyMesh");
}

TEST_F(WrittenFormats, PolyMeshRefusesFaceOfThreeTetsAndReadIsUnsupported) {
  VolumeMesh m = fixtures::two_tets({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1});
  m.tets.push_back(m.tets[0]);  // the same tet twice: face abc in three tets
  const Status s = write_volume(m, dir_ / "polyMesh");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("shared by"), std::string::npos) << s.to_string();
  EXPECT_FALSE(fs::exists(dir_ / "polyMesh"));
  for (const char* name : {"polyMesh", "m.cgns"}) {
    const auto r = read_volume(dir_ / name);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), StatusCode::kUnsupported) << r.status().to_string();
  }
  EXPECT_EQ(*volume_format_from_path("c/constant/polyMesh"), VolumeFormat::kFoam);
  EXPECT_EQ(*volume_format_from_path("a.CGNS"), VolumeFormat::kCgns);
  EXPECT_FALSE(volume_format_from_path("c/constant/polymesh").ok()) << "OpenFOAM's name, exactly";
}

TEST_F(WrittenFormats, CgnsHoldsZoneSectionsAndNamedBoundaryConditions) {
  VolumeMesh m = fixtures::cube();
  m.boundary_names = {{1, "inlet"}, {6, std::string(40, 'x')}};
  const fs::path out = dir_ / "cube.cgns";
  ASSERT_TRUE(write_volume(m, out).ok());
  int fn = 0;
  ASSERT_EQ(cg_open(out.c_str(), CG_MODE_READ, &fn), CG_OK) << cg_get_error();
  char name[64];
  cgsize_t size[3];
  ASSERT_EQ(cg_zone_read(fn, 1, 1, name, size), CG_OK);
  EXPECT_EQ(size[0], 8);
  EXPECT_EQ(size[1], 6);
  int sections = 0, bcs = 0;
  ASSERT_EQ(cg_nsections(fn, 1, 1, &sections), CG_OK);
  ASSERT_EQ(sections, 7) << "the tets and one per boundary id";
  CGNS_ENUMT(ElementType_t) type;
  cgsize_t start = 0, end = 0;
  int nbndry = 0, parent = 0;
  ASSERT_EQ(cg_section_read(fn, 1, 1, 1, name, &type, &start, &end, &nbndry, &parent), CG_OK);
  EXPECT_EQ(type, CGNS_ENUMV(TETRA_4));
  EXPECT_EQ(end - start + 1, 6);
  std::vector<cgsize_t> conn(24);
  ASSERT_EQ(cg_elements_read(fn, 1, 1, 1, conn.data(), nullptr), CG_OK);
  EXPECT_EQ(conn[0], static_cast<cgsize_t>(m.tets[0][0]) + 1) << "1-based, mesh order";
  ASSERT_EQ(cg_nbocos(fn, 1, 1, &bcs), CG_OK);
  ASSERT_EQ(bcs, 6);
  std::vector<std::string> bc_names;
  cgsize_t next = 7;
  for (int bc = 1; bc <= bcs; ++bc) {
    CGNS_ENUMT(BCType_t) bctype;
    CGNS_ENUMT(PointSetType_t) ptset;
    cgsize_t npnts = 0, normal_size = 0;
    int normal_index[3], ndataset = 0;
    CGNS_ENUMT(DataType_t) normal_type;
    ASSERT_EQ(cg_boco_info(fn, 1, 1, bc, name, &bctype, &ptset, &npnts, normal_index, &normal_size, &normal_type,
                           &ndataset),
              CG_OK);
    bc_names.push_back(name);
    EXPECT_EQ(ptset, CGNS_ENUMV(PointRange));
    cgsize_t range[2];
    ASSERT_EQ(cg_boco_read(fn, 1, 1, bc, range, nullptr), CG_OK);
    EXPECT_EQ(range[0], next) << name;
    EXPECT_EQ(range[1], next + 1) << name << ": the cube has two triangles per side";
    next = range[1] + 1;
    CGNS_ENUMT(GridLocation_t) location;
    ASSERT_EQ(cg_boco_gridlocation_read(fn, 1, 1, bc, &location), CG_OK);
    EXPECT_EQ(location, CGNS_ENUMV(FaceCenter));
  }
  EXPECT_EQ(bc_names, (std::vector<std::string>{"inlet", "surface_2", "surface_3", "surface_4", "surface_5",
                                                std::string(32, 'x')}));
  cg_close(fn);
}

TEST_F(WrittenFormats, CgnsIsTheSameBytesWrittenASecondLater) {
  // HDF5 stamps its objects with the time in seconds; the writer clears the stamps.
  VolumeMesh m = fixtures::cube();
  m.boundary_names = {{1, "inlet"}};
  m.tet_regions = {1, 1, 1, 2, 2, 2};
  const auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  ASSERT_TRUE(write_volume(m, dir_ / "a.cgns").ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  ASSERT_TRUE(write_volume(m, dir_ / "b.cgns").ok());
  const std::string a = bytes(dir_ / "a.cgns");
  ASSERT_GT(a.size(), 0u);
  EXPECT_TRUE(a == bytes(dir_ / "b.cgns")) << "two writes of one mesh differ";
  int fn = 0, sections = 0;  // HDF5 checks the recomputed checksums when it reads the headers
  ASSERT_EQ(cg_open((dir_ / "b.cgns").c_str(), CG_MODE_READ, &fn), CG_OK) << cg_get_error();
  EXPECT_EQ(cg_nsections(fn, 1, 1, &sections), CG_OK) << cg_get_error();
  EXPECT_EQ(sections, 8) << "two regions and one section per boundary id";
  cg_close(fn);
}

}  // namespace
}  // namespace pdrmesh
