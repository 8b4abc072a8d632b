// SPDX-License-Identifier: AGPL-3.0-or-later
// Deterministic parallel building blocks (oneTBB) for the validator and the
// decompositions: loops over fixed chunks whose bounds do not depend on the
// thread count (per-chunk results combined in chunk order give the serial
// result), parallel counting sorts (into buckets, and of indices by a key), and
// the faces of a tet mesh grouped by their smallest point.
#pragma once

#include <sys/mman.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <new>
#include <numeric>
#include <span>
#include <tuple>
#include <utility>
#include <vector>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include "pdrmesh/topology.hpp"
#include "pdrmesh/types.hpp"

namespace pdrmesh::detail {

/// The number of chunks of `grain` items (grain > 0) covering [0, n).
constexpr std::size_t chunk_count(std::size_t n, std::size_t grain) { return (n + grain - 1) / grain; }

/// Calls body(chunk, begin, end) for every chunk [chunk * grain, min(n, (chunk + 1) * grain)),
/// chunks in parallel. The chunks depend only on n and grain, never on the threads.
template <class Body>
void for_each_chunk(std::size_t n, std::size_t grain, Body&& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunk_count(n, grain)),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c) body(c, c * grain, std::min(n, (c + 1) * grain));
                    });
}

/// The per-chunk vectors concatenated in chunk order (each part emptied on the way).
template <class T>
std::vector<T> concatenate(std::vector<std::vector<T>>& parts) {
  std::size_t n = 0;
  for (const auto& p : parts) n += p.size();
  std::vector<T> all;
  all.reserve(n);
  for (auto& p : parts) {
    all.insert(all.end(), p.begin(), p.end());
    p = {};
  }
  return all;
}

/// std::copy of [first, last) to out in fixed chunks, the chunks in parallel:
/// a copy of millions of items is a memory pass one thread does not saturate.
template <class In, class Out>
void parallel_copy(In first, In last, Out out, std::size_t grain = std::size_t{1} << 16) {
  const auto n = static_cast<std::size_t>(last - first);
  for_each_chunk(n, grain, [&](std::size_t, std::size_t b, std::size_t e) {
    std::copy(first + static_cast<std::ptrdiff_t>(b), first + static_cast<std::ptrdiff_t>(e),
              out + static_cast<std::ptrdiff_t>(b));
  });
}

/// v.resize(n), with the pages of the new items (within v's capacity) faulted
/// in ahead by all threads: resize zero-fills the new items by one thread, and
/// into pages not yet touched that is a page fault, and the kernel zeroing a
/// page, every few items. MADV_POPULATE_WRITE (Linux 5.14) faults a range in;
/// where the kernel lacks it, resize faults the pages as before.
template <class T>
void resize_prefaulted(std::vector<T>& v, std::size_t n) {
  if (n > v.size() && n <= v.capacity()) {
    constexpr std::uintptr_t kPage = 4096;
    constexpr std::size_t kChunk = std::size_t{1} << 22;  // 4 MiB: whole pages, many chunks a call
    const auto base = reinterpret_cast<std::uintptr_t>(v.data());
    const std::uintptr_t lo = (base + v.size() * sizeof(T)) & ~(kPage - 1);
    const std::uintptr_t hi = base + n * sizeof(T);
    if (hi - lo >= 2 * kChunk) {
      for_each_chunk(static_cast<std::size_t>(hi - lo), kChunk, [&](std::size_t, std::size_t b, std::size_t e) {
        madvise(reinterpret_cast<void*>(lo + b), e - b, MADV_POPULATE_WRITE);  // a hint: a failure changes nothing
      });
    }
  }
  v.resize(n);
}

/// An allocator that leaves a resized vector's new items default-initialised
/// (trivial items: not written), so that a parallel pass writing every item
/// first touches the memory, rather than a serial zero fill.
template <class T>
struct NoInitAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = NoInitAllocator<U>;
  };
  NoInitAllocator() = default;
  template <class U>
  NoInitAllocator(const NoInitAllocator<U>&) noexcept {}
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    if constexpr (sizeof...(Args) == 0) {
      ::new (static_cast<void*>(p)) U;
    } else {
      ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
  }
};

/// A vector whose resize does not initialise trivial items (see NoInitAllocator).
template <class T>
using UninitVector = std::vector<T, NoInitAllocator<T>>;

/// The i in [0, n) with keep(i), ascending, in parallel: each fixed chunk
/// counts its own, prefix sums give each chunk its place.
template <class Keep>
std::vector<Index> filter_indices(std::size_t n, std::size_t grain, Keep&& keep) {
  std::vector<std::size_t> at(chunk_count(n, grain) + 1, 0);
  for_each_chunk(n, grain, [&](std::size_t c, std::size_t lo, std::size_t hi) {
    for (std::size_t i = lo; i < hi; ++i) at[c + 1] += keep(i) ? 1 : 0;
  });
  std::partial_sum(at.begin(), at.end(), at.begin());
  std::vector<Index> out(at.back());
  for_each_chunk(n, grain, [&](std::size_t c, std::size_t lo, std::size_t hi) {
    std::size_t k = at[c];
    for (std::size_t i = lo; i < hi; ++i)
      if (keep(i)) out[k++] = static_cast<Index>(i);
  });
  return out;
}

