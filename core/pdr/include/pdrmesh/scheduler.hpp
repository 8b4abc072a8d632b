// SPDX-License-Identifier: AGPL-3.0-or-later
// PDR leaf scheduling: runs one task per octree leaf, never two at once whose
// lock sets ({leaf} ∪ N1) overlap, and merges the results. Generic over the
// task; oneTBB supplies the threads (a one-thread arena is the serial mode).
//
// Two policies:
//
// kColoured (default, deterministic). The leaves are coloured greedily (at most
// 27 colours) so that no two leaves of one colour have overlapping lock sets
// (colour_classes). Classes run one after another; the tasks of a class run
// in parallel against the state left by the previous classes, and only when all
// of them are done are their results merged, on the calling thread, in ascending
// leaf order. Every run is therefore equivalent to the serial run "class 0 in
// leaf order, then class 1, ...", whatever the worker count or the timing. For
// byte-identical output the caller needs only:
//   * task(L) does not modify shared state (it may read anything: no merge runs
//     while tasks run) and is a deterministic function of what it reads;
//   * merge(L, r) is deterministic and numbers anything global (new points,
//     tets) in call order.
// The price is a barrier per class: a class waits for its slowest task.
//
// kDynamic (the paper's Algorithm 1). Whenever a worker is free, the ready leaf
// (its lock set free, not yet started) of lowest rank is locked and started
// (rank: the caller's priority order, e.g. longest task first; default: leaf
// index). When it finishes, the calling thread merges its result (merges are
// serialised, in completion order; other tasks keep running), then unlocks its
// lock set and starts whatever became ready. No barriers, so workers stay
// busy, but the merge order and the neighbour state each task sees follow the
// completion order: the results are independent of timing only when each
// task's input does not depend on other leaves' merges and the merges commute
// (run_pdr makes them so: frozen interfaces, and new points numbered in leaf
// order after the round, not in merge order). The tasks run on exactly
// `workers` threads of the scheduler's own (std::thread), so the calling
// thread is free to merge.
//
// Both policies lock through one LockTable; a failed lock (impossible when N1 is
// symmetric, as decompose() makes it) is counted in ScheduleStats::lock_failures
// and that leaf is run alone afterwards, so a leaf never runs beside a conflict.
//
// A caller whose workers come and go (the coordinator's remote workers) may
// pass `concurrency`: kDynamic asks it whenever it hands out tasks and runs at
// most that many at once (at least 1), starting more threads of its own when
// the answer grows (they stay until the end of the run); kColoured asks it
// once, at the start. The results do not depend on it.
//
// Thread count: the arena asks for `workers` threads, but oneTBB never starts
// more than its global limit (by default the hardware's); an application that
// wants more sets tbb::global_control(max_allowed_parallelism, ...) itself.
// Tasks must not throw (an exception would leave run_leaves by way of oneTBB).
#pragma once

#include <cstddef>
#include <functional>
#include <mutex>
#include <optional>
#include <queue>
#include <span>
#include <utility>
#include <vector>

#include "pdrmesh/decomposition.hpp"
#include "pdrmesh/types.hpp"

namespace pdrmesh {

enum class SchedulePolicy {
  kColoured,  ///< colour classes with barriers; deterministic (default)
  kDynamic,   ///< the paper's lock table, no barriers, completion-order merges
};

/// All-or-nothing locking of a leaf and its N1. Thread-safe.
class LockTable {
 public:
  explicit LockTable(std::size_t leaves);
  /// Locks `leaf` and every member of n1 iff none of them is locked; else
  /// changes nothing and returns false.
  bool try_lock(Index leaf, std::span<const Index> n1);
  /// Unlocks `leaf` and n1 (which must be what try_lock locked).
  void unlock(Index leaf, std::span<const Index> n1);
  bool locked(Index leaf) const;

