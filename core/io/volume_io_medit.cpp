// SPDX-License-Identifier: AGPL-3.0-or-later
// Medit volume meshes: ASCII .mesh and libMeshb binary .meshb.
//
// Triangles carry the surface id as their ref, tetrahedra the region (0 when
// the mesh has none); a mixed mesh adds Prisms and Pyramids (ref 0). Medit tets use the same positive orientation as VTK
// (refine's ref_import.c reads GmfTetrahedra unchanged and its validation
// rejects tets with negative volume).
//
// .meshb layout (LoicMarechal/libMeshb, libmeshb7.c GmfOpenMesh/GmfSetKwd):
//   int32 1 (byte-order mark), int32 version;
//   then keyword blocks: int32 code, position of the next keyword (int32 for
//   version 1-2, int64 for 3-4; 0 for the last), the line count (int32 up to
//   version 3, int64 for 4; absent for Dimension and End), then the records.
//   Reals are float for version 1, double otherwise; record integers are
//   int32 up to version 3, int64 for version 4. Codes: Dimension 3,
//   Vertices 4, Triangles 6, Quadrilaterals 7, Tetrahedra 8, Prisms 9,
//   Hexahedra 10, Pyramids 49, End 54.
#include <fmt/compile.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <limits>

#include "volume_io_detail.hpp"

namespace pdrmesh::volio {
namespace {

constexpr int kKwDimension = 3;
constexpr int kKwVertices = 4;
constexpr int kKwTriangles = 6;
constexpr int kKwQuadrilaterals = 7;
constexpr int kKwTetrahedra = 8;
constexpr int kKwPrisms = 9;
constexpr int kKwHexahedra = 10;
constexpr int kKwPyramids = 49;
constexpr int kKwEnd = 54;

/// The element refs of every kind of cell: their regions, all zero when the
/// mesh has none (VolumeMesh::tet_regions, prism_regions, pyramid_regions).
struct CellRefs {
  std::vector<int> tets, prisms, pyramids;
  void set_regions(VolumeMesh& mesh) {
    const auto zero = [](const std::vector<int>& refs) {
      return std::all_of(refs.begin(), refs.end(), [](int r) { return r == 0; });
    };
    if (zero(tets) && zero(prisms) && zero(pyramids)) return;
    tets.resize(mesh.tets.size());
    prisms.resize(mesh.prisms.size());
    pyramids.resize(mesh.pyramids.size());
    mesh.tet_regions = std::move(tets);
    mesh.prism_regions = std::move(prisms);
    mesh.pyramid_regions = std::move(pyramids);
  }
};

/// Cell i's ref: its region, 0 in a mesh without regions.
int ref_of(const std::vector<int>& regions, std::size_t i) { return regions.empty() ? 0 : regions[i]; }
int tet_ref(const VolumeMesh& mesh, std::size_t t) { return ref_of(mesh.tet_regions, t); }

bool starts_alpha(std::string_view t) { return !t.empty() && std::isalpha(static_cast<unsigned char>(t[0])); }

}  // namespace

// ---------------------------------------------------------------- ASCII

Status write_medit(const VolumeMesh& mesh, const std::filesystem::path& path) {
  OutputFile out(path);
  PDR_TRY(out.open());
  auto& buf = out.buf();
  auto it = std::back_inserter(buf);
  fmt::format_to(it, "MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n{}\n", mesh.points.size());
  for (const Vec3& p : mesh.points) {
    fmt::format_to(it, FMT_COMPILE("{} {} {} 0\n"), p[0], p[1], p[2]);
    PDR_TRY(out.maybe_flush());
  }
  if (!mesh.boundary.empty()) {
    fmt::format_to(it, "\nTriangles\n{}\n", mesh.boundary.size());
    for (std::size_t i = 0; i < mesh.boundary.size(); ++i) {
      const Tri& t = mesh.boundary[i];
      fmt::format_to(it, FMT_COMPILE("{} {} {} {}\n"), t[0] + 1, t[1] + 1, t[2] + 1, mesh.boundary_ids[i]);
      PDR_TRY(out.maybe_flush());
    }
  }
  if (!mesh.tets.empty()) {
    fmt::format_to(it, "\nTetrahedra\n{}\n", mesh.tets.size());
    for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
      const Tet& t = mesh.tets[i];
      fmt::format_to(it, FMT_COMPILE("{} {} {} {} {}\n"), t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1,
                     tet_ref(mesh, i));
      PDR_TRY(out.maybe_flush());
    }
  }
  // Prisms and pyramids in our vertex order (mixed_cells.hpp), which Gmsh reads unpermuted, ref their region.
  const auto cells = [&](const char* name, const auto& list, const std::vector<int>& regions) -> Status {
    if (list.empty()) return {};
    fmt::format_to(it, "\n{}\n{}\n", name, list.size());
    for (std::size_t i = 0; i < list.size(); ++i) {
      put_cell(buf, list[i], 1);
      fmt::format_to(it, FMT_COMPILE(" {}\n"), ref_of(regions, i));
      PDR_TRY(out.maybe_flush());
    }
    return {};
  };
  PDR_TRY(cells("Prisms", mesh.prisms, mesh.prism_regions));
  PDR_TRY(cells("Pyramids", mesh.pyramids, mesh.pyramid_regions));
  fmt::format_to(it, "\nEnd\n");
  return out.close();
}

