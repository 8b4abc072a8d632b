// SPDX-License-Identifier: AGPL-3.0-or-later
// `pdrmesh view MESH -o PICTURE.svg|png`: a picture of a volume mesh's cut (mesh_picture.hpp).
#pragma once

#include <CLI/CLI.hpp>

namespace pdrmesh::cli {

/// Adds the view command to `app`; its callback stores its exit code in `exit_code`.
void add_view_command(CLI::App& app, int& exit_code);

}  // namespace pdrmesh::cli
