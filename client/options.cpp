// SPDX-License-Identifier: AGPL-3.0-or-later
// The command-line checks (see options.hpp).
#include "options.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>

#include "exit_codes.hpp"
#include "pdrmesh/surface_io.hpp"
#include "pdrmesh/volume_io.hpp"

namespace pdrmesh::cli {

std::optional<double> parse_finite(std::string_view text) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return std::nullopt;
  const std::string s(text);
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || errno == ERANGE || !std::isfinite(v)) return std::nullopt;
  return v;
}

namespace {

bool is_whole_number(std::string_view text) {
  long long v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  return ec == std::errc() && end == text.data() + text.size();
}

bool within(double v, const Accepts& a) {
  return (a.min_excluded ? v > a.min : v >= a.min) && v <= a.max;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

}  // namespace

CLI::Validator number_check(const Accepts& accepts) {
  return CLI::Validator(
      [accepts](std::string& text) -> std::string {
        const std::optional<double> v = parse_finite(text);
        if (v && within(*v, accepts) && (!accepts.integer || is_whole_number(text))) return {};
        return fmt::format("must be {}, got '{}'", accepts.what, text);
      },
      "");
}

std::optional<SizeValue> SizeValue::parse(std::string_view text) {
  SizeValue s;
  if (!text.empty() && text.back() == '%') {
    s.percent = true;
    text.remove_suffix(1);
  }
  const std::optional<double> v = parse_finite(text);
  if (!v || !(*v > 0) || (s.percent && *v > 100)) return std::nullopt;
  s.value = *v;
  return s;
}

CLI::Validator size_check() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        if (SizeValue::parse(text)) return {};
        return fmt::format("must be a positive length or a percentage of the bounding-box diagonal such as 1%, "
                           "got '{}'",
                           text);
      },
      "");
}

namespace {

/// An OpenFOAM polyMesh output: a directory (replaced if there) whose missing
/// parents are made, so the nearest existing one must be writable.
std::string poly_mesh_output_problem(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path dir = fs::path(path);
  if (!dir.has_filename()) dir = dir.parent_path();
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    return fmt::format("cannot write '{}': it exists and is not a directory", path);
  fs::path ancestor = dir.parent_path();
  while (!ancestor.empty() && !fs::exists(ancestor, ec)) ancestor = ancestor.parent_path();
  if (ancestor.empty()) ancestor = ".";
  if (!fs::is_directory(ancestor, ec))
    return fmt::format("cannot write '{}': '{}' is not a directory", path, ancestor.string());
  if (::access(ancestor.c_str(), W_OK) != 0)
    return fmt::format("cannot write '{}': the directory '{}' is not writable", path, ancestor.string());
  return {};
}

}  // namespace

CLI::Validator output_check(OutputKind kind) {
  return CLI::Validator(
      [kind](std::string& path) -> std::string {
        namespace fs = std::filesystem;
        if (path.empty()) return "must name a file, got ''";
        std::error_code ec;
        if (kind == OutputKind::kVolumeMesh) {
          const auto f = volume_format_from_path(path);
          if (f.ok() && *f == VolumeFormat::kFoam) return poly_mesh_output_problem(path);
          if (fs::is_directory(path, ec))
            return fmt::format("'{}' is a directory, not a file (only a polyMesh output is a directory)", path);
          if (!f.ok()) return f.status().message();
        }
        if (fs::is_directory(path, ec)) return fmt::format("'{}' is a directory, not a file", path);
        fs::path dir = fs::path(path).parent_path();
        if (dir.empty()) dir = ".";
        if (!fs::is_directory(dir, ec))
          return fmt::format("cannot write '{}': the directory '{}' does not exist", path, dir.string());
        if (::access(dir.c_str(), W_OK) != 0)
          return fmt::format("cannot write '{}': the directory '{}' is not writable", path, dir.string());
        return {};
      },
      "");
}

CLI::Validator surface_input_check() {
  return CLI::Validator(
      [](std::string& path) -> std::string {
        if (auto f = surface_format_from_path(path); !f.ok()) return f.status().message();
        return {};
      },
      "");
}

CLI::Option* add_names_option(CLI::App* cmd, std::string& path) {
  return cmd
      ->add_option("--names", path,
                   "boundary names for the surface's ids: a text file of 'ID NAME' lines ('#' starts a comment; "
                   "a name is 1-32 letters, digits, '_', '-', '.', starting with a letter or '_'); over the names "
                   "an STL solid or OBJ group gives")
      ->check(CLI::Validator(CLI::ExistingFile).description(""))
      ->type_name("FILE");
}

void usage_error(const std::string& message) { throw CLI::ValidationError(message); }

void refuse_together(const CLI::App& cmd, const std::string& option, const std::vector<std::string>& others,
                     std::string_view why) {
  if (cmd.count(option) == 0) return;
  for (const std::string& other : others)
    if (cmd.count(other) > 0) usage_error(fmt::format("{} and {} do not go together: {}", option, other, why));
}

std::string nearest_command(std::string_view word, const std::vector<std::string>& commands) {
  // Names other tools use for what a command here does.
  static const std::map<std::string_view, std::string_view> kOtherNames = {
      {"logs", "watch"},  {"log", "watch"},     {"follow", "watch"},  {"ls", "list"},     {"jobs", "list"},
      {"ps", "list"},     {"rm", "delete"},     {"remove", "delete"}, {"kill", "cancel"}, {"stop", "cancel"},
      {"get", "fetch"},   {"download", "fetch"}, {"info", "status"},  {"stats", "quality"}, {"verify", "validate"},
      {"generate", "mesh"}, {"parallel", "run"}, {"upload", "submit"}};
  if (auto it = kOtherNames.find(word); it != kOtherNames.end()) return std::string(it->second);
  std::string best;
  std::size_t best_distance = 3;  // at most two edits
  for (const std::string& c : commands) {
    if (word.size() >= 2 && c.rfind(word, 0) == 0) return c;  // a prefix
    const std::size_t d = edit_distance(word, c);
    if (d < best_distance && d < word.size()) {
      best = c;
      best_distance = d;
    }
  }
  return best;
}

std::string help_footer(const std::vector<std::pair<std::string, std::string>>& examples) {
  std::string out = "\nExamples:\n";
  for (const auto& [line, what] : examples) out += fmt::format("  {}\n      {}\n", line, what);
  out += "\nExit codes:\n";
  for (const auto& [code, meaning] : kExitCodeMeanings) out += fmt::format("  {:<3} {}\n", code, meaning);
  return out;
}

}  // namespace pdrmesh::cli
