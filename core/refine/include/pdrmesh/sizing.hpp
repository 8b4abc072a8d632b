// SPDX-License-Identifier: AGPL-3.0-or-later
// The point distribution function: the target edge length h(x) that the refiner
// drives every element towards (AFLR's "point distribution function").
//
// What h is
// ---------
// h(x) is a length, in the units of the input coordinates: the edge length the
// refiner aims for near x. It is built once per job from the input surface and
// the initial (boundary-conforming) tet mesh, then shipped to every worker.
//
//  1. Boundary spacing. A boundary point is a surface point used by at least one
//     triangle. Its spacing s(p) is the mean length of the distinct surface edges
//     incident to it.
//  2. Background values. The background mesh (e.g. the TetGen initial mesh) must
//     contain every boundary point, matched by exactly equal coordinates. A
//     background point matched to a boundary point gets s(p). Every other
//     background point (TetGen's interior Steiner points) gets the inverse-
//     distance-weighted mean (Shepard, weights 1/d^2) of s over its
//     kIdwNeighbours nearest boundary points (ties broken by lower background
//     index).
//  3. Interpolation. I(x) is the linear (barycentric) interpolant of the
//     background values over the background tet containing x. When x lies on a
//     face or edge shared by several tets, the tet with the lowest index among
//     those that contain x (decided with exact::orient3d) is used. I is
//     continuous across faces up to rounding, and equals the vertex value
//     exactly at a vertex. (Point location: a bounding-box tree over the tets;
//     a tet holding x strictly inside ends the search, since in a conforming
//     mesh no other tet contains x.)
//  4. Growth limit. g(x) = min over boundary points p of s(p) + (G - 1) |x - p|,
//     found exactly (the same minimum a brute-force loop over all boundary
//     points gives, bit for bit) by branch and bound over a bounding-box tree.
//  5. h(x) = clamp(min(I(x), g(x)), hmin, hmax).
//
//  With options.size, h(x) = clamp(max(size, r(x)), hmin, hmax), where
//  r(x) = max over boundary points p of s(p) - |x - p| (found exactly by the
//  same branch and bound, maximising): the requested size, raised next to
//  boundary points whose spacing is coarser, since the boundary is never
//  changed and the tets on a triangle four h wide cannot be h high. The raise
//  falls by one unit of length per unit of distance, the rate at which the
//  local feature size of Delaunay refinement may change (it is 1-Lipschitz),
//  so a tet on a boundary triangle meets tets of the requested size about
//  where its apex lies. Where no boundary spacing exceeds the size, h is
//  clamp(size, hmin, hmax) everywhere and the background is only counted.
//
//  Outside the background mesh (the advancing front may propose such points):
//  y = the closest point of the nearest background tet (smallest distance, then
//  lowest tet index; distances and y are measured in doubles), and h(x) =
//  clamp(min(I_t(y), g(y))) with I_t the interpolant of that tet: the value at
//  the closest point. Such queries are slower (branch and bound over the tet
//  tree) but just as deterministic.
//
//  Cost: at() is O(log n) point location plus a branch and bound over the
//  boundary points that stops as soon as no unvisited point can lower the
//  minimum; a growth rate close to 1 makes far points compete and costs more.
//  Measured (tests/sizing_test.cpp, QueryTimeOnLargeBackground): ~0.6-0.8 us
//  per query for a 1e5-point, 6e5-tet background in spatially coherent order,
//  ~2.5 us for random order (cache misses), on a shared 2-core test machine.
//
// Determinism
// -----------
// h is a pure function of the field's data and of x: the field holds no caches
// or mutable state, at() allocates nothing and is safe to call from any number
// of threads, and every tie is broken by index, never by timing or by hash
// order. encode() writes every double bit for bit (little-endian, whatever the
// host); decode() rebuilds the search trees from that data with the same code,
// so a decoded field answers exactly like the original on the same binary.
// build() on the same input gives byte-identical encodings.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/types.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

