// SPDX-License-Identifier: AGPL-3.0-or-later
// VTU encodings (raw, zlib, ascii; what meshio and VTK write), Gmsh 2.2, and
// boundary names through .vtu and .msh.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>
#include <fstream>

#include "octree_fixtures.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_io.hpp"
#include "service/temp_dir.hpp"
#include "tet_fixtures.hpp"

namespace pdrmesh {
namespace {

namespace fs = std::filesystem;

class VolumeNames : public ::testing::Test {
 protected:
  fs::path path(const std::string& name) const { return dir_.path() / name; }
  fs::path write_text(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
    return path(name);
  }
  static std::string slurp(const fs::path& p) { return test::file_bytes(p); }
  test::TempDir dir_;
};

/// A 12^3 Kuhn grid (more than one 32 KiB zlib block per array) with awkward
/// coordinates, four boundary ids, regions and names (one with markup and
/// non-ASCII bytes). Valid.
VolumeMesh named_grid() {
  VolumeMesh m = fixtures::with_hull_boundary(fixtures::kuhn_grid(12));
  for (Vec3& p : m.points) p = {p[0] / 3.0 + 1e-17, p[1] * 1e-300 * 1e300, p[2] + 0.1};
  for (std::size_t i = 0; i < m.boundary_ids.size(); ++i) m.boundary_ids[i] = 1 + static_cast<int>(i % 4);
  for (std::size_t t = 0; t < m.tets.size(); ++t) m.tet_regions.push_back(static_cast<int>(t % 3) - 1);
  m.boundary_names = {{1, "inlet"}, {2, "wall <a & \"b\">"}, {4, "s\xc3\xbc" "d"}};
  return m;
}

void expect_same(const VolumeMesh& want, const VolumeMesh& got) {
  ASSERT_EQ(want.points.size(), got.points.size());
  EXPECT_EQ(std::memcmp(want.points.data(), got.points.data(), want.points.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(want.tets, got.tets);
  EXPECT_EQ(want.boundary, got.boundary);
  EXPECT_EQ(want.boundary_ids, got.boundary_ids);
  EXPECT_EQ(want.tet_regions, got.tet_regions);
  EXPECT_EQ(want.boundary_names, got.boundary_names);
}

TEST_F(VolumeNames, VtuRoundTripsEveryEncodingWithNames) {
  const VolumeMesh m = named_grid();
  ASSERT_TRUE(validate_mesh(m).ok()) << format_validation(validate_mesh(m));
  std::size_t raw_size = 0;
  for (const auto& [encoding, marker] : {std::pair{VtuEncoding::kBinary, "<AppendedData encoding=\"raw\">"},
                                         std::pair{VtuEncoding::kCompressed, "compressor=\"vtkZLibDataCompressor\""},
                                         std::pair{VtuEncoding::kAscii, "format=\"ascii\""}}) {
    SCOPED_TRACE(static_cast<int>(encoding));
    const fs::path p = path("grid.vtu");
    ASSERT_TRUE(write_volume(m, p, {encoding}).ok());
    const std::string bytes = slurp(p);
    EXPECT_NE(bytes.find(marker), std::string::npos);
    EXPECT_NE(bytes.find("Name=\"boundary_names\""), std::string::npos);
    if (encoding == VtuEncoding::kBinary) raw_size = bytes.size();
    if (encoding == VtuEncoding::kCompressed) {
      EXPECT_LT(bytes.size(), raw_size);
    }
    if (encoding == VtuEncoding::kAscii) {
      EXPECT_EQ(bytes.find("AppendedData"), std::string::npos);
    }
    const auto r = read_volume(p);
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    expect_same(m, *r);
  }
}

TEST_F(VolumeNames, VtuWritesTheSameBytesTwice) {
  const VolumeMesh m = named_grid();
  for (VtuEncoding e : {VtuEncoding::kBinary, VtuEncoding::kCompressed, VtuEncoding::kAscii}) {
    ASSERT_TRUE(write_volume(m, path("a.vtu"), {e}).ok());
    ASSERT_TRUE(write_volume(m, path("b.vtu"), {e}).ok());
    EXPECT_EQ(slurp(path("a.vtu")), slurp(path("b.vtu")));
  }
}

// ---------------------------------------------------------------- files as other writers make them

std::string base64(std::string_view bytes) {
  static const char* kDigits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    std::uint32_t w = static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i])) << 16;
    if (i + 1 < bytes.size()) w |= static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i + 1])) << 8;
    if (i + 2 < bytes.size()) w |= static_cast<unsigned char>(bytes[i + 2]);
    out += kDigits[(w >> 18) & 63];
    out += kDigits[(w >> 12) & 63];
    out += i + 1 < bytes.size() ? kDigits[(w >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kDigits[w & 63] : '=';
  }
  return out;
}

