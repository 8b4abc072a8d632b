// SPDX-License-Identifier: AGPL-3.0-or-later
// Bearer tokens: the tokens file maps each token to its user. One entry per
// line, `user token` separated by blanks; blank lines and lines starting with
// '#' are ignored.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "pdrmesh/status.hpp"

namespace pdrmesh::server {

class TokenTable {
 public:
  /// invalid_input naming file:line for a malformed line or a token used twice;
  /// not_found when the file does not exist.
  static Result<TokenTable> load(const std::filesystem::path& path);
  static Result<TokenTable> parse(std::string_view text, std::string_view name);
  /// The user of `token`; nullopt when unknown. Compares in time independent of
  /// where the first difference is.
  std::optional<std::string> user_for(std::string_view token) const;
  std::size_t size() const { return entries_.size(); }

 private:
  std::vector<std::pair<std::string, std::string>> entries_;  ///< (token, user)
};

/// The token of an `authorization` metadata value "Bearer <token>"; nullopt otherwise.
std::optional<std::string_view> bearer_token(std::string_view authorization);

}  // namespace pdrmesh::server
