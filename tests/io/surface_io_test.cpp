// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the surface readers and writers: one fixture per format built here,
// write/read round trips, malformed inputs, STL welding and the corpus sphere.
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/validate.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>

namespace pdrmesh {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------- helpers

Result<SurfaceMesh> parse(std::string_view text, SurfaceFormat format) {
  return parse_surface(text, format, "t");
}

/// The error message, or a marker when parsing unexpectedly succeeded.
std::string error_of(const Result<SurfaceMesh>& r) {
  return r.ok() ? std::string("<no error>") : r.status().message();
}

#define EXPECT_ERROR_HAS(result, text)                                     \
  do {                                                                     \
    const auto& r_ = (result);                                             \
    EXPECT_FALSE(r_.ok());                                                 \
    EXPECT_NE(error_of(r_).find(text), std::string::npos) << error_of(r_); \
  } while (false)

/// Renumbers points by first use in the triangle list (the numbering STL reading gives).
SurfaceMesh renumber_by_first_use(const SurfaceMesh& in) {
  SurfaceMesh out;
  out.name = in.name;
  std::vector<Index> map(in.points.size(), kNoIndex);
  for (const Tri& t : in.triangles) {
    Tri n{};
    for (std::size_t k = 0; k < 3; ++k) {
      if (map[t[k]] == kNoIndex) {
        map[t[k]] = static_cast<Index>(out.points.size());
        out.points.push_back(in.points[t[k]]);
      }
      n[k] = map[t[k]];
    }
    out.triangles.push_back(n);
  }
  out.surface_ids = in.surface_ids;
  return out;
}

/// A cube [x0, x0 + h]^3 with outward triangles; the first six triangles get id
/// 1, the other six id 2. Points are numbered by first use.
SurfaceMesh box_surface(double x0 = 0.0, double h = 1.0) {
  SurfaceMesh s;
  for (int i = 0; i < 8; ++i) {
    s.points.push_back({x0 + h * (i & 1), x0 + h * ((i >> 1) & 1), x0 + h * ((i >> 2) & 1)});
  }
  // Quads (outward, counter-clockwise seen from outside), each split in two.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    s.triangles.push_back({Index(q[0]), Index(q[1]), Index(q[2])});
    s.triangles.push_back({Index(q[0]), Index(q[2]), Index(q[3])});
  }
  for (std::size_t i = 0; i < s.triangles.size(); ++i) s.surface_ids.push_back(i < 6 ? 1 : 2);
  return renumber_by_first_use(s);
}

void expect_same(const SurfaceMesh& a, const SurfaceMesh& b, bool ids = true) {
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(std::bit_cast<std::uint64_t>(a.points[i][k]),
                std::bit_cast<std::uint64_t>(b.points[i][k]))
          << "point " << i << " coordinate " << k << ": " << a.points[i][k] << " vs "
          << b.points[i][k];
    }
  }
  EXPECT_EQ(a.triangles, b.triangles);
  if (ids) {
    EXPECT_EQ(a.surface_ids, b.surface_ids);
  }
}

/// Little/big-endian byte writer for binary fixtures.
class Bytes {
 public:
  explicit Bytes(bool big = false) : big_(big) {}
  template <class T>
  Bytes& put(T v) {
    std::array<char, sizeof(T)> b{};
    std::memcpy(b.data(), &v, sizeof(T));
    if (big_ != (std::endian::native == std::endian::big)) std::reverse(b.begin(), b.end());
    s_.append(b.data(), b.size());
    return *this;
  }
  Bytes& text(std::string_view t) {
    s_.append(t);
    return *this;
  }
  const std::string& str() const { return s_; }

 private:
  bool big_;
  std::string s_;
};

std::string binary_stl(const SurfaceMesh& s, std::string_view header = "binary") {
  Bytes b;
  std::string h(header);
  h.resize(80, ' ');
  b.text(h).put(static_cast<std::uint32_t>(s.triangles.size()));
  for (const Tri& t : s.triangles) {
    for (int k = 0; k < 3; ++k) b.put(0.0f);
    for (Index v : t) {
      for (double x : s.points[v]) b.put(static_cast<float>(x));
    }
    b.put(std::uint16_t{0});
  }
  return b.str();
}

/// A unique scratch directory, removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            fmt::format("pdrmesh_surface_io_{}_{}_{}", info->test_suite_name(), info->name(),
                        std::chrono::steady_clock::now().time_since_epoch().count());
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  fs::path file(std::string_view name, std::string_view content) const {
    const fs::path p = path_ / name;
    std::ofstream(p, std::ios::binary) << content;
    return p;
  }
  fs::path operator/(std::string_view name) const { return path_ / name; }

 private:
  fs::path path_;
};

const std::string kTetStl =
    "solid tet\n"
    " facet normal 0 0 -1\n  outer loop\n   vertex 0 0 0\n   vertex 0 1 0\n   vertex 1 0 0\n"
    "  endloop\n endfacet\n"
    " facet normal 0 -1 0\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 0 1\n"
    "  endloop\n endfacet\n"
    " facet normal -1 0 0\n  outer loop\n   vertex 0 0 0\n   vertex 0 0 1\n   vertex 0 1 0\n"
    "  endloop\n endfacet\n"
    " facet normal 1 1 1\n  outer loop\n   vertex 1 0 0\n   vertex 0 1 0\n   vertex 0 0 1\n"
    "  endloop\n endfacet\n"
    "endsolid tet\n";

// ---------------------------------------------------------------- formats

