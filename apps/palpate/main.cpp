// main.cpp — the palpate command: run, info, precompute (view and bench as they land).
#include <palpate/palpate.h>

#include "commands.h"

#include <CLI/CLI.hpp>

int main(int argc, char** argv) {
  CLI::App app{"palpate: real-time soft-tissue deformation with force feedback"};
  app.set_version_flag("--version", std::string("palpate ") + palpate::version());
  app.require_subcommand(1);
  app.footer("Run `palpate COMMAND --help` for a command's options. Docs: docs/ in the source tree.");
  palpate::cli::add_run_command(app);
  palpate::cli::add_info_command(app);
  palpate::cli::add_precompute_command(app);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
