// main.cpp — the palpate command: run, info, precompute, view, reference, schema.
#include <palpate/palpate.h>

#include "commands.h"

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <cstdio>
#include <cstring>
#include <new>

namespace {

int run_main(int argc, char** argv) {
  CLI::App app{"palpate: real-time soft-tissue deformation with force feedback"};
  app.set_version_flag("--version", std::string("palpate ") + palpate::version() +
                                        "\ncomponents: " + palpate::components());
  app.require_subcommand(1);
  app.footer("Run `palpate COMMAND --help` for a command's options. Docs: docs/ in the source tree.");
  palpate::cli::add_run_command(app);
  palpate::cli::add_info_command(app);
  palpate::cli::add_precompute_command(app);
  palpate::cli::add_view_command(app);
  palpate::cli::add_doctor_command(app);
  palpate::cli::add_report_command(app);
  CLI::App* ref = app.add_subcommand(
      "reference", "Print the reference of every scene-file key (type, unit, default, range)");
  ref->callback([] { fmt::print("{}", palpate::scene_reference_markdown()); });
  CLI::App* schema = app.add_subcommand(
      "schema", "Print the JSON Schema (draft 2020-12) of scene files, for editors and validators");
  schema->callback([] { fmt::print("{}", palpate::scene_json_schema()); });

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
      return palpate::cli::kExitUsage;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // a command's own status (each command's callback throws it)
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);  // prints the help; 0
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // CLI11's own codes (104–114) are internal: a wrong command line is a usage error, 2, after
    // CLI11's message (which names the option and what it expected).
    app.exit(e);
    return palpate::cli::kExitUsage;
  }
  return palpate::cli::kExitOk;
}

}  // namespace

// Out of memory is an error with a message, never an abort: what a scene asks for is estimated
// and refused at load where it can be (docs/scene-format.md), and what slips through ends here.
int main(int argc, char** argv) {
  try {
    return run_main(argc, argv);
  } catch (const std::bad_alloc&) {
    std::fputs("palpate: out of memory: the scene needs more memory than this machine (or its limit, "
               "ulimit -v) gives; make it smaller (a coarser spacing, fewer waypoints, a shorter "
               "duration) and run again\n",
               stderr);
    return palpate::cli::kExitOutOfMemory;
  }
}
