// SPDX-License-Identifier: AGPL-3.0-or-later
// The PDR engine in one process (the paper's Algorithm 1): a dense initial
// TetGen mesh, an octree grid over it, leaf tasks scheduled by run_leaves,
// each result validated and spliced into the global mesh, then the
// optimization: one task over every bad tet and its halo, or on large meshes
// optimization rounds and a final pass in buffered rounds over what they left.
//
// Refinement (a kernel that refines the volume it is given): buffered rounds.
// The leaves go in eight rounds by the parities of their grid coordinates, so
// two leaves of one round are a leaf apart. A task gets its leaf's tets (those
// whose barycenter the leaf's box holds) and one vertex layer of its
// neighbours' tets around them, the buffer the paper's lock set protects; it
// may change all of them and adds points only inside its box. Its hull lies in
// the neighbouring leaves, which later rounds refine with these points in
// view, so no interface stays coarse. A kernel that needs each leaf's hull to
// be a closed manifold (TetGen) runs the frozen scheme instead: one round with
// every leaf's hull frozen, then interface rounds over the grid shifted by half
// and by a quarter leaf.
//
// Numbering and determinism. Global point ids are indices into one global point
// array: the initial mesh's points (the surface points first), then each
// round's new points, appended after the round leaf by leaf in ascending leaf
// order (new point k of a leaf result taking the next id), whatever the order
// in which the results came in. The tasks of a round share no tet and read
// only their own tets and the points present before the round; no task moves
// a point of its hull. Hence each task's input bytes, the kernel's output
// bytes and the ids given are the same for any worker count, policy or timing:
// the result is byte-identical for 1 and N workers. Tets the round's tasks did
// not get come first, then each task's tets in ascending leaf order; unused
// points (interior points a TetGen kernel dropped) are removed at the end,
// keeping the order of the rest.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "pdrmesh/decomposition.hpp"
#include "pdrmesh/leaf_task.hpp"
#include "pdrmesh/scheduler.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/tetgen_adapter.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

/// The engine's state after a round: enough to go on from there (PdrOptions::
/// resume), e.g. after a coordinator restart. Rounds are counted in run order
/// (refinement 1, interface rounds 2 and 3, optimization rounds, the final
/// optimization task; those a run skips are not counted).
struct PdrCheckpoint {
  int rounds_done = 0;
  std::string round;  ///< the name of the last round done
  VolumeMesh mesh;    ///< the merged mesh after it, with the surface's own ids and each tet's leaf

  /// Bit-exact little-endian bytes (doubles as their bits), ending with their
  /// content_digest (digest.hpp).
  std::string encode() const;
  /// invalid_input for bytes that do not match their digest, are not a
  /// checkpoint of this version, whose counts the bytes cannot hold, or whose
  /// indices are out of range.
  static Result<PdrCheckpoint> decode(std::string_view bytes);
};

/// Where run_pdr is, for a progress display and for stopping early.
struct PdrProgress {
  std::string_view phase;        ///< "initial mesh", "refinement", "interface round", "optimization"
  std::size_t leaves_done = 0;   ///< leaf results merged in this phase
  std::size_t leaves_total = 0;  ///< leaves of this phase (0 outside the rounds)
  std::size_t tets = 0;          ///< tets of the mesh as merged so far
};

