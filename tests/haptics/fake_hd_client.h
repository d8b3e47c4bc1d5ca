// fake_hd_client.h — the tests' handle on the fake OpenHaptics library (tests/fake_hd): its poses,
// call counts and every force its servo sent, through dlsym; per device by configuration name
// ("Default Device", "Left", "Right") where the name is an argument.
#pragma once

#include <palpate/core.h>

#include <dlfcn.h>

#include <algorithm>
#include <vector>

namespace palpate::test {

struct FakeHd {
  void* lib = ::dlopen(PALPATE_FAKE_HD, RTLD_NOW);
  void (*reset)(int) = nullptr;
  void (*set_poses)(const double*, int) = nullptr;
  void (*set_rotation)(const double*) = nullptr;
  int (*calls)(const char*) = nullptr;
  int (*frame_errors)() = nullptr;
  int (*enabled)(unsigned) = nullptr;
  int (*forces)(double*, int) = nullptr;
  void (*set_max_force)(double) = nullptr;
  void (*stall)(int) = nullptr;
  void (*set_nan_position)(int) = nullptr;
  void (*set_calibration)(unsigned, int) = nullptr;
  int (*update_style)() = nullptr;
  int (*init_while_running)() = nullptr;
  int (*start_while_running)() = nullptr;
  int (*scheduler_running)() = nullptr;
  void (*device_stall)(const char*, int) = nullptr;
  void (*device_fault)(const char*, unsigned, int, long) = nullptr;
  void (*device_set_poses)(const char*, const double*, int) = nullptr;
  void (*device_set_limits)(const char*, double, double) = nullptr;
  int (*device_forces)(const char*, double*, int) = nullptr;
  long (*device_frames)(const char*) = nullptr;
  int (*device_initialised)(const char*) = nullptr;
  int (*device_enabled)(const char*, unsigned) = nullptr;
  template <class F>
  void sym(F& f, const char* name) {
    f = reinterpret_cast<F>(::dlsym(lib, name));
  }
  FakeHd() {
    sym(init_while_running, "fake_hd_init_while_running");
    sym(start_while_running, "fake_hd_start_while_running");
    sym(scheduler_running, "fake_hd_scheduler_running");
    sym(device_stall, "fake_hd_device_stall");
    sym(device_fault, "fake_hd_device_fault");
    sym(device_set_poses, "fake_hd_device_set_poses");
    sym(device_set_limits, "fake_hd_device_set_limits");
    sym(device_forces, "fake_hd_device_forces");
    sym(device_frames, "fake_hd_device_frames");
    sym(device_initialised, "fake_hd_device_initialised");
    sym(device_enabled, "fake_hd_device_enabled");
    set_calibration =
        reinterpret_cast<void (*)(unsigned, int)>(::dlsym(lib, "fake_hd_set_calibration"));
    update_style = reinterpret_cast<int (*)()>(::dlsym(lib, "fake_hd_update_style"));
    stall = reinterpret_cast<void (*)(int)>(::dlsym(lib, "fake_hd_stall"));
    set_nan_position = reinterpret_cast<void (*)(int)>(::dlsym(lib, "fake_hd_set_nan_position"));
    set_max_force = reinterpret_cast<void (*)(double)>(::dlsym(lib, "fake_hd_set_max_force"));
    reset = reinterpret_cast<void (*)(int)>(::dlsym(lib, "fake_hd_reset"));
    set_poses = reinterpret_cast<void (*)(const double*, int)>(::dlsym(lib, "fake_hd_set_poses"));
    set_rotation = reinterpret_cast<void (*)(const double*)>(::dlsym(lib, "fake_hd_set_rotation"));
    calls = reinterpret_cast<int (*)(const char*)>(::dlsym(lib, "fake_hd_calls"));
    frame_errors = reinterpret_cast<int (*)()>(::dlsym(lib, "fake_hd_frame_errors"));
    enabled = reinterpret_cast<int (*)(unsigned)>(::dlsym(lib, "fake_hd_enabled"));
    forces = reinterpret_cast<int (*)(double*, int)>(::dlsym(lib, "fake_hd_forces"));
  }
  ~FakeHd() { ::dlclose(lib); }
  Vec3 last_force() {
    std::vector<double> f(3 * 100000);
    const int n = forces(f.data(), 100000);
    if (n == 0 || n > 100000) return Vec3::Constant(-1);
    return Vec3(f[size_t(n - 1) * 3], f[size_t(n - 1) * 3 + 1], f[size_t(n - 1) * 3 + 2]);
  }
  // Every force the servo sent, in order (to the named device; null: the default one).
  std::vector<Vec3> all_forces(const char* device = nullptr) {
    std::vector<double> f(3 * 200000);
    const int n = std::min(
        device ? device_forces(device, f.data(), 200000) : forces(f.data(), 200000), 200000);
    std::vector<Vec3> out;
    for (int i = 0; i < n; ++i)
      out.emplace_back(f[size_t(i) * 3], f[size_t(i) * 3 + 1], f[size_t(i) * 3 + 2]);
    return out;
  }
};

}  // namespace palpate::test
