// fake_dhd_client.h — the tests' handle on the fake Force Dimension library (tests/fake_dhd): its
// devices, trajectories and faults, the calls it received and every force that reached its motors,
// through dlsym (the same library instance the backend dlopens).
#pragma once

#include <palpate/core.h>

#include <dlfcn.h>

#include <algorithm>
#include <vector>

namespace palpate::test {

// What reached a fake device's motors in one set call.
struct DhdSent {
  Vec3 force = Vec3::Zero();   // N
  Vec3 torque = Vec3::Zero();  // N·m
  double gripper = 0;          // N
};

struct FakeDhd {
  void* lib = ::dlopen(PALPATE_FAKE_DHD, RTLD_NOW);
  template <class F>
  F get(const char* name) {
    return lib ? reinterpret_cast<F>(::dlsym(lib, name)) : nullptr;
  }
  void (*reset)(int) = get<void (*)(int)>("fake_dhd_reset");
  void (*set_device)(int, int, int, int) = get<void (*)(int, int, int, int)>("fake_dhd_set_device");
  void (*set_motor_limits)(int, double, double, double) =
      get<void (*)(int, double, double, double)>("fake_dhd_set_motor_limits");
  void (*set_trajectory)(int, const double*,
                         int) = get<void (*)(int, const double*, int)>("fake_dhd_set_trajectory");
  void (*set_rotation)(int,
                       const double*) = get<void (*)(int, const double*)>("fake_dhd_set_rotation");
  void (*set_gripper)(int, double,
                      unsigned) = get<void (*)(int, double, unsigned)>("fake_dhd_set_gripper");
  void (*set_sdk_max_force)(int, double) = get<void (*)(int, double)>("fake_dhd_set_sdk_max_force");
  void (*set_timeguard)(int, int) = get<void (*)(int, int)>("fake_dhd_set_timeguard");
  void (*set_velocity_threshold)(int, unsigned) =
      get<void (*)(int, unsigned)>("fake_dhd_set_velocity_threshold");
  void (*set_auto_init_fails)(int, int) = get<void (*)(int, int)>("fake_dhd_set_auto_init_fails");
  void (*fault)(int, int) = get<void (*)(int, int)>("fake_dhd_fault");
  void (*reload_environment)() = get<void (*)()>("fake_dhd_reload_environment");
  int (*calls)(const char*) = get<int (*)(const char*)>("fake_dhd_calls");
  int (*first_call)(const char*) = get<int (*)(const char*)>("fake_dhd_first_call");
  int (*watchdog)(int) = get<int (*)(int)>("fake_dhd_watchdog");
  unsigned (*velocity_threshold)(int) = get<unsigned (*)(int)>("fake_dhd_velocity_threshold");
  int (*watchdog_trips)(int) = get<int (*)(int)>("fake_dhd_watchdog_trips");
  int (*forces_enabled)(int) = get<int (*)(int)>("fake_dhd_forces_enabled");
  int (*refused)(int) = get<int (*)(int)>("fake_dhd_refused");
  int (*saturated)(int) = get<int (*)(int)>("fake_dhd_saturated");
  int (*emulates_button)(int) = get<int (*)(int)>("fake_dhd_emulates_button");
  int (*forces)(int, double*, int) = get<int (*)(int, double*, int)>("fake_dhd_forces");
  double (*sdk_max_force)(char) = get<double (*)(char)>("dhdGetMaxForce");  // counts as a call

  ~FakeDhd() {
    if (lib) ::dlclose(lib);
  }
  // Every set call's record for device i, in order.
  std::vector<DhdSent> sent(int i) {
    std::vector<double> raw(7 * 200000);
    const int n = std::min(forces(i, raw.data(), 200000), 200000);
    std::vector<DhdSent> out(size_t(std::max(0, n)));
    for (size_t k = 0; k < out.size(); ++k) {
      const double* r = raw.data() + 7 * k;
      out[k] = {Vec3(r[0], r[1], r[2]), Vec3(r[3], r[4], r[5]), r[6]};
    }
    return out;
  }
};

// Device types (DHD_DEVICE_*) and faults of the fake.
constexpr int kOmega3 = 33, kOmega7 = 35, kFalcon = 60, kDelta3 = 63, kSigma7 = 104;
constexpr int kFaultNone = 0, kFaultStall = 1, kFaultErrors = 2, kFaultUnplugged = 3;

}  // namespace palpate::test