TEST(SurfaceFormat, FromSuffixIgnoresCase) {
  EXPECT_EQ(*surface_format_from_path("a/b.STL"), SurfaceFormat::kStl);
  EXPECT_EQ(*surface_format_from_path("x.Obj"), SurfaceFormat::kObj);
  EXPECT_EQ(*surface_format_from_path("x.off"), SurfaceFormat::kOff);
  EXPECT_EQ(*surface_format_from_path("x.PLY"), SurfaceFormat::kPly);
  EXPECT_EQ(*surface_format_from_path("x.y.mesh"), SurfaceFormat::kMedit);
  EXPECT_EQ(*surface_format_from_path("wing.surf"), SurfaceFormat::kAflr3Surf);
}

TEST(SurfaceFormat, UnknownSuffixIsUnsupported) {
  for (const char* p : {"x.vtk", "x", "stl"}) {
    const auto r = surface_format_from_path(p);
    ASSERT_FALSE(r.ok()) << p;
    EXPECT_EQ(r.status().code(), StatusCode::kUnsupported);
  }
  TempDir dir;
  const auto r = read_surface(dir.file("a.step", kTetStl));
  EXPECT_EQ(r.status().code(), StatusCode::kUnsupported);
  EXPECT_EQ(write_surface(box_surface(), dir / "a.step").code(), StatusCode::kUnsupported);
}

TEST(SurfaceReader, MissingFileIsNotFound) {
  const auto r = read_surface("/nonexistent/dir/none.stl");
  EXPECT_EQ(r.status().code(), StatusCode::kNotFound);
  EXPECT_NE(r.status().message().find("none.stl"), std::string::npos);
}

TEST(SurfaceReader, RejectsEmptyFileInEveryFormat) {
  for (SurfaceFormat f : {SurfaceFormat::kStl, SurfaceFormat::kObj, SurfaceFormat::kOff,
                          SurfaceFormat::kPly, SurfaceFormat::kMedit, SurfaceFormat::kAflr3Surf}) {
    for (const char* text : {"", " \n\n"}) {
      const auto r = parse_surface(text, f, "e.x");
      EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput);
      EXPECT_EQ(r.status().message(), "e.x: empty file");
    }
  }
}

// ---------------------------------------------------------------- STL

TEST(StlReader, ReadsAsciiTetrahedron) {
  TempDir dir;
  const auto r = read_surface(dir.file("tet.stl", kTetStl));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->name, "tet.stl");
  ASSERT_EQ(r->points.size(), 4u);
  EXPECT_EQ(r->triangles.size(), 4u);
  EXPECT_EQ(r->surface_ids, std::vector<int>(4, 1));
  // First appearance order: (0,0,0), (0,1,0), (1,0,0), (0,0,1).
  EXPECT_EQ(r->points[1], (Vec3{0, 1, 0}));
  EXPECT_EQ(r->points[3], (Vec3{0, 0, 1}));
  EXPECT_EQ(r->triangles[3], (Tri{2, 1, 3}));
  EXPECT_NEAR(enclosed_volume(*r), 1.0 / 6.0, 1e-15);
}

TEST(StlReader, EachSolidGetsItsOwnId) {
  // The cube as three solids of 4 triangles each, with upper-case keywords in one.
  const SurfaceMesh c = box_surface();
  std::string text;
  for (int s = 0; s < 3; ++s) {
    text += fmt::format("{} patch_{}\n", s == 1 ? "SOLID" : "solid", s);
    for (int i = 4 * s; i < 4 * s + 4; ++i) {
      text += "facet normal 0 0 0\nouter loop\n";
      for (Index v : c.triangles[i]) {
        text += fmt::format("vertex {} {} {}\n", c.points[v][0], c.points[v][1], c.points[v][2]);
      }
      text += "endloop\nendfacet\n";
    }
    text += s == 1 ? "ENDSOLID\n" : fmt::format("endsolid patch_{}\n", s);
  }
  const auto r = parse(text, SurfaceFormat::kStl);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points.size(), 8u);
  EXPECT_EQ(r->triangles, c.triangles);
  const std::vector<int> ids{1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3};
  EXPECT_EQ(r->surface_ids, ids);
  EXPECT_EQ(r->surface_names, (std::map<int, std::string>{{1, "patch_0"}, {2, "patch_1"}, {3, "patch_2"}}));
}

/// The cube's 12 triangles as ASCII STL solids: `solids[k]` is the header
/// line's name of solid k (empty: "solid" alone), each solid taking the next
/// 12 / solids.size() triangles.
std::string cube_stl(const std::vector<std::string>& solids) {
  const SurfaceMesh c = box_surface();
  const std::size_t per = 12 / solids.size();
  std::string text;
  for (std::size_t s = 0; s < solids.size(); ++s) {
    text += solids[s].empty() ? "solid\n" : fmt::format("solid {}\n", solids[s]);
    for (std::size_t i = per * s; i < per * (s + 1); ++i) {
      text += "facet normal 0 0 0\nouter loop\n";
      for (Index v : c.triangles[i]) text += fmt::format("vertex {} {} {}\n", c.points[v][0], c.points[v][1], c.points[v][2]);
      text += "endloop\nendfacet\n";
    }
    text += "endsolid\n";
  }
  return text;
}

TEST(StlReader, SolidsOfOneNameShareAnIdAndUnnamedSolidsHaveTheirOwn) {
  const auto r = parse(cube_stl({"inlet", "", "wall", "inlet", "", "wall"}), SurfaceFormat::kStl);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->surface_ids, (std::vector<int>{1, 1, 2, 2, 3, 3, 1, 1, 4, 4, 3, 3}));
  EXPECT_EQ(r->surface_names, (std::map<int, std::string>{{1, "inlet"}, {3, "wall"}}));
}

