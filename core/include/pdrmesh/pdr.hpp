// SPDX-License-Identifier: AGPL-3.0-or-later
// The PDR engine in one process (the paper's Algorithm 1, with frozen
// interfaces): a dense initial TetGen mesh, an octree decomposition, one leaf
// task per leaf scheduled by run_leaves, each result validated and spliced into
// the global mesh, then (beyond the paper) an interface round over a second
// decomposition shifted by half a leaf, so that every first-round interface lies
// inside a leaf and is refined too, then an optional final optimization hook.
//
// Numbering and determinism. Global point ids are indices into one global point
// array: the initial mesh's points (the surface points first), then new points
// appended in merge order, new point k of a leaf result taking the next id. Under
// SchedulePolicy::kColoured the merge order is fixed (colour classes in order,
// each in ascending leaf order) and every task reads only its own leaf's tets,
// whose hull no other task can change, so each task's input bytes, the kernel's
// output bytes and the ids given are the same for any worker count: the result
// is byte-identical for 1 and N workers. Tets are listed leaf by leaf (ascending
// leaf, then kernel output order); unused points (interior points a TetGen
// kernel dropped) are removed at the end, keeping the order of the rest.
// kDynamic merges in completion order, so its numbering depends on timing.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "pdrmesh/decomposition.hpp"
#include "pdrmesh/leaf_task.hpp"
#include "pdrmesh/scheduler.hpp"
#include "pdrmesh/sizing.hpp"
#include "pdrmesh/status.hpp"
#include "pdrmesh/surface.hpp"
#include "pdrmesh/volume_mesh.hpp"

namespace pdrmesh {

/// Where run_pdr is, for a progress display and for stopping early.
struct PdrProgress {
  std::string_view phase;        ///< "initial mesh", "refinement", "interface round", "optimization"
  std::size_t leaves_done = 0;   ///< leaf results merged in this phase
  std::size_t leaves_total = 0;  ///< leaves of this phase (0 outside the rounds)
  std::size_t tets = 0;          ///< tets of the mesh as merged so far
};

struct PdrOptions {
  /// Octree depth; -1: default_depth(E, final_tets_per_leaf) with E the
  /// estimated final tet count, enclosed volume / regular_tet_volume(mean h at
  /// the surface points).
  int depth = -1;
  std::size_t final_tets_per_leaf = 20000;
  std::size_t workers = 1;
  SchedulePolicy policy = SchedulePolicy::kColoured;
  /// The initial TetGen mesh gets max_volume = leaf volume / this (leaf volume
  /// = (octree cube side / 2^depth)^3), so a full leaf holds a few hundred tets.
  double initial_volume_divisor = 200;
  /// A second round over the decomposition shifted by half a leaf (skipped at
  /// depth 0, where there are no interfaces).
  bool interface_round = true;
  /// Partition swap and boundary extraction; unset: kernel.needs_manifold_hull().
  std::optional<bool> fixups;
  /// Fix-up sweeps (swap then extraction over all leaves) at most, per round.
  std::size_t max_fixup_sweeps = 100;
  double tetgen_time_limit_s = 600;  ///< for the initial mesh
  /// The final optimization over the merged mesh (optimize.hpp); empty: none.
  std::function<Status(VolumeMesh&)> optimize;
  /// Called on the calling thread at each phase start and after each merged
  /// leaf result (serialised; it must be quick). Returning false stops the run:
  /// no further leaf task starts, and run_pdr returns a kCancelled status.
  std::function<bool(const PdrProgress&)> progress;
};

struct PdrProfile {
  // Seconds.
  double initial = 0;          ///< initial TetGen mesh
  double decomposition = 0;    ///< both rounds' decompositions
  double fixups = 0;           ///< partition swap + boundary extraction, both rounds
  double partition_swap = 0;
  double boundary_extraction = 0;
  double leaves = 0;           ///< round one run_leaves wall time (tasks and merges)
  double merge = 0;            ///< decode + validate + splice, both rounds
  double interface_round = 0;  ///< round two: decomposition, fix-ups, run_leaves
  double optimization = 0;
  double total = 0;
  // Counts.
  int depth = 0;
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
};

/// Meshes the volume inside `checked_surface` (closed, outward, checked by
/// surface_check) with `kernel` refining each leaf towards `sizing` (built from
/// this surface and any background mesh of it). The result validates against
/// the surface (validate_mesh); tet_regions holds the grid id of the leaf that
/// last produced each tet. `profile` may be null.
Result<VolumeMesh> run_pdr(const SurfaceMesh& checked_surface, const SizingField& sizing,
                           const LeafKernel& kernel, const PdrOptions& options, PdrProfile* profile);

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
};

/// The task input of one leaf: its points (ascending global index, which is
/// also the global id), its tets in local indices, its hull oriented outward as
/// frozen faces with their surface ids (0 for an interface face).
LeafTaskInput build_leaf_input(std::uint32_t leaf, std::span<const Vec3> points, std::span<const Tet> tets,
                               const FaceIdTable& boundary);

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
