// SPDX-License-Identifier: AGPL-3.0-or-later
// The refiner's final optimization phase (AFLR: "sliver removal, grid coordinate
// smoothing, and further reconnection"), usable alone on any TetMesh: after the
// refinement passes, after the parallel engine merges leaves, or as a leaf task.
//
// What counts as bad
// ------------------
// A tet is bad when its smallest dihedral angle is below target_min_dihedral or
// its largest is above target_max_dihedral (quality.hpp's dihedral_range). A
// sliver is a bad tet with both (four nearly coplanar points: angles near 0 and
// near 180 degrees). A cap (one large angle) or a needle/wedge (small angles
// only) is bad but not a sliver.
//
// Insertion and smoothing raise a tet's measure: the smallest over its six
// dihedral angles of sin(angle) / sin(target_min_dihedral) for an angle up to
// 90 degrees and sin(angle) / sin(180 - target_max_dihedral) above, so that a
// tet is within the targets exactly when its measure is >= 1 (up to rounding),
// and a 154-degree cap with an 18-degree angle counts as bad for its 154 degrees
// (the plain smallest sine, which this replaced, saw only the 18).
//
// One sweep = reconnection, sliver removal, smoothing, in that order; sweeps
// stop early when one changes nothing. When the sweeps end with changes still
// coming, up to four polishing rounds follow (with smoothing on): reconnection
// seeded with the bad tets that have no fixed point (see 3.), then smoothing of
// their vertices alone, while the number of such tets falls. They finish the
// interior cheaply where the sweeps spend their work on tets next to the
// boundary, many beyond repair next to needle triangles. Their smoothing judges
// a move by the profile (see 3.) of the star's tets with no fixed point only;
// a tet with a fixed point is pinned: it must stay positive and its measure
// must not fall below min(its old measure, 1), but it does not lead the
// comparison, so a hopeless tet on a needle triangle next to the boundary no
// longer blocks (or steers) the repair of the interior tets it shares a point
// with. (A star whose tets all have a fixed point is judged as in 3.)
//
//  1. Reconnection. A FIFO work queue, seeded with the bad tets in slot order.
//     For a bad tet: edge removal (flips.hpp remove_edge: 3-2, 4-4 and larger
//     rings) of its six edges, largest dihedral angle first (ties: lower local
//     edge), then 2-3 flips of its four faces; if none applies, the edges of its
//     face neighbours that it does not hold (which may open a flip of its own;
//     the tet is then queued again). Every flip is accepted only when it raises
//     the smallest max_dihedral_cosine of the tets it replaces (min-max), so the
//     sorted vector of tet qualities rises lexicographically and the queue
//     ends. The created tets join the queue.
//  2. Sliver removal. Slivers left after reconnection were already offered every
//     flip. With a sizing field and insert_points, a sliver with no frozen face,
//     no hull face and no region interface is removed with its four face
//     neighbours (the cavity; a face two neighbours share must not be frozen)
//     and the cavity is re-tiled as the star of one new point over its outer
//     faces. The point starts at the sliver's centroid and moves towards the
//     smoothing targets below over the new star; the operation is done only
//     when every new tet is positive (exact::orient3d), the star's worst measure
//     strictly beats the cavity's, and the point lies
//     at least insert_min_distance * h(point) from every cavity vertex. The new
//     tets then go through the reconnection queue. Without sizing (null), no
//     point is ever inserted. (A sliver whose cavity has no such point, e.g.
//     two of its edges on the hull, stays: see tests/optimize_test.cpp.)
//  3. Smoothing. A point is fixed when it lies on a frozen face, a hull face or
//     a face between two regions; every other point is free. Each free vertex of
//     a bad tet (ascending index) is moved towards three targets, the mean of its
//     star's other vertices (Laplacian), the mean over its star's tets of the
//     position that would make that tet regular over its opposite face, and
//     that position for the star's worst tet alone, with a line search back to
//     the old position (steps 1, 1/2, ..., 1/64). A move is accepted only when
//     every tet of the star stays positive by exact::orient3d with the new
//     coordinates and the star's profile rises: the measures of its tets, each
//     clipped at 1 (within the targets), ascending, compared lexicographically.
//     So a move may improve a bad tet while a worse one that the point cannot
//     help (a tet on a needle triangle of the boundary) stays as it is; the
//     worst tet of a star never gets worse. With a sizing field, a move also
//     makes no edge between two points off the surface shorter than 0.6 h at
//     its midpoint, or than it was (keep_edge_sizes). The best of the targets
//     wins. When none helps, a compass search: trial steps along the 3 axes and 4
//     diagonals both ways from the point, the best accepted one taken, else
//     the step halved, from a quarter of the mean distance to the star's
//     other vertices down to 1/64 of it, at most 48 rounds (frame's parallel
//     mesh kept a point 0.2 above a surface fold whose targets all made its
//     star worse; about 1.5 aside its star's smallest angle rises from 7.8
//     to 12.3 degrees). Up to four passes per sweep: the next takes the free
//     vertices of the bad tets in the stars of the points just moved, and the
//     passes after the first try
//     at most max(2000, 0.02 * tets) vertices together (a time bound where most
//     bad tets are beyond repair). The star is gathered by a walk through
//     adjacency from one incident tet (a vertex -> tet map built per smoothing
//     step). Moved points have their tets' quality cache reset.
//
//  4. Interior repair (interior_repair, on), after the polishing rounds, up to
//     six rounds while the number of bad tets with no fixed point falls:
//     (a) flips for each such tet (slot order, then the created ones): edge
//     removal of its edges (the most extreme dihedral angle first), 2-3 flips
//     of its faces, then edge removal of its face neighbours' other edges,
//     each judged by the measure above instead of the largest dihedral angle
//     alone (so that a tet bad by a small angle only is seen too), min-max
//     over the tets it replaces (the new worst strictly above the old worst);
//     when no flip applies, a point in the cavity of the tet and its face
//     neighbours as in 2. (for any bad tet, not only slivers); when that
//     fails too (remove_points), a point of the tet removed: contracted onto
//     the point w of its link (on the surface or not) whose cone, the tets
//     from w over the link faces that do not hold w, has the best worst tet,
//     when that cone's tets are all positive (exact), beat the worst tet of
//     the star and hold the floors below. Next to needle triangles, where
//     first-layer points the surface tets cannot reach are joined by flat
//     tets, this took hinge's interior at diag/100 from 1.3 / 177.3 degrees
//     and 3,544 tets outside the targets to 3.0 / 174.9 and 883, and
//     couplingdown's from 11.4 / 158.5 and 460 to 12.7 / 158.8 and 87, with
//     9% and 1.5% fewer tets (session 15, `pdrmesh_bench_refine`); elsewhere
//     it finds little to do (sphere966 at diag/100: 10 points of 1.04M tets).
//     The point is left in no tet, and optimize() drops such points at its end;
//     (b) smoothing of their free vertices as in the polishing rounds, aimed
//     at the worst tet with no fixed point, where a tet with a point on the
//     surface (a TetMesh::boundary() triangle with a non-zero id, or any when
//     there are no ids; not a leaf's interface) may now give way down to
//     min(its measure, F) instead of min(its measure, 1), where F is 0.67
//     (about 10 degrees, or 160 on the obtuse side, at the default targets)
//     or, when the mesh holds worse tets when the repair starts, twice the
//     measure of its smallest dihedral angle: a tet next to the surface keeps
//     above that but need not stay within the targets for an interior tet to
//     get there, and next to needle triangles, where the tets on the surface
//     are that bad anyway, the interior gets the room it needs (hinge's
//     interior at the default size went from 10.0 / 160.9 degrees to within
//     [15, 150], couplingdown's at diag/100 from 2.1 / 175.4 to 11.4 / 158.5,
//     the meshes' smallest angles as they were). The flips and insertions of
//     (a) hold the same floors: a new tet with no fixed point, or with fixed
//     points on a leaf's interface only, is no worse than the worst such old
//     tet (capped at 1), one with a surface point no worse than min(F, the
//     worst such old tet). A tet whose repair would need a fixed point to move
//     stays as it is.
//
//  5. Cap repair (repair_caps, on; needs sizing and insert_points), last: a
//     bad tet with two or three kept faces (hull, frozen or region faces),
//     two of them surface triangles (TetMesh::boundary() with a non-zero id,
//     or any when there are no ids; not a leaf's interface), e.g. a flat
//     tet lying on a nearly flat patch of the surface with all its points
//     fixed, which the steps above cannot change; or a bad tet with one kept
//     face, a surface triangle whose angles are all 15 degrees or more (next
//     to a needle the repairs only added points: hinge), and all four points
//     fixed (flat, lying on the surface: sphere966's worst tets). Worst first (the smaller of the
//     smallest dihedral angle and 180 - the largest), one new point x goes
//     into a cavity around each, re-tiled as the star of x over the cavity's
//     outer faces; the kept faces stay exactly as they are (each becomes a
//     face of a new tet with x). The cavity starts as the ring of the edge
//     that the tet's two other faces share (with one or three kept faces:
//     the tet and its neighbours across the others; with two, the tet and its
//     neighbours are not star-shaped from any point inside: that edge is
//     reflex) and grows across every outer face that x does not see
//     (exact::orient3d) until all are seen; it fails at a kept face, at 24
//     tets, or when a vertex would be left out. x is tried above the mean
//     centroid of the kept faces along their mean inward normal, at 0.1 ..
//     0.9 times h there, each then moved as in 2.; the best by the star's
//     worst measure is done when every new tet is positive,
//     the worst measure rises over the cavity's, the new tets with no
//     surface point hold the interior repair's floors, x lies at least h / 3
//     from every link point not on the surface (a closer one makes a short
//     interior edge), its smallest dihedral angle rises and its largest does
//     not (with one kept face: the smaller of the smallest and 180 - the
//     largest rises, and the largest stays within 0.5 degrees of the mesh's
//     largest before the cap repair, as the best star of a flat tet may need
//     a larger angle than the cavity had).
//     Such tets form where the parallel engine's leaves meet the surface at
//     depths beyond the default. A second, relaxed pass then takes the caps
//     the first left, and also the bad tets of four surface points with no
//     kept face (a flat tet across a fold of the surface, whose faces no flip
//     may improve: the reconnection only lowers largest angles, and the
//     interior repair leaves tets with fixed points alone; x starts at the
//     centroid and beside each face, at a quarter and half the height of the
//     regular tet over it): a star is taken there when its smallest angle
//     rises and every new tet lies within [10, 165] degrees, whatever the
//     cavity's largest angle (frame's parallel mesh kept flat tets of 5.9
//     degrees over a shallow fold whose best stars reach 11.6 to 17.4 with a
//     largest angle of 138 to 158). The first pass stays as it was: relaxed
//     from the start, it repaired such a cap of frame's serial mesh to 7.0
//     degrees before a neighbouring cap's larger cavity took it to 12.2.
//     The relaxed pass also takes two kinds of bad tets the first leaves:
//     every bad tet of four surface points, whatever its surface triangles
//     (one lying on a needle triangle of frame's fold kept 5.6 degrees in
//     its parallel mesh), and a free-apex cap: one kept face, a surface
//     triangle that is not a needle, under a free fourth point a. For the
//     latter, each point s of that triangle whose tets all hold a over a
//     kept face (a alone covers the surface fan of s: over a curved fan
//     those tets are as bad as the fan is curved and no position of a helps
//     them all; armadillo's worst) first gets a new point over its fan: the
//     cavity starts as the tets of s, x above s along the fan's mean inward
//     normal at the heights above, judged as the relaxed pass judges.
//     No smoothing follows (it could trade an angle near 180 degrees
//     elsewhere for a star's worst tet); the angle polish (6.) does.
//     The relaxed pass runs once more after the absorption (10.), before the
//     size polish (late_caps): the steps between move points and flip tets,
//     which makes new caps and flat tets of four surface points or changes
//     the cavities around the ones left, and some fit a star then. frame at
//     diag/100 kept a tet of four surface points across a plate 1.2 h thick
//     (two short surface edges facing each other) at 5.49 degrees, which the
//     late pass replaced (the mesh's smallest angle then 10.0 degrees, no tet
//     under 10);
//     sphere966 at the default size went from 9.7 / 171.8 to 9.9 / 167.9
//     degrees; no interior count changed (session 21, `pdrmesh_bench_refine`).
//
//  6. Angle polish (polish_angles, on; only with smooth): each free
//     point of a tet whose smallest dihedral angle is under
//     target_min_dihedral, ascending, once, moves by the compass search of 3.
//     to raise the smallest dihedral angle
//     of its star (not the measure: at a star's local best the measure may
//     balance an 8-degree angle against a 163-degree one), every tet positive,
//     a tet with a surface point keeping its largest angle within the larger
//     of 165 degrees and the star's old largest, a tet with none staying
//     within the targets or no worse than it was. sphere966's serial minimum
//     went from 6.93 to 8.66 degrees, couplingdown's interior from 14.9 / 150.6
//     to within [15, 150], and with 5.'s relaxed additions armadillo's parallel
//     minimum from 8.42 to 10.12 (its serial one's).
//
//  7. Margin polish (polish_margins, on; only with smooth), last: up to eight
//     rounds, while one moves a point. The margin of a tet is how far its
//     dihedral angles lie inside the targets (min(smallest -
//     target_min_dihedral, target_max_dihedral - largest), negative outside).
//     Each round moves, by a compass search as in 3., first the ring (the free
//     points next to a free point of a bad tet with no surface point, not on
//     such a tet), ascending, each to raise the smallest margin of its star's
//     tets with no surface point (all within the targets: room for the bad
//     tets' points), with keep_edge_sizes no edge off the surface made short;
//     then the free points of those bad tets, ascending, each to raise the
//     smallest margin of its star's bad tets with no surface point. Every tet
//     stays positive, a tet with no surface point within the targets stays
//     within them, and a tet with a surface point keeps each side within [10,
//     165] degrees where it was within, and within the mesh's extreme on that
//     side where it was past (so no tet falls under 10 degrees that was not,
//     and the extremes over all tets stay). The angle polish above raises the
//     smallest angle alone and leaves tets that are bad by a large angle, or
//     bad by both next to a worse neighbour; the repair rounds judge a star by
//     the measure, which may balance a tet just outside the targets against
//     others. The bad tets' points alone (4 rounds) took couplingdown's
//     interior at diag/100 from 42 tets outside [15, 150] to 25 and hinge's
//     from 552 to 376 (session 16, `pdrmesh_bench_refine`; the other surfaces
//     had none and are unchanged); the bounds of the tets with a surface point
//     as above ([min(10, smallest), max(165, largest)] before) to 23 and 333,
//     the ring and eight rounds to 8 and 206 (session 17). After the repair
//     cycles (8.), while such bad tets are left, one more margin polish whose
//     compass searches end at 1/1024 of their first step instead of 1/64:
//     couplingdown 2 -> 0, hinge 113 -> 65 (session 17).
//
//  8. Repair cycles (repair_cycles, 4; with interior_repair and
//     polish_margins): while bad tets with no fixed point remain and a cycle
//     leaves fewer of them, the interior repair rounds of 4. and the margin
//     polish of 7. again: the polish moves points that the repair's flips,
//     insertions and removals then reach. couplingdown at diag/100 8 -> 2
//     interior tets outside [15, 150] (14.9 / 150.0 degrees), hinge 206 ->
//     113, for 1 and 2 CPU s (session 17, `pdrmesh_bench_refine`); hinge's
//     interior edges within [0.6, 1.5] h 90.3% -> 90.2%. Without the
//     repair's smoothing the cycles left 7 and 174.
//
//  9. Size polish (polish_sizes, on; with smooth and a sizing field), last: up
//     to six rounds, while one changes something. The edges between two points
//     off the surface, one of them moved or inserted by the steps above, whose
//     length is out of [0.6, 1.5] times the mean h of their ends. First (with
//     reconnect) each such long edge, in the order of its ends, is removed
//     where a triangulation of its ring exists (flips.hpp's search) whose new
//     edges are all shorter and, off the surface, within the band at their
//     midpoint, and whose new tets are positive (exact) and within the
//     targets, or, with a surface point and the room below, within its limits;
//     the best smallest measure wins. Then (with insert_points) each long edge
//     still there is split by a new point x on it (each tet of its ring in
//     two) where the new tets hold the same bounds and at most one new edge to
//     a point off the surface is out of the band (x is tried at 1/2, then
//     0.45, 0.55, ..., 0.3, 0.7 of the edge; it moves next). Then each free
//     point of such an edge, or new, ascending, moves by a compass search as
//     in 3. to lower the number of its edges to points off the surface out of
//     [0.6, 1.5] h (h at each edge's midpoint when the search begins), then
//     their summed distance to the band, every tet of its star positive
//     (exact); a tet with no surface point stays within the targets where it
//     was, no worse on either side where it was not; with surface_room, a
//     tet with a surface point stays within the limits [max(10, the mesh's
//     smallest angle), min(165, its largest)] when the polish begins, and a
//     side already past them goes no further than the mesh's extreme on that
//     side: neither extreme of the mesh, nor the share under 10 degrees, gets
//     worse, and a mesh whose tets all lie within the targets keeps them there
//     (without the room, a parallel leaf task's, it is held as the others
//     are).
//
//     The steps above judge moves by angles (with keep_edge_sizes only against
//     short edges) and leave edges stretched where they worked: with every tet
//     held as the interior ones are (session 18), couplingdown's interior
//     edges within the band went 91.4% -> 95.5% at the default size and 95.9%
//     -> 97.3% at diag/100, hinge's at diag/100 90.4% -> 93.1%, for about 0.2
//     CPU s on sphere966's million tets. The room of the surface tets (session
//     19) matters on thin parts: hinge at the default size, where no point
//     lies deeper than about 0.85 h and the interior points form one sheet
//     that the smoothing lets zig-zag between the faces, went 64.0% -> 83.0%;
//     couplingdown 95.5% -> 98.1% (diag/100 97.3% -> 97.9%), primitives13 at
//     diag/100 92.8% -> 96.0%, hinge at diag/100 93.1% -> 93.9%, the extremes
//     and interior counts as they were (`pdrmesh_bench_refine`); the edge
//     removals then took hinge to 85.0% and 94.5% at diag/100, couplingdown to
//     98.5% and 98.1%, and the splits hinge to 90.4% and 95.2%, couplingdown
//     to 98.9% and 98.4% (the tet counts +8.5%, +7.5%, +10%, +4%). With the
//     limits at [10, 165] for every mesh, bunny_npm, elephant, knot2, fandisk
//     and primitives13, all within [15, 150] or nearly, fell to minima of
//     10-12 degrees.
//
// 10. Absorption (absorb, on; with interior_repair, polish_margins and
//     surface_room), after the margin polish's last pass and before the
//     size polish, while bad tets with no fixed point remain: up to 10
//     cycles, ending after 3 in a row that leave no fewer of them than the
//     fewest so far (the count goes up and down). A cycle offers each such
//     tet the repair's edge removals, 2-3 flips and point removal of 4.(a)
//     (no insertion), then an edge collapse (two of its free points replaced
//     by one new point, the tets of both stars by the star of the new point
//     over their outer faces, the point placed by a compass search from the
//     edge's midpoint), all judged another way: the new tets with no surface
//     point must all beat the worst old such tet (by the measure), while
//     those with a surface point need only be positive and within the mesh's
//     extremes when the cycle begins; then the repair rounds of 4., then the
//     margin polish's fine pass of 7. with the tets with a surface point
//     held within the mesh's extremes instead of [10, 165] and a ring three
//     layers deep (the free points next to the bad tets' points, the ones
//     next to those, and the next). Next to needle
//     triangles the tets on the surface are far worse than any interior one
//     anyway, and an interior tet that the steps above leave is often one
//     flip or one removal away from being handed to them (its points then
//     reach the surface). The absorption's own operations make no extreme
//     of the mesh worse; its repair rounds hold the floors of 4. hinge,
//     whose interior tets outside [15, 150] lie flat along surface triangles
//     35 to 85 h long, went from 56 to 25 at diag/100, and at diag/90, /95,
//     /105, /110 from 36, 44, 51, 72 to 4, 0, 2, 49; the collapses then took
//     diag/100 to 13 (14.4 / 150.6 degrees) and diag/90 to 0 (the share of
//     tets under 10 degrees +0.005 to +0.008 points, the optimization 9-36%
//     longer than without the absorption), and the deeper ring diag/90, /95,
//     /100, /105, /110 to 0, 2, 0, 0, 14 (the share under 10 degrees up to
//     +0.05 points, the optimization up to 2.4 times as long: diag/110 31 ->
//     75 s); the other surfaces have none left before it and are unchanged
//     (session 20, `pdrmesh_bench_refine`, PDRMESH_BENCH_DIVISOR). Not in a
//     parallel leaf task (surface_room off there: a sub-mesh's extremes are
//     not the mesh's).
//
// Guarantees: frozen faces keep their vertices and coordinates (flips and
// insertion refuse them; their points are fixed); hull faces and region
// interfaces likewise; the total volume is conserved up to rounding (points
// on the boundary do not move, and reconnection and insertion re-tile the
// same region). Every tet stays positive (exact). Determinism: same mesh and
// options give the same mesh, bit for bit: every order is by slot or point
// index, no hashing, no timing (the stats' seconds are measured, not used).
#pragma once

