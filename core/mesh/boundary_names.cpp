// SPDX-License-Identifier: AGPL-3.0-or-later
// Boundary name rules and checks (boundary_names.hpp).
#include "pdrmesh/boundary_names.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <charconv>

namespace pdrmesh {
namespace {

bool is_letter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }
bool is_name_char(char c) { return is_letter(c) || (c >= '0' && c <= '9') || c == '_' || c == '-' || c == '.'; }

/// The n of "surface_<n>", when `name` has that form.
bool default_name_id(std::string_view name, int& n) {
  constexpr std::string_view kPrefix = "surface_";
  if (name.size() <= kPrefix.size() || name.substr(0, kPrefix.size()) != kPrefix) return false;
  const std::string_view digits = name.substr(kPrefix.size());
  const auto [p, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), n);
  return ec == std::errc() && p == digits.data() + digits.size() && std::to_string(n) == digits;
}

std::string quoted(std::string_view s) {
  std::string out = "'";
  for (char c : s.substr(0, 60)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
  if (s.size() > 60) out += "...";
  return out + "'";
}

}  // namespace

bool is_default_boundary_name(int id, std::string_view name) {
  int n = 0;
  return default_name_id(name, n) && n == id;
}

Status check_boundary_name(int id, std::string_view name) {
  if (name.empty()) return invalid_input("an empty name");
  if (name.size() > kMaxBoundaryNameLength)
    return invalid_input(fmt::format("{} is {} characters long; a boundary name has at most {}", quoted(name),
                                     name.size(), kMaxBoundaryNameLength));
  const auto bad = std::find_if_not(name.begin(), name.end(), is_name_char);
  if (bad != name.end())
    return invalid_input(fmt::format("{} has the character {}; a boundary name holds letters, digits, '_', '-' "
                                     "and '.' only",
                                     quoted(name), quoted(std::string_view(&*bad, 1))));
  if (!is_letter(name[0]) && name[0] != '_')
    return invalid_input(fmt::format("{} starts with {}; a boundary name starts with a letter or '_'", quoted(name),
                                     quoted(name.substr(0, 1))));
  int n = 0;
  if (default_name_id(name, n) && n != id)
    return invalid_input(fmt::format("{} is the name of the unnamed surface id {}, not of id {}", quoted(name), n, id));
  return {};
}

std::string sanitize_boundary_name(std::string_view raw) {
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; };
  while (!raw.empty() && blank(raw.front())) raw.remove_prefix(1);
  while (!raw.empty() && blank(raw.back())) raw.remove_suffix(1);
  if (raw.empty()) return {};
  std::string out;
  if (!is_letter(raw[0]) && raw[0] != '_') out += '_';
  for (char c : raw) out += is_name_char(c) ? c : '_';
  if (out.size() > kMaxBoundaryNameLength) out.resize(kMaxBoundaryNameLength);
  return out;
}

Status check_boundary_names(const std::map<int, std::string>& names, std::string_view what) {
  std::map<std::string_view, int> owner;
  for (const auto& [id, name] : names) {
    if (Status s = check_boundary_name(id, name); !s.ok())
      return invalid_input(fmt::format("{}: id {}: {}", what, id, s.message()));
    const auto [it, fresh] = owner.try_emplace(name, id);
    if (!fresh)
      return invalid_input(fmt::format("{}: ids {} and {} are both named '{}'; a name belongs to one id", what,
                                       it->second, id, name));
  }
  return {};
}

Status merge_boundary_names(std::map<int, std::string>& names, const std::vector<int>& ids,
                            const std::map<int, std::string>& extra, std::string_view what) {
  if (extra.empty()) return {};
  std::vector<int> present = ids;
  std::sort(present.begin(), present.end());
  present.erase(std::unique(present.begin(), present.end()), present.end());
  std::map<int, std::string> merged = names;
  for (const auto& [id, name] : extra) {
    if (!std::binary_search(present.begin(), present.end(), id)) {
      const std::size_t shown = std::min<std::size_t>(present.size(), 20);
      return invalid_input(fmt::format("{}: id {} ('{}') is not a surface id here (the ids are {}{})", what, id, name,
                                       fmt::join(present.begin(), present.begin() + static_cast<std::ptrdiff_t>(shown), ", "),
                                       shown < present.size() ? ", ..." : ""));
    }
    if (is_default_boundary_name(id, name)) {
      merged.erase(id);
    } else {
      merged[id] = name;
    }
  }
  PDR_TRY(check_boundary_names(merged, what));
  names = std::move(merged);
  return {};
}

}  // namespace pdrmesh
