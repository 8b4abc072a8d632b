// SPDX-License-Identifier: AGPL-3.0-or-later
// Tests of the PDR leaf scheduler: lock table, colouring, and run_leaves under
// both policies (exclusion, exactly-once, merge order, determinism).
#include "pdrmesh/scheduler.hpp"

#include <gtest/gtest.h>

#include <chrono>

#include <thread>

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <set>

#include <oneapi/tbb/global_control.h>

#include "octree_fixtures.hpp"

namespace pdrmesh {
namespace {

using fixtures::grid_decomposition;
using fixtures::kuhn_grid;

std::vector<Index> lock_set(std::span<const std::vector<Index>> n1, Index l) {
  std::vector<Index> s = n1[l];
  s.push_back(l);
  return s;
}

/// Deterministic busy work of a leaf-dependent length (a few microseconds).
std::uint64_t spin(Index leaf) {
  std::uint64_t h = leaf + 1;
  const int rounds = 2000 + static_cast<int>((leaf * 2654435761u) % 8000u);
  for (int i = 0; i < rounds; ++i) h = h * 6364136223846793005ull + 1442695040888963407ull;
  return h;
}

std::uint64_t mix(std::uint64_t a, std::uint64_t b) {
  return (a ^ (b + 0x9e3779b97f4a7c15ull + (a << 6) + (a >> 2))) * 0xff51afd7ed558ccdull;
}

const char* name(SchedulePolicy p) { return p == SchedulePolicy::kColoured ? "coloured" : "dynamic"; }

TEST(LockTable, LocksAllOrNothing) {
  LockTable t(6);
  const std::vector<Index> a{1, 2}, b{2, 4}, c{4}, e{1};
  EXPECT_TRUE(t.try_lock(0, a));
  EXPECT_TRUE(t.locked(0) && t.locked(1) && t.locked(2));
  EXPECT_FALSE(t.locked(3) || t.locked(4) || t.locked(5));
  EXPECT_FALSE(t.try_lock(3, b));  // 2 is taken: nothing changes
  EXPECT_FALSE(t.locked(3) || t.locked(4));
  EXPECT_FALSE(t.try_lock(1, c));  // the leaf itself is taken
  EXPECT_FALSE(t.locked(4));
  EXPECT_TRUE(t.try_lock(3, c));
  EXPECT_TRUE(t.locked(3) && t.locked(4));
  t.unlock(0, a);
  EXPECT_FALSE(t.locked(0) || t.locked(1) || t.locked(2));
  EXPECT_TRUE(t.locked(3));
  EXPECT_TRUE(t.try_lock(2, e));
}

/// Checks that `classes` cover every leaf of d once, each ascending and non-empty,
/// with no two conflicting leaves (n1 ∪ n2: overlapping lock sets) in one class.
/// Returns the colour of each leaf.
std::vector<int> check_colouring(const Decomposition& d, const std::vector<std::vector<Index>>& classes) {
  std::vector<int> colour(d.size(), -1);
  for (std::size_t c = 0; c < classes.size(); ++c) {
    EXPECT_FALSE(classes[c].empty());
    EXPECT_TRUE(std::is_sorted(classes[c].begin(), classes[c].end()));
    for (Index l : classes[c]) {
      EXPECT_EQ(colour[l], -1);
      colour[l] = static_cast<int>(c);
    }
  }
  for (std::size_t l = 0; l < d.size(); ++l) {
    EXPECT_GE(colour[l], 0) << "leaf " << l;
    for (const auto* ring : {&d.n1[l], &d.n2[l]}) {
      for (Index m : *ring) EXPECT_NE(colour[m], colour[l]) << "leaves " << l << " and " << m;
    }
  }
  return colour;
}

TEST(ColourClasses, AreProperGreedyAndCoverEveryLeafOnce) {
  for (int depth : {1, 2, 3}) {
    const Decomposition d = grid_decomposition(8, depth);
    const auto classes = colour_classes(d.n1);
    const std::vector<int> colour = check_colouring(d, classes);
    for (std::size_t l = 0; l < d.size(); ++l) {
      // Greedy: every lower colour is taken by a lower conflicting leaf.
      std::set<int> lower;
      for (const auto* ring : {&d.n1[l], &d.n2[l]}) {
        for (Index m : *ring) {
          if (m < l) lower.insert(colour[m]);
        }
      }
      for (int c = 0; c < colour[l]; ++c) EXPECT_TRUE(lower.count(c)) << "leaf " << l;
    }
    // A full grid of side n >= 3 needs the 27 colours of (i, j, k) mod 3.
    const std::size_t n = std::size_t{1} << depth;
    EXPECT_EQ(classes.size(), n >= 3 ? 27u : n * n * n);
    EXPECT_EQ(check_colouring(d, colour_classes(d)), check_colouring(d, colour_classes(d)));
    EXPECT_EQ(colour_classes(d).size(), classes.size());
  }
}

TEST(ColourClasses, ResidueOrderNeedsAtMost27ColoursWhereAscendingNeedsMore) {
  // A ball of cubes: empty leaves around it make ascending greedy use > 27 colours.
  const int k = 16;
  const VolumeMesh ball = kuhn_grid(k, [&](int x, int y, int z) {
    const double r = k / 2.0, dx = x + 0.5 - r, dy = y + 0.5 - r, dz = z + 0.5 - r;
    return dx * dx + dy * dy + dz * dz <= r * r;
  });
  const Decomposition d = std::move(decompose(ball, 4)).value();
  const auto ascending = colour_classes(d.n1);
  const auto classes = colour_classes(d);
  EXPECT_GT(ascending.size(), 27u);
  EXPECT_LE(classes.size(), 27u);
  check_colouring(d, ascending);
  check_colouring(d, classes);
}

/// Runs every leaf of `d` checking exclusion, exactly-once and the merge order.
struct Probe {
  explicit Probe(const Decomposition& dd) : d(dd), claims(dd.size()), ran(dd.size()) {}
  const Decomposition& d;
  std::vector<std::atomic<int>> claims;  // per leaf: tasks whose lock set holds it
  std::vector<std::atomic<int>> ran;
  std::atomic<int> violations{0};
  std::vector<Index> merge_order;

