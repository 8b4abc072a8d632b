// SPDX-License-Identifier: AGPL-3.0-or-later
// A bounding-volume hierarchy over axis-aligned boxes (internal to core).
//
// Items are sorted along a Morton curve of their box centres, grouped four to a
// leaf, and an implicit complete binary tree (heap layout) is built over the
// leaves bottom-up. Box overlap is tested with <= on every axis, so a query
// reports every item whose box touches the query box: candidate sets are
// complete, never approximate. Building is parallel and deterministic.
#pragma once

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "pdrmesh/types.hpp"

namespace pdrmesh::detail {

/// Spreads the low 21 bits of x so that two zero bits separate consecutive
/// ones: one axis of a 63-bit Morton code (also the refiner's tet order).
inline std::uint64_t spread_bits(std::uint64_t x) {
  x &= 0x1fffffULL;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

/// Closed boxes touch or overlap (compared with <=). Empty boxes touch nothing.
inline bool boxes_touch(const Box& a, const Box& b) {
  return a.lo[0] <= b.hi[0] && b.lo[0] <= a.hi[0] && a.lo[1] <= b.hi[1] && b.lo[1] <= a.hi[1] &&
         a.lo[2] <= b.hi[2] && b.lo[2] <= a.hi[2];
}

inline Box box_of(const Vec3& a, const Vec3& b) {
  Box x;
  x.add(a);
  x.add(b);
  return x;
}

inline Box box_of(const Vec3& a, const Vec3& b, const Vec3& c) {
  Box x = box_of(a, b);
  x.add(c);
  return x;
}

class BoxTree {
 public:
  BoxTree() = default;
  /// `ids[i]` is the caller's id of the item with box `boxes[i]`; boxes must be finite.
  BoxTree(const std::vector<Box>& boxes, const std::vector<Index>& ids);

  std::size_t size() const { return ids_.size(); }
  /// The items in tree order (Morton order): position k holds id(k) with box(k).
  Index id(std::size_t k) const { return ids_[k]; }
  const Box& box(std::size_t k) const { return boxes_[k]; }
  /// The box of everything (empty when there are no items).
  const Box& bounds() const { return nodes_.size() > 1 ? nodes_[1] : empty_; }

  /// Calls visit(position k) for every item at position k >= `from` whose box
  /// touches `query` (subtrees wholly before `from` are not entered).
  template <class Visit>
  void query(const Box& query, Visit&& visit, std::size_t from = 0) const {
    if (ids_.empty()) return;
    const int height = static_cast<int>(std::bit_width(leaf_base_)) - 1;
    std::size_t stack[64];
    int top = 0;
    stack[top++] = 1;
    while (top > 0) {
      const std::size_t node = stack[--top];
      // The items below `node` end before position `last`.
      const int depth = static_cast<int>(std::bit_width(node)) - 1;
      const std::size_t last = (node - (std::size_t{1} << depth) + 1)
                               << (height - depth) << kLeafShift;
      if (last <= from || !boxes_touch(nodes_[node], query)) continue;
      if (node >= leaf_base_) {
        const std::size_t first = std::max(from, (node - leaf_base_) << kLeafShift);
        const std::size_t end = std::min(last, ids_.size());
        for (std::size_t k = first; k < end; ++k)
          if (boxes_touch(boxes_[k], query)) visit(k);
      } else {
        stack[top++] = 2 * node + 1;
        stack[top++] = 2 * node;
      }
    }
  }

 private:
  static constexpr int kLeafShift = 2;
  static constexpr std::size_t kLeafSize = std::size_t{1} << kLeafShift;
  std::vector<Index> ids_;
  std::vector<Box> boxes_;
  std::vector<Box> nodes_;  ///< heap layout: root 1, children 2i and 2i+1, leaves from leaf_base_
  std::size_t leaf_base_ = 1;
  Box empty_;
};

}  // namespace pdrmesh::detail
