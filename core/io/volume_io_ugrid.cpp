// SPDX-License-Identifier: AGPL-3.0-or-later
// AFLR3/FUN3D UGRID volume meshes: ASCII .ugrid and C-binary (no record
// markers) .lb8.ugrid (little endian) and .b8.ugrid (big endian), int32 and
// float64.
//
// Layout (UG_IO "UGRID 3D Grid File Type", simcenter.msstate.edu; nasa/refine
// src/ref_import.c ref_import_ugrid / ref_import_bin_ugrid):
//   nnodes ntri nquad ntet npyr nprz nhex
//   x y z per node; triangle nodes; quad nodes; one surface id per triangle
//   then per quad; tet nodes; pyramid, prism, hex nodes. All indices 1-based.
// Anything after the elements (AFLR3's optional records) is ignored.
//
// Orientation: UGRID tets use the same right-handed order as VTK, so they are
// written and read unchanged. Source: nasa/refine reads UGRID tets without
// reordering (ref_import.c), its ref_node_tet_vol equals our signed_volume,
// ref_validation_cell_volume rejects tets whose volume is not positive, and
// its VTK/SU2 import maps only pyramids and prisms, not tets. Boundary faces:
// AFLR3 accepts either normal direction on a closed surface (UG_IO "3D
// Input/Output Grids"); refine's own fixtures use inward normals. We write the
// mesh's outward triangles unchanged so that a round trip is exact.
// Pyramids and prisms in UGRID's vertex order, a mirror of VTK's (see
// volume_io_mixed.cpp, which writes them): prism (1, 0, 2, 4, 3, 5) and
// pyramid (1, 0, 4, 2, 3) of our vertices. UGRID holds no regions.
//
// Boundary names go into FUN3D's .mapbc beside the grid (volume_io.hpp,
// mapbc_path): "N" on the first line, then "ID BC NAME" per surface id.
#include <fmt/compile.h>

#include <cctype>
#include <set>

#include "pdrmesh/boundary_names.hpp"
#include "pdrmesh/volume_io.hpp"
#include "volume_io_detail.hpp"

