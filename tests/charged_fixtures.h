// charged_fixtures.h — patches, tools and presses shared by the charged-particle step tests.
#pragma once

#include <palpate/charged.h>
#include <cmath>
#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace charged_test {

using namespace palpate;

inline constexpr double kDt = 0.001;

inline ChargedModel flat(double w, double spacing = 0.001, ChargedMaterialDef mat = {}, double y = 0) {
  PatchDef p;
  p.width = p.height = w, p.spacing = spacing, p.center = Vec3(0, y, 0);
  auto m = build_charged_patch(p, mat);
  EXPECT_TRUE(m.ok()) << m.error().message;
  return std::move(*m);
}

// The particle whose origin is nearest the patch centre's (x, z).
inline int central_particle(const ChargedModel& m) {
  int best = 0;
  double bd = 1e9;
  for (size_t i = 0; i < m.size(); ++i) {
    const Vec3 o = m.origin(i);
    const double d = std::hypot(o.x() - m.center.x(), o.z() - m.center.z());
    if (d < bd) bd = d, best = int(i);
  }
  return best;
}

inline ChargedHip hip_at(const Vec3& p) {
  ChargedHip h;
  h.position = p;
  return h;
}

inline double max_displacement(const ChargedModel& m, const ChargedState& s) {
  double d = 0;
  for (size_t i = 0; i < m.size(); ++i) d = std::max(d, (s.position(i) - m.origin(i)).norm());
  return d;
}

inline double max_neighbour_distance(const ChargedModel& m, const ChargedState& s) {
  double d = 0;
  std::array<int, 6> nb{};
  for (int i = 0; i < int(m.size()); ++i)
    for (int a = 0, k = m.neighbours_of(i, nb); a < k; ++a)
      d = std::max(d, (s.position(size_t(i)) - s.position(size_t(nb[size_t(a)]))).norm());
  return d;
}

// Press straight down above `at` from `y0` to `y1` in steps of `dy`; the force of every tick.
inline std::vector<Vec3> press(const ChargedModel& m, ChargedState& s, const Vec3& at, double y0, double y1,
                          double dy, std::vector<TissueEvent>* events = nullptr) {
  std::vector<Vec3> fy;
  for (double y = y0; y >= y1; y -= dy) {
    fy.push_back(step(m, s, hip_at(Vec3(at.x(), y, at.z())), kDt, 0));
    TissueEvent ev[8];
    const size_t n = drain_events(s, ev);
    if (events) events->insert(events->end(), ev, ev + n);
  }
  return fy;
}

}  // namespace charged_test
