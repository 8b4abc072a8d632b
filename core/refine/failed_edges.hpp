// SPDX-License-Identifier: AGPL-3.0-or-later
// The refiner's memory of failed edge removals (refine.cpp's reconnection),
// private to core/refine.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "pdrmesh/tet_mesh.hpp"
#include "pdrmesh/types.hpp"

namespace pdrmesh::refine_detail {

/// Edges whose removal failed during one deferred reconnection loop. A failed
/// removal depends only on the tets around the edge (the ring's triangulations
/// are the same from whichever ring tet it is tried), and a flip that changes
/// those tets has both ends of the edge among its vertices; so a failure stays
/// valid while one end has not been touched by a flip since. Open addressing,
/// cleared per loop; no allocation once grown.
class FailedEdges {
 public:
  void clear(Index points) {
    if (touched_.size() < points) touched_.resize(points, 0);
    std::fill(touched_.begin(), touched_.end(), 0u);
    clock_ = 0;
    if (slots_.empty()) slots_.resize(1024);
    std::fill(slots_.begin(), slots_.end(), Slot{});
    count_ = 0;
  }

  /// True when the removal of edge (a, b) failed and neither end changed since.
  bool known(Index a, Index b) const {
    const std::uint64_t key = edge_key(a, b);
    for (std::size_t h = hash(key);; h = (h + 1) & (slots_.size() - 1)) {
      const Slot& s = slots_[h];
      if (s.key == kEmptyKey) return false;
      if (s.key == key) return std::min(touched_[a], touched_[b]) <= s.time;
    }
  }

  /// Asks the cache for the slot where known(a, b) starts (a hint only).
  void prefetch(Index a, Index b) const { __builtin_prefetch(&slots_[hash(edge_key(a, b))]); }

  void add(Index a, Index b) {
    if (2 * (count_ + 1) > slots_.size()) grow();
    insert(edge_key(a, b), clock_);
  }

  /// Records a flip that created the tets `created`.
  void touch(const TetMesh& m, std::span<const Index> created) {
    ++clock_;
    for (const Index t : created)
      for (const Index v : m.tet(t)) touched_[v] = clock_;
  }

 private:
  static constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};
  struct Slot {
    std::uint64_t key = kEmptyKey;
    std::uint32_t time = 0;
  };
  static std::uint64_t edge_key(Index a, Index b) {
    return a < b ? (std::uint64_t{a} << 32) | b : (std::uint64_t{b} << 32) | a;
  }
  std::size_t hash(std::uint64_t key) const {
    key *= 0x9E3779B97F4A7C15ull;
    return static_cast<std::size_t>(key ^ (key >> 31)) & (slots_.size() - 1);
  }
  void insert(std::uint64_t key, std::uint32_t time) {
    for (std::size_t h = hash(key);; h = (h + 1) & (slots_.size() - 1)) {
      Slot& s = slots_[h];
      if (s.key == key) {
        s.time = time;
        return;
      }
      if (s.key == kEmptyKey) {
        s = {key, time};
        ++count_;
        return;
      }
    }
  }
  void grow() {
    std::vector<Slot> old(2 * slots_.size());
    old.swap(slots_);
    count_ = 0;
    for (const Slot& s : old)
      if (s.key != kEmptyKey) insert(s.key, s.time);
  }

  std::vector<std::uint32_t> touched_;  ///< per point: the clock of the last flip touching it
  std::uint32_t clock_ = 0;             ///< flips so far in this loop
  std::vector<Slot> slots_;
  std::size_t count_ = 0;
};

}  // namespace pdrmesh::refine_detail
