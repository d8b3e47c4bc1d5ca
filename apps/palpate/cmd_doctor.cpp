// cmd_doctor.cpp — `palpate doctor`: what a lab needs before its first trainee, checked on this
// machine, each line with what to do when it fails: the CPU and the vector units the models use,
// real-time priority and locked memory for the haptic thread, the device libraries (OpenHaptics'
// libHD.so, whether the device opens; Force Dimension's libdhd and how many devices it sees), a
// display for `palpate view`,
// gnuplot for the plots, and the predictor cache.
#include <palpate/palpate.h>

#include "commands.h"

#include <fmt/core.h>

#include <dlfcn.h>
#include <link.h>
#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

namespace palpate::cli {

namespace {

enum class Verdict { ok, warn, fail };

struct Report {
  bool quiet = false;  // only what failed or warns
  int failures = 0, warnings = 0;
  void line(Verdict v, const std::string& what, const std::string& detail, const std::string& what_to_do = {}) {
    failures += v == Verdict::fail;
    warnings += v == Verdict::warn;
    if (quiet && v == Verdict::ok) return;
    const char* tag = v == Verdict::ok ? "ok  " : v == Verdict::warn ? "warn" : "FAIL";
    fmt::print("{} {:<14} {}\n", tag, what, detail);
    if (v != Verdict::ok && !what_to_do.empty()) fmt::print("     {:<14} -> {}\n", "", what_to_do);
  }
};

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string l; std::getline(in, l);)
    if (l.rfind("model name", 0) == 0) {
      const size_t c = l.find(':');
      return c == std::string::npos ? l : l.substr(c + 2);
    }
  return "unknown";
}

std::string limit_text(rlim_t v) { return v == RLIM_INFINITY ? "unlimited" : std::to_string(v); }

// Whether a thread of this process may take SCHED_FIFO at the haptic loop's priority.
bool fifo_allowed(int priority, int& error) {
  bool ok = false;
  std::thread t([&] {
    sched_param p{};
    p.sched_priority = priority;
    error = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
    ok = error == 0;
  });
  t.join();
  return ok;
}

// The file a dlopen'ed library was loaded from.
std::string loaded_path(void* lib, const std::string& fallback) {
  link_map* map = nullptr;
  if (dlinfo(lib, RTLD_DI_LINKMAP, &map) == 0 && map && map->l_name && *map->l_name) return map->l_name;
  return fallback;
}

bool on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::string p = path;
  for (size_t a = 0; a <= p.size();) {
    const size_t b = std::min(p.find(':', a), p.size());
    const std::filesystem::path f = std::filesystem::path(p.substr(a, b - a)) / program;
    if (::access(f.c_str(), X_OK) == 0) return true;
    a = b + 1;
  }
  return false;
}

struct DoctorArgs {
  std::string hd_library = DeviceDef{}.hd_library;
  std::string dhd_library = DeviceDef{}.dhd_library;  // "" = libdhd.so.3, then libdhd.so
  bool open_device = true;
  bool quiet = false, verbose = false;
};

