// SPDX-License-Identifier: AGPL-3.0-or-later
// The deterministic parallel building blocks give what their serial loops give.
#include "pdrmesh/fixed_chunks.hpp"

#include <gtest/gtest.h>

#include <utility>
#include <vector>

#include "octree_fixtures.hpp"

namespace pdrmesh {
namespace {

// Over many chunks (n = 10,007, grain 64), the kept indices come out
// ascending and exactly those of a serial filter.
TEST(FixedChunks, FilterIndicesIsTheSerialFilter) {
  const std::size_t n = 10007;
  const auto keep = [](std::size_t i) { return (i * 2654435761u) % 7 < 3; };
  std::vector<Index> serial;
  for (std::size_t i = 0; i < n; ++i)
    if (keep(i)) serial.push_back(static_cast<Index>(i));
  ASSERT_GT(serial.size(), n / 4);
  EXPECT_EQ(detail::filter_indices(n, 64, keep), serial);
  EXPECT_TRUE(detail::filter_indices(0, 64, keep).empty());
  EXPECT_TRUE(detail::filter_indices(n, 64, [](std::size_t) { return false; }).empty());
}

// A counting sort into buckets, each sorted afterwards, is the serial grouping.
TEST(FixedChunks, SortedBucketsAreTheSerialGrouping) {
  const std::size_t n = 20000, keys = 37;
  const auto key = [](std::size_t i) { return static_cast<Index>((i * 40503u) % keys); };
  auto b = detail::bucket_items<Index>(n, keys, 128, [&](std::size_t i, auto&& emit) {
    if (i % 5 != 0) emit(key(i), static_cast<Index>(i));
  });
  detail::sort_buckets(b, std::less<Index>());
  std::vector<std::vector<Index>> serial(keys);
  for (std::size_t i = 0; i < n; ++i)
    if (i % 5 != 0) serial[key(i)].push_back(static_cast<Index>(i));
  ASSERT_EQ(b.first.size(), keys + 1);
  for (std::size_t k = 0; k < keys; ++k) {
    const std::vector<Index> got(b.items.begin() + static_cast<std::ptrdiff_t>(b.first[k]),
                                 b.items.begin() + static_cast<std::ptrdiff_t>(b.first[k + 1]));
    EXPECT_EQ(got, serial[k]) << "bucket " << k;
  }
}

// The stable counting sort groups every index under its key, ascending, with
// few keys (many chunks) and with more keys than a chunk-per-key count allows
// (fewer, larger chunks), and leaves the groups of unused keys empty.
TEST(FixedChunks, GroupIndicesIsTheSerialStableGrouping) {
  for (const auto& sizes : {std::pair<std::size_t, std::size_t>{300000, 5}, {300000, 40000}, {1000, 3}, {0, 4}}) {
    const std::size_t n = sizes.first, keys = sizes.second;  // (a lambda may not capture a structured binding in clang 14)
    const auto key = [&](std::size_t i) { return (i * 40503u) % (keys > 2 ? keys - 2 : 1); };  // the last two unused
    const detail::Buckets<Index> b = detail::group_indices(n, keys, key);
    std::vector<std::vector<Index>> serial(keys);
    for (std::size_t i = 0; i < n; ++i) serial[key(i)].push_back(static_cast<Index>(i));
    ASSERT_EQ(b.first.size(), keys + 1);
    ASSERT_EQ(b.items.size(), n);
    for (std::size_t k = 0; k < keys; ++k) {
      const std::vector<Index> got(b.items.begin() + static_cast<std::ptrdiff_t>(b.first[k]),
                                   b.items.begin() + static_cast<std::ptrdiff_t>(b.first[k + 1]));
      ASSERT_EQ(got, serial[k]) << "n " << n << " keys " << keys << " key " << k;
    }
  }
}

// A slice of the faces bucketed with the counts of one pass over all points
// is the slice bucketed on its own.
TEST(FixedChunks, SlicedFacesWithSharedCountsAreTheSlicesOwn) {
  const VolumeMesh m = fixtures::kuhn_grid(6);
  const std::vector<std::size_t> counts = detail::face_counts(m.tets, m.points.size());
  std::size_t total = 0;
  for (const std::size_t c : counts) total += c;
  EXPECT_EQ(total, 4 * m.tets.size());
  for (const auto& [lo, hi] : {std::pair<std::size_t, std::size_t>{0, 100}, {100, 250}, {250, m.points.size()}}) {
    const auto own = detail::faces_by_smallest_point(m.tets, lo, hi);
    const auto shared = detail::faces_by_smallest_point(m.tets, lo, hi, &counts);
    EXPECT_EQ(shared.first, own.first);
    ASSERT_EQ(shared.items.size(), own.items.size());
    for (std::size_t i = 0; i < own.items.size(); ++i) {
      EXPECT_EQ(shared.items[i].tet, own.items[i].tet);
      EXPECT_EQ(shared.items[i].slot, own.items[i].slot);
      EXPECT_EQ(shared.items[i].even, own.items[i].even);
    }
  }
}

}  // namespace
}  // namespace pdrmesh
