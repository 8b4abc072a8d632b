// SPDX-License-Identifier: AGPL-3.0-or-later
// The subcommands that work on local files in this process.
#pragma once

#include <CLI/CLI.hpp>

namespace pdrmesh::cli {

/// Adds check, mesh, quality, validate and convert to `app`. Each subcommand's
/// callback stores its exit code in `exit_code`.
void add_local_commands(CLI::App& app, int& exit_code);

}  // namespace pdrmesh::cli
