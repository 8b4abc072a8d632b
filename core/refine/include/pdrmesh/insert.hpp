// SPDX-License-Identifier: AGPL-3.0-or-later
// Point location by walking, and point insertion by splitting the element that
// contains the point: a tet (1 -> 4), a face (2 -> 6, or 1 -> 3 on the hull) or
// an edge (each of its n tets in two). Frozen faces are never split, nor are
// edges on them. Every decision uses exact::orient3d.
#pragma once

#include <cstdint>
#include <string_view>

#include "pdrmesh/tet_mesh.hpp"
#include "pdrmesh/types.hpp"

namespace pdrmesh {

enum class LocationKind : std::uint8_t {
  kInTet,     ///< strictly inside `tet`
  kOnFace,    ///< in the relative interior of face `local` of `tet`
  kOnEdge,    ///< in the relative interior of edge `local` of `tet`
  kOnVertex,  ///< equal to vertex `local` of `tet`
  kOutside,   ///< in no alive tet
};

struct Location {
  LocationKind kind = LocationKind::kOutside;
  Index tet = kNoIndex;
  int local = -1;  ///< face, edge or vertex index in `tet` (topology.hpp)
};

/// Finds the tet that contains p, walking from `start` across faces that p lies
/// beyond (exact orient3d; a deterministic rotation of the exit face choice
/// avoids cycling). Falls back to a scan of all tets, in slot order, when the
/// walk reaches the hull or runs longer than the mesh is large (a non-convex
/// mesh or a dead start tet), so the answer is exact and deterministic.
Location locate(const TetMesh& mesh, Index start, const Vec3& p);

/// The walk of locate() alone, bounded: kOutside when it reaches a hull face
/// (or, unless cross_frozen, a frozen face) that p lies beyond with no other way
/// on, when it runs more than max_steps tets, or when start is not alive. Never
/// scans the mesh, so a kOutside answer does not prove that p is in no tet.
Location walk(const TetMesh& mesh, Index start, const Vec3& p, Index max_steps,
              bool cross_frozen = true);

/// The tet that contains p, searched breadth first across faces from
/// `start`, frozen ones included: where a walk from a near tet meets the hull
/// of a non-convex mesh, this gets round it after the tets in between.
/// kOutside when p is in none of the first max_tets tets reached (or start is
/// not alive).
Location search(const TetMesh& mesh, Index start, const Vec3& p, Index max_tets);

enum class InsertOutcome : std::uint8_t {
  kDone,           ///< inserted; the new tets are mesh.last_created()
  kTooClose,       ///< declined: p coincides with a vertex
  kConstrained,    ///< declined: p lies on a frozen face or an edge of one
  kOutside,        ///< declined: p lies in no tet
  kNotApplicable,  ///< declined: the edge has more than EdgeRing::kMax tets
};
std::string_view to_string(InsertOutcome o);

struct InsertResult {
  InsertOutcome outcome = InsertOutcome::kOutside;
  Index point = kNoIndex;  ///< the new point's index when kDone
  Location where;
};

/// Inserts p at a known location (as locate() returns it for p).
InsertResult insert_at(TetMesh& mesh, const Location& where, const Vec3& p);

/// locate() then insert_at().
InsertResult insert_point(TetMesh& mesh, Index start, const Vec3& p);

}  // namespace pdrmesh
