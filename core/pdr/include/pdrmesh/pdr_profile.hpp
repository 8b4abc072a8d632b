// SPDX-License-Identifier: AGPL-3.0-or-later
// A PDR run's profile as a file, and its replay: `pdrmesh run --profile-json`
// writes the phase times and every round's schedule (leaves, N1, priorities,
// measured task seconds); `pdrmesh replay` reads it back and projects, with
// replay_schedule, what P workers would make of the same tasks under the lock
// table, to judge scaling beyond the cores at hand.
//
// Projection. For P workers, each round's leaf tasks are replayed (kDynamic,
// the run's priorities) and the run's work outside the tasks (initial mesh,
// decomposition, merges, validation, ...) is added as SerialModel says:
//   projected(P) = outside(P) + sum over rounds of makespan_r(P)
//   leaf speedup = sum of task seconds / sum of makespans
//   run speedup  = projected(1) / projected(P).
// Merges, locking and thread start-up inside the rounds count as free. A
// synthetic scaling stands in for a bigger job run at a deeper octree: every
// leaf is split into 8^k children k levels deeper, each taking 1/8^k of the
// leaf's time (refine_round). Multiplying all times by one factor (a job with
// the same depth and more tets a leaf) would not change any speedup.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "pdrmesh/pdr.hpp"
#include "pdrmesh/status.hpp"

namespace pdrmesh {

/// The profile as JSON (version 1): {"version", "phases": {name: seconds},
/// "depth", "final_tets", "workers", "rounds": [{"name", "depth", "leaves",
/// "n1", "rank", "task_s", "wall_s"}]}.
std::string profile_to_json(const PdrProfile& profile, std::size_t workers);

/// Reads profile_to_json's output back (phases, counts and rounds);
/// invalid_input naming the first problem (bad JSON, missing field, lengths
/// that disagree, an index out of range).
Result<PdrProfile> profile_from_json(std::string_view json);

/// Serial seconds of a run: its wall time (total when wall is 0) minus the
/// wall time of its rounds' leaf schedules (never below 0).
double serial_seconds(const PdrProfile& profile);

/// The run's time outside the leaf schedules on P cores. The initial mesh
/// (TetGen's boundary mesh, then the seed insertion) is serial. The rest
/// (sizing, decomposition, merges, validation, quality, writing, ...) is split
/// by Amdahl's law from its wall and CPU time on the measured run's T threads:
/// wall = s + w / T and cpu = s + w give its serial seconds s and its
/// parallel work w, and it takes s + w / P on P cores. Without CPU figures
/// (older profiles, one thread) everything outside the tasks counts as serial.
struct SerialModel {
  double initial_s = 0;   ///< the initial mesh (serial)
  double serial_s = 0;    ///< the rest's serial seconds
  double parallel_s = 0;  ///< the rest's parallel work, CPU seconds
  double at(std::size_t cores) const;
};
SerialModel serial_model(const PdrProfile& profile);

/// A round made 8^k times finer: every leaf at depth d becomes its 8^k
/// children at depth d + k, each with 1/8^k of the leaf's task time and rank
/// order kept (children of a leaf in grid order); N1 recomputed (grid_n1).
/// k = 0 returns the round as it is. invalid_input when d + k > kMaxDepth.
Result<RoundRecord> refine_round(const RoundRecord& round, int k);

struct ProjectedRun {
  std::size_t workers = 1;
  double leaf_total_s = 0;     ///< sum of task seconds over the rounds
  double leaf_makespan_s = 0;  ///< sum of the rounds' replayed makespans
  double leaf_speedup = 0;     ///< leaf_total_s / leaf_makespan_s
  double run_s = 0;            ///< serial + leaf_makespan_s
  double run_speedup = 0;      ///< run_s(1 worker) / run_s
};

/// The projection above for `workers` (as many cores), the rounds already
/// refined/scaled as wanted.
ProjectedRun project_run(const std::vector<RoundRecord>& rounds, const SerialModel& outside, std::size_t workers);

}  // namespace pdrmesh
