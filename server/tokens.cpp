// SPDX-License-Identifier: AGPL-3.0-or-later
// Loading the tokens file and looking tokens up.
#include "tokens.hpp"

#include <fmt/format.h>

#include <fstream>
#include <iterator>
#include <sstream>

namespace pdrmesh::server {
namespace {

bool equal_constant_time(std::string_view a, std::string_view b) {
  unsigned diff = a.size() == b.size() ? 0U : 1U;
  for (std::size_t i = 0; i < a.size(); ++i) {
    diff |= static_cast<unsigned>(static_cast<unsigned char>(a[i]) ^
                                  static_cast<unsigned char>(i < b.size() ? b[i] : 0));
  }
  return diff == 0;
}

}  // namespace

Result<TokenTable> TokenTable::load(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return not_found(fmt::format("{}: cannot open the tokens file", path.string()));
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parse(text, path.string());
}

Result<TokenTable> TokenTable::parse(std::string_view text, std::string_view name) {
  TokenTable t;
  std::istringstream lines{std::string(text)};
  std::string line;
  for (int n = 1; std::getline(lines, line); ++n) {
    std::istringstream words(line);
    std::string user, token, extra;
    if (!(words >> user) || user[0] == '#') continue;
    if (!(words >> token) || (words >> extra)) {
      return invalid_input(fmt::format("{}:{}: expected 'user token'", name, n));
    }
    if (t.user_for(token)) return invalid_input(fmt::format("{}:{}: this token is already given to a user", name, n));
    t.entries_.emplace_back(std::move(token), std::move(user));
  }
  return t;
}

std::optional<std::string> TokenTable::user_for(std::string_view token) const {
  std::optional<std::string> found;
  for (const auto& [t, user] : entries_) {
    if (equal_constant_time(t, token) && !found) found = user;
  }
  return found;
}

std::optional<std::string_view> bearer_token(std::string_view authorization) {
  constexpr std::string_view kPrefix = "Bearer ";
  if (authorization.substr(0, kPrefix.size()) != kPrefix) return std::nullopt;
  std::string_view token = authorization.substr(kPrefix.size());
  if (token.empty()) return std::nullopt;
  return token;
}

}  // namespace pdrmesh::server
