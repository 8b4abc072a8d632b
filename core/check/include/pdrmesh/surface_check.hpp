// SPDX-License-Identifier: AGPL-3.0-or-later
// The surface check: finds everything in a triangulated surface that TetGen
// cannot take (it crashes or hangs on defective input), and describes the
// surface's components (closed, manifold, oriented, genus, volume, nesting).
//
// Every path that meshes a surface runs check_surface first and refuses to go
// on unless the report is meshable(). All combinatorial decisions (degenerate
// triangles, nesting, self-intersections) are exact (predicates.hpp); volumes
// are measured in doubles.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/types.hpp"

namespace pdrmesh {

enum class DefectKind {
  kNonFiniteCoordinate,      ///< a point has a NaN or infinite coordinate
  kIndexOutOfRange,          ///< a triangle names a point that does not exist
  kDegenerateTriangle,       ///< zero area: a repeated index or three collinear points
  kDuplicateTriangle,        ///< same vertex set as another triangle (any order)
  kOpenEdge,                 ///< an edge with one triangle
  kNonManifoldEdge,          ///< an edge with more than two triangles
  kNonManifoldVertex,        ///< pinched: the triangles around a vertex form more than one fan
  kInconsistentOrientation,  ///< two triangles use their common edge in the same direction
  kInwardOrientation,  ///< a closed component whose volume sign is wrong for its nesting depth
  kSelfIntersection,   ///< two triangles cross or touch other than along shared vertices/edges
};
inline constexpr std::size_t kDefectKinds = 10;

/// Human-readable name, e.g. "open edge".
std::string_view to_string(DefectKind kind);

struct Defect {
  DefectKind kind;
  std::vector<Index> triangles;  ///< the triangles involved (indices into SurfaceMesh::triangles)
  std::vector<Index> points;     ///< the points involved (edge ends, the pinched vertex, ...)
  Vec3 where{0, 0, 0};  ///< a coordinate where it is (may be non-finite for kNonFiniteCoordinate)
  std::string message;  ///< one line, naming triangles/points and the coordinate
};

/// One connected component: triangles connected through shared edges (a
/// pinched vertex alone does not connect). Triangles skipped by the analysis
/// (invalid indices or coordinates, repeated indices, the second and later
/// copies of a duplicate) belong to no component.
struct ComponentReport {
  Index triangles = 0;
  Index points = 0;
  bool closed = false;                 ///< no open edge
  bool manifold = false;               ///< no non-manifold edge, one fan at every vertex
  bool consistently_oriented = false;  ///< every edge used once in each direction
  int euler = 0;                       ///< V - E + F
  int genus = -1;                      ///< (2 - euler) / 2 when closed, manifold and oriented
  double volume = 0;                   ///< signed, from the divergence theorem
  /// Number of other closed components that enclose this one (decided exactly);
  /// only computed for closed, manifold, oriented components without degenerate
  /// triangles, 0 otherwise.
  int nesting_depth = 0;
  /// The closed component directly enclosing this one (kNoIndex: none, or not analysed).
  Index parent = kNoIndex;
  /// Orientation valid for the nesting: positive volume (the shell holds
  /// material), or negative (a cavity) directly inside a positive parent;
  /// false when the nesting could not be analysed.
  bool outward = false;
  /// Positive inside a positive parent: the interface between two regions
  /// (regions.hpp) rather than a cavity.
  bool interface = false;
  Index first_triangle = kNoIndex;  ///< lowest triangle index in the component
};

/// A hole: open edges connected through their shared points (one boundary
/// loop, or several loops that touch at a point).
struct HoleReport {
  std::size_t open_edges = 0;
  Defect first;  ///< its first open edge (lowest point pair), described as an open-edge defect
};

struct SurfaceReport {
  Index points = 0;
  Index triangles = 0;
  std::vector<ComponentReport> components;  ///< ordered by first_triangle
  /// Ordered by kind, then by the triangles/points involved; capped per kind.
  std::vector<Defect> defects;
  /// Uncapped number of defects per kind, indexed by DefectKind.
  std::array<std::size_t, kDefectKinds> defect_counts{};
  /// The open edges grouped into holes (all of them counted, the first
  /// max_defects_per_kind kept), ordered by their first edge.
  std::vector<HoleReport> holes;
  std::size_t hole_count = 0;

  std::size_t total_defects() const;
  std::size_t count(DefectKind kind) const { return defect_counts[static_cast<std::size_t>(kind)]; }
  /// No defects at all.
  bool meshable() const { return total_defects() == 0; }
};

struct CheckOptions {
  std::size_t max_defects_per_kind = 20;
  bool self_intersections = true;
};

SurfaceReport check_surface(const SurfaceMesh& surface, const CheckOptions& options = {});

/// Several lines: a summary, one line per component (capped), the defects.
std::string format_report(const SurfaceReport& report, std::string_view name);
/// One JSON object.
std::string report_to_json(const SurfaceReport& report, std::string_view name);
/// Ok when meshable; otherwise invalid_input naming the first few defects (kind,
/// triangles, coordinate) and the total count.
Status require_meshable(const SurfaceReport& report, std::string_view name);

}  // namespace pdrmesh
