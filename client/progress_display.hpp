// SPDX-License-Identifier: AGPL-3.0-or-later
// The progress display of `pdrmesh run` and `pdrmesh submit --wait`: on a
// terminal one line redrawn in place (phase, a bar of leaves done of total,
// tets, elapsed); otherwise plain lines, one per phase and then at most one
// every few seconds. Messages (say) print above it with the elapsed time.
#pragma once

#include <fmt/format.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace pdrmesh::cli {

struct ProgressState {
  std::string phase;
  std::uint64_t leaves_done = 0;
  std::uint64_t leaves_total = 0;  ///< 0: no bar (outside the leaf rounds)
  std::uint64_t tets = 0;
  double elapsed_s = -1;           ///< < 0: the display's own clock
};

class ProgressDisplay {
 public:
  enum class Mode { kQuiet, kBar, kLines };
  /// kQuiet when quiet, else kBar when `out` is a terminal, else kLines.
  static Mode mode_for(std::FILE* out, bool quiet);

  explicit ProgressDisplay(Mode mode, std::FILE* out = stderr, double line_interval_s = 5);
  explicit ProgressDisplay(bool quiet) : ProgressDisplay(mode_for(stderr, quiet)) {}
  ~ProgressDisplay() { finish(); }
  ProgressDisplay(const ProgressDisplay&) = delete;
  ProgressDisplay& operator=(const ProgressDisplay&) = delete;

  void update(const ProgressState& state);
  /// A line "[elapsed] message" (above the bar on a terminal).
  void say(std::string_view message);
  template <class... Args>
  void say(fmt::format_string<Args...> f, Args&&... args) {
    say(std::string_view(fmt::format(f, std::forward<Args>(args)...)));
  }
  /// Ends the bar's line (the bar stays visible). Idempotent.
  void finish();
  /// The line update() shows for `state` (without the terminal controls).
  static std::string format_line(const ProgressState& state, double elapsed_s, bool bar);

 private:
  double elapsed() const;

  Mode mode_;
  std::FILE* out_;
  double line_interval_s_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_{};
  std::string last_phase_;
  ProgressState last_state_;  ///< the latest update, drawn or not (elapsed_s set)
  bool bar_open_ = false;  ///< a bar is drawn on the current line
};

}  // namespace pdrmesh::cli