/// Items grouped by a key in [0, keys): key k's items are items[first[k] .. first[k + 1]).
template <class T>
struct Buckets {
  std::vector<std::size_t> first;
  UninitVector<T> items;
};

/// bucket_items' counting pass: count[key] += 1 for every emit(key, item) of
/// each(i, emit), i in [0, n) (in this thread when n <= grain).
template <class Each>
void count_items(std::size_t n, std::size_t grain, Each& each, std::size_t* count) {
  if (n <= grain) {  // one chunk: without atomics
    for (std::size_t i = 0; i < n; ++i) each(i, [&](Index key, const auto&) { ++count[key]; });
    return;
  }
  for_each_chunk(n, grain, [&](std::size_t, std::size_t lo, std::size_t hi) {
    for (std::size_t i = lo; i < hi; ++i)
      each(i, [&](Index key, const auto&) { std::atomic_ref<std::size_t>(count[key]).fetch_add(1, std::memory_order_relaxed); });
  });
}

/// The number of items of each key in [0, keys) that bucket_items(n, keys,
/// grain, each) would bucket, for callers that bucket them in several calls.
template <class Each>
std::vector<std::size_t> bucket_counts(std::size_t n, std::size_t keys, std::size_t grain, Each&& each) {
  std::vector<std::size_t> count(keys, 0);
  count_items(n, grain, each, count.data());
  return count;
}

/// A counting sort, in parallel: each(i, emit) for every i in [0, n) calls
/// emit(key, item) for its items (the same ones on each of its two calls). The
/// bucket sizes are exact; the order of the items *inside* a bucket depends on
/// the threads, so a caller sorts each bucket by a total order (sort_buckets),
/// after which the result is what a serial counting sort plus that sort gives.
/// With `counts` (the number of items of each key, known from an earlier
/// pass: bucket_counts), the counting pass is skipped.
template <class T, class Each>
Buckets<T> bucket_items(std::size_t n, std::size_t keys, std::size_t grain, Each&& each,
                        const std::size_t* counts = nullptr) {
  Buckets<T> b;
  b.first.assign(keys + 1, 0);
  if (counts != nullptr) {
    std::copy(counts, counts + keys, b.first.begin() + 1);
  } else {
    count_items(n, grain, each, b.first.data() + 1);
  }
  if (n <= grain) {
    std::partial_sum(b.first.begin(), b.first.end(), b.first.begin());
    b.items.resize(b.first[keys]);
    std::vector<std::size_t> next(b.first.begin(), b.first.end() - 1);
    for (std::size_t i = 0; i < n; ++i) each(i, [&](Index key, const T& item) { b.items[next[key]++] = item; });
    return b;
  }
  std::partial_sum(b.first.begin(), b.first.end(), b.first.begin());
  b.items.resize(b.first[keys]);
  std::vector<std::size_t> next(b.first.begin(), b.first.end() - 1);
  for_each_chunk(n, grain, [&](std::size_t, std::size_t lo, std::size_t hi) {
    for (std::size_t i = lo; i < hi; ++i) {
      each(i, [&](Index key, const T& item) {
        b.items[std::atomic_ref<std::size_t>(next[key]).fetch_add(1, std::memory_order_relaxed)] = item;
      });
    }
  });
  return b;
}

/// The i in [0, n) grouped by key_of(i) in [0, keys), each group ascending:
/// a stable counting sort over fixed chunks (per chunk counts, prefix sums in
/// key-then-chunk order, a scatter), so the result needs no sort of its groups
/// and is the same for any thread count. Fewer, larger chunks where the keys
/// are many, so that the counts stay a small fraction of the items.
template <class KeyOf>
Buckets<Index> group_indices(std::size_t n, std::size_t keys, KeyOf&& key_of) {
  constexpr std::size_t kGrain = 65536;
  const std::size_t most_chunks = std::max<std::size_t>(1, n / 16 / std::max<std::size_t>(keys, 1));
  const std::size_t grain = std::max(kGrain, chunk_count(n, most_chunks));
  const std::size_t chunks = chunk_count(n, grain);
  std::vector<std::size_t> at(chunks * keys, 0);  // at[chunk * keys + key]: each chunk's counts together
  for_each_chunk(n, grain, [&](std::size_t c, std::size_t lo, std::size_t hi) {
    std::size_t* const count = at.data() + c * keys;
    for (std::size_t i = lo; i < hi; ++i) ++count[static_cast<std::size_t>(key_of(i))];
  });
  Buckets<Index> b;
  b.first.assign(keys + 1, 0);
  std::size_t sum = 0;
  for (std::size_t k = 0; k < keys; ++k) {
    b.first[k] = sum;
    for (std::size_t c = 0; c < chunks; ++c) {
      const std::size_t count = at[c * keys + k];
      at[c * keys + k] = sum;
      sum += count;
    }
  }
  b.first[keys] = sum;
  b.items.resize(sum);
  for_each_chunk(n, grain, [&](std::size_t c, std::size_t lo, std::size_t hi) {
    std::size_t* const next = at.data() + c * keys;
    for (std::size_t i = lo; i < hi; ++i)
      b.items[next[static_cast<std::size_t>(key_of(i))]++] = static_cast<Index>(i);
  });
  return b;
}

