// SPDX-License-Identifier: AGPL-3.0-or-later
// Prisms and pyramids beside tets (VolumeMesh::prisms, ::pyramids): their local
// numbering, drawn once, how one is cut into tets, and the checks of a mixed mesh.
//
// Prism (wedge), the VTK and Gmsh order:    Pyramid, the VTK order:
//
//        5                                          4
//      .'|`.          3 = (0,0,1)                 .'|`.        base 0 = (0,0,0) 1 = (1,0,0)
//    3 - - - 4        4 = (1,0,1)              .' / | \ `.          2 = (1,1,0) 3 = (0,1,0)
//    |   |   |        5 = (0,1,1)            3 - / -+- \ -2    apex 4 above the base
//    |   2   |        0 = (0,0,0)            | /   |   \ |
//    | .' `. |        1 = (1,0,0)            0 - - - - - 1     the base (0, 1, 2, 3) turns
//    0 - - - 1        2 = (0,1,0)                              counterclockwise seen from 4
//
// A prism's bottom (0, 1, 2) turns counterclockwise seen from its top: its
// right-hand normal points into the prism; vertex i + 3 lies above vertex i.
// Outward faces: bottom (0, 2, 1), top (3, 4, 5), quads (0, 1, 4, 3),
// (1, 2, 5, 4), (2, 0, 3, 5). A pyramid's outward faces: base (0, 3, 2, 1),
// triangles (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4).
//
// Cutting into tets: every quad face is cut by the diagonal from its vertex
// with the smallest global index (Dompierre, Labbe, Vallet and Camarero, "How
// to subdivide pyramids, prisms and hexahedra into tetrahedra", IMR 1999), so
// two cells sharing a quad cut it the same way and the tets of a conforming
// mixed mesh form a conforming tet mesh. A prism gives three tets, a pyramid two.
//
// A cell is positive when every tet of every such cut (any diagonal on any
// quad) is positive by exact::orient3d: then its faces do not fold, whichever
// diagonal a neighbour or a solver picks.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/types.hpp"
#include "pdrmesh/validate.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

namespace mixed {

/// Outward triangle and quad faces of a prism, as local vertices.
inline constexpr int kPrismTriangles[2][3] = {{0, 2, 1}, {3, 4, 5}};
inline constexpr int kPrismQuads[3][4] = {{0, 1, 4, 3}, {1, 2, 5, 4}, {2, 0, 3, 5}};
/// Outward faces of a pyramid.
inline constexpr int kPyramidBase[4] = {0, 3, 2, 1};
inline constexpr int kPyramidTriangles[4][3] = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};

}  // namespace mixed

/// The three tets of prism `p` cut by the smallest-index rule (positively
/// ordered when the prism is positive).
std::array<Tet, 3> prism_tets(const Prism& p);
/// The two tets of pyramid `p` cut by the smallest-index rule.
std::array<Tet, 2> pyramid_tets(const Pyramid& p);

/// True when every tet of every cut of the prism (pyramid) is positive, exactly.
bool prism_positive(const std::vector<Vec3>& points, const Prism& p);
bool pyramid_positive(const std::vector<Vec3>& points, const Pyramid& p);

/// The mixed mesh as a tet mesh: its tets, then three tets per prism (prism i
/// gives tets tets.size() + 3i ... + 3i + 2), then two per pyramid; the same
/// points, boundary and names; each tet the region of its cell when the mesh
/// has regions (VolumeMesh::prism_regions), else none.
VolumeMesh split_to_tets(const VolumeMesh& mesh);

/// validate_mesh of a mixed mesh: indices and distinct vertices of every
/// prism and pyramid, each cell positive (prism_positive), every quad face in
/// two cells or none of the tets' faces (a quad never meets two triangles),
/// then validate_mesh of split_to_tets (conformity, boundary = surface, volume).
/// validate_mesh calls this for a mesh with prisms or pyramids.
ValidationReport validate_mixed_mesh(const VolumeMesh& mesh, const SurfaceMesh* surface,
                                     const ValidationOptions& options);

/// The faces of a mixed mesh as a finite-volume solver sees them, in the order
/// cell_faces (cell_faces.hpp) gives a tet mesh's: cells are the tets, then the
/// prisms, then the pyramids; the faces two cells share by ascending (owner,
/// neighbour), owner the lower cell, then the faces of one cell by ascending
/// (cell, local face). Each face is oriented out of its owner; a triangle has
/// face[3] == kNoIndex.
struct MixedCellFaces {
  std::vector<std::array<Index, 4>> faces;
  std::vector<Index> owner;      ///< one per face
  std::vector<Index> neighbour;  ///< one per internal face
  std::size_t internal() const { return neighbour.size(); }
};

/// The faces of a mixed mesh of positive cells. An index out of range, or a
/// face in three or more cells, is `invalid_input` naming it.
Result<MixedCellFaces> mixed_cell_faces(const VolumeMesh& mesh);

/// What the CFD user reads of prism layers: stacks of prisms grown from
/// boundary triangles, found by walking from a boundary triangle through
/// prisms that share their triangle faces.
struct LayerReport {
  std::size_t prisms = 0, pyramids = 0, tets = 0;
  std::size_t stacks = 0;          ///< boundary triangles with a prism on them
  std::size_t min_layers = 0, max_layers = 0;
  std::size_t full_stacks = 0;     ///< stacks with max_layers prisms
  double first_height_min = 0, first_height_max = 0;  ///< the first prism's height (mean of its three rising edges)
  double ratio_min = 0, ratio_max = 0;  ///< height of a prism over the one below it
  double aspect_max = 0;  ///< the largest bottom edge over height of any prism
};

/// The layer figures of a mixed mesh (all zero without prisms).
LayerReport measure_layers(const VolumeMesh& mesh);
std::string format_layers(const LayerReport& r);
std::string layers_to_json(const LayerReport& r);

}  // namespace pdrmesh
