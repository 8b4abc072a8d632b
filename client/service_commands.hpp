// SPDX-License-Identifier: AGPL-3.0-or-later
// The subcommands that talk to a pdrmesh coordinator: submit, status, watch,
// fetch, list, cancel, delete. Server, token and TLS CA come from flags, the
// environment (PDRMESH_SERVER, PDRMESH_TOKEN, ...) or the client config file,
// in that order (service_commands.cpp says how).
#pragma once

#include <CLI/CLI.hpp>

namespace pdrmesh::cli {

/// Adds the service subcommands to `app`; each callback stores its exit code in
/// `exit_code`.
void add_service_commands(CLI::App& app, int& exit_code);

}  // namespace pdrmesh::cli
