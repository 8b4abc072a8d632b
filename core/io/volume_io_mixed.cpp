// SPDX-License-Identifier: AGPL-3.0-or-later
// Writers of mixed meshes (tets, prisms, pyramids: VolumeMesh::mixed()): VTK
// XML .vtu (ascii), Gmsh 4.1 .msh and UGRID (ascii and C-binary) here; Medit
// .mesh and SU2 through their one writer for tets and mixed cells (write_medit,
// write_su2). Medit .meshb, CGNS and polyMesh write mixed cells in their own
// writers; write_format sends the others' mixed meshes here.
//
// Vertex orders (our order is VTK's, mixed_cells.hpp):
//  - VTK (.vtu), SU2 and Gmsh: ours (wedge 13 / prism 6, pyramid 14 / 7); SU2
//    uses VTK's type numbers and windings.
//  - Medit: Prisms and Pyramids in the same order as Gmsh, which reads and
//    writes them unpermuted.
//  - UGRID: a mirror of VTK's (nasa/refine ref_export.c, VTK_WEDGE_ORDER and
//    VTK_PYRAMID_ORDER): prism (1, 0, 2, 4, 3, 5), pyramid (1, 0, 4, 2, 3)
//    of our vertices.
#include <fmt/compile.h>

#include <algorithm>
#include <numeric>

#include "pdrmesh/boundary_names.hpp"
#include "volume_io_detail.hpp"

