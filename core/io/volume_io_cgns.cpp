// SPDX-License-Identifier: AGPL-3.0-or-later
// CGNS output (.cgns) through libcgns (HDF5 files): one base "Base" (3-D),
// one unstructured zone "Zone" holding the points (CoordinateX/Y/Z, doubles),
// a TETRA_4 section "Tetrahedra" numbering the tets 1..T in mesh order, and
// per boundary id (ascending) a TRI_3 section with that id's triangles (mesh
// order) numbered after the tets. Each section has a boundary condition (BC_t)
// of the same name over its element range (PointRange, GridLocation
// FaceCenter), of type BCTypeUserDefined, and a family of that name (FamilyName),
// which is where SU2 and most CGNS readers take the marker name from.
// Names are boundary_name(), cut to CGNS's 32 characters and made unique.
// A mesh with regions has one TETRA_4 section per region instead (ascending
// id, named by region_name(), its tets in mesh order; the tets are numbered
// in that order). HDF5 records each object's creation time, so two
// writes of one mesh differ in those bytes (the only output that is not
// byte-identical).
#include <cgnslib.h>

#include <algorithm>
#include <mutex>
#include <set>
#include <string>

#include "volume_io_detail.hpp"

namespace pdrmesh::volio {
namespace {

// libcgns keeps its open files and error text in globals: one writer at a time.
std::mutex cgns_mutex;

constexpr std::size_t kCgnsNameMax = 32;

/// A CGNS node name: at most 32 characters, no '/' (the path separator), and
/// not "." or ".." ; unique among `used` (a suffix "_<id>" otherwise).
std::string cgns_name(std::string name, int id, std::set<std::string>& used) {
  std::replace(name.begin(), name.end(), '/', '_');
  if (name.empty() || name == "." || name == "..") name = fmt::format("surface_{}", id);
  if (name.size() > kCgnsNameMax) name.resize(kCgnsNameMax);
  if (used.count(name) != 0 || name == "Tetrahedra") {
    const std::string suffix = fmt::format("_{}", id);
    name = name.substr(0, kCgnsNameMax - suffix.size()) + suffix;
  }
  used.insert(name);
  return name;
}

/// Closes the file on every path out of write_cgns.
class CgnsFile {
 public:
  ~CgnsFile() {
    if (fn_ >= 0) cg_close(fn_);
  }
  int* handle() { return &fn_; }
  int fn() const { return fn_; }
  /// Closes now, reporting a failure to finish the file.
  int close() {
    const int rc = cg_close(fn_);
    fn_ = -1;
    return rc;
  }

