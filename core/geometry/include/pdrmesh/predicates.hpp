// SPDX-License-Identifier: AGPL-3.0-or-later
// Exact geometric predicates: the only place combinatorial decisions come from.
//
// Wraps Shewchuk's adaptive-precision predicates as exported by libtet. They are
// initialised once, at load time, with TetGen's static filter switched off, so
// every answer is the sign of the exact determinant. (TetGen itself re-runs
// exactinit with a bounding-box filter; that is one reason TetGen only ever runs
// in a child process, see tetgen_adapter.hpp.)
//
// Sign convention (the one used everywhere in pdrmesh):
//   orient3d(a, b, c, d) > 0  <=>  signed_volume(a, b, c, d) > 0
//                           <=>  d lies on the side that the right-hand normal
//                                of triangle (a, b, c) points to.
// Note this is the opposite of Shewchuk's own orient3d sign.
#pragma once

#include "pdrmesh/types.hpp"

namespace pdrmesh::exact {

/// Sign (+1, 0, -1) of the signed volume of (a, b, c, d), exactly.
int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// Sign (+1, 0, -1) of the orientation of the projections of a, b, c onto the
/// coordinate plane that drops axis `drop` (0, 1 or 2): +1 when counterclockwise
/// in the (u, v) = the two remaining axes in cyclic order (drop 0: (y, z);
/// drop 1: (z, x); drop 2: (x, y)). Exact, since projection drops a coordinate.
int orient2d(const Vec3& a, const Vec3& b, const Vec3& c, int drop);

/// +1 when e lies strictly inside the circumsphere of the positively oriented
/// tetrahedron (a, b, c, d), 0 on it, -1 outside. Exact.
int insphere(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, const Vec3& e);

/// True when a, b, c are collinear (the triangle has zero area), exactly.
bool collinear(const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace pdrmesh::exact
