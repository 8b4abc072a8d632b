// SPDX-License-Identifier: AGPL-3.0-or-later
// What a mesh will cost, before it is made: the tet count and the peak memory
// from the surface and the sizing options alone (no TetGen, no background
// mesh), so that a size that would exhaust the machine is refused up front.
//
// The tet count is the integral over the enclosed volume of the tet density
// kTetsPerRegularVolume / v(h(x)), with v(h) = h^3 / (6 sqrt 2) the volume of
// a regular tet of edge h: the refiner's tets are not regular, and the factor
// (calibrated on meshes made by `pdrmesh mesh`, see estimate.cpp) says how
// many of them fill a regular tet's volume.
//  - Volume: exact, from the surface by the divergence theorem.
//  - With options.size, h = clamp(size, hmin, hmax) everywhere: the count is
//    exact volume times a constant density.
//  - Otherwise the density is averaged over the centres of a coarse grid
//    (at most kEstimateGridCells a side) that lie inside the surface (a
//    winding count along grid rows), with h at a centre approximated by
//    min(s(x), g(x)) clamped: s(x) the spacings of the nearest boundary point
//    of each surface component weighted by inverse distance (what the
//    background interpolation gives between a body and its far field; one
//    component: its nearest point's spacing; beyond 8 components the 7 widest
//    alone and the others as one) and g the growth limit
//    min_p s(p) + (G - 1)|x - p|, both over the boundary points found by a
//    seed propagation over the grid. That mean times the exact volume is the
//    count. A body thinner than the grid (no centre inside) uses the mean
//    density at the boundary points instead.
// The result is a function of the inputs only (the threads used do not
// change it), and costs a few MB and well under a second for a 50k-triangle surface.
#pragma once

#include <cstddef>
#include <string_view>

#include "pdrmesh/sizing.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"

namespace pdrmesh {

/// Tets of the refined mesh per regular-tet volume h^3 / (6 sqrt 2) (calibrated).
inline constexpr double kTetsPerRegularVolume = 1.25;
/// Peak resident bytes per tet of `pdrmesh mesh` / `run` (calibrated), and the
/// fixed part of a process (the program, TBB, the surface).
inline constexpr double kPeakBytesPerTet = 200.0;
inline constexpr double kPeakBytesFixed = 32.0 * (1 << 20);
/// The grid of the graded estimate has at most this many cells along its longest side.
inline constexpr int kEstimateGridCells = 48;

struct MeshEstimate {
  double volume = 0;      ///< enclosed volume (input units cubed)
  double tets = 0;        ///< estimated tets of the refined mesh
  double peak_bytes = 0;  ///< estimated peak resident bytes of making it
  double mean_h = 0;      ///< the uniform h giving the same count
};

/// The estimate for meshing `surface` with `options` (see the top of this
/// header). invalid_input for bad options or a surface without triangles or
/// with an index out of range; a surface enclosing no volume estimates 0 tets.
Result<MeshEstimate> estimate_mesh(const SurfaceMesh& surface, const SizingOptions& options);

/// The uniform --size that gives about `max_tets` tets for a body of
/// `volume` (the estimate's volume), rounded up to two significant digits: the
/// smallest sensible size under that limit.
double smallest_size_for(double volume, double max_tets);

/// The machine's available physical memory in bytes: MemAvailable of
/// /proc/meminfo (else sysconf), or what a cgroup memory limit leaves when less.
double available_memory_bytes();

/// The tets whose estimated peak fits in `bytes` (0 when not even the fixed part does).
double tets_for_bytes(double bytes);

/// Tets a process may make by default: tets_for_bytes(available_memory_bytes()).
double default_max_tets();

/// The refusal when `estimate.tets` exceeds `max_tets`, e.g. "--size 1e-09 would
/// make about 3.1e+24 tets (about 6e+26 bytes); the limit is 120,000,000 tets
/// (--max-tets, from this machine's memory); use --size 0.0021 or larger";
/// `limit_source` names where the limit came from. ok when within the limit.
Status check_tet_limit(const MeshEstimate& estimate, const SizingOptions& options, double max_tets,
                       std::string_view limit_source);

}  // namespace pdrmesh