 private:
  int fn_ = -1;
};

}  // namespace

Status write_cgns(const VolumeMesh& mesh, const std::filesystem::path& path) {
  if (mesh.tets.size() + mesh.boundary.size() >= static_cast<std::size_t>(std::numeric_limits<cgsize_t>::max()))
    return invalid_input(fmt::format("mesh has {} tets and {} boundary triangles; this libcgns numbers elements in "
                                     "32 bits",
                                     mesh.tets.size(), mesh.boundary.size()));
  const std::lock_guard lock(cgns_mutex);
  const auto failed = [&](std::string_view what) {
    return io_error(fmt::format("{}: CGNS {} failed: {}", path.string(), what, cg_get_error()));
  };
  CgnsFile file;
  if (cg_set_file_type(CG_FILE_HDF5) != CG_OK) return failed("file type");
  if (cg_open(path.c_str(), CG_MODE_WRITE, file.handle()) != CG_OK) return failed("open");
  const int fn = file.fn();
  int base = 0, zone = 0, node = 0;
  if (cg_base_write(fn, "Base", 3, 3, &base) != CG_OK) return failed("base");
  cgsize_t size[3] = {static_cast<cgsize_t>(mesh.points.size()), static_cast<cgsize_t>(mesh.tets.size()), 0};
  if (cg_zone_write(fn, base, "Zone", size, CGNS_ENUMV(Unstructured), &zone) != CG_OK) return failed("zone");

  std::vector<double> coord(mesh.points.size());
  for (int k = 0; k < 3; ++k) {
    for (std::size_t i = 0; i < mesh.points.size(); ++i) coord[i] = mesh.points[i][static_cast<std::size_t>(k)];
    const char* name = k == 0 ? "CoordinateX" : k == 1 ? "CoordinateY" : "CoordinateZ";
    if (cg_coord_write(fn, base, zone, CGNS_ENUMV(RealDouble), name, coord.data(), &node) != CG_OK)
      return failed("coordinates");
  }
  coord = {};

  std::set<std::string> used;
  std::vector<cgsize_t> conn;
  conn.reserve(4 * mesh.tets.size());
  const auto tets = static_cast<cgsize_t>(mesh.tets.size());
  if (mesh.tet_regions.size() != mesh.tets.size()) {
    for (const Tet& t : mesh.tets)
      for (Index v : t) conn.push_back(static_cast<cgsize_t>(v) + 1);
    if (cg_section_write(fn, base, zone, "Tetrahedra", CGNS_ENUMV(TETRA_4), 1, tets, 0, conn.data(), &node) != CG_OK)
      return failed("tetrahedra");
  } else {
    std::vector<std::size_t> by_region(mesh.tets.size());
    for (std::size_t i = 0; i < by_region.size(); ++i) by_region[i] = i;
    std::stable_sort(by_region.begin(), by_region.end(),
                     [&](std::size_t a, std::size_t b) { return mesh.tet_regions[a] < mesh.tet_regions[b]; });
    cgsize_t first = 1;
    for (std::size_t k = 0; k < by_region.size();) {
      const int id = mesh.tet_regions[by_region[k]];
      conn.clear();
      for (; k < by_region.size() && mesh.tet_regions[by_region[k]] == id; ++k)
        for (Index v : mesh.tets[by_region[k]]) conn.push_back(static_cast<cgsize_t>(v) + 1);
      const auto count = static_cast<cgsize_t>(conn.size() / 4);
      const std::string name = cgns_name(region_name(mesh.region_names, id), id, used);
      if (cg_section_write(fn, base, zone, name.c_str(), CGNS_ENUMV(TETRA_4), first, first + count - 1, 0, conn.data(),
                           &node) != CG_OK)
        return failed(fmt::format("region section {}", name));
      first += count;
    }
  }

  std::vector<std::size_t> order(mesh.boundary.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return mesh.boundary_ids[a] < mesh.boundary_ids[b]; });
  cgsize_t next = tets + 1;
  for (std::size_t k = 0; k < order.size();) {
    const int id = mesh.boundary_ids[order[k]];
    conn.clear();
    for (; k < order.size() && mesh.boundary_ids[order[k]] == id; ++k)
      for (Index v : mesh.boundary[order[k]]) conn.push_back(static_cast<cgsize_t>(v) + 1);
    const auto count = static_cast<cgsize_t>(conn.size() / 3);
    const std::string name = cgns_name(boundary_name(mesh.boundary_names, id), id, used);
    const cgsize_t range[2] = {next, next + count - 1};
    int family = 0, bc = 0;
    if (cg_section_write(fn, base, zone, name.c_str(), CGNS_ENUMV(TRI_3), range[0], range[1], 0, conn.data(),
                         &node) != CG_OK)
      return failed(fmt::format("section {}", name));
    if (cg_family_write(fn, base, name.c_str(), &family) != CG_OK) return failed(fmt::format("family {}", name));
    if (cg_boco_write(fn, base, zone, name.c_str(), CGNS_ENUMV(BCTypeUserDefined), CGNS_ENUMV(PointRange), 2, range,
                      &bc) != CG_OK ||
        cg_boco_gridlocation_write(fn, base, zone, bc, CGNS_ENUMV(FaceCenter)) != CG_OK)
      return failed(fmt::format("boundary condition {}", name));
    if (cg_goto(fn, base, "Zone_t", zone, "ZoneBC_t", 1, "BC_t", bc, "end") != CG_OK ||
        cg_famname_write(name.c_str()) != CG_OK)
      return failed(fmt::format("family name of {}", name));
    next += count;
  }
  if (file.close() != CG_OK) return failed("close");
  return {};
}

}  // namespace pdrmesh::volio