 private:
  mutable std::mutex mu_;
  std::vector<unsigned char> locked_;
};

/// Greedy colouring of the conflict graph "lock sets overlap" (L and M conflict
/// iff M ∈ N1(L) ∪ N1(N1(L)), M != L): leaves are visited in `order` (empty:
/// ascending), each taking the smallest colour unused by its already coloured
/// conflicting leaves. Returns the non-empty classes, each ascending, in colour
/// order. n1 must be symmetric; `order`, when given, a permutation of the leaves.
std::vector<std::vector<Index>> colour_classes(std::span<const std::vector<Index>> n1,
                                               std::span<const Index> order = {});

/// The colouring run_leaves uses: greedy as above, visiting the leaves by their
/// grid residue class (i mod 3, j mod 3, k mod 3), then ascending. At most 27
/// colours: two distinct leaves of one residue class are 3 or more leaves apart,
/// so they never conflict, and by induction a leaf of the r-th residue class only
/// meets colours below r. Where empty leaves break conflicts, classes merge and
/// fewer colours result (plain ascending greedy can need more than 27).
std::vector<std::vector<Index>> colour_classes(const Decomposition& d);

/// The kDynamic picking policy without threads (shared by the scheduler and the
/// replay): tracks which leaves have a free lock set and hands out the lowest.
/// Not thread-safe.
class DynamicPicker {
 public:
  /// rank: one entry per leaf, the lower starts first among ready leaves (a
  /// permutation of the leaves is best; ties: lower leaf); empty: the leaf index.
  explicit DynamicPicker(std::span<const std::vector<Index>> n1, std::span<const Index> rank = {});
  bool has_ready();
  /// The not-yet-started leaf of lowest rank whose lock set is free; marks it
  /// started and its lock set taken. Precondition: has_ready().
  Index pop_lowest();
  /// Releases the lock set of a leaf returned by pop_lowest.
  void finish(Index leaf);

 private:
  void adjust(Index leaf, int delta);
  std::span<const std::vector<Index>> n1_;
  std::vector<Index> rank_;
  std::vector<unsigned> blocked_;  // per leaf: taken leaves in its lock set
  std::vector<unsigned char> started_;
  // Min-heap of candidates, checked lazily: a leaf is pushed whenever it may have
  // become ready; entries that are started or blocked are dropped at the top.
  std::priority_queue<std::pair<Index, Index>, std::vector<std::pair<Index, Index>>, std::greater<>> ready_;  // (rank, leaf)
};

struct ScheduleStats {
  std::size_t tasks = 0;
  double wall_s = 0;       ///< run_leaves, first task start to last merge
  double busy_s = 0;       ///< sum of the task durations (merges excluded)
  std::size_t max_concurrency = 0;  ///< most tasks seen running at once
  double mean_concurrency = 0;      ///< busy_s / wall_s
  std::size_t rounds = 0;           ///< colour classes run (kColoured), else 0
  std::size_t lock_failures = 0;    ///< see the file comment; 0 for a valid N1
  std::vector<double> task_s;       ///< per leaf: task duration (input to the replay)
};

/// The type-erased engine: run(leaf) computes and stores a leaf's result (it is
/// called concurrently for leaves with disjoint lock sets), commit(leaf) merges
/// the stored result (never two at once). n1 has one entry per leaf; `classes`
/// is the colouring for kColoured (empty: colour_classes(n1)); `rank` the
/// kDynamic priority (DynamicPicker).
ScheduleStats run_leaf_tasks(std::span<const std::vector<Index>> n1,
                             std::span<const std::vector<Index>> classes, std::size_t workers,
                             SchedulePolicy policy, const std::function<void(Index)>& run,
                             const std::function<void(Index)>& commit, std::span<const Index> rank = {},
                             const std::function<std::size_t()>& concurrency = {});

/// Runs task(leaf) for every leaf of `d` exactly once, at most `workers` (0 is
/// read as 1) at a time, never two with overlapping lock sets, and merge(leaf,
/// result) once per leaf after its task, as the policy says (file comment).
/// With lambdas, name the result type: run_leaves<MyResult>(d, 4, task, merge).
template <class Result>
ScheduleStats run_leaves(const Decomposition& d, std::size_t workers,
                         std::function<Result(Index)> task,
                         std::function<void(Index, Result&&)> merge,
                         SchedulePolicy policy = SchedulePolicy::kColoured, std::span<const Index> rank = {},
                         const std::function<std::size_t()>& concurrency = {}) {
  std::vector<std::optional<Result>> slots(d.size());
  const auto classes = policy == SchedulePolicy::kColoured ? colour_classes(d)
                                                           : std::vector<std::vector<Index>>{};
  return run_leaf_tasks(
      d.n1, classes, workers, policy, [&](Index leaf) { slots[leaf].emplace(task(leaf)); },
      [&](Index leaf) {
        merge(leaf, std::move(*slots[leaf]));
        slots[leaf].reset();
      },
      rank, concurrency);
}

}  // namespace pdrmesh
