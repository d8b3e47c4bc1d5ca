// test_faults.cpp — faults around a run: `palpate run` killed (SIGKILL) at seeded random moments,
// headless and realtime, leaves every output whole or absent; a predictor left by a killed
// `palpate precompute` is never loaded half-written; an unwritable output directory is a clear
// error naming it; a device that stops answering, answers late or reads NaN has the force head to
// zero on the tick it is noticed.
#include <palpate/device.h>
#include <palpate/haptics.h>
#include <palpate/scene.h>
#include <palpate/tissue.h>
#include <palpate/tissue_files.h>

#include "haptics/doubles.h"
#include "run_csv_rows.h"
#include "haptics/fake_hd_client.h"
#include "components.h"
#include "shell_run.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using palpate::Vec3;
using palpate::test::LinearFloor;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Start `argv` (argv[0] the program), stdout and stderr to /dev/null; its pid.
pid_t spawn(const std::vector<std::string>& args) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int null = ::open("/dev/null", O_RDWR);
    ::dup2(null, 0), ::dup2(null, 1), ::dup2(null, 2);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

// Run to the end; seconds it took, and its exit status in `code`.
double run_to_end(const std::vector<std::string>& args, int& code) {
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = spawn(args);
  int status = 0;
  ::waitpid(pid, &status, 0);
  code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Start it and SIGKILL it after `seconds`; false when it had already ended by itself.
bool run_and_kill(const std::vector<std::string>& args, double seconds) {
  const pid_t pid = spawn(args);
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  int status = 0;
  while (std::chrono::steady_clock::now() < until) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return WIFSIGNALED(status);
}

// Whether `file` is a whole PNG: the signature first and the IEND chunk last.
bool whole_png(const fs::path& file) {
  const std::string b = slurp(file);
  static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  static const unsigned char end[12] = {0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82};
  return b.size() >= 20 && std::memcmp(b.data(), sig, 8) == 0 && std::memcmp(b.data() + b.size() - 12, end, 12) == 0;
}

// The rows of a recording: each whole (the header's column count, ending in a newline), ticks
// consecutive from 0 (column 9). Returns how many; -1 (and a test failure) when one is not.
long whole_consecutive_rows(const fs::path& csv) {
  const std::string text = slurp(csv);
  if (text.empty()) return 0;  // opened, nothing written yet
  EXPECT_EQ(text.back(), '\n') << csv << ": ends in a torn row";
  std::istringstream in(text);
  std::string header, line;
  std::getline(in, header);
  const auto columns = std::count(header.begin(), header.end(), ',');
  long rows = 0;
  while (std::getline(in, line)) {
    if (std::count(line.begin(), line.end(), ',') != columns) {
      ADD_FAILURE() << csv << ": row " << rows << " is not whole: " << line;
      return -1;
    }
    size_t at = 0;
    for (int c = 0; c < 8; ++c) at = line.find(',', at) + 1;
    if (std::stol(line.substr(at)) != rows) {
      ADD_FAILURE() << csv << ": row " << rows << " has tick " << line.substr(at, 10);
      return -1;
    }
    ++rows;
  }
  return rows;
}

struct KillOutcome {
  bool csv = false, part = false, summary = false;
  size_t pngs = 0, temporaries = 0;
};

// After a kill: every output whole or absent. run.csv all `ticks` rows; else run.csv.part whole
// rows only; summary.json parses, says `ticks` and names outputs that are there and whole; each
// PNG whole. Temporary files (.part, .tmp-) may be left; a later run clears them.
KillOutcome expect_whole_or_absent(const fs::path& out, long ticks, const std::string& what) {
  KillOutcome k;
  if (!fs::exists(out)) return k;
  k.csv = fs::exists(out / "run.csv");
  k.part = fs::exists(out / "run.csv.part");
  if (k.csv) {
    EXPECT_EQ(whole_consecutive_rows(out / "run.csv"), ticks) << what;
  } else if (k.part) {
    EXPECT_GE(whole_consecutive_rows(out / "run.csv.part"), 0) << what;
  }
  k.summary = fs::exists(out / "summary.json");
  if (k.summary) {
    nlohmann::json j;
    EXPECT_NO_THROW(j = nlohmann::json::parse(slurp(out / "summary.json"))) << what;
    EXPECT_EQ(j.value("ticks", -1L), ticks) << what;
    EXPECT_FALSE(j.value("interrupted", true)) << what;
    EXPECT_TRUE(k.csv) << what << ": summary.json without run.csv";
    for (const auto& p : j["outputs"]["plots"]) EXPECT_TRUE(whole_png(out / p.get<std::string>())) << what << ": " << p;
    for (const auto& f : j["outputs"]["frames"]) EXPECT_TRUE(whole_png(out / f["file"].get<std::string>())) << what;
  }
  for (const auto& e : fs::directory_iterator(out)) {
    const std::string name = e.path().filename().string();
    if (name.find(".tmp") != std::string::npos || name.ends_with(".part")) {
      ++k.temporaries;
      continue;
    }
    if (name.ends_with(".png")) {
      ++k.pngs;
      EXPECT_TRUE(whole_png(e.path())) << what << ": " << name << " is not a whole PNG";
    }
  }
  return k;
}

// A short scene: a sphere pressing a small charged patch and releasing.
fs::path short_scene(const std::string& name, double duration) {
  const fs::path p = fs::temp_directory_path() / (name + ".yaml");
  std::ofstream(p) << "name: " << name << "\nduration: " << duration << "\ndt: 0.001\n"
                   << "tool: {kind: sphere, radius: 0.003}\n"
                   << "device:\n  waypoints:\n    - {t: 0, position: [0, 0.006, 0]}\n"
                   << "    - {t: " << duration / 2 << ", position: [0, -0.002, 0]}\n"
                   << "    - {t: " << duration << ", position: [0, 0.006, 0]}\n"
                   << "tissues:\n  - name: patch\n"
                   << "    patch: {width: 0.02, height: 0.02, spacing: 0.001}\n"
                   << "    material: {max_displacement: 0.01, particle_radius: 0, puncture_force: 5}\n";
  return p;
}

}  // namespace