namespace pdrmesh::volio {
namespace {

struct Header {
  std::int64_t nodes = 0, tri = 0, quad = 0, tet = 0, pyr = 0, prz = 0, hex = 0;
};

Status no_quads_or_hexes(const Header& h, const std::string& name) {
  if (h.quad != 0 || h.hex != 0)
    return unsupported(fmt::format("{}: {} boundary quads, {} hexes: only triangles, tets, pyramids and prisms are read",
                                   name, h.quad, h.hex));
  return {};
}

/// Our vertex order from UGRID's: the inverses of the orders above.
Pyramid pyramid_from_ugrid(const Pyramid& u) { return {u[1], u[0], u[3], u[4], u[2]}; }
Prism prism_from_ugrid(const Prism& u) { return {u[1], u[0], u[2], u[4], u[3], u[5]}; }

}  // namespace

Status write_ugrid_ascii(const VolumeMesh& mesh, const std::filesystem::path& path) {
  OutputFile out(path);
  PDR_TRY(out.open());
  auto it = std::back_inserter(out.buf());
  fmt::format_to(it, "{} {} 0 {} 0 0 0\n", mesh.points.size(), mesh.boundary.size(), mesh.tets.size());
  for (const Vec3& p : mesh.points) {
    fmt::format_to(it, FMT_COMPILE("{} {} {}\n"), p[0], p[1], p[2]);
    PDR_TRY(out.maybe_flush());
  }
  for (const Tri& t : mesh.boundary) {
    fmt::format_to(it, FMT_COMPILE("{} {} {}\n"), t[0] + 1, t[1] + 1, t[2] + 1);
    PDR_TRY(out.maybe_flush());
  }
  for (int id : mesh.boundary_ids) {
    fmt::format_to(it, FMT_COMPILE("{}\n"), id);
    PDR_TRY(out.maybe_flush());
  }
  for (const Tet& t : mesh.tets) {
    fmt::format_to(it, FMT_COMPILE("{} {} {} {}\n"), t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1);
    PDR_TRY(out.maybe_flush());
  }
  return out.close();
}

Result<VolumeMesh> read_ugrid_ascii(std::string_view text, const std::string& name) {
  TextScanner in(text, name);
  Header h;
  std::string_view counts[7];
  for (std::string_view& c : counts) c = in.next();
  PDR_TRY(in.parse_integer(counts[2], h.quad, "quad count"));
  PDR_TRY(in.parse_integer(counts[6], h.hex, "hex count"));
  PDR_TRY(no_quads_or_hexes(h, name));
  std::size_t np = 0, nb = 0, nt = 0, ny = 0, nq = 0;  // each checked against the file size
  PDR_TRY(in.parse_count(counts[0], np, 3, "node count"));
  PDR_TRY(in.parse_count(counts[1], nb, 4, "triangle count"));
  PDR_TRY(in.parse_count(counts[3], nt, 4, "tet count"));
  PDR_TRY(in.parse_count(counts[4], ny, 5, "pyramid count"));
  PDR_TRY(in.parse_count(counts[5], nq, 6, "prism count"));
  if (static_cast<std::uint64_t>(np) * 6 + static_cast<std::uint64_t>(nb) * 8 + static_cast<std::uint64_t>(nt) * 8 +
          static_cast<std::uint64_t>(ny) * 10 + static_cast<std::uint64_t>(nq) * 12 >
      in.remaining() + 1)
    return in.error("the header counts are more than the rest of the file can hold");

  VolumeMesh mesh;
  mesh.points.resize(np);
  for (Vec3& p : mesh.points) {
    PDR_TRY(in.real(p[0], "node x"));
    PDR_TRY(in.real(p[1], "node y"));
    PDR_TRY(in.real(p[2], "node z"));
  }
  mesh.boundary.resize(nb);
  for (Tri& t : mesh.boundary)
    for (Index& v : t) PDR_TRY(in.index(v, 1, np, "triangle node"));
  mesh.boundary_ids.resize(nb);
  for (int& id : mesh.boundary_ids) PDR_TRY(in.integer(id, "surface id"));
  mesh.tets.resize(nt);
  for (Tet& t : mesh.tets)
    for (Index& v : t) PDR_TRY(in.index(v, 1, np, "tet node"));
  mesh.pyramids.resize(ny);
  for (Pyramid& c : mesh.pyramids) {
    for (Index& v : c) PDR_TRY(in.index(v, 1, np, "pyramid node"));
    c = pyramid_from_ugrid(c);
  }
  mesh.prisms.resize(nq);
  for (Prism& c : mesh.prisms) {
    for (Index& v : c) PDR_TRY(in.index(v, 1, np, "prism node"));
    c = prism_from_ugrid(c);
  }
  return mesh;
}

Status write_ugrid_binary(const VolumeMesh& mesh, const std::filesystem::path& path, bool little) {
  OutputFile out(path);
  PDR_TRY(out.open());
  auto& buf = out.buf();
  for (std::size_t n : {mesh.points.size(), mesh.boundary.size(), std::size_t{0}, mesh.tets.size(), std::size_t{0},
                        std::size_t{0}, std::size_t{0}})
    put(buf, static_cast<std::int32_t>(n), little);
  const auto store = [little](char*& at, auto v) {
    if (little != kHostLittle) v = byteswap_value(v);
    std::memcpy(at, &v, sizeof(v));
    at += sizeof(v);
  };
  PDR_TRY(out.fixed_records(mesh.points.size(), 24, [&](std::size_t i, char* at) {
    for (double x : mesh.points[i]) store(at, x);
  }));
  for (const Tri& t : mesh.boundary) {
    for (Index v : t) put(buf, static_cast<std::int32_t>(v + 1), little);
    PDR_TRY(out.maybe_flush());
  }
  for (int id : mesh.boundary_ids) put(buf, static_cast<std::int32_t>(id), little);
  PDR_TRY(out.fixed_records(mesh.tets.size(), 16, [&](std::size_t i, char* at) {
    for (Index v : mesh.tets[i]) store(at, static_cast<std::int32_t>(v + 1));
  }));
  return out.close();
}

Result<VolumeMesh> read_ugrid_binary(std::string_view data, const std::string& name, bool little) {
  ByteReader in(data, name);
  in.set_swap(little != kHostLittle);
  Header h;
  for (std::int64_t* v : {&h.nodes, &h.tri, &h.quad, &h.tet, &h.pyr, &h.prz, &h.hex}) {
    const std::size_t at = in.pos();
    PDR_TRY(in.integer(*v, 4, "header count"));
    if (*v < 0)
      return in.error_at(at, fmt::format("negative count {} in the header (wrong byte order? this reader "
                                         "expects {} endian)", *v, little ? "little" : "big"));
  }
  PDR_TRY(no_quads_or_hexes(h, name));
  const auto np = static_cast<std::uint64_t>(h.nodes), nb = static_cast<std::uint64_t>(h.tri),
             nt = static_cast<std::uint64_t>(h.tet), ny = static_cast<std::uint64_t>(h.pyr),
             nq = static_cast<std::uint64_t>(h.prz);
  const std::uint64_t need = np * 24 + nb * 16 + nt * 16 + ny * 20 + nq * 24;
  if (np >= kNoIndex || nb >= kNoIndex || nt >= kNoIndex || ny >= kNoIndex || nq >= kNoIndex ||
      need > data.size() - in.pos())
    return in.error(fmt::format("header counts ({} nodes, {} triangles, {} tets, {} pyramids, {} prisms) need {} "
                                "bytes after the header, the file has {}",
                                np, nb, nt, ny, nq, need, data.size() - in.pos()));
  VolumeMesh mesh;
  mesh.points.resize(static_cast<std::size_t>(np));
  for (Vec3& p : mesh.points)
    for (double& x : p) PDR_TRY(in.real(x, 8, "node coordinate"));
  mesh.boundary.resize(static_cast<std::size_t>(nb));
  for (Tri& t : mesh.boundary)
    for (Index& v : t) PDR_TRY(in.index(v, 4, mesh.points.size(), "triangle node"));
  mesh.boundary_ids.resize(static_cast<std::size_t>(nb));
  for (int& id : mesh.boundary_ids) {
    std::int32_t w = 0;
    PDR_TRY(in.get(w, "surface id"));
    id = w;
  }
  mesh.tets.resize(static_cast<std::size_t>(nt));
  for (Tet& t : mesh.tets)
    for (Index& v : t) PDR_TRY(in.index(v, 4, mesh.points.size(), "tet node"));
  mesh.pyramids.resize(static_cast<std::size_t>(ny));
  for (Pyramid& c : mesh.pyramids) {
    for (Index& v : c) PDR_TRY(in.index(v, 4, mesh.points.size(), "pyramid node"));
    c = pyramid_from_ugrid(c);
  }
  mesh.prisms.resize(static_cast<std::size_t>(nq));
  for (Prism& c : mesh.prisms) {
    for (Index& v : c) PDR_TRY(in.index(v, 4, mesh.points.size(), "prism node"));
    c = prism_from_ugrid(c);
  }
  return mesh;
}

Status read_mapbc_beside(VolumeMesh& mesh, const std::filesystem::path& ugrid) {
  const std::filesystem::path path = mapbc_path(ugrid);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return {};
  PDR_ASSIGN_OR_RETURN(const std::string text, read_file(path));
  PDR_ASSIGN_OR_RETURN(const auto names, parse_mapbc(text, path.string()));
  return merge_boundary_names(mesh.boundary_names, mesh.boundary_ids, names,
                              fmt::format("{} (beside {})", path.string(), ugrid.filename().string()));
}

}  // namespace pdrmesh::volio

