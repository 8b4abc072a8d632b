// SPDX-License-Identifier: AGPL-3.0-or-later
// The checks of the pdrmesh command line, in one place for every command: what
// each kind of number accepts (one rule per kind, below), the output path's
// directory and format, the mesh size with its percentage form, the nearest
// command to a mistyped one, and the help footers. The checks run while the
// command line is parsed, before any file is read; a failure is a usage error
// (exit 64) whose message names the option, what it accepts and what it got.
#pragma once

#include <CLI/CLI.hpp>

#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace pdrmesh::cli {

/// What a number option accepts; `what` is said in its error message.
struct Accepts {
  std::string_view what;
  std::string_view unit;  ///< the value's name in the help ("LENGTH")
  double min = 0;
  double max = std::numeric_limits<double>::infinity();
  bool min_excluded = false;  ///< min itself is refused
  bool integer = false;       ///< whole numbers only
};

// The kinds of number the commands take. A new option names one of these (or
// a new rule here) in its add_number line.
inline constexpr Accepts kLength{"a positive length", "LENGTH", 0, std::numeric_limits<double>::infinity(), true};
inline constexpr Accepts kVolume{"a positive volume", "VOLUME", 0, std::numeric_limits<double>::infinity(), true};
inline constexpr Accepts kSeconds{"a positive number of seconds", "SECONDS", 0, std::numeric_limits<double>::infinity(), true};
inline constexpr Accepts kGrowth{"a growth factor greater than 1 (1.2: the spacing grows by 20% per unit length)",
                                 "FACTOR", 1,
                                 std::numeric_limits<double>::infinity(), true};
inline constexpr Accepts kWorkers{"a whole number from 1 to 4096", "N", 1, 4096, false, true};
inline constexpr Accepts kTets{"a positive number of tets", "TETS", 0, std::numeric_limits<double>::infinity(), true};
inline constexpr Accepts kDepth{"a whole number from 0 to 10", "DEPTH", 0, 10, false, true};
inline constexpr Accepts kPixels{"a whole number of pixels from 64 to 8192", "PIXELS", 64, 8192, false, true};

/// The check of a number option: the whole text a finite number (no NaN,
/// infinity or overflow) within the rule; else "must be <what>, got '<text>'".
CLI::Validator number_check(const Accepts& accepts);

/// The whole of `text` as a finite double (no NaN, infinity or overflow).
std::optional<double> parse_finite(std::string_view text);

/// Adds an option taking a number of the given kind: one line per option.
template <class T>
CLI::Option* add_number(CLI::App* cmd, const std::string& flags, T& value, const std::string& help,
                        const Accepts& accepts) {
  return cmd->add_option(flags, value, help)->check(number_check(accepts))->type_name(std::string(accepts.unit));
}

/// --size: a length, or a percentage of the surface's bounding-box diagonal ("1%").
struct SizeValue {
  double value = 0;  ///< the length, or the percentage
  bool percent = false;

  /// nullopt unless `text` is a positive finite length, or a percentage in (0, 100] followed by '%'.
  static std::optional<SizeValue> parse(std::string_view text);
  /// The length for a surface with this bounding-box diagonal.
  double length(double diagonal) const { return percent ? diagonal * value / 100 : value; }
};
CLI::Validator size_check();

/// What an output path must name.
enum class OutputKind {
  kVolumeMesh,  ///< a volume mesh: its suffix names the format
  kFile,        ///< any file (a profile, an SVG)
};
/// The check of an output path: its directory exists and can be written, and
/// (kVolumeMesh) its suffix names a volume mesh format.
CLI::Validator output_check(OutputKind kind);
/// The check of an input surface's suffix (the file itself is read later).
CLI::Validator surface_input_check();

/// Adds --names FILE: boundary names for the surface's ids, one "ID NAME" per
/// line (boundary_names_io.hpp); the file is read later, with the surface.
CLI::Option* add_names_option(CLI::App* cmd, std::string& path);

/// A usage error found after parsing (a combination of options): thrown from a
/// command's checks, printed like any parse error, exit 64.
[[noreturn]] void usage_error(const std::string& message);

/// Refuses `option` given together with any of `others` (their count > 0), with the reason.
void refuse_together(const CLI::App& cmd, const std::string& option, const std::vector<std::string>& others,
                     std::string_view why);

/// The command a mistyped `word` most likely meant (by edit distance, or a
/// known other name such as logs for watch); empty when none is close.
std::string nearest_command(std::string_view word, const std::vector<std::string>& commands);

/// A command's help footer: its examples (command line, what it does) and the exit codes.
std::string help_footer(const std::vector<std::pair<std::string, std::string>>& examples);

}  // namespace pdrmesh::cli
