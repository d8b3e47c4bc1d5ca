// cmd_run.cpp — `palpate run SCENE [--out DIR]`: a headless run with the scene's device.
#include <palpate/palpate.h>

#include "commands.h"

#include <fmt/core.h>

#include <cstdio>
#include <unistd.h>

namespace palpate::cli {

bool stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

namespace {

struct RunArgs {
  std::string scene;
  std::string out;
  bool quiet = false;
};

int run_command(const RunArgs& a) {
  auto scene = load_scene(a.scene);
  if (!scene) {
    fmt::print(stderr, "palpate run: {}\n", scene.error().message);
    return 2;
  }
  RunOptions opt;
  if (!a.out.empty()) opt.out = a.out;
  const bool bar = !a.quiet && stderr_is_terminal();
  if (bar) {
    opt.progress = [](double f) {
      const int width = 40, filled = static_cast<int>(f * width);
      fmt::print(stderr, "\r  running [{:<{}}] {:3.0f}%", std::string(size_t(filled), '#'), width,
                 f * 100);
      if (f >= 1.0) fmt::print(stderr, "\n");
    };
  }
  auto result = run_scene(*scene, opt);
  if (!result) {
    fmt::print(stderr, "palpate run: {}\n", result.error().message);
    return 1;
  }
  const RunSummary& s = *result;
  if (!a.quiet) {
    fmt::print("scene      {}\n", scene->name);
    fmt::print("ticks      {} at {} ms\n", s.ticks, s.dt * 1e3);
    fmt::print("step time  median {:.1f} us, p99 {:.1f} us, max {:.1f} us\n", s.step_median * 1e6,
               s.step_p99 * 1e6, s.step_max * 1e6);
    fmt::print("max force  {:.3f} N\n", s.max_force);
    for (const RunEvent& e : s.events)
      fmt::print("event      {:.3f} s  {:<9} {:<12} depth {:.2f} mm  force {:.3f} N\n", e.time,
                 e.kind, e.tissue, e.depth * 1e3, e.force);
    fmt::print("outputs    {}\n           {}\n", s.csv.string(), s.summary_json.string());
  }
  return 0;
}

}  // namespace

void add_run_command(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* run = app.add_subcommand("run", "Run a scene headless at its fixed tick; write run.csv and summary.json");
  run->add_option("scene", args->scene, "Scene file (YAML, see docs/scene-format.md)")
      ->required()->check(CLI::ExistingFile);
  run->add_option("--out,-o", args->out, "Output directory (default: the scene's `output`)");
  run->add_flag("--quiet,-q", args->quiet, "Print nothing but errors");
  run->callback([args] { throw CLI::RuntimeError(run_command(*args)); });
}

}  // namespace palpate::cli
