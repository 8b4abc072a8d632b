// SPDX-License-Identifier: AGPL-3.0-or-later
// Basic value types shared by every module of the meshing kernel.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

namespace pdrmesh {

/// Index of a point, triangle or tetrahedron. 32 bits hold 4 billion entities,
/// which is beyond what one process meshes; global ids across a distributed job
/// use GlobalId.
using Index = std::uint32_t;
using GlobalId = std::uint64_t;
inline constexpr Index kNoIndex = std::numeric_limits<Index>::max();

using Vec3 = std::array<double, 3>;
using Tri = std::array<Index, 3>;  ///< a triangle: three point indices
using Tet = std::array<Index, 4>;  ///< a tetrahedron: four point indices (see topology.hpp)
using Prism = std::array<Index, 6>;    ///< a prism (wedge): six point indices (see mixed_cells.hpp)
using Pyramid = std::array<Index, 5>;  ///< a pyramid: quad base, then apex (see mixed_cells.hpp)

inline Vec3 operator+(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline Vec3 operator*(double s, const Vec3& a) { return {s * a[0], s * a[1], s * a[2]}; }
inline double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }
/// All three coordinates are finite (no NaN, no infinity).
inline bool is_finite(const Vec3& p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

/// Signed volume of tetrahedron (a, b, c, d), measured in doubles: positive when
/// d lies on the side of triangle abc that its right-hand normal points to.
/// For decisions use exact::orient3d (predicates.hpp), never the sign of this.
inline double signed_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return dot(cross(b - a, c - a), d - a) / 6.0;
}

/// Axis-aligned bounding box.
struct Box {
  Vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity()};
  Vec3 hi{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
          -std::numeric_limits<double>::infinity()};

  void add(const Vec3& p) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::fmin(lo[k], p[k]);
      hi[k] = std::fmax(hi[k], p[k]);
    }
  }
  bool empty() const { return lo[0] > hi[0]; }
  double diagonal() const { return empty() ? 0.0 : norm(hi - lo); }
};

}  // namespace pdrmesh