/// User controls of the point distribution function (all lengths in input units).
struct SizingOptions {
  std::optional<double> size;  ///< --size H: uniform target spacing (overrides the surface-derived one; still clamped)
  std::optional<double> hmin;  ///< --hmin: lower clamp
  std::optional<double> hmax;  ///< --hmax: upper clamp
  double growth = 1.2;         ///< --growth G (> 1): h may grow by (G - 1) per unit distance from the boundary
};

/// Checks the options: size, hmin, hmax finite and > 0; growth finite and > 1;
/// hmin <= hmax. invalid_input naming the option otherwise.
Status validate(const SizingOptions& options);

namespace sizing_detail {

/// A node of a bounding-box tree (over boundary points or background tets):
/// items [begin, end) of the tree's order lie below it; a leaf when left == kNoIndex.
struct TreeNode {
  Box box;  ///< exact bounding box of the items below
  std::uint32_t begin = 0, end = 0;
  Index left = kNoIndex, right = kNoIndex;
};

}  // namespace sizing_detail

/// One caller's memory of its last query (SizingField::at(x, hint)): the
/// background tet that held the point and the boundary point that set its
/// growth limit. Consecutive queries near each other then skip most of the
/// search; the value is the one at(x) gives. Not shared between threads.
struct SizingHint {
  Index tet = kNoIndex;
  std::uint32_t point = UINT32_MAX;  ///< slot in the boundary-point tree
  /// The growth limit g at `at` (NaN: none yet). g is (G - 1)-Lipschitz, so
  /// where it stays above the interpolant by more than that allows for, the
  /// next query near `at` needs no search.
  double limit = std::numeric_limits<double>::quiet_NaN();
  Vec3 at{};
};

/// The point distribution function h(x); see the top of this header.
class SizingField {
 public:
  /// Interior background points average this many nearest boundary points.
  static constexpr std::size_t kIdwNeighbours = 8;

  /// Builds h from the surface and a positively oriented background tet mesh
  /// whose points include every boundary point. invalid_input on bad options,
  /// triangles with out-of-range or repeated indices, two boundary points at the
  /// same coordinates, a boundary point missing from the background, a background
  /// with no tets or with a tet that is not positively oriented (exactly).
  static Result<SizingField> build(const SurfaceMesh& surface, const VolumeMesh& background,
                                   const SizingOptions& options);

  /// The field of options.size from the surface alone (no background: with a
  /// size none is needed), the same h as build() gives; invalid_input without
  /// a size, and build's surface errors.
  static Result<SizingField> from_surface(const SurfaceMesh& surface, const SizingOptions& options);

  /// h at every surface point from the surface alone, without a background
  /// mesh: for a point used by a triangle, bit for bit what build(surface, B,
  /// options).at(point) gives for any background B that build accepts (at a
  /// background vertex the interpolant is the vertex's value); NaN for a point
  /// no triangle uses. Lets a caller plan from h at the surface while the
  /// background mesh is still being made. build's surface errors.
  static Result<std::vector<double>> surface_values(const SurfaceMesh& surface, const SizingOptions& options);

  /// at() at every surface point a triangle uses, NaN at the others.
  std::vector<double> at_surface_points(const SurfaceMesh& surface) const;

  /// h(x). Thread-safe, deterministic, allocation-free.
  double at(const Vec3& x) const;
  /// h(x), bit for bit at(x), starting from what the last query with `hint`
  /// found (a background tet that holds x strictly is the only one holding it).
  double at(const Vec3& x, SizingHint& hint) const;

  /// A lower bound of h over the points of `box` inside the background mesh
  /// (what a leaf's refined points can ask for): the least background value of
  /// the background tets whose bounding box meets `box`, and the least
  /// s(p) + (G - 1) dist(p, box) over boundary points, clamped like h; a
  /// relative 1e-9 below, so that no rounding of at() falls under it. Costs a
  /// walk over the background tets near `box`. NaN for an empty box.
  double lower_bound(const Box& box) const;