TEST(StlReader, NamesAreMadeSafeIdentifiersAndTheDefaultNamesAreNoNames) {
  // An exporter's header text, a leading digit, a very long name, pdrmesh's own "surface_<id>".
  const auto r = parse(cube_stl({"Exported from Blender-2.93 (v1)", "3d part", std::string(40, 'x'), "surface_4",
                                 "surface_9", "ok.name-1"}),
                       SurfaceFormat::kStl);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->surface_names, (std::map<int, std::string>{{1, "Exported_from_Blender-2.93__v1_"},
                                                          {2, "_3d_part"},
                                                          {3, std::string(32, 'x')},
                                                          {6, "ok.name-1"}}));
}

TEST(StlReader, TwoNamesThatBecomeOneAreAnErrorNamingBoth) {
  EXPECT_ERROR_HAS(parse(cube_stl({"front wall", "front_wall"}), SurfaceFormat::kStl),
                   "t: the solids 'front wall' and 'front_wall' both give the boundary name 'front_wall'");
}

TEST(StlReader, WeldsBinaryCube) {
  // Unwelded input: every facet carries its own three vertices.
  const SurfaceMesh c = box_surface(-0.5, 1.0);
  const std::string bin = binary_stl(c);
  ASSERT_EQ(bin.size(), 84u + 50u * 12u);
  const auto r = parse(bin, SurfaceFormat::kStl);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points.size(), 8u);
  EXPECT_EQ(r->triangles.size(), 12u);
  EXPECT_EQ(r->surface_ids, std::vector<int>(12, 1));
  expect_same(*r, c, /*ids=*/false);
  EXPECT_NEAR(enclosed_volume(*r), 1.0, 1e-12);
}

TEST(StlReader, BinaryWhoseHeaderStartsWithSolid) {
  const auto r = parse(binary_stl(box_surface(), "solid but binary"), SurfaceFormat::kStl);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points.size(), 8u);
}

TEST(StlReader, WeldsPlusAndMinusZeroOnly) {
  // (-0, 0, 0) and (0, 0, 0) are one point; 1 and 1 + 2^-52 are two.
  const std::string text = fmt::format(
      "solid z\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
      "endloop\nendfacet\nfacet normal 0 0 0\nouter loop\nvertex -0.0 0 0\nvertex {} 0 0\n"
      "vertex 0 0 1\nendloop\nendfacet\nendsolid\n",
      1.0 + std::numeric_limits<double>::epsilon());
  const auto r = parse(text, SurfaceFormat::kStl);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points.size(), 5u);
  EXPECT_EQ(r->triangles[1][0], 0u);
  EXPECT_EQ(r->triangles[1][1], 3u);
}

TEST(StlReader, RejectsTruncatedBinary) {
  const std::string bin = binary_stl(box_surface());
  const auto r = parse(std::string_view(bin).substr(0, bin.size() - 7), SurfaceFormat::kStl);
  EXPECT_ERROR_HAS(r,
                   "t: binary STL header announces 12 triangles (684 bytes) but the file has 677");
}

TEST(StlReader, RejectsHugeBinaryHeaderWithoutAllocating) {
  std::string bin = binary_stl(box_surface());
  bin.resize(1000);
  const std::uint32_t huge = 4'000'000'000u;
  std::memcpy(bin.data() + 80, &huge, 4);
  const auto r = parse(bin, SurfaceFormat::kStl);  // refused from the header, before any allocation
  EXPECT_ERROR_HAS(r, "announces 4000000000 triangles");
}

TEST(StlReader, RejectsNonFiniteBinaryCoordinate) {
  std::string bin = binary_stl(box_surface());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(bin.data() + 84 + 50 * 2 + 12 + 12 + 4, &nan, 4);  // facet 3, vertex 2, y
  EXPECT_ERROR_HAS(parse(bin, SurfaceFormat::kStl),
                   "t: byte 208: facet 3 vertex 2 has a non-finite");
}

TEST(StlReader, RejectsMalformedAscii) {
  // Line numbers: the first facet's vertices are on lines 4, 5, 6.
  std::string bad = kTetStl;
  bad.replace(bad.find("vertex 0 1 0"), 6, "vertx");
  EXPECT_ERROR_HAS(parse(bad, SurfaceFormat::kStl), "t:5: expected 'vertex', got 'vertx'");

  bad = kTetStl;
  bad.replace(bad.find("vertex 0 1 0"), 12, "vertex 0 1x 0");
  EXPECT_ERROR_HAS(parse(bad, SurfaceFormat::kStl), "t:5: expected a coordinate, got '1x'");

  bad = kTetStl;
  bad.replace(bad.find("vertex 0 1 0"), 12, "vertex 0 nan 0");
  EXPECT_ERROR_HAS(parse(bad, SurfaceFormat::kStl),
                   "t:5: facet 1 vertex 2 has a non-finite coordinate");

  bad = kTetStl;
  bad.replace(bad.find("vertex 0 1 0"), 12, "vertex 0 1");
  EXPECT_ERROR_HAS(parse(bad, SurfaceFormat::kStl),
                   "t:5: line ends where a coordinate was expected");

  EXPECT_ERROR_HAS(parse(kTetStl.substr(0, 200), SurfaceFormat::kStl), "t:");
  EXPECT_ERROR_HAS(parse(kTetStl.substr(0, kTetStl.find("endsolid")), SurfaceFormat::kStl),
                   "t:30: file ends where 'facet' or 'endsolid' was expected");
  EXPECT_ERROR_HAS(parse("solid empty\nendsolid empty\n", SurfaceFormat::kStl), "t: no triangles");
  EXPECT_ERROR_HAS(parse("garbage", SurfaceFormat::kStl), "too short for a binary STL");
}

