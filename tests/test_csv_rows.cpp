// test_csv_rows.cpp — the one CSV reader of the scripted and replay devices, and palpate's number
// readers under a comma-decimal process locale (an embedding program's): files still read the same.
#include <palpate/device.h>
#include <palpate/scene.h>

#include "io/csv_rows.h"

#include <gtest/gtest.h>

#include <clocale>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <locale>
#include <string>

namespace fs = std::filesystem;
using palpate::Vec3;

namespace {

fs::path write_tmp(const std::string& name, const std::string& text) {
  const fs::path p = fs::temp_directory_path() / ("palpate_test_csvloc_" + name);
  std::ofstream(p) << text;
  return p;
}

// A comma-decimal C locale (de_DE) for this process, built with localedef into a cache directory
// when the system has the locale sources but not the compiled locale; false when neither works.
bool set_comma_decimal_c_locale() {
  for (const char* name : {"de_DE.UTF-8", "de_DE.utf8", "fr_FR.UTF-8", "de_DE"})
    if (std::setlocale(LC_ALL, name)) return true;
  const fs::path dir = fs::temp_directory_path() / "palpate_test_locales";
  if (!fs::exists(dir / "de_DE.UTF-8")) {
    fs::create_directories(dir);
    const std::string cmd = "localedef -i de_DE -f UTF-8 '" + (dir / "de_DE.UTF-8").string() + "' >/dev/null 2>&1";
    if (std::system(cmd.c_str()) != 0 && !fs::exists(dir / "de_DE.UTF-8" / "LC_NUMERIC")) return false;
  }
  ::setenv("LOCPATH", dir.c_str(), 1);
  return std::setlocale(LC_ALL, "de_DE.UTF-8") != nullptr;
}

// The C++ side of an embedding program's locale: ',' as the decimal point in every stream.
struct CommaPoint : std::numpunct<char> {
  char do_decimal_point() const override { return ','; }
  char do_thousands_sep() const override { return '.'; }
  std::string do_grouping() const override { return "\3"; }
};

// Sets a comma-decimal locale for the test's lifetime (C and C++), and puts "C" back.
struct CommaDecimalLocale {
  bool c_locale = false;
  CommaDecimalLocale() {
    c_locale = set_comma_decimal_c_locale();
    std::locale::global(std::locale(std::locale::classic(), new CommaPoint));
  }
  ~CommaDecimalLocale() {
    std::locale::global(std::locale::classic());
    std::setlocale(LC_ALL, "C");
  }
};

}  // namespace

TEST(CsvRows, SplitsAtCommasOrBlanksAndNamesLines) {
  const fs::path p = write_tmp("rows.csv", "# comment\n\n a , b,,c \r\n1 2\t3,4\n");
  auto rows = palpate::io::CsvRows::open(p, "test file");
  ASSERT_TRUE(rows.ok()) << rows.error().message;
  std::vector<std::string_view> f;
  ASSERT_TRUE(rows->next(f));
  EXPECT_EQ(rows->line(), 3);
  ASSERT_EQ(f.size(), 4u);
  EXPECT_EQ(f[0], "a");
  EXPECT_EQ(f[1], "b");
  EXPECT_EQ(f[2], "");
  EXPECT_EQ(f[3], "c");
  ASSERT_TRUE(rows->next(f, /*whitespace_too=*/true));
  EXPECT_EQ(rows->line(), 4);
  ASSERT_EQ(f.size(), 4u);
  EXPECT_EQ(rows->where(), p.string() + ":4: ");
  EXPECT_FALSE(rows->next(f));
  double x = 0;
  EXPECT_TRUE(palpate::io::csv_number(" 1.5e-3 ", x));
  EXPECT_EQ(x, 1.5e-3);
  EXPECT_TRUE(palpate::io::csv_number("+4", x));
  EXPECT_EQ(x, 4.0);
  for (const char* bad : {"1,5", "1.5x", "", "0x10", "1e400"}) EXPECT_FALSE(palpate::io::csv_number(bad, x)) << bad;
  // Not a regular file (a directory, a FIFO): refused by name, never read.
  auto dir = palpate::io::CsvRows::open(fs::temp_directory_path(), "recording");
  ASSERT_FALSE(dir.ok());
  EXPECT_NE(dir.error().message.find("not a regular file"), std::string::npos) << dir.error().message;
}

