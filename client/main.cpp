// SPDX-License-Identifier: AGPL-3.0-or-later
// pdrmesh: the command-line program.
#include <CLI/CLI.hpp>

int main(int argc, char** argv) {
  CLI::App app{"pdrmesh: parallel tetrahedral mesh generation"};
  app.set_version_flag("--version", "pdrmesh 0.1.0");
  app.require_subcommand(1);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