// ---------------------------------------------------------------- OBJ

TEST(ObjReader, ReadsQuadsNegativeIndicesAndSlashForms) {
  // The cube as 6 quads: fan-split into 12 triangles, in every index syntax.
  const std::string text =
      "# cube\nmtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
      "v 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1 1.0\nvt 0 0\nvn 0 0 1\ns off\nusemtl m\n"
      "f 1 3 4 2\n"                      // z = 0
      "f 5/1 6/1 8/1 7/1\n"              // z = 1
      "f 1//1 2//1 6//1 5//1\n"          // y = 0
      "f -6/1/1 -2/1/1 -1/1/1 -5/1/1\n"  // y = 1: 3 7 8 4
      "f -8 -4 -2 -6\n"                  // x = 0: 1 5 7 3
      "f 2 4 8 6 # x = 1\n";
  const auto r = parse(text, SurfaceFormat::kObj);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points.size(), 8u);
  ASSERT_EQ(r->triangles.size(), 12u);
  EXPECT_EQ(r->triangles[0], (Tri{0, 2, 3}));
  EXPECT_EQ(r->triangles[1], (Tri{0, 3, 1}));
  EXPECT_EQ(r->triangles[6], (Tri{2, 6, 7}));
  EXPECT_EQ(r->triangles[7], (Tri{2, 7, 3}));
  EXPECT_EQ(r->surface_ids, std::vector<int>(12, 1));
  EXPECT_NEAR(enclosed_volume(*r), 1.0, 1e-15);
}

TEST(ObjReader, GroupsGetIdsInOrderOfFirstUse) {
  const std::string text =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
      "g unused\n"
      "g wall\nf 1 3 2\n"
      "o inlet\nf 1 2 4\n"
      "g wall\nf 1 4 3\n"
      "g outlet\nf 2 3 4\n";
  const auto r = parse(text, SurfaceFormat::kObj);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->surface_ids, (std::vector<int>{1, 2, 1, 3}));
  EXPECT_EQ(r->surface_names, (std::map<int, std::string>{{1, "wall"}, {2, "inlet"}, {3, "outlet"}}));
}

TEST(ObjReader, FacesBeforeAnyGroupAreUnnamedAndCommentsAreNotPartOfAName) {
  const std::string text =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
      "f 1 3 2\n"
      "g nose cone # the front\nf 1 2 4\n"
      "g\nf 1 4 3\n"
      "o tail\nf 2 3 4\n";
  const auto r = parse(text, SurfaceFormat::kObj);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->surface_ids, (std::vector<int>{1, 2, 1, 3}));
  EXPECT_EQ(r->surface_names, (std::map<int, std::string>{{2, "nose_cone"}, {3, "tail"}}));
  EXPECT_ERROR_HAS(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\ng a/b\nf 1 2 3\ng a_b\nf 1 3 2\n", SurfaceFormat::kObj),
                   "the groups 'a/b' and 'a_b' both give the boundary name 'a_b'");
}

TEST(ObjReader, NumbersBeyondDoubleRangeUnderflowToZeroOrAreRejected) {
  const auto r = parse("v 1e-400 -0.5e-999 +2.5\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", SurfaceFormat::kObj);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points[0], (Vec3{0, 0, 2.5}));
  EXPECT_TRUE(std::signbit(r->points[0][1]));
  EXPECT_ERROR_HAS(parse("v 1 -1e999 0\n", SurfaceFormat::kObj),
                   "t:1: point 1 has a non-finite coordinate (1, -inf, 0)");
}

TEST(ObjReader, RejectsMalformedInput) {
  const std::string head = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  EXPECT_ERROR_HAS(parse(head + "f 1 2 4\n", SurfaceFormat::kObj),
                   "t:4: face 1 (points 1, 2, 4): point index 4 out of range (valid: 1..3)");
  EXPECT_ERROR_HAS(parse(head + "f 1 2 3\nf 1 -4 2\n", SurfaceFormat::kObj),
                   "t:5: face 2: relative index -4 reaches before the first point");
  EXPECT_ERROR_HAS(parse(head + "f 1 0 2\n", SurfaceFormat::kObj),
                   "t:4: expected a nonzero point index");
  EXPECT_ERROR_HAS(parse(head + "f 1 2\n", SurfaceFormat::kObj), "t:4: face 1 has 2 point indices");
  EXPECT_ERROR_HAS(parse(head + "f 1 2 x\n", SurfaceFormat::kObj), "got 'x'");
  EXPECT_ERROR_HAS(parse("v 0 0 0\nv 1 inf 0\n", SurfaceFormat::kObj),
                   "t:2: point 2 has a non-finite coordinate (1, inf, 0)");
  EXPECT_ERROR_HAS(parse("v 0 0 0\nv 1 0", SurfaceFormat::kObj),
                   "t:2: file ends where a coordinate");
  EXPECT_ERROR_HAS(parse(head + "frobnicate 1\n", SurfaceFormat::kObj),
                   "t:4: unknown OBJ statement 'frobnicate'");
  EXPECT_ERROR_HAS(parse(head, SurfaceFormat::kObj), "t: no triangles");
}

// ---------------------------------------------------------------- OFF

