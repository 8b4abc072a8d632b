// SPDX-License-Identifier: AGPL-3.0-or-later
// The byte format between the TetGen adapter (tetgen_adapter.cpp, the parent)
// and its helper process pdrmesh-tetgen (tetgen_child.cpp). Both ends are built
// from this header in the same build, on the same machine: native endianness,
// no versioning beyond the magic numbers.
//
//   Request (the helper's stdin): RequestHeader, then n_points * 3 doubles,
//     n_triangles * 3 int32 corners, switches_len bytes of TetGen switches.
//   Answer (the helper's descriptor kAnswerFd): AnswerHeader, then for kOk
//     n_points * 3 doubles and n_tets * 4 int32 (TetGen's order); for the error
//     kinds, message_len bytes of text.
//   The helper's stdout and stderr are its log (TetGen's messages, a sanitizer's
//   report); the parent keeps the end of it for error messages.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdint>

namespace pdrmesh::tetgen_wire {

constexpr std::uint64_t kRequestMagic = 0x31514547524450ull;  // "PDRGEQ1"
constexpr std::uint64_t kAnswerMagic = 0x31544547524450ull;   // "PDRGET1"

/// The answer's descriptor in the helper (0 is the request, 1 and 2 the log).
constexpr int kAnswerFd = 3;

/// What the helper does instead of meshing (TetgenOptions::Fault, a test seam).
enum class Fault : std::uint32_t { kNone = 0, kCrash = 1, kHang = 2, kExit = 3, kThrow = 4 };

struct RequestHeader {
  std::uint64_t magic = kRequestMagic;
  std::uint64_t n_points = 0;
  std::uint64_t n_triangles = 0;
  std::uint64_t switches_len = 0;
  std::uint64_t memory_limit = 0;  // RLIMIT_AS the helper sets on itself; 0 = none
  std::uint32_t fault = 0;
  std::uint32_t reserved = 0;
};

enum class Answer : std::uint32_t {
  kOk = 0,
  kTetgenCode = 1,   // TetGen threw an int (terminatetetgen); `code` holds it
  kOutOfMemory = 2,  // std::bad_alloc
  kException = 3,    // another std::exception; the message holds what()
  kUnknown = 4,      // something else was thrown
};

struct AnswerHeader {
  std::uint64_t magic = kAnswerMagic;
  std::uint32_t answer = 0;
  std::int32_t code = 0;
  std::uint64_t n_points = 0;
  std::uint64_t n_tets = 0;
  std::uint64_t message_len = 0;
};

/// Writes all of `size` bytes (retrying on EINTR and short writes).
inline bool write_all(int fd, const void* data, std::size_t size) {
  const char* p = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd, p, std::min<std::size_t>(size, std::size_t{1} << 20));
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    p += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

/// Reads exactly `size` bytes; false on end of file or an error before that.
inline bool read_all(int fd, void* data, std::size_t size) {
  char* p = static_cast<char*>(data);
  while (size > 0) {
    const ssize_t n = ::read(fd, p, std::min<std::size_t>(size, std::size_t{1} << 20));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace pdrmesh::tetgen_wire