Result<VolumeMesh> read_medit(std::string_view text, const std::string& name) {
  TextScanner in(text, name, '#');
  VolumeMesh mesh;
  CellRefs refs;
  bool have_vertices = false, have_triangles = false, have_tets = false;
  for (;;) {
    const std::string_view kw = in.next();
    if (kw.empty()) break;  // a missing End is tolerated
    if (iequals(kw, "End")) break;
    if (iequals(kw, "MeshVersionFormatted")) {
      int version = 0;
      PDR_TRY(in.integer(version, "mesh version"));
      if (version < 1 || version > 4) return in.error(fmt::format("unknown MeshVersionFormatted {}", version));
    } else if (iequals(kw, "Dimension")) {
      int dim = 0;
      PDR_TRY(in.integer(dim, "dimension"));
      if (dim != 3) return unsupported(fmt::format("{}:{}: only 3D meshes are read (Dimension {})", name,
                                                   in.line_at(in.last_token_start()), dim));
    } else if (iequals(kw, "Vertices")) {
      if (have_vertices) return in.error("second Vertices section");
      have_vertices = true;
      std::size_t n = 0;
      PDR_TRY(in.count(n, 4, "vertex count"));
      mesh.points.resize(n);
      std::int64_t ref = 0;
      for (Vec3& p : mesh.points) {
        PDR_TRY(in.real(p[0], "vertex x"));
        PDR_TRY(in.real(p[1], "vertex y"));
        PDR_TRY(in.real(p[2], "vertex z"));
        PDR_TRY(in.integer(ref, "vertex ref"));
      }
    } else if (iequals(kw, "Triangles")) {
      if (!have_vertices) return in.error("Triangles before Vertices");
      if (have_triangles) return in.error("second Triangles section");
      have_triangles = true;
      std::size_t n = 0;
      PDR_TRY(in.count(n, 4, "triangle count"));
      mesh.boundary.resize(n);
      mesh.boundary_ids.resize(n);
      const std::size_t np = mesh.points.size();
      for (std::size_t i = 0; i < n; ++i) {
        for (Index& v : mesh.boundary[i]) PDR_TRY(in.index(v, 1, np, "triangle vertex"));
        PDR_TRY(in.integer(mesh.boundary_ids[i], "triangle ref"));
      }
    } else if (iequals(kw, "Tetrahedra")) {
      if (!have_vertices) return in.error("Tetrahedra before Vertices");
      if (have_tets) return in.error("second Tetrahedra section");
      have_tets = true;
      std::size_t n = 0;
      PDR_TRY(in.count(n, 5, "tetrahedron count"));
      mesh.tets.resize(n);
      refs.tets.resize(n);
      const std::size_t np = mesh.points.size();
      for (std::size_t i = 0; i < n; ++i) {
        for (Index& v : mesh.tets[i]) PDR_TRY(in.index(v, 1, np, "tetrahedron vertex"));
        PDR_TRY(in.integer(refs.tets[i], "tetrahedron ref"));
      }
    } else if (iequals(kw, "Prisms") || iequals(kw, "Pyramids")) {
      if (!have_vertices) return in.error(fmt::format("{} before Vertices", std::string(kw)));
      const bool prisms = iequals(kw, "Prisms");
      if (prisms ? !mesh.prisms.empty() : !mesh.pyramids.empty())
        return in.error(fmt::format("second {} section", std::string(kw)));
      std::size_t n = 0;
      PDR_TRY(in.count(n, prisms ? 7 : 6, "element count"));
      const std::size_t np = mesh.points.size();
      std::vector<int>& cell_refs = prisms ? refs.prisms : refs.pyramids;
      cell_refs.resize(n);
      if (prisms) mesh.prisms.resize(n);
      else mesh.pyramids.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        if (prisms)
          for (Index& v : mesh.prisms[i]) PDR_TRY(in.index(v, 1, np, "prism vertex"));
        else
          for (Index& v : mesh.pyramids[i]) PDR_TRY(in.index(v, 1, np, "pyramid vertex"));
        PDR_TRY(in.integer(cell_refs[i], "element ref"));
      }
    } else if (iequals(kw, "Quadrilaterals") || iequals(kw, "Hexahedra")) {
      const std::size_t at = in.last_token_start();
      std::size_t n = 0;
      PDR_TRY(in.count(n, 1, "element count"));
      if (n > 0)
        return unsupported(fmt::format("{}:{}: {} {}: only tetrahedral meshes are read", name, in.line_at(at),
                                       n, std::string(kw)));
    } else if (starts_alpha(kw)) {
      // An unknown section: skip its data up to the next keyword.
      while (!in.peek().empty() && !starts_alpha(in.peek())) in.next();
    } else {
      return in.error(fmt::format("expected a section keyword, got {}", show(kw)));
    }
  }
  if (!have_vertices) return invalid_input(fmt::format("{}: no Vertices section", name));
  refs.set_regions(mesh);
  return mesh;
}

