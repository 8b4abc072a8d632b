// SPDX-License-Identifier: AGPL-3.0-or-later
// Element quality, measured in doubles (decisions use predicates.hpp instead).
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "pdrmesh/types.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

/// The six interior dihedral angles of tetrahedron (a, b, c, d) in degrees, at
/// the edges ab, ac, ad, bc, bd, cd. A degenerate tet yields 0 or 180 degrees.
std::array<double, 6> dihedral_angles(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// Smallest and largest dihedral angle of a tet, in degrees.
struct AngleRange {
  double min;
  double max;
};
AngleRange dihedral_range(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// Whether a tet has a dihedral angle under `min` or over `max` degrees, for
/// scans of whole meshes: dihedral_range's extremes against the bounds, with
/// the bounds turned into cosines once and no arc cosine or division per tet
/// (the same decision up to rounding at the bounds themselves).
class DihedralBounds {
 public:
  DihedralBounds(double min, double max);
  bool outside(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) const;

 private:
  bool flat_is_outside_;  ///< a degenerate face's angle (0) is under min
  double below_, above_;  ///< the faces' normal cosines at min and max
};

/// Verdict's tet shape metric (mean ratio): 1 for the regular tet, 0 for a
/// degenerate or inverted one.
double verdict_shape(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// Verdict's relative size squared: min(R, 1/R)^2 with R = volume / average_volume;
/// 0 for an inverted tet.
double verdict_relative_size_squared(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                                     double average_volume);

/// Statistics of a whole mesh, as `pdrmesh quality` prints them.
struct QualityReport {
  std::size_t tets = 0;
  std::size_t points = 0;
  double volume = 0;
  double min_dihedral = 0;
  double max_dihedral = 0;
  /// Counts of all dihedral angles in 10-degree bins [0,10), [10,20), ... [170,180].
  std::array<std::size_t, 18> histogram{};
  double share_below_10 = 0;  ///< share of tets with a dihedral angle under 10 degrees
  double share_above_165 = 0;  ///< share of tets with a dihedral angle over 165 degrees
  /// With measure_quality(mesh, true): the tets with no vertex on the hull (a
  /// face that only one tet has) and their dihedral extremes (0 when there
  /// are none): what the interior bound of [15, 150] degrees is measured on.
  bool interior_measured = false;
  std::size_t interior_tets = 0;
  double interior_min_dihedral = 0;
  double interior_max_dihedral = 0;
  double min_shape = 0;
  double mean_shape = 0;
  double min_shape_and_size = 0;
  double mean_shape_and_size = 0;
};

/// With `interior`, also the interior tets' figures; their hull is found from
/// the tets alone (a file's triangles may be every face: TetGen's -g output),
/// by bucketing the tets' faces (64 bytes per tet while it runs).
QualityReport measure_quality(const VolumeMesh& mesh, bool interior = false);

/// Minimum dihedral angle of every tet, in mesh order.
std::vector<double> min_dihedral_per_tet(const VolumeMesh& mesh);

/// Human-readable multi-line summary.
std::string format_quality(const QualityReport& q);
/// JSON object (one line).
std::string quality_to_json(const QualityReport& q);
/// An SVG bar chart of the dihedral-angle histogram.
std::string quality_histogram_svg(const QualityReport& q, const std::string& title);

}  // namespace pdrmesh
