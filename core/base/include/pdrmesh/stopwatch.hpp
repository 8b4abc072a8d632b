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

/// CPU seconds (user and system) of this process so far, all threads
/// together, and of the child processes it has waited for: TetGen runs in
/// one (tetgen_adapter.hpp), and its time is the run's work too.
inline double process_cpu_seconds() {
  const auto s = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  double sum = 0;
  for (const int who : {RUSAGE_SELF, RUSAGE_CHILDREN}) {
    rusage u{};
    getrusage(who, &u);
    sum += s(u.ru_utime) + s(u.ru_stime);
  }
  return sum;
}

}  // namespace pdrmesh
