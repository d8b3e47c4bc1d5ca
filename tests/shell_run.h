// shell_run.h — tests that run a command line (the palpate CLI, xvfb-run, ...) and look at what it
// printed and how it exited.
#pragma once

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <sys/wait.h>

namespace palpate::test {

struct Ran {
  int code = -1;    // exit status; -1 when it did not exit normally or could not start
  std::string out;  // stdout and stderr together
};

// Run `command` with /bin/sh, stdin from /dev/null.
inline Ran shell_run(const std::string& command) {
  Ran r;
  FILE* p = popen((command + " 2>&1 </dev/null").c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  size_t n = 0;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// The palpate command (PALPATE_CLI, the test binary's definition) with `args`.
inline Ran run_cli(const std::string& args) { return shell_run(std::string(PALPATE_CLI) + " " + args); }

// A file's whole contents, bytes as they are ("" when it cannot be read).
inline std::string read_file(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

}  // namespace palpate::test
