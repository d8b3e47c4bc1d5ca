// test_report.cpp — report.html as its readers see it (issue 35; docs/cvc.md, "The report"): written
// by `palpate run` for a needle scene, opened in headless Chromium (Debian's package, installed by
// scripts/install-deps), screenshotted, and the screenshot read back: the outcome's banner in its
// colour, the force trace drawn, the ultrasound image's speckle. A scene named `<script>…` shows
// as text in the browser's DOM, and the page loads nothing from anywhere.
#include "png_read.h"
#include "shell_run.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <string>

namespace {

namespace fs = std::filesystem;
using palpate::test::Ran;

Ran run(const std::string& args) { return palpate::test::run_cli(args); }

std::string read_text(const fs::path& p) { return palpate::test::read_file(p); }

// Debian's chromium, as root or not, without a GPU or a session bus; "" when it is not installed.
std::string chromium() {
  for (const char* c : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (fs::exists(c)) return std::string(c) + " --headless --no-sandbox --disable-gpu --hide-scrollbars --no-first-run";
  return "";
}

// How many pixels are within `tol` of colour (r, g, b) on every channel.
long count_colour(const palpate::test::Png& png, int r, int g, int b, int tol) {
  long n = 0;
  for (int y = 0; y < png.height; ++y)
    for (int x = 0; x < png.width; ++x) {
      const unsigned char* p = png.at(x, y);
      n += std::abs(p[0] - r) <= tol && std::abs(p[1] - g) <= tol && std::abs(p[2] - b) <= tol;
    }
  return n;
}

// Rows that hold a B-mode image: a run of at least 200 grey pixels (R = G = B within 2, darker than
// the page's white) whose level changes by more than 12 at least 40 times — speckle. Text rows
// break into white between glyphs; the 3-D frames are coloured; the plot is white and lines.
int speckle_rows(const palpate::test::Png& png) {
  int rows = 0;
  for (int y = 0; y < png.height; ++y) {
    int run = 0, changes = 0, best = 0;
    for (int x = 0; x < png.width; ++x) {
      const unsigned char* p = png.at(x, y);
      const bool grey = std::abs(p[0] - p[1]) <= 2 && std::abs(p[1] - p[2]) <= 2 && p[0] < 245;
      if (!grey) {
        if (run >= 200) best = std::max(best, changes);
        run = changes = 0;
        continue;
      }
      if (run > 0 && std::abs(p[0] - png.at(x - 1, y)[0]) > 12) ++changes;
      ++run;
    }
    if (run >= 200) best = std::max(best, changes);
    rows += best >= 40;
  }
  return rows;
}

class ReportInBrowser : public ::testing::Test {
 protected:
  void SetUp() override {
    browser_ = chromium();
    if (browser_.empty()) GTEST_SKIP() << "chromium is not installed (scripts/install-deps installs it)";
    dir_ = fs::temp_directory_path() / ("palpate_test_report_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  // A screenshot of `html` at 1000 × 2600 (the whole of a one-attempt report).
  palpate::test::Png screenshot(const fs::path& html, const std::string& name) {
    const fs::path shot = dir_ / (name + ".png");
    Ran r = palpate::test::shell_run(browser_ + " --window-size=1000,2600 --screenshot=" + shot.string() + " file://" +
                                     html.string());
    EXPECT_TRUE(fs::exists(shot)) << r.out;
    return palpate::test::load_png(shot);
  }
  std::string browser_;
  fs::path dir_;
};

// No load from anywhere: no URL, no script, no stylesheet link, no image but data: ones, and the
// Content-Security-Policy that forbids the rest.
void expect_self_contained(const std::string& html) {
  EXPECT_EQ(html.find("http:"), std::string::npos);
  EXPECT_EQ(html.find("https:"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_EQ(html.find("url("), std::string::npos);
  EXPECT_NE(html.find("Content-Security-Policy\" content=\"default-src 'none'; img-src data:"), std::string::npos);
  // (Scanned by hand: std::regex recurses per character and overflows the stack on a data: URI.)
  for (size_t at = html.find("src=\""); at != std::string::npos; at = html.find("src=\"", at + 1))
    EXPECT_EQ(html.compare(at + 5, 22, "data:image/png;base64,"), 0) << html.substr(at, 80);
}

}  // namespace

// cvc.yaml into the vein: the report's green `vein` banner, the needle's blue force trace across
// the plot, and the ultrasound image at the flashback, as Chromium draws them; cvc-overlap.yaml
// into the carotid: the red `artery` banner and no green one.
TEST_F(ReportInBrowser, ARunsReportShowsItsOutcomeForcePlotAndUltrasoundImageInABrowser) {
  const fs::path out = dir_ / "cvc";
  Ran r = run(std::string("run ") + PALPATE_DATA_DIR + "/scenes/cvc.yaml --frames 2 -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const fs::path html = out / "report.html";
  ASSERT_TRUE(fs::exists(html)) << r.out;
  EXPECT_NE(r.out.find(html.string()), std::string::npos) << "listed among the outputs\n" << r.out;
  EXPECT_FALSE(fs::exists(out / ".report-flashback")) << "the re-run's folder is removed";
  const std::string text = read_text(html);
  expect_self_contained(text);
  EXPECT_NE(text.find("outcome: vein"), std::string::npos);
  EXPECT_NE(text.find("Ultrasound at the flashback"), std::string::npos);
  const palpate::test::Png png = screenshot(html, "cvc");
  ASSERT_EQ(png.width, 1000);
  EXPECT_GT(count_colour(png, 0x2e, 0x7d, 0x32, 3), 15000) << "the outcome's banner, green for vein";
  EXPECT_LT(count_colour(png, 0xc6, 0x28, 0x28, 3), 1000) << "no red banner";
  EXPECT_GT(count_colour(png, 0x1f, 0x5f, 0xbf, 40), 800) << "the needle's force trace";
  EXPECT_GT(speckle_rows(png), 100) << "the ultrasound image (384 rows drawn, some of them the black lumen)";

  const fs::path art = dir_ / "overlap";
  Ran o = run(std::string("run ") + PALPATE_DATA_DIR + "/scenes/cvc-overlap.yaml -o " + art.string());
  ASSERT_EQ(o.code, 0) << o.out;
  const palpate::test::Png red = screenshot(art / "report.html", "overlap");
  EXPECT_GT(count_colour(red, 0xc6, 0x28, 0x28, 3), 15000) << "the outcome's banner, red for artery";
  EXPECT_LT(count_colour(red, 0x2e, 0x7d, 0x32, 3), 1000) << "no green banner (the venous flashback's event line is green)";
  EXPECT_NE(read_text(art / "report.html").find("carotid punctured"), std::string::npos);
}

// A scene whose name is markup is shown as its text: Chromium's DOM of the report has no script or
// element from it, and holds the name as text. --no-report writes none.
TEST_F(ReportInBrowser, ASceneNamedLikeMarkupShowsAsTextAndNoReportWritesNone) {
  const std::string base = read_text(fs::path(PALPATE_DATA_DIR) / "scenes/default.yaml");
  std::string scene = std::regex_replace(base, std::regex("(^|\n)name: [^\n]*"), "$1name: \"<script>alert('x')</script><b id=bold>x</b>\"");
  ASSERT_NE(scene, base);
  scene = std::regex_replace(scene, std::regex("(^|\n)output: [^\n]*"), "$1output: out");
  const fs::path file = dir_ / "markup.yaml";
  std::ofstream(file) << scene;
  // The scene's relative paths (predictors, meshes) are the shipped scene's: run from its folder.
  Ran r = run("run " + file.string() + " -o " + (dir_ / "m").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string html = read_text(dir_ / "m" / "report.html");
  expect_self_contained(html);
  EXPECT_EQ(html.find("<b id=bold>"), std::string::npos);
  EXPECT_NE(html.find("&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;&lt;b id=bold&gt;x&lt;/b&gt;"), std::string::npos);
  Ran dom = palpate::test::shell_run(browser_ + " --dump-dom file://" + (dir_ / "m" / "report.html").string() + " 2>/dev/null");
  ASSERT_NE(dom.out.find("</html>"), std::string::npos) << dom.out.substr(0, 400);
  EXPECT_EQ(dom.out.find("<script"), std::string::npos) << "no script element in the DOM";
  EXPECT_EQ(dom.out.find("id=\"bold\""), std::string::npos) << "no element from the scene's name";
  EXPECT_NE(dom.out.find("&lt;script&gt;alert('x')&lt;/script&gt;&lt;b id=bold&gt;x&lt;/b&gt;"), std::string::npos)
      << "the name, as text";

  // A scene without a probe: no ultrasound image, and no speckle in the screenshot.
  EXPECT_EQ(html.find("Ultrasound at the flashback"), std::string::npos);
  EXPECT_LT(speckle_rows(screenshot(dir_ / "m" / "report.html", "markup")), 5);

  Ran none = run("run " + file.string() + " --no-report -o " + (dir_ / "n").string());
  ASSERT_EQ(none.code, 0) << none.out;
  EXPECT_FALSE(fs::exists(dir_ / "n" / "report.html"));
}

// `palpate report` puts several runs side by side: one row each in the attempts table, with their
// outcomes, and each run's section with the ultrasound image its run saved (flashback_us.png). A
// folder that is not a run's is refused, naming its summary.json.
TEST_F(ReportInBrowser, SeveralRunsAreComparedInOneTable) {
  Ran a = run(std::string("run ") + PALPATE_DATA_DIR + "/scenes/cvc.yaml -q -o " + (dir_ / "first").string());
  ASSERT_EQ(a.code, 0) << a.out;
  ASSERT_TRUE(fs::exists(dir_ / "first" / "flashback_us.png"));
  Ran b = run(std::string("run ") + PALPATE_DATA_DIR + "/scenes/cvc-small-vein.yaml -q -o " + (dir_ / "second").string());
  ASSERT_EQ(b.code, 0) << b.out;
  const fs::path html = dir_ / "both.html";
  Ran r = run("report " + (dir_ / "first").string() + " " + (dir_ / "second").string() + " -o " + html.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("first"), std::string::npos) << r.out;
  const std::string text = read_text(html);
  expect_self_contained(text);
  const size_t table = text.find("<table class=\"attempts\">");
  ASSERT_NE(table, std::string::npos);
  const std::string rows = text.substr(table, text.find("</table>", table) - table);
  const size_t first = rows.find("<td>first</td>"), second = rows.find("<td>second</td>");
  ASSERT_NE(first, std::string::npos) << rows;
  ASSERT_NE(second, std::string::npos) << rows;
  EXPECT_LT(first, second);
  EXPECT_NE(rows.find("<b>vein</b>", first), std::string::npos);
  EXPECT_NE(rows.find("<b>posterior_wall</b>", second), std::string::npos);
  EXPECT_NE(text.find("Ultrasound at the flashback"), std::string::npos) << "the first run's image";
  EXPECT_GT(speckle_rows(screenshot(html, "both")), 100);

  Ran bad = run("report " + dir_.string() + " -o " + (dir_ / "bad.html").string());
  EXPECT_EQ(bad.code, 1) << bad.out;
  EXPECT_NE(bad.out.find((dir_ / "summary.json").string() + ": cannot be read"), std::string::npos) << bad.out;
  EXPECT_FALSE(fs::exists(dir_ / "bad.html"));
}
