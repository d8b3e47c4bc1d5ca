// test_plots.cpp — the run's plots: whole PNGs or none. A full disk (here a file-size limit that
// gnuplot inherits) makes gnuplot write a PNG cut short and still exit 0: it is never put in place.
#include "simulation/plots.h"

#include <gtest/gtest.h>

#include <algorithm>
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

// Ordinary runs (up to 200,000 ticks) are plotted from every tick, exactly as given.
TEST(Plots, BuilderKeepsEveryTickOfAnOrdinaryRun) {
  const palpate::PlotSeries in = ramp_series(150000);
  palpate::PlotSeriesBuilder b(in.time.size());
  EXPECT_EQ(b.stride(), 1u);
  for (size_t i = 0; i < in.time.size(); ++i) b.add(in.time[i], in.depth[i], in.force[i], in.axial[i]);
  const palpate::PlotSeries out = b.finish();
  EXPECT_EQ(out.time, in.time);
  EXPECT_EQ(out.depth, in.depth);
  EXPECT_EQ(out.force, in.force);
  EXPECT_EQ(out.axial, in.axial);
}

// A long run (here 10⁷ ticks, an hour at 3.6e8 is the same) is held as a min/max envelope of at
// most 200,000 rows: in time order, every block's smallest and largest |F| and axial force kept, so
// the plot's extremes (a one-tick spike included) are the run's.
TEST(Plots, BuilderHoldsALongRunAsAMinMaxEnvelope) {
  constexpr std::uint64_t kTicks = 10000000;
  palpate::PlotSeriesBuilder b(kTicks);
  EXPECT_EQ(b.stride(), 200u);
  double fmin = 1e300, fmax = -1e300, amin = 1e300, amax = -1e300;
  for (std::uint64_t i = 0; i < kTicks; ++i) {
    const double t = double(i) * 0.001;
    double f = std::sin(t * 0.7) + 1.0 + (i == 4567891 ? 2.5 : 0.0);  // a one-tick spike
    const double a = std::cos(t * 1.3) - (i == 7654321 ? 1.5 : 0.0);
    fmin = std::min(fmin, f), fmax = std::max(fmax, f), amin = std::min(amin, a), amax = std::max(amax, a);
    b.add(t, 1e-6 * double(i % 1000), f, a);
  }
  const palpate::PlotSeries out = b.finish();
  EXPECT_LE(out.time.size(), palpate::PlotSeriesBuilder::kMaxRows);
  EXPECT_GE(out.time.size(), 2 * kTicks / 200);
  EXPECT_TRUE(std::is_sorted(out.time.begin(), out.time.end()));
  EXPECT_EQ(*std::min_element(out.force.begin(), out.force.end()), fmin);
  EXPECT_EQ(*std::max_element(out.force.begin(), out.force.end()), fmax);
  EXPECT_EQ(*std::min_element(out.axial.begin(), out.axial.end()), amin);
  EXPECT_EQ(*std::max_element(out.axial.begin(), out.axial.end()), amax);
  EXPECT_EQ(out.time.front(), 0.0);
  EXPECT_NEAR(out.time.back(), double(kTicks - 1) * 0.001, 0.2);
}

// Issue 35: the labels were written over the puncture's peak (anchored at the top, reading down),
// and the probe's force was missing. Labels now read up from the bottom; a probe's |F| is a series
// of its own, in the data and the force-time plot.
TEST(Plots, LabelsReadUpFromTheBottomAndTheProbesForceIsDrawn) {
  const fs::path dir = fs::temp_directory_path() / "palpate_plots_probe";
  fs::remove_all(dir);
  fs::create_directories(dir);
  palpate::PlotSeriesBuilder b(100);
  for (int i = 0; i < 100; ++i) b.add(i * 0.001, i * 1e-5, i < 50 ? i * 0.02 : 0.2, 0.0, 0.5 + i * 0.01);
  const palpate::PlotSeries s = b.finish();
  ASSERT_EQ(s.probe.size(), s.time.size());
  const std::vector<palpate::RunEvent> events = {{0.049, "puncture", "skin", 0.0, 1.0}};
  std::vector<fs::path> written;
  ASSERT_TRUE(palpate::plot_run(dir, "t", s, events, &written).ok());
  std::ifstream gp(dir / "plots.gp");
  const std::string script((std::istreambuf_iterator<char>(gp)), std::istreambuf_iterator<char>());
  EXPECT_NE(script.find("'puncture skin' at 0.049000, graph 0.03 rotate by 90 left"), std::string::npos) << script;
  EXPECT_EQ(script.find("graph 0.95"), std::string::npos) << script;
  EXPECT_NE(script.find("data using 1:5 with lines"), std::string::npos) << script;
  std::ifstream dat(dir / "force.dat");
  std::string header, first;
  std::getline(dat, header);
  std::getline(dat, first);
  EXPECT_EQ(header, "# time_s depth_mm force_N axial_N probe_force_N");
  EXPECT_EQ(first, "0.000000 0.000000 0.000000 0.000000 0.500000");
  // Without a probe: four columns, no probe line.
  palpate::PlotSeriesBuilder c(10);
  for (int i = 0; i < 10; ++i) c.add(i * 0.001, 0.0, 0.1, 0.0);
  ASSERT_TRUE(c.finish().probe.empty());
  fs::remove_all(dir);
}