/// How a test file stores its arrays.
struct Style {
  std::string_view format;  ///< "binary" (inline base64), "appended raw", "appended base64"
  bool zlib = false;
  bool header32 = false;  ///< UInt32 headers (the default when header_type is absent)
  bool big = false;       ///< BigEndian
  bool float32 = false;   ///< Float32 points, Int32 connectivity
};

template <class T>
void put_value(std::string& out, T v, bool big) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

void put_header(std::string& out, std::uint64_t v, const Style& s) {
  if (s.header32) put_value(out, static_cast<std::uint32_t>(v), s.big);
  else put_value(out, v, s.big);
}

/// An array's header and body: one length, or zlib blocks of 40 bytes (several per array).
std::pair<std::string, std::string> pack(const std::string& data, const Style& s) {
  std::string head, body;
  if (!s.zlib) {
    put_header(head, data.size(), s);
    return {head, data};
  }
  constexpr std::size_t kBlock = 40;
  const std::size_t blocks = (data.size() + kBlock - 1) / kBlock;
  put_header(head, blocks, s);
  put_header(head, kBlock, s);
  put_header(head, data.size() % kBlock, s);
  for (std::size_t k = 0; k < blocks; ++k) {
    const std::string block = data.substr(k * kBlock, kBlock);
    uLongf size = compressBound(static_cast<uLong>(block.size()));
    std::string z(size, '\0');
    EXPECT_EQ(compress(reinterpret_cast<Bytef*>(z.data()), &size, reinterpret_cast<const Bytef*>(block.data()),
                       static_cast<uLong>(block.size())),
              Z_OK);
    z.resize(size);
    put_header(head, z.size(), s);
    body += z;
  }
  return {head, body};
}

