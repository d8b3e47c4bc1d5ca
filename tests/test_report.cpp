// test_report.cpp — report.html's parts without a browser (palpate/report.h): the escaping of every
// text from a scene or a file, base64, the metrics judged against the published figures, and the
// page's self-containment. tests/apps/test_report.cpp opens a run's report in headless Chromium.
#include <palpate/report.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

namespace {

using palpate::Outcome;
using palpate::ReportAttempt;
using palpate::ReportCriterion;

const ReportCriterion& criterion(const std::vector<ReportCriterion>& c, const std::string& metric) {
  const auto it = std::find_if(c.begin(), c.end(), [&](const ReportCriterion& r) { return r.metric == metric; });
  EXPECT_NE(it, c.end()) << metric;
  return *it;
}

}  // namespace

TEST(Report, Base64IsRfc4648sTestVectors) {
  EXPECT_EQ(palpate::base64(""), "");
  EXPECT_EQ(palpate::base64("f"), "Zg==");
  EXPECT_EQ(palpate::base64("fo"), "Zm8=");
  EXPECT_EQ(palpate::base64("foo"), "Zm9v");
  EXPECT_EQ(palpate::base64("foob"), "Zm9vYg==");
  EXPECT_EQ(palpate::base64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(palpate::base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(palpate::base64(std::string("\xff\x00\xfe", 3)), "/wD+");
}

TEST(Report, HtmlEscapeTurnsEveryMarkupCharacterIntoItsEntity) {
  EXPECT_EQ(palpate::markup_escape("<script>alert('x' & \"y\")</script>"),
            "&lt;script&gt;alert(&#39;x&#39; &amp; &quot;y&quot;)&lt;/script&gt;");
  EXPECT_EQ(palpate::markup_escape("vein, 6.5 mm — ü"), "vein, 6.5 mm — ü");
}

// A clean pass into the vein meets every judged criterion; into the carotid through both walls of
// the vein, the outcome, the back wall and the carotid are not met; no flashback, no time.
TEST(Report, TheMetricsAreJudgedAgainstThePublishedFigures) {
  ReportAttempt a;
  a.metrics.outcome = Outcome::vein;
  a.metrics.skin_punctures = 1;
  a.metrics.passes = 1;
  a.metrics.flashback = true;
  a.metrics.time_to_flashback = 3.3;
  a.events = {{2.8, "puncture", "skin", 0, 1.2}, {6.2, "puncture", "ijv", 0, 0.5}};
  auto c = palpate::report_criteria(a);
  for (const ReportCriterion& r : c) EXPECT_GE(r.verdict, 0) << r.metric;
  EXPECT_EQ(criterion(c, "outcome").verdict, 1);
  EXPECT_FALSE(criterion(c, "outcome").source.empty());

  a.metrics.outcome = Outcome::artery;
  a.metrics.arterial_flashback = true;
  a.metrics.arterial_flashback_time = 8.0;
  a.events.push_back({7.0, "puncture", "ijv", 0, 0.5});
  c = palpate::report_criteria(a);
  EXPECT_EQ(criterion(c, "outcome").verdict, -1);
  EXPECT_EQ(criterion(c, "posterior wall punctured").verdict, -1) << "two vein punctures: through its back wall";
  EXPECT_EQ(criterion(c, "carotid punctured").verdict, -1);
  EXPECT_NE(criterion(c, "carotid punctured").value.find("8.0 s"), std::string::npos);

  ReportAttempt none;
  none.metrics.skin_punctures = 2;
  none.metrics.passes = 3;
  none.metrics.redirections = 1;
  c = palpate::report_criteria(none);
  EXPECT_EQ(criterion(c, "skin puncture to flashback").value, "no flashback");
  EXPECT_EQ(criterion(c, "skin puncture to flashback").verdict, -1);
  EXPECT_EQ(criterion(c, "skin punctures (insertion attempts)").verdict, -1);
  EXPECT_EQ(criterion(c, "needle passes").verdict, -1);
  EXPECT_EQ(criterion(c, "redirections").verdict, -1);
}

// Every text from a scene or a file — the scene's name and file, the attempt's label, an event's
// tissue, an image's caption, a note — is escaped; two attempts make two rows of one table.
TEST(Report, EveryTextFromASceneIsEscapedAndAttemptsShareOneTable) {
  ReportAttempt a;
  a.label = "<i>attempt</i>";
  a.scene = "<script>alert(1)</script>";
  a.scene_file = "/tmp/\"quoted\".yaml";
  a.duration = 2;
  a.events = {{1.0, "puncture", "<b>skin</b>", 0.001, 1.0}};
  a.force = {{0, 0}, {1, 1.0}, {2, 0.2}};
  a.frames = {{1.0, std::string("\x89PNG", 4), "<u>frame</u>"}};
  a.notes = {"<em>note</em>"};
  ReportAttempt b = a;
  b.label = "second";
  const ReportAttempt both[] = {a, b};
  const std::string html = palpate::report_html(both);
  for (const char* raw : {"<script>alert", "<i>attempt", "\"quoted\"", "<b>skin", "<u>frame", "<em>note"})
    EXPECT_EQ(html.find(raw), std::string::npos) << raw;
  for (const char* escaped : {"&lt;script&gt;alert(1)&lt;/script&gt;", "&lt;i&gt;attempt&lt;/i&gt;", "&quot;quoted&quot;",
                              "&lt;b&gt;skin&lt;/b&gt;", "&lt;u&gt;frame&lt;/u&gt;", "&lt;em&gt;note&lt;/em&gt;"})
    EXPECT_NE(html.find(escaped), std::string::npos) << escaped;
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("http:"), std::string::npos) << "nothing to load";
  EXPECT_EQ(html.find("https:"), std::string::npos) << "nothing to load";
  EXPECT_NE(html.find("data:image/png;base64,iVBORw=="), std::string::npos);
  // One comparison table with a row per attempt, then a section each.
  const size_t table = html.find("<table class=\"attempts\">");
  ASSERT_NE(table, std::string::npos);
  const size_t end = html.find("</table>", table);
  const std::string rows = html.substr(table, end - table);
  size_t n = 0;
  for (size_t at = rows.find("<tr><td>"); at != std::string::npos; at = rows.find("<tr><td>", at + 1)) ++n;
  EXPECT_EQ(n, 2u);
  EXPECT_NE(html.find("id=\"attempt-2\""), std::string::npos);
}
