// SPDX-License-Identifier: AGPL-3.0-or-later
// OpenFOAM polyMesh output: a directory with the files points, faces, owner,
// neighbour and boundary (and cellZones when the tets carry two or more
// regions), each an ASCII FoamFile dictionary.
//
// Cells are the tets in mesh order (then, in a mesh with prism layers, the
// prisms and the pyramids), points the mesh's points. Faces follow cell_faces
// (cell_faces.hpp; mixed_cell_faces in mixed_cells.hpp, where a face is a
// triangle or a quad): the internal faces in upper-triangular order, then the
// hull faces grouped into one patch per boundary id (ascending id, mesh order
// within an id), each face oriented out of its owner. A hull face that no
// boundary triangle names goes into a last patch "defaultFaces" (blockMesh's
// name for it). Patch names are boundary_name() made into OpenFOAM words;
// every patch is of type `patch`.
#include <fmt/compile.h>

#include <algorithm>
#include <cctype>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <tuple>

#include "pdrmesh/cell_faces.hpp"
#include "pdrmesh/mixed_cells.hpp"
#include "pdrmesh/topology.hpp"
#include "volume_io_detail.hpp"

namespace pdrmesh::volio {
namespace {

// A name OpenFOAM reads as one word: letters, digits and "_-.:+" kept, any
// other character '_', and a leading digit prefixed, since a key that starts
// like a number is not read as a patch name.
std::string foam_word(std::string_view name) {
  std::string w;
  for (char c : name) {
    const bool keep = std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-' || c == '.' ||
                      c == ':' || c == '+';
    w += keep ? c : '_';
  }
  if (w.empty() || std::isdigit(static_cast<unsigned char>(w[0])) != 0 || w[0] == '-' || w[0] == '+' ||
      w[0] == '.')
    w = "patch_" + w;
  return w;
}

void foam_header(fmt::memory_buffer& buf, std::string_view cls, std::string_view object, std::string_view note = {}) {
  fmt::format_to(std::back_inserter(buf),
                 "/* OpenFOAM polyMesh written by pdrmesh */\n"
                 "FoamFile\n{{\n    version     2.0;\n    format      ascii;\n    class       {};\n"
                 "{}    location    \"constant/polyMesh\";\n    object      {};\n}}\n\n",
                 cls, note.empty() ? std::string() : fmt::format("    note        \"{}\";\n", note), object);
}

template <class Body>
Status write_foam_file(const std::filesystem::path& path, Body&& body) {
  OutputFile out(path);
  PDR_TRY(out.open());
  PDR_TRY(body(out));
  return out.close();
}

Status write_foam_labels(const std::filesystem::path& path, std::string_view object, std::string_view note,
                    const std::vector<Index>& labels) {
  return write_foam_file(path, [&](OutputFile& out) -> Status {
    foam_header(out.buf(), "labelList", object, note);
    auto it = std::back_inserter(out.buf());
    fmt::format_to(it, "{}\n(\n", labels.size());
    for (Index l : labels) {
      fmt::format_to(it, FMT_COMPILE("{}\n"), l);
      PDR_TRY(out.maybe_flush());
    }
    fmt::format_to(it, ")\n");
    return {};
  });
}

struct FoamPatch {
  std::string name;
  std::size_t start = 0, count = 0;
};

// A face as a triangle (a quad is none), and a face in the faces file.
std::optional<Tri> as_triangle(const Tri& f) { return f; }
std::optional<Tri> as_triangle(const std::array<Index, 4>& f) {
  if (f[3] != kNoIndex) return std::nullopt;
  return Tri{f[0], f[1], f[2]};
}
void put_face(fmt::memory_buffer& b, const Tri& t) {
  fmt::format_to(std::back_inserter(b), FMT_COMPILE("3({} {} {})\n"), t[0], t[1], t[2]);
}
void put_face(fmt::memory_buffer& b, const std::array<Index, 4>& f) {
  if (f[3] == kNoIndex)
    fmt::format_to(std::back_inserter(b), FMT_COMPILE("3({} {} {})\n"), f[0], f[1], f[2]);
  else
    fmt::format_to(std::back_inserter(b), FMT_COMPILE("4({} {} {} {})\n"), f[0], f[1], f[2], f[3]);
}

/// The polyMesh of `mesh` with its `ncells` cells and their faces `cf`
/// (CellFaces or MixedCellFaces).
template <class Faces>
Status write_foam_faces(const VolumeMesh& mesh, const Faces& cf, std::size_t ncells, const std::filesystem::path& dir) {

  // Each hull face's boundary id, from the boundary triangle with its points
  // (the first one, should a file list a triangle twice); none: defaultFaces.
  std::vector<std::pair<Tri, std::size_t>> named;
  named.reserve(mesh.boundary.size());
  for (std::size_t i = 0; i < mesh.boundary.size(); ++i) named.emplace_back(topo::sorted_key(mesh.boundary[i]), i);
  std::sort(named.begin(), named.end());
  const std::size_t internal = cf.internal();
  struct HullFace {
    bool named;
    int id;
    std::size_t order;  // the boundary triangle, or the hull position
    std::size_t face;   // in cf
  };
  std::vector<HullFace> hull;
  hull.reserve(cf.faces.size() - internal);
  for (std::size_t f = internal; f < cf.faces.size(); ++f) {
    const std::optional<Tri> t = as_triangle(cf.faces[f]);
    const Tri key = t ? topo::sorted_key(*t) : Tri{};
    const auto it = std::lower_bound(named.begin(), named.end(), std::make_pair(key, std::size_t{0}));
    if (t && it != named.end() && it->first == key)
      hull.push_back({true, mesh.boundary_ids[it->second], it->second, f});
    else
      hull.push_back({false, 0, f, f});
  }
  std::sort(hull.begin(), hull.end(), [](const HullFace& a, const HullFace& b) {  // named first, by id, then order
    if (a.named != b.named) return a.named;
    return std::tie(a.id, a.order) < std::tie(b.id, b.order);
  });

  std::vector<FoamPatch> patches;
  std::set<std::string> used;
  for (std::size_t k = 0; k < hull.size();) {
    std::size_t e = k;
    while (e < hull.size() && hull[e].named == hull[k].named && hull[e].id == hull[k].id) ++e;
    std::string name = hull[k].named ? foam_word(boundary_name(mesh.boundary_names, hull[k].id)) : "defaultFaces";
    if (used.count(name) != 0) name += fmt::format("_{}", hull[k].named ? hull[k].id : -1);
    used.insert(name);
    patches.push_back({std::move(name), internal + k, e - k});
    k = e;
  }

  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return io_error(fmt::format("{}: cannot create the directory: {}", dir.string(), ec.message()));

  const auto points = [&](OutputFile& out) -> Status {
    foam_header(out.buf(), "vectorField", "points");
    auto it = std::back_inserter(out.buf());
    fmt::format_to(it, "{}\n(\n", mesh.points.size());
    for (const Vec3& p : mesh.points) {
      fmt::format_to(it, FMT_COMPILE("({} {} {})\n"), p[0], p[1], p[2]);
      PDR_TRY(out.maybe_flush());
    }
    fmt::format_to(it, ")\n");
    return {};
  };
  PDR_TRY(write_foam_file(dir / "points", points));

  // Faces and owners in file order: internal, then the hull by patch.
  std::vector<Index> owner(cf.owner.begin(), cf.owner.begin() + static_cast<std::ptrdiff_t>(internal));
  owner.reserve(cf.faces.size());
  for (const HullFace& h : hull) owner.push_back(cf.owner[h.face]);
  const auto faces = [&](OutputFile& out) -> Status {
    foam_header(out.buf(), "faceList", "faces");
    auto it = std::back_inserter(out.buf());
    fmt::format_to(it, "{}\n(\n", cf.faces.size());
    for (std::size_t f = 0; f < internal; ++f) {
      put_face(out.buf(), cf.faces[f]);
      PDR_TRY(out.maybe_flush());
    }
    for (const HullFace& h : hull) {
      put_face(out.buf(), cf.faces[h.face]);
      PDR_TRY(out.maybe_flush());
    }
    fmt::format_to(it, ")\n");
    return {};
  };
  PDR_TRY(write_foam_file(dir / "faces", faces));
  const std::string note = fmt::format("nPoints:{}  nCells:{}  nFaces:{}  nInternalFaces:{}", mesh.points.size(),
                                       ncells, cf.faces.size(), internal);
  PDR_TRY(write_foam_labels(dir / "owner", "owner", note, owner));
  PDR_TRY(write_foam_labels(dir / "neighbour", "neighbour", note, cf.neighbour));

  PDR_TRY(write_foam_file(dir / "boundary", [&](OutputFile& out) -> Status {  // no PDR_TRY inside
    foam_header(out.buf(), "polyBoundaryMesh", "boundary");
    auto it = std::back_inserter(out.buf());
    fmt::format_to(it, "{}\n(\n", patches.size());
    for (const FoamPatch& p : patches)
      fmt::format_to(it, "    {}\n    {{\n        type            patch;\n        nFaces          {};\n"
                         "        startFace       {};\n    }}\n",
                     p.name, p.count, p.start);
    fmt::format_to(it, ")\n");
    return {};
  }));

  // Regions as cellZones named by region_name(), ascending id, when there are
  // two or more; cells numbered as the faces' owners are: tets, prisms, pyramids.
  std::map<int, std::vector<Index>> zones;
  Index cell = 0;
  for (const std::vector<int>* regions : {&mesh.tet_regions, &mesh.prism_regions, &mesh.pyramid_regions})
    for (int r : *regions) zones[r].push_back(cell++);
  if (zones.size() < 2) return {};
  return write_foam_file(dir / "cellZones", [&](OutputFile& out) -> Status {
    foam_header(out.buf(), "regIOobject", "cellZones");
    auto it = std::back_inserter(out.buf());
    fmt::format_to(it, "{}\n(\n", zones.size());
    for (const auto& [id, cells] : zones) {
      fmt::format_to(it, "    {}\n    {{\n        type cellZone;\n        cellLabels List<label> {}\n(\n",
                     foam_word(region_name(mesh.region_names, id)), cells.size());
      for (Index c : cells) {
        fmt::format_to(it, FMT_COMPILE("{}\n"), c);
        PDR_TRY(out.maybe_flush());
      }
      fmt::format_to(it, ")\n;\n    }}\n");
    }
    fmt::format_to(it, ")\n");
    return {};
  });
}

}  // namespace

Status write_foam(const VolumeMesh& mesh, const std::filesystem::path& dir) {
  const std::size_t cells = mesh.tets.size() + mesh.prisms.size() + mesh.pyramids.size();
  if (mesh.mixed()) {
    PDR_ASSIGN_OR_RETURN(MixedCellFaces cf, mixed_cell_faces(mesh));
    return write_foam_faces(mesh, cf, cells, dir);
  }
  PDR_ASSIGN_OR_RETURN(CellFaces cf, cell_faces(mesh.tets, mesh.points.size()));
  if (cells == 0) return invalid_input("an OpenFOAM polyMesh needs at least one tet");
  return write_foam_faces(mesh, cf, cells, dir);
}

}  // namespace pdrmesh::volio
