// SPDX-License-Identifier: AGPL-3.0-or-later
// The boundary names file (`--names FILE`): names for the surface ids of a
// format that carries ids but no names (PLY, Medit .mesh, AFLR3 .surf), or
// new names for any input's ids.
//
// One "ID NAME" per line: an integer id and a name (boundary_names.hpp: 1 to
// 32 letters, digits, '_', '-', '.', starting with a letter or '_'). Blank
// lines and everything after '#' are ignored. An id given twice, a name given
// to two ids, a malformed line or a bad name is an error naming file:line.
//   # id  name
//   1     inlet
//   2     outlet
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <string_view>

#include "pdrmesh/status.hpp"

namespace pdrmesh {

/// Parses a names file held in memory; `file` names it in messages.
Result<std::map<int, std::string>> parse_boundary_names(std::string_view text, std::string_view file);

/// Reads and parses a names file.
Result<std::map<int, std::string>> read_boundary_names(const std::filesystem::path& path);

/// The names as a names file (ascending id), which parse_boundary_names reads back.
std::string format_boundary_names(const std::map<int, std::string>& names);

}  // namespace pdrmesh