struct PdrOptions {
  /// Octree depth; -1: 0 (one leaf, the serial path) when E is under
  /// min_parallel_tets, else the smallest depth whose occupied leaves hold
  /// about final_tets_per_leaf of E tets or fewer each (default_depth with
  /// occupied_leaves_estimate), E the estimated final tet count, enclosed
  /// volume / regular_tet_volume(mean h at the surface points).
  int depth = -1;
  /// A depth, asked for or chosen, whose leaves would be narrower than this
  /// many times the surface's spacing (PdrPlan::surface_h) runs at the
  /// deepest depth whose leaves are that wide (PdrPlan::requested_depth then
  /// says what was asked). The colour order shifts the points within about
  /// one spacing of a leaf's faces (the first leaves pile them up there, the
  /// last ones lack them), so a leaf with little inside those bands drifts
  /// from the serial mesh: more tets and a far longer optimization
  /// (bench/NOTES.md). 0: any depth.
  double min_leaf_width = 3;
  /// 0: 5000 with buffered rounds (each of the eight rounds then has many
  /// tasks, none of them long), 20000 without.
  std::size_t final_tets_per_leaf = 0;
  std::size_t min_parallel_tets = 100000;
  std::size_t workers = 1;
  /// Set: how many leaf tasks may run at once now, asked whenever tasks are
  /// handed out (scheduler.hpp), in place of `workers`: a coordinator whose
  /// workers join during a job widens it. The bytes do not depend on it.
  std::function<std::size_t()> concurrency;
  /// Both policies give the same bytes; kDynamic (no barriers) keeps workers busier.
  SchedulePolicy policy = SchedulePolicy::kDynamic;
  /// The initial TetGen mesh gets max_volume = leaf volume / this (leaf volume
  /// = (octree cube side / 2^depth)^3), so a full leaf holds a few hundred tets;
  /// at depth 0 with seeds_only none (the serial pipeline's initial mesh).
  double initial_volume_divisor = 200;
  /// ... but never below this times the regular tet volume at the mean h of
  /// the surface points: the refiner keeps every initial point, so seeds
  /// about as dense as the target set the spacing instead of the refiner
  /// (buffered rounds on sphere966 at diag/100, depth 4: 0.78 times the
  /// serial tets with 2, 1.06 with 8, 1.02 with 27). Unset: 16 with buffered
  /// rounds; 2 with frozen leaf hulls, where too coarse a start leaves small
  /// leaves nothing to refine between their hulls (0.52 times the serial tets
  /// with 8 on sphere966 at depth 3).
  std::optional<double> initial_min_volume_factor;
  /// Unset: true for a kernel that refines the volume it is given (native),
  /// false for one that needs the fix-ups (tetgen: they were tuned on TetGen's
  /// refined initial mesh and take 3x longer on the seeded one, primitives13 at
  /// depth 2: 188 s against 57 s). true: the initial mesh is the
  /// boundary-conforming mesh plus the seed lattice of max_volume
  /// (TetgenOptions::seeds_only): no TetGen refinement. TetGen's
  /// -a and -q place points next to the boundary, closer than the target
  /// spacing where the body is thin, and the refiner never removes a point:
  /// couplingdown at its default depth (1) made 1.058 times the serial tets
  /// with them, 0.992 without; the other seven small corpus surfaces at their
  /// default depths stay within 1.8% of serial either way, frame and armadillo
  /// within 0.6% without. false: TetGen refines with
  /// -a max_volume and -q initial_radius_edge.
  std::optional<bool> initial_seeds_only;
  /// TetGen -q for the initial mesh when !initial_seeds_only (radius-edge
  /// bound); unset: none. Without it the dense initial mesh holds flat tets of
  /// four surface points that no round refines and no optimization can flip
  /// away (fandisk, elephant: min dihedral 2.9 and 6.6 degrees where the serial
  /// mesh has 14.5 and 15). The seeds keep off the boundary, so at the default
  /// depths no such tet stays; at depths beyond the default a few do
  /// (primitives13 at depth 2: min dihedral 5.2 against the serial 15.2).
  std::optional<double> initial_radius_edge = 1.4;
  /// Refinement in buffered rounds (for a kernel that refines the volume it
  /// is given; not with the fix-ups): the leaves go in eight rounds by the
  /// parities of their grid coordinates. A task gets its leaf's tets and every
  /// tet within buffer_layers vertex layers of them, may change all of them,
  /// and adds points only inside its leaf's box (LeafTaskInput::core). Its
  /// frozen hull lies inside the neighbouring leaves, which a later round
  /// refines with this one's points in view, so no interface stays coarse and
  /// no interface round follows. Two leaves of one round are a leaf apart; a
  /// tet that both buffers would reach goes to neither. false: one round with
  /// every leaf's hull frozen, then the interface rounds below.
  bool buffered = true;
  int buffer_layers = 1;
  /// The interface rounds over the decomposition shifted by half a leaf, then
  /// by a quarter leaf (skipped at depth 0, where there are no interfaces).
  bool interface_round = true;
  /// How many of those rounds (1 or 2): after the half-leaf round, coarse
  /// tets stay where a first-round interface plane crosses a second-round one
  /// (frozen in both); the quarter-leaf round refines them (hinge, bunny_npm,
  /// elephant at depth 2: parallel/serial tets 0.81, 0.90, 0.96 with one round,
  /// 0.84, 0.98, 1.01 with two).
  int interface_rounds = 2;
  /// An interface round sends a leaf only its tets with a point on the last
  /// round's frozen interfaces and this many vertex layers around them (the
  /// leaf's other tets stay as they are, and a leaf with none runs no task):
  /// elsewhere the last round's kernel already ran to the end. 0, or a kernel
  /// that needs the fix-ups: whole leaves.
  int interface_halo = 2;
  /// Partition swap and boundary extraction; unset: kernel.needs_manifold_hull().
  std::optional<bool> fixups;
  /// Fix-up sweeps (swap then extraction over all leaves) at most, per round.
  std::size_t max_fixup_sweeps = 100;
  double tetgen_time_limit_s = 600;  ///< for the initial mesh
  /// Optimization as leaf tasks (the optimization rounds, over the grid and
  /// the shifted grid, and the final pass; not owned; null: none).
  /// mesh_parallel passes a NativeLeafKernel running optimize() with the leaf
  /// hull frozen.
  const LeafKernel* optimize_kernel = nullptr;
  /// The final pass where it is one task (see optimize_selects; not owned;
  /// null: optimize_kernel). That task holds every bad tet, so the mesh's
  /// angle extremes are its own, and it may run the whole mesh's schedule
  /// (final_optimize_options, leaf_kernels.hpp).
  const LeafKernel* final_optimize_kernel = nullptr;
  /// The final optimization over the whole merged mesh (optimize.hpp), after
  /// the optimization rounds; empty: none. It sees the mesh as one region.
  /// Not used when optimize_selects is set (see there).
  std::function<Status(VolumeMesh&)> optimize;
  /// The tets the optimization works on (optimize.hpp's bad tets), by their
  /// corners; empty: every tet. When set, each optimization round sends a leaf
  /// only its tets within optimize_halo vertex layers of such a tet (the others
  /// stay as they are; the selection's outer faces are frozen like any leaf
  /// hull, and a leaf with no selected tet runs no task), and the final pass
  /// runs optimize_kernel instead of `optimize`: with buffered rounds at depth
  /// 5 or more (large meshes, where one task would be the run's long pole) in
  /// colour rounds over a grid two levels coarser than the refinement's, two
  /// sweeps (a task's buffer changes tets of leaves whose round has passed;
  /// the second sweep seeds only the bad tets no task has had in its core
  /// since); below that as one task over the whole selection
  /// (final_optimize_kernel), with no optimization rounds before it: that
  /// task works on every bad tet again, and what the rounds did there would
  /// be paid twice. The work then follows the bad tets, not the mesh size.
  std::function<bool(const Vec3&, const Vec3&, const Vec3&, const Vec3&)> optimize_selects;
  /// Vertex layers around the selected tets: with 1, every point of a bad tet
  /// has its whole star in the task (it may move); 2 also lets the points of
  /// its neighbours move and their edges flip.
  int optimize_halo = 2;
  /// The final pass's buffer: a task gets its leaf's selected tets and this
  /// many vertex layers of any tets around them, and may change all of them
  /// but its hull.
  int optimize_buffer_layers = 2;
  /// A leaf whose kernel fails (is_kernel_failure: a TetGen crash on its hull,
  /// say) is kept as it was, unrefined, and counted in
  /// PdrProfile::failed_leaves; false: the run fails. A task that could not be
  /// run (a dispatcher's error) and a result that fails validation always fail
  /// the run.
  bool keep_failed_leaves = true;
  /// Called on the calling thread at each phase start and after each merged
  /// leaf result (serialised; it must be quick). Returning false stops the run:
  /// no further leaf task starts, and run_pdr returns a kCancelled status.
  std::function<bool(const PdrProgress&)> progress;
  /// Called on the calling thread after each round with the state then (to
  /// store it: PdrCheckpoint::encode); an error fails the run. Empty: none.
  std::function<Status(const PdrCheckpoint&)> checkpoint;
  /// Not owned; set: go on from this checkpoint, written by a run with the same
  /// surface, sizing field, kernels and options: no initial mesh is made, the
  /// rounds it counts are skipped, and the result is byte-identical to that
  /// run's (the profile then covers the rounds run, not the skipped ones).
  /// Its mesh is moved from (a large job holds one copy of it, not two).
  PdrCheckpoint* resume = nullptr;
};

