// SPDX-License-Identifier: AGPL-3.0-or-later
// What a boundary name may be, and the name map's checks.
//
// Names travel to every output format (Gmsh PhysicalNames, SU2 MARKER_TAG,
// CGNS BC names, OpenFOAM patches, FUN3D .mapbc, VTU field data), so a name is
// an identifier all of them take: 1 to 32 characters (CGNS's limit) of
// letters, digits, '_', '-' and '.', starting with a letter or '_'.
// "surface_<n>" is what an unnamed id n is called (boundary_name in
// volume_mesh.hpp): as the name of id n it means no name, and for another id
// it is refused.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "pdrmesh/status.hpp"

namespace pdrmesh {

inline constexpr std::size_t kMaxBoundaryNameLength = 32;

/// True when `name` is "surface_<id>", the name id `id` has without one.
bool is_default_boundary_name(int id, std::string_view name);

/// OK, or invalid_input saying why `name` cannot name id `id` (the message
/// starts with the quoted name).
Status check_boundary_name(int id, std::string_view name);

/// A name from a file that was not written for pdrmesh (an STL solid, an OBJ
/// group, an SU2 tag) made into one: every character outside the allowed set
/// becomes '_', a leading digit, '-' or '.' gets a '_' before it, and the
/// result is cut to kMaxBoundaryNameLength. Empty for an empty (or all-blank) name.
std::string sanitize_boundary_name(std::string_view raw);

/// Every name checked (check_boundary_name) and no name on two ids; `what`
/// leads the message ("names.txt", "job options").
Status check_boundary_names(const std::map<int, std::string>& names, std::string_view what);

/// `extra`'s names put into `names` (replacing an id's name there), for the ids
/// in `ids` alone: an id of `extra` that is not in `ids` is refused (naming
/// the ids there are), and so is a name that ends up on two ids. An entry that
/// is the id's default name removes its name. `what` names where `extra` came
/// from in messages.
Status merge_boundary_names(std::map<int, std::string>& names, const std::vector<int>& ids,
                            const std::map<int, std::string>& extra, std::string_view what);

}  // namespace pdrmesh