int doctor_command(const DoctorArgs& a) {
  Report r;
  r.quiet = a.quiet;
  if (!a.quiet) fmt::print("palpate {}\n", version());

  // The CPU and the kernels palpate picks on it (docs/models/mass-spring.md).
  const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  const bool avx512 = avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl");
  r.line(Verdict::ok, "cpu", fmt::format("{} ({} logical cores)", cpu_model(), std::thread::hardware_concurrency()));
  r.line(avx2 ? Verdict::ok : Verdict::warn, "vector units",
         avx512 ? "AVX-512 (F, VL) and AVX2 + FMA: the spring kernels' widest paths"
         : avx2 ? "AVX2 + FMA (no AVX-512): the spring kernels' AVX2 paths"
                : "SSE2 only: the spring kernels' scalar paths",
         "a large mass-spring organ may miss the 1 ms tick here; see docs/BENCHMARKS.md for the figures per path");

  // Real time: the haptic thread asks for SCHED_FIFO (priority 80) and the process locks its memory.
  rlimit rt{}, mem{};
  getrlimit(RLIMIT_RTPRIO, &rt);
  getrlimit(RLIMIT_MEMLOCK, &mem);
  int err = 0;
  const bool fifo = fifo_allowed(80, err);
  r.line(fifo ? Verdict::ok : Verdict::warn, "realtime",
         fifo ? fmt::format("SCHED_FIFO at priority 80 granted (RLIMIT_RTPRIO {})", limit_text(rt.rlim_cur))
              : fmt::format("SCHED_FIFO refused ({}; RLIMIT_RTPRIO {})", std::strerror(err), limit_text(rt.rlim_cur)),
         "allow it: a line `@USERGROUP - rtprio 95` in /etc/security/limits.d/palpate.conf and log in again, or "
         "`sudo setcap cap_sys_nice+ep $(command -v palpate)`; without it the 1 kHz loop runs at normal priority "
         "and misses deadlines on a busy machine");
  const bool lock_all = mem.rlim_cur == RLIM_INFINITY;
  r.line(lock_all ? Verdict::ok : Verdict::warn, "locked memory",
         fmt::format("RLIMIT_MEMLOCK {}{}", limit_text(mem.rlim_cur), lock_all ? "" : " bytes: mlockall is refused"),
         "raise it: `@USERGROUP - memlock unlimited` in /etc/security/limits.d/palpate.conf; without it a page "
         "fault to disk can stall the haptic thread");

  // OpenHaptics (Phantom Omni, Geomagic Touch).
  void* hd = ::dlopen(a.hd_library.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!hd) {
    const char* why = ::dlerror();
    r.line(Verdict::warn, "openhaptics", fmt::format("'{}' not found ({})", a.hd_library, why ? why : "?"),
           "install OpenHaptics for Linux and the Touch device driver (3D Systems), or give its path: "
           "`palpate doctor --hd-library /path/to/libHD.so` and device.hd_library in the scene; the scripted "
           "and replay devices need neither");
  } else {
    r.line(Verdict::ok, "openhaptics", "found " + loaded_path(hd, a.hd_library));
    ::dlclose(hd);
    if (a.open_device) {
      auto device = open_openhaptics(a.hd_library, "", DeviceLimits{});
      if (device) {
        // Read one pose through the servo loop; the device closes when it goes out of scope.
        DeviceState st;
        bool read = false;
        for (int i = 0; i < 200 && !read; ++i) {
          read = (*device)->read(0.0, st);
          if (!read) std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        (*device)->write(Vec3::Zero(), Vec3::Zero());
        r.line(read ? Verdict::ok : Verdict::fail, "  device",
               read ? fmt::format("the default HD device opens; stylus at ({:.1f}, {:.1f}, {:.1f}) mm",
                                  st.position.x() * 1e3, st.position.y() * 1e3, st.position.z() * 1e3)
                    : "the default HD device opens but its servo loop gave no pose in 1 s",
               "check the device in the vendor's Touch Diagnostic and run doctor again");
        const Calibration c = (*device)->calibration();
        r.line(c == Calibration::unknown ? Verdict::warn : Verdict::ok, "  calibration",
               c == Calibration::ok        ? "calibrated (hdCheckCalibration)"
               : c == Calibration::updated ? "was out of date; updated by the HD library (hdUpdateCalibration)"
                                           : "unknown: this HD library has no hdCheckCalibration",
               "check it in the vendor's Touch Diagnostic before a session: a device out of calibration puts "
               "the tool off where the hand is");
      } else {
        r.line(Verdict::fail, "  device", device.error().message,
               "connect and power the device, check it in the vendor's Touch Setup and Touch Diagnostic, "
               "then run doctor again");
      }
    }
  }
  // Force Dimension (omega.x, sigma.7, delta.x, Novint Falcon): the library and how many devices
  // it sees. No device is opened: opening one that is not calibrated moves its arm (drdAutoInit).
  const ForceDimensionProbe fd = probe_forcedimension(a.dhd_library);
  if (!fd.loaded) {
    r.line(Verdict::warn, "forcedimension", fmt::format("the DHD library ({}) not found", fd.library),
           "install the Force Dimension SDK (its lib/ on LD_LIBRARY_PATH, or in /usr/local/lib and `sudo ldconfig`), "
           "or give its path: `palpate doctor --dhd-library /path/to/libdhd.so.3` and device.dhd_library in the "
           "scene; the scripted and replay devices need neither");
  } else {
    r.line(Verdict::ok, "forcedimension",
           fmt::format("found {}{}", fd.library, fd.version.empty() ? "" : " (SDK " + fd.version + ")"));
    const std::string usb =
        "check power and the USB cable; on Linux your user needs access to the device's USB node: install the "
        "udev rule in docs/haptics.md (\"Force Dimension devices\": /etc/udev/rules.d/60-palpate-forcedimension.rules, "
        "then `sudo udevadm control --reload` and plug it in again), or run as root";
    if (fd.devices > 0)
      r.line(Verdict::ok, "  devices", fmt::format("{} Force Dimension device{} connected", fd.devices,
                                                   fd.devices == 1 ? "" : "s"));
    else
      r.line(Verdict::warn, "  devices",
             fd.devices == 0 ? "no Force Dimension device found (none connected, or no access to its USB device)"
                             : fd.error,
             usb);
  }

  // The viewer's window, the run's plots, the predictor cache.
  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  const bool has_display = (display && *display) || (wayland && *wayland);
  r.line(has_display ? Verdict::ok : Verdict::warn, "display",
         has_display ? fmt::format("{} (palpate view opens its window there)", display && *display ? display : wayland)
                     : "no DISPLAY nor WAYLAND_DISPLAY: palpate view cannot open a window",
         "run it in a desktop session, or headless under `xvfb-run -a palpate view ...`; palpate run needs none");
  const bool gnuplot = on_path("gnuplot");
  r.line(gnuplot ? Verdict::ok : Verdict::fail, "gnuplot", gnuplot ? "found (the run's force plots)" : "not on PATH",
         "install it (`sudo apt-get install gnuplot-nox`, scripts/install-deps does): a run without its plots "
         "exits 1");
  const std::filesystem::path cache = default_predictor_cache();
  if (cache.empty()) {
    r.line(Verdict::warn, "cache", "no home directory: predictors are recomputed on every run",
           "set HOME or XDG_CACHE_HOME, or pass --cache DIR to run, view and precompute");
  } else {
    std::error_code ec;
    std::filesystem::create_directories(cache, ec);
    const bool writable = !ec && ::access(cache.c_str(), W_OK) == 0;
    r.line(writable ? Verdict::ok : Verdict::fail, "cache",
           fmt::format("{} {}", cache.string(), writable ? "(writable)" : "cannot be written"),
           "make it writable, or pass --cache DIR to run, view and precompute");
  }
  if (!a.quiet || r.failures + r.warnings > 0) fmt::print("{} failed, {} warnings\n", r.failures, r.warnings);
  return r.failures > 0 ? kExitFailed : kExitOk;
}

}  // namespace

void add_doctor_command(CLI::App& app) {
  auto args = std::make_shared<DoctorArgs>();
  CLI::App* c = app.add_subcommand(
      "doctor", "Check what a lab needs: CPU and vector units, real-time priority, device libraries and "
                "whether the device opens, a display, gnuplot, the predictor cache");
  c->add_option("--hd-library", args->hd_library, "The OpenHaptics HD library to look for (file name or path)")
      ->capture_default_str();
  c->add_option("--dhd-library", args->dhd_library,
                "The Force Dimension DHD library to look for (file name or path; default libdhd.so.3, then libdhd.so)");
  c->add_flag_callback("--no-device-open", [args] { args->open_device = false; },
                       "Only look for the libraries; do not open the device");
  add_output_flags(c, args->quiet, args->verbose);  // --verbose: every check is printed already
  c->callback([args] { throw CLI::RuntimeError(doctor_command(*args)); });
}

}  // namespace palpate::cli