/// Sorts [first, last) by `less`: by insertion when short (a bucket of faces
/// holds a few dozen), else std::sort. The same order either way (a total order).
template <class It, class Less>
void sort_short(It first, It last, Less less) {
  if (last - first > 48) {
    std::sort(first, last, less);
    return;
  }
  for (It i = first; i != last; ++i) {
    auto v = std::move(*i);
    It j = i;
    for (; j != first && less(v, *(j - 1)); --j) *j = std::move(*(j - 1));
    *j = std::move(v);
  }
}

/// Sorts each bucket of `b` by `less`, buckets in parallel.
template <class T, class Less>
void sort_buckets(Buckets<T>& b, Less less) {
  if (b.items.size() <= 65536) {  // a small set (a leaf task's): in this thread
    for (std::size_t k = 0; k + 1 < b.first.size(); ++k)
      sort_short(b.items.begin() + static_cast<std::ptrdiff_t>(b.first[k]),
                 b.items.begin() + static_cast<std::ptrdiff_t>(b.first[k + 1]), less);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, b.first.size() - 1), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t k = r.begin(); k != r.end(); ++k) {
      sort_short(b.items.begin() + static_cast<std::ptrdiff_t>(b.first[k]),
                 b.items.begin() + static_cast<std::ptrdiff_t>(b.first[k + 1]), less);
    }
  });
}

/// One face of one tet: its sorted points are (the bucket's point, b, c).
struct FaceRef {
  Index b, c;  // b <= c
  Index tet;
  std::uint16_t slot;  // topo::face_of(tets[tet], slot)
  bool even;           // that face is an even permutation of (a, b, c); the two tets of a face
                       // of a valid mesh differ in it (the same: they overlap)
  friend bool operator<(const FaceRef& x, const FaceRef& y) {
    return std::tie(x.b, x.c, x.tet, x.slot) < std::tie(y.b, y.c, y.tet, y.slot);
  }
};

inline constexpr std::size_t kFaceGrain = 16384;

/// each(t, emit) for bucket_items: the faces of tet t whose smallest point a
/// lies in [lo, hi), as (a - lo, FaceRef).
inline auto face_emitter(std::span<const Tet> tets, std::size_t lo, std::size_t hi) {
  return [tets, lo, hi](std::size_t t, auto&& emit) {
    for (int f = 0; f < 4; ++f) {
      const auto [s, even] = topo::sorted_key_parity(topo::face_of(tets[t], f));
      if (s[0] >= lo && s[0] < hi)
        emit(static_cast<Index>(s[0] - lo), FaceRef{s[1], s[2], static_cast<Index>(t), static_cast<std::uint16_t>(f), even});
    }
  };
}

/// Every face of every tet, bucketed by its smallest point (every index must be
/// below `points`) and each bucket sorted by (b, c, tet, slot): the order of one
/// sort of all faces by (sorted points, tet, slot), in linear time plus small
/// sorts, 16 bytes a face. Equal faces are adjacent. With [lo, hi): only the
/// faces whose smallest point lies there, point a in bucket a - lo, so that a
/// caller walking the points in slices holds one slice's faces at a time.
/// With `counts` (face_counts' result for all points), the slice's faces are
/// not counted again.
inline Buckets<FaceRef> faces_by_smallest_point(std::span<const Tet> tets, std::size_t lo, std::size_t hi,
                                                const std::vector<std::size_t>* counts = nullptr) {
  auto b = bucket_items<FaceRef>(tets.size(), hi - lo, kFaceGrain, face_emitter(tets, lo, hi),
                                 counts != nullptr ? counts->data() + lo : nullptr);
  sort_buckets(b, std::less<FaceRef>());
  return b;
}

/// The number of faces of the tets whose smallest point is p, for each p
/// below `points`: one pass, so that a caller walking the points in slices
/// counts them once.
inline std::vector<std::size_t> face_counts(std::span<const Tet> tets, std::size_t points) {
  return bucket_counts(tets.size(), points, kFaceGrain, face_emitter(tets, 0, points));
}

/// Every face (every index must be below `points`).
inline Buckets<FaceRef> faces_by_smallest_point(std::span<const Tet> tets, std::size_t points) {
  return faces_by_smallest_point(tets, 0, points);
}

/// Calls f(group) for every run of faces with the same points in bucket a of
/// faces_by_smallest_point's result (a span of one or more FaceRefs).
template <class F>
void for_each_face_group(const Buckets<FaceRef>& faces, std::size_t a, F&& f) {
  const FaceRef* const last = faces.items.data() + faces.first[a + 1];
  for (const FaceRef* i = faces.items.data() + faces.first[a]; i != last;) {
    const FaceRef* j = i + 1;
    while (j != last && j->b == i->b && j->c == i->c) ++j;
    f(std::span<const FaceRef>(i, j));
    i = j;
  }
}

}  // namespace pdrmesh::detail
