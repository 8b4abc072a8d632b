// SPDX-License-Identifier: AGPL-3.0-or-later
// Construction of the Morton-ordered bounding-volume hierarchy (bvh.hpp).
#include "pdrmesh/bvh.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cstdint>
#include <utility>

namespace pdrmesh::detail {
namespace {

Box merge(const Box& a, const Box& b) {
  Box m;
  for (int k = 0; k < 3; ++k) {
    m.lo[k] = std::min(a.lo[k], b.lo[k]);
    m.hi[k] = std::max(a.hi[k], b.hi[k]);
  }
  return m;
}

}  // namespace

BoxTree::BoxTree(const std::vector<Box>& boxes, const std::vector<Index>& ids) {
  const std::size_t n = boxes.size();
  if (n == 0) return;
  Box all;
  for (const Box& b : boxes) all = merge(all, b);

  // Morton code of every box centre, quantised to 21 bits per axis.
  std::vector<std::pair<std::uint64_t, Index>> keys(n);
  const double scale = double((1u << 21) - 1);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    std::uint64_t code = 0;
    for (int k = 0; k < 3; ++k) {
      const double extent = all.hi[k] - all.lo[k];
      const double c = 0.5 * (boxes[i].lo[k] + boxes[i].hi[k]);
      double t = extent > 0 ? (c - all.lo[k]) / extent : 0.0;
      t = std::clamp(t, 0.0, 1.0);
      code |= spread_bits(static_cast<std::uint64_t>(t * scale)) << k;
    }
    keys[i] = {code, static_cast<Index>(i)};
  });
  // Keys are unique (the position breaks ties), so the order is deterministic.
  tbb::parallel_sort(keys.begin(), keys.end());

  ids_.resize(n);
  boxes_.resize(n);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t k) {
    ids_[k] = ids[keys[k].second];
    boxes_[k] = boxes[keys[k].second];
  });

  const std::size_t leaves = (n + kLeafSize - 1) / kLeafSize;
  leaf_base_ = 1;
  while (leaf_base_ < leaves) leaf_base_ *= 2;
  nodes_.assign(2 * leaf_base_, Box{});
  tbb::parallel_for(std::size_t{0}, leaves, [&](std::size_t leaf) {
    Box b;
    const std::size_t last = std::min(n, (leaf + 1) * kLeafSize);
    for (std::size_t k = leaf * kLeafSize; k < last; ++k) b = merge(b, boxes_[k]);
    nodes_[leaf_base_ + leaf] = b;
  });
  for (std::size_t level = leaf_base_ / 2; level >= 1; level /= 2) {
    tbb::parallel_for(level, 2 * level, [&](std::size_t node) {
      nodes_[node] = merge(nodes_[2 * node], nodes_[2 * node + 1]);
    });
  }
}

}  // namespace pdrmesh::detail