namespace {
// Empty `dir` for the next run. A killed run's gnuplot outlives it and may still be writing its
// `.part` PNG there for a moment (seen on a fresh Debian root: "Directory not empty"): retry.
void remove_all_when_quiet(const fs::path& dir) {
  for (int i = 0; i < 100; ++i) {
    std::error_code ec;
    fs::remove_all(dir, ec);
    if (!ec) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  fs::remove_all(dir);
}
}  // namespace

// SIGKILL at 24 seeded random moments of `palpate run` (12 headless, 12 realtime; with plots and
// frames): every output is whole or absent, and the recording holds whole, consecutive rows.
TEST(Faults, RunKilledAtRandomMomentsLeavesEveryOutputWholeOrAbsent) {
  PALPATE_NEEDS_CLI();
  std::mt19937 rng(23);
  size_t kills = 0, with_csv = 0, with_part = 0, with_summary = 0, pngs = 0;
  for (const bool realtime : {false, true}) {
    const double duration = realtime ? 0.6 : 2.0;
    const long ticks = std::lround(duration / 0.001);
    const fs::path scene = short_scene(realtime ? "palpate_faults_rt" : "palpate_faults_headless", duration);
    const fs::path out = fs::temp_directory_path() / "palpate_test_faults_kill";
    std::vector<std::string> args = {PALPATE_CLI, "run", "-q", "--frames", "2", "--out", out.string(), scene.string()};
    if (realtime) args.insert(args.begin() + 2, "--realtime");
    // One run to its end: how long a run takes, and that its outputs are whole.
    remove_all_when_quiet(out);
    int code = -1;
    const double whole = run_to_end(args, code);
    ASSERT_EQ(code, 0);
    const KillOutcome done = expect_whole_or_absent(out, ticks, "unkilled");
    ASSERT_TRUE(done.csv && done.summary);
    EXPECT_EQ(done.pngs, 4u);  // two plots, two frames
    // Kill moments uniform over the run's lifetime; a run that ended first (the shared machine ran
    // it faster) narrows the window. 12 kills per mode, 30 tries at most.
    double window = 0.95 * whole;
    size_t mode_kills = 0;
    for (int tries = 0; tries < 30 && mode_kills < 12; ++tries) {
      remove_all_when_quiet(out);
      const double t = std::uniform_real_distribution<double>(0.0, window)(rng);
      const std::string what = std::string(realtime ? "realtime" : "headless") + " run killed at " + std::to_string(t) + " s";
      if (!run_and_kill(args, t)) {  // it had ended: nothing was killed
        window = std::min(window, 0.9 * t);
        continue;
      }
      ++kills, ++mode_kills;
      const KillOutcome k = expect_whole_or_absent(out, ticks, what);
      with_csv += k.csv, with_part += k.part, with_summary += k.summary, pngs += k.pngs;
    }
  }
  std::printf("[ faults ] %zu kills: run.csv whole %zu, run.csv.part %zu, summary.json %zu, PNGs checked %zu\n",
              kills, with_csv, with_part, with_summary, pngs);
  EXPECT_EQ(kills, 24u);
  EXPECT_GT(with_part, 0u);  // some kills landed in the middle of the recording
}

// `palpate precompute` killed at 10 random moments and (6 tries) while writing its file: the predictor is either
// absent (the run's error names it) or whole (the run loads it); a temporary file a kill leaves,
// and the whole file cut at random lengths, put where the predictor goes, are refused with an
// error naming it, never loaded.
TEST(Faults, PredictorOfAKilledPrecomputeIsNeverLoadedHalfWritten) {
  PALPATE_NEEDS_CLI();
  const fs::path dir = fs::temp_directory_path() / "palpate_test_faults_precompute";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path pred = dir / "sheet.predictor";
  const fs::path scene = dir / "sheet.yaml";
  std::ofstream(scene) << "name: sheet\nduration: 0.01\noutput: out\n"
                       << "tissues:\n  - name: sheet\n    model: mass_spring\n"
                       << "    patch: {width: 0.015, height: 0.015, spacing: 0.001}\n"
                       << "    material: {solver: desbrun, predictor: sheet.predictor, predictor_policy: require_file}\n";
  const std::vector<std::string> args = {PALPATE_CLI, "precompute", "-q", scene.string()};
  auto load = [&]() -> std::string {  // "" when the tissue builds from the file
    auto s = palpate::load_scene(scene);
    if (!s) return s.error().message;
    auto t = palpate::make_tissue(*s, 0);
    return t ? "" : t.error().message;
  };
  int code = -1;
  const double whole = run_to_end(args, code);
  ASSERT_EQ(code, 0);
  ASSERT_EQ(load(), "");
  const auto full_size = fs::file_size(pred);
  std::mt19937 rng(4);
  double window = 0.9 * whole;  // narrowed when a run ends before its kill (a faster machine)
  size_t kills = 0, random_kills = 0, partial_temporaries = 0;
  auto clean = [&] {
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() != ".yaml") fs::remove_all(e.path());
  };
  // After a kill: the predictor absent (the run's error names it) or whole (it loads); a temporary
  // file left behind, put where the predictor goes, is refused unless it was written whole.
  auto after_kill = [&] {
    ++kills;
    const std::string message = load();
    if (fs::exists(pred)) {
      EXPECT_EQ(fs::file_size(pred), full_size);
      EXPECT_EQ(message, "") << "a whole predictor that does not load";
    } else {
      EXPECT_NE(message.find(pred.string()), std::string::npos) << message;
    }
    for (const auto& e : fs::directory_iterator(dir)) {
      if (e.path().string().find(".tmp") == std::string::npos) continue;
      const auto size = fs::file_size(e.path());
      fs::copy_file(e.path(), pred, fs::copy_options::overwrite_existing);
      const std::string m = load();
      if (size < full_size) {
        ++partial_temporaries;
        EXPECT_NE(m, "") << "a predictor cut at " << size << " of " << full_size << " bytes was loaded";
        EXPECT_NE(m.find(pred.string()), std::string::npos) << m;
      } else {
        EXPECT_EQ(m, "");  // written whole before the kill, not yet renamed
      }
    }
  };
  // 10 kills at random moments (30 tries at most).
  for (int tries = 0; tries < 30 && random_kills < 10; ++tries) {
    clean();
    const double t = std::uniform_real_distribution<double>(0.0, window)(rng);
    if (!run_and_kill(args, t)) {
      window = std::min(window, 0.9 * t);
      continue;
    }
    ++random_kills;
    after_kill();
  }
  // 6 tries to kill it while it writes: as soon as its temporary file has some of the bytes.
  for (int i = 0; i < 6; ++i) {
    clean();
    const pid_t pid = spawn(args);
    const std::uintmax_t at = std::uniform_int_distribution<std::uintmax_t>(0, full_size / 2)(rng);
    int status = 0;
    bool reaped = false;
    for (bool seen = false; !seen;) {
      if (::waitpid(pid, &status, WNOHANG) == pid) {
        reaped = true;  // it ended by itself: nothing to kill (its pid may be another's now)
        break;
      }
      for (const auto& e : fs::directory_iterator(dir)) {
        std::error_code ec;
        if (e.path().string().find(".tmp") != std::string::npos && fs::file_size(e.path(), ec) >= at && !ec) seen = true;
      }
    }
    if (!reaped && ::kill(pid, SIGKILL) == 0) {
      ::waitpid(pid, &status, 0);
      if (WIFSIGNALED(status)) after_kill();
    }
  }
  // What a writer killed mid-write would leave under the predictor's own name: refused at any length.
  int code2 = -1;
  run_to_end(args, code2);
  ASSERT_EQ(code2, 0);
  const std::string bytes = slurp(pred);
  size_t cuts = 0;
  for (int i = 0; i < 12; ++i) {
    const size_t at = i == 0 ? 0 : std::uniform_int_distribution<size_t>(1, bytes.size() - 1)(rng);
    std::ofstream(pred, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(at));
    const std::string m = load();
    EXPECT_NE(m.find(pred.string()), std::string::npos) << "cut at " << at << " of " << bytes.size() << ": " << m;
    ++cuts;
  }
  std::printf("[ faults ] precompute killed %zu times, %zu half-written temporaries and %zu cut files refused\n",
              kills, partial_temporaries, cuts);
  EXPECT_EQ(random_kills, 10u);
}