// ---------------------------------------------------------------- binary

Status write_meshb(const VolumeMesh& mesh, const std::filesystem::path& path) {
  const std::uint64_t np = mesh.points.size(), nb = mesh.boundary.size(), nt = mesh.tets.size(),
                      nq = mesh.prisms.size(), ny = mesh.pyramids.size();
  // Version 2 (32-bit positions) unless the file outgrows them; then version 3.
  auto total = [&](std::uint64_t pos_bytes) {
    std::uint64_t s = 8 + (8 + pos_bytes) + (8 + pos_bytes + np * 28) + (4 + pos_bytes);
    if (nb > 0) s += 8 + pos_bytes + nb * 16;
    if (nt > 0) s += 8 + pos_bytes + nt * 20;
    if (nq > 0) s += 8 + pos_bytes + nq * 28;
    if (ny > 0) s += 8 + pos_bytes + ny * 24;
    return s;
  };
  const bool v3 = total(4) > static_cast<std::uint64_t>(std::numeric_limits<std::int32_t>::max());
  const std::int32_t version = v3 ? 3 : 2;
  const std::uint64_t pos_bytes = v3 ? 8 : 4;

  OutputFile out(path);
  PDR_TRY(out.open());
  auto& buf = out.buf();
  constexpr bool kLittle = kHostLittle;  // libMeshb writes native order; readers detect it
  std::uint64_t offset = 0;              // bytes written so far
  auto keyword = [&](std::int32_t code, std::uint64_t body_bytes, bool last) {
    const std::uint64_t next = last ? 0 : offset + 4 + pos_bytes + body_bytes;
    put(buf, code, kLittle);
    if (v3) put(buf, static_cast<std::int64_t>(next), kLittle);
    else put(buf, static_cast<std::int32_t>(next), kLittle);
    offset += 4 + pos_bytes + body_bytes;
  };
  put(buf, std::int32_t{1}, kLittle);
  put(buf, version, kLittle);
  offset = 8;
  keyword(kKwDimension, 4, false);
  put(buf, std::int32_t{3}, kLittle);

  // The records in native order (libMeshb's), each of fixed size.
  const auto store = [](char*& at, auto v) {
    std::memcpy(at, &v, sizeof(v));
    at += sizeof(v);
  };
  keyword(kKwVertices, 4 + np * 28, false);
  put(buf, static_cast<std::int32_t>(np), kLittle);
  PDR_TRY(out.fixed_records(np, 28, [&](std::size_t i, char* at) {
    for (double x : mesh.points[i]) store(at, x);
    store(at, std::int32_t{0});
  }));
  if (nb > 0) {
    keyword(kKwTriangles, 4 + nb * 16, false);
    put(buf, static_cast<std::int32_t>(nb), kLittle);
    PDR_TRY(out.fixed_records(nb, 16, [&](std::size_t i, char* at) {
      for (Index v : mesh.boundary[i]) store(at, static_cast<std::int32_t>(v + 1));
      store(at, static_cast<std::int32_t>(mesh.boundary_ids[i]));
    }));
  }
  if (nt > 0) {
    keyword(kKwTetrahedra, 4 + nt * 20, false);
    put(buf, static_cast<std::int32_t>(nt), kLittle);
    PDR_TRY(out.fixed_records(nt, 20, [&](std::size_t i, char* at) {
      for (Index v : mesh.tets[i]) store(at, static_cast<std::int32_t>(v + 1));
      store(at, static_cast<std::int32_t>(tet_ref(mesh, i)));
    }));
  }
  // Prisms and pyramids in the ASCII writer's vertex order, ref their region.
  const auto cells = [&](std::int32_t code, const auto& list, const std::vector<int>& regions) -> Status {
    if (list.empty()) return {};
    keyword(code, 4 + list.size() * 4 * (list[0].size() + 1), false);
    put(buf, static_cast<std::int32_t>(list.size()), kLittle);
    for (std::size_t i = 0; i < list.size(); ++i) {
      for (Index v : list[i]) put(buf, static_cast<std::int32_t>(v + 1), kLittle);
      put(buf, static_cast<std::int32_t>(ref_of(regions, i)), kLittle);
      PDR_TRY(out.maybe_flush());
    }
    return {};
  };
  PDR_TRY(cells(kKwPrisms, mesh.prisms, mesh.prism_regions));
  PDR_TRY(cells(kKwPyramids, mesh.pyramids, mesh.pyramid_regions));
  keyword(kKwEnd, 0, true);
  if (offset != total(pos_bytes)) return internal_error("meshb writer: size bookkeeping is off");
  return out.close();
}

