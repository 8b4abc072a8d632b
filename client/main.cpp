// SPDX-License-Identifier: AGPL-3.0-or-later
// pdrmesh: the command-line program.
#include <CLI/CLI.hpp>

#include "exit_codes.hpp"
#include "local_commands.hpp"
#include "service_commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"pdrmesh: tetrahedral volume meshes for CFD from closed surface triangulations"};
  app.set_version_flag("--version", "pdrmesh " PDRMESH_VERSION);
  app.require_subcommand(1);
  int exit_code = pdrmesh::cli::kExitOk;
  pdrmesh::cli::add_local_commands(app, exit_code);
  pdrmesh::cli::add_service_commands(app, exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : pdrmesh::cli::kExitUsage;
  }
  return exit_code;
}
