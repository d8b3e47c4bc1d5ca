// test_recorder.cpp — the recorder: every row reaches the CSV in order, events are named, and a
// run killed mid-way keeps every whole row up to its last flush.
#include "haptics/recorder.h"

#include <palpate/safety.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <malloc.h>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/resource.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace fs = std::filesystem;

namespace {
std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

TEST(Recorder, EveryRowReachesTheFileInOrder) {
  const fs::path csv = fs::temp_directory_path() / "palpate_test_recorder" / "run.csv";
  fs::remove(csv);
  palpate::RecorderOptions o;
  o.capacity_rows = 1024;
  o.keep_columns = {1};
  auto r = palpate::Recorder::open(csv, {"tick", "t", "events"},
                                   {palpate::ColumnFormat::integer, palpate::ColumnFormat::number,
                                    palpate::ColumnFormat::safety_events},
                                   o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  constexpr int kN = 120000;  // two minutes at 1 kHz, pushed as fast as the writer takes them
  for (int i = 0; i < kN; ++i) {
    const double mask = i % 1000 == 0 ? double(palpate::kEventClamped | palpate::kEventRateLimited) : 0.0;
    const double row[3] = {double(i), (i + 1) * 0.001, mask};
    (*r)->push_wait(row);
  }
  ASSERT_TRUE((*r)->push_event({0.5, "puncture", 0, 0.002, 1.5}));
  ASSERT_TRUE((*r)->close());
  EXPECT_EQ((*r)->dropped(), 0u);
  EXPECT_EQ((*r)->rows_written(), std::uint64_t(kN));
  EXPECT_FALSE(fs::exists(csv.string() + ".part"));
  ASSERT_EQ((*r)->kept(0).size(), size_t(kN));
  EXPECT_EQ((*r)->kept(0).back(), kN * 0.001);
  ASSERT_EQ((*r)->events().size(), 1u);
  EXPECT_STREQ((*r)->events()[0].kind, "puncture");

  std::istringstream in(slurp(csv));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "tick,t,events");
  long expect = 0;
  while (std::getline(in, line)) {
    ASSERT_EQ(std::stol(line), expect) << line;
    if (expect % 1000 == 0)
      ASSERT_EQ(line.substr(line.rfind(',') + 1), "clamped|rate_limited") << line;
    else
      ASSERT_EQ(line.back(), ',') << line;
    ++expect;
  }
  EXPECT_EQ(expect, kN);
}

TEST(Recorder, KilledRunKeepsWholeRowsUpToLastFlush) {
  const fs::path csv = fs::temp_directory_path() / "palpate_test_recorder_kill" / "run.csv";
  fs::remove(csv);
  fs::remove(csv.string() + ".part");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // The child records at 1 kHz until it is killed; it never closes the recorder.
    auto r = palpate::Recorder::open(csv, {"tick", "x"}, {palpate::ColumnFormat::integer});
    if (!r) ::_exit(3);
    for (long i = 0;; ++i) {
      const double row[2] = {double(i), 0.123456789 * double(i)};
      (*r)->push(row);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  const std::string text = slurp(csv.string() + ".part");
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n');  // only whole rows were written
  std::istringstream in(text);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "tick,x");
  long expect = 0;
  while (std::getline(in, line)) {
    long tick = -1;
    double x = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%ld,%lf", &tick, &x), 2) << line;
    ASSERT_EQ(tick, expect++);
  }
  EXPECT_GE(expect, 100);  // ~600 rows pushed, flushed every 100 ms; slack for a loaded machine
}

// A full disk mid-row: the write takes what fits and then fails. The recording is cut back to its
// last whole row (docs/haptics.md promises whole rows), close() names the file, and nothing is
// renamed into place. The full disk is a file-size limit (RLIMIT_FSIZE: the write past it fails
// with EFBIG, after a partial write, as ENOSPC does).
TEST(Recorder, FullDiskKeepsWholeRowsOnly) {
  const fs::path csv = fs::temp_directory_path() / "palpate_test_recorder_full" / "run.csv";
  fs::remove(csv);
  fs::remove(csv.string() + ".part");
  rlimit old{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = old;
  small.rlim_cur = 10007;  // a limit inside a row
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  palpate::RecorderOptions o;
  o.capacity_rows = 256;
  o.flush_period = 0.001;
  auto r = palpate::Recorder::open(csv, {"tick", "t", "x"},
                                   {palpate::ColumnFormat::integer, palpate::ColumnFormat::number,
                                    palpate::ColumnFormat::number},
                                   o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  for (int i = 0; i < 5000; ++i) {
    const double row[3] = {double(i), (i + 1) * 0.001, 0.123456789 * i};
    (*r)->push_wait(row);
  }
  const palpate::Status st = (*r)->close();
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &old), 0);
  std::signal(SIGXFSZ, old_handler);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("run.csv.part: write failed (disk full?)"), std::string::npos)
      << st.error().message;
  EXPECT_FALSE(fs::exists(csv));
  const std::string text = slurp(csv.string() + ".part");
  ASSERT_GT(text.size(), 1000u);
  EXPECT_LE(text.size(), 10007u);
  EXPECT_EQ(text.back(), '\n');
  std::istringstream in(text);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "tick,t,x");
  long expect = 0;
  while (std::getline(in, line)) {
    ASSERT_EQ(std::count(line.begin(), line.end(), ','), 2) << line;
    EXPECT_EQ(std::stol(line.substr(0, line.find(','))), expect++);
  }
  EXPECT_GT(expect, 100);
}

