// blade.cpp — a blade against a mass-spring organ: the springs its edge cuts, the force it feels
// (blade.h; docs/models/cutting.md).
#include "tissue/spring/blade.h"

#include <algorithm>
#include <cmath>
#include <limits>

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

// The organ's own surface (its triangles before any cut, at rest) near p: the
// mean outward normal (area-weighted) of those whose centroid lies within three spring lengths of
// p, among those with a corner in [lo, hi] — a voxel-like staircase surface averages to its shape;
// false when none is there.
bool BladeCut::surface_normal_near( const Vec3& p, const Vec3& lo, const Vec3& hi) noexcept {
  const double R2 = 36 * reach_ * reach_;  // (reach_ is half a mean spring)
  Vec3 sum = Vec3::Zero();
  const double* x = model_.network.rest.data();  // (the rest shape: the dimple under the tip does not count)
  const size_t n = outer_start_.size() - 1;
  for (size_t i = 0; i < n; ++i) {
    if (outer_start_[i] == outer_start_[i + 1]) continue;
    const double* q = x + 3 * i;
    if (q[0] < lo.x() || q[0] > hi.x() || q[1] < lo.y() || q[1] > hi.y() || q[2] < lo.z() || q[2] > hi.z()) continue;
    for (int k = outer_start_[i]; k < outer_start_[i + 1]; ++k) {
      const auto& t = outer_[static_cast<size_t>(outer_of_[static_cast<size_t>(k)])];
      if (t[0] != static_cast<int>(i)) continue;  // each triangle once: from its first corner
      const RowMat3d& X = model_.network.rest;
      const Vec3 a = X.row(t[0]).transpose(), b = X.row(t[1]).transpose(), c = X.row(t[2]).transpose();
      if (((a + b + c) / 3.0 - p).squaredNorm() < R2) sum += (b - a).cross(c - a);
    }
  }
  if (!(sum.norm() > 0)) return false;
  surface_normal_ = sum.normalized();
  return true;
}

// Where the organ's own surface is over the tip (at rest: the dimple the blade presses and the
// wound's edges do not count): its surface vertices in [lo, hi] near the line through p along
// surface_normal_, averaged with weights (1 − d/R)² of their distance d from it (R three spring
// lengths), so the height moves smoothly as the blade goes along a staircase of elements; into
// `point`, or false (point untouched) when none is near.
bool BladeCut::surface_over(const Vec3& p, const Vec3& lo, const Vec3& hi, Vec3& point) const noexcept {
  const double R = 6 * reach_;  // (reach_ is half a mean spring)
  Vec3 sum = Vec3::Zero();
  double weights = 0;
  const double* x = model_.network.rest.data();
  const size_t n = outer_start_.size() - 1;
  for (size_t i = 0; i < n; ++i) {
    if (outer_start_[i] == outer_start_[i + 1]) continue;
    const double* q = x + 3 * i;
    if (q[0] < lo.x() || q[0] > hi.x() || q[1] < lo.y() || q[1] > hi.y() || q[2] < lo.z() || q[2] > hi.z()) continue;
    const Vec3 v(q[0], q[1], q[2]);
    const Vec3 d = v - p;
    const double off = (d - d.dot(surface_normal_) * surface_normal_).norm();
    if (!(off < R)) continue;
    const double w = (1 - off / R) * (1 - off / R);
    sum += w * v;
    weights += w;
  }
  if (!(weights > 0)) return false;
  point = sum / weights;
  return true;
}

BladeCut::BladeCut(const SpringModel& model, SpringCutter& cutter, const BladeSettings& settings)
    : model_(model), cutter_(cutter), settings_(settings) {
  const SpringNetwork& net = model.network;
  double sum = 0;
  for (double l : net.rest_length) sum += l;
  // A pressing tip parts the springs within half a typical spring of its sphere.
  reach_ = net.rest_length.empty() ? 0.0 : 0.5 * sum / static_cast<double>(net.rest_length.size());
  candidates_.reserve(net.springs.size());
  outer_ = net.triangles;  // (the organ's surface before any cut)
  outer_start_.assign(net.size() + 1, 0);
  for (const auto& t : outer_)
    for (int v : t) ++outer_start_[static_cast<size_t>(v) + 1];
  for (size_t i = 0; i < net.size(); ++i) outer_start_[i + 1] += outer_start_[i];
  outer_of_.resize(static_cast<size_t>(outer_start_.back()));
  std::vector<int> fill(outer_start_.begin(), outer_start_.end() - 1);
  for (size_t k = 0; k < outer_.size(); ++k)
    for (int v : outer_[k]) outer_of_[static_cast<size_t>(fill[static_cast<size_t>(v)]++)] = static_cast<int>(k);
  seen_.assign(net.springs.size(), 0);
}

void BladeCut::reset() noexcept {
  have_prev_ = false;
  cutting_ = false;
  since_cut_ = 1e9;
  since_cutting_ = 1e9;
  last_contact_ = 0;
  surface_point_.setZero();
  surface_normal_ = Vec3::UnitY();
  dimple_ = 0;
  out_.setZero();
  depth_ = 0;
}

