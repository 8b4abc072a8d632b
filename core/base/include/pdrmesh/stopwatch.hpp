// SPDX-License-Identifier: AGPL-3.0-or-later
// Wall-time measurement for the profiles and progress reports of the kernel.
#pragma once

#include <chrono>

namespace pdrmesh {

/// Seconds elapsed since `t0`.
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace pdrmesh
