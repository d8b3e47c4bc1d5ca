// exit_codes.h — the palpate command's exit statuses (README, "Exit statuses"), the same for every
// command; CLI11's own (104–114) never reach the shell.
#pragma once

namespace palpate::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailed = 1;       // a failed run or bad input: a scene, mesh or file refused
inline constexpr int kExitUsage = 2;        // the command line: unknown command or option, a bad value
inline constexpr int kExitOutOfMemory = 3;  // std::bad_alloc past every load-time estimate
// Interrupted: 128 + the signal, 130 for SIGINT (Ctrl-C) and 143 for SIGTERM, outputs written up to
// the last tick.

}  // namespace palpate::cli