TEST(OffReader, ReadsPolygonsWithCommentsAndColors) {
  const std::string text =
      "OFF # a cube\n# counts follow\n8 6 12\n"
      "0 0 0\n1 0 0\n0 1 0\n1 1 0\n0 0 1\n1 0 1\n0 1 1\n1 1 1\n"
      "4 0 2 3 1 255 0 0\n4 4 5 7 6\n4 0 1 5 4\n4 2 6 7 3\n4 0 4 6 2\n4 1 3 7 5\n";
  const auto r = parse(text, SurfaceFormat::kOff);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points.size(), 8u);
  EXPECT_EQ(r->triangles.size(), 12u);
  EXPECT_EQ(r->surface_ids, std::vector<int>(12, 1));
  EXPECT_NEAR(enclosed_volume(*r), 1.0, 1e-15);
  // Without the header line, and with the counts on the header line.
  const auto r2 = parse(text.substr(text.find("8 6 12")), SurfaceFormat::kOff);
  ASSERT_TRUE(r2.ok()) << r2.status().to_string();
  expect_same(*r, *r2);
  const auto r3 = parse("OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", SurfaceFormat::kOff);
  ASSERT_TRUE(r3.ok()) << r3.status().to_string();
  EXPECT_EQ(r3->triangles.size(), 1u);
}

TEST(OffReader, RejectsMalformedInput) {
  const std::string tri = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  EXPECT_ERROR_HAS(parse("OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", SurfaceFormat::kOff),
                   "t:7: file ends where face 1 of 1 was expected");
  EXPECT_ERROR_HAS(parse("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", SurfaceFormat::kOff),
                   "t:7: file ends where face 2 of 2 was expected");
  EXPECT_ERROR_HAS(parse(tri + "3 0 2 1\n", SurfaceFormat::kOff),
                   "t:7: unexpected data after the 3 vertices and 1 faces");
  EXPECT_ERROR_HAS(parse("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", SurfaceFormat::kOff),
                   "t:6: face 1 (points 0, 1, 3): point index 3 out of range (valid: 0..2)");
  EXPECT_ERROR_HAS(parse("OFF\n3 1 0\n0 0 0\n1 NaN 0\n0 1 0\n3 0 1 2\n", SurfaceFormat::kOff),
                   "t:4: point 2 has a non-finite coordinate");
  EXPECT_ERROR_HAS(parse("OFF\n3 1 0\n0 0 0\n1 0,5 0\n0 1 0\n3 0 1 2\n", SurfaceFormat::kOff),
                   "t:4: expected a coordinate, got '0,5'");
  EXPECT_ERROR_HAS(parse("OFF\n4000000000 1 0\n0 0 0\n", SurfaceFormat::kOff),
                   "number of vertices = 4000000000 cannot fit");
  EXPECT_ERROR_HAS(
      parse("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n10 0 1 2 0 1 2 0 1 2 7\n", SurfaceFormat::kOff),
      "t:6: face 1 (points 0, 1, 2, 0, 1, 2, 0, 1, ...): point index 7 out of range");
  EXPECT_ERROR_HAS(parse("4OFF\n3 1 0\n", SurfaceFormat::kOff),
                   "OFF variant '4OFF' is not supported");
}

// ---------------------------------------------------------------- PLY

const char* const kPlyAsciiCube =
    "ply\nformat ascii 1.0\ncomment made by hand\n"
    "element vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
    "property list uchar int extra\nproperty uchar red\n"
    "element face 6\nproperty list uchar int vertex_indices\nproperty float quality\n"
    "element edge 1\nproperty int vertex1\nproperty int vertex2\n"
    "end_header\n"
    "0 0 0 2 7 7 255\n1 0 0 0 1\n0 1 0 1 9 2\n1 1 0 0 3\n"
    "0 0 1 0 4\n1 0 1 0 5\n0 1 1 0 6\n1 1 1 0 7\n"
    "4 0 2 3 1 0.5\n4 4 5 7 6 1\n4 0 1 5 4 1\n4 2 6 7 3 1\n4 0 4 6 2 1\n4 1 3 7 5 1\n"
    "0 1\n";

TEST(PlyReader, ReadsAsciiSkippingOtherProperties) {
  const auto r = parse(kPlyAsciiCube, SurfaceFormat::kPly);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points.size(), 8u);
  EXPECT_EQ(r->points[7], (Vec3{1, 1, 1}));
  EXPECT_EQ(r->triangles.size(), 12u);
  EXPECT_EQ(r->surface_ids, std::vector<int>(12, 1));
  EXPECT_NEAR(enclosed_volume(*r), 1.0, 1e-15);
}

/// The cube as binary PLY: double x, ushort flags, float y, list (uchar uchar)
/// junk, int z; faces with an int8 count, uint indices and a surface_id; an
/// extra element before the faces.
std::string binary_ply_cube(bool big) {
  const SurfaceMesh c = box_surface();
  Bytes b(big);
  b.text(
       fmt::format("ply\r\nformat {} 1.0\r\n", big ? "binary_big_endian" : "binary_little_endian"))
      .text("element vertex 8\nproperty double x\nproperty ushort flags\nproperty float y\n")
      .text("property list uchar uchar junk\nproperty int z\n")
      .text("element material 2\nproperty list int short names\n")
      .text("element face 12\nproperty list char uint vertex_index\nproperty short surface_id\n")
      .text("end_header\r\n");
  for (const Vec3& p : c.points) {
    b.put(p[0]).put(std::uint16_t{7}).put(static_cast<float>(p[1]));
    b.put(std::uint8_t{2}).put(std::uint8_t{1}).put(std::uint8_t{2});
    b.put(static_cast<std::int32_t>(p[2]));
  }
  b.put(std::int32_t{1}).put(std::int16_t{-5});
  b.put(std::int32_t{0});
  for (std::size_t i = 0; i < c.triangles.size(); ++i) {
    b.put(std::int8_t{3});
    for (Index v : c.triangles[i]) b.put(static_cast<std::uint32_t>(v));
    b.put(static_cast<std::int16_t>(c.surface_ids[i]));
  }
  return b.str();
}

