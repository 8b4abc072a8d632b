// SPDX-License-Identifier: AGPL-3.0-or-later
// The faces of a tet mesh as a finite-volume solver sees them: every face once,
// with the cell that owns it and, for an internal face, its neighbour cell, in
// OpenFOAM's polyMesh order. The polyMesh writer and the finite-volume quality
// figures (foam_quality.hpp) both use it.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/types.hpp"

namespace pdrmesh {

/// faces[0, internal) are the faces two tets share, in upper-triangular order
/// (ascending owner, then ascending neighbour, owner < neighbour);
/// faces[internal, end) the faces only one tet has (the hull), in ascending
/// (owner, local face) order. Each face is oriented out of its owner: its
/// right-hand normal points from the owner into the neighbour (or outward).
struct CellFaces {
  std::vector<Tri> faces;
  std::vector<Index> owner;      ///< one per face
  std::vector<Index> neighbour;  ///< one per internal face
  std::size_t internal() const { return neighbour.size(); }
};

/// The faces of positively oriented tets (every index below `points`). A face
/// that three or more tets share is `invalid_input`, naming the face and tets.
Result<CellFaces> cell_faces(std::span<const Tet> tets, std::size_t points);

}  // namespace pdrmesh
