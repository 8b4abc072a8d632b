// SPDX-License-Identifier: AGPL-3.0-or-later
// The engine's rounds, private to core/pdr: one round of leaf tasks and the
// splice of its results into the mesh (rounds.cpp), and which tets go to which
// task (round_tasks.cpp: selections, buffered and selected rounds, sub-meshes).
// Every function here is deterministic: its result does not depend on the
// thread count or the order in which tasks finish.
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "pdrmesh/decomposition.hpp"
#include "pdrmesh/fixed_chunks.hpp"
#include "pdrmesh/pdr.hpp"
#include "pdrmesh/scheduler.hpp"

namespace pdrmesh::round_detail {

struct RoundResult {
  std::size_t leaves = 0;
  std::size_t max_leaf_tets = 0;
  std::size_t failed = 0;      ///< leaves kept unrefined after a kernel error
  std::string first_failure;   ///< the lowest such leaf's error
  double merge_s = 0;          ///< serial: merges and the final splice
  double cpu_s = 0;            ///< process CPU seconds while the schedule ran
  ScheduleStats schedule;
  FixupStats fixups;
  RoundRecord record;
};

/// A grid of leaves: the depth-`depth` octree over `box`.
struct Grid {
  Box box;
  int depth = 0;
};

/// One round over decomposition d of `cur`: every leaf's tets go through
/// `kernel` (its hull frozen), and `cur` gets the results, leaf by leaf in
/// ascending order, new points appended in that order. Task inputs depend only
/// on the leaf's own tets and the points present before the round (nothing
/// moves a hull point, and new points get their ids only after the round), so
/// the result is the same for any worker count, completion order or policy.
/// With `selected` (one flag per tet of `cur`), a leaf's task gets only its
/// selected tets and the others are kept as they are, after the task's tets.
/// A buffered round (BufferedRound) gives tets to no leaf (kept as they are,
/// before all others) and a core box to each task.
/// Buffers as large as the mesh that a run's rounds reuse (the tets of no
/// task and their leaves, gathered before the tasks and put back after
/// them): allocated, and their pages first touched, once per run rather than
/// once per round, and handed back to the system when the run ends.
struct RoundScratch {
  detail::UninitVector<Tet> outside;
  detail::UninitVector<int> outside_leaf;
};

struct RoundExtras {
  RoundScratch* scratch = nullptr;  ///< none: the round's own buffers
  const std::vector<char>* selected = nullptr;
  const detail::UninitVector<Index>* outside = nullptr;  ///< ascending
  const std::vector<Box>* cores = nullptr;      ///< per leaf
  const Grid* grid = nullptr;                   ///< see splice
  std::vector<double>* sizes = nullptr;         ///< h per point of `cur`, kept up to date (see splice)
  std::size_t leaves_before = 0;                ///< leaves merged in this phase's earlier rounds (progress)
  std::size_t tets_beside = 0;                  ///< tets of the whole mesh when `cur` is a part of it (progress)
  /// Per tet of `cur`, kept up to date (with `grid` and `outside`): 1 when the
  /// last task that had it made it in its own leaf (its core), else 0.
  std::vector<char>* cored = nullptr;
  /// Per tet of `cur`, kept up to date: is_bad (with options.optimize_selects).
  std::vector<char>* bad = nullptr;
  /// Per leaf of the decomposition: the points its task inserts before it
  /// refines (LeafTaskInput::seeds).
  const std::vector<std::vector<Vec3>>* seeds = nullptr;
};
Status run_round(std::string_view phase, VolumeMesh& cur, Decomposition d, const FaceIdTable& boundary,
                 const SizingField& sizing, const LeafKernel& kernel, const PdrOptions& options, bool fixups,
                 RoundResult& rr, RoundExtras extras = {});

/// Adds to `flag` (one per tet of `m`) every tet within `layers` vertex
/// layers of a flagged one (a layer: the tets sharing a point with a flagged tet).
void grow_selection(const VolumeMesh& m, std::vector<char>& flag, int layers);

/// Whether options.optimize_selects picks tet `k` of `m` (the optimization's seeds).
inline char is_bad(const VolumeMesh& m, const Tet& k, const PdrOptions& options) {
  const std::vector<Vec3>& P = m.points;
  return options.optimize_selects(P[k[0]], P[k[1]], P[k[2]], P[k[3]]) ? 1 : 0;
}
/// is_bad of every tet of `m`, in parallel. The optimization computes it once
/// and its rounds keep it up to date (RoundExtras::bad): only the tets a task
/// made are tested again.
std::vector<char> bad_tets(const VolumeMesh& m, const PdrOptions& options);

/// The optimization rounds' selection: the `bad` tets (one flag per tet of
/// `m`) and their `halo` layers. With `skip`, the tets it flags are no seeds
/// (they may join a halo).
std::vector<char> select_around(const VolumeMesh& m, const std::vector<char>& bad, int halo,
                                const std::vector<char>* skip = nullptr);

/// The interface rounds' selection: the tets with a point on a face between
/// two of the last round's leaves (`m.tet_regions`: the leaf of each tet),
/// which that round kept frozen, and their `halo` layers. Everywhere else the
/// last round's kernel already ran to the end with nothing frozen nearby.
std::vector<char> select_interface_tets(const VolumeMesh& m, int halo);

/// The tasks of one buffered round (PdrOptions::buffered): the leaves of one
/// colour (the parities of the grid coordinates, i&1 | (j&1)<<1 | (k&1)<<2),
/// each with the tets whose barycenter it holds (its core) and those within
/// `layers` vertex layers of them (its buffer). A tet that two leaves' layers
/// reach at once goes to neither, nor does any layer grow across it, so the
/// tasks' tets are disjoint; they may share hull points, which no task moves.
/// In parallel and deterministic: per point the least and greatest leaf of
/// its tets by atomic min and max, each tet writing only its own owner.
struct BufferedRound {
  Decomposition d;             ///< leaves, leaf_tets (core and buffer); no lock sets (none conflict), no tet_leaf
  detail::UninitVector<Index> outside;  ///< the tets of no task, ascending
  std::vector<Box> cores;      ///< per leaf: its box
};
/// The colour of leaf l of the depth-`depth` grid: the parities of its grid
/// coordinates, i&1 | (j&1)<<1 | (k&1)<<2.
int colour_of(LeafId l, int depth);

/// The tasks of a buffered round of colour `colour` over the depth-`depth`
/// grid at `box`; m.tet_regions must hold the leaf of each tet's barycenter.
/// Only leaves in `allowed` (ascending; null: all) get a task. With `selected`
/// (one flag per tet), a leaf's core is its selected tets only; its buffer
/// may take any tet.
BufferedRound buffered_round(const VolumeMesh& m, const Box& box, int depth, int colour, int layers,
                             const std::vector<LeafId>* allowed, const std::vector<char>* selected = nullptr);

/// The tasks of a round that sends each leaf only its selected tets (one flag
/// per tet of m): a selected tet goes to the leaf of the depth-`depth` grid
/// over `box` that holds its barycenter, the others to no task (kept where
/// they are). Only the selection is bucketed, and the tasks, whose tets are
/// disjoint and whose hulls are frozen, need no lock sets.
BufferedRound selected_round(const VolumeMesh& m, const Box& box, int depth, const std::vector<char>& selected);

/// The tasks of a round from each tet's leaf (`owner`; at least kBlocked:
/// none): leaves ascending, each one's tets ascending, the others `outside`;
/// no cores, no lock sets, no tet_leaf (only the fix-ups read it).
BufferedRound tasks_of_owners(std::span<const LeafId> owner, const Box& box, int depth);

/// Some tets of a mesh as a mesh of their own, for rounds that work on a small
/// part of a large mesh: their scans and copies then cost what the part does.
/// Points are renumbered in ascending global order; tet_regions and the
/// boundary faces among the points come along.
struct SubMesh {
  VolumeMesh mesh;
  std::vector<Index> global_points;  ///< global index of each of mesh.points
  std::vector<Index> global_tets;    ///< global index of each of mesh.tets, ascending
};

SubMesh extract_tets(const VolumeMesh& m, const std::vector<char>& flag);

/// Replaces the tets `sub` was extracted from by sub.mesh's: the other tets
/// keep their order, sub.mesh's follow them; sub.mesh's points go back to
/// their global indices, and its new points are appended in order.
void put_back(VolumeMesh& m, SubMesh&& sub);

/// The leaves of the depth-`depth` grid in m.tet_regions and not in `done`, ascending.
std::vector<LeafId> leaves_without(const VolumeMesh& m, int depth, const std::vector<LeafId>& done);

/// tet_regions = the leaf of the depth-`depth` grid over `box` that holds each
/// tet's barycenter (in parallel: each tet writes its own entry).
void assign_leaves(VolumeMesh& m, const Box& box, int depth);

/// Drops points no tet uses, keeping the order of the others. The marks and
/// the renumbering of the tets run in parallel (idempotent stores, own slots).
void remove_unused_points(VolumeMesh& m);

}  // namespace pdrmesh::round_detail