  ScheduleStats run(std::size_t workers, SchedulePolicy policy) {
    std::function<std::uint64_t(Index)> task = [this](Index l) {
      const auto ls = lock_set(d.n1, l);
      for (Index x : ls) {
        if (claims[x].fetch_add(1) != 0) violations.fetch_add(1);
      }
      ran[l].fetch_add(1);
      const std::uint64_t h = spin(l);
      for (Index x : ls) claims[x].fetch_sub(1);
      return h;
    };
    std::function<void(Index, std::uint64_t&&)> merge = [this](Index l, std::uint64_t&& h) {
      if (h != spin(l) || ran[l].load() != 1) violations.fetch_add(1);
      merge_order.push_back(l);
    };
    return run_leaves<std::uint64_t>(d, workers, task, merge, policy);
  }
};

TEST(RunLeaves, RunsEveryLeafOnceAndNeverTwoOverlappingLockSets) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 8);
  const Decomposition d = grid_decomposition(8, 3);  // 512 leaves
  for (SchedulePolicy policy : {SchedulePolicy::kColoured, SchedulePolicy::kDynamic}) {
    for (std::size_t workers : {1u, 2u, 8u}) {
      Probe p(d);
      const ScheduleStats s = p.run(workers, policy);
      const std::string where = std::string(name(policy)) + ", " + std::to_string(workers) + " workers";
      EXPECT_EQ(p.violations.load(), 0) << where;
      EXPECT_EQ(s.tasks, d.size()) << where;
      EXPECT_EQ(s.lock_failures, 0u) << where;
      EXPECT_GE(s.max_concurrency, 1u) << where;
      EXPECT_LE(s.max_concurrency, workers) << where;
      EXPECT_EQ(s.task_s.size(), d.size()) << where;
      EXPECT_GT(s.busy_s, 0.0) << where;
      ASSERT_EQ(p.merge_order.size(), d.size()) << where;
      std::vector<Index> sorted = p.merge_order;
      std::sort(sorted.begin(), sorted.end());
      for (std::size_t l = 0; l < d.size(); ++l) {
        EXPECT_EQ(sorted[l], l) << where;
        EXPECT_EQ(p.ran[l].load(), 1) << where;
      }
      if (policy == SchedulePolicy::kColoured) {
        EXPECT_EQ(s.rounds, 27u) << where;
        // Merge order: the classes in colour order, each ascending.
        std::vector<Index> expect;
        for (const auto& c : colour_classes(d)) expect.insert(expect.end(), c.begin(), c.end());
        EXPECT_EQ(p.merge_order, expect) << where;
      } else if (workers == 1) {
        EXPECT_TRUE(std::is_sorted(p.merge_order.begin(), p.merge_order.end())) << where;
      }
    }
  }
}

