// doubles.h — test doubles for the haptics tests: a linear floor tissue (that can stall or offer
// its stiffness), a tissue that records the tool it is handed, adversarial devices (teleports,
// NaN poses, 500 Hz oscillation) and a device that turns.
#pragma once

#include <palpate/device.h>
#include <palpate/haptics.h>
#include <palpate/tissue.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace palpate::test {

// A floor at y = 0 pushing back with stiffness·penetration of a sphere tool (N/m · m).
// `stall`: while true, step() blocks (a physics thread that stalls). `step_sleep`: seconds each
// step sleeps on every `sleep_every`-th step (an overrunning step), up to step `sleep_until`
// (0: all the run). `fail_steps`: steps (1-based) from `fail_from` on that reset the floor and
// report failure (a blow-up recovered inside the step), returning zero force.
class LinearFloor : public Tissue {
 public:
  explicit LinearFloor(double stiffness, std::string name = "floor") : k_(stiffness), name_(std::move(name)) {}
  const std::string& name() const override { return name_; }
  Vec3 step(const ToolState& tool, double) noexcept override {
    while (stall.load(std::memory_order_acquire)) std::this_thread::sleep_for(std::chrono::microseconds(200));
    ++steps_;
    if (sleep_every > 0 && steps_ % sleep_every == 0 && (sleep_until == 0 || steps_ <= sleep_until))
      std::this_thread::sleep_for(std::chrono::duration<double>(step_sleep));
    failed_ = fail_from > 0 && steps_ >= fail_from && steps_ < fail_from + fail_steps;
    if (failed_) {
      force_ = 0;
      return Vec3::Zero();
    }
    const double pen = std::max(0.0, tool.radius - tool.tip.y());
    force_ = k_ * pen;
    return Vec3(0, force_, 0);
  }
  bool last_step_failed() const noexcept override { return failed_; }
  std::span<const std::string> figure_names() const override { return names_; }
  void figures(std::span<double> out) const noexcept override { out[0] = force_; }
  size_t drain_events(std::span<TissueEvent>) noexcept override { return 0; }
  void snapshot(TissueSnapshot&) const override {}
  void reset() noexcept override { force_ = 0; }

  std::atomic<bool> stall{false};
  long sleep_every = 0;
  long sleep_until = 0;
  double step_sleep = 0;
  long fail_from = 0, fail_steps = 0;

 protected:
  double k_;
  double force_ = 0;
  long steps_ = 0;
  bool failed_ = false;
  std::string name_;
  std::vector<std::string> names_ = {"force_N"};
};

// The same floor, offering its exact contact stiffness ∂F/∂x.
class FloorWithJacobian final : public LinearFloor, public ContactJacobianSource {
 public:
  using LinearFloor::LinearFloor;
  bool contact_jacobian(Eigen::Matrix3d& j) const noexcept override {
    j.setZero();
    if (force_ > 0) j(1, 1) = -k_;
    return true;
  }
};

// A device whose position per tick comes from a function of the tick index; every force written
// is kept (sized up front) so a test can check what the hand would have felt.
class FunctionDevice final : public Device {
 public:
  using PoseFn = Vec3 (*)(long tick);
  FunctionDevice(PoseFn fn, double dt, size_t max_ticks, DeviceLimits limits = {})
      : fn_(fn), dt_(dt), limits_(limits) {
    written.reserve(max_ticks + 16);
  }
  const DeviceLimits& limits() const override { return limits_; }
  bool read(double t, DeviceState& out) noexcept override {
    const long tick = std::lround(t / dt_) - 1;
    out.time = t;
    out.position = fn_(tick < 0 ? 0 : tick);
    out.velocity.setZero();
    return true;
  }
  void write(const Vec3& force, const Vec3&) noexcept override {
    if (written.size() < written.capacity()) written.push_back(force);
  }
  std::vector<Vec3> written;

 private:
  PoseFn fn_;
  double dt_;
  DeviceLimits limits_;
};

