// SPDX-License-Identifier: AGPL-3.0-or-later
// The grid generation passes of the refiner, after AFLR (Marcum & Weatherill
// 1995): repeated passes of advancing-front point creation, rejection, insertion
// and local reconnection until the points satisfy the point distribution
// function h(x) (sizing.hpp).
//
// One pass
// --------
//  1. Activity. Every point carries h(p), evaluated once when the point enters
//     the mesh. A tet stays active while one of its edges is longer than
//     split_ratio * (h(a) + h(b)) / 2; the others are made inactive. Tets that
//     an insertion or a flip creates are active again (TetMesh::replace_cavity).
//  2. Candidates. The front is the set of faces of active tets whose other side
//     is an inactive tet, the hull or a frozen face (so the first pass advances
//     from the boundary). From each front face (a, b, c) of an active tet, in
//     tet slot order then face order, a candidate is placed on the face's inward
//     normal through its centroid, at advance_ratio * h_f from it, with h_f the
//     mean h of a, b, c: the apex of a regular tet of edge h_f when
//     advance_ratio = sqrt(2/3). An active tet with no front face (the
//     unfilled interior, e.g. behind boundary triangles much larger than h)
//     offers the midpoint of its longest edge instead, after all the front
//     candidates of the pass (void_midpoints). When a pass has no front candidate accepted,
//     the next pass uses every face of every active tet (a fallback for active
//     tets cut off from the front); the passes end when that too accepts none.
//  3. Rejection and insertion, one candidate at a time in that order (departure
//     from the paper, which rejects all of a pass's candidates first and inserts
//     them afterwards; inserting at once means an accepted candidate is in the
//     mesh when the next is checked, so no separate point hash is needed and
//     the result is the same kind of spacing). A candidate is located by a
//     bounded walk (insert.hpp's walk) that does not cross frozen faces; it is
//     rejected when the walk ends outside, on a vertex, on a hull or frozen face
//     or on an edge of one. It is rejected when an existing point lies closer than
//     reject_distance * h(candidate), or when a hull or frozen face lies closer
//     than boundary_reject_distance * h(candidate). Both searches are a walk
//     over the tets around the candidate's tet (faces whose distance lower bound
//     is below the radius are crossed, frozen faces never): this finds every
//     point that a straight segment inside the mesh joins to the candidate
//     within the radius, and adapts to graded h without a global grid.
//  4. Insertion with the Delaunay step: constrained Bowyer-Watson. The cavity
//     grows from the tets that contain the candidate across unfrozen faces
//     within one region to every tet whose circumsphere holds it strictly
//     (exact insphere); tets with a boundary face the point does not see
//     strictly (exact orient3d) are dropped until the cavity is star-shaped,
//     and it is re-tiled as the point's star (one TetMesh::replace_star).
//     When that cannot be done (a containing tet would be dropped, a cavity
//     vertex would vanish, over 1024 tets), the point splits its tet, face or
//     edge and Lawson's flips (2-3, 3-2) follow instead.
//  5. Reconnection (min-max), by default once at the end of each pass
//     (defer_min_max; else after each insertion): a FIFO queue of the tets
//     created since the last quality evaluation (their cached quality is still
//     unknown), in slot order; for each alive one, flip 2-3 across each face,
//     then edge removal (3-2, 4-4, up to kMaxRemovalRing tets) on each edge,
//     under the min-max dihedral criterion (flips.hpp); the tets of a flip that
//     succeeds join the queue. A tet is skipped when neither it nor a face
//     neighbour has a dihedral angle above min_max_angle. Then edges longer
//     than long_edge_ratio * h are removed from the same tets where
//     remove_long_edge allows it (no angle above min_max_angle, shorter new
//     edges). No sweep over the mesh beyond the slot scan.
//
// Frozen faces are never split, flipped or crossed and no point is added on
// them; hull faces get no point either. The result is a pure function of the
// input mesh, the field and the options: everything runs in slot order, no
// unordered container is iterated and no timing enters a decision.
#pragma once