TEST(PlyReader, ReadsBinaryLittleAndBigEndian) {
  for (bool big : {false, true}) {
    const auto r = parse(binary_ply_cube(big), SurfaceFormat::kPly);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    expect_same(*r, box_surface());
  }
}

TEST(PlyReader, RejectsHugeAndTruncatedBinary) {
  std::string bin = binary_ply_cube(false);
  std::string huge = bin;
  huge.replace(huge.find("vertex 8"), 8, "vertex 4000000000");
  const auto r = parse(huge, SurfaceFormat::kPly);  // refused from the header, before any allocation
  EXPECT_ERROR_HAS(r, "t:3: element 'vertex' count = 4000000000 cannot fit");

  const auto cut = parse(std::string_view(bin).substr(0, bin.size() - 5), SurfaceFormat::kPly);
  EXPECT_ERROR_HAS(cut,
                   fmt::format("t: byte {} (element 'face' record 12): file ends inside the record",
                               bin.size() - 6));
  EXPECT_ERROR_HAS(parse(bin + "x", SurfaceFormat::kPly),
                   fmt::format("t: byte {}: unexpected data after the last element", bin.size()));
}

TEST(PlyReader, RejectsMalformedAscii) {
  const std::string good = kPlyAsciiCube;
  const auto with = [&](std::string_view from, std::string_view to) {
    std::string s = good;
    s.replace(s.find(from), from.size(), to);
    return parse(s, SurfaceFormat::kPly);
  };
  EXPECT_ERROR_HAS(with("1 0 1 0 5", "1 nan 1 0 5"),
                   "t:22 (element 'vertex' record 6): point 6 has a non-finite");
  EXPECT_ERROR_HAS(with("4 0 1 5 4 1", "4 0 1 5 8 1"),
                   "t:27 (element 'face' record 3): face 3 (points 0, 1, 5, 8): point index 8 out "
                   "of range (valid: 0..7)");
  EXPECT_ERROR_HAS(with("1 1 0 0 3", "1 1 zero 0 3"),
                   "t:20 (element 'vertex' record 4): expected a number, got 'zero'");
  EXPECT_ERROR_HAS(with("0 1 0 1 9 2", "0 1 0 1 9 256"),
                   "expected an integer of type uchar, got '256'");
  EXPECT_ERROR_HAS(
      with("element face 6", "element face 7"),
      "t:31 (element 'face' record 7): face 7 has 0 point indices, at least 3 are needed");
  EXPECT_ERROR_HAS(with("element edge 1", "element edge 2"),
                   "t:13: element 'edge' count = 2 cannot fit");
  EXPECT_ERROR_HAS(parse(good.substr(0, good.find("1 1 1 0 7") + 5), SurfaceFormat::kPly),
                   "t:24 (element 'vertex' record 8): file ends where an integer of type uchar");
  EXPECT_ERROR_HAS(with("element face 6", "element face 5"),
                   "t:30: unexpected data after the last element");
  EXPECT_ERROR_HAS(with("vertex_indices", "corners"),
                   "t:10: element 'face' has no list property 'vertex_indices'");
  EXPECT_ERROR_HAS(with("property float z", "property float w"),
                   "element 'vertex' has no scalar property 'z'");
  EXPECT_ERROR_HAS(with("format ascii", "format ebcdic"),
                   "t:2: expected ascii, binary_little_endian");
  EXPECT_ERROR_HAS(with("end_header\n", ""), "t:16: unknown PLY header keyword '0'");
  EXPECT_ERROR_HAS(parse("ply\nformat ascii 1.0\nelement vertex 3\n", SurfaceFormat::kPly),
                   "t:4: file ends before 'end_header'");
  EXPECT_ERROR_HAS(parse("solid x\n", SurfaceFormat::kPly), "t:1: not a PLY file");
}

// ---------------------------------------------------------------- Medit

TEST(MeditReader, ReadsTrianglesQuadsAndSkipsOtherSections) {
  const std::string text =
      "MeshVersionFormatted 2\n# comment\nDimension\n3\n"
      "Vertices\n8\n0 0 0 1\n1 0 0 1\n0 1 0 1\n1 1 0 1\n0 0 1 1\n1 0 1 1\n0 1 1 1\n1 1 1 1\n"
      "Edges\n2\n1 2 0\n2 4 0\n"
      "Corners\n1\n1\nRidges 2 1 2\n"
      "Triangles\n4\n1 3 4 7\n1 4 2 7\n5 6 8 8\n5 8 7 8\n"
      "Normals\n1\n0 0 1\nNormalAtVertices\n1\n1 1\n"
      "Tetrahedra\n1\n1 2 3 5 0\n"
      "Quadrilaterals\n4\n1 2 6 5 9\n3 7 8 4 9\n1 5 7 3 9\n2 4 8 6 9\n"
      "End\n";
  const auto r = parse(text, SurfaceFormat::kMedit);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points.size(), 8u);
  ASSERT_EQ(r->triangles.size(), 12u);
  EXPECT_EQ(r->triangles[4], (Tri{0, 1, 5}));
  EXPECT_EQ(r->triangles[5], (Tri{0, 5, 4}));
  EXPECT_EQ(r->surface_ids, (std::vector<int>{7, 7, 8, 8, 9, 9, 9, 9, 9, 9, 9, 9}));
  EXPECT_NEAR(enclosed_volume(*r), 1.0, 1e-15);
}