// An output directory that cannot be written: a clear error naming the path, exit status 1 or 2,
// and nothing written there.
TEST(Faults, UnwritableOutputDirectoryIsAClearError) {
  PALPATE_NEEDS_CLI();
  const fs::path base = fs::temp_directory_path() / "palpate_test_faults_unwritable";
  fs::remove_all(base);
  fs::create_directories(base);
  const fs::path scene = short_scene("palpate_faults_unwritable", 0.05);
  // Below a regular file: no directory can be made there (root included).
  std::ofstream(base / "a_file") << "x";
  const fs::path below_file = base / "a_file" / "out";
  palpate::test::Ran r = palpate::test::shell_run(std::string(PALPATE_CLI) + " run -q --out " + below_file.string() + " " + scene.string());
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.code, -1) << "killed by a signal: " << r.out;
  EXPECT_NE(r.out.find(below_file.string()), std::string::npos) << r.out;
  EXPECT_EQ(slurp(base / "a_file"), "x");
  // A directory without write permission (not for root, who may write anywhere).
  if (::geteuid() != 0) {
    const fs::path ro = base / "read_only";
    fs::create_directories(ro);
    ::chmod(ro.c_str(), 0555);
    r = palpate::test::shell_run(std::string(PALPATE_CLI) + " run -q --out " + ro.string() + " " + scene.string());
    ::chmod(ro.c_str(), 0755);
    EXPECT_NE(r.code, 0) << r.out;
    EXPECT_NE(r.out.find(ro.string()), std::string::npos) << r.out;
    EXPECT_TRUE(fs::is_empty(ro));
  }
}

