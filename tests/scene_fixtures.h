// scene_fixtures.h — helpers shared by the scene-loader tests (test_scene.cpp, test_scene_errors.cpp).
#pragma once

#include <palpate/scene.h>
#include "io/scene_params.h"
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <sys/stat.h>

#include <gtest/gtest.h>

namespace scene_test {

using namespace palpate;

namespace fs = std::filesystem;
using palpate::parse_scene;
using palpate::SceneDef;
using palpate::Vec3;

inline const fs::path kTestData = PALPATE_TEST_DATA_DIR "/scenes";

// The error text of a scene that must fail to parse.
inline std::string error_of(const std::string& yaml, const fs::path& base = kTestData) {
  auto r = parse_scene(yaml, "s.yaml", base);
  EXPECT_FALSE(r.ok()) << "parsed, but expected an error:\n" << yaml;
  return r.ok() ? std::string() : r.error().message;
}

inline std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A valid scene's tissues list, appended to scenes that test other sections.
inline const char* const kOneTissue = "tissues:\n  - name: a\n    patch: {}\n";

}  // namespace scene_test
