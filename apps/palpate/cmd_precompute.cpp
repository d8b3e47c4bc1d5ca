// cmd_precompute.cpp — `palpate precompute`: build a mass-spring predictor file (issue 5).
#include "commands.h"

namespace palpate::cli {
void add_precompute_command(CLI::App&) {}
}  // namespace palpate::cli
