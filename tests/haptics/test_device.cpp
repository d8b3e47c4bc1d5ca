// test_device.cpp — the scripted device: interpolation, ends held, needle directions slerped, CSV
// trajectories (with and without directions) and their errors.
#include <palpate/device.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <utility>
#include <vector>
#include <fstream>

using palpate::DeviceState;
using palpate::Quat;
using palpate::ScriptedDevice;
using palpate::Vec3;
using palpate::Waypoint;

TEST(ScriptedDevice, InterpolatesLinearlyAndHoldsEnds) {
  ScriptedDevice d({{0.0, Vec3(0, 0.01, 0)}, {1.0, Vec3(0, -0.01, 0)}, {2.0, Vec3(0.02, -0.01, 0)}}, {}, Vec3(0, -1, 0));
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

// Issue 35: at a waypoint where an advance turns into a withdrawal the device reported the
// withdrawal's velocity on the waypoint's own tick, so the shaft's friction reversed one tick
// early (a 19–23 % drop in the force while still advancing). At a waypoint's time the velocity is
// the segment that ends there; the next tick has the next segment's.
TEST(ScriptedDevice, AtAWaypointTheVelocityIsTheMotionThatBroughtTheToolThere) {
  ScriptedDevice d({{0.0, Vec3(0, 0.01, 0)}, {1.0, Vec3(0, -0.01, 0)}, {1.5, Vec3(0, 0.0, 0)}, {2.0, Vec3(0, 0.0, 0)}},
                   {}, Vec3(0, -1, 0));
  DeviceState s;
  for (int pass = 0; pass < 2; ++pass) {  // forward, then again after a read later in time (the cache rewinds)
    d.read(0.999, s);
    EXPECT_NEAR(s.velocity.y(), -0.02, 1e-15);
    d.read(1.0, s);
    EXPECT_EQ(s.position, Vec3(0, -0.01, 0));  // exactly the waypoint
    EXPECT_NEAR(s.velocity.y(), -0.02, 1e-15) << "still advancing on the waypoint's tick";
    d.read(1.001, s);
    EXPECT_NEAR(s.velocity.y(), 0.02, 1e-15);
    d.read(1.5, s);
    EXPECT_EQ(s.position, Vec3(0, 0, 0));
    EXPECT_NEAR(s.velocity.y(), 0.02, 1e-15) << "still withdrawing on the waypoint's tick";
    d.read(1.75, s);
    EXPECT_EQ(s.velocity, Vec3::Zero());  // holding
    d.read(1.9, s);
  }
}

TEST(ScriptedDevice, PathIsContinuousTickByTick) {
  ScriptedDevice d({{0.0, Vec3::Zero()}, {0.3, Vec3(0, -0.003, 0)}, {0.6, Vec3(0.003, -0.003, 0)}}, {}, Vec3(0, -1, 0));
  DeviceState s;
  Vec3 prev = Vec3::Zero();
  for (int k = 0; k <= 700; ++k) {
    d.read(k * 0.001, s);
    EXPECT_LE((s.position - prev).norm(), 0.003 / 300 * 1.0000001) << k;
    prev = s.position;
  }
}

namespace {
// The needle's direction a device reading gives for a device-frame axis.
Vec3 axis_of(const DeviceState& s, const Vec3& tool_axis) { return palpate::needle_axis(tool_axis, s.orientation); }
double angle(const Vec3& a, const Vec3& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }
}  // namespace

TEST(ScriptedDevice, WaypointDirectionsGiveToolAxesThatFollowThem) {
  // A device-frame axis that is not a coordinate axis, and directions all round, one of them
  // opposite to it (the shortest arc is then any half turn), one waypoint without a direction.
  const Vec3 tool_axis = Vec3(0.2, -1, 0.3).normalized();
  const std::vector<Waypoint> w = {{0.0, Vec3::Zero()},                              // tool_axis
                                   {0.2, Vec3::Zero(), Vec3(1, -1, 0).normalized()},
                                   {0.5, Vec3::Zero(), Vec3(0, 0.2, -1).normalized()},
                                   {0.7, Vec3::Zero()},                              // holds (0,0.2,-1)
                                   {1.0, Vec3::Zero(), -tool_axis},
                                   {1.1, Vec3::Zero(), Vec3(0, 0, 1)}};
  ScriptedDevice d(w, {}, tool_axis);
  // At each waypoint: exactly its direction (inherited where it has none).
  const Vec3 at[] = {tool_axis, w[1].direction, w[2].direction, w[2].direction, -tool_axis, Vec3(0, 0, 1)};
  DeviceState s;
  for (size_t i = 0; i < w.size(); ++i) {
    ASSERT_TRUE(d.read(w[i].t, s));
    EXPECT_NEAR((axis_of(s, tool_axis) - at[i]).norm(), 0.0, 1e-12) << i;
    EXPECT_NEAR(s.orientation.norm(), 1.0, 1e-15) << i;
  }
  d.read(-1.0, s);
  EXPECT_EQ(s.orientation.coeffs(), Quat::Identity().coeffs());  // before the first: identity
  EXPECT_EQ(axis_of(s, tool_axis), tool_axis);
  d.read(5.0, s);
  EXPECT_NEAR((axis_of(s, tool_axis) - Vec3(0, 0, 1)).norm(), 0.0, 1e-12);  // held after the last

  // Between waypoints: the orientation moves along the slerp arc at a constant rate, so its
  // angle from each end is that end's share of the whole; the axis stays unit length.
  for (size_t i = 0; i + 1 < w.size(); ++i) {
    DeviceState a, b;
    d.read(w[i].t, a);
    d.read(w[i + 1].t, b);
    const double whole = a.orientation.angularDistance(b.orientation);
    for (double f : {0.1, 0.25, 0.5, 0.8, 0.95}) {
      d.read(w[i].t + f * (w[i + 1].t - w[i].t), s);
      EXPECT_NEAR(s.orientation.angularDistance(a.orientation), f * whole, 1e-9) << i << " " << f;
      EXPECT_NEAR(s.orientation.angularDistance(b.orientation), (1 - f) * whole, 1e-9) << i << " " << f;
      EXPECT_NEAR(axis_of(s, tool_axis).norm(), 1.0, 1e-15);
      if (i == 2) {
        EXPECT_NEAR((axis_of(s, tool_axis) - w[2].direction).norm(), 0.0, 1e-12);  // held
      }
    }
  }
}

TEST(ScriptedDevice, DirectionsInOnePlaneTurnTheNeedleAlongTheirGreatCircle) {
  // Directions in the plane of the device-frame axis (x-y): every rotation is about z, so the
  // needle sweeps the arc between two directions at a constant angular rate.
  const Vec3 down(0, -1, 0);
  auto dir = [](double deg) { return Vec3(std::sin(deg * M_PI / 180), -std::cos(deg * M_PI / 180), 0); };
  ScriptedDevice d({{0.0, Vec3::Zero(), dir(10)}, {1.0, Vec3::Zero(), dir(70)}, {2.0, Vec3::Zero(), dir(-30)}},
                   {}, down);
  DeviceState s;
  double prev = 10;
  for (int k = 0; k <= 2000; ++k) {
    const double t = k * 0.001;
    ASSERT_TRUE(d.read(t, s));
    const Vec3 a = axis_of(s, down);
    const double deg = std::atan2(a.x(), -a.y()) * 180 / M_PI;
    const double want = t <= 1 ? 10 + 60 * t : 70 - 100 * (t - 1);
    ASSERT_NEAR(a.z(), 0.0, 1e-15) << t;
    ASSERT_NEAR(deg, want, 1e-9) << t;
    ASSERT_LE(std::abs(deg - prev), 0.1 + 1e-9) << t;  // at most 100 deg/s, 1 ms a tick
    prev = deg;
  }
  EXPECT_NEAR(angle(axis_of(s, down), dir(-30)), 0.0, 1e-12);
}

TEST(ScriptedDevice, WithoutDirectionsTheOrientationIsIdentityExactly) {
  ScriptedDevice d({{0.0, Vec3::Zero()}, {1.0, Vec3(0, -0.01, 0)}}, {}, Vec3(0.3, -1, 0));
  DeviceState s;
  for (double t : {0.0, 0.1234, 0.5, 1.0, 3.0}) {
    d.read(t, s);
    EXPECT_EQ(s.orientation.coeffs(), Quat::Identity().coeffs()) << t;
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

TEST(ScriptedDevice, CsvTrajectoryMayCarryDirections) {
  auto p = write_tmp("traj_dir.csv", "t,x,y,z,dx,dy,dz\n0,0,0.01,0,0,-2,0\n0.5,0,0,0\n1,0,-0.01,0,3,0,-4\n");
  auto w = palpate::load_trajectory_csv(p);
  ASSERT_TRUE(w.ok()) << w.error().message;
  ASSERT_EQ(w->size(), 3u);
  EXPECT_EQ((*w)[0].direction, Vec3(0, -1, 0));           // normalised
  EXPECT_EQ((*w)[1].direction, Vec3::Zero());             // none: the device holds the previous one
  EXPECT_NEAR(((*w)[2].direction - Vec3(0.6, 0, -0.8)).norm(), 0.0, 1e-15);
  ScriptedDevice d(*w, {}, Vec3(0, -1, 0));
  DeviceState s;
  d.read(0.75, s);
  EXPECT_NEAR(palpate::needle_axis(Vec3(0, -1, 0), s.orientation).norm(), 1.0, 1e-15);
  d.read(1.0, s);
  EXPECT_NEAR((palpate::needle_axis(Vec3(0, -1, 0), s.orientation) - Vec3(0.6, 0, -0.8)).norm(), 0.0, 1e-12);
}

TEST(ScriptedDevice, CsvDirectionErrorsNameFileAndLine) {
  const std::pair<const char*, const char*> cases[] = {
      {"0,0,0,0\n1,0,0,0,1,0\n", ":2: expected four numbers t,x,y,z (s, m, m, m) or seven t,x,y,z,dx,dy,dz"},
      {"0,0,0,0,1\n", ":1: expected four numbers"},
      {"0,0,0,0,1,0,0,5\n", ":1: expected four numbers"},
      {"0,0,0,0,0,0,0\n", ":1: direction dx,dy,dz is zero; expected a non-zero vector"},
      {"0,0,0,0,nan,0,1\n", ":1: direction dx,dy,dz is NaN or infinite"},
      {"0,0,0,0,0,1,0 oops\n", ":1: unexpected 'oops' after the numbers; expected t,x,y,z or t,x,y,z,dx,dy,dz"},
  };
  for (const auto& [text, want] : cases) {
    auto r = palpate::load_trajectory_csv(write_tmp("bad_dir.csv", text));
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_NE(r.error().message.find(std::string("palpate_test_bad_dir.csv") + want), std::string::npos)
        << r.error().message;
  }
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