TEST(MeditReader, RejectsMalformedInput) {
  const std::string head =
      "MeshVersionFormatted 1\nDimension 3\nVertices\n3\n0 0 0 0\n1 0 0 0\n0 1 0 0\n";
  EXPECT_ERROR_HAS(parse(head + "Triangles\n1\n1 2 4 1\nEnd\n", SurfaceFormat::kMedit),
                   "t:10: triangle 1 (points 1, 2, 4): point index 4 out of range (valid: 1..3)");
  EXPECT_ERROR_HAS(parse(head + "Triangles\n2\n1 2 3 1\n", SurfaceFormat::kMedit),
                   "t:9: number of Triangles = 2 cannot fit in the 10 bytes left");
  EXPECT_ERROR_HAS(parse(head + "Triangles\n2\n1 2 3 1\n1 2   \n\n", SurfaceFormat::kMedit),
                   "t:13: file ends where a point index was expected");
  EXPECT_ERROR_HAS(parse(head + "Triangles\n1\n1 2 3 1\nTriangle\n", SurfaceFormat::kMedit),
                   "t:11: unknown keyword 'Triangle'");
  EXPECT_ERROR_HAS(parse(head + "triangles\n1\n1 2 3 1\n", SurfaceFormat::kMedit),
                   "unknown keyword 'triangles'");
  EXPECT_ERROR_HAS(parse(head + "Triangles\n1\n1 2 x 1\n", SurfaceFormat::kMedit),
                   "t:10: expected a point index, got 'x'");
  EXPECT_ERROR_HAS(parse("Dimension 3\nVertices\n2\n0 0 0 0\n-inf 0 0 0\n", SurfaceFormat::kMedit),
                   "t:5: point 2 has a non-finite coordinate (-inf, 0, 0)");
  EXPECT_ERROR_HAS(parse("Dimension 3\nVertices\n4000000000\n0 0 0 0\n", SurfaceFormat::kMedit),
                   "t:3: number of vertices = 4000000000 cannot fit");
  EXPECT_ERROR_HAS(parse("Dimension 3\nTriangles\n1\n1 2 3 1\n", SurfaceFormat::kMedit),
                   "t:3: Triangles before Vertices");
  const auto r = parse("Dimension 2\n", SurfaceFormat::kMedit);
  EXPECT_EQ(r.status().code(), StatusCode::kUnsupported);
}

// ---------------------------------------------------------------- AFLR3 .surf

TEST(Aflr3SurfReader, ReadsTrianglesQuadsAndExtraColumns) {
  // The cube: 4 triangles (ids 3, 4), 4 quads (id 5) with spacing columns and flags.
  const std::string text =
      "4 4 8\n"
      "0 0 0 0.1\n1 0 0 0.1\n0 1 0\n1 1 0 0.1 7\n0 0 1\n1 0 1\n0 1 1\n1 1 1\n"
      "1 3 4 3 0 0\n1 4 2 3\n5 6 8 4 1 2\n5 8 7\n"
      "1 2 6 5 5 0 0\n3 7 8 4 5\n1 5 7 3 5 0 0\n2 4 8 6 5 0 0\n";
  const auto r = parse(text, SurfaceFormat::kAflr3Surf);
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points.size(), 8u);
  ASSERT_EQ(r->triangles.size(), 12u);
  EXPECT_EQ(r->surface_ids, (std::vector<int>{3, 3, 4, 1, 5, 5, 5, 5, 5, 5, 5, 5}));
  EXPECT_EQ(r->triangles[4], (Tri{0, 1, 5}));
  EXPECT_EQ(r->triangles[5], (Tri{0, 5, 4}));
  EXPECT_NEAR(enclosed_volume(*r), 1.0, 1e-15);
}

TEST(Aflr3SurfReader, RejectsMalformedInput) {
  const std::string nodes = "0 0 0\n1 0 0\n0 1 0\n";
  EXPECT_ERROR_HAS(parse("1 0 3\n" + nodes + "1 2 4 1\n", SurfaceFormat::kAflr3Surf),
                   "t:5: triangle 1 (points 1, 2, 4): point index 4 out of range (valid: 1..3)");
  EXPECT_ERROR_HAS(parse("1 1 3\n" + nodes + "1 2 3 1\n1 2 3 0 1\n", SurfaceFormat::kAflr3Surf),
                   "t:6: quad 1 (points 1, 2, 3, 0): point index 0 out of range");
  EXPECT_ERROR_HAS(parse("2 0 3\n" + nodes + "1 2 3 1\n", SurfaceFormat::kAflr3Surf),
                   "t:6: file ends where triangle 2 of 2 was expected");
  EXPECT_ERROR_HAS(parse("1 0 3\n" + nodes + "1 2 3 1\n1 3 2 1\n", SurfaceFormat::kAflr3Surf),
                   "t:6: unexpected data after the 3 nodes, 1 triangles and 0 quads");
  EXPECT_ERROR_HAS(parse("1 0 3\n0 0 0\n1 0 0\n0 1e999 0\n1 2 3 1\n", SurfaceFormat::kAflr3Surf),
                   "t:4: point 3 has a non-finite coordinate (0, inf, 0)");
  EXPECT_ERROR_HAS(parse("1 0 3\n0 0 0\n1 0 0\n0 nan 0\n1 2 3 1\n", SurfaceFormat::kAflr3Surf),
                   "t:4: point 3 has a non-finite coordinate");
  EXPECT_ERROR_HAS(parse("1 0 3\n" + nodes + "1 2 3 wall\n", SurfaceFormat::kAflr3Surf),
                   "t:5: expected a surface id, got 'wall'");
  EXPECT_ERROR_HAS(parse("1 0 4000000000\n0 0 0\n", SurfaceFormat::kAflr3Surf),
                   "t:1: number of nodes = 4000000000 cannot fit");
}

