// SPDX-License-Identifier: AGPL-3.0-or-later
// Deterministic event simulation of the PDR leaf schedule (see schedule_replay.hpp).
#include "pdrmesh/schedule_replay.hpp"

#include <algorithm>
#include <functional>
#include <queue>
#include <utility>

namespace pdrmesh {
namespace {

double coloured_makespan(std::span<const std::vector<Index>> classes,
                         std::span<const double> dur, std::size_t workers) {
  double start = 0;
  // Min-heap of (free time, worker).
  using Slot = std::pair<double, std::size_t>;
  for (const std::vector<Index>& cls : classes) {
    std::priority_queue<Slot, std::vector<Slot>, std::greater<>> free;
    for (std::size_t w = 0; w < workers; ++w) free.emplace(start, w);
    double end = start;
    for (Index leaf : cls) {
      auto [t, w] = free.top();
      free.pop();
      const double done = t + std::max(0.0, dur[leaf]);
      end = std::max(end, done);
      free.emplace(done, w);
    }
    start = end;
  }
  return start;
}

double dynamic_makespan(std::span<const std::vector<Index>> n1, std::span<const double> dur,
                        std::size_t workers, std::span<const Index> rank) {
  DynamicPicker picker(n1, rank);
  using Event = std::pair<double, Index>;  // (finish time, leaf)
  std::priority_queue<Event, std::vector<Event>, std::greater<>> running;
  double now = 0;
  auto fill = [&] {
    while (running.size() < workers && picker.has_ready()) {
      const Index leaf = picker.pop_lowest();
      running.emplace(now + std::max(0.0, dur[leaf]), leaf);
    }
  };
  fill();
  while (!running.empty()) {
    now = running.top().first;
    while (!running.empty() && running.top().first == now) {
      picker.finish(running.top().second);
      running.pop();
    }
    fill();
  }
  return now;
}

}  // namespace

ReplayResult replay_schedule(std::span<const std::vector<Index>> n1,
                             std::span<const double> durations, std::size_t workers,
                             SchedulePolicy policy,
                             std::span<const std::vector<Index>> classes,
                             std::span<const Index> rank) {
  ReplayResult r;
  r.workers = std::max<std::size_t>(workers, 1);
  for (double d : durations) r.total_s += std::max(0.0, d);
  if (policy == SchedulePolicy::kColoured) {
    const auto own = classes.empty() ? colour_classes(n1) : std::vector<std::vector<Index>>{};
    r.makespan_s = coloured_makespan(classes.empty() ? std::span(own) : classes, durations, r.workers);
  } else {
    r.makespan_s = dynamic_makespan(n1, durations, r.workers, rank);
  }
  r.speedup = r.makespan_s > 0 ? r.total_s / r.makespan_s : 1.0;
  r.efficiency = r.speedup / static_cast<double>(r.workers);
  return r;
}

}  // namespace pdrmesh
