// record.cpp — palpate_golden_record: re-record the golden force traces of the shipped scenes
// (`make golden`). A trace is re-recorded only on purpose: a change meant to change what the hand
// feels says so, and why, in its commit (tests/golden/README.md).
//
//   palpate_golden_record GOLDEN_DIR SCENES_DIR [SCENE.yaml ...]   (no scene named: every one)
#include "golden/trace.h"

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s GOLDEN_DIR SCENES_DIR [SCENE.yaml ...]\n", argv[0]);
    return 2;
  }
  const fs::path golden = argv[1], scenes = argv[2];
  std::vector<std::string> names;
  for (int i = 3; i < argc; ++i) names.push_back(argv[i]);
  if (names.empty())
    for (const auto& e : fs::directory_iterator(scenes))
      if (e.path().extension() == ".yaml") names.push_back(e.path().filename().string());
  fs::create_directories(golden);
  int failed = 0;
  for (const std::string& name : names) {
    auto r = palpate::golden::run_trace(scenes / name);
    std::string error = r.error;
    const fs::path file = golden / (fs::path(name).stem().string() + ".trace.gz");
    if (error.empty()) palpate::golden::write_trace(file, r.trace, error);
    if (!error.empty()) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), error.c_str());
      ++failed;
      continue;
    }
    std::printf("%s: %zu ticks, %zu columns, path %s -> %s (%ju bytes)\n", name.c_str(), r.trace.rows(),
                r.trace.columns.size(), r.trace.path.c_str(), file.c_str(), std::uintmax_t(fs::file_size(file)));
  }
  return failed ? 1 : 0;
}
