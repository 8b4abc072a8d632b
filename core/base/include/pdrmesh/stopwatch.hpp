// SPDX-License-Identifier: AGPL-3.0-or-later
// Wall and CPU time measurement for the profiles and progress reports of the kernel.
#pragma once

#include <sys/resource.h>

#include <chrono>

namespace pdrmesh {

/// Seconds elapsed since `t0`.
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// CPU seconds (user and system) of this process so far, all threads together.
inline double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  const auto s = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  return s(u.ru_utime) + s(u.ru_stime);
}

}  // namespace pdrmesh