/// `mesh` (tets and triangles, surface ids) as a .vtu in `style`, laid out
/// as meshio and VTK do: meshio's inline uncompressed data is one base64
/// stream, compressed data and VTK's appended base64 encode the header apart.
std::string foreign_vtu(const VolumeMesh& mesh, const Style& s) {
  struct Array {
    std::string attributes, data;
  };
  std::vector<Array> arrays;
  std::string pts, conn, offs, types, ids;
  for (const Vec3& p : mesh.points)
    for (double c : p) s.float32 ? put_value(pts, static_cast<float>(c), s.big) : put_value(pts, c, s.big);
  std::int64_t offset = 0;
  auto put_index = [&](Index v) { s.float32 ? put_value(conn, static_cast<std::int32_t>(v), s.big) : put_value(conn, static_cast<std::int64_t>(v), s.big); };
  for (const Tet& t : mesh.tets) {
    for (Index v : t) put_index(v);
    put_value(offs, offset += 4, s.big);
    types += char{10};
    put_value(ids, std::int32_t{0}, s.big);
  }
  for (std::size_t i = 0; i < mesh.boundary.size(); ++i) {
    for (Index v : mesh.boundary[i]) put_index(v);
    put_value(offs, offset += 3, s.big);
    types += char{5};
    put_value(ids, static_cast<std::int32_t>(mesh.boundary_ids[i]), s.big);
  }
  const std::string ftype = s.float32 ? "Float32" : "Float64", itype = s.float32 ? "Int32" : "Int64";
  arrays = {{"type=\"" + ftype + "\" Name=\"points\" NumberOfComponents=\"3\"", pts},
            {"type=\"" + itype + "\" Name=\"connectivity\"", conn},
            {"type=\"Int64\" Name=\"offsets\"", offs},
            {"type=\"UInt8\" Name=\"types\"", types},
            {"type=\"Int32\" Name=\"surface_id\"", ids}};
  std::vector<std::string> tags;
  std::string appended;
  for (const Array& a : arrays) {
    const auto [head, body] = pack(a.data, s);
    if (s.format == "binary") {
      const std::string text = s.zlib ? base64(head) + base64(body) : base64(head + body);
      tags.push_back(fmt::format("<DataArray {} format=\"binary\">\n{}\n</DataArray>", a.attributes, text));
    } else {
      tags.push_back(fmt::format("<DataArray {} format=\"appended\" offset=\"{}\"/>", a.attributes, appended.size()));
      appended += s.format == "appended raw" ? head + body : base64(head) + base64(body);
    }
  }
  std::string f = fmt::format("<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"{}\"{}{}>\n"
                              "<UnstructuredGrid>\n<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n",
                              s.big ? "BigEndian" : "LittleEndian", s.header32 ? "" : " header_type=\"UInt64\"",
                              s.zlib ? " compressor=\"vtkZLibDataCompressor\"" : "", mesh.points.size(),
                              mesh.tets.size() + mesh.boundary.size());
  f += "<Points>\n" + tags[0] + "\n</Points>\n<Cells>\n" + tags[1] + "\n" + tags[2] + "\n" + tags[3] +
       "\n</Cells>\n<CellData>\n" + tags[4] + "\n</CellData>\n</Piece>\n</UnstructuredGrid>\n";
  if (s.format != "binary")
    f += fmt::format("<AppendedData encoding=\"{}\">\n _{}\n</AppendedData>\n", s.format == "appended raw" ? "raw" : "base64",
                     appended);
  return f + "</VTKFile>\n";
}

TEST_F(VolumeNames, VtuReadsWhatMeshioAndVtkWrite) {
  const VolumeMesh m = fixtures::cube();
  ASSERT_TRUE(validate_mesh(m).ok());
  const Style styles[] = {
      {"binary", false, false, false, false},         // meshio's default: inline base64, UInt32 headers
      {"binary", true, false, false, false},          // meshio with compression
      {"binary", true, true, false, true},            // Float32 points, Int32 connectivity
      {"appended base64", false, false, false, false},
      {"appended base64", true, true, false, false},  // ParaView's "appended, encoded"
      {"appended raw", false, true, false, false},
      {"appended raw", true, false, true, false},     // big endian
      {"appended raw", false, true, true, true},
  };
  for (const Style& s : styles) {
    SCOPED_TRACE(fmt::format("{} zlib={} header32={} big={} float32={}", s.format, s.zlib, s.header32, s.big, s.float32));
    const auto r = read_volume(write_text("foreign.vtu", foreign_vtu(m, s)));
    ASSERT_TRUE(r.ok()) << r.status().to_string();
    EXPECT_EQ(r->points, m.points);
    EXPECT_EQ(r->tets, m.tets);
    EXPECT_EQ(r->boundary, m.boundary);
    EXPECT_EQ(r->boundary_ids, m.boundary_ids);
  }
}