/// What one round's schedule was: enough to replay it (schedule_replay.hpp).
struct RoundRecord {
  std::string name;                    ///< "refinement", "interface round", ...
  int depth = 0;
  std::vector<LeafId> leaves;          ///< grid ids of the round's leaves, ascending
  std::vector<std::vector<Index>> n1;  ///< the decomposition's N1 (lock sets)
  std::vector<Index> rank;             ///< kDynamic priority of each leaf
  std::vector<double> task_s;          ///< measured task seconds per leaf
  double wall_s = 0;                   ///< the schedule's wall time (tasks and merges)
  std::size_t tets = 0;                ///< tets in the mesh when the round began
  std::size_t tets_sent = 0;           ///< of them, tets given to the leaf tasks (a selection: fewer)
};

struct PdrProfile {
  // Seconds.
  double initial = 0;          ///< the initial mesh: the seeds' insertion into the background mesh (mesh_parallel), or all of initial_mesh
  double decomposition = 0;    ///< both rounds' decompositions
  double fixups = 0;           ///< partition swap + boundary extraction, both rounds
  double partition_swap = 0;
  double boundary_extraction = 0;
  double leaves = 0;           ///< round one run_leaves wall time (tasks and merges)
  double merge = 0;            ///< serial merge work (results stored, splice), all rounds
  double interface_round = 0;  ///< the interface rounds: decomposition, fix-ups, run_leaves
  double optimization = 0;     ///< optimization rounds and the global hook
  double optimization_leaves = 0;  ///< of which the optimization rounds (decomposition included)
  double task_busy = 0;        ///< sum of all leaf task durations, all rounds
  double global_optimization = 0;  ///< of optimization: the global `optimize` hook (serial)
  double total = 0;            ///< the engine: initial mesh to the end of the last round or hook
  // Outside run_pdr, so that the profile covers the whole run (0 when not measured).
  double read = 0;             ///< reading the surface (CLI)
  double surface_check = 0;    ///< surface_check (CLI)
  double background = 0;       ///< TetGen's boundary mesh: the sizing field's background and the initial mesh's start (mesh_parallel)
  double sizing = 0;           ///< SizingField::build (mesh_parallel)
  double overlapped = 0;       ///< time steps ran side by side: validation beside the write (CLI)
  double validation = 0;       ///< validate_mesh of the result (CLI)
  double write = 0;            ///< writing the result (CLI)
  double quality = 0;          ///< the quality summary (CLI)
  double wall = 0;             ///< the whole run as measured by its caller; 0: total
  double cpu = 0;              ///< process CPU seconds of the whole run (its caller; 0: not measured)
  double task_cpu = 0;         ///< process CPU seconds while the leaf schedules ran
  std::size_t threads = 0;     ///< threads the run's parallel steps had (0: not recorded)
  // Counts.
  int depth = 0;
  int requested_depth = -1;  ///< PdrPlan::requested_depth: the depth asked for when the run went shallower
  std::size_t initial_tets = 0;
  std::size_t leaf_count = 0;          ///< non-empty leaves of round one
  std::size_t interface_leaf_count = 0;
  std::size_t fixup_swaps = 0;         ///< tets moved by partition swap
  std::size_t fixup_moves = 0;         ///< tets moved by boundary extraction
  std::size_t fixup_unresolved = 0;    ///< leaves still failing after max_fixup_sweeps
  std::size_t max_leaf_tets = 0;       ///< largest round-one leaf (input tets)
  std::size_t interior_points = 0;     ///< result points that are not surface points
  std::size_t final_tets = 0;
  std::size_t max_concurrency = 0;     ///< most leaf tasks seen running at once
  std::size_t failed_leaves = 0;       ///< leaves kept unrefined after a kernel error, all rounds
  std::string first_failure;           ///< the first such error
  std::vector<RoundRecord> rounds;     ///< every round's schedule, in run order
};

