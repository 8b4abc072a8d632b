// SPDX-License-Identifier: AGPL-3.0-or-later
// Union-find over [0, n) whose roots are deterministic: the smallest index of
// each set (used by the surface check's components and the PDR fix-ups).
#pragma once

#include <algorithm>
#include <cstddef>
#include <numeric>
#include <utility>
#include <vector>

#include "pdrmesh/types.hpp"

namespace pdrmesh {

class UnionFind {
 public:
  explicit UnionFind(std::size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), Index{0}); }
  Index find(Index x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  void unite(Index a, Index b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (a < b) std::swap(a, b);
    parent_[a] = b;  // the smaller index is the root
  }

 private:
  std::vector<Index> parent_;
};

}  // namespace pdrmesh
