// SPDX-License-Identifier: AGPL-3.0-or-later
// The subcommands that talk to a pdrmesh coordinator: submit, status, watch,
// fetch, list, cancel. Server and token come from --server/--token or the
// environment (PDRMESH_SERVER, PDRMESH_TOKEN).
#pragma once

#include <CLI/CLI.hpp>

namespace pdrmesh::cli {

/// Adds the service subcommands to `app`; each callback stores its exit code in
/// `exit_code`.
void add_service_commands(CLI::App& app, int& exit_code);

}  // namespace pdrmesh::cli