// The kept columns (the plots' series) go to an unlinked temporary file, not to memory: 300,000
// rows of 12 columns (29 MB kept in memory before) leave the heap as it was, and come back from
// the file exactly, in order; no file is left beside the CSV.
TEST(Recorder, KeptColumnsAreStreamedThroughAFileNotHeldInMemory) {
  const fs::path csv = fs::temp_directory_path() / "palpate_test_recorder_kept" / "run.csv";
  fs::remove_all(csv.parent_path());
  palpate::RecorderOptions o;
  o.capacity_rows = 8192;
  for (size_t c = 0; c < 12; ++c) o.keep_columns.push_back(c + 1);
  std::vector<std::string> names = {"tick"};
  // (std::string("c") +: GCC 12 warns falsely, -Wrestrict, on "c" + std::string&&)
  for (int c = 0; c < 12; ++c) names.push_back(std::string("c") + std::to_string(c));
  const size_t heap0 = ::mallinfo2().uordblks;
  auto r = palpate::Recorder::open(csv, names, {palpate::ColumnFormat::integer}, o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  constexpr long kRows = 300000;
  double row[13];
  for (long i = 0; i < kRows; ++i) {
    row[0] = double(i);
    for (int c = 0; c < 12; ++c) row[c + 1] = 0.25 * double(i) + c;
    (*r)->push_wait(row);
  }
  ASSERT_TRUE((*r)->close());
  const double grown = double(::mallinfo2().uordblks) - double(heap0);
  EXPECT_LT(grown, 8e6) << "the heap grew by " << grown << " bytes";  // the ring and buffers, not 29 MB
  EXPECT_EQ((*r)->kept_rows(), std::uint64_t(kRows));
  long k = 0;
  bool exact = true;
  ASSERT_TRUE((*r)->for_each_kept([&](std::span<const double> v) {
    for (int c = 0; c < 12; ++c) exact = exact && v[size_t(c)] == 0.25 * double(k) + c;
    ++k;
  }));
  EXPECT_EQ(k, kRows);
  EXPECT_TRUE(exact);
  EXPECT_EQ((*r)->kept(3).size(), size_t(kRows));  // the whole column, on request
  EXPECT_EQ((*r)->kept(3)[1000], 250.0 + 3);
  for (const auto& e : fs::directory_iterator(csv.parent_path())) EXPECT_EQ(e.path().filename(), "run.csv");
}
