// SPDX-License-Identifier: AGPL-3.0-or-later
// The passes' point moves (smoothing, angle, margin and size polish), one point after
// another or side by side on the calling task arena's threads with the same result.
#pragma once

#include <oneapi/tbb/enumerable_thread_specific.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <optional>
#include <span>
#include <vector>

#include "optimizer.hpp"

namespace pdrmesh::optimize_detail {

/// A pass's moves over the points `todo`, in order: a point that failed
/// `kind` before, with nothing changed around it, is skipped; the others go
/// to move(opt, v, start), which may move v (move_point, from the star walk
/// at `start`) and returns the outcome, counted in the stats when `tallied`.
/// A failure is remembered; after a move, after(opt, out) appends to `out`
/// what the pass wants of the moved point's star (opt.star_). `opt` is this
/// optimizer or one of its hands. Returns the moves.
///
/// With parallel_moves, on a large enough list and more than one thread, the
/// moves run side by side by deterministic reservations. Each window takes
/// the points an earlier window left, then the next ones in order; every
/// point claims its footprint (itself and its link points: all that a move
/// reads or writes) with its place in the window, and a point that holds its
/// whole footprint moves, in a hand (Optimizer's second constructor), while
/// the others wait for the next window. A point that moves shares no
/// footprint point with any point before it in the window, so none of them
/// changes what it reads or reads what it changes, and its outcome is the one
/// it gets in order. The holder then takes the outcomes in window order
/// (tallies, failures, touches, after's results). Points whose footprints
/// meet take their turns in todo's order, so every comparison of the work
/// queue's clock comes out as in order, and the mesh is the same, bit for
/// bit, for any thread count. (The stars do not change during a pass: moves
/// keep the topology.)
template <class Move, class After>
std::size_t Optimizer::move_points(std::span<const Index> todo, Attempt kind, bool tallied, Move&& move,
                                   After&& after, std::vector<Index>& out) {
  std::size_t moved = 0;
  const auto finish = [&](Index v, Outcome o) {
    if (tallied) tally(LocalOperation::kMove, o);
    if (o == Outcome::kDone) {
      ++moved;
      return true;
    }
    remember_failure(kind, v);
    return false;
  };
  const std::size_t threads = static_cast<std::size_t>(tbb::this_task_arena::max_concurrency());
  if (!o_.parallel_moves || todo.size() < kParallelMovesMin || threads < 2) {
    for (Index v : todo) {
      if (failed_before(kind, v)) continue;
      if (finish(v, move(*this, v, first_tet(v)))) after(*this, out);
    }
    return moved;
  }

  // What the hands read and never grow: a badness per slot, a tet per point.
  if (s_.known.size() < m_.num_slots()) s_.known.resize(m_.num_slots(), 0);
  (void)any_tet(todo.front());
  if (claims_.size() < m_.num_points()) claims_.resize(m_.num_points(), kNoIndex);
  struct Hand {
    OptimizeStats stats;  // unused: the holder tallies
    MoveNote note;
    std::optional<Optimizer> opt;
  };
  tbb::enumerable_thread_specific<Hand> hands;
  const auto hand = [&]() -> Optimizer& {
    Hand& h = hands.local();
    if (!h.opt) h.opt.emplace(*this, h.stats, h.note);
    return *h.opt;
  };
  struct Item {
    Index start = kNoIndex;      ///< kNoIndex until its footprint is known
    std::vector<Index> footprint;
    bool holds = false;    ///< held its whole footprint in the last window
    bool skipped = false;  ///< failed before: not tried
    Outcome outcome = Outcome::kNotBetter;
    MoveNote note;
    std::vector<Index> after;  ///< after's results
  };
  std::vector<Item> items(todo.size());
  const std::size_t width = kMovesPerThread * threads;
  std::vector<std::size_t> window, waiting;  // places in todo
  std::size_t fresh = 0;
  while (!waiting.empty() || fresh < todo.size()) {
    ++st_.move_windows;
    window.assign(waiting.begin(), waiting.end());
    while (window.size() < width && fresh < todo.size()) window.push_back(fresh++);
    tbb::parallel_for(std::size_t{0}, window.size(), [&](std::size_t i) {
      Item& it = items[window[i]];
      const Index v = todo[window[i]];
      if (it.start == kNoIndex) {
        Optimizer& h = hand();
        it.start = h.first_tet(v);
        for (Index t : h.walk_) it.footprint.insert(it.footprint.end(), m_.tet(t).begin(), m_.tet(t).end());
        sort_unique(it.footprint);
      }
      for (Index u : it.footprint) {
        std::atomic_ref<Index> claim(claims_[u]);
        Index held = claim.load(std::memory_order_relaxed);
        while (i < held && !claim.compare_exchange_weak(held, static_cast<Index>(i), std::memory_order_relaxed)) {
        }
      }
    });
    tbb::parallel_for(std::size_t{0}, window.size(), [&](std::size_t i) {
      Item& it = items[window[i]];
      const Index v = todo[window[i]];
      it.holds = std::all_of(it.footprint.begin(), it.footprint.end(), [&](Index u) {
        return std::atomic_ref<Index>(claims_[u]).load(std::memory_order_relaxed) == i;
      });
      if (!it.holds) return;
      Optimizer& h = hand();
      it.skipped = h.failed_before(kind, v);
      if (it.skipped) return;
      it.outcome = move(h, v, it.start);
      if (it.outcome != Outcome::kDone) return;
      it.note.point = h.note_->point;
      it.note.tets.assign(h.note_->tets.begin(), h.note_->tets.end());
      it.after.clear();
      after(h, it.after);
    });
    waiting.clear();
    for (std::size_t place : window) {
      Item& it = items[place];
      for (Index u : it.footprint) claims_[u] = kNoIndex;
      if (!it.holds) {
        waiting.push_back(place);
        continue;
      }
      if (it.skipped || !finish(todo[place], it.outcome)) continue;
      note_moved(it.note);
      out.insert(out.end(), it.after.begin(), it.after.end());
    }
  }
  return moved;
}

}  // namespace pdrmesh::optimize_detail