int BladeCut::cut(const SpringState& s, const ToolState& tool, double dt) noexcept {
  since_cut_ += dt;
  since_cutting_ += dt;
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
  // The organ's surface under the tip (its own, before any cut), while the blade presses or cuts: how
  // deep the edge is in it.
  // An edge held across the organ (its belly cutting, its tip out beside it: a bed divided under an
  // organ) is as deep as its deepest point: the middle and the heel count when deeper than the tip.
  double belly = -std::numeric_limits<double>::infinity();
  if (pressed || cutting_) {
    const Vec3 heel = tool.tip - tool.length * axis;
    const Vec3 m = Vec3::Constant(tool.radius + 6 * reach_);  // (surface_over reaches 6 reach_ around the line)
    const Vec3 lo = tool.tip.cwiseMin(heel) - m, hi = tool.tip.cwiseMax(heel) + m;
    // The surface's direction where the cut begins; then, each tick, the surface over the tip.
    if (!cutting_ && !surface_normal_near(tool.tip, lo, hi)) surface_normal_ = -axis;
    if (!surface_over(tool.tip, lo, hi, surface_point_) && !cutting_) surface_point_ = tool.tip;
    for (const Vec3& p : {Vec3(0.5 * (tool.tip + heel)), heel}) {
      Vec3 q;
      if (surface_over(p, lo, hi, q)) belly = std::max(belly, (q - p).dot(surface_normal_));
    }
  }
  const double below = std::max((surface_point_ - tool.tip).dot(surface_normal_), belly);
  // The dimple the blade pressed before the tissue parted is not edge in the organ: it springs back
  // up along the blade over relax_time once cut, so the edge's length in the organ grows smoothly.
  dimple_ *= std::exp(-dt / settings_.relax_time);
  // In the organ: once it has started to cut, until the tip is drawn back out of its surface
  // (a scalpel drawn along its incision cuts what its edge meets).
  const bool in_cut = cutting_ && below > -settings_.withdrawn;
  if (pressed && !cutting_) dimple_ = std::max(0.0, below);
  cutting_ = pressed || in_cut;
  int removed = 0;
  if (cutting_ && have_prev_) {
    const double r = tool.radius + reach_;
    // The edge reaches r past the tip: what the tip's sphere presses on is under the edge.
    const BladeSweep sweep = blade_sweep(prev_tip_ + r * prev_axis_, prev_axis_, tool.tip + r * axis, axis, tool.length + r);
    Vec3 lo, hi;
    sweep_bounds(sweep, 2 * r, lo, hi);  // (the lead sweep below reaches r past it)
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
    // Pressed past the cutting force while moving across its own edge, the blade parts what it
    // presses ahead of it: the springs crossing the edge's sweep one reach further along the motion
    // (the surface contact holds what is ahead out of the edge's own sweep).
    Vec3 across = tool.velocity.allFinite() ? Vec3(tool.velocity - tool.velocity.dot(axis) * axis) : Vec3::Zero();
    const bool ahead = pressed && across.norm() > 1e-4;
    BladeSweep lead;
    if (ahead) {
      across.normalize();
      const Vec3 tip = tool.tip + r * axis;
      lead = blade_sweep(tip, axis, tip + r * across, axis, tool.length + r);
    }
    const auto& gone = cutter_.removed_springs();
    for (int e : candidates_) {
      seen_[static_cast<size_t>(e)] = 0;
      if (gone[static_cast<size_t>(e)]) continue;
      const auto [i, j] = model_.network.springs[static_cast<size_t>(e)];
      const Vec3 a = s.x.row(i).transpose(), b = s.x.row(j).transpose();
      const bool crossed = segment_crosses_sweep(a, b, sweep) || (ahead && segment_crosses_sweep(a, b, lead));
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
  // The edge in the organ: how far the tip is below the organ's surface over it, along that
  // surface's outward normal, over the cosine of the edge's angle to it.
  if (!cutting_) {
    depth_ = 0;
  } else {
    const double cosine = std::max(std::abs(axis.dot(surface_normal_)), 0.2);
    depth_ = std::clamp((below - dimple_) / cosine, 0.0, tool.length);
  }
  prev_tip_ = tool.tip;
  prev_axis_ = axis;
  have_prev_ = true;
  return removed;
}

Vec3 BladeCut::felt(const Vec3& contact, const ToolState& tool, double dt) noexcept {
  last_contact_ = contact.norm();
  Vec3 want = contact;
  const double speed = tool.velocity.allFinite() ? tool.velocity.norm() : 0.0;
  if (cutting_ && speed > 0) {
    // While it cuts, the resistance along the blade's motion is the tissue parting — cutting_force
    // (reached over the first cut_speed of motion) plus the drag of the edge in the organ — not the
    // contact's component there, which falls by a whole element's share each time one is removed
    // (grit). Across the motion the contact stays (the wound's walls). Drawn back out of the organ,
    // the blade cuts nothing: the contact alone (the drag is the parting edge's, not friction).
    const Vec3 dir = tool.velocity / speed;
    const bool out = dir.dot(surface_normal_) > 0.5;
    const double parting = out ? 0.0 : settings_.cutting_force * std::min(1.0, speed / settings_.cut_speed);
    const double drag = out ? 0.0 : settings_.drag_per_length * depth_ * std::min(1.0, speed / settings_.drag_speed);
    want = contact - contact.dot(dir) * dir - (parting + drag) * dir;
  } else if (cutting_ && last_contact_ > settings_.cutting_force) {
    want *= settings_.cutting_force / last_contact_;  // held still, pressed: the tissue gives at cutting_force
  }
  // While cutting (and on the way out of it) every change is rate-limited: the wound's walls change
  // by a whole element when one is removed; the hand feels a ramp, not grit. And the parting and
  // drag the blade felt while it cut fade at that rate once it stops (an edge slid out along
  // itself leaves the organ with its drag on).
  if (cutting_) since_cutting_ = 0;
  if (cutting_ || since_cut_ <= settings_.hold_time + 0.1 || since_cutting_ <= settings_.hold_time + 0.1) {
    const Vec3 d = want - out_;
    const double limit = settings_.force_rate * dt;
    out_ = d.norm() > limit ? Vec3(out_ + d * (limit / d.norm())) : want;
  } else {
    out_ = want;
  }
  return out_;
}

}  // namespace palpate::spring
