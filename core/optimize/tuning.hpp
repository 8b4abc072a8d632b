// SPDX-License-Identifier: AGPL-3.0-or-later
// The optimizer's tuning constants (private to core/optimize): counts, bounds and
// search lengths that the passes share. Changing one changes the meshes produced.
#pragma once

#include <array>
#include <cstddef>
#include <limits>

#include "pdrmesh/types.hpp"

namespace pdrmesh::optimize_detail {

/// Full-mesh scans run in parallel from this many tet slots (below: a leaf task's mesh, on its thread).
constexpr Index kParallelTets = Index{1} << 17;
/// Safety cap on the successful flips of a sweep, times the tets at its start (the min-max rule already ends it).
constexpr double kMaxFlipsPerTet = 20;
/// Sliver removal: a new point keeps at least this times h (at the point) from every vertex of its cavity.
constexpr double kInsertMinDistance = 0.5;
/// Parallel smoothing (parallel_moves): the least number of points a pass must try to run side by side,
/// and the points each window of side-by-side moves takes per thread.
constexpr std::size_t kParallelMovesMin = 256;
constexpr std::size_t kMovesPerThread = 256;
/// Smoothing passes per sweep (each over the vertices the previous one left bad).
constexpr int kSmoothPasses = 4;
/// Share of the tets (as a count of vertices) that the smoothing passes after the first may try per sweep.
constexpr double kSmoothRetries = 0.02;
/// The least number of vertices those passes may try, whatever kSmoothRetries gives.
constexpr std::size_t kSmoothRetriesMin = 2000;
/// Most polishing rounds after the sweeps (see optimize()).
constexpr int kPolishRounds = 4;
/// Compass search: most rounds of 14 trial steps around a point.
constexpr int kCompassRounds = 48;
/// The lower end of the size band: no edge off the surface gets shorter than this times h (keep_edge_sizes).
constexpr double kShortEdge = 0.6;
/// The upper end of the size band: the size polish brings edges off the surface back under this times h.
constexpr double kLongEdge = 1.5;
/// Most rounds of the size polish (a round that changes nothing ends it).
constexpr int kSizeRounds = 6;
/// Where the size polish's splits try the new point along the edge, in this order.
constexpr std::array<double, 9> kSplitAt{0.5, 0.45, 0.55, 0.4, 0.6, 0.35, 0.65, 0.3, 0.7};
/// Line-search steps towards each smoothing target: 1, 1/2, ..., 1/64.
constexpr int kLineSteps = 7;
/// Most rounds of the interior repair (they stop early where nothing falls).
constexpr int kRepairRounds = 6;
/// Interior repair: the floor for tets with a surface point (about 10 or 160 degrees at the default targets).
constexpr double kRepairFloor = 0.67;
/// Interior repair: the floor drops to this many times the measure of the mesh's worst angle (start_repair).
constexpr double kRepairFloorMargin = 2.0;
/// Point removal: stars of more tets than this are not tried.
constexpr std::size_t kRemovalMaxStar = 256;
/// Cap repair: heights (times h) above the kept faces at which the new point is tried.
constexpr std::array<double, 7> kCapHeights{0.1, 0.2, 0.3, 0.45, 0.6, 0.75, 0.9};
/// Cap repair: most tets in a cavity.
constexpr std::size_t kCapMaxCavity = 24;
/// Cap repair: the least distance (times h) from the new point to its link points off the surface.
constexpr double kCapMinSpacing = 1.0 / 3.0;
/// Cap repair, one kept face: degrees by which the star's largest angle may pass the mesh's largest before.
constexpr double kCapMaxAngleSlack = 0.5;
/// Cap repair, relaxed pass: the range (degrees) every new tet's dihedral angles must lie in.
constexpr std::array<double, 2> kRelaxedCapAngles{10.0, 165.0};
/// Cap repair, one kept face: the least smallest angle (degrees) of that surface triangle (no needles).
constexpr double kCapMinTriangleAngle = 15.0;
/// Most rounds of the margin polish (a round that moves nothing ends it).
constexpr int kMarginRounds = 8;
/// The compass search ends when its step falls below its first step over this.
constexpr double kSearchEnd = 64.0;
/// The same for the margin polish's last, finer pass.
constexpr double kFineSearchEnd = 1024.0;
/// Absorption: most cycles.
constexpr int kAbsorbCycles = 10;
/// Absorption stops after this many cycles in a row with no fewer bad interior tets than the fewest yet.
constexpr int kAbsorbPatience = 3;
/// Absorption: the depth of its margin polish's ring (polish_margins).
constexpr int kAbsorbRingLayers = 3;

}  // namespace pdrmesh::optimize_detail
