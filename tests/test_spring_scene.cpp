// test_spring_scene.cpp — scene keys of the mass-spring material that reach the model:
// single_precision runs the same organ in float, close to the double run but not identical.
#include <palpate/scene.h>
#include <palpate/tissue.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

namespace {

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// SOFA's liver set-up (data/scenes/liver-springs.yaml) with `extra` added to its material.
palpate::SceneDef liver_scene(const std::string& extra) {
  std::string yaml = read_text(PALPATE_SOURCE_DIR "/data/scenes/liver-springs.yaml");
  const std::string key = "    material:\n";
  const size_t at = yaml.find(key);
  EXPECT_NE(at, std::string::npos);
  yaml.insert(at + key.size(), extra);
  auto scene = palpate::parse_scene(yaml, "liver-springs.yaml", PALPATE_SOURCE_DIR "/data/scenes");
  EXPECT_TRUE(scene.ok()) << scene.error().message;
  return *scene;
}

}  // namespace

TEST(SpringScene, SinglePrecisionKeyRunsTheOrganInFloatCloseToDouble) {
  const auto file = std::filesystem::temp_directory_path() /
                    ("palpate_liver_single_" + std::to_string(::getpid()) + ".predictor");
  std::filesystem::remove(file);
  palpate::SceneDef dbl = liver_scene("");
  palpate::SceneDef sgl = liver_scene("      single_precision: true\n");
  ASSERT_FALSE(dbl.tissues.empty());
  EXPECT_FALSE(dbl.tissues[0].spring.single_precision);
  EXPECT_TRUE(sgl.tissues[0].spring.single_precision);
  // One predictor file serves both: it holds doubles; float is a choice made at load.
  dbl.tissues[0].spring.predictor = sgl.tissues[0].spring.predictor = file.string();
  auto a = palpate::make_tissue(dbl, 0);
  ASSERT_TRUE(a.ok()) << a.error().message;
  sgl.tissues[0].spring.predictor_policy = "require_file";
  auto b = palpate::make_tissue(sgl, 0);
  ASSERT_TRUE(b.ok()) << b.error().message;
  // Sag under gravity for 0.2 s (dt 0.02 as in SOFA's scene), no tool near.
  palpate::ToolState tool;
  tool.tip = palpate::Vec3(100, 100, 100);
  for (int i = 0; i < 10; ++i) {
    tool.time = i * dbl.dt;
    (*a)->step(tool, dbl.dt);
    (*b)->step(tool, sgl.dt);
  }
  palpate::TissueSnapshot sa, sb;
  (*a)->snapshot(sa);
  (*b)->snapshot(sb);
  ASSERT_EQ(sa.points.size(), sb.points.size());
  double max_diff = 0, max_move = 0;
  palpate::SceneDef rest = liver_scene("");
  rest.tissues[0].spring.predictor = file.string();
  auto r = palpate::make_tissue(rest, 0);
  ASSERT_TRUE(r.ok()) << r.error().message;
  palpate::TissueSnapshot s0;
  (*r)->snapshot(s0);
  for (size_t i = 0; i < sa.points.size(); ++i) {
    max_diff = std::max(max_diff, double((sa.points[i] - sb.points[i]).norm()));
    max_move = std::max(max_move, double((sa.points[i] - s0.points[i]).norm()));
  }
  EXPECT_GT(max_move, 1e-4);               // it sagged
  EXPECT_LT(max_diff, 1e-3 * max_move);    // float follows double to well within 0.1 %
  std::filesystem::remove(file);
}
