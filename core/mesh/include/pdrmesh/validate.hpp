// SPDX-License-Identifier: AGPL-3.0-or-later
// The mesh validator: every test that makes a mesh calls it, and so does
// `pdrmesh validate`. All combinatorial checks are exact; only the volume
// comparison is a measurement with a relative tolerance.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

struct ValidationOptions {
  /// Relative tolerance of |mesh volume - enclosed volume| / enclosed volume.
  double volume_tolerance = 1e-9;
  /// At most this many messages are kept per check (all are counted).
  std::size_t max_messages_per_check = 10;
  /// The face check holds one slice of the points' faces at a time: this many
  /// slices (0: four from a million tets on, else one). The report is the same.
  std::size_t face_slices = 0;
};

struct ValidationReport {
  std::size_t tets = 0;
  std::size_t prisms = 0, pyramids = 0;  ///< of a mixed mesh (mixed_cells.hpp)
  std::size_t points = 0;
  std::size_t boundary_faces = 0;
  std::size_t regions = 0;          ///< distinct tet regions (0: the mesh carries none)
  std::size_t interface_faces = 0;  ///< listed boundary faces between two tets of different regions
  double volume = 0;           ///< sum of tet volumes
  double enclosed_volume = 0;  ///< of the surface, when one was given
  long long euler_volume = 0;   ///< V - E + F - T of the tet mesh
  long long euler_boundary = 0; ///< V - E + F of its boundary
  std::size_t error_count = 0;
  std::vector<std::string> errors;  ///< the first few of each kind

  bool ok() const { return error_count == 0; }
};

/// Checks, exactly: indices in range and distinct per tet; every tet positively
/// oriented (exact::orient3d); every face shared by at most two tets, with opposite
/// orientations (conformity, symmetric adjacency); no duplicate (coordinate-equal)
/// or unused points; the boundary a closed 2-manifold (every boundary edge in
/// exactly two boundary faces, used once each way; one fan per boundary vertex);
/// `mesh.boundary`, when present, equal to the derived boundary with one id per
/// face; V - E + F - T equal to half the boundary's Euler characteristic.
/// With a surface: the boundary equals the surface triangulation exactly (same
/// coordinates, same triangles, same orientation, and the same ids when the mesh
/// carries them) and the volume equals the enclosed volume.
/// With regions (mesh.tet_regions): a listed boundary face may also be an
/// interface, a face shared by two tets of different regions (either
/// orientation); an input triangle on such a face is one, every one of them
/// must be listed, and its shell's volume is not counted in the enclosed volume.
/// A mesh with prisms or pyramids goes to validate_mixed_mesh (mixed_cells.hpp).
/// Runs in parallel (oneTBB, fixed chunks): the report, messages and volume bits
/// included, is the same for any number of threads.
ValidationReport validate_mesh(const VolumeMesh& mesh, const SurfaceMesh* surface = nullptr,
                               const ValidationOptions& options = {});

/// Enclosed volume of a closed, outward-oriented surface (divergence theorem).
double enclosed_volume(const SurfaceMesh& surface);

/// Multi-line text: counts, then each kept error.
std::string format_validation(const ValidationReport& report);

/// ok, or invalid_input with the first errors.
Status validation_status(const ValidationReport& report);

}  // namespace pdrmesh