/// Meshes the volume inside `checked_surface` (closed, outward, checked by
/// surface_check) with `kernel` refining each leaf towards `sizing` (built from
/// this surface and any background mesh of it). The result validates against
/// the surface (validate_mesh), its boundary with the surface's ids (any int:
/// inside, they are engine ids >= 1, surface_ids.hpp) and names; tet_regions holds the
/// grid id of the leaf that last produced each tet. `profile` may be null.
Result<VolumeMesh> run_pdr(const SurfaceMesh& checked_surface, const SizingField& sizing,
                           const LeafKernel& kernel, const PdrOptions& options, PdrProfile* profile);

/// How run_pdr starts: the octree depth and the initial TetGen options, both
/// from the mean of h over the surface points (surface_h).
struct PdrPlan {
  double surface_h = 0;
  int depth = 0;
  /// The depth asked for (PdrOptions::depth) when min_leaf_width made it
  /// shallower, else -1.
  int requested_depth = -1;
  /// The final tet count the plan expects (the estimate it was given, or the
  /// surface's volume over a regular tet of edge surface_h): run_pdr reserves
  /// room for it, so that the rounds grow the mesh's arrays in place.
  double estimated_tets = 0;
  TetgenOptions tetgen;
  /// With seeds only, the native kernel and buffered rounds: the initial mesh
  /// holds the seeds of insert_points' coarser rounds, and those of its finest
  /// round (about 7/8) go in by leaf tasks, in a sweep of colour rounds before
  /// the refinement: each to the task of the leaf that holds it
  /// (LeafTaskInput::seeds), in parallel with the other leaves.
  bool leaf_seeds = false;
  /// With seeds only: no seed's lattice cell holds fewer than about this many
  /// regular tets of edge h at the seed (PdrOptions::initial_min_volume_factor).
  /// Where h is coarser than surface_h, in a far field above all, the lattice
  /// of max_volume thins out to coarser lattices (seed_points' widest), so
  /// that at no depth are the seeds denser than the field asks for: one depth
  /// below the default, a lattice spaced for the smaller leaves had put a
  /// quarter to a third more tets into far-field meshes.
  double seed_min_tets = 16;
  /// With a size (SizingOptions::size): the initial mesh leaves out the seeds
  /// where h rises above it next to wider surface triangles (the lattice is
  /// spaced for the size, and points the refiner would not put there stay).
  SizingOptions sizing;
};

