// SPDX-License-Identifier: AGPL-3.0-or-later
// pdrmesh: the command-line program.
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "exit_codes.hpp"
#include "local_commands.hpp"
#include "options.hpp"
#include "service_commands.hpp"
#include "view_command.hpp"

namespace {

using namespace pdrmesh::cli;

std::vector<std::string> command_names(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* c : app.get_subcommands([](const CLI::App*) { return true; })) names.push_back(c->get_name());
  return names;
}

/// "unknown command 'mesg'; did you mean 'mesh'?" and the commands; exit 64.
int unknown_command(const CLI::App& app, std::string_view word) {
  const std::vector<std::string> names = command_names(app);
  const std::string near = nearest_command(word, names);
  fmt::print(stderr, "pdrmesh: error: unknown command '{}'{}\n", word,
             near.empty() ? std::string() : fmt::format("; did you mean '{}'?", near));
  fmt::print(stderr, "commands: {}\nRun 'pdrmesh --help' for more.\n", fmt::join(names, ", "));
  return kExitUsage;
}

/// `pdrmesh help [CMD]`: the program's or a command's help on stdout.
void add_help_command(CLI::App& app, int& exit_code) {
  auto* cmd = app.add_subcommand("help", "Show the help of pdrmesh or of one command (pdrmesh help mesh).");
  auto name = std::make_shared<std::string>();
  cmd->add_option("COMMAND", *name, "the command");
  cmd->callback([&app, &exit_code, name] {
    // The formatter directly: app.help() would show the selected command's (help's own) help.
    if (name->empty()) {
      fmt::print("{}", app.get_formatter()->make_help(&app, "pdrmesh", CLI::AppFormatMode::Normal));
      return;
    }
    for (const CLI::App* c : app.get_subcommands([](const CLI::App*) { return true; })) {
      if (c->get_name() == *name) {
        fmt::print("{}", c->get_formatter()->make_help(c, "pdrmesh " + *name, CLI::AppFormatMode::Normal));
        return;
      }
    }
    exit_code = unknown_command(app, *name);
  });
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pdrmesh: tetrahedral volume meshes for CFD from closed surface triangulations", "pdrmesh"};
  app.set_version_flag("--version", "pdrmesh " PDRMESH_VERSION);
  app.require_subcommand(1);
  app.footer(help_footer({{"pdrmesh mesh part.stl -o part.vtu", "mesh a closed surface on one core"},
                          {"pdrmesh help run", "the options of one command"}}));
  int exit_code = kExitOk;
  add_local_commands(app, exit_code);
  add_view_command(app, exit_code);
  add_service_commands(app, exit_code);
  add_help_command(app, exit_code);
  // The first word that is not an option names the command: a mistyped one
  // gets a suggestion rather than CLI11's "A subcommand is required".
  if (argc < 2) {
    fmt::print(stderr, "pdrmesh: error: a command is required\ncommands: {}\nRun 'pdrmesh --help' for more.\n",
               fmt::join(command_names(app), ", "));
    return kExitUsage;
  }
  if (argv[1][0] != '-') {
    const std::vector<std::string> names = command_names(app);
    if (std::find(names.begin(), names.end(), argv[1]) == names.end()) return unknown_command(app, argv[1]);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // Usage errors, from parsing or from a command's checks before it reads anything.
    const auto parsed = app.get_subcommands();
    const std::string where = parsed.empty() ? std::string("pdrmesh") : "pdrmesh " + parsed.front()->get_name();
    fmt::print(stderr, "pdrmesh: error: {}\nRun '{} --help' for usage.\n", e.what(), where);
    return kExitUsage;
  }
  return exit_code;
}
