// SPDX-License-Identifier: AGPL-3.0-or-later
// TetGen adapter: a boundary-conforming Delaunay tetrahedralization of a checked,
// closed, outward-oriented surface, with no Steiner point on the boundary (the
// boundary of the result is exactly the input triangulation).
//
// TetGen runs in a helper process, the program pdrmesh-tetgen (built from
// core/tetgen/tetgen_child.cpp, installed beside pdrmesh), because it can crash,
// hang, call exit() or throw on bad input, and re-initialises the global
// predicate state (see predicates.hpp). Each call starts a fresh helper with
// posix_spawn: it shares no lock with the caller's other threads, whatever they
// hold at that moment. The helper sends its result through a pipe; the parent
// validates it (counts, indices, finiteness, orientation, boundary) before it is
// trusted. Each call uses its own pipes and helper and touches no global state,
// so calls from several threads at once are safe.
//
// The helper is $PDRMESH_TETGEN_HELPER if set, else pdrmesh-tetgen in the
// folder of the running program, else the one in the build tree.
//
// Limitations:
//  - The caller must not set SIGCHLD to SIG_IGN (the child could not be reaped).
//  - Input points not used by any triangle are not supported (TetGen would keep
//    or drop them depending on where they lie): check the surface first.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

struct TetgenOptions {
  /// TetGen -a: maximum tetrahedron volume (the dense initial mesh). Unset: only
  /// the points TetGen needs to recover the boundary are added. Best effort:
  /// TetGen 1.5 cannot refine where a new point would encroach on the
  /// preserved boundary, so a few tets (mostly next to the boundary, up to
  /// 2x on smooth surfaces, far more next to coarse CAD faces) exceed it; the
  /// adapter adds a seed lattice (see tetgen_adapter.cpp) so the mesh is dense.
  std::optional<double> max_volume;
  /// TetGen -q: radius-edge ratio bound (quality refinement); off by default.
  std::optional<double> radius_edge;
  /// With max_volume: insert only the seed lattice, and run no TetGen
  /// refinement (neither -a nor -q): the interior points are the lattice's,
  /// none is placed next to the boundary.
  bool seeds_only = false;
  /// The child is killed after this many seconds (deadline_exceeded).
  double time_limit_s = 600;
  /// 0 = none; else RLIMIT_AS of the child (resource_exhausted when hit).
  std::size_t memory_limit_bytes = 0;
  /// Test seam: makes the child misbehave instead of meshing, to test isolation.
  /// kCrash: SIGSEGV; kHang: sleeps forever; kExit: exit(3) (runs atexit
  /// handlers, as a library calling exit() would); kThrow: throws a
  /// std::runtime_error out of the meshing code.
  enum class Fault { kNone, kCrash, kHang, kExit, kThrow };
  Fault inject_fault = Fault::kNone;
};

/// Tetrahedralizes the volume enclosed by `surface` (closed, manifold,
/// outward-oriented, not self-intersecting: check it first). Several bodies and
/// cavities (inner surfaces oriented into the cavity) are supported.
///
/// Result: points = the input points (same order, bit-identical), then the
/// interior points: TetGen's Steiner points and, with max_volume, the seed
/// lattice's (seed_points), in TetGen's order, not the lattice's; every tet positively oriented
/// (exact::orient3d > 0); boundary = the input triangles in input order with
/// boundary_ids = surface.surface_ids, boundary_names = surface.surface_names; tet_regions empty.
///
/// Errors: invalid_input for input TetGen rejects (self-intersections, ...),
/// deadline_exceeded past time_limit_s, resource_exhausted past
/// memory_limit_bytes, internal_error when TetGen crashes or returns a mesh that
/// fails validation (the message says what differs).
Result<VolumeMesh> tetrahedralize(const SurfaceMesh& surface, const TetgenOptions& options = {});

/// The interior points added for `max_volume` (TetGenOptions::max_volume): the
/// points of a jittered body-centred cubic lattice whose Delaunay tets have
/// about half that volume, inside the domain and at least 0.4 lattice spacing
/// from every triangle, in lattice order. With `widest` (a spacing at a point),
/// a seed p where widest(p) is 2^k times the lattice's spacing or more (k >= 1)
/// stays only if it lies on the lattice 2^k times as wide with the same origin:
/// the seeds grade with what widest allows. Deterministic (widest must be a
/// pure function; it is called from several threads). resource_exhausted when
/// the lattice over the bounding box would exceed 2e8 points.
Result<std::vector<Vec3>> seed_points(const SurfaceMesh& surface, double max_volume,
                                      const std::function<double(const Vec3&)>& widest = {});

/// The spacing of seed_points' lattice for `max_volume`.
double seed_spacing(double max_volume);

/// The TetGen switch string used for `options`, e.g. "pYzQMJF" or
/// "pYzQMJFa0.5" (letters documented in tetgen_adapter.cpp).
std::string tetgen_switches(const TetgenOptions& options);

}  // namespace pdrmesh