/// The initial mesh, and with PdrPlan::leaf_seeds the seeds left for the leaf tasks.
struct InitialMesh {
  VolumeMesh mesh;
  std::vector<Vec3> leaf_seeds;
};

/// The h a plan sizes leaves by: with --size, the size (the volume's h, not
/// its rise next to wide triangles); otherwise the mean of sizing.at over the
/// surface points, in point order.
double surface_spacing(const SurfaceMesh& surface, const SizingField& sizing);

/// The plan run_pdr makes for this surface_h: depth (options.depth, or the
/// default from the estimated tet count: `estimated_tets`, or when that is
/// negative the surface's volume over a regular tet of edge surface_h) and the
/// initial mesh's volume bound. invalid_input on a bad depth or divisor or an
/// empty surface. `kernel` decides an unset PdrOptions::initial_seeds_only.
Result<PdrPlan> plan_pdr(const SurfaceMesh& checked_surface, double surface_h, const PdrOptions& options,
                         const LeafKernel& kernel, double estimated_tets = -1);

/// The plan's initial mesh. With seeds only (TetgenOptions::seeds_only and a
/// max_volume): TetGen's boundary-conforming mesh of the surface (`background`
/// when given: tetrahedralize(surface) with no volume bound, as the sizing
/// field's background mesh is made) with the seed lattice's points
/// (seed_points, graded by the field's h: PdrPlan::seed_min_tets) inserted by
/// constrained Delaunay insertion (insert_points): TetGen runs once, not again
/// with the seeds. `sizing`: the field of plan.sizing over that background
/// (SizingField::build), or null to build it here. With plan.leaf_seeds only
/// the seeds of the coarser rounds (insertion_round) go in here; the others
/// come back in leaf_seeds, in lattice order. Otherwise tetrahedralize(surface,
/// plan.tetgen).
Result<InitialMesh> initial_mesh(const SurfaceMesh& checked_surface, const PdrPlan& plan,
                                 const VolumeMesh* background = nullptr, const SizingField* sizing = nullptr);

