// main.cpp — the palpate command: run, info, precompute, reference.
#include <palpate/palpate.h>

#include "commands.h"

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <cstring>

int main(int argc, char** argv) {
  CLI::App app{"palpate: real-time soft-tissue deformation with force feedback"};
  app.set_version_flag("--version", std::string("palpate ") + palpate::version());
  app.require_subcommand(1);
  app.footer("Run `palpate COMMAND --help` for a command's options. Docs: docs/ in the source tree.");
  palpate::cli::add_run_command(app);
  palpate::cli::add_info_command(app);
  palpate::cli::add_precompute_command(app);
  palpate::cli::add_view_command(app);
  CLI::App* ref = app.add_subcommand(
      "reference", "Print the reference of every scene-file key (type, unit, default, range)");
  ref->callback([] { fmt::print("{}", palpate::scene_reference_markdown()); });

  // CLI11 reports an unknown command only as "a subcommand is required": name it instead.
  if (argc > 1 && argv[1][0] != '-') {
    bool known = false;
    std::string names;
    for (const CLI::App* sub : app.get_subcommands({})) {
      known = known || sub->get_name() == argv[1];
      names += (names.empty() ? "" : ", ") + sub->get_name();
    }
    if (!known) {
      fmt::print(stderr, "palpate: unknown command '{}' (commands: {}; see palpate --help)\n",
                 argv[1], names);
      return 2;
    }
  }
  CLI11_PARSE(app, argc, argv);
  return 0;
}
