// SPDX-License-Identifier: AGPL-3.0-or-later
// Projected scaling of the PDR leaf schedule: replays measured per-leaf task
// durations on P simulated workers under a scheduling policy (scheduler.hpp),
// with a deterministic event simulation, to judge scaling beyond the cores at
// hand. Merges, locking and thread start-up are taken as free, so the figures
// are upper bounds on what the schedule allows, not predictions of wall time.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "pdrmesh/scheduler.hpp"
#include "pdrmesh/types.hpp"

namespace pdrmesh {

struct ReplayResult {
  std::size_t workers = 1;
  double total_s = 0;     ///< sum of the durations (the one-worker makespan)
  double makespan_s = 0;  ///< projected time to run every leaf
  double speedup = 0;     ///< total_s / makespan_s (1 when total_s is 0)
  double efficiency = 0;  ///< speedup / workers
};

/// Simulates `workers` (0 is read as 1) workers running one task of
/// durations[leaf] seconds per leaf, the lock sets given by n1 (one entry per
/// leaf, symmetric, as in Decomposition::n1):
///  kColoured: the classes (empty: colour_classes(n1); pass colour_classes(d)
///    to replay what run_leaves does) one after another; within a
///    class, tasks in ascending leaf order, each on the earliest free worker
///    (ties: lowest worker); the next class starts when the class's last task ends.
///  kDynamic: DynamicPicker with `rank` (empty: leaf order); at each time,
///    free workers start the ready leaves of lowest rank; completions are processed in (time, leaf) order, and all tasks
///    finishing at one instant release their locks before anything starts.
/// Negative durations count as 0. Deterministic. Note that the makespan need not
/// fall as workers are added: greedy list scheduling has anomalies (kDynamic on
/// unequal durations shows them: a leaf started early can block a better one).
ReplayResult replay_schedule(std::span<const std::vector<Index>> n1,
                             std::span<const double> durations, std::size_t workers,
                             SchedulePolicy policy,
                             std::span<const std::vector<Index>> classes = {},
                             std::span<const Index> rank = {});

}  // namespace pdrmesh
