// output_flags.cpp — the flags every command shares for how much it prints (--quiet, --verbose),
// and what --verbose prints of a scene: what it loads, and from where.
#include <palpate/palpate.h>

#include "commands.h"

#include <fmt/core.h>

#include <unistd.h>

namespace palpate::cli {

bool stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

void add_output_flags(CLI::App* command, bool& quiet, bool& verbose) {
  CLI::Option* q = command->add_flag("--quiet,-q", quiet, "Print nothing but errors");
  CLI::Option* v = command->add_flag("--verbose,-v", verbose,
                                     "Also print what was loaded from where, and each stage's timing");
  q->excludes(v);
}

namespace {

void print_device(const char* who, const DeviceDef& d) {
  std::string from = d.kind;
  if (d.kind == "scripted")
    from += d.trajectory.empty() ? fmt::format(", {} waypoints", d.waypoints.size())
                                 : ", trajectory " + std::filesystem::absolute(d.trajectory).string();
  else if (d.kind == "replay")
    from += ", recording " + std::filesystem::absolute(d.recording).string();
  else if (d.kind == "openhaptics")
    from += ", library " + d.hd_library;
  else if (d.kind == "forcedimension")
    from += ", library " + (d.dhd_library.empty() ? std::string("libdhd.so.3") : d.dhd_library) +
            (d.dhd_serial > 0 ? fmt::format(", serial {}", d.dhd_serial) : fmt::format(", index {}", d.dhd_index));
  fmt::print("loaded     {} device: {}\n", who, from);
}

}  // namespace

void print_scene_inputs(const SceneDef& scene, const std::filesystem::path& cache) {
  fmt::print("loaded     scene {}\n", scene.file.empty() ? std::string("(from memory)")
                                                          : std::filesystem::absolute(scene.file).string());
  print_device("tool", scene.device);
  if (scene.probe) print_device("probe", scene.probe->device);
  if (scene.grasper) print_device("grasper", scene.grasper->device);
  if (scene.anatomy) fmt::print("loaded     anatomy: the generated neck (docs/cvc.md)\n");
  const std::filesystem::path cache_dir = cache.empty() ? default_predictor_cache() : cache;
  for (const TissueDef& t : scene.tissues) {
    std::string what;
    if (t.mesh)
      what = fmt::format("mesh {} (scale {})", std::filesystem::absolute(t.mesh->file).string(), t.mesh->scale);
    else if (t.patch)
      what = fmt::format("{} patch {} x {} m at {} m spacing", t.patch->shape, t.patch->width, t.patch->height,
                         t.patch->spacing);
    fmt::print("loaded     tissue {} ({}, {}): {}\n", t.name, t.model, t.role, what);
    if (t.model == "mass_spring")
      fmt::print("           predictor {}\n",
                 t.spring.predictor.empty()
                     ? fmt::format("from the cache {} (named by its key; built and kept there when absent)",
                                   cache_dir.empty() ? std::string("(none: no home)") : cache_dir.string())
                     : std::filesystem::absolute(t.spring.predictor).string());
  }
}

}  // namespace palpate::cli
