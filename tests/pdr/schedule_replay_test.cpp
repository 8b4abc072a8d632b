// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the schedule replay (projected makespan and speedup on P workers).
#include "pdrmesh/schedule_replay.hpp"

#include <gtest/gtest.h>

#include <random>

#include "octree_fixtures.hpp"

namespace pdrmesh {
namespace {

using fixtures::grid_decomposition;
std::vector<double> seeded_durations(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::lognormal_distribution<double> dist(0.0, 1.0);
  std::vector<double> d(n);
  for (double& x : d) x = dist(rng);
  return d;
}

constexpr SchedulePolicy kPolicies[] = {SchedulePolicy::kColoured, SchedulePolicy::kDynamic};

TEST(ScheduleReplay, OneWorkerRunsEverythingBackToBack) {
  const Decomposition d = grid_decomposition(8, 3);
  const auto dur = seeded_durations(d.size(), 7);
  for (SchedulePolicy p : kPolicies) {
    const ReplayResult r = replay_schedule(d.n1, dur, 1, p);
    EXPECT_NEAR(r.makespan_s, r.total_s, 1e-9 * r.total_s);
    EXPECT_NEAR(r.speedup, 1.0, 1e-9);
    EXPECT_NEAR(r.efficiency, 1.0, 1e-9);
  }
}

TEST(ScheduleReplay, EqualDurationsOnAFullGridMeetTheExpectedBounds) {
  for (int depth : {3, 4}) {
    const Decomposition d = grid_decomposition(16, depth);
    const std::size_t n = std::size_t{1} << depth;
    ASSERT_EQ(d.size(), n * n * n);
    const std::vector<double> dur(d.size(), 1.0);
    const auto classes = colour_classes(d.n1);
    // At most ceil(n/3)^3 leaves can hold their lock sets at once.
    const double independent = std::pow(static_cast<double>((n + 2) / 3), 3.0);
    for (std::size_t workers : {1u, 2u, 4u, 16u, 64u, 1024u}) {
      double coloured = 0;  // unit tasks: class c takes ceil(|c| / P) steps
      for (const auto& c : classes) coloured += static_cast<double>((c.size() + workers - 1) / workers);
      const ReplayResult rc = replay_schedule(d.n1, dur, workers, SchedulePolicy::kColoured);
      EXPECT_DOUBLE_EQ(rc.makespan_s, coloured) << "depth " << depth << ", P = " << workers;
      for (SchedulePolicy p : kPolicies) {
        const ReplayResult r = replay_schedule(d.n1, dur, workers, p);
        EXPECT_DOUBLE_EQ(r.total_s, static_cast<double>(d.size()));
        EXPECT_LE(r.speedup, std::min(static_cast<double>(workers), independent) + 1e-9);
        EXPECT_GE(r.makespan_s, std::ceil(r.total_s / static_cast<double>(workers)) - 1e-9);
      }
    }
    // With a worker per leaf the coloured schedule takes one step per colour.
    EXPECT_DOUBLE_EQ(replay_schedule(d.n1, dur, d.size(), SchedulePolicy::kColoured).makespan_s, 27.0);
  }
}

TEST(ScheduleReplay, MakespanNeverGrowsWithMoreWorkersOnEqualTasks) {
  const Decomposition d = grid_decomposition(16, 4);
  const std::vector<double> dur(d.size(), 0.5);
  for (SchedulePolicy p : kPolicies) {
    double last = std::numeric_limits<double>::infinity();
    for (std::size_t workers = 1; workers <= 1024; workers *= 2) {
      const ReplayResult r = replay_schedule(d.n1, dur, workers, p);
      EXPECT_LE(r.makespan_s, last) << "P = " << workers;
      last = r.makespan_s;
    }
  }
}

TEST(ScheduleReplay, IsDeterministicAndIgnoresNegativeDurations) {
  const Decomposition d = grid_decomposition(8, 3);
  auto dur = seeded_durations(d.size(), 11);
  for (SchedulePolicy p : kPolicies) {
    const ReplayResult a = replay_schedule(d.n1, dur, 16, p);
    const ReplayResult b = replay_schedule(d.n1, dur, 16, p);
    EXPECT_EQ(a.makespan_s, b.makespan_s);
    EXPECT_GT(a.speedup, 1.0);
    EXPECT_LE(a.speedup, 16.0);
  }
  dur[0] = -5.0;
  const ReplayResult r = replay_schedule(d.n1, dur, 1, SchedulePolicy::kDynamic);
  EXPECT_NEAR(r.makespan_s, r.total_s, 1e-9 * r.total_s);
  const std::vector<double> zero(d.size(), 0.0);
  EXPECT_EQ(replay_schedule(d.n1, zero, 4, SchedulePolicy::kColoured).speedup, 1.0);
}

}  // namespace
}  // namespace pdrmesh
