// SPDX-License-Identifier: AGPL-3.0-or-later
// The boundary names file (boundary_names_io.hpp).
#include "pdrmesh/boundary_names_io.hpp"

#include <fmt/format.h>

#include <charconv>

#include "pdrmesh/boundary_names.hpp"
#include "volume_io_detail.hpp"

namespace pdrmesh {
namespace {

std::string_view trim_blanks(std::string_view s) {
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; };
  while (!s.empty() && blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && blank(s.back())) s.remove_suffix(1);
  return s;
}

/// The next blank-separated word of `s`, removed from it.
std::string_view take_blank_separated(std::string_view& s) {
  s = trim_blanks(s);
  std::size_t n = 0;
  while (n < s.size() && s[n] != ' ' && s[n] != '\t') ++n;
  const std::string_view w = s.substr(0, n);
  s.remove_prefix(n);
  return w;
}

}  // namespace

Result<std::map<int, std::string>> parse_boundary_names(std::string_view text, std::string_view file) {
  std::map<int, std::string> names;
  std::map<int, std::size_t> id_line;
  std::map<std::string, std::pair<int, std::size_t>, std::less<>> name_line;
  std::size_t line_no = 0;
  while (!text.empty()) {
    ++line_no;
    const std::size_t end = text.find('\n');
    std::string_view line = text.substr(0, end);
    text.remove_prefix(end == std::string_view::npos ? text.size() : end + 1);
    line = trim_blanks(line.substr(0, line.find('#')));
    if (line.empty()) continue;
    const auto error = [&](const std::string& msg) {
      return invalid_input(fmt::format("{}:{}: {}", file, line_no, msg));
    };
    const std::string_view id_text = take_blank_separated(line);
    const std::string_view name = take_blank_separated(line);
    int id = 0;
    const auto [p, ec] = std::from_chars(id_text.data(), id_text.data() + id_text.size(), id);
    if (ec != std::errc() || p != id_text.data() + id_text.size())
      return error(fmt::format("expected 'ID NAME' with an integer id, got {}", volio::show(id_text)));
    if (name.empty()) return error(fmt::format("id {} has no name (expected 'ID NAME')", id));
    if (!trim_blanks(line).empty())
      return error(fmt::format("unexpected {} after the name {} (a name has no blanks)", volio::show(trim_blanks(line)),
                               volio::show(name)));
    if (Status s = check_boundary_name(id, name); !s.ok()) return error(std::string(s.message()));
    if (const auto it = id_line.find(id); it != id_line.end())
      return error(fmt::format("id {} is named again (first on line {})", id, it->second));
    if (const auto it = name_line.find(name); it != name_line.end())
      return error(fmt::format("'{}' names id {} here and id {} on line {}; a name belongs to one id", name, id,
                               it->second.first, it->second.second));
    id_line[id] = line_no;
    name_line.emplace(std::string(name), std::pair{id, line_no});
    names[id] = std::string(name);
  }
  return names;
}

Result<std::map<int, std::string>> read_boundary_names(const std::filesystem::path& path) {
  PDR_ASSIGN_OR_RETURN(const std::string text, volio::read_file(path));
  return parse_boundary_names(text, path.string());
}

std::string format_boundary_names(const std::map<int, std::string>& names) {
  std::string out;
  for (const auto& [id, name] : names) out += fmt::format("{} {}\n", id, name);
  return out;
}

}  // namespace pdrmesh