// ---------------------------------------------------------------- writers

/// A cube with coordinates that print with many digits, ids 1, 2 in first-appearance order.
SurfaceMesh awkward_cube() {
  SurfaceMesh s = box_surface(0.1, 1.0 / 3.0);
  s.points[3][0] = 1e-300;
  s.points[5][2] = 12345678.901234567;
  return s;
}

TEST(SurfaceWriter, RoundTripsEveryFormat) {
  TempDir dir;
  const SurfaceMesh s = awkward_cube();
  for (const char* name : {"c.mesh", "c.surf", "c.ply", "c.obj", "c.stl", "c.off"}) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(write_surface(s, dir / name).ok());
    const auto r = read_surface(dir / name);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    const bool off = std::string_view(name) == "c.off";
    expect_same(*r, s, /*ids=*/!off);
    if (off) {
      EXPECT_EQ(r->surface_ids, std::vector<int>(12, 1));
    }
  }
}

TEST(SurfaceWriter, KeepsUnusedPointsAndArbitraryIdsWhereTheFormatCan) {
  SurfaceMesh s = awkward_cube();
  s.points.push_back({5, 6, 7});  // unused
  for (int& id : s.surface_ids) id = id == 1 ? 42 : -3;
  for (SurfaceFormat f : {SurfaceFormat::kMedit, SurfaceFormat::kAflr3Surf, SurfaceFormat::kPly}) {
    const auto text = format_surface(s, f);
    ASSERT_TRUE(text.ok());
    const auto r = parse_surface(*text, f, "x");
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    expect_same(*r, s);
  }
  // STL: one solid per id in ascending order, so -3 comes back as 1 and 42 as 2.
  const auto stl = parse(*format_surface(s, SurfaceFormat::kStl), SurfaceFormat::kStl);
  ASSERT_TRUE(stl.ok());
  EXPECT_EQ(stl->surface_ids, (std::vector<int>{1, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2}));
  EXPECT_EQ(stl->points.size(), 8u);
}

TEST(SurfaceWriter, StlSolidsAndObjGroupsCarryTheNames) {
  SurfaceMesh s = awkward_cube();
  for (std::size_t i = 0; i < s.surface_ids.size(); ++i) s.surface_ids[i] = i < 4 ? 7 : (i < 8 ? 9 : 12);
  s.surface_names = {{7, "inlet"}, {12, "far.field"}};  // 9 unnamed
  for (SurfaceFormat f : {SurfaceFormat::kStl, SurfaceFormat::kObj}) {
    const auto text = format_surface(s, f);
    ASSERT_TRUE(text.ok());
    const auto r = parse_surface(*text, f, "x");
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    // Ids come back as 1..k (ascending for STL, first use for OBJ: the same here), with their names.
    EXPECT_EQ(r->surface_ids, (std::vector<int>{1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3}));
    EXPECT_EQ(r->surface_names, (std::map<int, std::string>{{1, "inlet"}, {3, "far.field"}}));
  }
}

TEST(SurfaceWriter, RejectsInvalidSurfaces) {
  TempDir dir;
  SurfaceMesh s = box_surface();
  s.points[2][1] = std::nan("");
  EXPECT_EQ(write_surface(s, dir / "x.stl").code(), StatusCode::kInvalidInput);
  s = box_surface();
  s.triangles[4][2] = 8;
  EXPECT_EQ(write_surface(s, dir / "x.obj").code(), StatusCode::kInvalidInput);
  s = box_surface();
  s.surface_ids.pop_back();
  EXPECT_EQ(write_surface(s, dir / "x.mesh").code(), StatusCode::kInvalidInput);
  EXPECT_EQ(write_surface(box_surface(), "/nonexistent/dir/x.mesh").code(), StatusCode::kIoError);
}

// ---------------------------------------------------------------- corpus

TEST(SurfaceReader, CorpusSphereStlAndMeshAgree) {
  const fs::path dir = PDRMESH_CORPUS_DIR;
  const auto stl = read_surface(dir / "sphere966.stl");
  const auto mesh = read_surface(dir / "sphere966.mesh");
  ASSERT_TRUE(stl.ok()) << stl.status().to_string();
  ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
  EXPECT_EQ(stl->points.size(), 926u);
  EXPECT_EQ(stl->triangles.size(), 1848u);
  expect_same(*stl, *mesh);
  EXPECT_GT(enclosed_volume(*stl), 0.0);
}

TEST(SurfaceReader, CorpusStlAndMeshAgreeUpToPointOrder) {
  // Some corpus .mesh files list points in another order than first use.
  const fs::path dir = PDRMESH_CORPUS_DIR;
  for (const char* name : {"bunny_npm", "hinge"}) {
    SCOPED_TRACE(name);
    const auto stl = read_surface(dir / fmt::format("{}.stl", name));
    const auto mesh = read_surface(dir / fmt::format("{}.mesh", name));
    ASSERT_TRUE(stl.ok()) << stl.status().to_string();
    ASSERT_TRUE(mesh.ok()) << mesh.status().to_string();
    expect_same(*stl, renumber_by_first_use(*mesh));
  }
}

}  // namespace
}  // namespace pdrmesh
