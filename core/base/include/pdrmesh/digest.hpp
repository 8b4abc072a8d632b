// SPDX-License-Identifier: AGPL-3.0-or-later
// A content digest: tells bytes apart from other bytes (a cached sizing field
// on a worker, a stored checkpoint that was cut short or belongs to another
// job). FNV-1a, 64 bits: quick and stable across builds, not cryptographic.
#pragma once

#include <cstdint>
#include <string_view>

namespace pdrmesh {

inline std::uint64_t content_digest(std::string_view bytes) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (const char c : bytes) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;
  }
  return h;
}

}  // namespace pdrmesh
