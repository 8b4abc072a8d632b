// SPDX-License-Identifier: AGPL-3.0-or-later
// ProgressDisplay: the bar on a terminal, periodic lines elsewhere.
#include "progress_display.hpp"

#include <unistd.h>

#include <algorithm>

namespace pdrmesh::cli {

ProgressDisplay::Mode ProgressDisplay::mode_for(std::FILE* out, bool quiet) {
  if (quiet) return Mode::kQuiet;
  return isatty(fileno(out)) ? Mode::kBar : Mode::kLines;
}

ProgressDisplay::ProgressDisplay(Mode mode, std::FILE* out, double line_interval_s)
    : mode_(mode), out_(out), line_interval_s_(line_interval_s), start_(std::chrono::steady_clock::now()) {}

double ProgressDisplay::elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

std::string ProgressDisplay::format_line(const ProgressState& s, double elapsed_s, bool bar) {
  std::string line = bar ? fmt::format("[{:7.2f}s] {:<16}", elapsed_s, s.phase)
                         : fmt::format("[{:7.2f}s] {}", elapsed_s, s.phase);
  if (s.leaves_total > 0) {
    if (bar) {
      constexpr std::size_t kWidth = 24;
      const auto filled = static_cast<std::size_t>(
          static_cast<double>(kWidth) * static_cast<double>(std::min(s.leaves_done, s.leaves_total)) /
          static_cast<double>(s.leaves_total));
      line += fmt::format(" [{}{}]", std::string(filled, '#'), std::string(kWidth - filled, '.'));
    }
    line += fmt::format(" {}/{} leaves", s.leaves_done, s.leaves_total);
  }
  if (s.tets > 0) line += fmt::format(" {} tets", s.tets);
  return line;
}

void ProgressDisplay::update(const ProgressState& state) {
  if (mode_ == Mode::kQuiet) return;
  const auto now = std::chrono::steady_clock::now();
  const bool new_phase = state.phase != last_phase_;
  const double since = std::chrono::duration<double>(now - last_draw_).count();
  const double t = state.elapsed_s >= 0 ? state.elapsed_s : elapsed();
  if (mode_ == Mode::kBar) {
    if (!new_phase && since < 0.1) {
      last_state_ = state;
      last_state_.elapsed_s = t;
      return;
    }
    // A finished phase keeps its line, with its last state; the new one draws below it.
    if (new_phase && bar_open_) fmt::print(out_, "\r{}\x1b[K\n", format_line(last_state_, last_state_.elapsed_s, true));
    fmt::print(out_, "\r{}\x1b[K", format_line(state, t, true));
    bar_open_ = true;
  } else {
    if (!new_phase && since < line_interval_s_) return;
    fmt::print(out_, "{}\n", format_line(state, t, false));
  }
  std::fflush(out_);
  last_draw_ = now;
  last_phase_ = state.phase;
  last_state_ = state;
  last_state_.elapsed_s = t;
}

void ProgressDisplay::say(std::string_view message) {
  if (mode_ == Mode::kQuiet) return;
  if (bar_open_) fmt::print(out_, "\r\x1b[K");
  fmt::print(out_, "[{:7.2f}s] {}\n", elapsed(), message);
  if (bar_open_) last_phase_.clear();  // redrawn by the next update
  bar_open_ = false;
  std::fflush(out_);
}

void ProgressDisplay::finish() {
  if (!bar_open_) return;
  fmt::print(out_, "\r{}\x1b[K\n", format_line(last_state_, last_state_.elapsed_s, true));
  std::fflush(out_);
  bar_open_ = false;
}

}  // namespace pdrmesh::cli
