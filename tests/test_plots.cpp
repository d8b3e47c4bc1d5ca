// test_plots.cpp — the run's plots: whole PNGs or none. A full disk (here a file-size limit that
// gnuplot inherits) makes gnuplot write a PNG cut short and still exit 0: it is never put in place.
#include "io/plots.h"

#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sys/resource.h>

namespace fs = std::filesystem;

namespace {

palpate::PlotSeries ramp_series(size_t n) {
  palpate::PlotSeries s;
  for (size_t i = 0; i < n; ++i) {
    s.time.push_back(double(i) * 0.001);
    s.depth.push_back(double(i) * 1e-5);
    s.force.push_back(std::sin(double(i) * 0.05) + 1.0);
    s.axial.push_back(std::cos(double(i) * 0.05));
  }
  return s;
}

bool ends_with_iend(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return bytes.size() > 20 && bytes.substr(bytes.size() - 8, 4) == "IEND";
}

}  // namespace

TEST(Plots, WholePngsOrNoneOnAFullDisk) {
  const fs::path dir = fs::temp_directory_path() / "palpate_test_plots_full";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const palpate::PlotSeries s = ramp_series(100);
  std::vector<fs::path> written;
  const palpate::RunEvent ev[] = {{0.05, "puncture", "skin", 0.0005, 1.2}};
  ASSERT_TRUE(palpate::plot_run(dir, "ok", s, ev, &written));  // the control: both whole
  ASSERT_EQ(written.size(), 2u);
  for (const auto& p : written) EXPECT_TRUE(ends_with_iend(p)) << p;
  fs::remove_all(dir);
  fs::create_directories(dir);

  rlimit old{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  auto old_handler = std::signal(SIGXFSZ, SIG_IGN);  // inherited by gnuplot: writes fail, no signal
  rlimit small = old;
  small.rlim_cur = 8000;  // the data and the script fit; a 900x540 PNG does not
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  written.clear();
  const palpate::Status st = palpate::plot_run(dir, "full", s, ev, &written);
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &old), 0);
  std::signal(SIGXFSZ, old_handler);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find(dir.string()), std::string::npos) << st.error().message;
  EXPECT_TRUE(written.empty());
  EXPECT_FALSE(fs::exists(dir / "force_time.png"));
  EXPECT_FALSE(fs::exists(dir / "force_depth.png"));
  for (const auto& e : fs::directory_iterator(dir)) EXPECT_NE(e.path().extension(), ".part") << e.path();
}