TEST_F(VolumeNames, VtuRejectsDamagedBinaryData) {
  const VolumeMesh m = named_grid();
  for (VtuEncoding e : {VtuEncoding::kBinary, VtuEncoding::kCompressed}) {
    SCOPED_TRACE(static_cast<int>(e));
    ASSERT_TRUE(write_volume(m, path("good.vtu"), {e}).ok());
    const std::string good = slurp(path("good.vtu"));
    const std::size_t data = good.find('_', good.find("<AppendedData")) + 1;
    // Cut anywhere inside the data: an error naming the file, never a crash.
    const std::string tail = "\n  </AppendedData>\n</VTKFile>\n";
    for (std::size_t cut = data; cut < good.size() - tail.size(); cut += (good.size() - data) / 97 + 1) {
      const auto r = read_volume(write_text("cut.vtu", good.substr(0, cut)));
      ASSERT_FALSE(r.ok()) << "cut at " << cut;
      EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput) << r.status().to_string();
      EXPECT_NE(r.status().message().find("cut.vtu:"), std::string::npos) << r.status().to_string();
    }
    // A wrong length in the first header.
    std::string bad = good;
    bad[data] = static_cast<char>(bad[data] ^ 0x10);
    auto r = read_volume(write_text("header.vtu", bad));
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(r.status().message().find("'Points'"), std::string::npos) << r.status().to_string();
    if (e == VtuEncoding::kCompressed) {
      // A damaged byte inside the first compressed block: zlib's checksum says so.
      bad = good;
      const std::size_t blocks = 2;  // Points: 3 * 13^3 doubles in 32 KiB blocks
      bad[data + 8 * (3 + blocks) + 40] = static_cast<char>(bad[data + 8 * (3 + blocks) + 40] ^ 0x55);
      r = read_volume(write_text("zlib.vtu", bad));
      ASSERT_FALSE(r.ok());
      EXPECT_NE(r.status().message().find("damaged"), std::string::npos) << r.status().to_string();
    }
  }
  const Style inline_style{"binary", false, false, false, false};
  std::string text = foreign_vtu(fixtures::cube(), inline_style);
  text.insert(text.find("format=\"binary\">\n") + 18, "*");
  const auto r = read_volume(write_text("base64.vtu", text));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("base64"), std::string::npos) << r.status().to_string();
  std::string lz4 = foreign_vtu(fixtures::cube(), {"appended raw", false, false, false, false});
  lz4.replace(lz4.find("version=\"0.1\""), 8, "compressor=\"vtkLZ4DataCompressor\" version=");
  const auto u = read_volume(write_text("lz4.vtu", lz4));
  ASSERT_FALSE(u.ok());
  EXPECT_EQ(u.status().code(), StatusCode::kUnsupported) << u.status().to_string();
  EXPECT_NE(u.status().message().find("vtkLZ4DataCompressor"), std::string::npos);
}

// ---------------------------------------------------------------- Gmsh

TEST_F(VolumeNames, GmshRoundTripsNamesAsPhysicalNames) {
  VolumeMesh m = fixtures::cube();
  m.boundary_names = {{1, "inlet"}, {4, "far \"field\""}};
  ASSERT_TRUE(write_volume(m, path("named.msh")).ok());
  const std::string text = slurp(path("named.msh"));
  EXPECT_NE(text.find("2 1 \"inlet\"\n"), std::string::npos) << text;
  EXPECT_NE(text.find("2 2 \"surface_2\"\n"), std::string::npos);
  const auto r = read_volume(path("named.msh"));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->boundary_ids, m.boundary_ids);
  EXPECT_EQ(r->boundary, m.boundary);
  const std::map<int, std::string> want{{1, "inlet"}, {4, "far 'field'"}};  // Gmsh names hold no double quote
  EXPECT_EQ(r->boundary_names, want);
}

