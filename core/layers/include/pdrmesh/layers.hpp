// SPDX-License-Identifier: AGPL-3.0-or-later
// Prism boundary layers grown from the walls of a closed surface, by advancing
// normals (as AFLR3 does): every wall point marches along one direction into
// the meshed volume, N layers of prisms stand on every wall triangle, and the
// last layer's top with the walls that get no layers bounds the rest of the
// volume, which the tet pipeline fills (layered_pipeline.hpp in core/pdr).
//
// Marching directions: the angle-weighted mean of the inward normals of the
// triangles around the point, moved where needed so that it sees every one of
// them as well as it can (the smallest dot product is raised), smoothed over
// the neighbours while that stays so, and stretched by 1 / that dot product (at
// most 2) so that a layer keeps its height across convex and concave edges and
// corners.
//
// Heights: layer k ends at H (R^k - 1) / (R - 1) from the wall (H k when R = 1).
// Where the stack must be thinner (the thickness cap; a ray along the direction
// that meets the surface within the stack: 0.45 of the distance to a wall that
// grows layers too, 0.8 to one that does not; a layer cell that would not be
// positive; a top that would cross another part of the top or the surface) the
// stack of that point is first compressed, every height scaled by one factor,
// down to half its thickness; a stack that must be thinner still keeps the
// heights of that half and stops at the last layer that fits, so that its
// first layers keep the wall distance asked for. Where a stack stops beside
// taller ones, the layers above it close with pyramids (two rising corners)
// and tets (one): prisms collapsed along the stopped stack's edge, which
// share their faces with their neighbours. The thicknesses are graded so that
// neighbours differ by at most half their distance. The validity checks are
// exact: every cell positive (mixed_cells.hpp) and the fill boundary free of
// self-intersections (the surface check).
//
// This first slice grows layers on whole closed components: a wall triangle
// that shares an edge with a triangle without layers is refused, naming both ids.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/types.hpp"

namespace pdrmesh {

struct LayerOptions {
  int layers = 0;             ///< N (0: none)
  double first_height = 0;    ///< H, in the surface's units
  double growth_ratio = 1.2;  ///< R >= 1: each layer's height over the one below
  std::optional<double> max_thickness;  ///< the stack's total height is at most this
  /// The surface ids that grow layers; empty: every id.
  std::vector<int> walls;
  /// A surface of several regions (regions.hpp): the regions, by name or id,
  /// on whose side the walls grow layers; the others hold tets only. Needed
  /// there (an interface has two sides, and a solid wants no layers); a
  /// surface of one region takes none.
  std::vector<std::string> regions;
};

/// invalid_input naming the option: layers 1..1000, first height and cap
/// finite and > 0, growth ratio finite and in [1, 10].
Status validate(const LayerOptions& options);

/// Layer options as a user gives them, before they meet a surface: the walls
/// by boundary name or id, the first height as a length or as a y+. What
/// `pdrmesh mesh --layers` and a service job (MeshOptions.layers) take.
struct LayerRequest {
  int layers = 0;
  double first_height = 0;  ///< a length, or with `yplus` a wall distance in wall units
  bool yplus = false;
  double reynolds = 0;          ///< with yplus: U L / nu on the reference length
  double reference_length = 0;  ///< with yplus; 0: the walls' length
  double growth_ratio = 1.2;
  std::optional<double> max_thickness;
  std::vector<std::string> on;  ///< boundary names or ids; empty: the default walls
  std::vector<std::string> in;  ///< LayerOptions::regions
};

/// The request's values alone (invalid_input naming the option): validate's
/// ranges, a y+ with a positive Reynolds number and reference length (0: the
/// walls'), and a Reynolds number or reference length only with a y+.
Status validate(const LayerRequest& request);

/// The layer options for `surface`: each name of `on` resolved to the surface
/// id that bears it (a name of surface_names, "surface_<id>", or the id
/// itself), invalid_input naming an unknown one and the surface's names;
/// without names the walls are `default_walls` (empty: every surface). A y+
/// becomes a length by first_height_for_yplus on the reference length, or on
/// the walls' length (the longest side of their bounding box).
Result<LayerOptions> resolve_layers(const LayerRequest& request, const SurfaceMesh& surface,
                                    const std::vector<int>& default_walls = {});

/// The first layer's height for a wall distance `yplus` in wall units, at
/// Reynolds number `reynolds` on `length` (U length / nu), from the turbulent
/// flat-plate skin friction Cf = 0.026 Re^(-1/7) (White, Fluid Mechanics):
/// the friction velocity u* = U sqrt(Cf / 2), so y = yplus nu / u* =
/// yplus length / (Re sqrt(Cf / 2)). invalid_input unless all three are finite and > 0.
Result<double> first_height_for_yplus(double yplus, double reynolds, double length);

struct LayerMesh {
  /// The surface's points (same indices), then the layer points, layer by
  /// layer, each layer's in wall point order (the stacks that reach it).
  std::vector<Vec3> points;
  /// The cells, each list layer by layer, wall triangle by wall triangle:
  /// prisms, and the pyramids and tets that close the layers above a stack
  /// that stopped.
  std::vector<Prism> prisms;
  std::vector<Pyramid> pyramids;
  std::vector<Tet> tets;
  std::size_t wall_triangles = 0, wall_points = 0;
  /// The boundary of what is left to fill: the last layer's top (oriented
  /// like the wall under it, with its id) and the triangles without layers,
  /// outward; its points are the used ones, numbered afresh.
  SurfaceMesh fill;
  std::vector<Index> fill_points;  ///< fill.points[i] is points[fill_points[i]]
  std::vector<Index> top_triangles;  ///< the fill triangles that are the top of a layer stack
  double thickness_min = 0, thickness_max = 0;  ///< of the stacks, along their directions
  std::size_t compressed_points = 0;  ///< wall points whose stack is thinner than N layers of H, R
  std::size_t stopped_points = 0;     ///< of those, the stacks with fewer than N layers
  /// Wall triangles whose three stacks have their full thickness (N layers of
  /// H, R, or the cap): the layers they reach. Smooth: the wall triangles whose
  /// neighbours at their points all have normals within kSmoothAngle degrees
  /// of their own (away from the surface's sharp edges and corners).
  std::size_t full_faces = 0, smooth_faces = 0, smooth_full_faces = 0;
  static constexpr double kSmoothAngle = 30;
  int shrink_rounds = 0;  ///< rounds of thinning for validity
};

/// Grows the layers on a checked (closed, outward, meshable) surface.
/// invalid_input: a wall triangle next to one without layers, a wall point
/// from which no direction sees every triangle around it, or a stack that
/// stays invalid after every compression (naming where).
Result<LayerMesh> grow_layers(const SurfaceMesh& checked_surface, const LayerOptions& options);

}  // namespace pdrmesh
