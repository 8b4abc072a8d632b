// SPDX-License-Identifier: AGPL-3.0-or-later
// Readers for the mesh-generator formats Medit .mesh (ASCII) and AFLR3 .surf.
#include <array>

#include "surface_io_internal.hpp"

namespace pdrmesh::surface_io_detail {
namespace {

/// Sections this reader skips, with the number of values in each record.
struct SkippedSection {
  std::string_view keyword;
  int values;
};
constexpr std::array<SkippedSection, 23> kSkipped{{
    {"Edges", 3},
    {"Tetrahedra", 5},
    {"Pyramids", 6},
    {"Prisms", 7},
    {"Hexahedra", 9},
    {"Corners", 1},
    {"Ridges", 1},
    {"RequiredVertices", 1},
    {"RequiredEdges", 1},
    {"RequiredTriangles", 1},
    {"RequiredQuadrilaterals", 1},
    {"Normals", 3},
    {"Tangents", 3},
    {"NormalAtVertices", 2},
    {"NormalAtTriangleVertices", 3},
    {"NormalAtQuadrilateralVertices", 3},
    {"TangentAtVertices", 2},
    {"TangentAtEdgeVertices", 3},
    {"EdgesP2", 4},
    {"TrianglesP2", 7},
    {"QuadrilateralsQ2", 10},
    {"TetrahedraP2", 11},
    {"HexahedraQ2", 28},
}};

std::string known_keywords() {
  std::string s = "MeshVersionFormatted, Dimension, Vertices, Triangles, Quadrilaterals, End";
  for (const auto& k : kSkipped) s += fmt::format(", {}", k.keyword);
  return s;
}

/// Reads `n` records of `k` point indices (1-based) and a reference.
Status read_medit_faces(TextCursor& c, SurfaceBuilder& out, std::size_t k, std::string_view what,
                        bool have_vertices) {
  std::uint64_t n = 0;
  PDR_TRY(c.read_count(n, fmt::format("number of {}", what), 2 * (k + 1)));
  out.start_section(k == 3 ? "triangle" : "quadrilateral");
  if (n > 0 && !have_vertices) {
    return c.error(fmt::format("{} before Vertices (this reader needs the vertices first)", what));
  }
  out.reserve(out.point_count(), out.face_count() + n * (k - 2));
  std::array<std::int64_t, 4> rec{};
  for (std::uint64_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < k; ++j) PDR_TRY(c.read_int(rec[j], "a point index"));
    std::int64_t ref = 0;
    PDR_TRY(c.read_int(ref, "a reference"));
    if (ref < INT32_MIN || ref > INT32_MAX)
      return c.bad_token(fmt::format("{}", ref), "an int reference");
    PDR_TRY(out.add_face(std::span(rec.data(), k), 1, static_cast<int>(ref), where_at(c)));
  }
  return {};
}

}  // namespace

Result<SurfaceMesh> parse_medit(std::string_view bytes, std::string_view name) {
  TextCursor c(bytes, name, '#');
  SurfaceBuilder out(name, "triangle");
  std::int64_t dimension = 3;
  bool have_vertices = false;
  for (std::string_view kw = c.token(); !kw.empty() && kw != "End"; kw = c.token()) {
    if (kw == "MeshVersionFormatted") {
      std::int64_t v = 0;
      PDR_TRY(c.read_int(v, "a version number"));
      if (v < 1 || v > 4) return c.error(fmt::format("unsupported MeshVersionFormatted {}", v));
    } else if (kw == "Dimension") {
      PDR_TRY(c.read_int(dimension, "a dimension"));
      if (dimension != 3) {
        return unsupported(
            fmt::format("{}:{}: Dimension {}: only 3D meshes are read", name, c.line(), dimension));
      }
    } else if (kw == "Vertices") {
      if (have_vertices) return c.error("a second Vertices section");
      have_vertices = true;
      std::uint64_t n = 0;
      PDR_TRY(c.read_count(n, "number of vertices", 8));
      out.reserve(n, out.face_count());
      for (std::uint64_t i = 0; i < n; ++i) {
        Vec3 p{};
        for (double& x : p) PDR_TRY(c.read_double(x, "a coordinate"));
        std::int64_t ref = 0;
        PDR_TRY(c.read_int(ref, "a vertex reference"));
        PDR_TRY(out.add_point(p, where_at(c)));
      }
    } else if (kw == "Triangles") {
      PDR_TRY(read_medit_faces(c, out, 3, "Triangles", have_vertices));
    } else if (kw == "Quadrilaterals") {
      PDR_TRY(read_medit_faces(c, out, 4, "Quadrilaterals", have_vertices));
    } else {
      const auto* section = std::find_if(kSkipped.begin(), kSkipped.end(),
                                         [&](const SkippedSection& s) { return s.keyword == kw; });
      if (section == kSkipped.end()) {
        return c.error(
            fmt::format("unknown keyword {} (known: {})", quote_token(kw), known_keywords()));
      }
      const auto values = static_cast<std::uint64_t>(section->values);
      std::uint64_t n = 0;
      PDR_TRY(c.read_count(n, fmt::format("number of {}", kw), 2 * values));
      const std::string what = fmt::format("a value of {}", kw);
      for (std::uint64_t i = 0; i < n * values; ++i) {
        double ignored = 0;
        PDR_TRY(c.read_double(ignored, what));
      }
    }
  }
  return std::move(out).finish();
}

Result<SurfaceMesh> parse_aflr3_surf(std::string_view bytes, std::string_view name) {
  TextCursor c(bytes, name, '\0');
  SurfaceBuilder out(name, "triangle");
  std::uint64_t ntri = 0;
  std::uint64_t nquad = 0;
  std::uint64_t nnodes = 0;
  PDR_TRY(c.read_count(ntri, "number of triangles", 8));
  PDR_TRY(c.read_count(nquad, "number of quads", 10));
  PDR_TRY(c.read_count(nnodes, "number of nodes", 6));
  c.next_line();
  out.reserve(nnodes, ntri + 2 * nquad);
  PDR_TRY(read_point_lines(c, out, nnodes, "node"));  // ignoring spacing and other columns
  std::array<std::int64_t, 4> rec{};
  for (std::size_t k : {std::size_t{3}, std::size_t{4}}) {
    const std::uint64_t n = k == 3 ? ntri : nquad;
    out.start_section(k == 3 ? "triangle" : "quad");
    for (std::uint64_t i = 0; i < n; ++i) {
      PDR_TRY(read_record_start(c, rec[0], k == 3 ? "triangle" : "quad", i, n));
      for (std::size_t j = 1; j < k; ++j) PDR_TRY(c.read_int(rec[j], "a node index", true));
      std::int64_t id = 1;
      if (const std::string_view tok = c.line_token(); !tok.empty()) {
        if (!parse_int(tok, id) || id < INT32_MIN || id > INT32_MAX)
          return c.bad_token(tok, "a surface id");
      }
      PDR_TRY(out.add_face(std::span(rec.data(), k), 1, static_cast<int>(id), where_at(c)));
      c.next_line();  // reconnection and boundary-condition flags
    }
  }
  if (!c.at_end()) {
    return c.error(
        fmt::format("unexpected data after the {} nodes, {} triangles and {} quads the "
                    "header announced",
                    nnodes, ntri, nquad));
  }
  return std::move(out).finish();
}

}  // namespace pdrmesh::surface_io_detail
