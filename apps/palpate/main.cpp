// main.cpp — the palpate command: run, info (and, as they land, precompute, view, bench).
#include <palpate/palpate.h>

#include <CLI/CLI.hpp>
#include <fmt/core.h>

int main(int argc, char** argv) {
  CLI::App app{"palpate: real-time soft-tissue deformation with force feedback"};
  app.set_version_flag("--version", std::string("palpate ") + palpate::version());
  app.require_subcommand(1);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
