// SPDX-License-Identifier: AGPL-3.0-or-later
// STL reader (ASCII and binary) with exact vertex welding.
#include "surface_io_internal.hpp"

namespace pdrmesh::surface_io_detail {
namespace {

constexpr std::uint64_t kBinaryHeader = 84;
constexpr std::uint64_t kBinaryFacet = 50;

std::uint32_t load_u32_le(const char* p) { return load_scalar<std::uint32_t>(p, false); }
float load_f32_le(const char* p) { return load_scalar<float>(p, false); }

Status nonfinite_vertex(const Vec3& p, std::uint64_t facet, int vertex, const std::string& where) {
  return invalid_input(
      fmt::format("{}: facet {} vertex {} has a non-finite coordinate ({}, {}, {})", where, facet,
                  vertex, p[0], p[1], p[2]));
}

Result<SurfaceMesh> parse_binary(std::string_view bytes, std::string_view name) {
  if (bytes.size() < kBinaryHeader) {
    return invalid_input(fmt::format(
        "{}: {} bytes is too short for a binary STL (84-byte header) and the file does not "
        "start with 'solid'",
        name, bytes.size()));
  }
  const std::uint64_t n = load_u32_le(bytes.data() + 80);
  const std::uint64_t expected = kBinaryHeader + kBinaryFacet * n;
  if (expected != bytes.size()) {
    return invalid_input(fmt::format(
        "{}: binary STL header announces {} triangles ({} bytes) but the file has {} bytes{}", name,
        n, expected, bytes.size(), expected > bytes.size() ? " (truncated?)" : ""));
  }
  SurfaceBuilder out(name, "facet");
  PointWelder welder;
  out.reserve(n / 2 + 3, n);
  welder.reserve(n / 2 + 3);
  for (std::uint64_t f = 0; f < n; ++f) {
    const char* rec = bytes.data() + kBinaryHeader + kBinaryFacet * f;
    Tri t{};
    for (int v = 0; v < 3; ++v) {
      const char* at = rec + 12 + 12 * v;
      const Vec3 p{load_f32_le(at), load_f32_le(at + 4), load_f32_le(at + 8)};
      if (!is_finite(p)) {
        return nonfinite_vertex(p, f + 1, v + 1,
                                fmt::format("{}: byte {}", name, at - bytes.data()));
      }
      t[static_cast<std::size_t>(v)] = welder.add(p, out.points());
    }
    out.add_triangle(t, 1);
  }
  return std::move(out).finish();
}

Result<SurfaceMesh> parse_ascii(std::string_view bytes, std::string_view name) {
  TextCursor c(bytes, name, '\0');
  SurfaceBuilder out(name, "facet");
  PointWelder welder;
  GroupIds solids;
  while (!c.at_end()) {
    PDR_TRY(c.expect("solid"));
    // The rest of the line is the solid's name: solids of one name share an
    // id, each unnamed solid has its own.
    const std::string_view solid_name = c.rest_of_line();
    const int solid = solid_name.empty() ? solids.fresh() : solids.id_of(solid_name);
    c.next_line();
    for (;;) {
      const std::string_view tok = c.token();
      if (iequals(tok, "endsolid")) {
        c.next_line();
        break;
      }
      if (!iequals(tok, "facet")) return c.bad_token(tok, "'facet' or 'endsolid'");
      PDR_TRY(c.expect("normal"));
      for (int k = 0; k < 3; ++k) {  // normal values are ignored
        if (c.line_token().empty()) return c.bad_token({}, "a normal component");
      }
      PDR_TRY(c.expect("outer"));
      PDR_TRY(c.expect("loop"));
      Tri t{};
      for (int v = 0; v < 3; ++v) {
        PDR_TRY(c.expect("vertex"));
        Vec3 p{};
        for (double& x : p) PDR_TRY(c.read_double(x, "a coordinate", true));
        if (!is_finite(p))
          return nonfinite_vertex(p, out.face_count() + 1, v + 1, where_at(c)());
        t[static_cast<std::size_t>(v)] = welder.add(p, out.points());
      }
      PDR_TRY(c.expect("endloop"));
      PDR_TRY(c.expect("endfacet"));
      out.add_triangle(t, solid);
    }
  }
  PDR_ASSIGN_OR_RETURN(auto names, solids.names(name, "solid"));
  PDR_ASSIGN_OR_RETURN(SurfaceMesh mesh, std::move(out).finish());
  mesh.surface_names = std::move(names);
  return mesh;
}

bool starts_with_solid(std::string_view bytes) {
  const std::size_t i = bytes.find_first_not_of(" \t\r\n");
  return i != std::string_view::npos && bytes.size() - i >= 5 &&
         iequals(bytes.substr(i, 5), "solid");
}

}  // namespace

Result<SurfaceMesh> parse_stl(std::string_view bytes, std::string_view name) {
  if (bytes.size() >= kBinaryHeader &&
      kBinaryHeader + kBinaryFacet * load_u32_le(bytes.data() + 80) == bytes.size()) {
    return parse_binary(bytes, name);
  }
  // A binary file may start with "solid" too; text has no NUL bytes.
  const std::string_view head = bytes.substr(0, 4096);
  if (starts_with_solid(bytes) && head.find('\0') == std::string_view::npos) {
    return parse_ascii(bytes, name);
  }
  return parse_binary(bytes, name);
}

}  // namespace pdrmesh::surface_io_detail