// An embedding program that set a comma-decimal locale still reads palpate's trajectory,
// recording and scene files with the same numbers (with the C locale set to de_DE, strtod would
// stop at the '.' of 0.01).
TEST(CsvRows, NumbersReadTheSameUnderACommaDecimalLocale) {
  const fs::path traj = write_tmp("traj.csv", "t,x,y,z\n0,0,0.01,0\n0.5,0.0015,-0.0025,1e-3\n");
  const fs::path rec = write_tmp("rec.csv",
                                 "t,tool_x,tool_y,tool_z,tool_qw,tool_qx,tool_qy,tool_qz,buttons\n"
                                 "0.001,0.25,-0.5,0.125,1,0,0,0,1\n0.002,0.5,-1.5,2.5e-2,0.6,0.8,0,0,0\n");
  const fs::path scene = write_tmp("scene.yaml",
                                   "name: loc\nduration: 0.25\ndt: 0.0005\n"
                                   "tool: {kind: sphere, radius: 0.0015}\n"
                                   "device: {kind: scripted, max_force: 2.5,\n"
                                   "         waypoints: [{t: 0, position: [0, 0.01, 0]}, {t: 0.25, position: [0, -0.0025, 0]}]}\n"
                                   "tissues:\n"
                                   "  - name: patch\n"
                                   "    model: charged_particles\n"
                                   "    patch: {shape: flat, width: 0.04, height: 0.04, spacing: 0.0025}\n"
                                   "    material: {max_displacement: 0.0075, elasticity: 20.5}\n");
  CommaDecimalLocale loc;
  if (!loc.c_locale) std::printf("note: no comma-decimal C locale on this system: C++ streams only\n");
  EXPECT_EQ(std::use_facet<std::numpunct<char>>(std::locale()).decimal_point(), ',');

  auto w = palpate::load_trajectory_csv(traj);
  ASSERT_TRUE(w.ok()) << w.error().message;
  ASSERT_EQ(w->size(), 2u);
  EXPECT_EQ((*w)[0].position, Vec3(0, 0.01, 0));
  EXPECT_EQ((*w)[1].t, 0.5);
  EXPECT_EQ((*w)[1].position, Vec3(0.0015, -0.0025, 1e-3));

  auto r = palpate::load_recording_csv(rec);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[1].t, 0.002);
  EXPECT_EQ((*r)[1].position, Vec3(0.5, -1.5, 2.5e-2));
  EXPECT_NEAR((*r)[1].orientation.x(), 0.8, 1e-15);

  auto s = palpate::load_scene(scene);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->dt, 0.0005);
  EXPECT_EQ(s->tool.radius, 0.0015);
  EXPECT_EQ(s->device.max_force, 2.5);
  ASSERT_EQ(s->device.waypoints.size(), 2u);
  EXPECT_EQ(s->device.waypoints[1].position.y(), -0.0025);
  ASSERT_EQ(s->tissues.size(), 1u);
  ASSERT_TRUE(s->tissues[0].patch.has_value());
  EXPECT_EQ(s->tissues[0].patch->spacing, 0.0025);
  EXPECT_EQ(s->tissues[0].charged.elasticity, 20.5);

  // An error message's numbers are written with a '.' too.
  auto back = palpate::load_trajectory_csv(write_tmp("back.csv", "0,0,0,0\n1.5,0,0,0\n0.5,0,0,0\n"));
  ASSERT_FALSE(back.ok());
  EXPECT_NE(back.error().message.find("time 0.5 s goes back (previous 1.5 s)"), std::string::npos)
      << back.error().message;
}
