// SPDX-License-Identifier: AGPL-3.0-or-later
// The closest point of a triangle to a point, for distance queries of the
// kernel (the sizing field's nearest background tet, the refiner's boundary
// reject). A distance in floating point, not an orientation: it decides
// spacing (which candidates the refiner keeps), never the mesh's topology.
#pragma once

#include "pdrmesh/types.hpp"

namespace pdrmesh {

/// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5).
inline Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = va + vb + vc;
  if (!(denom > 0)) return a;  // degenerate triangle: any vertex is as good
  return a + (vb / denom) * ab + (vc / denom) * ac;
}

}  // namespace pdrmesh
