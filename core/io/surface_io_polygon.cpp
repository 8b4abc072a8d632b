// SPDX-License-Identifier: AGPL-3.0-or-later
// Readers for the polygon formats OBJ and OFF (polygons are fan-triangulated).
#include <map>

#include "surface_io_internal.hpp"

namespace pdrmesh::surface_io_detail {
namespace {

bool is_ignored_obj_statement(std::string_view s) {
  static constexpr std::string_view kIgnored[] = {
      "vt",     "vn",     "vp",         "usemtl",    "mtllib", "s",        "l",        "p", "lod",
      "maplib", "usemap", "shadow_obj", "trace_obj", "bevel",  "c_interp", "d_interp", "mg"};
  for (std::string_view k : kIgnored) {
    if (s == k) return true;
  }
  return false;
}

}  // namespace

Result<SurfaceMesh> parse_obj(std::string_view bytes, std::string_view name) {
  TextCursor c(bytes, name, '#');
  SurfaceBuilder out(name, "face");
  GroupIds group_ids;
  std::string group;  // faces before any g/o belong to the unnamed group ""
  int group_id = 0;   // 0: not yet looked up
  std::vector<std::int64_t> face;
  while (!c.at_end()) {
    const std::string_view tok = c.line_token();
    if (tok == "v") {
      Vec3 p{};
      for (double& x : p) PDR_TRY(c.read_double(x, "a coordinate", true));
      PDR_TRY(out.add_point(p, where_at(c)));
    } else if (tok == "f") {
      face.clear();
      const auto defined = static_cast<std::int64_t>(out.point_count());
      for (std::string_view t = c.line_token(); !t.empty(); t = c.line_token()) {
        std::int64_t i = 0;
        if (!parse_int(t.substr(0, t.find('/')), i) || i == 0) {
          return c.bad_token(t, "a nonzero point index (i, i/t, i//n or i/t/n)");
        }
        if (i < 0) {
          if (-i > defined) {
            return c.error(
                fmt::format("face {}: relative index {} reaches before the first point "
                            "({} points defined so far)",
                            out.face_count() + 1, i, defined));
          }
          i += defined + 1;
        }
        face.push_back(i);
      }
      if (group_id == 0) {
        group_id = group_ids.id_of(group);
      }
      PDR_TRY(out.add_face(face, 1, group_id, where_at(c)));
    } else if (tok == "g" || tok == "o") {
      const std::string_view rest = c.rest_of_line();
      group = std::string(rest.substr(0, rest.find('#')));
      group_id = 0;
    } else if (!is_ignored_obj_statement(tok)) {
      return c.error(fmt::format("unknown OBJ statement {}", quote_token(tok)));
    }
    c.next_line();
  }
  PDR_ASSIGN_OR_RETURN(auto names, group_ids.names(name, "group"));
  PDR_ASSIGN_OR_RETURN(SurfaceMesh mesh, std::move(out).finish());
  mesh.surface_names = std::move(names);
  return mesh;
}

Result<SurfaceMesh> parse_off(std::string_view bytes, std::string_view name) {
  TextCursor c(bytes, name, '#');
  SurfaceBuilder out(name, "face");
  std::string_view tok = c.token();
  std::uint64_t nv = 0;
  std::uint64_t nf = 0;
  if (tok.size() >= 3 && tok.substr(tok.size() - 3) == "OFF") {
    const std::string_view prefix = tok.substr(0, tok.size() - 3);
    if (prefix.find_first_not_of("STCN") != std::string_view::npos) {
      return unsupported(
          fmt::format("{}:{}: OFF variant {} is not supported (only 3D OFF, COFF, "
                      "NOFF, STOFF)",
                      name, c.line(), quote_token(tok)));
    }
    if (const std::string_view next = c.line_token(); next == "BINARY") {
      return unsupported(fmt::format("{}:{}: binary OFF is not supported", name, c.line()));
    } else if (!next.empty()) {
      tok = next;  // counts on the header line
    } else {
      tok = c.token();
    }
  }
  std::int64_t first = 0;
  if (!parse_int(tok, first) || first < 0) return c.bad_token(tok, "the number of vertices");
  nv = static_cast<std::uint64_t>(first);
  PDR_TRY(check_count_fits(nv, 6, c.remaining(), where_at(c)(), "number of vertices"));
  PDR_TRY(c.read_count(nf, "number of faces", 8));
  std::int64_t ne = 0;
  PDR_TRY(c.read_int(ne, "number of edges"));
  c.next_line();
  out.reserve(nv, nf);
  PDR_TRY(read_point_lines(c, out, nv, "vertex"));  // ignoring colours, normals, ...
  std::vector<std::int64_t> face;
  for (std::uint64_t f = 0; f < nf; ++f) {
    std::int64_t k = 0;
    PDR_TRY(read_record_start(c, k, "face", f, nf));
    if (k < 0 || static_cast<std::uint64_t>(k) > c.remaining() / 2 + 1) {
      return c.error(fmt::format("face {}: invalid number of vertices {}", f + 1, k));
    }
    face.resize(static_cast<std::size_t>(k));
    for (std::int64_t& i : face) PDR_TRY(c.read_int(i, "a point index", true));
    PDR_TRY(out.add_face(face, 0, 1, where_at(c), nv));
    c.next_line();  // colours
  }
  if (!c.at_end()) {
    return c.error(
        fmt::format("unexpected data after the {} vertices and {} faces the header "
                    "announced",
                    nv, nf));
  }
  return std::move(out).finish();
}

}  // namespace pdrmesh::surface_io_detail
