// SPDX-License-Identifier: AGPL-3.0-or-later
// Atomic minimum and maximum: a value lowered (raised) by many threads ends at
// the least (greatest) value offered, whatever order the threads run in, which
// is what the parallel loops need to stay deterministic.
#pragma once

#include <atomic>

namespace pdrmesh::detail {

/// Lowers `a` to `value` when value is smaller (std::atomic or std::atomic_ref).
/// Relaxed order: the callers read the result after their parallel loop joins.
template <class Atomic, class T>
void atomic_lower(Atomic& a, T value) {
  for (T cur = a.load(std::memory_order_relaxed);
       value < cur && !a.compare_exchange_weak(cur, value, std::memory_order_relaxed);) {
  }
}

/// Raises `a` to `value` when value is greater (std::atomic or std::atomic_ref).
template <class Atomic, class T>
void atomic_raise(Atomic& a, T value) {
  for (T cur = a.load(std::memory_order_relaxed);
       cur < value && !a.compare_exchange_weak(cur, value, std::memory_order_relaxed);) {
  }
}

}  // namespace pdrmesh::detail