namespace pdrmesh {

std::filesystem::path mapbc_path(const std::filesystem::path& ugrid) {
  std::string name = ugrid.filename().string();
  std::string lower = name;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (std::string_view suffix : {".lb8.ugrid", ".b8.ugrid", ".ugrid"}) {
    if (lower.size() > suffix.size() && lower.compare(lower.size() - suffix.size(), suffix.size(), suffix) == 0) {
      name.resize(name.size() - suffix.size());
      break;
    }
  }
  return ugrid.parent_path() / (name + ".mapbc");
}

std::string format_mapbc(const VolumeMesh& mesh) {
  const std::vector<int> ids = volio::distinct(mesh.boundary_ids);
  std::string out = fmt::format("{}\n", ids.size());
  for (int id : ids) out += fmt::format("{} {} {}\n", id, kMapbcDefaultBc, boundary_name(mesh.boundary_names, id));
  return out;
}

Result<std::map<int, std::string>> parse_mapbc(std::string_view text, const std::string& name) {
  volio::TextScanner in(text, name, '#');
  std::size_t n = 0;
  PDR_TRY(in.count(n, 2, "number of boundary patches"));
  std::map<int, std::string> names;
  std::set<int> seen;
  for (std::size_t k = 0; k < n; ++k) {
    int id = 0, bc = 0;
    PDR_TRY(in.integer(id, "patch id"));
    PDR_TRY(in.integer(bc, "boundary condition"));
    const std::string_view raw = in.next_in_line();
    in.skip_line();
    if (!seen.insert(id).second) return in.error(fmt::format("patch id {} is listed twice", id));
    std::string patch = sanitize_boundary_name(raw);
    if (patch.empty() || is_default_boundary_name(id, patch) || !check_boundary_name(id, patch).ok()) continue;
    names.emplace(id, std::move(patch));
  }
  return names;
}

}  // namespace pdrmesh