namespace pdrmesh::volio {
namespace {

Status check_cells(const VolumeMesh& mesh) {
  const std::size_t n = mesh.points.size();
  for (std::size_t c = 0; c < mesh.prisms.size(); ++c)
    for (Index v : mesh.prisms[c])
      if (v >= n) return invalid_input(fmt::format("prism {} refers to point {} of {}", c, v, n));
  for (std::size_t c = 0; c < mesh.pyramids.size(); ++c)
    for (Index v : mesh.pyramids[c])
      if (v >= n) return invalid_input(fmt::format("pyramid {} refers to point {} of {}", c, v, n));
  return {};
}

/// Boundary triangle positions grouped by id (ascending), mesh order within an id.
std::vector<std::size_t> by_id(const VolumeMesh& mesh) {
  std::vector<std::size_t> order(mesh.boundary.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return mesh.boundary_ids[a] < mesh.boundary_ids[b]; });
  return order;
}

Status write_mixed_vtu(const VolumeMesh& mesh, const std::filesystem::path& path) {
  const std::size_t nt = mesh.tets.size(), nq = mesh.prisms.size(), ny = mesh.pyramids.size(),
                    nb = mesh.boundary.size();
  OutputFile out(path);
  PDR_TRY(out.open());
  auto& b = out.buf();
  auto it = std::back_inserter(b);
  fmt::format_to(it,
                 "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
                 "header_type=\"UInt64\">\n  <UnstructuredGrid>\n");
  write_vtu_field_data(mesh, b);
  fmt::format_to(it,
                 "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n"
                 "      <Points>\n        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n",
                 mesh.points.size(), nt + nq + ny + nb);
  for (const Vec3& p : mesh.points) fmt::format_to(it, FMT_COMPILE("{} {} {}\n"), p[0], p[1], p[2]);
  fmt::format_to(it, "        </DataArray>\n      </Points>\n      <Cells>\n"
                     "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
  const auto cells = [&](const auto& list) -> Status {
    for (const auto& c : list) {
      put_cell(b, c, 0);
      b.push_back('\n');
      PDR_TRY(out.maybe_flush());
    }
    return {};
  };
  PDR_TRY(cells(mesh.tets));
  PDR_TRY(cells(mesh.prisms));
  PDR_TRY(cells(mesh.pyramids));
  PDR_TRY(cells(mesh.boundary));
  fmt::format_to(it, "        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
  std::size_t offset = 0;
  const auto offsets = [&](std::size_t n, std::size_t k) {
    for (std::size_t i = 0; i < n; ++i) fmt::format_to(it, FMT_COMPILE("{}\n"), offset += k);
  };
  offsets(nt, 4);
  offsets(nq, 6);
  offsets(ny, 5);
  offsets(nb, 3);
  fmt::format_to(it, "        </DataArray>\n        <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
  const auto types = [&](std::size_t n, int type) {
    for (std::size_t i = 0; i < n; ++i) fmt::format_to(it, FMT_COMPILE("{}\n"), type);
  };
  types(nt, kVtkTetra);
  types(nq, kVtkWedge);
  types(ny, kVtkPyramid);
  types(nb, kVtkTriangle);
  fmt::format_to(it, "        </DataArray>\n      </Cells>\n      <CellData Scalars=\"surface_id\">\n"
                     "        <DataArray type=\"Int32\" Name=\"surface_id\" format=\"ascii\">\n");
  types(nt + nq + ny, 0);
  for (int id : mesh.boundary_ids) fmt::format_to(it, FMT_COMPILE("{}\n"), id);
  fmt::format_to(it, "        </DataArray>\n");
  if (mesh.has_regions()) {  // as write_vtu's `region`, 0 for triangles
    fmt::format_to(it, "        <DataArray type=\"Int32\" Name=\"region\" format=\"ascii\">\n");
    for (const std::vector<int>* regions : {&mesh.tet_regions, &mesh.prism_regions, &mesh.pyramid_regions})
      for (int r : *regions) fmt::format_to(it, FMT_COMPILE("{}\n"), r);
    types(nb, 0);
    fmt::format_to(it, "        </DataArray>\n");
  }
  fmt::format_to(it, "      </CellData>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
  return out.close();
}

Status write_mixed_gmsh(const VolumeMesh& mesh, const std::filesystem::path& path) {
  const std::size_t np = mesh.points.size(), nt = mesh.tets.size(), nq = mesh.prisms.size(),
                    ny = mesh.pyramids.size();
  const std::vector<std::size_t> order = by_id(mesh);
  const std::vector<int> ids = distinct(mesh.boundary_ids);
  // Volumes: one per region (ascending id), or one named "volume".
  const bool regions = mesh.has_regions();
  const std::vector<int> region_ids =
      regions ? distinct([&] {
        std::vector<int> all = mesh.tet_regions;
        all.insert(all.end(), mesh.prism_regions.begin(), mesh.prism_regions.end());
        all.insert(all.end(), mesh.pyramid_regions.begin(), mesh.pyramid_regions.end());
        return all;
      }())
              : std::vector<int>{0};
  const bool positive = std::all_of(region_ids.begin(), region_ids.end(), [](int r) { return r > 0; });
  Box box;
  for (const Vec3& p : mesh.points) box.add(p);
  OutputFile out(path);
  PDR_TRY(out.open());
  auto& b = out.buf();
  auto it = std::back_inserter(b);
  // Physical and entity tags: surface k (ids ascending) is k + 1; volume v is
  // entity v + 1, its physical the region id (when all are positive) or
  // ids.size() + v + 1.
  const auto volume_physical = [&](std::size_t v) {
    return regions && positive ? region_ids[v] : static_cast<int>(ids.size() + v + 1);
  };
  fmt::format_to(it, "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n{}\n", ids.size() + region_ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k)
    fmt::format_to(it, "2 {} \"{}\"\n", k + 1, boundary_name(mesh.boundary_names, ids[k]));
  for (std::size_t v = 0; v < region_ids.size(); ++v)
    fmt::format_to(it, "3 {} \"{}\"\n", volume_physical(v),
                   regions ? region_name(mesh.region_names, region_ids[v]) : std::string("volume"));
  fmt::format_to(it, "$EndPhysicalNames\n$Entities\n0 0 {} {}\n", ids.size(), region_ids.size());
  const std::string bounds = fmt::format("{} {} {} {} {} {}", box.lo[0], box.lo[1], box.lo[2], box.hi[0], box.hi[1], box.hi[2]);
  for (std::size_t k = 0; k < ids.size(); ++k) fmt::format_to(it, "{} {} 1 {} 0\n", k + 1, bounds, k + 1);
  for (std::size_t v = 0; v < region_ids.size(); ++v)
    fmt::format_to(it, "{} {} 1 {} 0\n", v + 1, bounds, volume_physical(v));
  fmt::format_to(it, "$EndEntities\n$Nodes\n1 {} 1 {}\n3 1 0 {}\n", np, np, np);
  for (std::size_t i = 1; i <= np; ++i) fmt::format_to(it, FMT_COMPILE("{}\n"), i);
  for (const Vec3& p : mesh.points) fmt::format_to(it, FMT_COMPILE("{} {} {}\n"), p[0], p[1], p[2]);
  // Element tags follow the mesh's order within each kind (tets, prisms,
  // pyramids, triangles), whatever block holds the element.
  struct Block {
    int dim, entity, type;
    std::vector<std::size_t> members;
    std::size_t tag0;
  };
  std::vector<Block> blocks;
  const auto of_region = [&](const std::vector<int>& cell_regions, std::size_t n, std::size_t v) {
    std::vector<std::size_t> members;
    for (std::size_t i = 0; i < n; ++i)
      if (!regions || cell_regions[i] == region_ids[v]) members.push_back(i);
    return members;
  };
  for (std::size_t v = 0; v < region_ids.size(); ++v) {
    const int entity = static_cast<int>(v + 1);
    blocks.push_back({3, entity, 4, of_region(mesh.tet_regions, nt, v), 0});
    blocks.push_back({3, entity, 6, of_region(mesh.prism_regions, nq, v), nt});
    blocks.push_back({3, entity, 7, of_region(mesh.pyramid_regions, ny, v), nt + nq});
  }
  for (std::size_t s = 0, k = 0; s < ids.size(); ++s) {
    Block tris{2, static_cast<int>(s + 1), 2, {}, nt + nq + ny};
    for (; k < order.size() && mesh.boundary_ids[order[k]] == ids[s]; ++k) tris.members.push_back(order[k]);
    blocks.push_back(std::move(tris));
  }
  std::erase_if(blocks, [](const Block& k) { return k.members.empty(); });
  const std::size_t ncells = nt + nq + ny + mesh.boundary.size();
  fmt::format_to(it, "$EndNodes\n$Elements\n{} {} 1 {}\n", blocks.size(), ncells, ncells);
  for (const Block& k : blocks) {
    fmt::format_to(it, "{} {} {} {}\n", k.dim, k.entity, k.type, k.members.size());
    for (std::size_t i : k.members) {
      fmt::format_to(it, FMT_COMPILE("{} "), k.tag0 + i + 1);
      switch (k.type) {
        case 4: put_cell(b, mesh.tets[i], 1); break;
        case 6: put_cell(b, mesh.prisms[i], 1); break;
        case 7: put_cell(b, mesh.pyramids[i], 1); break;
        default: put_cell(b, mesh.boundary[i], 1); break;
      }
      b.push_back('\n');
      PDR_TRY(out.maybe_flush());
    }
  }
  fmt::format_to(it, "$EndElements\n");
  return out.close();
}

/// UGRID, ascii (`binary` false) or C-binary int32/float64 in the given byte order.
Status write_mixed_ugrid(const VolumeMesh& mesh, const std::filesystem::path& path, bool binary, bool little) {
  OutputFile out(path);
  PDR_TRY(out.open());
  auto& b = out.buf();
  auto it = std::back_inserter(b);
  std::size_t on_line = 0;  // ascii: values on the current line
  const auto integer = [&](std::int64_t v, bool end_line) {
    if (binary) {
      put(b, static_cast<std::int32_t>(v), little);
      return;
    }
    fmt::format_to(it, FMT_COMPILE("{}{}"), on_line++ ? " " : "", v);
    if (end_line) b.push_back('\n'), on_line = 0;
  };
  const auto real = [&](double v, bool end_line) {
    if (binary) {
      put(b, v, little);
      return;
    }
    fmt::format_to(it, FMT_COMPILE("{}{}"), on_line++ ? " " : "", v);
    if (end_line) b.push_back('\n'), on_line = 0;
  };
  const std::int64_t counts[7] = {static_cast<std::int64_t>(mesh.points.size()),
                                  static_cast<std::int64_t>(mesh.boundary.size()),
                                  0,
                                  static_cast<std::int64_t>(mesh.tets.size()),
                                  static_cast<std::int64_t>(mesh.pyramids.size()),
                                  static_cast<std::int64_t>(mesh.prisms.size()),
                                  0};
  for (int i = 0; i < 7; ++i) integer(counts[i], i == 6);
  for (const Vec3& p : mesh.points) {
    real(p[0], false);
    real(p[1], false);
    real(p[2], true);
    PDR_TRY(out.maybe_flush());
  }
  const auto cell = [&](const auto& c, std::initializer_list<int> order) -> Status {
    std::size_t i = 0;
    for (int k : order) integer(static_cast<std::int64_t>(c[k]) + 1, ++i == order.size());
    return out.maybe_flush();
  };
  for (const Tri& t : mesh.boundary) PDR_TRY(cell(t, {0, 1, 2}));
  for (int id : mesh.boundary_ids) integer(id, true);
  for (const Tet& t : mesh.tets) PDR_TRY(cell(t, {0, 1, 2, 3}));
  for (const Pyramid& p : mesh.pyramids) PDR_TRY(cell(p, {1, 0, 4, 2, 3}));
  for (const Prism& p : mesh.prisms) PDR_TRY(cell(p, {1, 0, 2, 4, 3, 5}));
  return out.close();
}

}  // namespace

Status write_mixed(const VolumeMesh& mesh, VolumeFormat format, const std::filesystem::path& path) {
  PDR_TRY(check_cells(mesh));
  switch (format) {
    case VolumeFormat::kMedit: return write_medit(mesh, path);
    case VolumeFormat::kVtu: return write_mixed_vtu(mesh, path);
    case VolumeFormat::kGmsh: return write_mixed_gmsh(mesh, path);
    case VolumeFormat::kSu2: return write_su2(mesh, path);
    case VolumeFormat::kUgridAscii: return write_mixed_ugrid(mesh, path, false, true);
    case VolumeFormat::kUgridLittle: return write_mixed_ugrid(mesh, path, true, true);
    case VolumeFormat::kUgridBig: return write_mixed_ugrid(mesh, path, true, false);
    default: break;
  }
  return internal_error("write_mixed: no writer of mixed meshes for this format");
}

}  // namespace pdrmesh::volio