/// A stand-in for refinement whose outcome depends on the neighbours' state and
/// on the global merge order: tasks read their leaf's N1 and N2, merges rewrite
/// the lock set and number their results in call order.
std::vector<std::uint64_t> coloured_simulation(const Decomposition& d, std::size_t workers) {
  std::vector<std::uint64_t> state(d.size());
  for (std::size_t l = 0; l < d.size(); ++l) state[l] = l * 0x9e3779b97f4a7c15ull;
  std::uint64_t counter = 0;
  std::function<std::uint64_t(Index)> task = [&](Index l) {
    std::uint64_t h = mix(state[l], spin(l));
    for (Index x : d.n1[l]) h = mix(h, state[x]);
    for (Index x : d.n2[l]) h = mix(h, state[x]);
    return h;
  };
  std::function<void(Index, std::uint64_t&&)> merge = [&](Index l, std::uint64_t&& h) {
    ++counter;
    for (Index x : lock_set(d.n1, l)) state[x] = mix(mix(state[x], h), counter);
  };
  run_leaves<std::uint64_t>(d, workers, task, merge, SchedulePolicy::kColoured);
  state.push_back(counter);
  return state;
}

TEST(RunLeaves, ColouredResultIsIndependentOfWorkerCount) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 8);
  const Decomposition d = grid_decomposition(8, 3);
  const auto serial = coloured_simulation(d, 1);
  for (std::size_t workers : {2u, 3u, 8u}) {
    EXPECT_EQ(coloured_simulation(d, workers), serial) << workers << " workers";
  }
  // The simulation is sensitive to order: merging the same leaves in another
  // order gives another state.
  std::vector<std::uint64_t> state(d.size());
  for (std::size_t l = 0; l < d.size(); ++l) state[l] = l * 0x9e3779b97f4a7c15ull;
  EXPECT_NE(std::vector<std::uint64_t>(serial.begin(), serial.end() - 1), state);
}

TEST(RunLeaves, AnAsymmetricN1IsCountedAndStillExclusive) {
  // Leaf 0 lists 1 as a neighbour but 1 does not list 0: the colouring puts them
  // in one class and the dynamic picker sees no conflict; the lock table refuses.
  const std::vector<std::vector<Index>> n1{{1}, {}, {3}, {2}};
  for (SchedulePolicy policy : {SchedulePolicy::kColoured, SchedulePolicy::kDynamic}) {
    std::mutex mu;
    std::vector<int> runs(n1.size(), 0), merges(n1.size(), 0);
    std::vector<std::atomic<int>> claims(n1.size());
    std::atomic<int> violations{0};
    const ScheduleStats s = run_leaf_tasks(
        n1, {}, 2, policy,
        [&](Index l) {
          const auto ls = lock_set(n1, l);
          for (Index x : ls) {
            if (claims[x].fetch_add(1) != 0) violations.fetch_add(1);
          }
          spin(l);
          for (Index x : ls) claims[x].fetch_sub(1);
          std::lock_guard lock(mu);
          ++runs[l];
        },
        [&](Index l) { ++merges[l]; });
    EXPECT_EQ(violations.load(), 0) << name(policy);
    EXPECT_EQ(runs, std::vector<int>(4, 1)) << name(policy);
    EXPECT_EQ(merges, std::vector<int>(4, 1)) << name(policy);
    if (policy == SchedulePolicy::kColoured) {
      EXPECT_EQ(s.lock_failures, 1u);  // leaf 1, in leaf 0's class
    }
  }
}

TEST(DynamicPicker, StartsTheReadyLeafOfLowestRank) {
  // A chain 0 - 1 - 2 - 3 - 4: lock sets {l-1, l, l+1}.
  const std::vector<std::vector<Index>> n1{{1}, {0, 2}, {1, 3}, {2, 4}, {3}};
  const std::vector<Index> rank{4, 3, 2, 1, 0};  // leaf 4 first
  DynamicPicker p(n1, rank);
  ASSERT_TRUE(p.has_ready());
  EXPECT_EQ(p.pop_lowest(), 4u);
  EXPECT_EQ(p.pop_lowest(), 1u);  // 3 and 2 conflict with 4 (2 shares 3); 1 is next by rank
  EXPECT_FALSE(p.has_ready());
  p.finish(4);
  EXPECT_FALSE(p.has_ready());  // 1 still holds {0, 1, 2}: 0, 2 and 3 all meet it
  p.finish(1);
  EXPECT_EQ(p.pop_lowest(), 3u);  // rank 1
  EXPECT_EQ(p.pop_lowest(), 0u);  // {0, 1} misses {2, 3, 4}; 2 does not
  EXPECT_FALSE(p.has_ready());
  p.finish(3);
  p.finish(0);
  EXPECT_EQ(p.pop_lowest(), 2u);
  EXPECT_FALSE(p.has_ready());
}

