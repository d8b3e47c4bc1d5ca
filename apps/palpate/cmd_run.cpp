// cmd_run.cpp — `palpate run SCENE [--out DIR]`.
#include "commands.h"

namespace palpate::cli {
void add_run_command(CLI::App&) {}
void add_info_command(CLI::App&) {}
bool stderr_is_terminal() { return false; }
}  // namespace palpate::cli
