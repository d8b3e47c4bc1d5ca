// virtual_device.cpp — VirtualDevice: a pose set by another thread, exchanged without locks.
#include <palpate/device.h>

#include "haptics/triple_buffer.h"

namespace palpate {

struct VirtualDevice::Exchange {
  TripleBuffer<DeviceState> pose;  // producer: set_pose; consumer: the haptic thread
  TripleBuffer<Vec3> force;        // producer: the haptic thread; consumer: force()
};

VirtualDevice::VirtualDevice(DeviceLimits limits) : limits_(limits), x_(std::make_unique<Exchange>()) {
  x_->pose.fill(DeviceState{});
  x_->force.fill(Vec3::Zero());
}

VirtualDevice::~VirtualDevice() = default;

bool VirtualDevice::read(double t, DeviceState& out) noexcept {
  x_->pose.update();
  out = x_->pose.read();
  out.time = t;
  return true;
}

void VirtualDevice::write(const Vec3& force, const Vec3&) noexcept {
  x_->force.write_slot() = force;
  x_->force.publish();
}

void VirtualDevice::set_pose(const DeviceState& state) noexcept {
  x_->pose.write_slot() = state;
  x_->pose.publish();
}

Vec3 VirtualDevice::force() const noexcept {
  // The reader's side of the force buffer belongs to force()'s caller (one thread).
  x_->force.update();
  return x_->force.read();
}

}  // namespace palpate
