// SPDX-License-Identifier: AGPL-3.0-or-later
// A tetrahedral volume mesh as exchanged with files and between pipeline stages.
// (The refiner works on its own adjacency structure and converts to and from this.)
#pragma once

#include <map>
#include <string>
#include <vector>

#include "pdrmesh/types.hpp"

namespace pdrmesh {

/// Every tet is positively oriented: signed_volume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]) > 0
/// (the VTK/Gmsh/Medit convention). `boundary` lists the boundary triangles
/// oriented outward with one `boundary_ids` entry each; `tet_regions` is
/// empty or holds one integer per tet (a region, or the octree leaf that made it).
/// `boundary_names` names some boundary ids (carried from the input surface),
/// `region_names` some region ids (regions.hpp). A mesh of several regions
/// lists their interfaces in `boundary` too: faces shared by two tets of
/// different regions, each once, with their input surface ids.
/// `prisms` and `pyramids` are empty in a tetrahedral mesh; a mixed mesh (prism
/// boundary layers) holds them beside the tets, numbered and checked as
/// mixed_cells.hpp draws them. `prism_regions` and `pyramid_regions` are empty,
/// or hold the region of each prism and pyramid when the cells have regions
/// (regions_fit: on every cell or on none).
struct VolumeMesh {
  std::vector<Vec3> points;
  std::vector<Tet> tets;
  std::vector<Tri> boundary;
  std::vector<int> boundary_ids;
  std::vector<int> tet_regions;
  std::map<int, std::string> boundary_names;
  std::map<int, std::string> region_names;
  std::vector<Prism> prisms;
  std::vector<Pyramid> pyramids;
  std::vector<int> prism_regions;
  std::vector<int> pyramid_regions;

  bool mixed() const { return !prisms.empty() || !pyramids.empty(); }
  /// Whether the cells carry regions (a mesh without tets may have them on its prisms).
  bool has_regions() const { return !tet_regions.empty() || !prism_regions.empty() || !pyramid_regions.empty(); }
  /// Whether the regions are on every cell of every kind, or on none.
  bool regions_fit() const {
    return !has_regions() || (tet_regions.size() == tets.size() && prism_regions.size() == prisms.size() &&
                              pyramid_regions.size() == pyramids.size());
  }
};

/// The name a format writes for boundary id `id`: its entry in `names`, else
/// "surface_<id>" (the name unnamed surfaces have always had).
inline std::string boundary_name(const std::map<int, std::string>& names, int id) {
  const auto it = names.find(id);
  return it != names.end() ? it->second : "surface_" + std::to_string(id);
}

/// The name a format writes for region `id`: its entry in `names`, else "region_<id>".
inline std::string region_name(const std::map<int, std::string>& names, int id) {
  const auto it = names.find(id);
  return it != names.end() ? it->second : "region_" + std::to_string(id);
}

}  // namespace pdrmesh
