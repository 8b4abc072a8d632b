// SPDX-License-Identifier: AGPL-3.0-or-later
// The refiner's final optimization phase (AFLR: "sliver removal, grid coordinate
// smoothing, and further reconnection"), usable alone on any TetMesh: after the
// refinement passes, after the parallel engine merges leaves, or as a leaf task.
//
// What counts as bad
// ------------------
// A tet is bad when its smallest dihedral angle is below target_min_dihedral or
// its largest is above target_max_dihedral (quality.hpp's dihedral_range). A
// sliver is bad both ways (four nearly coplanar points); a cap has one large
// angle; a needle or wedge small angles only.
//
// The operations that raise quality judge a tet by its measure: the smallest
// over its six dihedral angles of sin(angle) / sin(target_min_dihedral) for an
// angle up to 90 degrees and sin(angle) / sin(180 - target_max_dihedral) above.
// A tet is within the targets exactly when its measure is >= 1 (up to
// rounding), and the measure is small both for angles near 0 and near 180.
//
// Points. A point is fixed when it lies on a frozen face, a hull face or a
// face between two regions, and free otherwise; fixed points never move and
// are never removed. A surface point is a point of a surface triangle
// (TetMesh::boundary() with a non-zero id, or any when there are no ids; not a
// leaf's interface). Tets are classed by their points: interior (no fixed
// point), on the surface (a surface point), or next to an interface only.
//
// Work list
// ---------
// One scan of the mesh finds the bad tets; from then on the optimizer looks
// only at what its operations change. Every operation (flip, insertion,
// removal, collapse, move) reports the tets it created or whose points moved;
// the list of bad tets is the last one merged with those, and the mesh's
// extreme angles come from a tree over blocks of slots measured again only
// where tets changed. Star walks start from a tet kept per point as operations
// create tets. A local attempt that failed (a tet's flips, insertion or repair, a
// point's move) is not made again in a later round while no tet holding its points
// has changed and the parameters it reads (a floor, the mesh's extremes) are the
// same: it would fail again, bit for bit. So the cost of a call follows the bad
// region and what the operations change, not the mesh or the number of rounds.
//
// Steps
// -----
// A sweep is 1., 2., 3. in turn (up to `sweeps`, while one changes
// something); then the polishing rounds, 4., 5., 6., 7., 8., the last margin
// polish, 10., the late cap pass of 5. and 9., in that order.
//
//  1. Reconnection: a queue of the bad tets; edge removal (flips.hpp) of their
//     edges, largest angle first, then 2-3 flips of their faces, then their
//     face neighbours' other edges. A flip is taken only when it raises the
//     worst largest angle of the tets it replaces, so the queue ends; the
//     created bad tets join it.
//  2. Sliver removal (with a sizing field and insert_points): a sliver with
//     no kept face and its face neighbours are re-tiled as the star of one new
//     point, placed by the smoothing targets of 3., when every new tet is
//     positive (exact), the star's worst measure beats the cavity's and the
//     point keeps half of h from the cavity's points (tuning.hpp).
//  3. Smoothing: each free point of a bad tet moves towards the Laplacian and
//     regular-tet targets (a line search back to its old position), else by a
//     compass search. A move is taken when every tet of its star stays
//     positive (exact) and the star's profile (its measures, each capped at 1,
//     ascending) rises lexicographically; with keep_edge_sizes no interior
//     edge gets shorter than 0.6 h (or than it was).
//     Polishing rounds: 1. and 3. for the interior bad tets alone, tets with a
//     fixed point pinned (no worse than min(their measure, 1)), while the
//     number of interior bad tets falls.
//  4. Interior repair rounds, while the interior bad tets get fewer: for each,
//     flips judged by the measure (min-max), else a point inserted into its
//     cavity as in 2., else one of its points removed (contracted onto the
//     point of its link whose cone is best); then smoothing, where a tet with
//     a surface point may fall to a floor (about 10 degrees at the default
//     targets, lower where the mesh holds worse tets already) so that the
//     interior tets can reach the targets.
//  5. Cap repair (needs a sizing field and insert_points): a bad tet lying on
//     the surface, with two or three kept faces (or one, a well-shaped surface
//     triangle, under fixed points), gets a new point in a cavity around it,
//     grown until the point sees every outer face; kept faces stay as they
//     are. A relaxed pass follows for the caps left, flat tets of four surface
//     points and free-apex caps, each new tet within [10, 165] degrees; it
//     runs once more after 10. (late_caps).
//  6. Angle polish: the free points of tets under target_min_dihedral move to
//     raise their stars' smallest angle.
//  7. Margin polish: the free points of the interior bad tets, and a ring of
//     free points around them, move to bring their stars within the targets
//     (tets with a surface point kept within [10, 165] degrees or their old
//     angles); after 8., once more with a finer search.
//  8. Repair cycles: 4. and 7. again while the interior bad tets get fewer.
//  9. Size polish (with a sizing field), last: the edges between two points
//     off the surface, one of them moved or inserted by the optimization, out
//     of [0.6, 1.5] h are removed or split where the new tets hold the angle
//     bounds, and their free points move back towards the band where no tet
//     leaves its bounds.
// 10. Absorption (with surface_room): the interior bad tets left are offered
//     flips, point removals and edge collapses judged so that interior tets
//     improve while tets with a surface point stay within the mesh's
//     extremes; then 4. and 7. with a deeper ring. Not in a leaf task, whose
//     extremes are not the mesh's.
//
// Guarantees
// ----------
// Every tet stays positive (exact predicates for every combinatorial
// decision). Frozen faces, hull faces and region interfaces keep their
// vertices and coordinates; the total volume is conserved up to rounding.
// No operation makes the mesh's extreme angles worse where it judges by them
// (the cap, margin, absorption and size steps), and an interior tet is never
// traded for a worse one. Determinism: the same mesh and options give the same
// mesh, bit for bit, whatever the thread count: every order is by slot or
// point index, no hashing, no timing (the stats' seconds are measured, not used),
// and the moves that run side by side (parallel_moves) take effect as in turn.
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include "pdrmesh/flips.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/tet_mesh.hpp"

