// commands.h — each subcommand of `palpate` registers itself on the CLI11 app.
#pragma once

#include "exit_codes.h"

#include <CLI/CLI.hpp>

namespace palpate::cli {
void add_run_command(CLI::App& app);
void add_info_command(CLI::App& app);
void add_precompute_command(CLI::App& app);
void add_view_command(CLI::App& app);
void add_doctor_command(CLI::App& app);
// True when standard error is a terminal: progress is shown only then.
bool stderr_is_terminal();
}  // namespace palpate::cli