/// run_pdr from an initial mesh the caller made with initial_mesh(surface,
/// plan, background, &sizing) (in initial_s seconds, counted in the profile),
/// plan from plan_pdr(surface, surface_spacing(surface, sizing), options): the
/// same result as run_pdr above. Lets the caller plan beside TetGen and share
/// TetGen's mesh and the field with the initial mesh (mesh_parallel does).
Result<VolumeMesh> run_pdr(const SurfaceMesh& checked_surface, const SizingField& sizing,
                           const LeafKernel& kernel, const PdrOptions& options, PdrProfile* profile,
                           const PdrPlan& plan, InitialMesh initial, double initial_s);

// ---- engine pieces, public for tests and for a distributed coordinator

/// Surface id lookup of boundary faces by their sorted point triple.
class FaceIdTable {
 public:
  FaceIdTable() = default;
  FaceIdTable(std::span<const Tri> faces, std::span<const int> ids);
  /// The id of the face with these points (any order), or 0 when not listed.
  int lookup(const Tri& face) const;

 private:
  std::vector<std::pair<Tri, int>> sorted_;
  Index last_point_ = 0;  ///< the largest point of a listed face (the surface's come first)
};

/// The task input of one leaf: its points (ascending global index, which is
/// also the global id), its tets in local indices, its hull oriented outward as
/// frozen faces with their surface ids (0 for an interface face); with
/// `sizes` (one per global point) their h as LeafTaskInput::sizes.
LeafTaskInput build_leaf_input(std::uint32_t leaf, std::span<const Vec3> points, std::span<const Tet> tets,
                               const FaceIdTable& boundary, std::span<const double> sizes = {});

struct FixupStats {
  std::size_t swaps = 0;       ///< partition swap: tets moved out of a leaf
  std::size_t moves = 0;       ///< boundary extraction: tets moved into a leaf
  std::size_t unresolved = 0;  ///< leaves still loose or non-manifold at the end
  std::size_t sweeps = 0;
  double swap_s = 0, extraction_s = 0;
};

/// The paper's fix-ups on d.tet_leaf and d.leaf_tets (n1, n2, interface_faces
/// are left as the grid made them). Partition swap: in each leaf, face-connected
/// components that share a vertex or an edge with another of the leaf's
/// components (loosely connected) are moved, tet by tet, to the lowest-index
/// leaf holding a face neighbour, keeping the largest component. Boundary
/// extraction: where the tets of a leaf around a hull edge or vertex form more
/// than one face-connected sector (a non-manifold hull edge or a pinched
/// vertex), the smallest sector of other leaves' tets there is moved into the
/// leaf. Sweeps over the leaves in ascending order until nothing changes, at
/// most max_sweeps. Deterministic.
FixupStats apply_fixups(const VolumeMesh& mesh, Decomposition& d, std::size_t max_sweeps);

/// Leaves (indices into d.leaves) whose tets are loosely connected or whose hull
/// is not manifold at an edge or vertex (the fix-ups' target condition).
std::vector<Index> leaves_needing_fixups(const VolumeMesh& mesh, const Decomposition& d);

}  // namespace pdrmesh