// A tissue that exerts no force and keeps every ToolState it is stepped with (sized up front, so
// the haptic thread never allocates), or wraps another tissue and records what it is handed.
// The states go into its own `seen`, or into a caller's vector (reserved by the caller) that
// outlives it, e.g. when run_scene owns and destroys the tissue.
class ToolRecorder final : public Tissue {
 public:
  explicit ToolRecorder(size_t max_steps, std::unique_ptr<Tissue> inner = nullptr)
      : seen(own_), inner_(std::move(inner)) {
    seen.reserve(max_steps);
  }
  explicit ToolRecorder(std::vector<ToolState>& sink, std::unique_ptr<Tissue> inner = nullptr)
      : seen(sink), inner_(std::move(inner)) {}
  ToolRecorder(const ToolRecorder&) = delete;
  ToolRecorder& operator=(const ToolRecorder&) = delete;
  const std::string& name() const override { return inner_ ? inner_->name() : name_; }
  Vec3 step(const ToolState& tool, double dt) noexcept override {
    if (seen.size() < seen.capacity()) seen.push_back(tool);
    return inner_ ? inner_->step(tool, dt) : Vec3::Zero();
  }
  std::span<const std::string> figure_names() const override {
    return inner_ ? inner_->figure_names() : std::span<const std::string>();
  }
  void figures(std::span<double> out) const noexcept override {
    if (inner_) inner_->figures(out);
  }
  size_t drain_events(std::span<TissueEvent> out) noexcept override {
    return inner_ ? inner_->drain_events(out) : 0;
  }
  void snapshot(TissueSnapshot& s) const override {
    if (inner_) inner_->snapshot(s);
  }
  void reset() noexcept override {
    if (inner_) inner_->reset();
  }

 private:
  std::vector<ToolState> own_;

 public:
  std::vector<ToolState>& seen;

 private:
  std::unique_ptr<Tissue> inner_;
  std::string name_ = "recorder";
};

// Forwards to a tissue with the tool's axis replaced by a fixed one: the loop as it was before the
// needle followed the device's orientation.
class FixedAxis final : public Tissue {
 public:
  FixedAxis(std::unique_ptr<Tissue> inner, const Vec3& axis) : inner_(std::move(inner)), axis_(axis) {}
  const std::string& name() const override { return inner_->name(); }
  Vec3 step(const ToolState& tool, double dt) noexcept override {
    ToolState fixed = tool;
    fixed.axis = axis_;
    return inner_->step(fixed, dt);
  }
  std::span<const std::string> figure_names() const override { return inner_->figure_names(); }
  void figures(std::span<double> out) const noexcept override { inner_->figures(out); }
  size_t drain_events(std::span<TissueEvent> out) noexcept override { return inner_->drain_events(out); }
  void snapshot(TissueSnapshot& s) const override { inner_->snapshot(s); }
  void reset() noexcept override { inner_->reset(); }

 private:
  std::unique_ptr<Tissue> inner_;
  Vec3 axis_;
};

// A device whose pose per tick comes from a function of the tick index that may also fail the
// read (returns false) or hand out any orientation, NaN included.
class PoseDevice final : public Device {
 public:
  // Fills position and orientation for tick k; returns what read() returns.
  using PoseFn = bool (*)(long tick, Vec3& position, Quat& orientation);
  PoseDevice(PoseFn fn, double dt, DeviceLimits limits = {}) : fn_(fn), dt_(dt), limits_(limits) {}
  const DeviceLimits& limits() const override { return limits_; }
  bool read(double t, DeviceState& out) noexcept override {
    const long tick = std::lround(t / dt_) - 1;
    out.time = t;
    out.velocity.setZero();
    return fn_(tick < 0 ? 0 : tick, out.position, out.orientation);
  }
  void write(const Vec3&, const Vec3&) noexcept override {}

 private:
  PoseFn fn_;
  double dt_;
  DeviceLimits limits_;
};

}  // namespace palpate::test
