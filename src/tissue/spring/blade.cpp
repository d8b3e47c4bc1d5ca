// blade.cpp — a blade against a mass-spring organ: the springs its edge cuts, the force it feels
// (blade.h; docs/models/cutting.md).
#include "tissue/spring/blade.h"

#include <algorithm>
#include <cmath>

namespace palpate::spring {

namespace {

// Distance from p to the segment [a, b].
double point_segment_distance(const Vec3& p, const Vec3& a, const Vec3& b) noexcept {
  const Vec3 d = b - a;
  const double len2 = d.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (a + t * d - p).norm();
}

}  // namespace

BladeCut::BladeCut(const SpringModel& model, SpringCutter& cutter, const BladeSettings& settings)
    : model_(model), cutter_(cutter), settings_(settings) {
  const SpringNetwork& net = model.network;
  double sum = 0;
  for (double l : net.rest_length) sum += l;
  // A pressing tip parts the springs within half a typical spring of its sphere.
  reach_ = net.rest_length.empty() ? 0.0 : 0.5 * sum / static_cast<double>(net.rest_length.size());
  candidates_.reserve(net.springs.size());
  seen_.assign(net.springs.size(), 0);
}

void BladeCut::reset() noexcept {
  have_prev_ = false;
  cutting_ = false;
  since_cut_ = 1e9;
  last_contact_ = 0;
  out_.setZero();
  depth_ = 0;
}

int BladeCut::cut(const SpringState& s, const ToolState& tool, double dt) noexcept {
  since_cut_ += dt;
  const bool valid = tool.blade && tool.length > 0 && std::isfinite(tool.length) && tool.tip.allFinite() &&
                     tool.axis.allFinite() && tool.axis.norm() > 0.5;
  if (!valid) {
    have_prev_ = false;
    cutting_ = false;
    return 0;
  }
  const Vec3 axis = tool.axis.normalized();
  if (have_prev_ && (tool.tip - prev_tip_).norm() > settings_.max_jump) {
    ++jumps_;  // a teleport: this tick sweeps nothing, the next one starts from here
    have_prev_ = false;
  }
  const bool pressed = last_contact_ >= settings_.cutting_force;
  if (pressed && !cutting_) entry_ = tool.tip;
  // In the organ: once it has started to cut, until the tip is drawn back out past where it went in
  // (a scalpel drawn along its incision cuts what its edge meets).
  const bool in_cut = cutting_ && (tool.tip - entry_).dot(axis) > -settings_.withdrawn;
  cutting_ = pressed || in_cut;
  int removed = 0;
  if (cutting_ && have_prev_) {
    const double r = tool.radius + reach_;
    // The edge reaches r past the tip: what the tip's sphere presses on is under the edge.
    const BladeSweep sweep = blade_sweep(prev_tip_ + r * prev_axis_, prev_axis_, tool.tip + r * axis, axis, tool.length + r);
    Vec3 lo, hi;
    sweep_bounds(sweep, r, lo, hi);
    const Vec3 near = tool.tip + r * axis;
    candidates_.clear();
    const double* x = s.x.data();
    const size_t n = static_cast<size_t>(s.x.rows());
    for (size_t i = 0; i < n; ++i) {
      const double* p = x + 3 * i;
      if (p[0] < lo.x() || p[0] > hi.x() || p[1] < lo.y() || p[1] > hi.y() || p[2] < lo.z() || p[2] > hi.z()) continue;
      for (int q = model_.adjacency_start[i]; q < model_.adjacency_start[i + 1]; ++q) {
        const int e = model_.adjacency[static_cast<size_t>(q)];
        if (seen_[static_cast<size_t>(e)]) continue;
        seen_[static_cast<size_t>(e)] = 1;
        candidates_.push_back(e);
      }
    }
    const auto& gone = cutter_.removed_springs();
    for (int e : candidates_) {
      seen_[static_cast<size_t>(e)] = 0;
      if (gone[static_cast<size_t>(e)]) continue;
      const auto [i, j] = model_.network.springs[static_cast<size_t>(e)];
      const Vec3 a = s.x.row(i).transpose(), b = s.x.row(j).transpose();
      const bool crossed = segment_crosses_sweep(a, b, sweep);
      // Pressed past the cutting force, the tip parts what lies within its reach.
      const bool parted = pressed && (point_segment_distance(near, a, b) < r || point_segment_distance(tool.tip, a, b) < r);
      if (crossed || parted) {
        const int one[] = {e};
        removed += cutter_.remove_springs(one);
      }
    }
  }
  if (removed > 0) {
    since_cut_ = 0;
    cut_ += static_cast<std::uint64_t>(removed);
  }
  if (!cutting_) depth_ = 0;
  else depth_ = std::clamp((tool.tip - entry_).dot(axis), 0.0, tool.length);
  prev_tip_ = tool.tip;
  prev_axis_ = axis;
  have_prev_ = true;
  return removed;
}

Vec3 BladeCut::felt(const Vec3& contact, const ToolState& tool, double dt) noexcept {
  last_contact_ = contact.norm();
  Vec3 want = contact;
  if (cutting_) {
    // The tissue parts at the cutting force: the hand never feels more while it cuts.
    if (last_contact_ > settings_.cutting_force) want *= settings_.cutting_force / last_contact_;
    // The drag of the edge in the organ along its motion, fading to zero below drag_speed.
    const double speed = tool.velocity.norm();
    if (speed > 0 && std::isfinite(speed))
      want -= settings_.drag_per_length * depth_ * std::min(1.0, speed / settings_.drag_speed) * (tool.velocity / speed);
  }
  // While cutting (and on the way out of it) every change is rate-limited: removed springs make the
  // contact force fall in steps of a spring's share; the hand feels a ramp, not grit.
  if (cutting_ || since_cut_ <= settings_.hold_time + 0.1) {
    const Vec3 d = want - out_;
    const double limit = settings_.force_rate * dt;
    out_ = d.norm() > limit ? Vec3(out_ + d * (limit / d.norm())) : want;
  } else {
    out_ = want;
  }
  return out_;
}

}  // namespace palpate::spring