  /// h at background point i: clamp(min(value_i, g(p_i))), equal bit for bit to
  /// at(points[i]) for every point used by a tet. NaN when i is out of range,
  /// and for a graded size (which keeps the boundary points, not the background).
  double at_point(Index background_point) const;

  /// Serialisation for shipping to workers (exact doubles, little-endian).
  std::string encode() const;
  /// Validates everything (magic, version, sizes against the buffer, indices,
  /// finite positive values, exactly positive tets) and rebuilds the search trees.
  static Result<SizingField> decode(std::string_view bytes);

  /// h is one value everywhere (options.size, and no boundary spacing above it).
  bool uniform() const { return uniform_ && !graded_; }
  /// options.size clamped to [hmin, hmax] (h away from the boundary), or none
  /// for the field from the surface's spacing.
  std::optional<double> requested_size() const { return uniform_ ? std::optional(uniform_value_) : std::nullopt; }
  std::size_t background_points() const { return point_count_; }
  std::size_t boundary_points() const { return boundary_.size(); }

 private:
  SizingField() = default;
  Status finish();  // derived data (bounding boxes, search trees) from the stored data
  /// With options.size: keeps the boundary points and their spacings (and
  /// grades h from them) when a spacing exceeds the size.
  Status grade(std::vector<Vec3> points, std::vector<double> spacing);
  /// from_surface's field from the boundary points and their spacings.
  static Result<SizingField> sized_field(const SizingOptions& options, std::vector<Vec3> points,
                                         std::vector<double> spacing);

  double combine(double interpolated, const Vec3& x, std::uint32_t* point = nullptr) const;
  double combine(double interpolated, const Vec3& x, SizingHint& hint) const;
  double growth_limit(const Vec3& x, double best, std::uint32_t* point) const;
  double graded(const Vec3& x, std::uint32_t* point) const;
  Index walk_to(Index tet, const Vec3& x) const;
  double idw(const Vec3& x) const;
  double interpolate_in(Index tet, const Vec3& x) const;
  Index locate(const Vec3& x) const;
  Index nearest_tet(const Vec3& x, Vec3& closest) const;

  // Stored (encoded) data.
  bool uniform_ = false;
  bool graded_ = false;  ///< with uniform_: the size raised next to coarser boundary points (points_ holds them)
  double uniform_value_ = 0;
  std::size_t point_count_ = 0;
  double growth_ = 1.2;
  double lo_ = 0;  ///< effective hmin (0 when unset)
  double hi_ = 0;  ///< effective hmax (+inf when unset)
  std::vector<Vec3> points_;
  std::vector<double> values_;  ///< one per background point, before growth limit and clamp
  std::vector<Tet> tets_;
  std::vector<Index> boundary_;  ///< background indices of boundary points, ascending

  // Derived on build and on decode.
  std::vector<sizing_detail::TreeNode> kd_;  ///< tree over boundary points, root first
  std::vector<double> kd_h_min_;             ///< per node: least boundary spacing below it
  std::vector<double> kd_h_max_;             ///< per node: largest boundary spacing below it
  std::vector<Index> kd_item_;               ///< tree order -> index into boundary_
  std::vector<Vec3> kd_xyz_;                 ///< boundary point coordinates, tree order
  std::vector<double> kd_h_;                 ///< boundary spacing, tree order
  std::vector<sizing_detail::TreeNode> bvh_;  ///< tree over background tets, root first
  std::vector<Index> bvh_item_;               ///< tree order -> tet
  std::vector<Box> bvh_box_;                  ///< tet bounding boxes, tree order
  std::vector<std::array<Index, 4>> neighbours_;  ///< per background tet: the tet across face f (opposite vertex f)
};

}  // namespace pdrmesh