Result<VolumeMesh> read_meshb(std::string_view data, const std::string& name) {
  ByteReader in(data, name);
  std::int32_t code = 0, version = 0;
  PDR_TRY(in.get(code, "byte-order mark"));
  if (code != 1) {
    if (byteswap_value(code) != 1) return in.error_at(0, fmt::format("not a meshb file (first word {}, expected 1)", code));
    in.set_swap(true);
  }
  PDR_TRY(in.get(version, "version"));
  if (version < 1 || version > 4)
    return unsupported(fmt::format("{}: meshb version {} (1 to 4 are read)", name, version));
  const int real_bytes = version == 1 ? 4 : 8;
  const int pos_bytes = version >= 3 ? 8 : 4;
  const int int_bytes = version >= 4 ? 8 : 4;

  // Walk the keyword chain; remember where each block we need starts and ends.
  struct Block {
    std::size_t data = 0, end = 0;
    bool present = false;
  };
  std::array<Block, kKwEnd + 1> blocks{};
  std::size_t at = 8;
  while (at < data.size()) {
    PDR_TRY(in.seek(at, "keyword"));
    std::int32_t kw = 0;
    std::int64_t next = 0;
    PDR_TRY(in.get(kw, "keyword code"));
    PDR_TRY(in.integer(next, pos_bytes, "next keyword position"));
    if (kw == kKwEnd) break;
    if (next != 0 && (next <= static_cast<std::int64_t>(at) || next > static_cast<std::int64_t>(data.size())))
      return in.error_at(at, fmt::format("keyword {} points to the next keyword at {}, outside ({}, {}]", kw,
                                         next, at, data.size()));
    const std::size_t end = next == 0 ? data.size() : static_cast<std::size_t>(next);
    if (kw >= 0 && kw <= kKwEnd && !blocks[static_cast<std::size_t>(kw)].present)
      blocks[static_cast<std::size_t>(kw)] = {in.pos(), end, true};
    if (next == 0) break;
    at = end;
  }

  auto open_block = [&](int kw, std::int64_t& count, std::uint64_t record_bytes, const char* what) -> Status {
    const Block& b = blocks[static_cast<std::size_t>(kw)];
    PDR_TRY(in.seek(b.data, what));
    PDR_TRY(in.integer(count, version >= 4 ? 8 : 4, what));
    if (count < 0) return in.error(fmt::format("negative {} {}", what, count));
    // A block whose next-keyword position lies inside its own count leaves nothing (b.end - pos
    // wrapped around and let a 45-byte file allocate gigabytes: found by fuzzing).
    const std::uint64_t available = in.pos() <= b.end ? b.end - in.pos() : 0;
    return in.fits(static_cast<std::uint64_t>(count), record_bytes, available, what);
  };

  if (blocks[kKwDimension].present) {
    PDR_TRY(in.seek(blocks[kKwDimension].data, "dimension"));
    std::int32_t dim = 0;
    PDR_TRY(in.get(dim, "dimension"));
    if (dim != 3) return unsupported(fmt::format("{}: only 3D meshes are read (Dimension {})", name, dim));
  }
  for (int kw : {kKwQuadrilaterals, kKwHexahedra}) {
    if (!blocks[static_cast<std::size_t>(kw)].present) continue;
    std::int64_t n = 0;
    PDR_TRY(open_block(kw, n, 1, "element count"));
    if (n > 0)
      return unsupported(fmt::format("{}: {} elements of keyword {}: only tetrahedral meshes are read", name, n, kw));
  }
  if (!blocks[kKwVertices].present) return invalid_input(fmt::format("{}: no Vertices keyword", name));

  VolumeMesh mesh;
  std::int64_t n = 0;
  PDR_TRY(open_block(kKwVertices, n, 3 * static_cast<std::uint64_t>(real_bytes) + static_cast<std::uint64_t>(int_bytes),
                     "vertex count"));
  mesh.points.resize(static_cast<std::size_t>(n));
  std::int64_t ref = 0;
  for (Vec3& p : mesh.points) {
    for (double& x : p) PDR_TRY(in.real(x, real_bytes, "vertex coordinate"));
    PDR_TRY(in.integer(ref, int_bytes, "vertex ref"));
  }
  const std::size_t np = mesh.points.size();
  auto ref_int = [&](std::int64_t r, std::size_t pos, int& out) -> Status {
    if (r < std::numeric_limits<int>::min() || r > std::numeric_limits<int>::max())
      return in.error_at(pos, fmt::format("ref {} does not fit a 32-bit integer", r));
    out = static_cast<int>(r);
    return {};
  };
  if (blocks[kKwTriangles].present) {
    PDR_TRY(open_block(kKwTriangles, n, 4 * static_cast<std::uint64_t>(int_bytes), "triangle count"));
    mesh.boundary.resize(static_cast<std::size_t>(n));
    mesh.boundary_ids.resize(static_cast<std::size_t>(n));
    for (std::size_t i = 0; i < mesh.boundary.size(); ++i) {
      for (Index& v : mesh.boundary[i]) PDR_TRY(in.index(v, int_bytes, np, "triangle vertex"));
      const std::size_t pos = in.pos();
      PDR_TRY(in.integer(ref, int_bytes, "triangle ref"));
      PDR_TRY(ref_int(ref, pos, mesh.boundary_ids[i]));
    }
  }
  CellRefs refs;
  if (blocks[kKwTetrahedra].present) {
    PDR_TRY(open_block(kKwTetrahedra, n, 5 * static_cast<std::uint64_t>(int_bytes), "tetrahedron count"));
    mesh.tets.resize(static_cast<std::size_t>(n));
    refs.tets.resize(mesh.tets.size());
    for (std::size_t i = 0; i < mesh.tets.size(); ++i) {
      for (Index& v : mesh.tets[i]) PDR_TRY(in.index(v, int_bytes, np, "tetrahedron vertex"));
      const std::size_t pos = in.pos();
      PDR_TRY(in.integer(ref, int_bytes, "tetrahedron ref"));
      PDR_TRY(ref_int(ref, pos, refs.tets[i]));
    }
  }
  // Prisms and pyramids, their refs their regions.
  const auto cells = [&](int kw, auto& list, std::vector<int>& cell_refs, const char* what) -> Status {
    if (!blocks[static_cast<std::size_t>(kw)].present) return {};
    using Cell = typename std::decay_t<decltype(list)>::value_type;
    const std::size_t corners = std::tuple_size_v<Cell>;
    const std::string count = fmt::format("{} count", what), vertex = fmt::format("{} vertex", what),
                      cell_ref = fmt::format("{} ref", what);
    PDR_TRY(open_block(kw, n, (corners + 1) * static_cast<std::uint64_t>(int_bytes), count.c_str()));
    list.resize(static_cast<std::size_t>(n));
    cell_refs.resize(list.size());
    for (std::size_t i = 0; i < list.size(); ++i) {
      for (Index& v : list[i]) PDR_TRY(in.index(v, int_bytes, np, vertex.c_str()));
      const std::size_t pos = in.pos();
      PDR_TRY(in.integer(ref, int_bytes, cell_ref.c_str()));
      PDR_TRY(ref_int(ref, pos, cell_refs[i]));
    }
    return {};
  };
  PDR_TRY(cells(kKwPrisms, mesh.prisms, refs.prisms, "prism"));
  PDR_TRY(cells(kKwPyramids, mesh.pyramids, refs.pyramids, "pyramid"));
  refs.set_regions(mesh);
  return mesh;
}

}  // namespace pdrmesh::volio