namespace pdrmesh {

/// The quality threshold options of the final optimization.
struct OptimizeOptions {
  /// Degrees: a tet whose smallest dihedral angle is below this is bad.
  double target_min_dihedral = 15;
  /// Degrees: a tet whose largest dihedral angle is above this is bad.
  double target_max_dihedral = 150;
  /// Rounds of (reconnection, sliver removal, smoothing); fewer when a round
  /// changes nothing; then the polishing rounds (above). 0 only measures.
  int sweeps = 4;
  /// Run the smoothing step.
  bool smooth = true;
  /// Smoothing (with a sizing field) makes no edge between two points off the
  /// surface shorter than 0.6 h at its midpoint, nor shorter than it was when
  /// it was shorter already: moves judged by angles alone squeeze the
  /// interior next to needle triangles.
  bool keep_edge_sizes = true;
  /// Run the reconnection step (flips; also after insertions).
  bool reconnect = true;
  /// Sliver removal by point insertion (needs a sizing field; see above).
  bool insert_points = true;
  /// Polishing rounds: tets with a fixed point are pinned (must not get worse)
  /// instead of leading the smoothing comparison (see above). Off: the
  /// polishing smoothing compares whole stars as in 3.
  bool polish_pins_fixed = true;
  /// Interior repair rounds after the polishing rounds (see above).
  bool interior_repair = true;
  /// The interior repair may remove a free point (see above, 4.), and the
  /// absorption collapse an edge (10.); optimize() then drops the points left
  /// in no tet and renumbers the others (TetMesh::remove_unused_points).
  bool remove_points = true;
  /// Removed points stay in the mesh, used by no tet, so that every point
  /// keeps its index; the caller drops them. For a leaf task, whose output
  /// names its input points by index (leaf_optimize_options, leaf_kernels.hpp).
  bool keep_point_indices = false;
  /// Cap repair after the interior repair rounds (5. above; needs a sizing
  /// field and insert_points).
  bool repair_caps = true;
  /// Angle polish after the cap repair (6. above; with smooth).
  bool polish_angles = true;
  /// Margin polish after the angle polish (7. above; with smooth).
  bool polish_margins = true;
  /// At most this many cycles of interior repair rounds and margin polish
  /// after the margin polish (8. above; with interior_repair and
  /// polish_margins); 0: none.
  int repair_cycles = 4;
  /// Size polish, last (9. above; with smooth and a sizing field).
  bool polish_sizes = true;
  /// Tets with a surface point may give way within limits taken from the
  /// mesh's extremes: in the size polish (9. above; off, they are held as the
  /// interior ones are) and the absorption (10.; off, it does not run). A
  /// parallel leaf task's sub-mesh is not the mesh: its extremes include bad
  /// tets that its frozen hull keeps until a later task, so
  /// leaf_optimize_options turns it off.
  bool surface_room = true;
  /// Absorption after the repair cycles (10. above; with interior_repair,
  /// polish_margins and surface_room).
  bool absorb = true;
  /// The cap repair's relaxed pass once more after the absorption, before the
  /// size polish (5. above; with repair_caps). Off in a parallel leaf task
  /// (leaf_optimize_options), where it adds points that the merged mesh does
  /// not need.
  bool late_caps = true;
  /// The schedule of passes: the whole mesh's (above), or a parallel leaf
  /// task's, fitted to a sub-mesh with frozen faces: no absorption (10.), no
  /// late cap pass, and no room for the tets with a surface point in the size
  /// polish (9.), whatever surface_room and late_caps say.
  enum class Schedule { kWholeMesh, kLeafTask };
  Schedule schedule = Schedule::kWholeMesh;
  /// The passes' point moves (smoothing, angle, margin and size polish) run
  /// side by side on the threads of the calling task arena, in windows of
  /// points whose stars do not meet, and the size polish's and the bad-tet
  /// list's scans in parallel: the same mesh, bit for bit, as one thread, for
  /// any thread count. Off,
  /// one thread (the serial mesher's optimization, and the rounds' leaf tasks).
  bool parallel_moves = false;
};

/// The kinds of local operation whose outcomes OptimizeStats::tried counts.
enum class LocalOperation : unsigned char { kFlip, kInsertion, kRemoval, kCollapse, kMove };

struct OptimizeStats {
  std::size_t flips = 0;            ///< successful flips (all kinds)
  std::size_t slivers_removed = 0;  ///< successful operations aimed at a sliver (flip or insertion)
  std::size_t points_inserted = 0;  ///< sliver insertions (counted in slivers_removed too)
  std::size_t points_removed = 0;   ///< point removals of the interior repair (remove_points)
  std::size_t points_moved = 0;     ///< accepted smoothing moves
  std::size_t bad_before = 0;       ///< bad tets before / after
  std::size_t bad_after = 0;
  int sweeps_run = 0;
  int polish_rounds = 0;  ///< polishing rounds run after the sweeps
  int repair_rounds = 0;  ///< interior repair rounds run after them
  std::size_t repair_flips = 0;  ///< flips of the interior repair (counted in flips too)
  std::size_t caps_repaired = 0;  ///< cap repairs (counted in points_inserted too)
  std::size_t margin_moves = 0;   ///< moves of the margin polish (counted in points_moved too)
  int repair_cycles = 0;          ///< cycles of 8. run (their repair rounds count in repair_rounds)
  std::size_t size_moves = 0;     ///< moves of the size polish (counted in points_moved too)
  std::size_t size_flips = 0;     ///< edge removals of the size polish (counted in flips too)
  std::size_t size_splits = 0;    ///< edge splits of the size polish (counted in points_inserted too)
  int absorb_cycles = 0;          ///< cycles of 10. run (their repair rounds count in repair_rounds)
  std::size_t absorbed = 0;       ///< operations of the absorption (counted in repair_flips and flips too)
  std::size_t edges_collapsed = 0;  ///< the absorption's edge collapses (counted in absorbed too)
  /// Windows of point moves run side by side (parallel_moves): 0 on one thread. The only
  /// figure here that depends on the threads.
  std::size_t move_windows = 0;
  /// Local operations tried, by kind (LocalOperation) and outcome (Outcome,
  /// flips.hpp): why the operations that did not happen were declined.
  static constexpr std::size_t kOperationKinds = static_cast<std::size_t>(LocalOperation::kMove) + 1;
  std::array<std::array<std::size_t, kOutcomeCount>, kOperationKinds> tried{};
  std::size_t count(LocalOperation op, Outcome o) const {
    return tried[static_cast<std::size_t>(op)][static_cast<std::size_t>(o)];
  }
  double min_dihedral_before = 0, min_dihedral_after = 0;  ///< degrees, over all alive tets
  double max_dihedral_before = 0, max_dihedral_after = 0;
  double seconds = 0;  ///< wall time, measured only for reporting
};

/// One line of OptimizeStats::tried for a reader: per kind of operation, how
/// many were done and why the others were declined (kinds never tried left out).
std::string outcome_summary(const OptimizeStats& stats);

/// Validates the options: targets finite with 0 <= min < max <= 180, sweeps >= 0, repair_cycles >= 0;
/// invalid_input naming the option.
Status validate(const OptimizeOptions& options);

/// Runs the final optimization on the alive tets of `mesh` (all of them, active
/// or not). `sizing` may be null (no point insertion then). invalid_input on bad
/// options; the mesh is left valid (TetMesh::check) in every case. When the
/// interior repair removed points or the absorption collapsed edges, the
/// others are renumbered at the end (TetMesh::remove_unused_points: their
/// order and global ids stay), unless keep_point_indices.
Result<OptimizeStats> optimize(TetMesh& mesh, const SizingField* sizing,
                               const OptimizeOptions& options = {});

}  // namespace pdrmesh