TEST_F(VolumeNames, GmshReadsFormat22) {
  // As Gmsh 4 writes with -format msh22: physical and elementary tags per
  // element, node tags out of order, a point and a line element to skip.
  const std::string text =
      "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n3\n2 3 \"outlet\"\n2 8 \"surface_5\"\n3 9 \"fluid\"\n"
      "$EndPhysicalNames\n$Nodes\n4\n40 0 0 1\n10 0 0 0\n20 1 0 0\n30 0 1 0\n$EndNodes\n"
      "$Elements\n6\n1 15 2 0 1 10\n2 1 2 0 1 10 20\n3 4 2 9 1 10 20 30 40\n4 2 2 3 1 10 30 20\n"
      "5 2 2 8 2 10 20 40\n6 2 0 20 30 40\n$EndElements\n";
  const auto r = read_volume(write_text("v22.msh", text));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points, (std::vector<Vec3>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}));
  EXPECT_EQ(r->tets, (std::vector<Tet>{{0, 1, 2, 3}}));
  EXPECT_EQ(r->boundary, (std::vector<Tri>{{0, 2, 1}, {0, 1, 3}, {1, 2, 3}}));
  EXPECT_EQ(r->boundary_ids, (std::vector<int>{3, 5, 0}));  // physical tag, "surface_<id>", no tags at all
  EXPECT_EQ(r->boundary_names, (std::map<int, std::string>{{3, "outlet"}}));
  EXPECT_TRUE(r->tet_regions.empty());

  const auto bad = read_volume(write_text("bad22.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n"
                                                       "$EndNodes\n$Elements\n1\n1 2 2 1 1 1 1 7\n$EndElements\n"));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("bad22.msh:10:"), std::string::npos) << bad.status().to_string();
  const auto hex = read_volume(write_text("hex22.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n0\n$EndNodes\n"
                                                       "$Elements\n1\n1 5 0 1 2 3 4 5 6 7 8\n$EndElements\n"));
  ASSERT_FALSE(hex.ok());
  EXPECT_EQ(hex.status().code(), StatusCode::kUnsupported) << hex.status().to_string();
}

TEST_F(VolumeNames, GmshReadsBinaryFormat22) {
  // As Gmsh writes with -format msh22 -bin: an int32 1 for the byte order,
  // nodes as (int32 tag, 3 float64), elements in blocks headed (type, count, ntags).
  std::string b = "$MeshFormat\n2.2 1 8\n";
  auto i32 = [&b](std::int32_t v) { b.append(reinterpret_cast<const char*>(&v), 4); };
  i32(1);
  b += "\n$EndMeshFormat\n$PhysicalNames\n1\n2 7 \"wall\"\n$EndPhysicalNames\n$Nodes\n4\n";
  const double xyz[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1.0 / 3.0}};
  for (int i = 0; i < 4; ++i) {
    i32(i + 1);
    b.append(reinterpret_cast<const char*>(xyz[i]), 24);
  }
  b += "\n$EndNodes\n$Elements\n3\n";
  for (std::int32_t v : {4, 1, 2, 1, 3, 1, 1, 2, 3, 4}) i32(v);         // one tet, physical 3
  for (std::int32_t v : {2, 2, 2, 2, 7, 1, 1, 3, 2, 3, 7, 1, 1, 2, 4}) i32(v);  // two triangles, physical 7
  b += "\n$EndElements\n";
  const auto r = read_volume(write_text("bin22.msh", b));
  ASSERT_TRUE(r.ok()) << r.status().to_string();
  EXPECT_EQ(r->points, (std::vector<Vec3>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1.0 / 3.0}}));
  EXPECT_EQ(r->tets, (std::vector<Tet>{{0, 1, 2, 3}}));
  EXPECT_EQ(r->boundary, (std::vector<Tri>{{0, 2, 1}, {0, 1, 3}}));
  EXPECT_EQ(r->boundary_ids, (std::vector<int>{7, 7}));
  EXPECT_EQ(r->boundary_names, (std::map<int, std::string>{{7, "wall"}}));
  // Cut short anywhere after the header: a clear error, never a crash (a
  // file that ends right after $EndNodes is a mesh without elements).
  const std::size_t end_nodes = b.find("$EndNodes") + 9;
  for (std::size_t cut = 24; cut + 14 < b.size(); ++cut) {
    if (cut == end_nodes || cut == end_nodes + 1) continue;
    const auto c = read_volume(write_text("cut22.msh", b.substr(0, cut)));
    EXPECT_FALSE(c.ok()) << "cut at " << cut;
  }
}

}  // namespace
}  // namespace pdrmesh