#include <chrono>
#include <optional>

#include <cstddef>
#include <functional>
#include <span>
#include <limits>
#include <vector>

#include "pdrmesh/sizing.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/tet_mesh.hpp"

namespace pdrmesh {

struct RefineOptions {
  /// A candidate closer than this * h(candidate) to an existing point is
  /// rejected. Lower packs points closer (more, shorter edges).
  double reject_distance = 0.6;
  /// A candidate closer than this * h(candidate) to a hull or frozen face is
  /// rejected (keeps flat tets off the boundary). The distance to the face
  /// itself: a bound by its plane would also reject points far beside a
  /// needle triangle many h long.
  double boundary_reject_distance = 0.5;
  /// A tet is active while an edge is longer than this * the mean h of its ends.
  double split_ratio = 1.4;
  /// Distance of a candidate from its front face, in units of the face's h:
  /// sqrt(2/3), the height of a regular tet.
  double advance_ratio = 0.816496580927726;
  /// At most this many passes.
  int max_passes = 100;
  /// A candidate whose location walk runs longer than this is rejected.
  Index max_walk_steps = 4096;
  /// The proximity search around a candidate visits at most this many tets.
  Index max_search_tets = 512;
  /// Flips attempted after one insertion stop after this many succeed.
  Index max_flips_per_point = 256;
  /// Local reconnection after each insertion (off: insertion only, for tests).
  bool reconnect = true;
  /// Reconnection step 1: Lawson's (constrained) Delaunay flips around the new point.
  bool delaunay = true;
  /// The Delaunay step skips a flip that would join the new point p to a point
  /// farther than this * h(p). Unlimited by default: measured on sphere966,
  /// limits of 2.5 and 6 left 16-40% of the interior edges longer than 1.5 h
  /// (the far connections are never repaired) and were not faster.
  double delaunay_reach = std::numeric_limits<double>::infinity();
  /// Reconnection step 2: min-max dihedral flips over the tets step 1 left.
  bool min_max = true;
  /// Step 2 tries flips only from a tet that has, or whose face neighbour has,
  /// a dihedral angle above this many degrees (0: from every tet); the tets of
  /// a flip that succeeds join the queue under the same test. Measured (bench
  /// and `pdrmesh mesh` on elephant, knot2, fandisk, bunny_npm, hinge): 150
  /// is 3-5x faster than 0, with a higher share of edges in [0.6, 1.5] h and
  /// final dihedral extremes as good; t alone (no neighbour test) left worse
  /// extremes on bunny_npm (3.3 / 175.6 degrees after optimization).
  double min_max_angle = 150.0;
  /// Run step 2 once at the end of each pass, from every tet created during
  /// the pass that is still alive, instead of after each insertion.
  bool defer_min_max = true;
  /// Front stage: an active tet with no front face (the unfilled interior)
  /// offers the midpoint of its longest edge when that edge is long, after
  /// every front candidate of the pass; the interior then fills in a few
  /// passes instead of one layer per pass from a coarse boundary.
  bool void_midpoints = true;
  /// With defer_min_max: after step 2, edges longer than this times the mean h
  /// of their ends are removed where a flip can do it without a dihedral angle
  /// above min_max_angle (flips.hpp remove_long_edge); 0: off.
  double long_edge_ratio = 1.2;
  /// Renumber the tets in the Morton order of their barycentres at the start of
  /// a pass whenever the mesh grew by a quarter since the last renumbering:
  /// fewer cache misses, so the refinement takes markedly less CPU time on big
  /// meshes. It changes the insertion order and so the mesh (the quality
  /// extremes move either way by up to a few degrees).
  bool spatial_order = true;
  /// The renumbering starts once the mesh holds this many tets. A smaller
  /// mesh's arrays stay in cache, so renumbering it saves nothing and only
  /// changes it.
  Index spatial_order_min_tets = 65536;
  /// Set: refinement stops soon after this time, within the pass (every 1024
  /// tets' candidates) or between passes; RefineStats::stopped_at_deadline is then
  /// true and the mesh valid, only not refined to the end.
  std::optional<std::chrono::steady_clock::time_point> deadline;
  /// Set: no candidate outside this closed box is made. A PDR leaf task
  /// inserts points only in its own leaf; the tets around the leaf that it is
  /// also given hold the cavities of points near the leaf's faces and the
  /// neighbours' points that the spacing checks must see. Its frozen faces
  /// of boundary id 0 are then cuts through the volume, not walls: no
  /// candidate is rejected for being near one (boundary_reject_distance holds
  /// for the surface's faces), as the task beyond sees these points.
  std::optional<Box> insert_within;
};

/// Checks the options (positive, finite distances and limits).
Status validate(const RefineOptions& options);

struct RefinePassStats {
  int pass = 0;
  std::size_t candidates = 0;  ///< candidates created
  std::size_t accepted = 0;    ///< candidates that passed location and rejection
  std::size_t inserted = 0;    ///< accepted candidates the mesh took (insert_at kDone)
  std::size_t flips = 0;       ///< successful flips of the reconnection
  std::size_t tets = 0;        ///< alive tets after the pass
  double seconds = 0;
};

struct RefineStats {
  std::vector<RefinePassStats> passes;
  std::size_t points_added = 0;
  double seconds = 0;
  bool stopped_at_deadline = false;  ///< RefineOptions::deadline passed before the last pass
};

using RefineProgress = std::function<void(const RefinePassStats&)>;  // may be empty

/// Runs the passes on `mesh` (in place) towards `sizing`. invalid_input on bad
/// options; internal_error if the mesh check fails afterwards in debug builds.
/// `sizes`, when given: on entry h at the mesh's points (sizing.at, bit for
/// bit) if it has one entry per point, else ignored; on return h at every
/// point, the new ones included.
Result<RefineStats> refine(TetMesh& mesh, const SizingField& sizing, const RefineOptions& options = {},
                           const RefineProgress& progress = {}, std::vector<double>* sizes = nullptr);

struct InsertPointsStats {
  std::size_t inserted = 0;
  std::size_t split = 0;     ///< of those, by a split and flips (the cavity would have removed a vertex or crossed its seeds' region)
  std::size_t declined = 0;  ///< on a vertex, on a frozen face or edge, or in no tet
  std::size_t scans = 0;     ///< locations that needed a scan of the mesh (the walk met the hull)
  std::size_t flips = 0;     ///< Lawson's flips over the whole mesh, before and after the insertions
};

/// Inserts `points` into `mesh` one by one as a constrained Delaunay
/// insertion: the cavity of tets whose circumsphere holds the point, bounded
/// by hull and frozen faces and made star-shaped, is re-tiled from the point
/// (a split and Lawson's flips where a cavity cannot be used). The order is a
/// biased randomized one (rounds coarse to fine, each in Morton order), and
/// Lawson's flips over the whole mesh before and after make every face a flip
/// can change locally Delaunay. A point on a vertex, on a frozen face or
/// edge, in no tet, or not finite is skipped. Deterministic; the new points
/// follow the mesh's, in insertion order.
Result<InsertPointsStats> insert_points(TetMesh& mesh, std::span<const Vec3> points);

/// The rounds of insert_points' order, coarse to fine.
inline constexpr int kInsertionRounds = 8;
/// The round (0 coarsest, kInsertionRounds - 1 finest) in which insert_points
/// inserts the point at `index` of its list: from a hash of the index, about
/// 7/8 of the points in the finest round and 7/8 of the rest in each round
/// before it.
int insertion_round(std::size_t index);

}  // namespace pdrmesh
