// SPDX-License-Identifier: AGPL-3.0-or-later
// Shared helpers of the libFuzzer targets: a property that must hold for every
// accepted input, checked with FUZZ_REQUIRE (prints what failed and aborts, so
// libFuzzer records the input as a crash).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "pdrmesh/types.hpp"

#define FUZZ_REQUIRE(cond)                                                                \
  do {                                                                                    \
    if (!(cond)) {                                                                        \
      std::fprintf(stderr, "%s:%d: property failed: %s\n", __FILE__, __LINE__, #cond);  \
      std::abort();                                                                       \
    }                                                                                     \
  } while (false)

namespace pdrmesh::fuzz {

inline std::string_view bytes_of(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

inline bool finite(const Vec3& p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

/// Every index of every element is below `n`.
template <typename Elements>
bool indices_below(const Elements& elements, std::size_t n) {
  for (const auto& e : elements)
    for (auto i : e)
      if (static_cast<std::size_t>(i) >= n) return false;
  return true;
}

}  // namespace pdrmesh::fuzz
