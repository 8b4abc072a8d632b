// SPDX-License-Identifier: AGPL-3.0-or-later
// Local reconnection: flips 2-3, 3-2, 4-4 and general edge removal, accepted
// only when they lower the largest dihedral angle of the tets they replace
// (AFLR's min-max criterion).
//
// Decisions: every new tet must be positive by exact::orient3d (no epsilon).
// Measurements: dihedral angles in doubles. A flip never touches a frozen face:
// a frozen face is never removed, and an edge on a frozen face is never removed.
#pragma once

#include <cstdint>
#include <string_view>

#include "pdrmesh/tet_mesh.hpp"
#include "pdrmesh/types.hpp"

namespace pdrmesh {

/// What a flip did. Only kDone changes the mesh; the others are expected,
/// ordinary answers ("declined"), never errors.
enum class FlipOutcome : std::uint8_t {
  kDone,           ///< flipped; the new tets are mesh.last_created()
  kNotBetter,      ///< declined: no candidate is strictly better (some may also invert)
  kConstrained,    ///< declined: a frozen face would be removed, or regions differ
  kWouldInvert,    ///< declined: every candidate has a tet with orient3d <= 0 (flip23
                   ///< checks orientation before quality, so this takes precedence)
  kNotApplicable,  ///< declined: the configuration does not fit (hull face or
                   ///< edge, dead tet, wrong ring size, ring longer than kMaxRemovalRing)
};
std::string_view to_string(FlipOutcome o);

/// Cosine of the largest interior dihedral angle of tet (a, b, c, d): the flip
/// criterion (higher is better; 1 > regular tet's 1/3 > ... > -1 for a flat one).
/// Only meaningful for positive tets.
double max_dihedral_cosine(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// max_dihedral_cosine of tet k of `mesh`, evaluated in a canonical vertex
/// order so that the value depends on the vertex set only (which makes repeated
/// flipping terminate: the same tet always measures the same).
double tet_quality(const TetMesh& mesh, const Tet& k);

/// Longest ring remove_edge handles (Klincsek's O(n^3) triangulation search).
inline constexpr int kMaxRemovalRing = 8;

/// 2-3: removes face f of tet t (and its neighbour u), replacing the two tets
/// by three around the new edge joining their apexes.
FlipOutcome flip23(TetMesh& mesh, Index t, int f);

/// 3-2: removes edge e of tet t when exactly three tets surround it.
FlipOutcome flip32(TetMesh& mesh, Index t, int e);

/// 4-4: removes edge e of tet t when exactly four tets surround it, choosing the
/// better of the two diagonals of the ring.
FlipOutcome flip44(TetMesh& mesh, Index t, int e);

/// Flips read and fill the mesh's per-tet quality cache (TetMesh::cached_quality).
///
/// Edge removal for any interior edge with 3..kMaxRemovalRing tets around it:
/// n tets become 2(n-2), over the triangulation of the ring that maximises the
/// smallest max_dihedral_cosine (dynamic programming over the ring polygon).
FlipOutcome remove_edge(TetMesh& mesh, Index t, int e);

/// Edge removal that shortens: like remove_edge, but accepted when every new
/// tet's quality is above min(floor, the old tets' worst) (so a flip may lower
/// the local worst as long as it stays above `floor`), and only over
/// triangulations of the ring whose new edges are all strictly shorter than the
/// removed one (so repeated use ends: the multiset of edge lengths falls).
/// The refiner removes over-long edges with it. kNotApplicable for a NaN floor.
FlipOutcome remove_long_edge(TetMesh& mesh, Index t, int e, double floor);

}  // namespace pdrmesh