TEST(RunLeaves, DynamicMergesOnTheCallingThreadWithAllWorkersBusy) {
  const Decomposition d = grid_decomposition(8, 3);
  const auto caller = std::this_thread::get_id();
  std::atomic<int> off_thread{0};
  std::mutex mu;
  std::set<std::thread::id> task_threads;
  const ScheduleStats s = run_leaf_tasks(
      d.n1, {}, 4, SchedulePolicy::kDynamic,
      [&](Index l) {
        spin(l);
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        std::lock_guard lock(mu);
        task_threads.insert(std::this_thread::get_id());
      },
      [&](Index) {
        if (std::this_thread::get_id() != caller) off_thread.fetch_add(1);
      });
  EXPECT_EQ(off_thread.load(), 0);
  EXPECT_EQ(task_threads.size(), 4u);  // exactly `workers` threads, none of them the caller
  EXPECT_EQ(task_threads.count(caller), 0u);
  EXPECT_GE(s.max_concurrency, 2u);
  EXPECT_LE(s.max_concurrency, 4u);
}

TEST(RunLeaves, DynamicStartsMoreThreadsWhenTheConcurrencyGrows) {
  const Decomposition d = grid_decomposition(8, 3);  // 512 leaves
  std::atomic<int> asked{0};
  std::atomic<int> running{0}, most_at_first{0}, violations{0};
  std::vector<std::atomic<int>> claims(d.size());
  std::mutex mu;
  std::set<std::thread::id> task_threads;
  std::atomic<int> ran{0};
  // One task at a time for the first 40 hand-outs, then four.
  const auto concurrency = [&]() -> std::size_t { return asked.fetch_add(1) < 40 ? 1 : 4; };
  const ScheduleStats s = run_leaf_tasks(
      d.n1, {}, 1, SchedulePolicy::kDynamic,
      [&](Index l) {
        const auto ls = lock_set(d.n1, l);
        for (Index x : ls)
          if (claims[x].fetch_add(1) != 0) violations.fetch_add(1);
        const int now = running.fetch_add(1) + 1;
        if (ran.load() < 30) most_at_first.store(std::max(most_at_first.load(), now));
        spin(l);
        std::this_thread::sleep_for(std::chrono::microseconds(200));
        {
          std::lock_guard lock(mu);
          task_threads.insert(std::this_thread::get_id());
        }
        running.fetch_sub(1);
        ran.fetch_add(1);
        for (Index x : ls) claims[x].fetch_sub(1);
      },
      [](Index) {}, {}, concurrency);
  EXPECT_EQ(s.tasks, d.size());
  EXPECT_EQ(ran.load(), static_cast<int>(d.size()));
  EXPECT_EQ(violations.load(), 0);
  EXPECT_EQ(most_at_first.load(), 1);  // while it was told 1
  EXPECT_EQ(task_threads.size(), 4u);  // grown to 4 threads
  EXPECT_GE(s.max_concurrency, 2u);
  EXPECT_LE(s.max_concurrency, 4u);
}

TEST(RunLeaves, HandlesNoLeavesAndZeroWorkers) {
  const std::vector<std::vector<Index>> none;
  const ScheduleStats s = run_leaf_tasks(none, {}, 0, SchedulePolicy::kDynamic, [](Index) {}, [](Index) {});
  EXPECT_EQ(s.tasks, 0u);
  const std::vector<std::vector<Index>> one{{}};
  int calls = 0;
  const ScheduleStats s1 = run_leaf_tasks(one, {}, 0, SchedulePolicy::kColoured, [&](Index) { ++calls; },
                                          [&](Index) { ++calls; });
  EXPECT_EQ(calls, 2);
  EXPECT_EQ(s1.max_concurrency, 1u);
}

}  // namespace
}  // namespace pdrmesh
