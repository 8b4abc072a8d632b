// SPDX-License-Identifier: AGPL-3.0-or-later
// The finite-volume figures an OpenFOAM user reads first in checkMesh's
// report, computed as checkMesh computes them (primitiveMeshCheck and
// primitiveMeshTools): face non-orthogonality and face skewness.
//
// With C_o, C_n the centroids of a face's owner and neighbour tets, c_f and S
// the face's centroid and area vector (normal times area, out of the owner):
//  - non-orthogonality: the angle between d = C_n - C_o and S, internal faces
//    only. The maximum is acos of the smallest cosine, the mean is acos of the
//    mean cosine (checkMesh's "average"), not the mean of the angles.
//  - skewness: the distance from c_f to the point where the line C_o -> C_n
//    crosses the face plane, over a normalising distance: the largest extent
//    of the face from c_f in the direction of that offset, at least 0.2 |d|.
//    A hull face uses the owner's mirror image across the face (d = 2 x the
//    normal part of c_f - C_o, so 0.4 of its half) as checkMesh does; the
//    maximum is over every face.
#pragma once

#include <cstddef>
#include <span>
#include <string>

#include "pdrmesh/cell_faces.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

struct FoamQuality {
  std::size_t internal_faces = 0;
  std::size_t boundary_faces = 0;
  double max_non_orthogonality = 0;   ///< degrees
  double mean_non_orthogonality = 0;  ///< degrees: acos of the mean cosine
  /// Internal faces over 70 degrees; those at 90 degrees or more (cosine at
  /// most 1e-15) are also counted in faces_over_90. checkMesh's "severely
  /// non-orthogonal" count is faces_over_70 - faces_over_90, its
  /// "non-orthogonality errors" faces_over_90.
  std::size_t faces_over_70 = 0;
  std::size_t faces_over_90 = 0;
  double max_skewness = 0;
};

/// The figures of `faces` (cell_faces of `tets`) over `points`.
FoamQuality measure_foam_quality(std::span<const Vec3> points, std::span<const Tet> tets, const CellFaces& faces);

/// The figures of a mesh; a face shared by three or more tets is `invalid_input`.
Result<FoamQuality> measure_foam_quality(const VolumeMesh& mesh);

/// "OpenFOAM non-orthogonality max .. mean .., faces over 70 degrees ..; max skewness .." (a line).
std::string format_foam_quality(const FoamQuality& q);
/// A JSON object (one line) with the same figures.
std::string foam_quality_to_json(const FoamQuality& q);

}  // namespace pdrmesh