#include <cstddef>

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
  /// it was shorter already: moves judged by angles alone squeezed the
  /// interior next to needle triangles, to 86% of hinge's interior edges
  /// within [0.6, 1.5] h at diag/100 (92% after refinement) and 87.8% of
  /// couplingdown's at the default size; 90.4% and 90.6% with it (session
  /// 13, `pdrmesh_bench_refine`; the interior angle ranges as before on the
  /// surfaces that met [15, 150]).
  bool keep_edge_sizes = true;
  /// Run the reconnection step (flips; also after insertions).
  bool reconnect = true;
  /// Sliver removal by point insertion (needs a sizing field; see above).
  bool insert_points = true;
  /// A point is inserted only this far (times h at the point) from every
  /// vertex of the sliver's cavity.
  double insert_min_distance = 0.5;
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
  /// tets that its frozen hull keeps until a later task (frame's parallel
  /// minimum went from 14.1 to 10.7 degrees with the size polish's room
  /// there), so leaf_optimize_options turns it off.
  bool surface_room = true;
  /// Absorption after the repair cycles (10. above; with interior_repair,
  /// polish_margins and surface_room).
  bool absorb = true;
  /// The cap repair's relaxed pass once more after the absorption, before the
  /// size polish (5. above; with repair_caps). Off in a parallel leaf task
  /// (leaf_optimize_options): there it added points that took couplingdown's
  /// parallel tet count from 1.029 to 1.034 times the serial one.
  bool late_caps = true;
  /// Safety cap on successful flips per sweep, times the number of tets at the
  /// start of the sweep (the min-max rule already guarantees an end).
  double max_flips_per_tet = 20;
};

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
  double min_dihedral_before = 0, min_dihedral_after = 0;  ///< degrees, over all alive tets
  double max_dihedral_before = 0, max_dihedral_after = 0;
  double seconds = 0;  ///< wall time, measured only for reporting
};

/// Validates the options: targets finite with 0 <= min < max <= 180, sweeps >= 0, repair_cycles >= 0,
/// insert_min_distance >= 0, max_flips_per_tet > 0; invalid_input naming the option.
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
