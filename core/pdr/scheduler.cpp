// SPDX-License-Identifier: AGPL-3.0-or-later
// PDR leaf scheduling on oneTBB: lock table, colouring, dynamic picking and the
// type-erased engine behind run_leaves (see scheduler.hpp).
#include "pdrmesh/scheduler.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <thread>

#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include "pdrmesh/atomic_extremum.hpp"
#include "pdrmesh/stopwatch.hpp"

namespace pdrmesh {

LockTable::LockTable(std::size_t leaves) : locked_(leaves, 0) {}

bool LockTable::try_lock(Index leaf, std::span<const Index> n1) {
  std::lock_guard lock(mu_);
  if (locked_[leaf]) return false;
  for (Index m : n1) {
    if (locked_[m]) return false;
  }
  locked_[leaf] = 1;
  for (Index m : n1) locked_[m] = 1;
  return true;
}

void LockTable::unlock(Index leaf, std::span<const Index> n1) {
  std::lock_guard lock(mu_);
  locked_[leaf] = 0;
  for (Index m : n1) locked_[m] = 0;
}

bool LockTable::locked(Index leaf) const {
  std::lock_guard lock(mu_);
  return locked_[leaf] != 0;
}

std::vector<std::vector<Index>> colour_classes(std::span<const std::vector<Index>> n1,
                                               std::span<const Index> order) {
  const std::size_t nl = n1.size();
  constexpr std::size_t kNone = ~std::size_t{0};
  std::vector<std::size_t> colour(nl, kNone);
  std::vector<std::vector<Index>> classes;
  std::vector<unsigned char> used;
  for (std::size_t i = 0; i < nl; ++i) {
    const Index l = order.empty() ? static_cast<Index>(i) : order[i];
    used.assign(classes.size() + 1, 0);
    auto visit = [&](Index m) {
      if (m != l && colour[m] != kNone) used[colour[m]] = 1;
    };
    for (Index x : n1[l]) {  // the lock sets {x} ∪ N1(x) that hold l
      visit(x);
      for (Index m : n1[x]) visit(m);
    }
    const std::size_t c =
        static_cast<std::size_t>(std::find(used.begin(), used.end(), 0) - used.begin());
    colour[l] = c;
    if (c == classes.size()) classes.emplace_back();
    classes[c].push_back(l);
  }
  for (auto& cls : classes) std::sort(cls.begin(), cls.end());
  return classes;
}

std::vector<std::vector<Index>> colour_classes(const Decomposition& d) {
  std::vector<std::pair<std::uint32_t, Index>> keyed(d.size());
  for (std::size_t l = 0; l < d.size(); ++l) {
    const auto c = leaf_coords(d.leaves[l], d.depth);
    keyed[l] = {c[0] % 3 + 3 * (c[1] % 3 + 3 * (c[2] % 3)), static_cast<Index>(l)};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<Index> order(d.size());
  for (std::size_t i = 0; i < keyed.size(); ++i) order[i] = keyed[i].second;
  return colour_classes(d.n1, order);
}

DynamicPicker::DynamicPicker(std::span<const std::vector<Index>> n1, std::span<const Index> rank)
    : n1_(n1), rank_(n1.size()), blocked_(n1.size(), 0), started_(n1.size(), 0) {
  for (std::size_t l = 0; l < n1.size(); ++l) {
    rank_[l] = l < rank.size() ? rank[l] : static_cast<Index>(l);
    ready_.emplace(rank_[l], static_cast<Index>(l));
  }
}

void DynamicPicker::adjust(Index leaf, int delta) {
  // Taking x blocks every leaf whose lock set holds x: x itself and N1(x).
  auto touch = [&](Index m) {
    if (delta > 0) {
      ++blocked_[m];
    } else if (--blocked_[m] == 0 && !started_[m]) {
      ready_.emplace(rank_[m], m);
    }
  };
  auto take = [&](Index x) {
    touch(x);
    for (Index m : n1_[x]) touch(m);
  };
  take(leaf);
  for (Index x : n1_[leaf]) take(x);
}

bool DynamicPicker::has_ready() {
  while (!ready_.empty() && (started_[ready_.top().second] || blocked_[ready_.top().second] != 0)) ready_.pop();
  return !ready_.empty();
}

Index DynamicPicker::pop_lowest() {
  has_ready();
  const Index leaf = ready_.top().second;
  ready_.pop();
  started_[leaf] = 1;
  adjust(leaf, +1);
  return leaf;
}

void DynamicPicker::finish(Index leaf) { adjust(leaf, -1); }

namespace {

using Clock = std::chrono::steady_clock;

/// Runs tasks with timing and concurrency accounting.
class Instrument {
 public:
  Instrument(std::size_t leaves, const std::function<void(Index)>& run)
      : run_(run), task_s_(leaves, 0.0) {}

  void operator()(Index leaf) {
    const std::size_t now = running_.fetch_add(1) + 1;
    detail::atomic_raise(max_, now);
    const auto t0 = Clock::now();
    run_(leaf);
    task_s_[leaf] = seconds_since(t0);
    running_.fetch_sub(1);
  }

  void fill(ScheduleStats& s, double wall) {
    s.tasks = task_s_.size();
    s.wall_s = wall;
    s.busy_s = 0;
    for (double t : task_s_) s.busy_s += t;
    s.max_concurrency = max_.load();
    s.mean_concurrency = wall > 0 ? s.busy_s / wall : 0.0;
    s.task_s = std::move(task_s_);
  }

 private:
  const std::function<void(Index)>& run_;
  std::vector<double> task_s_;
  std::atomic<std::size_t> running_{0};
  std::atomic<std::size_t> max_{0};
};

/// A leaf whose lock failed runs here, alone, once everything else is idle.
void run_alone(Index leaf, std::span<const Index> n1, LockTable& locks, Instrument& inst,
               const std::function<void(Index)>& commit) {
  [[maybe_unused]] const bool ok = locks.try_lock(leaf, n1);  // nothing else is locked now
  inst(leaf);
  commit(leaf);
  locks.unlock(leaf, n1);
}

/// kDynamic: `workers` threads (or as many as `concurrency` says, asked at
/// each hand-out) run the tasks the calling thread hands them; the calling
/// thread merges each finished one, unlocks it and hands out what became
/// ready. Leaves whose lock fails (an asymmetric n1) go to `postponed`.
void run_dynamic(std::span<const std::vector<Index>> n1, std::size_t workers,
                 const std::function<std::size_t()>& concurrency, LockTable& locks, Instrument& inst,
                 const std::function<void(Index)>& commit, std::span<const Index> rank,
                 std::vector<Index>& postponed) {
  DynamicPicker picker(n1, rank);
  std::mutex mu;  // guards jobs, done, quit
  std::condition_variable work_cv, done_cv;
  std::deque<Index> jobs;
  std::vector<Index> done;
  bool quit = false;
  std::vector<std::thread> pool;
  const auto serve = [&] {
    std::unique_lock lock(mu);
    for (;;) {
      work_cv.wait(lock, [&] { return quit || !jobs.empty(); });
      if (jobs.empty()) return;
      const Index leaf = jobs.front();
      jobs.pop_front();
      lock.unlock();
      inst(leaf);
      lock.lock();
      done.push_back(leaf);
      done_cv.notify_one();
    }
  };
  std::size_t in_flight = 0;
  auto launch = [&] {
    const std::size_t cap = concurrency ? std::max<std::size_t>(concurrency(), 1) : workers;
    while (pool.size() < cap) pool.emplace_back(serve);
    while (in_flight < cap && picker.has_ready()) {
      const Index leaf = picker.pop_lowest();
      if (!locks.try_lock(leaf, n1[leaf])) {
        picker.finish(leaf);
        postponed.push_back(leaf);
        continue;
      }
      ++in_flight;
      {
        std::lock_guard lock(mu);
        jobs.push_back(leaf);
      }
      work_cv.notify_one();
    }
  };
  launch();
  std::vector<Index> finished;
  while (in_flight > 0) {
    {
      std::unique_lock lock(mu);
      done_cv.wait(lock, [&] { return !done.empty(); });
      finished.swap(done);
    }
    for (Index leaf : finished) {
      commit(leaf);
      locks.unlock(leaf, n1[leaf]);
      picker.finish(leaf);
      --in_flight;
    }
    finished.clear();
    launch();
  }
  {
    std::lock_guard lock(mu);
    quit = true;
  }
  work_cv.notify_all();
  for (std::thread& t : pool) t.join();
}

}  // namespace

ScheduleStats run_leaf_tasks(std::span<const std::vector<Index>> n1,
                             std::span<const std::vector<Index>> classes, std::size_t workers,
                             SchedulePolicy policy, const std::function<void(Index)>& run,
                             const std::function<void(Index)>& commit, std::span<const Index> rank,
                             const std::function<std::size_t()>& concurrency) {
  workers = std::max<std::size_t>(workers, 1);
  const std::size_t nl = n1.size();
  ScheduleStats stats;
  LockTable locks(nl);
  Instrument inst(nl, run);
  std::vector<Index> postponed;
  const auto t0 = Clock::now();

  if (policy == SchedulePolicy::kColoured) {
    if (concurrency) workers = std::max<std::size_t>(concurrency(), 1);
    tbb::task_arena arena(static_cast<int>(workers));
    std::vector<std::vector<Index>> own;
    if (classes.empty()) {
      own = colour_classes(n1);
      classes = own;
    }
    for (const std::vector<Index>& cls : classes) {
      std::vector<Index> batch;
      batch.reserve(cls.size());
      for (Index leaf : cls) {
        if (locks.try_lock(leaf, n1[leaf])) {
          batch.push_back(leaf);
        } else {
          postponed.push_back(leaf);
        }
      }
      arena.execute([&] {
        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(0, batch.size(), 1),
            [&](const tbb::blocked_range<std::size_t>& r) {
              for (std::size_t i = r.begin(); i != r.end(); ++i) inst(batch[i]);
            },
            tbb::simple_partitioner());
      });
      for (Index leaf : batch) {
        commit(leaf);
        locks.unlock(leaf, n1[leaf]);
      }
      ++stats.rounds;
      stats.lock_failures += postponed.size();
      for (Index leaf : postponed) run_alone(leaf, n1[leaf], locks, inst, commit);
      postponed.clear();
    }
  } else {
    run_dynamic(n1, workers, concurrency, locks, inst, commit, rank, postponed);
    stats.lock_failures = postponed.size();
    std::sort(postponed.begin(), postponed.end());
    for (Index leaf : postponed) run_alone(leaf, n1[leaf], locks, inst, commit);
  }
  inst.fill(stats, seconds_since(t0));
  return stats;
}

}  // namespace pdrmesh
