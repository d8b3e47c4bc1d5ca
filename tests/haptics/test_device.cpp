// test_device.cpp — the scripted device: interpolation, ends held, CSV trajectories and their errors.
#include <palpate/device.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

using palpate::DeviceState;
using palpate::ScriptedDevice;
using palpate::Vec3;
using palpate::Waypoint;

TEST(ScriptedDevice, InterpolatesLinearlyAndHoldsEnds) {
  ScriptedDevice d({{0.0, Vec3(0, 0.01, 0)}, {1.0, Vec3(0, -0.01, 0)}, {2.0, Vec3(0.02, -0.01, 0)}}, {});
  DeviceState s;
  ASSERT_TRUE(d.read(-1.0, s));
  EXPECT_EQ(s.position, Vec3(0, 0.01, 0));
  d.read(0.25, s);
  EXPECT_NEAR(s.position.y(), 0.005, 1e-15);
  EXPECT_NEAR(s.velocity.y(), -0.02, 1e-15);
  d.read(1.5, s);
  EXPECT_NEAR(s.position.x(), 0.01, 1e-15);
  EXPECT_NEAR(s.velocity.x(), 0.02, 1e-15);
  d.read(0.5, s);  // time going back still gives the right segment
  EXPECT_NEAR(s.position.y(), 0.0, 1e-15);
  d.read(5.0, s);
  EXPECT_EQ(s.position, Vec3(0.02, -0.01, 0));
  EXPECT_EQ(s.velocity, Vec3::Zero());
}

TEST(ScriptedDevice, PathIsContinuousTickByTick) {
  ScriptedDevice d({{0.0, Vec3::Zero()}, {0.3, Vec3(0, -0.003, 0)}, {0.6, Vec3(0.003, -0.003, 0)}}, {});
  DeviceState s;
  Vec3 prev = Vec3::Zero();
  for (int k = 0; k <= 700; ++k) {
    d.read(k * 0.001, s);
    EXPECT_LE((s.position - prev).norm(), 0.003 / 300 * 1.0000001) << k;
    prev = s.position;
  }
}

namespace {
std::filesystem::path write_tmp(const std::string& name, const std::string& text) {
  auto p = std::filesystem::temp_directory_path() / ("palpate_test_" + name);
  std::ofstream(p) << text;
  return p;
}
}  // namespace

TEST(ScriptedDevice, LoadsCsvTrajectoryWithHeaderAndComments) {
  auto p = write_tmp("traj.csv", "# a comment\nt,x,y,z\n0,0,0.01,0\n1,0,-0.01,0\n");
  auto w = palpate::load_trajectory_csv(p);
  ASSERT_TRUE(w.ok()) << w.error().message;
  ASSERT_EQ(w->size(), 2u);
  EXPECT_EQ((*w)[1].position, Vec3(0, -0.01, 0));
}

TEST(ScriptedDevice, CsvErrorsNameFileAndLine) {
  auto bad = write_tmp("bad.csv", "t,x,y,z\n0,0,0,0\n0.5,1,2\n");
  auto r = palpate::load_trajectory_csv(bad);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("palpate_test_bad.csv:3:"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("t,x,y,z"), std::string::npos);

  auto back = write_tmp("back.csv", "0,0,0,0\n1,0,0,0\n0.5,0,0,0\n");
  r = palpate::load_trajectory_csv(back);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find(":3: time 0.5"), std::string::npos) << r.error().message;

  auto nan = write_tmp("nan.csv", "0,0,nan,0\n");
  r = palpate::load_trajectory_csv(nan);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find(":1:"), std::string::npos) << r.error().message;

  r = palpate::load_trajectory_csv("/nonexistent/traj.csv");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("/nonexistent/traj.csv"), std::string::npos);
}