namespace {

using Row = palpate::test::RunRow;
using palpate::test::read_run_rows;

// On every tick marked `fault`, the force heads to zero at the full rate: no larger than the tick
// before less one step (max_force_rate · dt), so it is zero within |F| / step ticks of the first.
// Returns the number of separate runs of such ticks.
size_t expect_faults_head_to_zero(const std::vector<Row>& rows, const std::string& fault, double step) {
  size_t runs = 0;
  for (size_t k = 1; k < rows.size(); ++k) {
    if (rows[k].events.find(fault) == std::string::npos) continue;
    if (rows[k - 1].events.find(fault) == std::string::npos) ++runs;
    EXPECT_LE(rows[k].force.norm(), std::max(0.0, rows[k - 1].force.norm() - step) + 1e-9)
        << fault << " at tick " << rows[k].tick;
    EXPECT_TRUE(rows[k].tool.allFinite()) << "tick " << rows[k].tick;
  }
  return runs;
}

}  // namespace

// The OpenHaptics device stops answering (its servo blocked inside the library for 150 ms), then
// reads NaN positions for 60 ms: each is a device_failed fault (the stall within the 20 ms a pose
// may age), on which the loop's force heads to zero at once; the servo's frames after the stall
// change by at most a frame's rate limit; the loop recovers and presses again.
TEST(Faults, DeviceThatStopsAnsweringOrReadsNaNHasItsForceZeroed) {
  palpate::test::FakeHd hd;
  ASSERT_NE(hd.lib, nullptr) << ::dlerror();
  ASSERT_NE(hd.stall, nullptr);
  hd.reset(1);
  const double pose[3] = {0.0, -2.0, 0.0};  // mm: 3 mm into the floor with a 1 mm sphere, 1.5 N
  hd.set_poses(pose, 1);
  auto d = palpate::open_openhaptics(PALPATE_FAKE_HD, "", {});
  ASSERT_TRUE(d.ok()) << d.error().message;
  LinearFloor floor(500.0);
  const fs::path csv = fs::temp_directory_path() / "palpate_test_faults_device" / "run.csv";
  palpate::LoopSettings s;
  s.max_ticks = 1200;
  s.ramp_in = 0.02;
  s.try_realtime_priority = false;
  s.csv = csv;
  s.watchdog.overrun_margin = 0.015;  // the shared machine's delays are not what is tested here
  auto loop = palpate::HapticLoop::create(**d, {{&floor, 0.0}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  ASSERT_TRUE((*loop)->start());
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const std::uint64_t stall_tick = (*loop)->stats().ticks;
  hd.stall(1);
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  hd.stall(0);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  hd.set_nan_position(1);
  std::this_thread::sleep_for(std::chrono::milliseconds(60));
  hd.set_nan_position(0);
  (*loop)->wait();
  ASSERT_TRUE((*loop)->finish_recording());
  const palpate::LoopStats st = (*loop)->stats();
  const auto rows = read_run_rows(csv);
  ASSERT_EQ(rows.size(), 1200u);
  const double step = 200.0 * 1e-3;
  EXPECT_GE(expect_faults_head_to_zero(rows, "device_failed", step), 2u);
  EXPECT_GT(st.safety.device_failed, 50u);
  // The stall was noticed within the pose's 20 ms (and the shared machine's slack).
  size_t first = 0;
  while (first < rows.size() && rows[first].events.find("device_failed") == std::string::npos) ++first;
  ASSERT_LT(first, rows.size());
  EXPECT_LE(rows[first].tick, long(stall_tick) + 20 + 60) << "stalled at about tick " << stall_tick;
  EXPECT_GE(rows[first].tick, long(stall_tick));
  // Pressing again at the end, at the full 1.5 N.
  EXPECT_NEAR(rows.back().force.y(), 1.5, 1e-9);
  (*loop).reset();
  (*d).reset();
  // What the hand felt: never past the maximum, never faster than the rate per servo frame.
  Vec3 prev = Vec3::Zero();
  for (const Vec3& f : hd.all_forces()) {
    ASSERT_TRUE(f.allFinite());
    ASSERT_LE(f.norm(), 3.3 + 1e-12);
    ASSERT_LE((f - prev).norm(), step + 1e-12);
    prev = f;
  }
}

namespace {

// A device that answers late: its read blocks for 30 ms on ticks 299, 599, 899.
class LateDevice final : public palpate::Device {
 public:
  const palpate::DeviceLimits& limits() const override { return lim_; }
  bool read(double t, palpate::DeviceState& out) noexcept override {
    const long tick = std::lround(t / 0.001) - 1;  // the loop reads at t = (tick + 1) dt
    if (tick % 300 == 299 && tick != slept_) {
      slept_ = tick;
      std::this_thread::sleep_for(std::chrono::milliseconds(30));
    }
    out.time = t;
    out.position = Vec3(0, -0.002, 0);
    return true;
  }
  void write(const Vec3&, const Vec3&) noexcept override {}

 private:
  palpate::DeviceLimits lim_;
  long slept_ = -1;
};

}  // namespace

// A device whose read blocks past the tick's deadline: an overrun on that tick, whose force heads
// to zero at once; the loop presses again after.
TEST(Faults, DeviceThatAnswersLateHasItsForceZeroedOnThatTick) {
  LateDevice dev;
  LinearFloor floor(500.0);
  const fs::path csv = fs::temp_directory_path() / "palpate_test_faults_late" / "run.csv";
  palpate::LoopSettings s;
  s.max_ticks = 1000;
  s.ramp_in = 0.02;
  s.try_realtime_priority = false;
  s.csv = csv;
  s.watchdog.overrun_margin = 0.015;
  auto loop = palpate::HapticLoop::create(dev, {{&floor, 0.0}}, s);
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  ASSERT_TRUE((*loop)->start());
  (*loop)->wait();
  ASSERT_TRUE((*loop)->finish_recording());
  const auto rows = read_run_rows(csv);
  ASSERT_EQ(rows.size(), 1000u);
  EXPECT_GE(expect_faults_head_to_zero(rows, "overrun", 0.2), 3u);
  for (long k : {299L, 599L, 899L}) EXPECT_NE(rows[size_t(k)].events.find("overrun"), std::string::npos) << k;
  EXPECT_NEAR(rows.back().force.y(), 1.5, 1e-9);
}
